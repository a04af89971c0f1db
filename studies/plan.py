"""``python -m studies plan SPEC``: validate a spec, list the runs it still needs, estimate their cost.

Nothing runs and nothing is written.  Each run's CPU time comes from :mod:`studies.cost` (the
study's own finished runs, else CPU seconds per body and step of every committed run); where the
second is used the total says "about".
"""
from __future__ import annotations

import math

from . import cost
from . import design
from . import spec as S


def _fmt_h(s):
    if math.isnan(s):
        return "?"
    return f"{s / 60:.1f} min" if s < 360 else f"{s / 3600:.2f} h"


def plan(spec, log=print):
    """Print the runs a spec still needs and their estimated cost; returns the total CPU-hours."""
    from . import engine

    rows = engine.status(spec, log=log)
    runs = {r["key"]: r for r in S.runs(spec, extra_seeds=design.possible_extra_seeds(spec))}
    own = design.load_records(spec, S.results_dir(spec))
    per = cost.seconds_per_body_step(cost.committed_records())
    max_att = spec["study"]["max_attempts"]
    todo = [k for k, r in rows.items() if r["status"] in ("todo", "running")
            or (r["status"] == "failed" and int(r["attempts"] or 0) < max_att)]
    total, sources = 0.0, set()
    for k in todo:
        p = runs[k]["params"] if k in runs else S.resolve_run(spec, spec["groups"][rows[k]["group"]],
                                                             rows[k]["case"], rows[k]["seed"])
        bodies, steps = cost.bodies_and_steps(p)
        s, src = cost.estimate(p, own, per)
        sources.add(src)
        total += s
        log(f"  {rows[k]['name']}: {bodies} bodies x {steps:,.0f} steps, {_fmt_h(s)} ({src})")
    word = "about " if "model" in sources else ""
    log(f"{spec['study']['name']}: {len(rows)} runs, {len(rows) - len(todo)} done, {len(todo)} to do: "
        f"{word}{_fmt_h(total)} of CPU" + (" (then the sequential groups may add seeds)"
                                          if todo and any(g.get("target") for g in spec["groups"]) else ""))
    return total / 3600
