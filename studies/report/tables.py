"""The report's tables and records: what every section of ``results/README.md`` states, read or
computed from the results files and the run records, with no words (:mod:`studies.report.answers`
and the templates make the sentences).

Reads ``results/granular_gas/*.csv`` (the paper's Fig. 2), the run records of the headline's specs
(:func:`planned`: records read and designs planned once), and computes the paper's share of the
sphere-clump gap (:func:`paper_share`) and the same-spin runs' drift-corrected effects
(:func:`same_spin_rows`).
"""
from __future__ import annotations

import json
import math
import os
from typing import NamedTuple

import numpy as np
import pandas as pd

from .. import design, effects, effects_plots, rates
from .. import spec as S
from ..sequential import MIN_PAIRS


def read_json(path):
    """The JSON document at ``path``, or None if there is none (a section then says so)."""
    if not os.path.exists(path):
        return None
    with open(path) as fh:
        return json.load(fh)


def uncorrected_share(results):
    """The uncorrected row of ``granular_gas/ratio_D.csv`` (the paper's "about 10 %"), or None."""
    rd = os.path.join(results, "granular_gas", "ratio_D.csv")
    if not os.path.exists(rd):
        return None
    q = pd.read_csv(rd)
    u = q[q.case == "uncorrected"]
    return u.iloc[0] if len(u) else None


def fig2_tables(results):
    """(params, summary, paired differences) of the paper's Fig. 2 (``results/granular_gas/``), or
    None without its ``diff_D.csv``; a table without its ``params.json`` is refused, not guessed."""
    d = os.path.join(results, "granular_gas")
    if not os.path.exists(os.path.join(d, "diff_D.csv")):
        return None
    p = read_json(os.path.join(d, "params.json"))
    if p is None:
        raise FileNotFoundError(f"{d}/diff_D.csv has no params.json beside it: the parameters that made it are lost")
    return p, pd.read_csv(os.path.join(d, "summary.csv")), pd.read_csv(os.path.join(d, "diff_D.csv"))


def first_version_row(results):
    """The first version's uncorrected vs exact row of ``granular_gas/diff_D.csv`` (paired), or None."""
    d = os.path.join(results, "granular_gas", "diff_D.csv")
    if not os.path.exists(d):
        return None
    diff = pd.read_csv(d)
    u = diff[(diff.case == "uncorrected") & (diff.protocol == "paired")]
    return u.iloc[0] if len(u) else None
class Planned(NamedTuple):
    """One spec's finished records (by run key) and, for a spec with sequential groups, the status of
    each group from :func:`design.plan` (empty for a spec without targets)."""
    spec: dict
    records: dict
    status: dict


def planned(specs):
    """[:class:`Planned`] of every spec: each spec's records read and its design planned once, for
    every section of the report."""
    out = []
    for sp in specs:
        rdir = S.results_dir(sp)
        recs = design.load_records(sp, rdir) if os.path.isdir(rdir) else {}
        status = design.plan(sp, rdir, recs)[1] if any(g.get("target") for g in sp["groups"]) else {}
        out.append(Planned(sp, recs, status))
    # a question before the end of its pilot (MIN_PAIRS pairs; below 2 it has no interval of its
    # own): projected also from one with pairs that differs only in stiffness, run length or time
    # step (design.prior_projection), so that its budget can be judged before its own spread is
    refs = [(sp, gi, st, recs) for sp, recs, status in out for gi, st in status.items()]
    for sp, _, status in out:
        for gi, st in status.items():
            if st["n"] < 2:
                st["prior"] = design.prior_projection(sp, gi, refs)
            elif st["n"] < MIN_PAIRS and st["state"] == "running":     # a second opinion, from a full pilot only
                pr = design.prior_projection(sp, gi, refs)
                if pr is not None and pr["ref_pairs"] >= MIN_PAIRS:
                    st["prior"] = pr
    return out


def status_rows(plans):
    """(spec, group, status, CPU-hours spent) of every sequential group, those of a spec not started
    yet included (no records: 0 pairs, 0 CPU-hours); ``plans``: :func:`planned` of the specs."""
    out = []
    for sp, recs, status in plans:
        for gi, st in status.items():
            out.append((sp, sp["groups"][gi], st, design.cpu_hours(recs)))
    return out


