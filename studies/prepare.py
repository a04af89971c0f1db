"""Run files of a spec for running by hand: ``python -m studies prepare SPEC --out DIR``.

Writes ``DIR/<run name>.run.json`` (the run file ``yade_scripts/granular_gas.py`` reads) for every
run of the spec and a yade-batch table ``DIR/runs.table`` with one line per run (columns
``run out``), so a single run is ``YADE_BATCH=DIR/runs.table:2 yade -n -x
yade_scripts/granular_gas.py`` and all of them ``yade-batch DIR/runs.table
yade_scripts/granular_gas.py``.  The outputs (``DIR/<run name>.npz`` and ``.json``) are raw: the study
driver, not this command, reduces and records runs.
"""
from __future__ import annotations

import json
import os

from . import spec as S


def write(spec, out):
    os.makedirs(out, exist_ok=True)
    lines = ["run out"]
    for run in S.runs(spec):
        path = os.path.abspath(os.path.join(out, run["name"] + ".run.json"))
        with open(path, "w") as f:
            json.dump(S.run_input(run["params"]), f)
        lines.append(f"{path!r} {os.path.abspath(os.path.join(out, run['name']))!r}")
    with open(os.path.join(out, "runs.table"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"[prepare] {len(lines) - 1} run files and runs.table in {out}")
