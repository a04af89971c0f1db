"""LIGGGHTS (3.x, the engine of Parteli's paper): ``fix particletemplate/multisphere`` with given values.

For each clump a sphere file ``NAME_spheres.multisphere`` (``x y z r`` per line, centred on
the clump's centre of mass, input axes, no comment lines) and, in ``STEM_liggghts.in`` (one
file for all clumps, to ``include``), the template line::

    fix ptsK all particletemplate/multisphere SEED atom_type 1 density constant RHO nspheres N
        ntry 1000000 spheres file NAME_spheres.multisphere scale 1 type K
        mass M inertia_tensor Ixx Ixy Ixz Iyy Iyz Izz use_density

The path rule: LIGGGHTS opens the sphere file relative to the folder it runs in, and the
deck is run from the output folder, so the template names the file relative to that folder.
The ``_spheres`` suffix keeps the name distinct from the user's own sphere file (commonly
``NAME.multisphere``), which a run from another folder would otherwise read instead.
A one-sphere clump (LIGGGHTS refuses ``nspheres 1``) becomes the plain sphere
``fix ptsK all particletemplate/sphere SEED atom_type 1 density constant RHO radius constant R``:
a single sphere's exact mass and inertia are the ones LIGGGHTS computes itself.

Facts from LIGGGHTS-PUBLIC 3.8.0 ``src/fix_template_multisphere.cpp``:

* ``inertia_tensor`` takes the six components in the order ``moi[0][0] moi[0][1] moi[0][2]
  moi[1][1] moi[1][2] moi[2][2]``, i.e. Ixx Ixy Ixz Iyy Iyz Izz, of the *tensor* (its own
  Monte Carlo ``calc_inertia`` accumulates ``moi[0][1] -= x y``: off-diagonals are -sum m x y),
  about the centre of mass, in the sphere file's axes; it diagonalises it itself (Jacobi);
* ``mass`` and ``inertia_tensor`` go together; ``use_density`` then skips LIGGGHTS' centre
  of mass step (``FixTemplateMultiplespheres::post_create``), so the body's centre of mass is
  the origin of the sphere file: the file is written centred; the volume becomes mass/density;
* without them LIGGGHTS estimates mass, centre of mass and inertia by Monte Carlo over
  ``ntry`` points in the bounding box (``ntry`` is still used for the CFD volume weights).
"""
from __future__ import annotations

from pathlib import Path
from typing import List, Sequence

import numpy as np

from ._common import Clump, Props, fmt_rows, fnum, header_lines

ENGINE = "LIGGGHTS 3.x fix particletemplate/multisphere"
NTRY = 1000000


