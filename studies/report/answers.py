"""The facts behind the report's sentences: for each answer, the numbers it states and the
decisions it reports (inside or outside an interval, resolved or not), with no words.  The words
are the templates' (``studies/templates/report/answers.md.j2`` and ``plain_words.md.j2``)."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from .. import design, effects_plots
from .. import shapes as shp
from . import tables


def question(sp, g, st, cpu):
    """The facts of one sequential question: its status ``st`` (:func:`studies.design.plan`), the
    spec's CPU-hours ``cpu`` and budget, and its interval's ends."""
    hw = st["halfwidth"]
    return dict(label=design.shape_label(g), case=st["case"], protocol=g["protocol"], study=sp["study"]["name"],
                n=st["n"], mean=st["mean"], halfwidth=hw, lo=st["mean"] - hw, hi=st["mean"] + hw,
                has_interval=not (st["n"] < 2 or hw != hw), target=st["target"], state=st.get("state"),
                met=st.get("met"), min_n=st.get("min_n", 0), n_needed=st.get("n_needed"),
                cpu_hours_to_target=st.get("cpu_hours_to_target"), prior=st.get("prior"), cpu=cpu,
                budget=sp["study"].get("budget_cpu_hours"))


def mass_scaling(sp, g, st):
    """For uncorrected vs exact in the equal-energy protocol: the summed mass's error ``x``, the
    hard-particle prediction ``pred`` (every mass scaled by 1 + x at equal energy leaves collisions
    unchanged and slows the gas by sqrt(1 + x)) and whether the interval holds it (``inside``, None
    without an interval); None for other cases and protocols."""
    if g.get("protocol") != "equal_energy" or st["case"] != "uncorrected":
        return None
    x = shp.mass_error(sp["shapes"][g["shape"]], sp["material"]["density"])
    pred = 1.0 / math.sqrt(1.0 + x) - 1.0
    hw = st["halfwidth"]
    inside = None if st["n"] < 2 or hw != hw else st["mean"] - hw <= pred <= st["mean"] + hw
    return dict(x=x, pred=pred, inside=inside)


def map_check(sp, g, st, maps):
    """A group's gas against the collision map of its case and protocol: the map's prediction and
    ``reading``, "inside" (the interval holds it), "overlap" (outside, the two intervals meet),
    "apart" or None (no interval); None without such a map.  The map is the first Chapman-Enskog
    approximation from YADE collisions with the gas's contacts (softness included), so it checks
    the gas where a hard-particle prediction cannot."""
    m, protocol = tables.map_of_group(maps, sp, g, st["case"])
    r = None if m is None else tables.map_rows(m).get((st["case"], protocol))
    if r is None:
        return None
    hw = st["halfwidth"]
    reading = None
    if not (st["n"] < 2 or hw != hw):
        lo, hi = st["mean"] - hw, st["mean"] + hw
        p_lo, p_hi = r["relative"] - 1.96 * r["se"], r["relative"] + 1.96 * r["se"]
        reading = ("inside" if lo <= r["relative"] <= hi else "overlap" if p_lo <= hi and lo <= p_hi else "apart")
    return dict(file=m["file"], relative=r["relative"], se=r["se"], reading=reading)


def collision_map_facts(maps):
    """The collision maps' bullets: ``paper`` (each map of the paper's dimer with its paired split
    into softness and k², and its equal-energy row), ``limit`` (the paper's dimer's mass_scaled
    rows by E, when there are two or more) and ``others`` (the other shapes' maps with both
    protocols)."""
    paper = [m for m in maps if effects_plots.is_paper_dimer(m)]
    out = {"paper": [], "limit": [], "others": []}
    for m in paper:
        rows = tables.map_rows(m)
        u, sc = rows.get(("uncorrected", "paired")), rows.get(("mass_scaled", "paired"))
        if u and sc and u.get("minus_mass_scaled") is not None:
            ee = rows.get(("uncorrected", "equal_energy"))
            out["paper"].append(dict(m=m, u=u, sc=sc, ee=ee,
                                     factorised=None if ee is None else tables.hard_times_k2(ee, u["minus_mass_scaled"])))
    soft = sorted(((m["material"]["youngs_modulus"], r) for m in paper for r in m["rows"]
                   if r["case"] == "mass_scaled" and r["protocol"] == "paired"), key=lambda t: t[0])
    if len(soft) > 1:
        out["limit"] = soft
    for m in maps:
        rows = tables.map_rows(m)
        u, ee = rows.get(("uncorrected", "paired")), rows.get(("uncorrected", "equal_energy"))
        if m in paper or not (u and ee):
            continue
        k2 = u.get("minus_mass_scaled")
        out["others"].append(dict(m=m, u=u, ee=ee, soft=rows.get(("mass_scaled", "paired")),
                                  factorised=None if k2 is None else tables.hard_times_k2(ee, k2)))
    return out


def sphere_gas_facts(sph, effect_rows):
    """Each sphere-gas row with its verdict against the Hertz theory (``consistent``: None from one
    run) and, where the paper's dimer has an uncorrected row at its stiffness and the row a
    stiffness slope, the D shift the summed mass alone makes through the contact's softness."""
    out = []
    for r in sph:
        lo, hi = r["ratio_hertz_ci_low"] - 1, r["ratio_hertz_ci_high"] - 1
        consistent = None if (pd.isna(lo) or pd.isna(hi)) else bool(lo <= 0 <= hi)
        dimer = [e for e in effect_rows if e["shape"] == "dimer" and e["case"] == "uncorrected"
                 and str(e["overlap"]) == "0.5" and float(e["youngs_modulus"]) == r["youngs_modulus"]]
        soft = None
        if dimer and r["dlnD_dlnE"] == r["dlnD_dlnE"]:
            x = float(dimer[0]["mass_error"])
            soft = dict(x=x, shift=-r["dlnD_dlnE"] * math.log1p(x))
        out.append(dict(r=r, lo=lo, hi=hi, consistent=consistent, soft=soft))
    return out


