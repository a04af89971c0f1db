"""The study's sphere gas against kinetic theory: ``results/sphere_gas.csv``.

Issue 12's hard-particle question compares the reference sphere gas with Chapman-Enskog theory at
each contact stiffness.  This module reads what the runs left (no live simulation):

* the run records whose case is ``spheres`` of every spec in the results
  (:func:`studies.effects.results_specs`; D per run by the study's
  Green-Kubo estimator, :func:`studies.design.run_d`; the translational temperature
  kT = (2/3) <E_trans> / N over the analysed window), grouped by gas (Young's modulus, sphere
  size and mass, box, N);
* the first version's paper-scale table (``results/granular_gas``: 8 seeds of 400 s at
  E = 1e7 Pa, D by OLS on MSD lags 125-175 s, temperature from ``energy.csv`` after t_eq),

and puts each gas's measured D next to :mod:`studies.kinetic`'s predictions for the same n, kT,
m, sigma, E and nu: hard spheres and Hertz spheres, first Chapman-Enskog approximation and the
full linear Boltzmann solution, each divided by the Enskog factor.  ``ratio_hertz`` is
D_measured / D_Hertz,Boltzmann with the measured D's 95 % interval (the prediction's own
Monte Carlo error, ``d_hertz_boltzmann_se``, is ~0.1 % and listed, not folded in).
``dlnD_dlnE`` is the softness of D: at fixed velocities a mass scaled by lambda acts as the
contact stiffness scaled by 1/lambda, so a clump whose mass (and inertia) are off by a factor
lambda diffuses faster by about -dlnD_dlnE ln(lambda); in the hard-particle limit this vanishes.

    .venv/bin/python -m studies.sphere_gas      # writes results/sphere_gas.csv (~2 min per gas)
"""
from __future__ import annotations

import csv
import json
import os
import sys

import numpy as np

from . import design, engine, kinetic
from . import spec as S
from .estimators import t_interval

RESULTS = os.path.join(S.ROOT, "results")
COLUMNS = ("source", "youngs_modulus", "poisson", "estimator", "n_runs", "D", "ci_low", "ci_high", "kT",
           "n_particles", "box_length", "diameter", "mass", "number_density", "volume_fraction",
           "enskog_chi", "d_hard_first", "d_hard_boltzmann", "d_hard_boltzmann_se", "d_hertz_first",
           "d_hertz_boltzmann", "d_hertz_boltzmann_se", "dlnD_dlnE", "ratio_hertz", "ratio_hertz_ci_low",
           "ratio_hertz_ci_high", "ratio_hard", "ratio_hard_ci_low", "ratio_hard_ci_high")


def _kT_of(rec, t_cut):
    e = rec["energy"]
    t = np.asarray(e["t"])
    et = np.asarray(e["e_trans"])[t >= t_cut]
    if et.size == 0:
        raise ValueError(f"run {rec['name']}: no energy samples after {t_cut} s")
    return 2.0 / 3.0 * float(et.mean()) / rec["params"]["gas"]["n_particles"]


def gases_from_records(specs):
    """One entry per sphere gas found in the specs' finished, passing records."""
    groups = {}
    for sp in specs:
        rdir = engine.results_dir(sp)
        if not os.path.isdir(rdir):
            continue
        for rec in design.load_records(sp, rdir).values():
            if rec["params"]["case"] != "spheres" or not rec["checks"]["ok"]:
                continue
            p, body = rec["params"], rec["case_body"]
            gas = dict(n_particles=p["gas"]["n_particles"], box_length=rec["box_length"],
                       diameter=2.0 * body["radius"], mass=body["mass"],
                       youngs_modulus=p["material"]["youngs_modulus"], poisson=p["material"]["poisson"])
            g = design.run_d(rec, sp["analysis"]["t_eq"])
            key = (sp["study"]["name"],) + tuple(sorted(gas.items()))
            entry = groups.setdefault(key, {"source": f"{sp['study']['name']} (Green-Kubo)", "gas": gas,
                                            "estimator": "green_kubo", "D": [], "kT": []})
            entry["D"].append(g["D"])
            entry["kT"].append(_kT_of(rec, g["t_cut"]))
    out = []
    for e in groups.values():
        m, lo, hi, _, n = t_interval(e["D"]) if len(e["D"]) > 1 else (e["D"][0], np.nan, np.nan, np.nan, 1)
        out.append({"source": e["source"], "estimator": e["estimator"], "n_runs": n, "D": m, "ci_low": lo,
                    "ci_high": hi, "kT": float(np.mean(e["kT"])), **e["gas"]})
    return out