def same_spin_pairs(sp, settle_s=200.0, recs=None):
    """Per seed, for each non-exact case of a ``spin_pairing = "same"`` spec: D_case/D_exact (Green-Kubo)
    and the ratio r of the case's translational kinetic energy per unit mass to exact's after
    ``settle_s`` (the thermal speed squared the gas relaxed to).  {case: [(seed, D ratio, r)]}.
    ``recs``: the spec's records, if already read."""
    if recs is None:
        rdir = S.results_dir(sp)
        if not os.path.isdir(rdir):
            return {}
        recs = design.load_records(sp, rdir)
    by = {}
    for rec in recs.values():
        if not rec["checks"]["ok"]:
            continue
        e = rec["energy"]
        t = np.asarray(e["t"])
        late = t >= settle_s
        v2 = float(np.mean(np.asarray(e["e_trans"])[late])) / rec["case_body"]["mass"]
        d = design.run_d(rec, sp["analysis"]["t_eq"], stderr=False)["D"]
        by.setdefault(rec["seed"], {})[rec["case"]] = (d, v2)
    out = {}
    for seed, cases in sorted(by.items()):
        if "exact" not in cases:
            continue
        for case, (d, v2) in cases.items():
            if case != "exact":
                out.setdefault(case, []).append((seed, d / cases["exact"][0], v2 / cases["exact"][1]))
    return out


def paper_share(specs, shape="dimer", overlap=0.5, youngs_modulus=1e7, values=None):
    """The paper's "about 10 %" from the equilibrated runs: (D_uncorrected - D_exact) / (D_spheres - D_exact)
    as mean(a) / mean(b), a = per-seed D_uncorrected/D_exact - 1 of the paired runs, b = per-seed
    D_spheres/D_exact - 1 of the sphere gas against exact, with Fieller's 95 % interval
    (studies.intervals.fieller_ratio, which takes a and b independent; coverage checked in the
    tests).  Independence: an exact run's initial state (:func:`studies.effects.state_key`, seed) is
    in at most one of the two samples; a seed whose state both use (the same exact run, or the same
    start at another time step or run length) is left out of the larger sample (``n_dropped``).
    None without two pairs of each.  ``values``: :func:`studies.effects.paired_values` of
    ``specs``, if already read."""
    from ..intervals import fieller_ratio

    values = effects.paired_values(specs) if values is None else values

    def best(case):
        c = [pv for pv in values if pv.case == case and pv.protocol == "paired" and _is(pv.facts)]
        return max(c, key=lambda pv: len(pv.values)) if c else None

    def _is(p):
        return (p["shape"]["definition"].get("kind") == shape
                and p["shape"]["definition"].get("overlap") == overlap
                and float(p["material"]["youngs_modulus"]) == youngs_modulus and p["gas"].get("start") == "equipartition")

    na_, nb_ = best("uncorrected"), best("spheres")
    if na_ is None or nb_ is None:
        return None
    shared = set(na_.exact_states) & set(nb_.exact_states)
    a, b = list(na_.values), list(nb_.values)
    if shared:                                  # not independent: drop them from the larger sample
        if len(a) >= len(b):
            a = [v for v, st in zip(na_.values, na_.exact_states) if st not in shared]
        else:
            b = [v for v, st in zip(nb_.values, nb_.exact_states) if st not in shared]
    if len(a) < 2 or len(b) < 2:
        return None
    th, lo, hi, _, na, nb = fieller_ratio(a, b)
    return {"share": th, "low": lo, "high": hi, "n_num": na, "n_gap": nb, "gap": float(np.mean(b)),
            "n_dropped": len(shared), "shape": shape, "youngs_modulus": youngs_modulus}


