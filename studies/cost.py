"""The cost model of the study runs: how long a run of given parameters takes, before it runs.

A run's CPU time, in this order, from

1. the finished runs like it in the study's own records (:func:`expected_wall_s`:
   the same physics at another seed, or at another stiffness, length or step, scaled);
2. otherwise CPU seconds per body and step, the median over every committed record of the project
   (``results/*/runs``), times the run's bodies (particles x (members + 1)) and steps (t_end / dt).
   Runs of one machine vary about twofold around it (engines, shapes and recording differ).

Used by ``python -m studies plan`` (:mod:`studies.plan`) and the driver's ETAs (:mod:`studies.engine`).
"""
from __future__ import annotations

import glob
import json
import math
import os

import numpy as np

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
    return read_records(os.path.join(root, "results", "*", "runs", "*.json"))


def bodies_and_steps_run(rec):
    """(bodies, integration steps) a recorded run really made: a cooling run that stopped early
    (``run.cooling_stop``) records ``steps_done``; other runs made every planned step."""
    bodies, steps = bodies_and_steps(rec["params"])
    done = (rec.get("facts") or {}).get("steps_done")
    return bodies, (float(done) if done else steps)


def seconds_per_body_step(recs):
    """Median CPU seconds per body and integration step over the records (None without any)."""
    xs = []
    for rec in recs.values():
        try:
            bodies, steps = bodies_and_steps_run(rec)
        except (KeyError, ValueError, OSError):
            continue
        xs.append(float(rec.get("cpu_s") or rec["wall_s"]) / (bodies * steps))
    return float(np.median(xs)) if xs else None


def estimate(params, own, per_body_step):
    """(CPU seconds, source) of one run: from the study's own like runs, else the cost model."""
    w = expected_wall_s(params, own)
    if w is not None:
        return float(w), "records"
    if per_body_step is None:
        return math.nan, "no estimate"
    bodies, steps = bodies_and_steps(params)
    return per_body_step * bodies * steps, "model"


def _key_without(params, top=("seed",), material=(), run=()):
    """A run's parameters as a comparable string, without the keys named: ``top`` of the parameters
    themselves, ``material`` of its material table, ``run`` of its run table."""
    q = {k: v for k, v in params.items() if k not in top}
    q["material"] = {k: v for k, v in params["material"].items() if k not in material}
    q["run"] = {k: v for k, v in params["run"].items() if k not in run}
    return json.dumps(q, sort_keys=True, default=str)


def _cost_key(params):
    """A run's parameters without its seed and time-step factor: runs that cost the same per step
    (same shape, case, protocol, stiffness, length, gas)."""
    return _key_without(params, run=("dt_factor",))


def _median_like(p, recs, value):
    """Median of ``value(record)`` [s] over the finished runs of the case, protocol and time step of
    resolved run parameters ``p`` (any seed).  Without a run at that time step, the runs at other
    factors, each scaled by its factor over p's (the number of steps goes as 1/dt); None while there
    is none."""
    key = _cost_key(p)
    same = [r for r in recs.values() if _cost_key(r["params"]) == key]
    f = p["run"]["dt_factor"]
    xs = [value(r) for r in same if r["params"]["run"]["dt_factor"] == f]
    if not xs:
        xs = [value(r) * r["params"]["run"]["dt_factor"] / f for r in same]
    return float(np.median(xs)) if xs else None


def _run_cost(p, recs):
    """Median CPU-hours of the finished runs like ``p`` (:func:`_median_like`); None while there is none."""
    c = _median_like(p, recs, lambda r: r.get("cpu_s", r["wall_s"]))
    return None if c is None else c / 3600.0


def read_records(pattern):
    """Every finished run record among the files matching the glob ``pattern`` (dict by path);
    unreadable files and other JSON are skipped."""
    recs = {}
    for path in glob.glob(pattern):
        try:
            with open(path) as f:
                rec = json.load(f)
        except (OSError, ValueError):
            continue
        if isinstance(rec, dict) and "params" in rec and "wall_s" in rec:
            recs[path] = rec
    return recs


def expected_wall_s_in(rdir, p):
    """:func:`expected_wall_s` from every record under ``rdir``/runs (what a worker sees when a run
    is about to start; no spec needed)."""
    return expected_wall_s(p, read_records(os.path.join(rdir, "runs", "*.json")))


def expected_wall_s(p, recs):
    """Expected wall time [s] of a run of resolved parameters ``p``: the median wall time of the
    finished runs like it (:func:`_median_like`).  Without one, an upper bound from the runs that
    differ only in Young's modulus, run length or time-step factor (:func:`_wall_upper_bound`), so
    that a deadline drain can start the first run at a new stiffness; None while there is neither.
    A deadline drain (``studies.runner.may_start``) starts a run only if it fits."""
    w = _median_like(p, recs, lambda r: r["wall_s"])
    return _wall_upper_bound(p, recs) if w is None else w


def _wall_upper_bound(p, recs):
    """Median over the finished runs that differ from ``p`` only in Young's modulus E, run length T
    or time-step factor f (:func:`_bound_key`) of wall_s x :func:`cost_scale` [s]; None without
    such a run."""
    key = _bound_key(p)
    xs = [float(r["wall_s"]) * cost_scale(p, r["params"]) for r in recs.values() if _bound_key(r["params"]) == key]
    return float(np.median(xs)) if xs else None


def cost_scale(p, q):
    """A factor that bounds a run of parameters ``p``'s cost by that of a run ``q`` differing in
    Young's modulus E, run length T and time-step factor f: max(1, (T / T_q) max(1, r)), with
    r = sqrt(E / E_q) f_q / f the ratio of steps per simulated second (dt goes as E^-1/2,
    docs/timestep.md).  An upper bound if a run costs a fixed part (start-up, the analysis) plus a
    part per step plus a part per simulated second (recording), each the same at any E: the first
    needs the factor >= 1, the second (T / T_q) r, the third T / T_q."""
    r = (np.sqrt(float(p["material"]["youngs_modulus"]) / float(q["material"]["youngs_modulus"]))
         * float(q["run"]["dt_factor"]) / float(p["run"]["dt_factor"]))
    return float(max(1.0, float(p["run"]["t_end"]) / float(q["run"]["t_end"]) * max(1.0, r)))


def _bound_key(params):
    """:func:`_cost_key` without the Young's modulus and the run length: the runs whose wall time,
    scaled by :func:`cost_scale`, bounds a run's (the versions stay: a newer model may be slower)."""
    return _key_without(params, material=("youngs_modulus",), run=("dt_factor", "t_end"))
