"""The gas's velocity relaxation time against the collision map's: where a gas and the binary
collisions behind the map (studies/maps.py) agree, and where not.

In a dilute gas a body's velocity autocorrelation starts as exp(-t/tau), and 1/tau (the collision
rate times the mean fractional momentum loss per collision) is set by binary collisions alone: it
is the first Chapman-Enskog approximation, which the collision map computes from YADE collisions
as tau x n (``relaxation_time_n``, s m^-3).  A run record gives tau from the first seconds of its
velocity autocorrelation (:func:`studies.diffusion.initial_decay_time`) and n = N / L^3.  The
comparison needs no model of the VACF's tail, so it tests the collisions themselves, case by case:
a D ratio that disagrees with its map can be traced to the case whose collision rate disagrees.

Pure functions of run records and map files; no YADE, no Dask.
"""
from __future__ import annotations

import math

import numpy as np

from . import diffusion, intervals

T_FIT = 2.0     # s of VACF fitted: 0.05-0.08 tau for these gases, 8 frames at 0.25 s


def _vacf(rec):
    """(lags (s), VACF (m^2/s^2)) of a record's first analysis window."""
    w = rec["windows"][0]
    c = np.asarray(w["vacf"])
    return np.arange(len(c)) * w["frame_interval"], c


def run_tau(rec, t_fit=T_FIT):
    """(tau (s) from the record's first analysis window, number density n (m^-3), C(0) = <v^2>
    (m^2/s^2)).  C(0) tau / 3 is the run's D if its VACF is a single exponential."""
    lag, c = _vacf(rec)
    n = rec["params"]["gas"]["n_particles"] / rec["box_length"] ** 3
    return diffusion.initial_decay_time(lag, c, t_fit), n, float(c[0])


def run_shape_factor(rec, t_fit=T_FIT, tau=None):
    """The VACF's shape factor D / D_init of a record's first analysis window: the Green-Kubo D
    (:func:`studies.diffusion.diffusion_green_kubo`, the estimator of record) over the first-seconds
    D_init = C(0) tau / 3.  1 for a single-exponential VACF; how far the full D departs from the first
    Chapman-Enskog approximation that the collision map computes.  ``tau``: the record's
    :func:`run_tau` where the caller has it (else fitted here).  NaN when the window's lags are too
    short for the Green-Kubo estimator."""
    lag, c = _vacf(rec)
    try:
        d = diffusion.diffusion_green_kubo(lag, c)
    except ValueError:
        return float("nan")
    if tau is None:
        tau = diffusion.initial_decay_time(lag, c, t_fit)
    return d / (float(c[0]) * tau / 3.0)


def _same(a, b):
    return a is not None and b is not None and math.isclose(float(a), float(b), rel_tol=1e-9)


def map_matches(m, p):
    """Whether collision map ``m`` (studies/maps.py's file) is of the gas of run parameters
    ``p``: the same shape (kind, overlap, sphere diameter), density, Young's modulus, Poisson ratio
    (where the map states it) and energy per particle."""
    ms, sh, mm, pm = m.get("shape", {}), p["shape"]["definition"], m.get("material", {}), p["material"]
    return (ms.get("kind") == sh.get("kind") and ms.get("overlap") == sh.get("overlap")
            and ms.get("sphere_diameter") == sh.get("sphere_diameter")
            and _same(mm.get("youngs_modulus"), pm["youngs_modulus"]) and _same(mm.get("density"), pm["density"])
            and ("poisson" not in mm or _same(mm["poisson"], pm["poisson"]))
            and _same(m.get("energy_per_particle"), p["gas"]["energy_per_particle"]))


def _map_for(maps, p):
    return next((m for m in maps if "relaxation_time_n" in m and map_matches(m, p)), None)


def _per_seed(collected, maps):
    """{(map file, case, protocol): {seed: {(dt factor, pair key): (tau, n, C(0), shape factor)}}} of the runs
    started in equilibrium that have a map.  The pair key (:func:`studies.effects.collect`'s) keeps
    runs of one seed made with other parameters (another run length, say) apart: a case's run is
    paired only with the exact run of its own pair key and dt factor."""
    by, facts = collected.by, collected.facts
    per = {}
    for pk in by:
        p = facts[pk]
        if p["gas"].get("start") != "equipartition":
            continue
        m = _map_for(maps, p)
        if m is None:
            continue
        for seed, cases in by[pk].items():
            for (case, protocol), (_, rec) in cases.items():
                if f"{case}/{protocol}" not in m["relaxation_time_n"]:
                    continue
                tau_n_c0 = run_tau(rec)
                per.setdefault((m["file"], case, protocol), {}).setdefault(seed, {})[(p["run"]["dt_factor"], pk)] = \
                    tau_n_c0 + (run_shape_factor(rec, tau=tau_n_c0[0]),)
    return per


