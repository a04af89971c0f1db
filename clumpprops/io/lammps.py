"""LAMMPS: ``fix rigid`` / ``fix rigid/small`` ``infile`` and molecule files with given values.

Files (SI; use ``units si`` in LAMMPS):

* ``STEM.rigid``, the ``infile`` of ``fix rigid`` and ``fix rigid/small`` (LAMMPS 29 Sep 2021 and
  later): comment lines, then the number of bodies N, then one line per body::

      ID masstotal xcm ycm zcm ixx iyy izz ixy ixz iyz vxcm vycm vzcm lx ly lz ixcm iycm izcm

  ID = molecule ID (1..M, the order of the clumps), centre of mass in box coordinates (the
  source file's coordinates), inertia tensor about the centre of mass in box axes with the
  tensor's off-diagonals (-sum m x y), zero velocity, angular momentum and image flags.
  LAMMPS would otherwise sum the member spheres (overlaps counted twice).
* ``STEM.data``: the member spheres as a data file for ``atom_style hybrid sphere molecular``
  (``atom-ID type x y z diameter density molecule-ID``), so the infile's IDs match.
* ``NAME.mol`` per clump, for ``fix rigid/small ... mol`` with ``fix deposit``/``fix pour``
  (``... mol ID rigid FIX``; after ``create_atoms ... mol`` LAMMPS sums the created atoms
  instead): spheres centred on the centre of mass, header lines ``mass``, ``com``
  (0 0 0) and ``inertia`` (tensor components in the order LAMMPS' source reads them,
  ``Ixx Iyy Izz Iyz Ixz Ixy``: see :func:`molecule_inertia_words`), sections
  ``Coords``, ``Types``, ``Diameters``, ``Masses`` (sphere masses rho 4/3 pi r^3; the
  body's mass and inertia come from the header).

A one-sphere clump is refused (``ValueError``, nothing written): ``fix rigid`` and
``fix rigid/small`` stop on a one-atom body ("One or zero atoms in rigid body"); such a
particle is a plain ``atom_style sphere`` atom, whose mass and inertia LAMMPS gets right.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import List, Sequence

import numpy as np

from ._common import Clump, Props, fmt_rows, fnum, header_lines

ENGINE = "LAMMPS fix rigid, fix rigid/small (infile, molecule file)"


def tensor6_infile(I) -> List[str]:
    """ixx iyy izz ixy ixz iyz, the order of the infile columns."""
    I = np.asarray(I, dtype=float)
    return [fnum(I[0, 0]), fnum(I[1, 1]), fnum(I[2, 2]), fnum(I[0, 1]), fnum(I[0, 2]), fnum(I[1, 2])]


def infile_line(body_id: int, mass: float, com, inertia, v=(0.0, 0.0, 0.0), angmom=(0.0, 0.0, 0.0), image=(0, 0, 0)) -> str:
    cells = [str(int(body_id)), fnum(mass)] + [fnum(x) for x in com] + tensor6_infile(inertia)
    cells += [fnum(x) for x in v] + [fnum(x) for x in angmom] + [str(int(i)) for i in image]
    return " ".join(cells)


def infile_text(clumps, mp, header, angmom=None, velocity=None) -> str:
    """The ``fix rigid`` infile: one line per body; `angmom` and `velocity` (M x 3, or None for
    zeros) fill the ``lx ly lz`` and ``vxcm vycm vzcm`` columns."""
    P = Props(mp)
    out = [f"# {h}" for h in header]
    out.append("# ID masstotal xcm ycm zcm ixx iyy izz ixy ixz iyz vxcm vycm vzcm lx ly lz ixcm iycm izcm")
    out.append("# inertia about the centre of mass in box axes, tensor components (off-diagonals -sum m x y)")
    out.append(str(len(clumps)))
    M = len(clumps)
    I = P.inertia
    L = np.zeros((M, 3)) if angmom is None else np.asarray(angmom, dtype=float).reshape(M, 3)
    V = np.zeros((M, 3)) if velocity is None else np.broadcast_to(np.asarray(velocity, dtype=float), (M, 3))
    cols = np.column_stack([P.mass, P.com, I[:, 0, 0], I[:, 1, 1], I[:, 2, 2], I[:, 0, 1], I[:, 0, 2], I[:, 1, 2],
                            V, L])
    out.extend(f"{k + 1} {row} 0 0 0" for k, row in enumerate(fmt_rows(cols)))
    return "\n".join(out) + "\n"


def data_text(clumps, density: float, header, margin: float = None) -> str:
    allc = np.concatenate([c.centers for c in clumps])
    allr = np.concatenate([c.radii for c in clumps])
    lo = (allc - allr[:, None]).min(axis=0)
    hi = (allc + allr[:, None]).max(axis=0)
    pad = margin if margin is not None else float(np.max(hi - lo))
    lo, hi = lo - pad, hi + pad
    n = len(allr)
    # the first line is the title: LAMMPS reads it into a 256-character buffer, keep it short
    out = ["LAMMPS data file written by clumpprops"] + [f"# {h}" for h in header] + ["", f"{n} atoms", "1 atom types",
           f"{fnum(lo[0])} {fnum(hi[0])} xlo xhi", f"{fnum(lo[1])} {fnum(hi[1])} ylo yhi",
           f"{fnum(lo[2])} {fnum(hi[2])} zlo zhi", "", "Atoms # hybrid sphere molecular", ""]
    rho = fnum(density)
    mol = np.repeat(np.arange(1, len(clumps) + 1), [c.n_spheres for c in clumps]).tolist()
    rows = fmt_rows(np.column_stack([allc, 2.0 * allr]))
    out.extend(f"{i + 1} 1 {row} {rho} {m}" for i, (row, m) in enumerate(zip(rows, mol)))
    return "\n".join(out) + "\n"


def molecule_inertia_words(I) -> List[str]:
    """The six values of a molecule file's ``inertia`` header line, in the order LAMMPS uses them.

    LAMMPS' documentation lists ``Ixx Iyy Izz Ixy Ixz Iyz``, but ``Molecule::read`` stores the
    six numbers as they come into ``itensor[0..5]``, and ``itensor`` is in Voigt order
    (xx, yy, zz, yz, xz, xy) everywhere else (``Molecule::compute_inertia`` accumulates
    ``itensor[3] -= m dy dz``, ``[4] -= m dx dz``, ``[5] -= m dx dy``).  Checked in LAMMPS
    29 Sep 2021 (Debian 12): with the documented order
    the principal moments of an asymmetric clump came out wrong by 4e-4; with this order they
    match to 1e-15 (tests/test_engines_lammps.py).  So the file gets Ixx Iyy Izz Iyz Ixz Ixy.
    """
    I = np.asarray(I, dtype=float)
    return [fnum(I[0, 0]), fnum(I[1, 1]), fnum(I[2, 2]), fnum(I[1, 2]), fnum(I[0, 2]), fnum(I[0, 1])]


def molecule_text(clump: Clump, mass, com, inertia, density: float, header) -> str:
    rel = clump.centers - com
    I = np.asarray(inertia)
    n = clump.n_spheres
    # the first line is the title (a 256-character buffer in LAMMPS: a longer line spills into the header)
    out = [f"LAMMPS molecule file written by clumpprops: {clump.name}"[:200]] + [f"# {h}" for h in header] + ["", f"{n} atoms", f"{fnum(mass)} mass", "0.0 0.0 0.0 com",
           "# inertia: Ixx Iyy Izz Iyz Ixz Ixy, the order molecule.cpp stores (see molecule_inertia_words)",
           " ".join(molecule_inertia_words(I)) + " inertia",
           "", "Coords", ""]
    out += [f"{i + 1} {fnum(p[0])} {fnum(p[1])} {fnum(p[2])}" for i, p in enumerate(rel)]
    out += ["", "Types", ""] + [f"{i + 1} 1" for i in range(n)]
    out += ["", "Diameters", ""] + [f"{i + 1} {fnum(2.0 * r)}" for i, r in enumerate(clump.radii)]
    out += ["", "Masses", ""] + [f"{i + 1} {fnum(density * 4.0 / 3.0 * math.pi * r ** 3)}" for i, r in enumerate(clump.radii)]
    return "\n".join(out) + "\n"


def write(clumps: Sequence[Clump], mp, out_dir, density: float, method: str, source: str = "", scale: float = 1.0,
          stem: str = None, templates: bool = True, velocity=None, spin=None) -> List[Path]:
    """``STEM.rigid`` and ``STEM.data`` for all clumps, and (``templates``) one ``NAME.mol`` per clump.

    `velocity` (m/s) and `spin` (rad/s, space frame), when given, go into every body's line of the
    infile as ``vxcm vycm vzcm`` and ``lx ly lz`` = I w (I the body's inertia tensor)."""
    single = [c.name for c in clumps if c.n_spheres < 2]
    if single:
        raise ValueError(f"clump {single[0]} has one sphere: LAMMPS' fix rigid refuses one-atom bodies "
                         "(insert it as a plain atom_style sphere atom)")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    P = Props(mp)
    hdr = header_lines(ENGINE, density, method, source, scale)
    stem = stem or (clumps[0].name if len(clumps) == 1 else "clumps")
    written = []
    p = out_dir / f"{stem}.rigid"
    angmom = None if spin is None else P.inertia @ np.asarray(spin, dtype=float)
    p.write_text(infile_text(clumps, mp, hdr, angmom=angmom, velocity=velocity))
    written.append(p)
    p = out_dir / f"{stem}.data"
    p.write_text(data_text(clumps, density, hdr))
    written.append(p)
    if templates:
        for k, c in enumerate(clumps):
            p = out_dir / f"{c.name}.mol"
            p.write_text(molecule_text(c, P.mass[k], P.com[k], P.inertia[k], density,
                                       hdr + [f"clump {c.name}, centred on its centre of mass"]))
            written.append(p)
    return written
