"""``docs/findings.md``: the study's findings page, generated from the report's tables (no typed numbers).

The facts of each bullet of ``studies/templates/report/findings.md.j2``, gathered from what
:func:`studies.report.build` already computes (effects.csv's rows, the collision maps, the paper's
share, the programme's status, the sphere gas, the relaxation-time rows, the hard-sphere gas) and
from ``results/sphere_gas_size/sphere_gas.csv`` (a diagnostic kept out of the report's tables).
"""
from __future__ import annotations

import inspect
import math
import os
import sys

import numpy as np

from .. import design, effects_plots, rates, sphere_gas
from .. import spec as S
from . import answers, tables
from .render import render

FINDINGS = os.path.join(S.ROOT, "docs", "findings.md")


def _map_row(maps, kind, overlap, youngs_modulus, case="uncorrected", protocol="paired"):
    """The collision map's row of one shape, E, case and protocol, or None."""
    for m in maps:
        sh = m["shape"]
        if (sh["kind"] == kind and float(sh.get("overlap", 0)) == overlap
                and float(m["material"]["youngs_modulus"]) == youngs_modulus):
            return tables.map_rows(m).get((case, protocol))
    return None


def _spec_cost(plans, name):
    """The spec ``name``'s CPU-hours spent (``cpu``), ``budget``, number of targets, whether every
    target is met (``met``), its ``[run]`` table and ``targets`` by (case, protocol); None without it."""
    for sp, recs, status in plans:
        if sp["study"]["name"] == name:
            return dict(cpu=design.cpu_hours(recs), budget=sp["study"].get("budget_cpu_hours"),
                        n_targets=len(status), met=all(st["state"] == "target met" for st in status.values()),
                        run=sp["run"], targets={(st["case"], sp["groups"][gi]["protocol"]): st["target"]
                                                     for gi, st in status.items()})
    return None


def _softness_exponent(soft):
    """The slope of log |mass_scaled part| against log E over the paper's dimer's maps (``soft``:
    [(E, row)]), or None with fewer than two."""
    if len(soft) < 2:
        return None
    e = np.log([E for E, _ in soft])
    return float(np.polyfit(e, np.log([abs(r["relative"]) for _, r in soft]), 1)[0])


def _shape_maps(maps, youngs_modulus):
    """The maps other than the paper's dimer at ``youngs_modulus``: {(kind, overlap): row facts}."""
    out = {}
    for m in maps:
        if float(m["material"]["youngs_modulus"]) != youngs_modulus:
            continue
        rows = tables.map_rows(m)
        u, ee, sc = rows.get(("uncorrected", "paired")), rows.get(("uncorrected", "equal_energy")), \
            rows.get(("mass_scaled", "paired"))
        if u and ee:
            out[(m["shape"]["kind"], float(m["shape"].get("overlap", 0.5)))] = dict(
                u=u, ee=ee, soft=sc, k2=u.get("minus_mass_scaled"), above=ee["relative"] - ee["hard_particles"])
    return out


def _span(values):
    """(smallest, largest) of ``values``; (NaN, NaN) without any."""
    return (min(values), max(values)) if values else (math.nan, math.nan)


def _overlap(row):
    """A table row's overlap D/d_s as a float; None for a shape without one (a grain from a file)."""
    return float(row["overlap"]) if row["overlap"] not in ("", None) else None


def _shapes(effect_rows, maps, checks):
    """The other shapes' bullet: the maps at 1e7 and 1e9 Pa and each gas row beside its map."""
    m7, m9 = _shape_maps(maps, 1e7), _shape_maps(maps, 1e9)
    dimers = {k: v for k, v in m7.items() if k[0] == "dimer" and k[1] != 0.5}
    gas = {(e["shape"], _overlap(e), e["protocol"]): e for e in effect_rows
           if e["case"] == "uncorrected" and float(e["youngs_modulus"]) == 1e7 and e["n_pairs"] >= 2}
    return dict(m7=m7, m9=m9, gas=gas,
                soft9=_span([v["soft"]["relative"] for k, v in m9.items() if v["soft"] and k != ("dimer", 0.5)]),
                k2_9=_span([v["k2"] for v in m9.values() if v["k2"] is not None]),
                k2_dimers=_span([v["k2"] for v in dimers.values() if v["k2"] is not None]),
                above=_span([v["above"] for v in m7.values()]),
                dimer_ee=_span([v["ee"]["relative"] for v in dimers.values()]),
                all_inside=all(c is None or c["reading"] in (None, "inside") for c in checks))


def _rates(rrows, ratio_rows):
    """The gas-against-map bullet: the exact clumps' relaxation times and the D ratios' two factors."""
    exact = [abs(r["relative"]) for r in rrows if r["case"] == "exact"]
    meets = [r["gas_ci_low"] <= r["map_relative"] + 1.96 * r["map_se"]
             and r["map_relative"] - 1.96 * r["map_se"] <= r["gas_ci_high"] for r in ratio_rows]
    zero = [r["shape_ci_low"] <= 0 <= r["shape_ci_high"] for r in ratio_rows if r["shape_n_pairs"] >= 2]

    def row(shape, protocol, overlap=0.5):
        return next((r for r in ratio_rows if r["shape"] == shape and float(r["overlap"]) == overlap
                     and r["protocol"] == protocol and r["case"] == "uncorrected" and r["youngs_modulus"] == 1e7), None)

    return dict(t_fit=rates.T_FIT, exact=_span(exact), n=len(ratio_rows), n_meet=sum(meets), n_zero=sum(zero),
                n_shape=len(zero),
                pairs=_span([r["n_pairs"] for r in ratio_rows]), tet_ee=row("tetrahedron", "equal_energy"),
                tri_ee=row("trimer_triangle", "equal_energy"), paper=row("dimer", "paired"))


