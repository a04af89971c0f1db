"""YADE: a ``ymport.textClumps`` file (``x y z r clumpId`` per line, SI).

YADE computes a clump's mass and inertia itself when it builds it (summing the spheres,
overlaps counted twice); the exact values are in the comment lines.  To get them inside
YADE use ``clumpprops.yade.text_clumps(FILE)`` (the YADE adapter) instead of
``ymport.textClumps``.  Ids are renumbered 0..M-1 in the order of the clumps; all numbers
are written with 17 significant digits (``yade.export.textClumps`` writes 6).
"""
from __future__ import annotations

from pathlib import Path
from typing import List, Sequence

import numpy as np

from ._common import Clump, Props, fmt_rows, fnum, header_lines

ENGINE = "YADE ymport.textClumps (exact values via clumpprops.yade.text_clumps)"


def text(clumps: Sequence[Clump], mp, density: float, method: str, source: str = "", scale: float = 1.0) -> str:
    P = Props(mp)
    out = ["#format x_y_z_r_clumpId"] + [f"# {h}" for h in header_lines(ENGINE, density, method, source, scale)]
    out.append("# per clump: mass kg, com x y z m, principal moments I1 I2 I3 kg m^2 (ascending)")
    info = fmt_rows(np.column_stack([P.mass, P.com, P.moments]))
    spheres = fmt_rows(np.concatenate([np.column_stack([c.centers, c.radii]) for c in clumps]))
    i = 0
    for k, c in enumerate(clumps):
        out.append(f"# clump {k} ({c.name}): {info[k]}")
        tail = f" {k}"
        out.extend(row + tail for row in spheres[i:i + c.n_spheres])
        i += c.n_spheres
    return "\n".join(out) + "\n"


def write(clumps: Sequence[Clump], mp, out_dir, density: float, method: str, source: str = "", scale: float = 1.0,
          stem: str = None) -> List[Path]:
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    stem = stem or (clumps[0].name if len(clumps) == 1 else "clumps")
    p = out_dir / f"{stem}_textclumps.txt"
    p.write_text(text(clumps, mp, density, method, source, scale))
    return [p]