def seeds(n: int, start: int = 15485863) -> List[int]:
    """n distinct primes >= start (LIGGGHTS' docs ask for "prime number greater 10000"), by a segmented sieve."""
    out: List[int] = []
    lo = start
    while len(out) < n:
        hi = lo + max(64 * (n - len(out)), 1024)
        root = int(hi ** 0.5) + 1
        small = np.ones(root + 1, dtype=bool)
        small[:2] = False
        for p in range(2, int(root ** 0.5) + 1):
            if small[p]:
                small[p * p::p] = False
        seg = np.ones(hi - lo, dtype=bool)
        for p in np.flatnonzero(small):
            first = max(p * p, -(-lo // p) * p)
            seg[first - lo::p] = False
        out.extend((lo + np.flatnonzero(seg)).tolist())
        lo = hi
    return out[:n]


def inertia_words(inertia) -> List[str]:
    """The six ``inertia_tensor`` values in LIGGGHTS' order: Ixx Ixy Ixz Iyy Iyz Izz (tensor components)."""
    I = np.asarray(inertia, dtype=float)
    return [fnum(I[0, 0]), fnum(I[0, 1]), fnum(I[0, 2]), fnum(I[1, 1]), fnum(I[1, 2]), fnum(I[2, 2])]


def sphere_file_text(clump: Clump, com) -> str:
    """The sphere file: ``x y z r`` lines (m), centred on the clump's centre of mass (LIGGGHTS'
    ``use_density`` needs this), and nothing else: LIGGGHTS 3.8.0 stops on '#' lines in it when run
    with ``-screen none``, so its provenance goes into the deck as comments."""
    rel = clump.centers - np.asarray(com)
    return "\n".join(fmt_rows(np.column_stack([rel, clump.radii]))) + "\n"


def sphere_file_name(name: str) -> str:
    """The name of clump `name`'s sphere file, relative to the output folder the deck runs in.

    Parameters
    ----------
    name : str
        The clump's name.

    Returns
    -------
    str
        ``NAME_spheres.multisphere``: distinct from the user's own ``NAME.multisphere``.
    """
    return f"{name}_spheres.multisphere"


def sphere_line(k: int, seed: int, radius: float, density: float, atom_type: int = 1) -> str:
    """The ``fix particletemplate/sphere`` line of a one-sphere clump (template ``ptsK``)."""
    return (f"fix pts{k} all particletemplate/sphere {seed} atom_type {atom_type} density constant {fnum(density)} "
            f"radius constant {fnum(radius)}")


def fix_line(k: int, seed: int, clump: Clump, file_name: str, mass: float, inertia, density: float,
             atom_type: int = 1, ntry: int = NTRY) -> str:
    return (
        f"fix pts{k} all particletemplate/multisphere {seed} atom_type {atom_type} density constant {fnum(density)} "
        f"nspheres {clump.n_spheres} ntry {ntry} spheres file {file_name} scale 1 type {k} "
        f"mass {fnum(mass)} inertia_tensor {' '.join(inertia_words(inertia))} use_density"
    )


def write(clumps: Sequence[Clump], mp, out_dir, density: float, method: str, source: str = "", scale: float = 1.0,
          stem: str = None) -> List[Path]:
    """Write the sphere files and ``STEM_liggghts.in``; returns the paths written."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    P = Props(mp)
    hdr = header_lines(ENGINE, density, method, source, scale)
    hdr_text = "".join(f"# {h}\n" for h in hdr)
    written, fixes = [], []
    sd = seeds(len(clumps) + 1)
    for k, c in enumerate(clumps):
        summary = (f"# {c.name}: mass {fnum(P.mass[k])} kg, principal moments "
                   f"{' '.join(fnum(x) for x in P.moments[k])} kg m^2")
        if c.n_spheres == 1:
            fixes.append(f"# {c.name}: one sphere, a plain LIGGGHTS sphere (particletemplate/sphere) centred at "
                         f"{' '.join(fnum(x) for x in P.com[k])} m in the source file's frame")
            fixes += [summary, sphere_line(k + 1, sd[k], float(c.radii[0]), density)]
            continue
        fname = sphere_file_name(c.name)
        (out_dir / fname).write_text(sphere_file_text(c, P.com[k]))
        written.append(out_dir / fname)
        fixes.append(f"# {c.name}: {c.n_spheres} spheres in {fname} (x y z r in m, centred on the centre of mass; "
                     f"in the source file's frame the centre of mass is at {' '.join(fnum(x) for x in P.com[k])} m)")
        fixes += [summary, fix_line(k + 1, sd[k], c, fname, P.mass[k], P.inertia[k], density)]
    stem = stem or (clumps[0].name if len(clumps) == 1 else "clumps")
    weights = " ".join(f"pts{k + 1} {fnum(1.0 / len(clumps))}" for k in range(len(clumps)))
    text = [hdr_text.rstrip("\n"),
            "# include this file after the material fixes, running LIGGGHTS in this file's folder: the sphere files",
            "# are named relative to it.",
            "# inertia_tensor: Ixx Ixy Ixz Iyy Iyz Izz about the centre of mass (tensor components, off-diagonals -sum m x y)"]
    text += fixes
    text.append(f"fix pdd1 all particledistribution/discrete {sd[-1]} {len(clumps)} {weights}")
    path = out_dir / f"{stem}_liggghts.in"
    path.write_text("\n".join(text) + "\n")
    written.append(path)
    return written
