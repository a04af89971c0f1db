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
micrometre particles in SI units below 1.2e-38 kg m^2) or when two principal moments that
differ in float64 become equal in float32 (the principal axes then become arbitrary).
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import List, Sequence

import numpy as np

from .. import __version__
from ._common import Clump, fnum, header_lines, principal_frame

ENGINE = "DEM-Engine (DEME) LoadClumpType"
FLOAT32_TOL = 1e-7  # float32 rounds normal numbers to <= 6e-8 relative


def float32_report(mass: float, moments, rel_pos, radii) -> dict:
    """Largest relative change of mass, moments and sphere data when DEME rounds them to float32."""
    def rel(a):
        a = np.atleast_1d(np.asarray(a, dtype=np.float64))
        with np.errstate(over="ignore", invalid="ignore"):
            b = a.astype(np.float32).astype(np.float64)
            d = np.abs(b - a) / np.where(a != 0, np.abs(a), 1.0)
        d[~np.isfinite(b)] = np.inf
        return float(d.max()) if d.size else 0.0

    size = float(np.max(np.linalg.norm(rel_pos, axis=1) + radii))
    with np.errstate(over="ignore"):
        pos32 = np.asarray(rel_pos, dtype=np.float64).astype(np.float32).astype(np.float64)
    m32 = np.sort(np.asarray(moments, dtype=np.float64).astype(np.float32))
    m64 = np.sort(np.asarray(moments, dtype=np.float64))
    collapsed = bool(np.any((np.diff(m64) > 0) & (np.diff(m32) == 0)))
    return {
        "mass": rel(mass),
        "moi": rel(moments),
        "radii": rel(radii),
        "positions_over_size": float(np.max(np.abs(pos32 - rel_pos)) / size) if size > 0 else 0.0,
        "moments_collapse": collapsed,
    }


def float32_problems(rep: dict, tol: float = FLOAT32_TOL) -> List[str]:
    out = [f"{k} changes by {rep[k]:.2g} relative" for k in ("mass", "moi", "radii", "positions_over_size") if rep[k] > tol]
    if rep["moments_collapse"]:
        out.append("distinct principal moments become equal in float32 (principal axes then arbitrary)")
    return out


def write(clumps: Sequence[Clump], mp, out_dir, density: float, method: str, source: str = "", scale: float = 1.0,
          stem: str = None, warn=None) -> List[Path]:
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    batch = np.ndim(mp.mass) == 1
    stem = stem or (clumps[0].name if len(clumps) == 1 else "clumps")
    written, items = [], []
    for k, c in enumerate(clumps):
        m = mp[k] if batch else mp
        rel = principal_frame(c, m)
        name = f"{c.name}_deme.csv"
        lines = ["x,y,z,r"] + [f"{fnum(p[0])},{fnum(p[1])},{fnum(p[2])},{fnum(r)}" for p, r in zip(rel, c.radii)]
        (out_dir / name).write_text("\n".join(lines) + "\n")
        written.append(out_dir / name)
        rep = float32_report(m.mass, m.principal_moments, rel, c.radii)
        probs = float32_problems(rep)
        if probs and warn is not None:
            warn(f"DEME float32: clump {c.name}: " + "; ".join(probs))
        items.append({
            "name": c.name,
            "csv": name,
            "mass": float(m.mass),
            "moi": [float(x) for x in m.principal_moments],
            "n_spheres": c.n_spheres,
            "com": [float(x) for x in m.center_of_mass],
            "principal_axes": np.asarray(m.principal_axes).tolist(),
            "float32_relative_rounding": rep,
            "float32_warnings": probs,
        })
    doc = {
        "comment": header_lines(ENGINE, density, method, source, scale) + [
            "moi = principal moments about the centre of mass along the CSV's x, y, z axes",
            "DEME: DEMSim.LoadClumpType(mass, moi, radii, relPos, material) or LoadClumpType(mass, moi, csv_file, material)",
        ],
        "units": {"length": "m", "mass": "kg", "moi": "kg m^2", "density": "kg/m^3"},
        "density": float(density),
        "method": method,
        "clumpprops_version": __version__,
        "clumps": items,
    }
    p = out_dir / f"{stem}_deme.json"
    p.write_text(json.dumps(doc, indent=1) + "\n")
    written.append(p)
    return written