def gas_from_first_version(path=os.path.join(RESULTS, "granular_gas")):
    """The paper-scale sphere gas of the first version's table (None if it is not there)."""
    import pandas as pd
    try:
        summ = pd.read_csv(os.path.join(path, "summary.csv")).set_index("case")
        energy = pd.read_csv(os.path.join(path, "energy.csv"))
        with open(os.path.join(path, "params.json")) as f:
            params = json.load(f)
    except FileNotFoundError:
        return None
    if "spheres" not in summ.index:
        return None
    paper = S.load(os.path.join(S.SPEC_DIR, "paper.toml"))
    e = energy[(energy["case"] == "spheres") & (energy["t"] >= params["t_eq"])]
    body = params["case_properties"]["spheres"]
    row = summ.loc["spheres"]
    return {"source": "granular_gas (first version, OLS on MSD lags 125-175 s)", "estimator": "ols_msd_125_175",
            "n_runs": int(row["n_seeds"]), "D": float(row["diffusion_coefficient"]),
            "ci_low": float(row["ci_low"]), "ci_high": float(row["ci_high"]),
            "kT": 2.0 / 3.0 * float(e.groupby("seed")["e_trans"].mean().mean()) / params["n_particles"],
            "n_particles": params["n_particles"], "box_length": params["box_length"],
            "diameter": 2.0 * body["radius"], "mass": body["mass"],
            "youngs_modulus": paper["material"]["youngs_modulus"], "poisson": paper["material"]["poisson"]}


def rows(specs, n_chains=2000, n_steps=3000, log=print):
    gases = [g for g in [gas_from_first_version()] if g] + gases_from_records(specs)
    out = []
    for g in gases:
        gas = kinetic.SphereGas(g["n_particles"], g["box_length"], g["diameter"], g["mass"], g["kT"],
                                g["youngs_modulus"], g["poisson"])
        log(f"[sphere_gas] {g['source']}: E = {g['youngs_modulus']:g} Pa, kT = {g['kT']:.5g} J, "
            f"{g['n_runs']} runs: kinetic theory ...")
        pred = gas.predictions(n_chains, n_steps)
        row = {**g, "number_density": gas.number_density, "volume_fraction": gas.volume_fraction, **pred}
        for name, ref in (("hertz", pred["d_hertz_boltzmann"]), ("hard", pred["d_hard_boltzmann"])):
            row[f"ratio_{name}"] = g["D"] / ref
            row[f"ratio_{name}_ci_low"] = g["ci_low"] / ref
            row[f"ratio_{name}_ci_high"] = g["ci_high"] / ref
        out.append(row)
    out.sort(key=lambda r: (r["youngs_modulus"], r["source"]))
    return out


def write(specs, path=os.path.join(RESULTS, "sphere_gas.csv"), **kw):
    rs = rows(specs, **kw)
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS, lineterminator="\n", extrasaction="ignore")
        w.writeheader()
        for r in rs:
            w.writerow({k: (f"{v:.10g}" if isinstance(v, float) else v) for k, v in r.items()})
    os.replace(tmp, path)
    return rs


def read(path=os.path.join(RESULTS, "sphere_gas.csv")):
    """The rows of results/sphere_gas.csv as dicts of floats/strings ([] if it does not exist)."""
    if not os.path.exists(path):
        return []
    with open(path) as f:
        out = []
        for r in csv.DictReader(f):
            out.append({k: (v if k in ("source", "estimator") else float(v) if v not in ("", "nan") else np.nan)
                        for k, v in r.items()})
        return out


if __name__ == "__main__":
    from .effects import results_specs
    rs = write(results_specs(), log=lambda s: print(s, file=sys.stderr))
    for r in rs:
        print(f"{r['source']}: E = {r['youngs_modulus']:g} Pa, D = {r['D']:.4g} [{r['ci_low']:.4g}, {r['ci_high']:.4g}] "
              f"m^2/s; Hertz-Boltzmann {r['d_hertz_boltzmann']:.4g} (ratio {r['ratio_hertz']:.4f}), "
              f"hard-sphere Boltzmann {r['d_hard_boltzmann']:.4g} (ratio {r['ratio_hard']:.4f})")