def effect_row(effect_rows, protocol, case="uncorrected", shape="dimer", overlap="0.5", youngs_modulus=1e7):
    r = [e for e in effect_rows if e["shape"] == shape and str(e["overlap"]) == overlap and e["protocol"] == protocol
         and e["case"] == case and float(e["youngs_modulus"]) == youngs_modulus and e["n_pairs"] >= 2]
    return max(r, key=lambda e: e["n_pairs"]) if r else None


def map_rows(m):
    return {(r["case"], r["protocol"]): r for r in m["rows"]}


def paper_maps(maps):
    """The paper's dimer's collision maps by Young's modulus: {E: {(case, protocol): row}}."""
    return {m["material"]["youngs_modulus"]: map_rows(m) for m in maps if effects_plots.is_paper_dimer(m)}


def measured(effect_rows, shape, e_mod, case, protocol):
    for r in effect_rows:
        if (r["shape"] == shape["kind"] and str(r["overlap"]) == str(shape.get("overlap", ""))
                and float(r["youngs_modulus"]) == float(e_mod) and r["case"] == case and r["protocol"] == protocol):
            return r
    return None


def hard_times_k2(ee, k2_part):
    """Equal energy: the hard-particle mass scaling times one plus the paired k² part, - 1.  At one kT
    a Hertz gas with every mass scaled by lambda is the same gas in time scaled by lambda^1/2, so the
    contact's softness drops out of the equal-energy ratio and what is left beside the mass scaling
    is the collisions' k² effect (the paired uncorrected - mass_scaled)."""
    return (1.0 + ee["hard_particles"]) * (1.0 + k2_part) - 1.0


def map_of_group(maps, sp, g, case):
    """(collision map, effective protocol) of a group's gas for ``case`` (studies/maps.py; the
    same shape, material and energy: :func:`studies.rates.map_matches`), or (None, None).  A map
    is of a gas in equipartition at each case's own temperature, so a spec that gives every case
    exact's spins (``spin_pairing = "same"``) has none."""
    p = S.resolve_run(sp, g, case, g["seeds"][0])
    if S.spin_pairing_of(p) == "same":
        return None, None
    m = next((m for m in maps if rates.map_matches(m, p)), None)
    return m, (None if m is None else p["protocol"])


def readable_specs():
    """(specs, failures): the headline's specs (:data:`studies.effects.HEADLINE`) whose spec loads
    and whose records can be read and planned, and [(name, one-line error)] of the others, so that one
    broken study is reported in its own section and never stops the report of the rest.  Each spec is
    tried alone first (its records read and paired once more than the report needs: seconds, for a
    report that never stops on one study)."""
    specs, failures = [], []
    for name in effects.HEADLINE:
        try:
            sp = effects.results_specs(names=(name,))[0]
            planned([sp])
            effects.paired_values([sp])
        except (ValueError, OSError) as e:        # SpecError is a ValueError
            failures.append((name, f"{type(e).__name__}: {e}".splitlines()[0]))
            continue
        specs.append(sp)
    return specs, failures




def same_spin_rows(specs, records=None):
    """The superseded same-spin runs, one dict a case of each ``spin_pairing = "same"`` spec with an
    equipartition start and two or more pairs: the measured effect (``m, lo, hi`` over ``n`` seed
    pairs), the thermal-speed drift the spin pairing caused (``dm, dlo, dhi``: sqrt of the energy
    ratio - 1) and the effect with that drift divided out (``cm, clo, chi``: hard-particle scaling
    D ~ thermal speed), each a t-interval over seeds.  ``records``: each spec's records in the
    order of ``specs``, if already read."""
    from ..intervals import t_interval

    out = []
    for i, sp in enumerate(specs):
        if sp["gas"].get("spin_pairing") != "same" or sp["gas"].get("start") != "equipartition":
            continue
        for case, vals in same_spin_pairs(sp, recs=None if records is None else records[i]).items():
            if len(vals) < 2:
                continue
            m, lo, hi, _, n = t_interval([v - 1.0 for _, v, _ in vals])
            dm, dlo, dhi, _, _ = t_interval([math.sqrt(r) - 1.0 for _, _, r in vals])
            cm, clo, chi, _, _ = t_interval([v / math.sqrt(r) - 1.0 for _, v, r in vals])
            out.append({"shape": sp["groups"][0]["shape"], "case": case, "study": sp["study"]["name"], "n": n,
                        "m": m, "lo": lo, "hi": hi, "dm": dm, "dlo": dlo, "dhi": dhi, "cm": cm, "clo": clo, "chi": chi})
    return out


