"""``results/README.md``: the study's answers, generated from the results tables (no typed numbers).

    .venv/bin/python -m studies.report          # writes results/effects.csv and results/README.md

Reads ``results/granular_gas/*.csv`` (the paper's Fig. 2, paired and equal-energy protocols),
``results/sphere_gas.csv`` (the sphere gas against kinetic theory, :mod:`studies.sphere_gas`),
the run records of every spec under ``studies/specs/`` but those with ``study.in_results = false``
(:func:`studies.effects.results_specs`; through
:mod:`studies.effects` and :mod:`studies.design`), and states, for each question of the paper,
the answer its interval supports, or the half-width reached, the CPU-hours spent and the
projected number of seed pairs where the target is not met yet.
"""
from __future__ import annotations

import json
import math
import os
import sys
from typing import NamedTuple

import numpy as np
import pandas as pd
from scipy import stats

from . import design, effects, effects_plots, rates, sphere_gas
from . import shapes as shp
from . import spec as S
from .estimators import MIN_PAIRS

RESULTS = os.path.join(S.ROOT, "results")


def pct(x, nd=2):
    return "n/a" if pd.isna(x) else f"{100 * x:+.{nd}f} %"


def interval(lo, hi, nd=2):
    return "n/a" if pd.isna(lo) or pd.isna(hi) else f"[{100 * lo:+.{nd}f}, {100 * hi:+.{nd}f}] %"


def verdict(lo, hi, scale=None):
    """Plain words for a 95 % interval of a relative effect."""
    if pd.isna(lo) or pd.isna(hi):
        return "not resolved (fewer than 2 pairs)"
    if lo > 0:
        return "larger than exact, resolved"
    if hi < 0:
        return "smaller than exact, resolved"
    w = max(abs(lo), abs(hi))
    return f"no effect resolved: |effect| < {100 * w:.2f} % at 95 %"


def fig2_section(lines):
    d = os.path.join(RESULTS, "granular_gas")
    if not os.path.exists(os.path.join(d, "diff_D.csv")):
        return
    p = _read_json(os.path.join(d, "params.json"))
    if p is None:
        raise FileNotFoundError(f"{d}/diff_D.csv has no params.json beside it: the parameters that made it are lost")
    diff = pd.read_csv(os.path.join(d, "diff_D.csv"))
    summ = pd.read_csv(os.path.join(d, "summary.csv"))
    lines += ["## The paper's Fig. 2 (`results/granular_gas/`)", "",
              f"{p.get('n_particles')} particles, {p.get('t_end'):g} s per run, D from the MSD on lags "
              f"{p['fit_window_s'][0]:g}-{p['fit_window_s'][1]:g} s (the first version's estimator), "
              f"{p.get('n_runs_ok', '?')} runs.  ![Fig. 2](granular_gas/fig2_msd.png)", "",
              "| case | seeds | D (m²/s) | 95 % CI |", "|---|---|---|---|"]
    for r in summ.itertuples():
        lines.append(f"| {r.case} | {r.n_seeds} | {r.diffusion_coefficient:.3f} | [{r.ci_low:.3f}, {r.ci_high:.3f}] |")
    lines += ["", "| vs exact, paired by seed | protocol | seeds | D_case/D_exact − 1 | 95 % CI | reading |",
              "|---|---|---|---|---|---|"]
    for r in diff.itertuples():
        lines.append(f"| {r.case} | {r.protocol} | {r.n_seeds} | {pct(r.relative)} | "
                     f"{interval(r.relative_ci_low, r.relative_ci_high)} | "
                     f"{verdict(r.relative_ci_low, r.relative_ci_high)} |")
    u = _uncorrected_share()
    if u is not None:
        within = u.ci_low <= 0.10 <= u.ci_high
        lines += ["", f"The paper's \"about 10 %\" (the uncorrected clumps' share of the sphere-clump gap in D): "
                  f"{u.ratio:+.3f} [{u.ci_low:+.3f}, {u.ci_high:+.3f}] over {u.n_seeds} seeds, which "
                  + ("contains 0.10." if within else "excludes 0.10.")]
    lines.append("")


def _uncorrected_share():
    """The uncorrected row of ``granular_gas/ratio_D.csv`` (the paper's "about 10 %"), or None."""
    rd = os.path.join(RESULTS, "granular_gas", "ratio_D.csv")
    if not os.path.exists(rd):
        return None
    q = pd.read_csv(rd)
    u = q[q.case == "uncorrected"]
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


def programme_section(lines, plans):
    """The table of every sequential question; ``plans``: :func:`planned` of the specs."""
    lines += ["## Questions and how far the runs have answered them", ""]
    any_group = False
    for sp, recs, status in plans:
        if not status:
            continue
        lines.append(f"### `{sp['study']['name']}`: {sp['study']['description']}")
        lines.append("")
        budget = sp["study"].get("budget_cpu_hours")
        of = "" if budget is None else f" of a budget of {budget:g}"
        lines.append(f"Spec `{sp['path']}`; " + (f"{len(recs)} finished runs, {design.cpu_hours(recs):.1f} CPU-hours{of}."
                                                  if recs else "not started" + ("" if budget is None else
                                                                                f"; budget {budget:g} CPU-hours") + "."))
        lines.append("")
        lines.append("| question | pairs | D_case/D_exact − 1 | 95 % half-width | target | state | projected pairs "
                     "| CPU-h to target |")
        lines.append("|---|---|---|---|---|---|---|---|")
        prior_seen = False
        for gi, st in status.items():
            any_group = True
            g = sp["groups"][gi]
            mean = st["mean"]
            hw = st["halfwidth"]
            cost = "n/a" if st.get("cpu_hours_to_target") is None else f"{st['cpu_hours_to_target']:.1f}"
            need = "n/a" if st["n_needed"] is None else str(st["n_needed"])
            prior = st.get("prior")
            if prior is not None and st["n"] < 2:
                prior_seen = True
                need = f"{prior['n_needed']} (prior)"
                if prior["cpu_hours_to_target"] is not None:
                    cost = f"{prior['cpu_hours_to_target']:.1f} (prior)"
            elif prior is not None:        # inside its pilot: its own spread, of a few pairs, and the prior's
                prior_seen = True
                need += f"; {prior['n_needed']} (prior)"
            lines.append(f"| {design.shape_label(g)}, {st['case']} vs exact, {g['protocol']} | {st['n']} | {pct(mean)} | "
                         f"{'n/a' if hw != hw else f'{100 * hw:.2f} %'} | {100 * st['target']:.2f} % | {st['state']} | "
                         f"{need} | {cost} |")
        lines.append("")
        lines.append("Projected pairs: the 95 % half-width's target at the spread so far, never fewer than the "
                     f"design's minimum of {MIN_PAIRS} pairs (a smaller pilot sample undercovers). CPU-h to target: the runs "
                     "those pairs still need, each at the median CPU time of the finished runs of its case and time "
                     "step; a run another question already made (a seed's exact run) costs nothing."
                     + (" (prior): a question with fewer than 2 pairs (or, beside its own projection, fewer "
                        f"than the pilot's {MIN_PAIRS}), projected from a question that differs "
                        f"from it only in stiffness, run length or time-step factor (one with {MIN_PAIRS} pairs or more "
                        "first, then the nearest stiffness and run length, then the most pairs; its spread scaled as "
                        "1/sqrt of the analysed length, its run cost as the run length and, when there are more, the "
                        "steps per simulated second (sqrt(E) / dt factor), never below one reference run: an upper "
                        "bound, as the recording's share of a run's cost does not grow with E; "
                        "`studies.design.prior_projection`)." if prior_seen else ""))
        lines.append("")
    if not any_group:
        lines += ["No sequential study has finished pairs yet.", ""]


