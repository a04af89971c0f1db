"""A predictor for any clump: each case's effect from binary collisions, before a gas campaign.

    .venv/bin/python -m studies predict grains                 # every shape and case the spec's groups name
    .venv/bin/python -m studies predict grains --pairs 1000    # a quicker, noisier look
    .venv/bin/python -m studies predict hcs_clumps --factor ellipsoid20=2.0   # one shape on its own step

For every shape and (case, protocol) the spec's groups name, the relative effect of the case
against ``exact`` on the first Chapman-Enskog self-diffusion coefficient D of the elastic gas,
from paired YADE binary collisions (the collision-map method of ``studies.maps``, for any shape a
spec defines; an aspherical shape runs on YADE 2025.2 through scripts/debian13.sh), with its
standard error over the collisions and the CPU time of its YADE runs.  Beside each prediction
stands the gas interval where the committed gas runs have one (``results/effects.csv``).
Writes ``results/predictions.csv`` (columns ``COLUMNS``): the rows of the spec's shapes and contact
laws replace theirs, the other rows stay (:func:`studies.prediction_table.merged`); never writes
another file than ``--out``.

Inelastic and frictional contacts (spec keys ``restitution`` and ``friction`` under [material] or
in a group) make the homogeneous cooling state the gas's natural state: for them each case's effect
on the cooling rate, on T_rot / T_tr and on the HCS self-diffusion comes from the two-temperature
balance of YADE binary collisions (``studies.predict_cooling``), beside the cooling gas runs'
intervals (``results/hcs_effects.csv``).  Such predictions are of the paired protocol: the cases
share the translational velocities, each its spins at its own temperature.
"""
from __future__ import annotations

import argparse
import csv
import math
import os
import sys
import tempfile
import time

import numpy as np

from . import maps, predict_cooling
from . import shapes as shp
from .prediction_table import (COLUMNS, EFFECTS, HCS_EFFECTS, OUT, gas_intervals, hcs_intervals,  # noqa: F401
                               is_elastic, merged, refresh_gas, write_table)
from .timestep import collisions as tc

ROOT = tc.ROOT
CASES = ("uncorrected", "mass_only", "inertia_only")       # each predicted against exact


def contact_law(spec, group=None):
    """A group's contact law: (youngs_modulus Pa, restitution, friction); elastic and frictionless
    unless [material] or the group says otherwise.

    Parameters
    ----------
    spec : dict
        A validated study spec (``studies.spec.load``).
    group : dict, optional
        One of its groups (its overrides apply); None: the spec's [material].

    Returns
    -------
    tuple of float
        (youngs_modulus, restitution, friction).
    """
    from . import spec as S

    mat = S.group_tables(spec, group)[0] if group is not None else spec["material"]
    return float(mat["youngs_modulus"]), float(mat.get("restitution", 1.0)), float(mat.get("friction", 0.0))


def shape_cases(spec):
    """The (case, protocol) pairs of ``CASES`` the spec's groups name for each shape and contact law.

    Parameters
    ----------
    spec : dict
        A validated study spec.

    Returns
    -------
    dict
        (shape name, contact law) -> list of (case, protocol), in the groups' order.  A dissipative
        law's cases are all paired (``studies.predict_cooling``).
    """
    out = {}
    for g in spec["groups"]:
        law = contact_law(spec, g)
        todo = out.setdefault((g["shape"], law), [])
        for case in g["cases"]:
            prot = g["protocol"] if is_elastic(law) else "paired"
            if case in CASES and (case, prot) not in todo:
                todo.append((case, prot))
    return out


def step_factors(values, shapes, default=0.5):
    """Each shape's time step factor from ``--factor`` arguments.

    Parameters
    ----------
    values : list of str or None
        Each ``F`` (every shape not named otherwise) or ``SHAPE=F`` (that shape); a later argument
        overrides an earlier one.
    shapes : iterable of str
        The spec's shape names.
    default : float
        The factor where no argument sets one.

    Returns
    -------
    dict
        shape name -> factor on the smallest member's P-wave step.

    Raises
    ------
    ValueError
        A factor that is not a positive finite number, or a shape the spec does not define.
    """
    shapes = list(shapes)
    every, own = default, {}
    for v in values or ():
        name, sep, num = v.rpartition("=")
        try:
            f = float(num)
        except ValueError:
            f = float("nan")
        if not (math.isfinite(f) and f > 0):
            raise ValueError(f"--factor {v}: the factor must be a positive number")
        if not sep:
            every = f
        elif name in shapes:
            own[name] = f
        else:
            raise ValueError(f"--factor {v}: the spec has no shape {name!r} (it has {', '.join(shapes)})")
    return {name: own.get(name, every) for name in shapes}