HCS_TARGETS = {"cooling_rate": 0.01, "temperature_ratio": 0.01, "diffusion": 0.02}     # issue 36's half-widths
PREDICTOR_TARGET_CPU_MIN = 30.0          # the predictor's cost per shape and contact law, every case


def _csv_rows(path):
    return pd.read_csv(path).to_dict("records") if os.path.exists(path) else []


def predictor_costs(preds):
    """The predictor's CPU cost per shape and dissipative contact law, every case together.

    Parameters
    ----------
    preds : iterable of dict
        ``predictions.csv`` rows.  A row's ``cpu_s`` is its share: its case's YADE runs and an
        equal share of the exact case's, split over the case's observables, so a law's rows sum to
        its cost.

    Returns
    -------
    list of dict
        shape, youngs_modulus, restitution, friction, n_cases, cpu_min, within (cpu_min <=
        ``PREDICTOR_TARGET_CPU_MIN``), costliest first.
    """
    laws = {}
    for p in preds:
        law = (p["shape"], float(p["youngs_modulus"]), float(p["restitution"]), float(p["friction"]))
        cost, cases = laws.setdefault(law, [0.0, set()])
        laws[law][0] = cost + float(p["cpu_s"])
        cases.add(str(p["case"]))
    out = [dict(shape=k[0], youngs_modulus=k[1], restitution=k[2], friction=k[3], n_cases=len(cases),
                cpu_min=cost / 60, within=cost / 60 <= PREDICTOR_TARGET_CPU_MIN) for k, (cost, cases) in laws.items()]
    return sorted(out, key=lambda c: -c["cpu_min"])


def cooling_tables(results):
    """The cooling section's rows from ``results/hcs_theory.csv``, ``hcs_effects.csv`` and
    ``predictions.csv``: (theory rows, clump rows each with its prediction, the predictor's record,
    dissipative predictions without a gas row)."""
    theory = []
    for r in _csv_rows(os.path.join(results, "hcs_theory.csv")):
        off = r["measured"] / r["theory"] - 1
        theory.append(dict(r, halfwidth=(r["ci_high"] - r["ci_low"]) / 2 / abs(r["measured"]), offset=off,
                           theory_inside=r["ci_low"] <= r["theory"] <= r["ci_high"],
                           within_accuracy=abs(off) <= r["theory_accuracy"]))
    preds = {}
    for p in _csv_rows(os.path.join(results, "predictions.csv")):
        if p["restitution"] != 1 or p["friction"] != 0:
            case, _, prot = str(p["case"]).partition("/")
            preds[(p["shape"], float(p["youngs_modulus"]), float(p["restitution"]), float(p["friction"]), case,
                   p["observable"])] = p
    clumps, used = [], set()
    for r in _csv_rows(os.path.join(results, "hcs_effects.csv")):
        key = (r["shape"], float(r["youngs_modulus"]), float(r["restitution"]), float(r["friction"]), r["case"],
               r["observable"])
        p = preds.get(key)
        used.add(key)
        clumps.append(dict(r, halfwidth=(r["relative_ci_high"] - r["relative_ci_low"]) / 2,
                           target=HCS_TARGETS[r["observable"]],
                           predicted=None if p is None else float(p["predicted"]),
                           predicted_se=None if p is None else float(p["predicted_se"]),
                           inside=p is not None and r["n_pairs"] >= 2
                           and r["relative_ci_low"] <= float(p["predicted"]) <= r["relative_ci_high"]))
    both = [c for c in clumps if c["predicted"] is not None and c["n_pairs"] >= 2]
    apart = [c for c in both if not (c["relative_ci_low"] <= c["predicted"] + 1.96 * c["predicted_se"]
                                     and c["predicted"] - 1.96 * c["predicted_se"] <= c["relative_ci_high"])]
    record = dict(n=len(both), overlap=len(both) - len(apart), apart=len(apart), apart_rows=apart,
                  contain=sum(c["inside"] for c in both),
                  n_rows=len(clumps), targets_met=sum(c["n_pairs"] >= 2 and c["halfwidth"] <= c["target"]
                                                      for c in clumps),
                  costs=predictor_costs(preds.values()), cost_target=PREDICTOR_TARGET_CPU_MIN) if clumps else None
    predicted = [p for k, p in preds.items() if k not in used]
    return theory, clumps, record, predicted