def effects_section(lines, rows):
    lines += ["## Effect on D for every shape, protocol and stiffness (`effects.csv`)", ""]
    if not rows:
        lines += ["No paired runs finished yet.", ""]
        return
    lines += ["Mass error and k² error: of the body each case runs with, against the exact clump (uncorrected: the "
              "summed clump; mass_only: exact m, summed I; inertia_only: summed m, exact I); k² = I/m with I the mean "
              "principal moment about the axes a frictionless contact can turn (I_⊥ of a linear clump, tr(I)/3 "
              "otherwise); none for the spheres.", "",
              "| shape | D/d_s | protocol | E (Pa) | case | pairs | D_case/D_exact − 1 | 95 % CI | mass error | k² error | YADE | rotation |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['shape']} | {r['overlap']} | {r['protocol']} | {r['youngs_modulus']:.0e} | {r['case']} | "
                     f"{r['n_pairs']} | {pct(r['relative'])} | {interval(r['relative_ci_low'], r['relative_ci_high'])} | "
                     f"{pct(r['mass_error'], 1)} | {pct(r['k2_error'], 1)} | {r['yade_version']} | {r['rot_algorithm']} |")
    lines.append("")


def _status_rows(plans):
    """(spec, group, status, CPU-hours spent) of every sequential group, those of a spec not started
    yet included (no records: 0 pairs, 0 CPU-hours); ``plans``: :func:`planned` of the specs."""
    out = []
    for sp, recs, status in plans:
        for gi, st in status.items():
            out.append((sp, sp["groups"][gi], st, design.cpu_hours(recs)))
    return out


def _cpu_hours(h):
    """"about 3 CPU-hours", "about 1 CPU-hour", "under half a CPU-hour"."""
    if h < 0.5:
        return "under half a CPU-hour"
    n = max(1, int(h + 0.5))
    return f"about {n} CPU-hour{'' if n == 1 else 's'}"


def _cpu_hours_more(h):
    """"about 3 CPU-hours more", "about 1 CPU-hour more", "under half a CPU-hour more"."""
    return _cpu_hours(h) + " more"


def _answer(sp, g, st, cpu):
    """One sentence for one sequential question, from its status (no typed numbers)."""
    what = f"{design.shape_label(g)}, {st['case']} vs exact ({g['protocol']} protocol, `{sp['study']['name']}`)"
    n, mean, hw = st["n"], st["mean"], st["halfwidth"]
    if n < 2 or hw != hw:
        budget = sp["study"].get("budget_cpu_hours")
        of = "" if budget is None else f" of its {budget:g} budgeted"
        begun = "not started" if cpu == 0 else f"the spec has spent {cpu:.1f}{of} CPU-hours"
        return (f"* **{what}:** {n} seed pair(s) so far, no interval yet (target ±{100 * st['target']:.2f} %); "
                f"{begun}" + (f" ({budget:g} CPU-hours budgeted)" if cpu == 0 and budget is not None else "") + "."
                + _prior_words(st.get("prior"), st["target"]))
    lo, hi = mean - hw, mean + hw
    text = (f"* **{what}:** D_case/D_exact − 1 = {pct(mean)}, 95 % CI {interval(lo, hi)} over {n} seed pairs: "
            f"{verdict(lo, hi)}.")
    if st["state"] == "target met":
        text += f" Target half-width ±{100 * st['target']:.2f} % met."
    elif st["met"]:
        text += (f" Target ±{100 * st['target']:.2f} % reached (half-width {100 * hw:.2f} % after "
                 f"{cpu:.1f} CPU-hours for the whole spec); the seeds the group lists are still running "
                 f"(state: {st['state']}).")
    elif hw <= st["target"] and n < st.get("min_n", 0):
        text += (f" Half-width {100 * hw:.2f} % already within the target ±{100 * st['target']:.2f} %, but the "
                 f"design stops no earlier than {st['min_n']} pairs (a smaller pilot sample undercovers, "
                 f"docs/estimator.md): {st['min_n'] - n} more (state: {st['state']}).")
        text += _pilot_prior_words(st)
    else:
        need = st["n_needed"]
        text += (f" Target ±{100 * st['target']:.2f} % not met yet: half-width {100 * hw:.2f} % after "
                 f"{cpu:.1f} CPU-hours for the whole spec; the spread so far projects "
                 f"{need if need is not None else 'n/a'} pairs")
        if st.get("cpu_hours_to_target") is not None:
            text += f", {_cpu_hours_more(st['cpu_hours_to_target'])} for the runs not made yet"
        text += f" (state: {st['state']})."
        text += _pilot_prior_words(st)
    return text


def _prior_words(prior, target, n_done=0):
    """The sentence of a question's prior projection: what its target would take, projected from
    the same question at another stiffness, run length or time step (``design.prior_projection``'s
    choice: a full pilot, then the nearest stiffness and length); "" without one.  ``n_done``: the
    pairs the question already has, which cost nothing more (the CPU-hours are for the rest)."""
    if prior is None:
        return ""
    text = (f" Projected from `{prior['ref']}` ({prior['ref_pairs']} pairs at E = {prior['ref_youngs_modulus']:.0e} Pa, "
            f"{prior['ref_t_end']:g} s runs; spread scaled to this run length, {100 * prior['sd']:.2f} % a pair), "
            f"±{100 * target:.2f} % needs about {prior['n_needed']} pairs")
    if prior["cpu_hours_to_target"] is not None:
        more = max(0, prior["n_needed"] - n_done) * prior["cpu_hours_per_pair"]
        text += (f", at most {_cpu_hours(more)}{' more' if n_done else ''} ({prior['cpu_hours_per_pair']:.2f} a pair, "
                 "the run cost scaled with the number of steps)")
    if (prior["max_seeds"] is not None and prior["n_needed"] > prior["max_seeds"]
            and prior["halfwidth_at_max"] is not None):
        text += (f"; the group's max_seeds ({prior['max_seeds']}) would stop it at about "
                 f"±{100 * prior['halfwidth_at_max']:.2f} %")
    return text + "."


def _pilot_prior_words(st):
    """For a question inside its pilot (2-11 pairs, still running): its own spread is uncertain, so
    the prior's projection follows (:func:`planned` keeps it only from a question with a full
    pilot); "" otherwise."""
    if st.get("prior") is None or st["n"] < 2:
        return ""
    return (f" The spread of {st['n']} pairs is itself uncertain until the design's {MIN_PAIRS}-pair pilot is "
            "complete; the same question at another stiffness, run length or time step gives a second projection."
            + _prior_words(st["prior"], st["target"], n_done=st["n"]))


def _mass_scaling(sp, g, st):
    """For uncorrected vs exact in the equal-energy protocol: the hard-particle prediction (every mass
    scaled by 1 + x at equal energy leaves collisions unchanged and slows the gas by sqrt(1 + x)),
    and whether the interval contains it; "" otherwise."""
    if g.get("protocol") != "equal_energy" or st["case"] != "uncorrected":
        return ""
    x = shp.mass_error(sp["shapes"][g["shape"]], sp["material"]["density"])
    pred = 1.0 / math.sqrt(1.0 + x) - 1.0
    text = (f" Hard particles with every mass {pct(x, 1)} too large predict sqrt(m_exact/m_summed) − 1 = "
            f"{pct(pred)}")
    hw = st["halfwidth"]
    if st["n"] < 2 or hw != hw:
        return text + "."
    inside = st["mean"] - hw <= pred <= st["mean"] + hw
    return text + (": inside the interval." if inside else ": **outside** the interval.")


def _map_of_group(maps, sp, g, case):
    """(collision map, effective protocol) of a group's gas for ``case`` (benchmarks/case_map.py; the
    same shape, material and energy: :func:`studies.rates.map_matches`), or (None, None).  A map
    is of a gas in equipartition at each case's own temperature, so a spec that gives every case
    exact's spins (``spin_pairing = "same"``) has none."""
    p = S.resolve_run(sp, g, case, g["seeds"][0])
    if S.spin_pairing_of(p) == "same":
        return None, None
    m = next((m for m in maps if rates.map_matches(m, p)), None)
    return m, (None if m is None else p["protocol"])


