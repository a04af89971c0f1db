"""``results/effects.csv``: the correction's effect on D for every shape, protocol and stiffness.

Reads the manifests and run records of the given specs (no live simulation) and writes one row
per shape x overlap x protocol x Young's modulus x case against ``exact``:

    shape, overlap, protocol, youngs_modulus, case, n_pairs, relative, relative_ci_low,
    relative_ci_high, mass_error, k2_error, yade_version, rot_algorithm

``relative`` is the mean over seeds of D_case / D_exact - 1, paired by seed (the two runs of a
pair share their initial state and every parameter but the case), with a 95 % Student-t
interval over the seeds (the independent units).  D of a run: :func:`studies.design.run_d`.
Pairs made at different time-step factors (a study that raised ``run.dt_factor`` and kept its
earlier seeds, ``run.legacy_dt``) are pooled into one row, one pair per seed (the smaller factor
where a seed has both): each pair is made at one dt, and a case's D moves by about 3e-4 between
factors 0.5 and 1.0 (docs/timestep.md, the dimer), so a paired ratio by at most 6e-4, against
half-widths of >= 5e-3.  A group's own ``dt_factor`` is never pooled; two rows that differ only in
parameters effects.csv does not show are an error (:func:`paired_values`), never a silent mix.
``mass_error`` = m_case / m_exact - 1 and ``k2_error`` the relative error of the case's squared
radius of gyration k^2 = I/m against exact's, I the mean moment over the axes a frictionless
contact can turn (I_perp for a linear clump, tr(I)/3 otherwise; :func:`studies.shapes.k2_error`):
for ``uncorrected`` the summed clump's errors, for ``mass_only`` (0, +4.5 %) and for
``inertia_only`` (+18.5 %, -15.6 %) on the paper's dimer; empty for ``spheres`` (not a clump).
"""
from __future__ import annotations

import csv
import math
import os
from typing import NamedTuple

from . import design
from .gas_model import CASE_SOURCES
from . import shapes as shp
from . import spec as S

# the gas a row was measured in: two rows compare like with like only where these agree
GAS_COLUMNS = ("n_particles", "volume_fraction", "t_end", "energy_per_particle", "poisson", "density", "n_spheres")
COLUMNS = ("shape", "overlap", "protocol", "youngs_modulus", "case", "n_pairs", "relative", "relative_ci_low",
           "relative_ci_high", "mass_error", "k2_error", "yade_version", "rot_algorithm") + GAS_COLUMNS


def gas_of(p):
    """effects.csv's :data:`GAS_COLUMNS` of a run's parameters."""
    return {"n_particles": int(p["gas"]["n_particles"]), "volume_fraction": float(p["gas"]["volume_fraction"]),
            "t_end": float(p["run"]["t_end"]), "energy_per_particle": float(p["gas"]["energy_per_particle"]),
            "poisson": float(p["material"]["poisson"]), "density": float(p["material"]["density"]),
            "n_spheres": len(p["shape"]["radii"])}


def _pair_key(params):
    """Everything of a run's parameters but case, protocol, seed, sphere options and spin pairing:
    runs with the same pair key and seed are a paired comparison."""
    return S.run_key(_pair_facts(params))


def state_key(params):
    """What sets a run's initial state (studies.gas_model.initial_state via studies.spec.run_input),
    but the seed: the clump's members and radii, the density, the gas (without the spin pairing,
    which leaves the exact case's state alone) and the model version.  Not the YADE or clumpprops
    version, the stiffness, the run options (time step, length), the case or the protocol.  Two
    exact runs of one seed and one state key start from the same state, so their D are correlated
    even when nothing else is shared."""
    return S.run_key({"model_version": params.get("model_version"),
                      "shape": {k: params["shape"][k] for k in ("members", "radii")},
                      "density": float(params["material"]["density"]),
                      "gas": {k: v for k, v in params["gas"].items() if k != "spin_pairing"}})


