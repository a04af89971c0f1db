"""The report's table sections, each rendered from its template (``studies/templates/report/``)
and appended to the report's lines: the paper's Fig. 2, the programme of sequential questions,
the effects table, the collision maps, the relaxation times, the sphere gas against kinetic theory,
the event-driven hard-sphere gas and the cooling (dissipative) gases."""
from __future__ import annotations

import math
import os

import pandas as pd
from scipy import stats

from .. import design, rates
from . import tables
from .render import lines as _lines
from .render import render

RECORD_VARIANT = "t_c = 2 tau, fit 1-3 tau (the estimator of record)"
LATE_VARIANT = "t_c = 2 tau, fit 2-4 tau"


def fig2_section(lines, results):
    """The paper's Fig. 2 from ``results/granular_gas/`` (nothing without its tables)."""
    fig2 = tables.fig2_tables(results)
    if fig2 is None:
        return
    p, summary, diff = fig2
    params = dict(n_particles=p.get("n_particles"), t_end=p.get("t_end"), fit_window_s=p["fit_window_s"],
                  n_runs_ok=p.get("n_runs_ok", "?"))
    lines += _lines(render("fig2.md.j2", p=params, summary=list(summary.itertuples()), diff=list(diff.itertuples()),
                           share=tables.uncorrected_share(results)))


def _question(g, st):
    """One row of the programme table: the group's label and protocol with its status."""
    return dict(label=design.shape_label(g), protocol=g["protocol"], case=st["case"], n=st["n"], mean=st["mean"],
                halfwidth=st["halfwidth"], target=st["target"], state=st["state"], n_needed=st["n_needed"],
                cpu_hours_to_target=st.get("cpu_hours_to_target"), prior=st.get("prior"))


def programme_section(lines, plans):
    """The table of every sequential question; ``plans``: :func:`tables.planned` of the specs."""
    studies = [dict(name=sp["study"]["name"], description=sp["study"]["description"], path=sp["path"],
                    n_records=len(recs), cpu_hours=design.cpu_hours(recs), budget=sp["study"].get("budget_cpu_hours"),
                    questions=[_question(sp["groups"][gi], st) for gi, st in status.items()])
               for sp, recs, status in plans if status]
    lines += _lines(render("programme.md.j2", studies=studies))


def effects_section(lines, rows):
    """The effects table (``effects.csv``'s rows)."""
    lines += _lines(render("effects.md.j2", rows=rows))


def collision_map_section(lines, maps, effect_rows):
    """Every collision map's rows, each beside the gas's measured interval where there is one."""
    rows = [(m, r, tables.measured(effect_rows, m["shape"], m["material"]["youngs_modulus"], r["case"], r["protocol"]))
            for m in maps for r in m["rows"]]
    lines += _lines(render("collision_map.md.j2", rows=rows))


def rates_section(lines, rrows):
    """The relaxation times of the gas against its collision map (:func:`studies.rates.rows`)."""
    lines += _lines(render("rates.md.j2", rows=rrows, t_fit=rates.T_FIT))


def rate_ratio_section(lines, rr):
    """The first seconds' D ratios against the map (:func:`studies.rates.ratio_rows`)."""
    lines += _lines(render("rate_ratio.md.j2", rows=rr))


def cooling_section(lines, results):
    """The dissipative and frictional gases: the sphere validations, each clump case's effect in the
    HCS beside its prediction, the predictor's record (:func:`tables.cooling_tables`)."""
    theory, clumps, record, predicted = tables.cooling_tables(results)
    est, moving, n_relax = tables.cooling_checks(results)
    lines += _lines(render("cooling.md.j2", theory=theory, clumps=clumps, record=record, predicted=predicted,
                           answer=tables.cooling_answer(clumps), campaign=tables.cooling_campaign(),
                           estimator=est, moving=moving, n_relax=n_relax, flow=tables.cooling_flow(results),
                           window=tables.cooling_window(results), settling=tables.cooling_settling(results),
                           maxwellian=tables.cooling_maxwellian(results)))


def law_section(lines, results):
    """The law fitted to the predictions and checked on the gas (:mod:`studies.law`); writes
    ``law.csv`` and ``law.png`` under ``results``."""
    from .. import law

    rows, fits, checks = law.law_rows(results, os.path.join(results, "predictions.csv"))
    if rows:
        law.write(rows, os.path.join(results, "law.csv"))
        law.plot(fits, checks, os.path.join(results, "law.png"))
    lines += _lines(render("law.md.j2", rows=law_words(rows, fits), formula=law.FORMULA))