def _map_check(sp, g, st, maps):
    """" The collision map predicts X ± Y %: inside / outside the interval." for a group whose gas has
    a collision map with its case and protocol; "" otherwise.  The map is the first Chapman-Enskog
    approximation from YADE collisions with the gas's contacts (softness included), so it checks
    the gas where a hard-particle prediction cannot."""
    m, protocol = _map_of_group(maps, sp, g, st["case"])
    r = None if m is None else _map_rows(m).get((st["case"], protocol))
    if r is None:
        return ""
    text = (f" The collision map (`{m['file']}`, Hertz contacts, first Chapman-Enskog approximation) predicts "
            f"{pct(r['relative'])} ± {100 * 1.96 * r['se']:.2f} %")
    hw = st["halfwidth"]
    if st["n"] < 2 or hw != hw:
        return text + "."
    lo, hi = st["mean"] - hw, st["mean"] + hw
    p_lo, p_hi = r["relative"] - 1.96 * r["se"], r["relative"] + 1.96 * r["se"]
    reading = ("inside the interval" if lo <= r["relative"] <= hi
               else "outside the interval, but the two intervals overlap" if p_lo <= hi and lo <= p_hi
               else "**outside** the interval, and the two intervals do not overlap")
    return text + f": {reading}."


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


def _same_spin_answers(specs, records=None):
    """Bullets for the superseded same-spin runs: the measured effect, the thermal-speed drift the
    spin pairing caused (from the energy records), and the effect with that drift divided out
    (hard-particle scaling D ~ thermal speed), each a t-interval over seeds.  ``records``: each
    spec's records in the order of ``specs``, if already read."""
    from .estimators import t_interval

    out = []
    for i, sp in enumerate(specs):
        if sp["gas"].get("spin_pairing") != "same" or sp["gas"].get("start") != "equipartition":
            continue
        for case, vals in same_spin_pairs(sp, recs=None if records is None else records[i]).items():
            if len(vals) < 2:
                continue
            rel = [v - 1.0 for _, v, _ in vals]
            drift = [math.sqrt(r) - 1.0 for _, _, r in vals]
            corr = [v / math.sqrt(r) - 1.0 for _, v, r in vals]
            m, lo, hi, _, n = t_interval(rel)
            dm, dlo, dhi, _, _ = t_interval(drift)
            cm, clo, chi, _, _ = t_interval(corr)
            shape = sp["groups"][0]["shape"]
            out.append(
                f"* **{shape}, {case} vs exact, paired with the exact case's spins (`{sp['study']['name']}`, "
                f"superseded):** {pct(m)} {interval(lo, hi)} over {n} seed pairs. Those starts put the {case} "
                f"clumps out of equipartition; the gas relaxed to a thermal speed {pct(dm)} {interval(dlo, dhi)} "
                f"from exact's (translational energy per unit mass after 200 s), which alone moves D as much "
                f"for hard particles. With it divided out: {pct(cm)} {interval(clo, chi)} "
                f"({verdict(clo, chi)}). `dimer_paired` now starts each case in its own equipartition.")
    return out


def paper_share(specs, shape="dimer", overlap=0.5, youngs_modulus=1e7, values=None):
    """The paper's "about 10 %" from the equilibrated runs: (D_uncorrected - D_exact) / (D_spheres - D_exact)
    as mean(a) / mean(b), a = per-seed D_uncorrected/D_exact - 1 of the paired runs, b = per-seed
    D_spheres/D_exact - 1 of the sphere gas against exact, with Fieller's 95 % interval
    (studies.estimators.fieller_ratio, which takes a and b independent; coverage checked in the
    tests).  Independence: an exact run's initial state (:func:`studies.effects.state_key`, seed) is
    in at most one of the two samples; a seed whose state both use (the same exact run, or the same
    start at another time step or run length) is left out of the larger sample (``n_dropped``).
    None without two pairs of each.  ``values``: :func:`studies.effects.paired_values` of
    ``specs``, if already read."""
    from .estimators import fieller_ratio

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


def paper_share_answers(specs, shape="dimer", overlap=0.5, youngs_modulus=1e7, share=False):
    """The bullet of :func:`paper_share` (empty without both samples); ``share``: its result, if known."""
    r = paper_share(specs, shape, overlap, youngs_modulus) if share is False else share
    if r is None:
        return []
    th, lo, hi, na, nb = r["share"], r["low"], r["high"], r["n_num"], r["n_gap"]
    k = r.get("n_dropped", 0)
    dropped = (f"; {k} seed{'s' if k != 1 else ''} whose exact start both samples use left out of the larger one, "
               f"so that the two are independent" if k else "")
    if not np.isfinite(lo):
        reading = "the sphere-clump gap is not resolved from 0: no interval"
        ci = ""
    else:
        ci = f" [{lo:+.3f}, {hi:+.3f}]"
        reading = ("contains" if lo <= 0.10 <= hi else "excludes") + " 0.10 and " + \
                  ("contains" if lo <= 0 <= hi else "excludes") + " 0"
    return [f"* **The paper's \"about 10 %\", equilibrated start** ((D_uncorrected − D_exact) / (D_spheres − D_exact), "
            f"the paper's {shape}, E = {youngs_modulus:.0e} Pa, paired velocities; {na} seed pairs for the numerator, "
            f"{nb} for the sphere-clump gap of {pct(r['gap'])}{dropped}; Fieller 95 % interval): {th:+.3f}{ci}, "
            f"which {reading}. Positive would mean the uncorrected clumps move towards the spheres."]


def _effect_row(effect_rows, protocol, case="uncorrected", shape="dimer", overlap="0.5", youngs_modulus=1e7):
    r = [e for e in effect_rows if e["shape"] == shape and str(e["overlap"]) == overlap and e["protocol"] == protocol
         and e["case"] == case and float(e["youngs_modulus"]) == youngs_modulus and e["n_pairs"] >= 2]
    return max(r, key=lambda e: e["n_pairs"]) if r else None


def _map_rows(m):
    return {(r["case"], r["protocol"]): r for r in m["rows"]}


def _paper_maps(maps):
    """The paper's dimer's collision maps by Young's modulus: {E: {(case, protocol): row}}."""
    return {m["material"]["youngs_modulus"]: _map_rows(m) for m in maps if effects_plots.is_paper_dimer(m)}


def _shape_label(e):
    return f"dimer D/d_s = {e['overlap']}" if e["shape"] == "dimer" else str(e["shape"])


def _other_shapes_words(effect_rows, youngs_modulus=1e7):
    """The gas's answer for the shapes other than the paper's dimer (uncorrected vs exact, at
    ``youngs_modulus``, two or more pairs), in words: at the same velocities the range and the largest
    95 % bound; at the same energy each shape against the hard-particle mass scaling
    (1 + mass error)^(-1/2) - 1.  Empty without such rows."""
    rows = [e for e in effect_rows if e["case"] == "uncorrected" and float(e["youngs_modulus"]) == youngs_modulus
            and e["n_pairs"] >= 2 and not (e["shape"] == "dimer" and str(e["overlap"]) == "0.5")]
    paired = sorted((e for e in rows if e["protocol"] == "paired"), key=lambda e: e["mass_error"])
    equal = sorted((e for e in rows if e["protocol"] == "equal_energy"), key=lambda e: e["mass_error"])
    if not paired and not equal:
        return []

    def ci(e):
        return f"{pct(e['relative'])} {interval(e['relative_ci_low'], e['relative_ci_high'])}"

    def pairs(es):
        ns = sorted({int(e["n_pairs"]) for e in es})
        return f"{ns[0]} seed pairs each" if len(ns) == 1 else f"{ns[0]}-{ns[-1]} seed pairs"

    parts = []
    if paired:
        top = max(max(abs(e["relative_ci_low"]), abs(e["relative_ci_high"])) for e in paired)
        parts.append("At the same velocities the uncorrected clumps' D differs from exact's by "
                     + ", ".join(f"{ci(e)} ({_shape_label(e)}, mass {pct(e['mass_error'], 1)}, "
                                 f"k² {pct(e['k2_error'], 1)})" for e in paired)
                     + f" ({pairs(paired)}): for every shape at most {100 * top:.1f} % of D at 95 %.")
    if equal:
        hard = [(1.0 + e["mass_error"]) ** -0.5 - 1.0 for e in equal]
        inside = [e["relative_ci_low"] <= h <= e["relative_ci_high"] for e, h in zip(equal, hard)]
        sub = [f"{ci(e)} ({_shape_label(e)}; hard particles {pct(h)}, {'inside' if i else 'outside'})"
               for e, h, i in zip(equal, hard, inside)]
        parts.append("At the same kinetic energy: " + ", ".join(sub) + f" ({pairs(equal)}): the hard-particle mass "
                     f"scaling sqrt(m_exact/m_summed) is inside {sum(inside)} of {len(equal)} intervals; the measured "
                     "effects are " + ", ".join(f"{100 * e['relative'] / h:.0f} %" for e, h in zip(equal, hard))
                     + " of it (point estimates).")
    return ["* **Other shapes and overlaps (gas, uncorrected vs exact):** " + " ".join(parts)]