def protocol_label(params):
    """The protocol column: the run's protocol, with "_same_spin" for runs started with every case
    at the exact case's angular velocities (``gas.spin_pairing = "same"``), whose thermal speeds
    drift from exact's (studies.gas_model.initial_state)."""
    return params["protocol"] + ("_same_spin" if S.spin_pairing_of(params) == "same" else "")


class Collected(NamedTuple):
    """What :func:`collect` read: ``by`` {pair key: {seed: {(case, protocol): (D, record)}}}, ``facts``
    {pair key: the run parameters}, ``pooled``, the (pair key, seed) made at their spec's own time
    step (``run.dt_factor``, or ``run.legacy_dt``'s for a seed below its ``below_seed``): only those
    pool across time-step factors into one effects row, a group's own ``dt_factor`` (a convergence
    check) stays apart; and ``studies`` {pair key: names of the specs whose records it came from}."""
    by: dict
    facts: dict
    pooled: set
    studies: dict


def _at_own_dt(spec, params):
    """Is the run made at its spec's own time step: ``run.dt_factor``, or the legacy factor for a
    seed below ``run.legacy_dt.below_seed``?  (A group can set ``dt_factor`` equal to either.)"""
    dtf, leg = float(params["run"]["dt_factor"]), spec["run"].get("legacy_dt")
    return dtf == float(spec["run"]["dt_factor"]) or bool(
        leg and params["seed"] < leg["below_seed"] and dtf == float(leg["dt_factor"]))


def collect(specs, records=None):
    """:class:`Collected` of the specs' finished, passing records (D by Green-Kubo).
    ``records``: :func:`design.load_records` of each spec, in the order of ``specs``, if already read."""
    if records is not None and len(records) != len(specs):
        raise ValueError(f"collect: {len(records)} record sets for {len(specs)} specs")
    by, facts, pooled, studies = {}, {}, set(), {}
    for i, sp in enumerate(specs):
        rdir = S.results_dir(sp)
        if records is not None:
            recs = records[i]
        elif os.path.isdir(rdir):
            recs = design.load_records(sp, rdir)
        else:
            continue
        for key, rec in recs.items():
            if not rec["checks"]["ok"]:
                continue
            p = rec["params"]
            d = design.run_d(rec, sp["analysis"]["t_eq"], stderr=False)["D"]
            pk = _pair_key(p)
            by.setdefault(pk, {}).setdefault(p["seed"], {})[(p["case"], protocol_label(p))] = (d, rec)
            facts[pk] = p
            studies.setdefault(pk, set()).add(sp["study"]["name"])
            if _at_own_dt(sp, p):
                pooled.add((pk, p["seed"]))
    return Collected(by, facts, pooled, studies)


class Paired(NamedTuple):
    """One effects row's paired sample: per-seed D_case/D_exact - 1 in seed order, the seeds, the
    initial states (:func:`state_key`, seed) of the exact runs used, in seed order (two samples
    that share none are independent), and the YADE versions and rotation algorithms of its runs."""
    facts: dict
    case: str
    protocol: str
    values: list
    yade_versions: set
    rot_algorithms: set
    seeds: list
    exact_states: list


def _row_key(params):
    """:func:`_pair_key` without the time-step factor: the pairs of one effects row."""
    p = dict(params, run={k: v for k, v in params["run"].items() if k != "dt_factor"})
    return _pair_key(p)


def _visible(p, case, protocol):
    """What names an effects row in effects.csv: shape, overlap, protocol, Young's modulus, case and
    the gas (:data:`GAS_COLUMNS`)."""
    shape = p["shape"]["definition"]
    return (shape_name(shape), shape.get("overlap", ""), protocol, p["material"]["youngs_modulus"], case,
            *gas_of(p).values())


def _differences(a, b, where=""):
    """The dotted paths at which two parameter dicts differ."""
    out = []
    for k in sorted(set(a) | set(b), key=str):
        x, y = a.get(k), b.get(k)
        if isinstance(x, dict) and isinstance(y, dict):
            out += _differences(x, y, f"{where}{k}.")
        elif x != y:
            out.append(f"{where}{k} ({x!r} / {y!r})")
    return out


