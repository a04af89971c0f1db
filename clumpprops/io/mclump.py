"""MercuryDPM: the clump folder MClump writes and MercuryDPM's clump drivers load.

Layout (MercuryDPM ``Drivers/Clump``'s ``ClumpIO.h`` reads these with ``getline``/``stof``)::

    NAME/Clump/Clump.txt      one sphere per line: x,y,z,r   (principal frame, centre of mass at 0)
    NAME/Inertia/Mass.txt     the clump mass (kg)
    NAME/Inertia/TOI.txt      the 3x3 inertia tensor, one row per line, comma-separated (kg m^2)
    NAME/Inertia/PD.txt       principal directions v1, v2, v3, one per line (identity here)
    NAME/clumpprops.txt       units, density, method, the source and the input frame

MClump aligns the principal directions with the axes, so the tensor is diagonal and PD
the identity; ``clumpprops.txt`` records ``com`` and ``principal_axes`` to map the spheres
back to the source frame.  The data files carry no comment lines (each line is parsed as
numbers).  MercuryDPM parses them with ``std::stof``: float32, ~7 significant digits.
"""
from __future__ import annotations

from pathlib import Path
from typing import List, Sequence

import numpy as np

from ._common import Clump, Props, fmt_rows, fnum, header_lines, principal_frame

ENGINE = "MercuryDPM (MClump folder layout)"


def write(clumps: Sequence[Clump], mp, out_dir, density: float, method: str, source: str = "", scale: float = 1.0,
          stem: str = None) -> List[Path]:
    out_dir = Path(out_dir)
    P = Props(mp)
    written = []
    for k, c in enumerate(clumps):
        base = out_dir / c.name
        (base / "Clump").mkdir(parents=True, exist_ok=True)
        (base / "Inertia").mkdir(parents=True, exist_ok=True)
        rel = principal_frame(c.centers, P.com[k], P.axes[k])
        files = {
            base / "Clump" / "Clump.txt": fmt_rows(np.column_stack([rel, c.radii]), ","),
            base / "Inertia" / "Mass.txt": [fnum(P.mass[k])],
            base / "Inertia" / "TOI.txt": [",".join(fnum(P.moments[k][i] if i == j else 0.0) for j in range(3))
                                           for i in range(3)],
            base / "Inertia" / "PD.txt": ["1.0,0.0,0.0", "0.0,1.0,0.0", "0.0,0.0,1.0"],
            base / "clumpprops.txt": header_lines(ENGINE, density, method, source, scale) + [
                "Clump.txt: x,y,z,r in the principal frame (centre of mass at 0); TOI diagonal, PD identity",
                "MercuryDPM reads these files with std::stof (float32, ~7 significant digits)",
                f"mass {fnum(P.mass[k])} kg",
                "principal moments " + " ".join(fnum(x) for x in P.moments[k]) + " kg m^2",
                "com (source frame) " + " ".join(fnum(x) for x in P.com[k]) + " m",
                "principal_axes (columns, source frame): source = com + axes @ Clump.txt position",
            ] + [" ".join(fnum(x) for x in row) for row in P.axes[k]],
        }
        for path, lines in files.items():
            path.write_text("\n".join(lines) + "\n")
            written.append(path)
    return written