def _stiffness_words(effect_rows, maps):
    """The gas's answer to the hard-particle-limit question in words: the paper's dimer, mass
    corrected alone (mass_only) vs exact at the same velocities, at every stiffness but 1e7 Pa with two
    or more pairs, each beside its collision map's prediction and the mass_scaled part (summed mass,
    exact k²: the softness, which a hard particle cannot feel).  Empty without such rows."""
    stiffer = sorted({float(e["youngs_modulus"]) for e in effect_rows} - {1e7})
    rows = [r for r in (_effect_row(effect_rows, "paired", case="mass_only", youngs_modulus=E) for E in stiffer) if r]
    if not rows:
        return []
    paper = _paper_maps(maps)
    parts = []
    for e in rows:
        E = float(e["youngs_modulus"])
        c = (f"{pct(e['relative'])} {interval(e['relative_ci_low'], e['relative_ci_high'])} at E = {E:.0e} Pa "
             f"({e['n_pairs']} seed pairs; {verdict(e['relative_ci_low'], e['relative_ci_high'])}")
        m = paper.get(E, {}).get(("mass_only", "paired"))
        if m is not None:
            c += f"; collision map {pct(m['relative'])} ± {100 * 1.96 * m['se']:.2f} %"
        parts.append(c + ")")
    soft = [(E, r[("mass_scaled", "paired")]) for E, r in sorted(paper.items()) if ("mass_scaled", "paired") in r]
    tail = ""
    if soft:
        tail = (" What a hard particle cannot feel, the softness acting on a heavier mass (mass_scaled: summed m, "
                "exact k²), is " + ", ".join(f"{pct(r['relative'])} at E = {E:.0e} Pa" for E, r in soft)
                + " in the collision maps; mass_only keeps the summed clump's k² error, so its maps do not go to zero.")
    return ["* **The hard-particle limit (gas, the paper's dimer, mass corrected alone, same velocities):** "
            + ", ".join(parts) + "." + tail]


def plain_words(effect_rows, maps, share):
    """The three answers the issue asks for, in words, from effects.csv's rows, the collision maps
    and the paper's share (each clause only where its numbers exist)."""
    def ci(e):
        return f"{pct(e['relative'])} {interval(e['relative_ci_low'], e['relative_ci_high'])} ({e['n_pairs']} seed pairs)"

    def pm(r, key="relative", se="se"):
        return f"{pct(r[key])} ± {100 * 1.96 * r[se]:.2f} %"

    paper = _paper_maps(maps)
    m7 = paper.get(1e7, {})
    gp, ge = _effect_row(effect_rows, "paired"), _effect_row(effect_rows, "equal_energy")
    mp, me, ms = m7.get(("uncorrected", "paired")), m7.get(("uncorrected", "equal_energy")), m7.get(("mass_scaled", "paired"))
    out = ["## In plain words", ""]
    said = []
    if gp or mp or ge or me:
        parts = []
        if gp or mp:
            c = ("With the paper's protocol (the same velocities for every case) the uncorrected dimer's D differs "
                 "from exact's by " + (ci(gp) if gp else "(no gas interval yet)")
                 + (f", and the collision map predicts {pm(mp)}" if mp else ""))
            if gp and np.isfinite(gp["relative_ci_low"]):
                c += f": at most {100 * max(abs(gp['relative_ci_low']), abs(gp['relative_ci_high'])):.1f} % of D at 95 %"
            parts.append(c + ".")
        if ge or me:
            sub = []
            if ge:
                sub.append(ci(ge) + ("" if ge["relative_ci_low"] <= 0 <= ge["relative_ci_high"] else ", resolved"))
            if me:
                sub.append(f"predicted {pm(me)}, hard particles {pct(me['hard_particles'])}")
            c = "With the same kinetic energy for every case: " + "; ".join(sub)
            if me and abs(me["relative"] - me["hard_particles"]) < 0.25 * abs(me["hard_particles"]):
                c += ", nearly all of it the summed mass through the thermal speed"
            parts.append(c + ".")
        said.append("* **Does the correction matter for D?** " + " ".join(parts))
    if mp and ms and mp.get("minus_mass_scaled") is not None:
        soft = sorted((e, r[("mass_scaled", "paired")]) for e, r in paper.items() if ("mass_scaled", "paired") in r)
        others = [(e, r) for e, r in soft if e != 1e7]
        falls = len(soft) > 1 and all(abs(b[1]["relative"]) < abs(a[1]["relative"]) for a, b in zip(soft, soft[1:]))
        k2s = [(m["shape"]["kind"], m["shape"].get("overlap"), m["material"]["youngs_modulus"], u)
               for m in maps for u in [_map_rows(m).get(("uncorrected", "paired"))]
               if u is not None and u.get("minus_mass_scaled") is not None]
        big = max(k2s, key=lambda t: abs(t[3]["minus_mass_scaled"]))
        top = max(abs(r["minus_mass_scaled"]) + 1.96 * r["minus_mass_scaled_se"] for *_, r in k2s)
        said.append("* **Through which part?** At the same velocities, "
                    f"{pm(ms)} is the contact's softness acting on the heavier summed mass"
                    + (" (" + ", ".join(f"{pct(r['relative'])} at E = {e:.0e} Pa" for e, r in others)
                       + (": it falls as the contact stiffens, towards hard particles, which cannot feel it)"
                          if falls else ")") if others else "")
                    + f", and {pm(mp, 'minus_mass_scaled', 'minus_mass_scaled_se')} the wrong radius of gyration "
                    f"(k² = I/m {pct(mp['iperp_over_m_error'], 1)}). Over the {len(k2s)} collision maps (shapes, "
                    f"overlaps, stiffnesses) the largest k² part is {pm(big[3], 'minus_mass_scaled', 'minus_mass_scaled_se')} "
                    f"({big[0]}, D/d_s = {big[1]}, E = {big[2]:.0e} Pa); in every map its size is below "
                    f"{100 * top:.2f} % of D at 95 %"
                    + (": no shape shows an inertia effect as large as 1 % of D." if top < 0.01 else ".")
                    + " At the same energy the mass error acts through the thermal speed, sqrt(m_exact/m_summed)"
                    + _equal_energy_factorised(maps) + ".")
    gas = [(label, e) for label, e in (("mass corrected alone (mass_only: exact m, summed I)",
                                         _effect_row(effect_rows, "paired", case="mass_only")),
                                        ("inertia corrected alone (inertia_only: summed m, exact I)",
                                         _effect_row(effect_rows, "paired", case="inertia_only"))) if e]
    if gas:
        c = ("In the gas (the paper's dimer, same velocities), with the " + "; with the ".join(
            f"{label}: {ci(e)}, {verdict(e['relative_ci_low'], e['relative_ci_high'])}" for label, e in gas) + ".")
        if said and said[-1].startswith("* **Through which part?**"):
            said[-1] += " " + c
        else:
            said.append("* **Through which part?** " + c)
    said += _other_shapes_words(effect_rows)
    said += _stiffness_words(effect_rows, maps)
    if share is not None and np.isfinite(share["low"]):
        where = ("inside" if share["low"] <= 0.10 <= share["high"] else "outside")
        said.append(f"* **The paper's \"about 10 %\"** of the sphere-clump gap: the uncorrected clumps' share is "
                    f"{share['share']:+.3f} [{share['low']:+.3f}, {share['high']:+.3f}] of a gap of {pct(share['gap'])} "
                    f"({share['n_num']} and {share['n_gap']} seed pairs, equilibrated start): 0.10 is {where} the "
                    "interval.")
    if not said:
        return []
    return out + said + [""]