def cooling_campaign(name="hcs_clumps"):
    """The cooling clump campaign's state: each sequential group's target, pairs and projection
    (:func:`planned`), and the spec's CPU-hours and budget; None without the spec or its records.

    Parameters
    ----------
    name : str
        The campaign's spec (a committed spec's name or a file).

    Returns
    -------
    dict or None
        name, path, cpu_hours, budget and ``groups``: per sequential group its shape, label and
        :func:`studies.design.plan` status (case, observable, n, mean, halfwidth, target, state,
        n_needed, cpu_hours_to_target).
    """
    try:
        sp = S.load(S.spec_path(name))
    except (S.SpecError, OSError):
        return None
    plan = planned([sp])[0]
    if not plan.records:
        return None
    groups = [dict(st, shape=sp["groups"][gi]["shape"], label=sp["groups"][gi].get("label", ""))
              for gi, st in sorted(plan.status.items())]
    return dict(name=sp["study"]["name"], path=sp["path"], groups=groups,
                cpu_hours=design.cpu_hours(plan.records), budget=sp["study"].get("budget_cpu_hours"))


def cooling_answer(clumps, case="uncorrected"):
    """Does the correction matter in a cooling gas?  One row per shape and contact law: ``case``'s
    paired effect against exact on each observable, whether its interval excludes 0.

    Parameters
    ----------
    clumps : list of dict
        :func:`cooling_tables`' clump rows.
    case : str
        The case against exact (default the summed spheres, ``uncorrected``).

    Returns
    -------
    dict
        ``rows``: shape, youngs_modulus, restitution, friction, n_pairs (the fewest of its observables) and
        ``effects``: observable -> dict(relative, low, high, halfwidth, resolved), resolved None
        with fewer than two pairs; in the table's order.  ``n``: the effects with an interval;
        ``resolved``: those whose interval excludes 0; ``smallest``, ``largest``: their sizes
        |relative|, and ``top`` the largest one's effect with its shape, friction and observable
        (None when none is resolved).
    """
    out = {}
    for c in clumps:
        if c["case"] != case or c.get("protocol", "paired") != "paired":
            continue
        key = (c["shape"], float(c["youngs_modulus"]), float(c["restitution"]), float(c["friction"]))
        row = out.setdefault(key, dict(shape=key[0], youngs_modulus=key[1], restitution=key[2], friction=key[3],
                                       n_pairs=int(c["n_pairs"]), effects={}))
        row["n_pairs"] = min(row["n_pairs"], int(c["n_pairs"]))
        two = c["n_pairs"] >= 2
        row["effects"][c["observable"]] = dict(
            relative=c["relative"], low=c["relative_ci_low"], high=c["relative_ci_high"],
            halfwidth=c["halfwidth"],
            resolved=_excludes_zero(c, "relative") if two else None)
    rows = list(out.values())
    judged = [dict(x, shape=r["shape"], friction=r["friction"], observable=o)
              for r in rows for o, x in r["effects"].items() if x["resolved"] is not None]
    hits = sorted((x for x in judged if x["resolved"]), key=lambda x: abs(x["relative"]))
    return dict(rows=rows, n=len(judged), resolved=len(hits), smallest=abs(hits[0]["relative"]) if hits else None,
                largest=abs(hits[-1]["relative"]) if hits else None, top=hits[-1] if hits else None)


def _excludes_zero(row, name):
    """Whether the interval ``name``_ci_low .. ``name``_ci_high of a row lies on one side of 0."""
    return row[f"{name}_ci_high"] < 0 or row[f"{name}_ci_low"] > 0