def gas_key(name, shape):
    """How ``results/effects.csv`` names a shape: (shape, overlap) with overlap '' for a template."""
    if shape["kind"] == "file":
        return name, ""
    return shape["kind"], f"{float(shape['overlap']):g}"


def yade_for(shape, density, friction=0.0):
    """The YADE a shape's collisions run on: 2023.02a for a frictionless linear clump (isotropic
    route), 2025.2 (delValle2023) otherwise."""
    return "2023.02a" if shp.properties(shape, density)["linear"] and not friction else "2025.2"


def elastic_predictions(shape, cases, pairs, seed, factor, workdir, tag):
    """Each case's D_case/D_exact - 1 from ``pairs`` paired binary collisions (``studies.maps``).

    Parameters
    ----------
    shape : dict
        A shape of a spec (``kind`` and its parameters).
    cases : list of (str, str)
        (case, protocol) pairs to predict.
    pairs : int
        Collision courses drawn (``studies.maps.wide_pairs``).
    seed : int
        Seed of the draws.
    factor : float
        Time step factor on the smallest member's P-wave step.
    workdir : str
        Folder of the YADE runs' files (a repeated call reuses identical runs).
    tag : str
        Prefix of the run files.

    Returns
    -------
    list of dict
        Per case: case, protocol, predicted, predicted_se, cpu_s (the case's YADE run plus an
        equal share of the exact run's), pairs_used.
    """
    yade = yade_for(shape, tc.MATERIAL["density"])
    base = maps.wide_pairs(shape, pairs, seed)
    runs = {("exact", "paired"): (base, 1.0)}
    for case, prot in cases:
        runs[(case, prot)] = maps.case_input(base, shape, case, prot)
    res, cpu = {}, {}
    for i, ((case, prot), (inp, _)) in enumerate(runs.items()):
        out = tc.run_map(inp, factor, yade, workdir, f"{tag}-{case}-{prot}")
        cpu[(case, prot)] = float(out.get("cpu_s", 0.0))
        res[(case, prot)] = tc.outcome(inp, out)
        print(f"[predict] {tag} {case} {prot} ({i + 1}/{len(runs)}): {int(res[(case, prot)]['touched'].sum())} of "
              f"{pairs} collided, cpu {cpu[(case, prot)]:.0f} s{' (reused)' if out.get('reused') else ''}", flush=True)
    ok = np.logical_and.reduce([r["apart"] for r in res.values()])
    x = np.asarray(base["g"]) ** 2 * (base["body"]["mass"] / 2) / (2 * base["kT"])    # gamma^2 = mu g^2 / 2kT
    q_e = res[("exact", "paired")]["q"]
    rows = []
    for case, prot in cases:
        rel, se = maps.ratio(x[ok], q_e[ok], res[(case, prot)]["q"][ok], runs[(case, prot)][1])
        rows.append({"case": case, "protocol": prot, "predicted": rel, "predicted_se": se,
                     "cpu_s": cpu[(case, prot)] + cpu[("exact", "paired")] / len(cases),
                     "pairs_used": int(ok.sum())})
    return rows


def prediction_rows(name, shape, law, rows, gas, hcs_gas=None):
    """The CSV rows of one shape's predictions, each with its gas interval where one exists
    (``gas``: :func:`gas_intervals`, elastic; ``hcs_gas``: :func:`hcs_intervals`, cooling)."""
    youngs, e, mu = law
    out = []
    for r in rows:
        obs = r.get("observable", "diffusion")
        if is_elastic(law):
            g = gas.get(gas_key(name, shape) + (r["protocol"], youngs, r["case"]))
        else:
            g = (hcs_gas or {}).get((name, youngs, e, mu, r["case"], obs))
        case = f"{r['case']}/{r['protocol']}"        # the table's one column for case and protocol
        out.append({"shape": name, "youngs_modulus": f"{youngs:g}", "restitution": f"{e:g}", "friction": f"{mu:g}",
                    "case": case, "observable": obs, "predicted": f"{r['predicted']:.6g}",
                    "predicted_se": f"{r['predicted_se']:.3g}", "cpu_s": f"{r['cpu_s']:.1f}",
                    "gas_relative": "" if g is None else f"{g[0]:.6g}",
                    "gas_ci_low": "" if g is None else f"{g[1]:.6g}",
                    "gas_ci_high": "" if g is None else f"{g[2]:.6g}"})
    return out