def answers_section(lines, plans, sph, effect_rows=(), maps=(), share=False):
    """The answers, one bullet each; ``plans``: :func:`planned` of the specs."""
    lines += ["## The answers so far", ""]
    d = os.path.join(RESULTS, "granular_gas", "diff_D.csv")
    specs = [p.spec for p in plans]
    rows = _status_rows(plans)
    for sp, g, st, cpu in rows:
        lines.append(_answer(sp, g, st, cpu) + _mass_scaling(sp, g, st) + _map_check(sp, g, st, maps))
    if not rows:
        lines.append("* No sequential study has finished pairs yet.")
    lines += _same_spin_answers(specs, [p.records for p in plans])
    lines += collision_map_answers(maps)
    if os.path.exists(d):
        diff = pd.read_csv(d)
        u = diff[(diff.case == "uncorrected") & (diff.protocol == "paired")]
        if len(u):
            u = u.iloc[0]
            lines.append(f"* **First version, paper scale** (400 s runs from the paper's zero-spin start, OLS on MSD lags, "
                         f"{u.n_seeds} seeds): uncorrected vs exact {pct(u.relative)}, 95 % CI "
                         f"{interval(u.relative_ci_low, u.relative_ci_high)}: {verdict(u.relative_ci_low, u.relative_ci_high)}.")
    u = _uncorrected_share()
    if u is not None:
        within = u.ci_low <= 0.10 <= u.ci_high
        lines.append(f"* **The paper's \"about 10 %\"** (the uncorrected clumps' share of the sphere-clump gap in D, "
                     f"first version, paper scale): {u.ratio:+.3f} [{u.ci_low:+.3f}, {u.ci_high:+.3f}] over "
                     f"{u.n_seeds} seeds, which " + ("contains 0.10 and 0: not resolved." if within and u.ci_low <= 0
                                                     else "contains 0.10." if within else "excludes 0.10."))
    lines += paper_share_answers(specs, share=share)
    for r in sph:
        lo, hi = r["ratio_hertz_ci_low"] - 1, r["ratio_hertz_ci_high"] - 1
        judged = ("(one run so far: no interval, no verdict)" if pd.isna(lo) or pd.isna(hi)
                  else "(consistent)" if lo <= 0 <= hi else "(**not consistent**)")
        lines.append(f"* **Sphere gas vs kinetic theory, E = {r['youngs_modulus']:.0e} Pa** ({r['source']}): measured D "
                     f"{pct(r['ratio_hertz'] - 1)} {interval(lo, hi)} from the Boltzmann-equation D of Hertz spheres "
                     + judged
                     + f", and {pct(r['ratio_hard'] - 1)} {interval(r['ratio_hard_ci_low'] - 1, r['ratio_hard_ci_high'] - 1)} "
                     "from hard spheres of the same diameter: the contact's softness alone moves D by "
                     f"{pct(r['d_hertz_boltzmann'] / r['d_hard_boltzmann'] - 1)} at this stiffness"
                     + (f"; the runs' time step ({r['dt']:.3g} s) by {r['dt_effect'] * 100:+.3f} % (the collision "
                        "as YADE's leapfrog integrates it)." if _finite(r.get("dt_effect")) else "."))
        dimer = [e for e in effect_rows if e["shape"] == "dimer" and e["case"] == "uncorrected"
                 and str(e["overlap"]) == "0.5" and float(e["youngs_modulus"]) == r["youngs_modulus"]]
        if dimer and r["dlnD_dlnE"] == r["dlnD_dlnE"]:
            x = float(dimer[0]["mass_error"])
            lines.append(f"  Softness also makes D depend on mass at fixed velocities (a mass scaled by lambda acts as "
                         f"E scaled by 1/lambda; d ln D / d ln E = {r['dlnD_dlnE']:.4f} for this sphere gas): the dimer's summed mass, "
                         f"{pct(x, 1)} too large, would by itself raise D by about "
                         f"{pct(-r['dlnD_dlnE'] * math.log1p(x))} in the paired protocol, an effect that vanishes "
                         "as E^-0.4 in the hard-particle limit (estimated with the sphere gas's softness; the dimer's smaller "
                         "member spheres make its contacts softer still).")
    lines.append("")


def _measured(effect_rows, shape, e_mod, case, protocol):
    for r in effect_rows:
        if (r["shape"] == shape["kind"] and str(r["overlap"]) == str(shape.get("overlap", ""))
                and float(r["youngs_modulus"]) == float(e_mod) and r["case"] == case and r["protocol"] == protocol):
            return r
    return None


def _hard_times_k2(ee, k2_part):
    """Equal energy: the hard-particle mass scaling times one plus the paired k² part, - 1.  At one kT
    a Hertz gas with every mass scaled by lambda is the same gas in time scaled by lambda^1/2, so the
    contact's softness drops out of the equal-energy ratio and what is left beside the mass scaling
    is the collisions' k² effect (the paired uncorrected - mass_scaled)."""
    return (1.0 + ee["hard_particles"]) * (1.0 + k2_part) - 1.0


def _equal_energy_factorised(maps):
    """", and the softness drops out: ..." for the plain words, from every map with both an
    equal-energy row and a paired k² part; "" without one."""
    gaps = []
    for m in maps:
        rows = _map_rows(m)
        u, ee = rows.get(("uncorrected", "paired")), rows.get(("uncorrected", "equal_energy"))
        if u and ee and u.get("minus_mass_scaled") is not None:
            gaps.append(abs(ee["relative"] - _hard_times_k2(ee, u["minus_mass_scaled"])))
    if not gaps:
        return ""
    return (f"; the contact's softness drops out there (at one kT every mass scaled alike is the same Hertz gas in "
            f"rescaled time), and what is left beside the mass scaling is the k² part: in each of the {len(gaps)} "
            f"collision maps with an equal-energy row the equal-energy ratio is the hard-particle scaling times one plus the paired k² part to "
            f"{100 * max(gaps):.2f} % of D")


def _equal_energy_words(ee, k2_part):
    if ee is None or k2_part is None:
        return ""
    return (f" At equal energy {pct(ee['relative'])} ± {100 * 1.96 * ee['se']:.2f} %: the hard-particle mass scaling "
            f"{pct(ee['hard_particles'])} times one plus the k² part, {pct(_hard_times_k2(ee, k2_part))} (at one kT the "
            "softness drops out: every mass scaled by lambda is the same Hertz gas in time scaled by lambda^1/2).")