def _pair_facts(params):
    """The run parameters a pair key is made of (:func:`_pair_key`'s), as a dict."""
    p = {k: v for k, v in params.items() if k not in ("case", "spheres", "protocol", "seed")}
    p["gas"] = {k: v for k, v in p["gas"].items() if k != "spin_pairing"}
    return p


def paired_values(specs, collected=None):
    """[:class:`Paired`] for every row: the seeds where both the case and exact ran at one time
    step, pooled over their specs' own time-step factors (one pair per seed, the smaller factor
    first).  ``collected``: :func:`collect` of ``specs``, if already read.

    Raises ValueError when two rows would carry the same shape, overlap, protocol, Young's modulus
    and case in effects.csv but differ in other run parameters (a run length, a start, a group's own
    time step), naming the studies and the parameters: effects.csv has one row per such
    combination, never two that a reader cannot tell apart."""
    by, facts, pooled, studies = collect(specs) if collected is None else collected
    rows = {}       # (row key, case, protocol) -> {seed: (dt_factor, value, exact record, case record, facts)}
    row_pks = {}    # (row key, case, protocol) -> the pair keys of its pairs
    for pk in sorted(by, key=lambda k: facts[k]["run"]["dt_factor"]):
        seeds, dtf = by[pk], facts[pk]["run"]["dt_factor"]
        for seed, cases in seeds.items():
            ex = cases.get(("exact", "paired"))
            if ex is None:
                continue
            rk = _row_key(facts[pk]) if (pk, seed) in pooled else pk
            for (case, protocol), cc in cases.items():
                if case == "exact":
                    continue
                slot = rows.setdefault((rk, case, protocol), {})
                if seed not in slot:
                    slot[seed] = (dtf, cc[0] / ex[0] - 1.0, ex[1], cc[1], facts[pk])
                    row_pks.setdefault((rk, case, protocol), set()).add(pk)
    out, seen = [], {}
    for rk in dict.fromkeys(k[0] for k in rows):            # first-seen order of the rows
        for (_, case, protocol) in sorted(k for k in rows if k[0] == rk):
            slot = rows[(rk, case, protocol)]
            used = sorted(slot)
            recs = [r for s in used for r in slot[s][2:4]]
            row = Paired(slot[used[0]][4], case, protocol, [slot[s][1] for s in used],
                         {r["yade_version"] for r in recs}, {r["rot_algorithm"] for r in recs}, used,
                         [(state_key(slot[s][2]["params"]), s) for s in used])
            v = _visible(row.facts, case, protocol)
            names = sorted(set().union(*(studies[pk] for pk in row_pks[(rk, case, protocol)])))
            if v in seen:
                first, first_names = seen[v]
                diff = "; ".join(_differences(_pair_facts(first.facts), _pair_facts(row.facts)))
                src = (f"both from {', '.join(names)}" if names == first_names else
                       f"from {', '.join(first_names)} and from {', '.join(names)}")
                raise ValueError(
                    f"effects: two rows of {case} vs exact, {protocol}, {v[0]} (overlap {v[1]}), E = {v[3]:g} Pa, "
                    f"which effects.csv cannot tell apart, {src}, differing in "
                    f"{diff or 'the seeds made at a time step not their own'}.  "
                    "Set `in_results = false` in the [study] table of the spec whose runs are not part of the "
                    "results; a group that overrides one of these answers another question: give it a spec of "
                    "its own with `in_results = false`")
            seen[v] = (row, names)
            out.append(row)
    return out