def _other_shapes(effect_rows, youngs_modulus=1e7):
    """The shapes other than the paper's dimer (uncorrected vs exact at ``youngs_modulus``, two or
    more pairs): at the same velocities the rows and the largest 95 % bound (``top``); at the same
    energy each row beside the hard-particle mass scaling (1 + mass error)^(-1/2) - 1; None
    without such rows."""
    rows = [e for e in effect_rows if e["case"] == "uncorrected" and float(e["youngs_modulus"]) == youngs_modulus
            and e["n_pairs"] >= 2 and not (e["shape"] == "dimer" and str(e["overlap"]) == "0.5")]
    paired = sorted((e for e in rows if e["protocol"] == "paired"), key=lambda e: e["mass_error"])
    equal = sorted((e for e in rows if e["protocol"] == "equal_energy"), key=lambda e: e["mass_error"])
    if not paired and not equal:
        return None
    top = max((max(abs(e["relative_ci_low"]), abs(e["relative_ci_high"])) for e in paired), default=None)
    hard = [(1.0 + e["mass_error"]) ** -0.5 - 1.0 for e in equal]
    equal = [dict(e=e, hard=h, inside=e["relative_ci_low"] <= h <= e["relative_ci_high"],
                  share=100 * e["relative"] / h) for e, h in zip(equal, hard)]
    return dict(paired=paired, top=top, paired_pairs=sorted({int(e["n_pairs"]) for e in paired}), equal=equal,
                equal_pairs=sorted({int(r["e"]["n_pairs"]) for r in equal}), n_inside=sum(r["inside"] for r in equal))


def _stiffness(effect_rows, maps):
    """The hard-particle-limit question: the paper's dimer, mass corrected alone (mass_only) vs
    exact at the same velocities, at every stiffness but 1e7 Pa with two or more pairs, each beside
    its collision map's prediction (``rows``: (row, map row or None)), and the maps' mass_scaled
    part (summed mass, exact k²: the softness, which a hard particle cannot feel) by E; None
    without such rows."""
    stiffer = sorted({float(e["youngs_modulus"]) for e in effect_rows} - {1e7})
    rows = [r for r in (tables.effect_row(effect_rows, "paired", case="mass_only", youngs_modulus=E) for E in stiffer) if r]
    if not rows:
        return None
    paper = tables.paper_maps(maps)
    return dict(rows=[(e, paper.get(float(e["youngs_modulus"]), {}).get(("mass_only", "paired"))) for e in rows],
                soft=[(E, r[("mass_scaled", "paired")]) for E, r in sorted(paper.items()) if ("mass_scaled", "paired") in r])


