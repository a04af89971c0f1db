"""A predictor for any clump: each case's effect from binary collisions, before a gas campaign.

    .venv/bin/python -m studies predict grains                 # every shape and case the spec's groups name
    .venv/bin/python -m studies predict grains --pairs 1000    # a quicker, noisier look

For every shape and (case, protocol) the spec's groups name, the relative effect of the case
against ``exact`` on the first Chapman-Enskog self-diffusion coefficient D of the elastic gas,
from paired YADE binary collisions (the collision-map method of ``studies.maps``, for any shape a
spec defines; an aspherical shape runs on YADE 2025.2 through scripts/debian13.sh), with its
standard error over the collisions and the CPU time of its YADE runs.  Beside each prediction
stands the gas interval where the committed gas runs have one (``results/effects.csv``).
Writes ``results/predictions.csv`` (columns ``COLUMNS``); never overwrites another file than
``--out``.

Inelastic and frictional contacts (spec keys ``restitution`` and ``friction`` under
[material], defaults 1.0 and 0.0) make the homogeneous cooling state the gas's natural state;
its observables follow from binary collisions by the two-temperature balance of
``studies.predict_hcs`` (validated on spheres against ``studies.hcs_theory``).  The clumps' YADE
route for those contacts is not built yet: a spec with them stops with a one-line error.
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

from . import maps
from . import shapes as shp
from .timestep import collisions as tc

ROOT = tc.ROOT
OUT = os.path.join(ROOT, "results", "predictions.csv")
EFFECTS = os.path.join(ROOT, "results", "effects.csv")
CASES = ("uncorrected", "mass_only", "inertia_only")       # each predicted against exact
COLUMNS = ["shape", "youngs_modulus", "restitution", "friction", "case", "observable", "predicted",
           "predicted_se", "cpu_s", "gas_relative", "gas_ci_low", "gas_ci_high"]


def contact_law(spec):
    """The spec's contact law: (youngs_modulus Pa, restitution, friction); elastic and frictionless
    unless [material] says otherwise.

    Parameters
    ----------
    spec : dict
        A validated study spec (``studies.spec.load``).

    Returns
    -------
    tuple of float
        (youngs_modulus, restitution, friction).
    """
    mat = spec["material"]
    return float(mat["youngs_modulus"]), float(mat.get("restitution", 1.0)), float(mat.get("friction", 0.0))


def shape_cases(spec):
    """The (case, protocol) pairs of ``CASES`` the spec's groups name for each shape.

    Parameters
    ----------
    spec : dict
        A validated study spec.

    Returns
    -------
    dict
        shape name -> list of (case, protocol), in the groups' order.
    """
    out = {}
    for g in spec["groups"]:
        todo = out.setdefault(g["shape"], [])
        for case in g["cases"]:
            if case in CASES and (case, g["protocol"]) not in todo:
                todo.append((case, g["protocol"]))
    return out


def gas_key(name, shape):
    """How ``results/effects.csv`` names a shape: (shape, overlap) with overlap '' for a template."""
    if shape["kind"] == "file":
        return name, ""
    return shape["kind"], f"{float(shape['overlap']):g}"


def gas_intervals(path=EFFECTS):
    """The committed gas effects: (shape, overlap, protocol, youngs_modulus, case) -> (relative,
    ci_low, ci_high); empty when ``path`` does not exist.

    Parameters
    ----------
    path : str
        A table with the columns of ``results/effects.csv``.

    Returns
    -------
    dict
    """
    if not os.path.exists(path):
        return {}
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    out = {}
    for r in rows:
        ov = f"{float(r['overlap']):g}" if r["overlap"] else ""
        key = (r["shape"], ov, r["protocol"], float(r["youngs_modulus"]), r["case"])
        out[key] = tuple(float(r[k]) for k in ("relative", "relative_ci_low", "relative_ci_high"))
    return out


def yade_for(shape, density):
    """The YADE a shape's collisions run on: 2023.02a for a linear clump (isotropic route), 2025.2
    (delValle2023) otherwise."""
    return "2023.02a" if shp.properties(shape, density)["linear"] else "2025.2"


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


def prediction_rows(name, shape, law, rows, gas):
    """The CSV rows of one shape's predictions, each with its gas interval where one exists."""
    youngs, e, mu = law
    out = []
    for r in rows:
        g = gas.get(gas_key(name, shape) + (r["protocol"], youngs, r["case"]))
        case = f"{r['case']}/{r['protocol']}"        # the table's one column for case and protocol
        out.append({"shape": name, "youngs_modulus": f"{youngs:g}", "restitution": f"{e:g}", "friction": f"{mu:g}",
                    "case": case, "observable": "diffusion", "predicted": f"{r['predicted']:.6g}",
                    "predicted_se": f"{r['predicted_se']:.3g}", "cpu_s": f"{r['cpu_s']:.1f}",
                    "gas_relative": "" if g is None else f"{g[0]:.6g}",
                    "gas_ci_low": "" if g is None else f"{g[1]:.6g}",
                    "gas_ci_high": "" if g is None else f"{g[2]:.6g}"})
    return out