def rows(collected, maps):
    """One row per map x (case, protocol) with gas runs started in equilibrium: the map's tau and
    its standard error, the gas's mean tau over seeds with a 95 % Student-t interval (one run per
    seed: the smallest dt factor, then the first pair key, where a seed ran several times; a seed's
    runs share its initial state, so they are not independent), and gas / map - 1."""
    per = _per_seed(collected, maps)
    out = []
    by_file = {m["file"]: m for m in maps}
    for (f, case, protocol), seeds in per.items():
        m = by_file[f]
        first = [v[min(v)] for v in seeds.values()]       # one run per seed: the smallest dt factor
        taus = [v[0] for v in first]
        ns = {round(v[1], 12) for v in first}
        if len(ns) != 1:
            raise ValueError(f"{f} {case}/{protocol}: gas runs at different number densities {sorted(ns)}")
        n = ns.pop()
        rt = m["relaxation_time_n"][f"{case}/{protocol}"]
        mean, lo, hi, _, k = intervals.t_interval(taus)
        out.append({"shape": m["shape"]["kind"], "overlap": m["shape"].get("overlap"),
                    "youngs_modulus": m["material"]["youngs_modulus"], "case": case, "protocol": protocol,
                    "map_tau": rt["value"] / n, "map_tau_se": rt["se"] / n, "gas_tau": mean, "gas_ci_low": lo,
                    "gas_ci_high": hi, "n_seeds": k, "relative": mean / (rt["value"] / n) - 1.0, "file": f})
    out.sort(key=lambda r: (r["shape"], str(r["overlap"]), r["youngs_modulus"], r["case"] != "exact", r["case"],
                            r["protocol"]))
    return out


def ratio_rows(collected, maps):
    """One row per map x (case, protocol) other than exact: D_case/D_exact - 1 from the first seconds
    of the VACF, D_init = C(0) tau / 3 per run, paired by seed (both runs at one dt and one pair key; 95 % Student-t
    interval over seeds), next to the map's prediction (``rows`` of the map file, ± 1.96 se paired
    over its collisions).  Where the gas's VACF is one exponential, D_init is its Green-Kubo D, and
    a disagreement with the map is a disagreement of the collisions themselves.

    ``shape_relative`` (with ``shape_ci_low``/``shape_ci_high``, ``shape_n_pairs``): the paired ratio
    of the two cases' VACF shape factors (:func:`run_shape_factor`) - 1.  The Green-Kubo ratio is the
    first-seconds ratio times it: the part of the Green-Kubo ratio the map does not see.  Pairs whose
    shape factor is NaN are left out of it (not of the first-seconds ratio)."""
    per = _per_seed(collected, maps)
    by_file = {m["file"]: m for m in maps}
    out = []
    for (f, case, protocol), seeds in per.items():
        if case == "exact":
            continue
        ex = per.get((f, "exact", "paired"), {})
        vals, shape = [], []
        for s in sorted(seeds):
            common = sorted(set(seeds[s]) & set(ex.get(s, {})))    # a pair: one dt and pair key; the smallest dt
            if common:
                (tc, _, cc, fc), (te, _, ce, fe) = seeds[s][common[0]], ex[s][common[0]]
                vals.append(cc * tc / (ce * te) - 1.0)
                if math.isfinite(fc) and math.isfinite(fe):
                    shape.append(fc / fe - 1.0)
        mrow = next((r for r in by_file[f]["rows"] if r["case"] == case and r["protocol"] == protocol), None)
        if not vals or mrow is None:
            continue
        mean, lo, hi, _, k = intervals.t_interval(vals)
        s_mean, s_lo, s_hi, _, s_k = intervals.t_interval(shape)
        m = by_file[f]
        out.append({"shape": m["shape"]["kind"], "overlap": m["shape"].get("overlap"),
                    "youngs_modulus": m["material"]["youngs_modulus"], "case": case, "protocol": protocol,
                    "map_relative": mrow["relative"], "map_se": mrow["se"], "gas_relative": mean,
                    "gas_ci_low": lo, "gas_ci_high": hi, "n_pairs": k, "shape_relative": s_mean,
                    "shape_ci_low": s_lo, "shape_ci_high": s_hi, "shape_n_pairs": s_k, "file": f})
    out.sort(key=lambda r: (r["shape"], str(r["overlap"]), r["youngs_modulus"], r["case"], r["protocol"]))
    return out