def case_errors(shape, density, case):
    """effects.csv's ``mass_error`` and ``k2_error`` of one case's body against the exact clump:
    the summed values for ``uncorrected``, (0, the summed I over the exact m) for ``mass_only``,
    (the summed m, the exact I over it) for ``inertia_only`` (:data:`studies.gas_model.CASE_SOURCES`).
    None for a case that is not a clump (``spheres``: another shape, no rotation at all)."""
    src = CASE_SOURCES.get(case)
    if src is None:
        return {"mass_error": None, "k2_error": None}
    return {"mass_error": shp.mass_error(shape, density, src[0]),
            "k2_error": shp.k2_error(shape, density, *src)}


def shape_name(shape):
    return shape["kind"] if shape["kind"] != "file" else os.path.splitext(os.path.basename(shape["path"]))[0]


def effect_rows(specs, values=None):
    """effects.csv's rows; ``values``: :func:`paired_values` of ``specs``, if already read."""
    from .intervals import t_interval

    rows = []
    for p, case, protocol, vals, yv, ra, *_ in (paired_values(specs) if values is None else values):
        shape = p["shape"]["definition"]
        m, lo, hi, se, n = t_interval(vals)
        rho = p["material"]["density"]
        rows.append({"shape": shape_name(shape), "overlap": shape.get("overlap", ""), "protocol": protocol,
                     "youngs_modulus": p["material"]["youngs_modulus"], "case": case, "n_pairs": n,
                     "relative": m, "relative_ci_low": lo, "relative_ci_high": hi,
                     **case_errors(shape, rho, case),
                     "yade_version": ";".join(sorted(yv)), "rot_algorithm": ";".join(sorted(ra)), **gas_of(p)})
    rows.sort(key=lambda r: (r["shape"], str(r["overlap"]), r["protocol"], r["youngs_modulus"], r["case"]))
    return rows


def write(specs, path, values=None):
    rows = effect_rows(specs, values)
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS, lineterminator="\n")
        w.writeheader()
        for r in rows:
            # one pair has no interval: its bounds are empty cells, never "nan"
            w.writerow({k: ((f"{v:.10g}" if math.isfinite(v) else "") if isinstance(v, float) else v)
                        for k, v in r.items()})
    os.replace(tmp, path)
    return rows


# The studies of the project's programme, whose run records the headline (results/effects.csv,
# results/README.md) reads, by spec file name.  Listed, never discovered: a new spec (a user's own
# study, or one of the project's before it is added here) cannot change the headline.
HEADLINE = ("dimer_equal_energy", "dimer_paired", "dimer_paired_same_spin", "grains", "shapes", "sphere_gas",
            "stiffness")


def results_specs(spec_dir=None, names=HEADLINE):
    """The specs of :data:`HEADLINE` under ``spec_dir`` (default studies/specs/), loaded; each must
    exist and have ``study.in_results`` true (the test and quick scales, whose runs are not committed,
    and the first version's paper scale, whose tables results/granular_gas/*.csv are read as such,
    have it false)."""
    spec_dir = spec_dir or S.SPEC_DIR
    out = []
    for name in names:
        sp = S.load(os.path.join(spec_dir, name + ".toml"))
        if not sp["study"]["in_results"]:
            raise ValueError(f"{name}: listed in studies.effects.HEADLINE but has in_results = false")
        out.append(sp)
    return out


if __name__ == "__main__":       # python -m studies.effects: results/effects.csv from every spec in the results
    import argparse
    argparse.ArgumentParser(prog="python -m studies.effects",
                            description="Write results/effects.csv (one row per shape, overlap, protocol, "
                                        "stiffness and case against exact) from the committed run records of "
                                        "every spec in the results.").parse_args()
    rows = write(results_specs(), os.path.join(S.ROOT, "results", "effects.csv"))
    print(f"[effects] {len(rows)} rows in results/effects.csv")
    for r in rows:
        print(f"  {r['shape']} {r['overlap']} {r['protocol']} E={r['youngs_modulus']:g} {r['case']}: "
              f"{100 * r['relative']:+.2f} % [{100 * r['relative_ci_low']:+.2f}, {100 * r['relative_ci_high']:+.2f}] "
              f"(n={r['n_pairs']})")
