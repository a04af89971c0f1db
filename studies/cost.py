"""The cost model of the study runs: how long a run of given parameters takes, before it runs.

A run's CPU time, in this order, from

1. the finished runs like it in the study's own records (:func:`studies.design.expected_wall_s`:
   the same physics at another seed, or at another stiffness, length or step, scaled);
2. otherwise CPU seconds per body and step, the median over every committed record of the project
   (``results/*/runs``), times the run's bodies (particles x (members + 1)) and steps (t_end / dt).
   Runs of one machine vary about twofold around it (engines, shapes and recording differ).

Used by ``python -m studies plan`` (:mod:`studies.plan`) and the driver's ETAs (:mod:`studies.engine`).
"""
from __future__ import annotations

import math
import os

import numpy as np

from . import design
from . import shapes as shp
from . import spec as S


def bodies_and_steps(params):
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
            bodies, steps = bodies_and_steps(rec["params"])
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
    bodies, steps = bodies_and_steps(params)
    return per_body_step * bodies * steps, "model"