def _equal_energy_gaps(maps):
    """(number of maps, largest gap) between each map's equal-energy ratio and the hard-particle
    scaling times one plus its paired k² part, over every map with both; None without one."""
    gaps = []
    for m in maps:
        rows = tables.map_rows(m)
        u, ee = rows.get(("uncorrected", "paired")), rows.get(("uncorrected", "equal_energy"))
        if u and ee and u.get("minus_mass_scaled") is not None:
            gaps.append(abs(ee["relative"] - tables.hard_times_k2(ee, u["minus_mass_scaled"])))
    return (len(gaps), max(gaps)) if gaps else None


def _through(paper, maps):
    """Through which part the paper's dimer's paired effect acts (softness or k²), over every map; None
    without the 1e7 Pa map's paired rows."""
    m7 = paper.get(1e7, {})
    mp, ms = m7.get(("uncorrected", "paired")), m7.get(("mass_scaled", "paired"))
    if not (mp and ms and mp.get("minus_mass_scaled") is not None):
        return None
    soft = sorted((e, r[("mass_scaled", "paired")]) for e, r in paper.items() if ("mass_scaled", "paired") in r)
    k2s = [(m["shape"]["kind"], m["shape"].get("overlap"), m["material"]["youngs_modulus"], u)
           for m in maps for u in [tables.map_rows(m).get(("uncorrected", "paired"))]
           if u is not None and u.get("minus_mass_scaled") is not None]
    return dict(mp=mp, ms=ms, others=[(e, r) for e, r in soft if e != 1e7],
                falls=len(soft) > 1 and all(abs(b[1]["relative"]) < abs(a[1]["relative"]) for a, b in zip(soft, soft[1:])),
                n_maps=len(k2s), big=max(k2s, key=lambda t: abs(t[3]["minus_mass_scaled"])),
                top=max(abs(r["minus_mass_scaled"]) + 1.96 * r["minus_mass_scaled_se"] for *_, r in k2s),
                gaps=_equal_energy_gaps(maps))


def plain_words_facts(effect_rows, maps, share, cooling=None):
    """The facts of the answers the issues ask for, from effects.csv's rows, the collision maps,
    the paper's share and the cooling gases' answer (``tables.cooling_answer``; each only where its
    numbers exist; ``said``: any of them)."""
    paper = tables.paper_maps(maps)
    m7 = paper.get(1e7, {})
    gp, ge = tables.effect_row(effect_rows, "paired"), tables.effect_row(effect_rows, "equal_energy")
    mp, me = m7.get(("uncorrected", "paired")), m7.get(("uncorrected", "equal_energy"))
    matter = None
    if gp or mp or ge or me:
        matter = dict(gp=gp, mp=mp, ge=ge, me=me,
                      gp_top=(max(abs(gp["relative_ci_low"]), abs(gp["relative_ci_high"]))
                              if gp and np.isfinite(gp["relative_ci_low"]) else None),
                      ge_resolved=bool(ge) and not ge["relative_ci_low"] <= 0 <= ge["relative_ci_high"],
                      me_mass=bool(me) and abs(me["relative"] - me["hard_particles"]) < 0.25 * abs(me["hard_particles"]))
    gas = [(case, e) for case, e in ((c, tables.effect_row(effect_rows, "paired", case=c))
                                     for c in ("mass_only", "inertia_only")) if e]
    f = dict(matter=matter, through=_through(paper, maps), gas=gas, other_shapes=_other_shapes(effect_rows),
             stiffness=_stiffness(effect_rows, maps),
             share=share if share is not None and np.isfinite(share["low"]) else None,
             cooling=cooling if cooling and cooling["n"] else None)
    f["said"] = any(v for v in f.values())
    return f