def collision_map_answers(maps):
    """Bullets: for each dimer map, what the collision integral predicts for the paired protocol, split
    into the softness of the heavier mass (``mass_scaled``) and the rest (k^2)."""
    out = []
    paper = [m for m in maps if effects_plots.is_paper_dimer(m)]
    for m in paper:
        rows = _map_rows(m)
        u, sc = rows.get(("uncorrected", "paired")), rows.get(("mass_scaled", "paired"))
        if not (u and sc):
            continue
        k2, k2_se = u.get("minus_mass_scaled"), u.get("minus_mass_scaled_se")
        if k2 is None:
            continue
        out.append(
            f"* **Collision-map prediction, the paper's dimer, E = {m['material']['youngs_modulus']:.0e} Pa** "
            f"(first Chapman-Enskog approximation from {m['pairs_used']} binary collisions run in YADE per case, "
            f"the same courses for every case; ± 1.96 standard errors; `{m['file']}`): uncorrected vs exact, "
            f"paired, {pct(u['relative'])} ± {100 * 1.96 * u['se']:.2f} %. Of it, the heavier mass at the same "
            f"velocities (every mass and moment scaled, k² exact: nothing a hard particle could notice) "
            f"{pct(sc['relative'])} ± {100 * 1.96 * sc['se']:.2f} %, and the wrong k² the rest, "
            f"{pct(k2)} ± {100 * 1.96 * k2_se:.2f} %." + _equal_energy_words(rows.get(("uncorrected", "equal_energy")), k2))
    soft = [(m["material"]["youngs_modulus"], r) for m in paper for r in m["rows"]
            if r["case"] == "mass_scaled" and r["protocol"] == "paired"]
    if len(soft) > 1:
        soft.sort(key=lambda t: t[0])
        out.append("* **The hard-particle limit** (collision map, the paper's dimer, paired, the summed mass with k² "
                   "exact): " + ", ".join(f"{pct(r['relative'])} ± {100 * 1.96 * r['se']:.2f} % at E = {e:.0e} Pa"
                                          for e, r in soft)
                   + ": the mass effect at fixed velocities is the contact's softness and falls as E stiffens.")
    for m in maps:     # the other shapes and overlaps: the paired effect (the k^2 question) and equal energy
        if m in paper:
            continue
        rows = _map_rows(m)
        u, ee = rows.get(("uncorrected", "paired")), rows.get(("uncorrected", "equal_energy"))
        if not (u and ee):
            continue
        sh = m["shape"]
        soft = rows.get(("mass_scaled", "paired"))
        soft_txt = (f", of which the heavier mass's softness {pct(soft['relative'])} ± {100 * 1.96 * soft['se']:.2f} %"
                    if soft else "")
        if soft and u.get("minus_mass_scaled") is not None:
            soft_txt += (f" and the wrong k² {pct(u['minus_mass_scaled'])} ± "
                         f"{100 * 1.96 * u['minus_mass_scaled_se']:.2f} %")
        out.append(
            f"* **Collision-map prediction, {sh['kind']} (D/d_s = {sh.get('overlap')}), "
            f"E = {m['material']['youngs_modulus']:.0e} Pa** ({m['pairs_used']} collisions per case; `{m['file']}`; "
            f"summed mass {pct(u['mass_error'], 1)}, largest moment over mass {pct(u['iperp_over_m_error'], 1)}): uncorrected vs "
            f"exact, paired, {pct(u['relative'])} ± {100 * 1.96 * u['se']:.2f} %{soft_txt}; equal energy "
            f"{pct(ee['relative'])} ± {100 * 1.96 * ee['se']:.2f} % (hard particles {pct(ee['hard_particles'])}"
            + (f"; times one plus the paired k² part: {pct(_hard_times_k2(ee, u['minus_mass_scaled']))}"
               if u.get("minus_mass_scaled") is not None else "") + ").")
    return out