def law_words(rows, fits):
    """The law's rows for its words: each with the stiffnesses its fit's points ran at
    (``stiffnesses``), the one its mass term is quoted at (``mass_at``: E_REF where the points hold
    it, else the lowest of theirs) and that term for a mass 10 % too large (``mass_10pct``, %)."""
    from .. import law

    out = []
    for r in rows:
        es = sorted({p["youngs_modulus"] for p in fits[(r["observable"], r["restitution"], r["friction"])][1]})
        at = law.E_REF if law.E_REF in es or not es else es[0]
        out.append(dict(r, stiffnesses=es, mass_at=at, mass_10pct=10 * r["coef_mass"] * law.softness(at)))
    return out


def sphere_gas_section(lines, sph):
    """The sphere gas against kinetic theory (``sphere_gas.csv``'s rows)."""
    lines += _lines(render("sphere_gas.md.j2", rows=sph))


def vacf_shape_cause(v, e):
    """Why the estimator reads low on the hard-sphere entry ``e``: ``{"kind": "guess"}`` unless
    ``vacf_shape_md.json`` (``v``) is of the same N and has resolved (>= 3 standard errors) a local
    decay time that rises with the lag; then ``kind = "measured"``, with ``explains`` true when a
    tail fitted where it is used (2-4 tau) also moves D by a resolved amount that matches the bias
    within 2 combined standard errors (otherwise the rise is a measured contributor)."""
    if not v or v.get("n") != e["n"]:
        return {"kind": "guess"}
    rise, se = v.get("rise_2_3_over_0_05", math.nan), v.get("rise_se", math.nan)
    if not (se > 0 and rise / se >= 3):                   # NaN fails both
        return {"kind": "guess"}
    rec, late = v.get("variants", {}).get(RECORD_VARIANT), v.get("variants", {}).get(LATE_VARIANT)
    shift = (late["rel_record"], late["rel_record_se"]) if late and "rel_record" in late else None
    explains = (shift is not None and shift[1] > 0 and shift[0] / shift[1] >= 3
                and abs(shift[0] + e["gk_minus_exact"]) <= 2 * math.hypot(shift[1], e["gk_minus_exact_se"]))
    return dict(kind="measured", v=v, t=v["local_decay_time"], ts=v["local_decay_time_se"], rise=rise, rise_se=se,
                rec=rec, late=late, shift=shift, explains=explains)


def _yade_against_md(sph, entries):
    """Each sphere-gas row (two or more Green-Kubo runs) beside the hard-sphere gas of its N and
    density: both offsets from their theory and the YADE gas's offset from what the N-body gas leads
    one to expect, with one standard error."""
    out = []
    for r in sph:
        same = [g for g in entries if g["n"] == int(r["n_particles"])
                and abs(r["number_density"] / g["number_density"] - 1) <= 1e-6]
        if not same or r["n_runs"] < 2 or pd.isna(r["ratio_hertz_ci_low"]) or r.get("estimator") != "green_kubo":
            continue
        e = same[0]
        se_r = (r["ratio_hertz_ci_high"] - r["ratio_hertz_ci_low"]) / (2 * stats.t.ppf(0.975, int(r["n_runs"]) - 1))
        out.append(dict(youngs_modulus=r["youngs_modulus"], n_runs=int(r["n_runs"]), relative=r["ratio_hertz"] - 1,
                        md_relative=e["d_gk_rel_enskog"], diff=r["ratio_hertz"] - 1 - e["d_gk_rel_enskog"],
                        se=math.hypot(se_r, e["d_gk_rel_enskog_se"]), n=e["n"]))
    return out


def hard_sphere_md_section(lines, entries, sph=(), vacf_shape=None):
    """What the event-driven hard-sphere gas (``results/hard_sphere_md.json``) says about the theory
    columns' density correction and about the study's estimator on a real gas's VACF, one row per
    N (two or more runs); and, for each sphere-gas row of the same N and density, its offset from
    the hard-sphere gas analysed the same way.  ``vacf_shape``: ``vacf_shape_md.json`` (the VACF's
    local decay time by lag window, and the estimator with other tail fits), or None."""
    entries = sorted((e for e in entries if e.get("n_runs", 0) >= 2 and "gk_minus_exact" in e), key=lambda e: -e["n"])
    if not entries:
        return
    e = entries[0]                         # the largest N
    lines += _lines(render("hard_sphere_md.md.j2", entries=entries,
                           z_true=e["d_exact_rel_enskog"] / e["d_exact_rel_enskog_se"],
                           z_est=e["gk_minus_exact"] / e["gk_minus_exact_se"], cause=vacf_shape_cause(vacf_shape, e),
                           yade=_yade_against_md(sph, entries)))