def _parser():
    ap = argparse.ArgumentParser(prog="python -m studies predict", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("spec", help="study spec file or name (studies/specs/NAME.toml)")
    ap.add_argument("--pairs", type=int, default=4000, help="collision courses per shape (default 4000)")
    ap.add_argument("--seed", type=int, default=17)
    ap.add_argument("--factor", action="append", metavar="[SHAPE=]F",
                    help="dt factor on the smallest member's P-wave step (default 0.5); SHAPE=F sets one shape's, "
                         "and the option repeats")
    ap.add_argument("--workdir", default=None, help="keep the YADE runs here (reused by a repeated call)")
    ap.add_argument("--gas", default=EFFECTS, help="the gas effects table (default results/effects.csv)")
    ap.add_argument("--hcs-gas", default=HCS_EFFECTS,
                    help="the cooling gas effects table (default results/hcs_effects.csv)")
    ap.add_argument("--out", default=OUT, help="the predictions table (default results/predictions.csv)")
    return ap


def _load(name):
    from . import spec as S
    return S.load(S.spec_path(name))


def _set_material(spec, law):
    """The collision runs' material (``studies.timestep.collisions.MATERIAL``): the spec's density and
    Poisson ratio, the contact law ``law`` (:func:`contact_law`)."""
    for k in ("density", "poisson"):
        tc.MATERIAL[k] = float(spec["material"][k])
    tc.MATERIAL["youngs_modulus"] = law[0]
    for k in ("restitution", "friction"):
        tc.MATERIAL.pop(k, None)
    if not is_elastic(law):
        tc.MATERIAL.update(restitution=law[1], friction=law[2])


def main(argv=None):
    """``python -m studies predict SPEC [options]``: writes ``--out``; 0 on success, 2 on bad input.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit status.
    """
    from . import spec as S

    a = _parser().parse_args(list(sys.argv[1:] if argv is None else argv))
    try:
        spec = _load(a.spec)
    except S.SpecError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    if a.pairs < 10:
        print(f"error: --pairs {a.pairs}: at least 10 collision courses are needed for a standard error", file=sys.stderr)
        return 2
    try:
        a.factor = step_factors(a.factor, spec["shapes"])
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    saved = dict(tc.MATERIAL)
    try:
        return _predict(a, spec)
    except predict_cooling.NoBalance as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    finally:
        tc.MATERIAL.clear()
        tc.MATERIAL.update(saved)


def _predict(a, spec):
    work = a.workdir or tempfile.mkdtemp(prefix="predict-")
    os.makedirs(work, exist_ok=True)
    gas, hcs_gas = gas_intervals(a.gas), hcs_intervals(a.hcs_gas)
    table, t0 = [], time.time()
    for (name, law), cases in shape_cases(spec).items():
        if not cases:
            continue
        _set_material(spec, law)
        shape = spec["shapes"][name]
        tag, factor = f"{name}-E{law[0]:g}-n{a.pairs}-s{a.seed}", a.factor[name]
        if is_elastic(law):
            rows = elastic_predictions(shape, cases, a.pairs, a.seed, factor, work, tag)
        else:
            tag += f"-e{law[1]:g}-mu{law[2]:g}"
            rows = predict_cooling.cooling_predictions(shape, [c for c, _ in cases], a.pairs, a.seed, factor, work,
                                                       tag, yade_for(shape, tc.MATERIAL["density"], law[2]))
        cpu = sum(r["cpu_s"] for r in rows)
        for r in rows:
            print(f"[predict] {name} {r['case']} {r['protocol']}: {r.get('observable', 'diffusion')} case/exact - 1 = "
                  f"{100 * r['predicted']:+.2f} % ± {100 * r['predicted_se']:.2f} % (se, {r['pairs_used']} collisions)"
                  + (f"; T_rot/T_tr {r['ratio_exact']:.4f} (exact), {r['ratio_case']:.4f} (case), root check "
                     f"at r* {100 * r['root_check']:.2f} %" if "ratio_exact" in r else ""))
        print(f"[predict] {name}: CPU {cpu / 60:.1f} min (dt factor {factor:g})", flush=True)
        table += prediction_rows(name, shape, law, rows, gas, hcs_gas)
    write_table(merged(table, a.out, gas, hcs_gas), a.out)
    print(f"[predict] wrote {os.path.relpath(a.out, ROOT)}; wall {(time.time() - t0) / 60:.1f} min")
    return 0


if __name__ == "__main__":
    sys.exit(main())