def collision_map_section(lines, maps, effect_rows):
    lines += ["## Collision-map predictions (`results/collision_map/`, `benchmarks/case_map.py`)", "",
              "D_case/D_exact − 1 in the first Chapman-Enskog (Mason-Monchick) approximation: the same binary "
              "collision courses, drawn from the equilibrium gas, run in YADE with each case's mass properties "
              "and its gas-study state (`spin_pairing = \"own\"`); ± 1.96 standard errors over the collisions. "
              "`mass_scaled` (not a gas case): the summed mass with every moment scaled alike, k² exact. "
              "Measured: the gas study's paired interval from `effects.csv`, where there is one.", ""]
    if not maps:
        lines += ["No collision maps committed.", ""]
        return
    lines += ["| shape | D/d_s | E (Pa) | case | protocol | mass error | I_max/m error | predicted | hard particles | measured (gas) |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for m in maps:
        sh, e_mod = m["shape"], m["material"]["youngs_modulus"]
        for r in m["rows"]:
            meas = _measured(effect_rows, sh, e_mod, r["case"], r["protocol"])
            mtxt = (f"{pct(meas['relative'])} {interval(meas['relative_ci_low'], meas['relative_ci_high'])} "
                    f"({meas['n_pairs']} pairs)" if meas else "")
            lines.append(f"| {sh['kind']} | {sh.get('overlap', '')} | {e_mod:.0e} | {r['case']} | {r['protocol']} | "
                         f"{pct(r['mass_error'], 1)} | {pct(r['iperp_over_m_error'], 1)} | "
                         f"{pct(r['relative'])} ± {100 * 1.96 * r['se']:.2f} % | {pct(r['hard_particles'])} | {mtxt} |")
    lines.append("")


def _gas_against_map(n, value, lo, hi, map_value, map_se, num, ival):
    """Table cells "gas value [CI]" and whether its 95 % interval meets the map's (value ± 1.96 SE):
    "overlap" or "**apart**"; with fewer than 2 seeds the value alone and no verdict.  ``num`` and
    ``ival`` format a value and an interval."""
    if n < 2:
        return num(value), ""
    lo_m, hi_m = map_value - 1.96 * map_se, map_value + 1.96 * map_se
    return f"{num(value)} {ival(lo, hi)}", ("overlap" if lo <= hi_m and lo_m <= hi else "**apart**")


def rates_section(lines, rrows):
    lines += ["## Velocity relaxation time: gas against collision map (`studies/rates.py`)", "",
              "A body's velocity autocorrelation starts as exp(−t/τ); in a dilute gas 1/τ is the binary "
              "collisions' rate of momentum loss, the first Chapman-Enskog approximation that the collision map "
              "computes (τ·n, `relaxation_time_n`; ± 1.96 standard errors over its collisions). The gas's τ comes "
              f"from the first {rates.T_FIT:g} s of each run's autocorrelation (95 % Student-t interval over seeds). "
              "The comparison needs no model of the autocorrelation's tail: where a gas D ratio disagrees with "
              "its map, it shows which case's collisions disagree.", ""]
    if not rrows:
        lines += ["No gas runs with a matching collision map yet.", ""]
        return
    lines += ["| shape | D/d_s | E (Pa) | case | protocol | map τ (s) | gas τ (s), 95 % CI | seeds | gas / map − 1 | 95 % intervals |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rrows:
        gas, ov = _gas_against_map(r["n_seeds"], r["gas_tau"], r["gas_ci_low"], r["gas_ci_high"], r["map_tau"],
                                   r["map_tau_se"], lambda x: f"{x:.2f}", lambda lo, hi: f"[{lo:.2f}, {hi:.2f}]")
        lines.append(f"| {r['shape']} | {r['overlap']} | {r['youngs_modulus']:.0e} | {r['case']} | {r['protocol']} | "
                     f"{r['map_tau']:.2f} ± {1.96 * r['map_tau_se']:.2f} | {gas} | {r['n_seeds']} | "
                     f"{pct(r['relative'])} | {ov} |")
    lines.append("")


def rate_ratio_section(lines, rr):
    lines += ["D_case/D_exact − 1 from the first seconds alone (D_init = C(0) τ / 3 per run, paired by seed) "
              "against the map's prediction; equal to the Green-Kubo ratio where the autocorrelation is one "
              "exponential. The last column is the rest of the Green-Kubo ratio: the paired ratio of the two "
              "cases' VACF shape factors D/D_init − 1 (Green-Kubo D over the first-seconds D; 1 for one "
              "exponential; `rates.run_shape_factor`): the Green-Kubo ratio is the first-seconds ratio times "
              "it. The map, a first Chapman-Enskog approximation, is compared with the first-seconds ratio; a "
              "Green-Kubo ratio apart from its map can be apart through either factor.", ""]
    if not rr:
        return
    lines += ["| shape | D/d_s | E (Pa) | case | protocol | map | gas, first seconds, 95 % CI | pairs | 95 % intervals "
              "| shape factors' ratio − 1, 95 % CI |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rr:
        gas, ov = _gas_against_map(r["n_pairs"], r["gas_relative"], r["gas_ci_low"], r["gas_ci_high"],
                                   r["map_relative"], r["map_se"], pct, interval)
        k = r.get("shape_n_pairs", 0)
        shape = ("n/a" if k == 0 else f"{pct(r['shape_relative'])} {interval(r['shape_ci_low'], r['shape_ci_high'])}"
                 + ("" if k == r["n_pairs"] else f" ({k} of {r['n_pairs']} pairs)"))
        lines.append(f"| {r['shape']} | {r['overlap']} | {r['youngs_modulus']:.0e} | {r['case']} | {r['protocol']} | "
                     f"{pct(r['map_relative'])} ± {100 * 1.96 * r['map_se']:.2f} % | {gas} | {r['n_pairs']} | {ov} "
                     f"| {shape} |")
    lines.append("")


def _finite(x):
    return x is not None and not pd.isna(x)


def sphere_gas_section(lines, sph):
    lines += ["## The sphere gas against kinetic theory (`sphere_gas.csv`)", "",
              "The reference gas of frictionless Hertz spheres (the `spheres` case) against the self-diffusion "
              "coefficient of the dilute gas from the Boltzmann equation, for the measured n, kT, m, sigma, E "
              "and nu (`studies/kinetic.py`: the deflection of the Hertz contact by quadrature, the tagged "
              "particle's collision chain summed to all orders; first Chapman-Enskog order for comparison; "
              "all divided by the Enskog factor).", ""]
    if not sph:
        lines += ["No sphere-gas runs yet.", ""]
        return
    if "stderr" in sph[0]:         # a table without the theory's 'stderr' column divides the runs' interval by the theory
        lines += ["The ratios' intervals are Fieller intervals that carry both the runs' error and the theory's "
                  "Monte Carlo error (± one standard error in the theory columns). \"Time step\": the relative "
                  "change of D that the runs' time step makes, from the collision as YADE's leapfrog integrates it "
                  "(`kinetic.timestep_shift`; the theory columns are for the exact orbit).", ""]
    lines += [
              "| E (Pa) | source | runs | D measured (m²/s) | 95 % CI | Hertz, Boltzmann | Hertz, 1st CE | "
              "hard, Boltzmann | hard, 1st CE | time step | measured / Hertz − 1 | measured / hard − 1 |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in sph:
        ci = "n/a" if pd.isna(r["ci_low"]) or pd.isna(r["ci_high"]) else f"[{r['ci_low']:.3f}, {r['ci_high']:.3f}]"
        lines.append(f"| {r['youngs_modulus']:.0e} | {r['source']} | {int(r['n_runs'])} | {r['D']:.3f} | "
                     f"{ci} | {r['d_hertz_boltzmann']:.3f} ± {r['d_hertz_boltzmann_se']:.3f} | "
                     f"{r['d_hertz_first']:.3f} | {r['d_hard_boltzmann']:.3f} ± {r['d_hard_boltzmann_se']:.3f} | "
                     f"{r['d_hard_first']:.3f} | "
                     + (f"{r['dt_effect'] * 100:+.3f} %" if _finite(r.get("dt_effect")) else "n/a")
                     + f" | {pct(r['ratio_hertz'] - 1)} {interval(r['ratio_hertz_ci_low'] - 1, r['ratio_hertz_ci_high'] - 1)} | "
                     f"{pct(r['ratio_hard'] - 1)} {interval(r['ratio_hard_ci_low'] - 1, r['ratio_hard_ci_high'] - 1)} |")
    lines.append("")


RECORD_VARIANT = "t_c = 2 tau, fit 1-3 tau (the estimator of record)"
LATE_VARIANT = "t_c = 2 tau, fit 2-4 tau"


def _vacf_shape_cause(v, e):
    """The sentence on why the estimator reads low on the hard-sphere entry ``e``, from
    ``vacf_shape_md.json`` (``v``) when it is of the same N and has resolved (>= 3 standard errors) a
    local decay time that rises with the lag; else stated as the likely cause.  The rise is called
    the cause only when a tail fitted where it is used (2-4 tau) also moves D by a resolved amount
    that matches the bias within 2 combined standard errors; otherwise it is a measured contributor."""
    guess = ("the likely cause, not proven: a real gas's VACF falls more slowly at long lags than the "
             "exponential the estimator fits on 1-3 tau, docs/estimator.md")
    if not v or v.get("n") != e["n"]:
        return guess
    rise, se = v.get("rise_2_3_over_0_05", math.nan), v.get("rise_se", math.nan)
    if not (se > 0 and rise / se >= 3):                   # NaN fails both
        return guess
    t, ts = v["local_decay_time"], v["local_decay_time_se"]
    measured = (f"(`benchmarks/vacf_shape_md.py`, {v['runs']} runs of {v['n']}): the mean VACF's local "
                f"decay time grows with the lag, {t[0]:.2f} ± {ts[0]:.2f} s on 0-0.5 tau to {t[2]:.2f} ± {ts[2]:.2f} s on "
                f"2-3 tau ({pct(rise)} ± {100 * se:.2f} %), as a mixture of collision rates makes it, so the "
                "exponential fitted on 1-3 tau falls off too fast beyond 2 tau")
    rec, late = v.get("variants", {}).get(RECORD_VARIANT), v.get("variants", {}).get(LATE_VARIANT)
    shift = None
    if late and "rel_record" in late:
        shift = (late["rel_record"], late["rel_record_se"])
    explains = (shift is not None and shift[1] > 0 and shift[0] / shift[1] >= 3
                and abs(shift[0] + e["gk_minus_exact"]) <= 2 * math.hypot(shift[1], e["gk_minus_exact_se"]))
    out = ("the cause, measured " if explains else "a contributor, measured ") + measured
    if rec:
        out += (f"; in those runs the estimator reads {pct(rec['rel_exact'], 3)} ± {100 * rec['rel_exact_se']:.3f} % "
                "from the exact integral")
    if shift is not None and rec:
        out += (f", and a tail fitted where it is used (2-4 tau) reads {pct(shift[0], 3)} ± {100 * shift[1]:.3f} % "
                f"above the estimator (paired), at a per-run sd of {100 * late['sd_per_run']:.2f} % instead of "
                f"{100 * rec['sd_per_run']:.2f} %")
        if not explains:
            out += ", short of the whole bias"
    return out + "; paired ratios, which carry almost none of the bias, keep the estimator of record"


def _read_json(path):
    """The JSON document at ``path``, or None if there is none (a section then says so)."""
    if not os.path.exists(path):
        return None
    with open(path) as fh:
        return json.load(fh)


def hard_sphere_md_section(lines, entries, sph=(), vacf_shape=None):
    """What the event-driven hard-sphere gas (``results/hard_sphere_md.json``) says about the theory
    columns' density correction and about the study's estimator on a real gas's VACF, one row per
    N; and, for each sphere-gas row of the same N and density, its offset from the hard-sphere gas
    analysed the same way.  ``vacf_shape``: ``benchmarks/results/vacf_shape_md.json`` (the VACF's
    local decay time by lag window, and the estimator with other tail fits), or None."""
    entries = sorted((e for e in entries if e.get("n_runs", 0) >= 2 and "gk_minus_exact" in e), key=lambda e: -e["n"])
    if not entries:
        return
    def pm(x, se):
        return f"{pct(x, 3)} ± {100 * se:.3f} %"
    lines += ["### The N-body gas: event-driven hard spheres (`hard_sphere_md.json`)", "",
              "Dividing by Enskog's chi is the theory columns' only density correction; correlated (ring) and "
              "three-body collisions, and recollisions through the periodic images, act at the same order. "
              "`python -m studies.hard_sphere_md` measures them: event-driven molecular dynamics of hard spheres "
              "(a second engine, exact for hard spheres) at the sphere gas's number density, sphere size, mass "
              "and temperature, 1,000 s runs recorded every 0.25 s as the YADE runs are. D of a run two ways: the "
              "study's Green-Kubo estimator, and the exact Green-Kubo integral to 150 s, <v(0)·(r(T) − r(0))>/3 "
              "from the unwrapped positions (no quadrature, no tail model). Against the Boltzmann-equation D of "
              "the same N, ± one standard error (runs and theory):", "",
              "| N | ρσ³ | runs | Enskog 1/χ − 1 | Green-Kubo / D_Boltzmann − 1 | exact integral / D_Boltzmann − 1 | "
              "Green-Kubo / (D_Boltzmann/χ) − 1 | exact integral / (D_Boltzmann/χ) − 1 | Green-Kubo / exact − 1 (paired) | "
              "collision rate / Enskog's − 1 |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for e in entries:
        lines.append(f"| {e['n']} | {e['rho_sigma3']:.5f} | {e['n_runs']} | {pct(e['enskog_rel'], 3)} | "
                     f"{pm(e['d_gk_rel_boltzmann'], e['d_gk_rel_boltzmann_se'])} | "
                     f"{pm(e['d_exact_rel_boltzmann'], e['d_exact_rel_boltzmann_se'])} | "
                     f"{pm(e['d_gk_rel_enskog'], e['d_gk_rel_enskog_se'])} | "
                     f"{pm(e['d_exact_rel_enskog'], e['d_exact_rel_enskog_se'])} | "
                     f"{pm(e['gk_minus_exact'], e['gk_minus_exact_se'])} | "
                     f"{pm(e['rate_rel_enskog'], e['rate_rel_enskog_se'])} |")
    e = entries[0]                         # the largest N
    z_true = e["d_exact_rel_enskog"] / e["d_exact_rel_enskog_se"]
    z_est = e["gk_minus_exact"] / e["gk_minus_exact_se"]
    lines += ["", f"At N = {e['n']}: the hard-sphere gas's true D (the exact integral) is "
              f"{pm(e['d_exact_rel_enskog'], e['d_exact_rel_enskog_se'])} from Enskog's D_Boltzmann / chi ({z_true:+.1f} "
              "standard errors: "
              + ("many-body collisions beyond Enskog's are not resolved at this density" if abs(z_true) < 2 else
                 "many-body collisions beyond Enskog's move D at this density, and the theory columns leave them out")
              + f"), and its collision rate is Enskog's to {pm(e['rate_rel_enskog'], e['rate_rel_enskog_se'])}. "
              f"On this gas the study's Green-Kubo estimator reads {pm(e['gk_minus_exact'], e['gk_minus_exact_se'])} "
              f"from the exact integral of the same runs ({z_est:+.1f} standard errors"
              + ("; " + _vacf_shape_cause(vacf_shape, e) if z_est <= -2 else ": not resolved")
              + ").", ""]
    for r in sph:
        same = [g for g in entries if g["n"] == int(r["n_particles"])
                and abs(r["number_density"] / g["number_density"] - 1) <= 1e-6]
        if not same or r["n_runs"] < 2 or pd.isna(r["ratio_hertz_ci_low"]) or r.get("estimator") != "green_kubo":
            continue
        e = same[0]
        se_r = (r["ratio_hertz_ci_high"] - r["ratio_hertz_ci_low"]) / (2 * stats.t.ppf(0.975, int(r["n_runs"]) - 1))
        diff = r["ratio_hertz"] - 1 - e["d_gk_rel_enskog"]
        lines.append(f"* The YADE sphere gas at E = {r['youngs_modulus']:.0e} Pa ({int(r['n_runs'])} runs, "
                     f"the same estimator) sits {pct(r['ratio_hertz'] - 1)} from its theory column; the hard-sphere "
                     f"N-body gas sits {pct(e['d_gk_rel_enskog'])} from its own: the YADE gas is "
                     f"{pm(diff, math.hypot(se_r, e['d_gk_rel_enskog_se']))} from what the N-body gas of {e['n']} leads one to "
                     "expect (one standard error; assumed: softness changes neither the many-body part nor the "
                     "estimator's bias on the VACF).")
    lines.append("")


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


def failures_section(lines, failures):
    """The studies the report could not read, each with its error (nothing when there is none)."""
    if not failures:
        return
    lines += ["## Studies not reported", "",
              "These studies of the programme could not be read; every other section leaves them out:", ""]
    lines += [f"* `{name}`: {err}" for name, err in failures] + [""]


def build():
    specs, failures = readable_specs()
    plans = planned(specs)                    # every record read, and every design planned, once
    collected = effects.collect(specs, [p.records for p in plans])
    values = effects.paired_values(specs, collected)
    rows = effects.write(specs, os.path.join(RESULTS, "effects.csv"), values=values)
    lines = ["# Results", "",
             "Generated by `.venv/bin/python -m studies.report` from the tables and run records under "
             "`results/`; every interval is a 95 % Student-t interval over seeds (the independent units), "
             "paired by seed where it compares two cases.  D of a run: Green-Kubo on its velocity "
             "autocorrelation (docs/estimator.md) unless a table says otherwise.", ""]
    sph = sphere_gas.read(os.path.join(RESULTS, "sphere_gas.csv"))
    figs = effects_plots.plot_all(RESULTS, log=lambda s: None)
    maps = effects_plots.read_collision_maps(RESULTS)
    share = paper_share(specs, values=values)
    failures_section(lines, failures)
    lines += plain_words(rows, maps, share)
    answers_section(lines, plans, sph, rows, maps, share)
    fig2_section(lines)
    programme_section(lines, plans)
    effects_section(lines, rows)
    collision_map_section(lines, maps, rows)
    rates_section(lines, rates.rows(collected, maps))
    rate_ratio_section(lines, rates.ratio_rows(collected, maps))
    sphere_gas_section(lines, sph)
    vacf_shape = _read_json(os.path.join(S.ROOT, "results", "estimator", "vacf_shape_md.json"))
    hsmd = _read_json(os.path.join(RESULTS, "hard_sphere_md.json"))        # written by studies.hard_sphere_md
    hard_sphere_md_section(lines, hsmd["gases"] if hsmd else [], sph, vacf_shape)
    if figs:
        lines += ["## Figures (drawn from `effects.csv` and `sphere_gas.csv`)", ""]
        lines += [f"![{f}]({f})" for f in figs] + [""]
    text = "\n".join(lines) + "\n"
    path = os.path.join(RESULTS, "README.md")
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)
    return text


def main(argv=()):
    """``python -m studies.report``: 0 on success; 1 with the reason on stderr, no traceback, when
    the results cannot be reported as they are (two effects rows a reader could not tell apart, a
    record without a Green-Kubo D, a bad spec).  A headline study that cannot be read alone is left
    out of the report, which says so in its own section; the status is then 1 too.  ``argv``: the command line's arguments (none are
    taken; ``--help`` prints what the command writes and writes nothing)."""
    import argparse
    argparse.ArgumentParser(prog="python -m studies.report", description="Write results/README.md, the study's answers, generated "
                            "from the results tables (no typed numbers).",
                            epilog="Writes results/effects.csv, results/README.md and the report's plots "
                                   "in results/ from the committed run records.").parse_args(list(argv))
    try:
        text = build()
    except ValueError as e:         # SpecError is one
        print(f"[report] error: {e}", file=sys.stderr)
        return 1
    sys.stdout.write(text)
    if "\n## Studies not reported\n" in text:
        print("[report] error: some studies of the programme could not be read: see 'Studies not reported' in "
              "results/README.md", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
