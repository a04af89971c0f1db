"""The mass properties a file STATES for its clumps, and where those values came from.

Engines take a clump's mass and inertia from the user's files; this module reads them back so
that ``clumpprops audit`` can compare them with the exact values:

* LIGGGHTS input scripts: ``fix ... particletemplate/multisphere ... mass M ... inertia_tensor
  Ixx Ixy Ixz Iyy Iyz Izz`` (spheres and command syntax as
  :mod:`clumpprops.io.liggghts_script` reads them).  LIGGGHTS uses the tensor about the sphere
  file's origin, which it then treats as the centre of mass;
* LAMMPS molecule files: the header keywords ``mass``, ``com`` and ``inertia`` (six values,
  in the order LAMMPS stores them: Ixx Iyy Izz Iyz Ixz Ixy; see
  :func:`clumpprops.io.lammps.molecule_inertia_words`), the inertia about ``com``;
* LAMMPS ``fix rigid infile`` lines: ``id mass xcm ycm zcm ixx iyy izz ixy ixz iyz ...``
  (:func:`read_rigid_infile`; the geometry comes from another file);
* DEM-Engine JSON as :mod:`clumpprops.io.deme` writes it (``mass``, principal ``moi``,
  ``relPos``, ``radii``): DEME uses ``moi`` as the diagonal of the tensor in the frame of
  ``relPos``, about its origin;
* MClump/MercuryDPM folders (:mod:`clumpprops.io.mclump`): ``Inertia/Mass.txt`` and
  ``Inertia/TOI.txt`` beside ``Clump/Clump.txt``.

Each reader returns :class:`Stated` records: the clump geometry and what the file says.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import List, Optional

import numpy as np

from ._common import Clump, ClumpFileError
from .detect import _TEMPLATE


@dataclass
class Stated:
    """What one file states about one clump.

    Parameters
    ----------
    clump : Clump or None
        The spheres the values belong to (None when the file has no geometry).
    engine : str
        The engine whose convention the values follow.
    mass : float or None
        Stated mass in kg.
    inertia : numpy.ndarray, shape (3, 3), or None
        Stated inertia tensor in kg m^2, in the frame of the clump's coordinates.
    reference : numpy.ndarray, shape (3,)
        The point the engine takes the tensor about (and as the centre of mass), in m.
    diagonal_only : bool
        The engine uses only the diagonal (DEME's ``moi``): the frame must be principal.
    source : str
        File and line the values come from.
    density : float or None
        The density the file gives (kg/m^3), when it gives one.
    """

    clump: Optional[Clump]
    engine: str
    mass: Optional[float]
    inertia: Optional[np.ndarray]
    reference: np.ndarray
    diagonal_only: bool = False
    source: str = ""
    density: Optional[float] = None


def _float(word, src, lineno):
    try:
        return float(word)
    except ValueError:
        raise ClumpFileError(f"expected a number, got {word!r}", src, lineno) from None


def read_liggghts_script(path) -> List[Stated]:
    """The ``particletemplate/multisphere`` templates of a LIGGGHTS input script.

    Parameters
    ----------
    path : str or os.PathLike
        The input script.

    Returns
    -------
    list of Stated
        One per template, in script order, the spheres as
        :func:`clumpprops.io.liggghts_script.read_liggghts_script` reads them; ``mass``/``inertia``
        None when the template leaves them to LIGGGHTS' Monte Carlo.

    Raises
    ------
    ClumpFileError
        If a template is malformed or its sphere file cannot be read.
    """
    from .liggghts_script import _commands, read_liggghts_script as read_templates

    path = Path(path)
    src = str(path)
    clumps = read_templates(path)
    commands = [(first, [w for w, _ in words]) for first, words in _commands(path.read_text().splitlines())
                if _TEMPLATE.match(" ".join(w for w, _ in words[:4]))]
    return [_liggghts_stated(w, clump, src, lineno) for clump, (lineno, w) in zip(clumps, commands)]


def _liggghts_stated(w, clump, src, lineno) -> Stated:
    kw = {k: i for i, k in enumerate(w)}
    mass = _float(w[kw["mass"] + 1], src, lineno) if "mass" in kw else None
    inertia = None
    if "inertia_tensor" in kw:
        a = [_float(x, src, lineno) for x in w[kw["inertia_tensor"] + 1:kw["inertia_tensor"] + 7]]
        if len(a) != 6:
            raise ClumpFileError("inertia_tensor needs six values", src, lineno)
        inertia = np.array([[a[0], a[1], a[2]], [a[1], a[3], a[4]], [a[2], a[4], a[5]]])
    rho = None
    if "density" in kw and w[kw["density"] + 1] == "constant":
        rho = _float(w[kw["density"] + 2], src, lineno)
    return Stated(clump, "LIGGGHTS particletemplate/multisphere", mass, inertia, np.zeros(3),
                  source=f"{src}:{lineno}", density=rho)


def read_lammps_molecule(path, clump: Optional[Clump] = None) -> List[Stated]:
    """The ``mass``/``com``/``inertia`` header of a LAMMPS molecule file.

    Parameters
    ----------
    path : str or os.PathLike
        The molecule file.
    clump : Clump, optional
        Its spheres; by default read with ``clumpprops.io.read(path, fmt="lammps")``.

    Returns
    -------
    list of Stated
        One record, or none when the header states neither mass nor inertia.

    Raises
    ------
    ClumpFileError
        If a header keyword has the wrong number of values.
    """
    path = Path(path)
    src = str(path)
    lines = path.read_text().splitlines()
    head = {}
    for i, raw in enumerate(lines[1:], 2):
        words = raw.split("#", 1)[0].split()
        if words and words[0][:1].isalpha():
            break  # first section name
        if words and words[-1] in ("mass", "com", "inertia"):
            head[words[-1]] = ([_float(x, src, i) for x in words[:-1]], i)
    if "mass" not in head and "inertia" not in head:
        return []
    if clump is None:
        from .readers import read

        clump = read(path, fmt="lammps")[0]
    ref = np.array(head["com"][0]) if "com" in head else np.zeros(3)
    inertia = None
    if "inertia" in head:
        a, i = head["inertia"]
        if len(a) != 6:
            raise ClumpFileError("inertia needs six values", src, i)
        xx, yy, zz, yz, xz, xy = a
        inertia = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    mass = head["mass"][0][0] if "mass" in head else None
    first = min(v[1] for v in head.values())
    return [Stated(clump, "LAMMPS molecule", mass, inertia, ref, source=f"{src}:{first}")]


def read_rigid_infile(path) -> List[Stated]:
    """The bodies of a LAMMPS ``fix rigid ... infile`` file (no geometry).

    Parameters
    ----------
    path : str or os.PathLike
        The infile: ``id mass xcm ycm zcm ixx iyy izz ixy ixz iyz [...]`` per line, after a
        first line with the number of bodies.

    Returns
    -------
    list of Stated
        One per body, ``clump`` None, ``reference`` the stated centre of mass.

    Raises
    ------
    ClumpFileError
        If a body line has fewer than 11 values.
    """
    path = Path(path)
    src = str(path)
    out, seen_count = [], False
    for i, raw in enumerate(path.read_text().splitlines(), 1):
        w = raw.split("#", 1)[0].split()
        if not w:
            continue
        if not seen_count and len(w) == 1:
            seen_count = True
            continue
        if len(w) < 11:
            raise ClumpFileError(f"a body line needs at least 11 values, got {len(w)}", src, i)
        v = [_float(x, src, i) for x in w[1:11]]
        xx, yy, zz, xy, xz, yz = v[4:10]
        out.append(Stated(None, f"LAMMPS fix rigid infile (body {w[0]})", v[0],
                          np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]), np.array(v[1:4]), source=f"{src}:{i}"))
    return out


def read_deme_json(path) -> List[Stated]:
    """The clumps of a DEME JSON file as :mod:`clumpprops.io.deme` writes it.

    Parameters
    ----------
    path : str or os.PathLike
        The JSON file.

    Returns
    -------
    list of Stated
        ``inertia`` = diag(moi) in the ``relPos`` frame, about its origin, ``diagonal_only``.

    Raises
    ------
    ClumpFileError
        If the file is not such JSON.
    """
    src = str(path)
    try:
        doc = json.loads(Path(path).read_text())
        items = doc["clumps"]
        out = []
        for it in items:
            clump = Clump(np.asarray(it["relPos"], float), np.asarray(it["radii"], float), name=str(it.get("name", "")))
            out.append(Stated(clump, "DEM-Engine LoadClumpType", float(it["mass"]), np.diag(np.asarray(it["moi"], float)),
                              np.zeros(3), diagonal_only=True, source=f"{src}:{it.get('name', '')}",
                              density=float(doc["density"]) if "density" in doc else None))
        return out
    except (ValueError, KeyError, TypeError) as exc:
        raise ClumpFileError(f"not a DEME clump JSON ({type(exc).__name__}: {exc})", src, None) from None


def read_mclump_folder(folder) -> List[Stated]:
    """``Inertia/Mass.txt`` and ``Inertia/TOI.txt`` of an MClump folder, with ``Clump/Clump.txt``.

    Parameters
    ----------
    folder : str or os.PathLike
        The clump's folder (``NAME/``) or its ``clumpprops.txt``.

    Returns
    -------
    list of Stated
        One record; the tensor about the ``Clump.txt`` origin.

    Raises
    ------
    ClumpFileError
        If a file is missing or malformed.
    """
    folder = Path(folder)
    if folder.is_file():
        folder = folder.parent
    src = str(folder)
    try:
        mass = float((folder / "Inertia" / "Mass.txt").read_text().split()[0])
        toi = np.array([[float(x) for x in ln.split(",")] for ln in
                        (folder / "Inertia" / "TOI.txt").read_text().split("\n") if ln.strip()])
        rows = np.array([[float(x) for x in ln.split(",")] for ln in
                         (folder / "Clump" / "Clump.txt").read_text().split("\n") if ln.strip()])
    except (OSError, ValueError, IndexError) as exc:
        raise ClumpFileError(f"not an MClump folder ({exc})", src, None) from None
    if toi.shape != (3, 3) or rows.ndim != 2 or rows.shape[1] != 4:
        raise ClumpFileError("not an MClump folder (TOI.txt 3x3, Clump.txt x,y,z,r)", src, None)
    clump = Clump(rows[:, :3], rows[:, 3], name=folder.name)
    return [Stated(clump, "MercuryDPM (MClump)", mass, toi, np.zeros(3), source=src)]


def read_stated(path) -> List[Stated]:
    """The stated values of any of the files above, recognised by content.

    Parameters
    ----------
    path : str or os.PathLike
        A LIGGGHTS input script, LAMMPS molecule file or ``fix rigid`` infile (a first line with
        the number of bodies, then body lines), DEME JSON, or an MClump folder (or its
        ``clumpprops.txt``).

    Returns
    -------
    list of Stated
        Empty when the file states nothing this module reads.

    Raises
    ------
    ClumpFileError
        If a file of a recognised kind is malformed.
    """
    p = Path(path)
    if p.is_dir() or p.name == "clumpprops.txt" and (p.parent / "Inertia").is_dir():
        return read_mclump_folder(p)
    text = p.read_text(errors="replace")
    head = text.lstrip()[:1]
    if head == "{":
        return read_deme_json(p)
    if "particletemplate/multisphere" in text:
        return read_liggghts_script(p)
    lines = text.splitlines()
    if any(ln.split("#", 1)[0].split()[-1:] in (["mass"], ["inertia"]) for ln in lines[1:40]):
        return read_lammps_molecule(p)
    data = [ln.split("#", 1)[0].split() for ln in lines]
    data = [w for w in data if w]
    if data and len(data[0]) == 1 and data[0][0].isdigit() and all(len(w) >= 11 for w in data[1:]):
        return read_rigid_infile(p)
    return []
