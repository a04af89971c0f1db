"""``python -m studies plan SPEC``: validate a spec, list the runs it still needs, estimate their cost.

Nothing runs and nothing is written.  A run's CPU time is estimated, in this order, from

1. the finished runs like it in the study's own records (:func:`studies.design.expected_wall_s`:
   the same physics at another seed, or at another stiffness, length or step, scaled);
2. otherwise the cost model: CPU seconds per body and step, the median over every committed
   record of the project (``results/*/runs``), times the run's bodies (particles x (members + 1))
   and steps (t_end / dt).  Runs of one machine vary about twofold around it (engines, shapes and
   recording differ), so this first estimate says "about".
"""
from __future__ import annotations

import math
import os

import numpy as np

from . import design
from . import shapes as shp
from . import spec as S


def _bodies_and_steps(params):
    """(bodies in the scene, integration steps) of a run of resolved parameters."""
    props = shp.properties(params["shape"]["definition"], params["material"]["density"])
    members = 1 if params["case"] == "spheres" else len(props["radii"]) + 1
    steps = params["run"]["t_end"] / S.time_step(params, props)
    return int(params["gas"]["n_particles"]) * members, steps


def committed_records(root=S.ROOT):
    """Every reduced run record under ``root``/results/*/runs (dict by path)."""
    return design.read_records(os.path.join(root, "results", "*", "runs", "*.json"))


def seconds_per_body_step(recs):
    """Median CPU seconds per body and integration step over the records (None without any)."""
    xs = []
    for rec in recs.values():
        try:
            bodies, steps = _bodies_and_steps(rec["params"])
        except (KeyError, ValueError, OSError):
            continue
        xs.append(float(rec.get("cpu_s") or rec["wall_s"]) / (bodies * steps))
    return float(np.median(xs)) if xs else None


def estimate(params, own, per_body_step):
    """(CPU seconds, source) of one run: from the study's own like runs, else the cost model."""
    w = design.expected_wall_s(params, own)
    if w is not None:
        return float(w), "records"
    if per_body_step is None:
        return math.nan, "no estimate"
    bodies, steps = _bodies_and_steps(params)
    return per_body_step * bodies * steps, "model"


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
    per = seconds_per_body_step(committed_records())
    max_att = spec["study"]["max_attempts"]
    todo = [k for k, r in rows.items() if r["status"] in ("todo", "running")
            or (r["status"] == "failed" and int(r["attempts"] or 0) < max_att)]
    total, sources = 0.0, set()
    for k in todo:
        p = runs[k]["params"] if k in runs else S.resolve_run(spec, spec["groups"][rows[k]["group"]],
                                                             rows[k]["case"], rows[k]["seed"])
        bodies, steps = _bodies_and_steps(p)
        s, src = estimate(p, own, per)
        sources.add(src)
        total += s
        log(f"  {rows[k]['name']}: {bodies} bodies x {steps:,.0f} steps, {_fmt_h(s)} ({src})")
    word = "about " if "model" in sources else ""
    log(f"{spec['study']['name']}: {len(rows)} runs, {len(rows) - len(todo)} done, {len(todo)} to do: "
        f"{word}{_fmt_h(total)} of CPU" + (" (then the sequential groups may add seeds)"
                                          if todo and any(g.get("target") for g in spec["groups"]) else ""))
    return total / 3600