def write_table(rows, path):
    """Write ``rows`` (dicts with the keys ``COLUMNS``) as CSV to ``path``."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows)


def _parser():
    ap = argparse.ArgumentParser(prog="python -m studies predict", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("spec", help="study spec file or name (studies/specs/NAME.toml)")
    ap.add_argument("--pairs", type=int, default=4000, help="collision courses per shape (default 4000)")
    ap.add_argument("--seed", type=int, default=17)
    ap.add_argument("--factor", type=float, default=0.5, help="dt factor on the smallest member's P-wave step")
    ap.add_argument("--workdir", default=None, help="keep the YADE runs here (reused by a repeated call)")
    ap.add_argument("--gas", default=EFFECTS, help="the gas effects table (default results/effects.csv)")
    ap.add_argument("--out", default=OUT, help="the predictions table (default results/predictions.csv)")
    return ap


def _load(name):
    from . import spec as S
    from .__main__ import _spec_path
    return S.load(_spec_path(name))


def _set_material(spec):
    """The collision runs' material from the spec (``studies.timestep.collisions.MATERIAL``)."""
    for k in ("density", "youngs_modulus", "poisson"):
        tc.MATERIAL[k] = float(spec["material"][k])


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
    law = contact_law(spec)
    if law[1] != 1.0 or law[2] != 0.0:
        print(f"error: {spec['path']}: restitution {law[1]:g}, friction {law[2]:g}: the clumps' YADE route for "
              "inelastic or frictional contacts is not built (studies.predict_hcs covers spheres)", file=sys.stderr)
        return 2
    if a.pairs < 10:
        print(f"error: --pairs {a.pairs}: at least 10 collision courses are needed for a standard error", file=sys.stderr)
        return 2
    saved = dict(tc.MATERIAL)
    _set_material(spec)
    try:
        return _predict(a, spec, law)
    finally:
        tc.MATERIAL.clear()
        tc.MATERIAL.update(saved)


def _predict(a, spec, law):
    work = a.workdir or tempfile.mkdtemp(prefix="predict-")
    os.makedirs(work, exist_ok=True)
    gas = gas_intervals(a.gas)
    table, t0 = [], time.time()
    for name, cases in shape_cases(spec).items():
        if not cases:
            continue
        shape = spec["shapes"][name]
        tag = f"{name}-E{law[0]:g}-n{a.pairs}-s{a.seed}"
        rows = elastic_predictions(shape, cases, a.pairs, a.seed, a.factor, work, tag)
        cpu = sum(r["cpu_s"] for r in rows)
        for r in rows:
            print(f"[predict] {name} {r['case']} {r['protocol']}: D_case/D_exact - 1 = {100 * r['predicted']:+.2f} % "
                  f"± {100 * r['predicted_se']:.2f} % (se, {r['pairs_used']} collisions)")
        print(f"[predict] {name}: CPU {cpu / 60:.1f} min", flush=True)
        table += prediction_rows(name, shape, law, rows, gas)
    write_table(table, a.out)
    print(f"[predict] wrote {os.path.relpath(a.out, ROOT)}; wall {(time.time() - t0) / 60:.1f} min")
    return 0


if __name__ == "__main__":
    sys.exit(main())
