"""DEM-Engine (DEME): clump templates for ``DEMSolver.LoadClumpType(mass, moi, radii, relPos, material)``.

DEME takes the clump in its principal frame: sphere positions relative to the centre of
mass along the principal axes, and the three principal moments ``moi``.  Per clump:

* ``NAME_deme.csv``: columns ``x,y,z,r`` (the header row DEME's CSV clump loader reads),
  principal-frame positions and radii in m.  No comment line: DEME reads the first row as
  the column names, so the metadata go to the JSON file;
* one ``STEM_deme.json`` for all clumps: per clump ``mass`` (kg), ``moi`` (principal
  moments, kg m^2, ascending, matching the CSV's x, y, z axes), ``csv``, ``principal_axes``
  (columns, input frame: a point x_p of the CSV is at com + axes @ x_p in the source file),
  ``com`` (source frame), and the float32 check below; plus units, density and method.

DEME stores clump mass, moments and sphere offsets as ``float`` (float32).  :func:`float32_report`
gives the relative change each value suffers when rounded to float32; the exporter warns
when it exceeds ``FLOAT32_TOL`` (values outside float32's normal range, e.g. moments of
nanometre particles in SI units below 1.2e-38 kg m^2) or when two principal moments that
differ in float64 become equal in float32 (the principal axes then become arbitrary).
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import List, Sequence

import numpy as np

from .. import __version__
from ._common import Clump, Props, fmt_rows, header_lines

ENGINE = "DEM-Engine (DEME) LoadClumpType"
FLOAT32_TOL = 1e-7  # float32 rounds normal numbers to <= 6e-8 relative


def _rel32(a):
    """Relative change of each value when rounded to float32 (inf where it overflows)."""
    a = np.asarray(a, dtype=np.float64)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        b = a.astype(np.float32).astype(np.float64)
        d = np.abs(b - a) / np.where(a != 0, np.abs(a), 1.0)
    d[~np.isfinite(b)] = np.inf
    return d


def float32_reports(mass, moments, rel_pos, radii, counts) -> dict:
    """:func:`float32_report` for a batch: arrays with one entry per clump (spheres concatenated,
    ``counts`` spheres per clump)."""
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.intp)
    size = np.maximum.reduceat(np.linalg.norm(rel_pos, axis=1) + radii, starts)
    with np.errstate(over="ignore"):
        pos32 = rel_pos.astype(np.float32).astype(np.float64)
    perr = np.maximum.reduceat(np.max(np.abs(pos32 - rel_pos), axis=1), starts) / np.where(size > 0, size, 1.0)
    m64 = np.sort(np.asarray(moments, dtype=np.float64), axis=1)
    m32 = np.sort(m64.astype(np.float32), axis=1)
    return {
        "mass": _rel32(mass),
        "moi": _rel32(moments).max(axis=1),
        "radii": np.maximum.reduceat(_rel32(radii), starts),
        "positions_over_size": perr,
        "moments_collapse": np.any((np.diff(m64, axis=1) > 0) & (np.diff(m32, axis=1) == 0), axis=1),
    }


def float32_report(mass: float, moments, rel_pos, radii) -> dict:
    """Largest relative change of mass, moments and sphere data when DEME rounds them to float32;
    ``moments_collapse`` if distinct principal moments become equal."""
    rel_pos = np.asarray(rel_pos, dtype=np.float64).reshape(-1, 3)
    r = float32_reports(np.atleast_1d(mass), np.atleast_2d(moments), rel_pos, np.asarray(radii, float), [len(rel_pos)])
    return {k: (bool(v[0]) if k == "moments_collapse" else float(v[0])) for k, v in r.items()}


def float32_problems(rep: dict, tol: float = FLOAT32_TOL) -> List[str]:
    out = [f"{k} changes by {rep[k]:.2g} relative" for k in ("mass", "moi", "radii", "positions_over_size") if rep[k] > tol]
    if rep["moments_collapse"]:
        out.append("distinct principal moments become equal in float32 (principal axes then arbitrary)")
    return out


def write(clumps: Sequence[Clump], mp, out_dir, density: float, method: str, source: str = "", scale: float = 1.0,
          stem: str = None, warn=None, templates: bool = True) -> List[Path]:
    """``STEM_deme.json`` for all clumps (mass, moi, radii, relPos, ...) and, with ``templates``,
    one ``NAME_deme.csv`` per clump."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    P = Props(mp)
    stem = stem or (clumps[0].name if len(clumps) == 1 else "clumps")
    counts = np.array([c.n_spheres for c in clumps])
    owner = np.repeat(np.arange(len(clumps)), counts)
    centers = np.concatenate([c.centers for c in clumps])
    radii = np.concatenate([c.radii for c in clumps])
    rel_all = np.einsum("ni,nij->nj", centers - P.com[owner], P.axes[owner])  # principal frame
    reps = float32_reports(P.mass, P.moments, rel_all, radii, counts)
    written, items = [], []
    start = 0
    for k, c in enumerate(clumps):
        rel = rel_all[start:start + c.n_spheres]
        start += c.n_spheres
        name = f"{c.name}_deme.csv"
        if templates:
            lines = ["x,y,z,r"] + fmt_rows(np.column_stack([rel, c.radii]), ",")
            (out_dir / name).write_text("\n".join(lines) + "\n")
            written.append(out_dir / name)
        rep = {key: (bool(v[k]) if key == "moments_collapse" else float(v[k])) for key, v in reps.items()}
        probs = float32_problems(rep)
        if probs and warn is not None:
            warn(f"DEME float32: clump {c.name}: " + "; ".join(probs))
        items.append(json.dumps({
            "name": c.name,
            "csv": name if templates else None,
            "mass": float(P.mass[k]),
            "moi": P.moments[k].tolist(),
            "radii": c.radii.tolist(),
            "relPos": rel.tolist(),
            "com": P.com[k].tolist(),
            "principal_axes": P.axes[k].tolist(),
            "float32_relative_rounding": rep,
            "float32_warnings": probs,
        }))
    head = {
        "comment": header_lines(ENGINE, density, method, source, scale) + [
            "moi = principal moments about the centre of mass along the x, y, z axes of relPos and the CSV",
            "relPos = sphere centres in that principal frame; source frame: com + principal_axes @ relPos",
            "DEME: DEMSim.LoadClumpType(mass, moi, radii, relPos, material) or LoadClumpType(mass, moi, csv_file, material)",
        ],
        "units": {"length": "m", "mass": "kg", "moi": "kg m^2", "density": "kg/m^3"},
        "density": float(density),
        "method": method,
        "clumpprops_version": __version__,
    }
    text = json.dumps(head, indent=1)[:-2] + ',\n "clumps": [\n' + ",\n".join(items) + "\n ]\n}\n"
    p = out_dir / f"{stem}_deme.json"
    p.write_text(text)
    written.append(p)
    return written