def cooling_checks(results):
    """The cooling estimators' checks: (rows of ``results/estimator/hcs_cooling.csv``, the bias and
    coverage on synthetic DSMC gases; rows of ``results/hcs_relaxation.csv`` whose drift interval
    excludes 0, the clump groups whose T_rot / T_tr still moves in the analysed window; the number
    of groups checked)."""
    est = []
    for r in _csv_rows(os.path.join(results, "estimator", "hcs_cooling.csv")):
        est.append(dict(r, covers=r["coverage_low"] <= 0.95 <= r["coverage_high"],
                        unbiased=abs(r["bias"]) <= 2 * r["bias_se"]))
    relax = _csv_rows(os.path.join(results, "hcs_relaxation.csv"))
    moving = [r for r in relax if _excludes_zero(r, "drift")]
    return est, moving, len(relax)


def cooling_flow(results):
    """The velocity-field check of ``results/hcs_relaxation.csv``: (its rows with a flow growth over
    two or more runs, those whose growth interval lies above 0: vortices forming in the window)."""
    rows = [r for r in _csv_rows(os.path.join(results, "hcs_relaxation.csv"))
            if r.get("flow_runs") is not None and r["flow_runs"] >= 2]
    return rows, [r for r in rows if r["flow_growth_ci_low"] > 0]


def cooling_window(results):
    """The window check of ``results/hcs_window.csv``: (its rows, those whose shift interval
    excludes 0: effects that move when each run's window starts later)."""
    rows = _csv_rows(os.path.join(results, "hcs_window.csv"))
    return rows, [r for r in rows if _excludes_zero(r, "shift")]


def cooling_settling(results):
    """The frictional T_rot / T_tr rows of ``results/hcs_settling.csv``, one dict per (study, shape,
    case) with a reference bin (the first past the effect rows' transient in every seed) and a later
    bin: its bins (``s_low`` order), ``early`` (the reference bin), ``late`` (the last bin with a
    change), ``moved`` (the late bin's change from the reference, per seed and Student-t over the
    seeds in both, excludes 0), ``bound`` (the largest change its interval allows, either sign) and ``predicted`` (the predictor's stationary value from
    ``predictions.csv``, or None)."""
    rows = [r for r in _csv_rows(os.path.join(results, "hcs_settling.csv"))
            if r["friction"] > 0 and r["observable"] == "temperature_ratio"]
    preds = {(p["shape"], float(p["restitution"]), float(p["friction"]), str(p["case"]).partition("/")[0]):
             float(p["predicted"]) for p in _csv_rows(os.path.join(results, "predictions.csv"))
             if p["observable"] == "temperature_ratio"}
    out = []
    for key in sorted({(r["study"], r["shape"], r["restitution"], r["friction"], r["case"]) for r in rows}):
        bins = sorted((r for r in rows if (r["study"], r["shape"], r["restitution"], r["friction"], r["case"]) == key),
                      key=lambda r: r["s_low"])
        changed = [b for b in bins if not pd.isna(b["change"])]
        if not changed:
            continue
        late = changed[-1]
        early = next(b for b in bins if abs(b["s_low"] - late["reference_s"]) < 1e-9)
        out.append({"study": key[0], "shape": key[1], "friction": key[3], "case": key[4], "bins": bins,
                    "early": early, "late": late, "moved": _excludes_zero(late, "change"),
                    "bound": max(abs(late["change_ci_low"]), abs(late["change_ci_high"])),
                    "predicted": preds.get((key[1], key[2], key[3], key[4]))})
    return out


def cooling_maxwellian(results):
    """Rows of ``results/estimator/hcs_maxwellian.csv``: each relative effect of the synthetic
    gases in the DSMC and in the Maxwellian approximation the predictor uses, with ``agrees``
    (the difference within twice its standard error)."""
    return [dict(r, agrees=abs(r["difference"]) <= 2 * r["difference_se"])
            for r in _csv_rows(os.path.join(results, "estimator", "hcs_maxwellian.csv"))]