def _kinetic(sph, hsmd, vacf, results):
    """The sphere gas against kinetic theory, the hard-sphere gas and the estimator's bias."""
    gk = [r for r in sph if r.get("estimator") == "green_kubo"]
    by_e = {r["youngs_modulus"]: r for r in gk}
    first = next((r for r in sph if r.get("estimator") != "green_kubo"), None)
    md = max((g for g in (hsmd or {}).get("gases", []) if g.get("n_runs", 0) >= 2), key=lambda g: g["n"], default=None)
    size = sphere_gas.read(os.path.join(results, "sphere_gas_size", "sphere_gas.csv"))
    late = (vacf or {}).get("variants", {}).get("t_c = 2 tau, fit 2-4 tau")
    r7 = by_e.get(1e7)
    yade = None
    if md and r7:
        se_r = (r7["ratio_hertz_ci_high"] - r7["ratio_hertz_ci_low"]) / (2 * _t975(int(r7["n_runs"]) - 1))
        yade = dict(diff=r7["ratio_hertz"] - 1 - md["d_gk_rel_enskog"], se=math.hypot(se_r, md["d_gk_rel_enskog_se"]))
    return dict(first=first, by_e=by_e, md=md, yade=yade, vacf=vacf, late=late,
                size=sorted(size, key=lambda r: -r["n_particles"]),
                n_chains=inspect.signature(sphere_gas.rows).parameters["n_chains"].default,
                hard=_span([(r["ratio_hard"] - 1) for r in sph if r["youngs_modulus"] == 1e7]))


def _t975(dof):
    from scipy import stats

    return float(stats.t.ppf(0.975, dof))


def _paper_dimer(effect_rows, maps, words):
    """The paper's dimer in the collision maps (the 1e7 Pa map's rows ``map7`` and file ``map_file``,
    the softness part by E with its exponent, the k² parts' span and the stiffest map's k² part) and
    the mass corrected alone in the gas (the largest 95 % bound) and in the maps (their span)."""
    paper = tables.paper_maps(maps)
    soft = sorted((E, r[("mass_scaled", "paired")]) for E, r in paper.items() if ("mass_scaled", "paired") in r)
    k2 = {E: r[("uncorrected", "paired")].get("minus_mass_scaled") for E, r in paper.items()
          if ("uncorrected", "paired") in r}
    stiff = words["stiffness"]
    mass_only = ([tables.effect_row(effect_rows, "paired", case="mass_only")]
                 + [e for e, _ in (stiff["rows"] if stiff else [])])
    return dict(map7=paper.get(1e7, {}),
                map_file=next((m for m in maps if effects_plots.is_paper_dimer(m)
                               and float(m["material"]["youngs_modulus"]) == 1e7), None),
                soft=soft, exponent=_softness_exponent(soft), k2_paper=_span(list(k2.values())),
                k2_stiffest=k2[max(k2)] if k2 else None,
                mass_only_top=max((max(abs(e["relative_ci_low"]), abs(e["relative_ci_high"])) for e in mass_only if e),
                                  default=math.nan),
                mass_only_maps=_span([r[("mass_only", "paired")]["relative"] for r in paper.values()
                                      if ("mass_only", "paired") in r]))


def facts(plans, effect_rows, maps, share, sph, rrows, ratio_rows, hsmd, vacf, results):
    """Everything ``findings.md.j2`` states, from the report's tables (see the module's docstring):
    ``plans`` (:func:`tables.planned`), effects.csv's rows, the collision maps, the paper's share
    (:func:`tables.paper_share`), the sphere-gas rows, :func:`studies.rates.rows` and
    :func:`studies.rates.ratio_rows`, ``hard_sphere_md.json``, ``vacf_shape_md.json`` and the results
    folder."""
    words = answers.plain_words_facts(effect_rows, maps, share)
    checks = [answers.map_check(sp, g, st, maps) for sp, g, st, _ in tables.status_rows(plans)]
    fig2 = tables.fig2_tables(results)
    spheres_first = None if fig2 is None else fig2[2][(fig2[2].case == "spheres") & (fig2[2].protocol == "paired")].iloc[0]
    return dict(w=words, share=share, share_first=tables.uncorrected_share(results), spheres_first=spheres_first,
                all_met=all(st["state"] == "target met" for p in plans for st in p.status.values()),
                same_spin=tables.same_spin_rows([p.spec for p in plans], [p.records for p in plans]),
                paired=_spec_cost(plans, "dimer_paired"), equal=_spec_cost(plans, "dimer_equal_energy"),
                shapes_spec=_spec_cost(plans, "shapes"), stiffness_spec=_spec_cost(plans, "stiffness"),
                shapes=_shapes(effect_rows, maps, checks), rates=_rates(rrows, ratio_rows),
                kinetic=_kinetic(sph, hsmd, vacf, results), cooling=tables.cooling_tables(results),
                **_paper_dimer(effect_rows, maps, words))


def write(path=FINDINGS, **kwargs):
    """Render ``findings.md.j2`` with :func:`facts` (``kwargs``) and write it to ``path``; returns the
    text.  Results without a table or row the page states (a study not reported, no sphere-gas
    table, no collision map of a shape) leave ``path`` as it is and say so on stderr: None."""
    import jinja2

    try:
        text = render("findings.md.j2", **facts(**kwargs))
    except (jinja2.UndefinedError, KeyError, TypeError, IndexError) as e:
        print(f"[report] {os.path.relpath(path, S.ROOT)} not written: the results lack a number it states "
              f"({type(e).__name__}: {e})", file=sys.stderr)
        return None
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)
    return text
