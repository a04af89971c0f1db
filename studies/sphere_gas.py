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
D_measured / D_Hertz,Boltzmann with a 95 % Fieller interval that carries both errors: the runs'
Student-t mean and the prediction's own Monte Carlo error (``d_hertz_boltzmann_se``, ~0.04 %
over the default 16,000 independent chains, ~0.1 % over 2,000; :func:`studies.intervals.fieller_from_means` with the
runs' n - 1 dof, whose coverage is tested; ignoring the theory's error covered 91.8 % at the
1e7 Pa gas's sizes).
``dt_effect`` is the relative change of D that the runs' time step ``dt`` [s] makes
(:func:`studies.kinetic.timestep_shift`: the collision map as YADE's leapfrog resolves it; the
predictions are for the exact orbit).  ``dlnD_dlnE`` is the softness of D: at fixed velocities a mass scaled by lambda acts as the
contact stiffness scaled by 1/lambda, so a clump whose mass (and inertia) are off by a factor
lambda diffuses faster by about -dlnD_dlnE ln(lambda); in the hard-particle limit this vanishes.
Dividing by the Enskog factor is the predictions' only density correction; the N-body hard-sphere
gas at the same state point (:mod:`studies.hard_sphere_md`, ``results/hard_sphere_md.json``)
measures what it leaves out.

    .venv/bin/python -m studies.sphere_gas      # writes results/sphere_gas.csv (~2 min per gas)
    .venv/bin/python -m studies.sphere_gas --spec studies/specs/sphere_gas_size.toml   # a diagnostic spec's gases
"""
from __future__ import annotations

import csv
import json
import os
import sys

import numpy as np
from scipy import stats

from . import design, kinetic
from . import spec as study_spec
from .intervals import fieller_from_means, t_interval

RESULTS = os.path.join(study_spec.ROOT, "results")
COLUMNS = ("source", "youngs_modulus", "poisson", "estimator", "n_runs", "D", "ci_low", "ci_high", "stderr", "kT",
           "n_particles", "box_length", "diameter", "mass", "number_density", "volume_fraction",
           "enskog_chi", "d_hard_first", "d_hard_boltzmann", "d_hard_boltzmann_se", "d_hertz_first",
           "d_hertz_boltzmann", "d_hertz_boltzmann_se", "dlnD_dlnE", "dt", "dt_effect", "ratio_hertz", "ratio_hertz_ci_low",
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
        rdir = study_spec.results_dir(sp)
        if not os.path.isdir(rdir):
            continue
        for rec in design.load_records(sp, rdir).values():
            if rec["params"]["case"] != "spheres" or not rec["checks"]["ok"]:
                continue
            p, body = rec["params"], rec["case_body"]
            gas = dict(n_particles=p["gas"]["n_particles"], box_length=rec["box_length"],
                       diameter=2.0 * body["radius"], mass=body["mass"],
                       youngs_modulus=p["material"]["youngs_modulus"], poisson=p["material"]["poisson"],
                       dt=rec["facts"].get("dt") or study_spec.time_step(p))     # the step the run used
            g = design.run_d(rec, sp["analysis"]["t_eq"])
            key = (sp["study"]["name"],) + tuple(sorted(gas.items()))
            entry = groups.setdefault(key, {"source": f"{sp['study']['name']} (Green-Kubo)", "gas": gas,
                                            "estimator": "green_kubo", "D": [], "kT": []})
            entry["D"].append(g["D"])
            entry["kT"].append(_kT_of(rec, g["t_cut"]))
    out = []
    for e in groups.values():
        m, lo, hi, se, n = t_interval(e["D"]) if len(e["D"]) > 1 else (e["D"][0], np.nan, np.nan, np.nan, 1)
        out.append({"source": e["source"], "estimator": e["estimator"], "n_runs": n, "D": m, "ci_low": lo,
                    "ci_high": hi, "stderr": se, "kT": float(np.mean(e["kT"])), **e["gas"]})
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
    paper = study_spec.load(os.path.join(study_spec.SPEC_DIR, "paper.toml"))
    e = energy[(energy["case"] == "spheres") & (energy["t"] >= params["t_eq"])]
    body = params["case_properties"]["spheres"]
    row = summ.loc["spheres"]
    n = int(row["n_seeds"])
    se = (float(row["ci_high"]) - float(row["ci_low"])) / (2.0 * float(stats.t.ppf(0.975, n - 1)))
    return {"source": "granular_gas (first version, OLS on MSD lags 125-175 s)", "estimator": "ols_msd_125_175",
            "n_runs": int(row["n_seeds"]), "D": float(row["diffusion_coefficient"]),
            "ci_low": float(row["ci_low"]), "ci_high": float(row["ci_high"]), "stderr": se,
            "kT": 2.0 / 3.0 * float(e.groupby("seed")["e_trans"].mean().mean()) / params["n_particles"],
            "n_particles": params["n_particles"], "box_length": params["box_length"],
            "diameter": 2.0 * body["radius"], "mass": body["mass"],
            "youngs_modulus": paper["material"]["youngs_modulus"], "poisson": paper["material"]["poisson"],
            "dt": params["dt"]}


def rows(specs, n_chains=16000, n_steps=3000, log=print, first_version=True):
    """One row per gas (``COLUMNS``): the first version's gas (``first_version``) and every sphere
    gas of ``specs``' records, each with its kinetic-theory predictions."""
    gases = [g for g in [gas_from_first_version() if first_version else None] if g] + gases_from_records(specs)
    out = []
    for g in gases:
        gas = kinetic.SphereGas(g["n_particles"], g["box_length"], g["diameter"], g["mass"], g["kT"],
                                g["youngs_modulus"], g["poisson"], g["dt"])
        log(f"[sphere_gas] {g['source']}: E = {g['youngs_modulus']:g} Pa, kT = {g['kT']:.5g} J, "
            f"{g['n_runs']} runs: kinetic theory ...")
        pred = gas.predictions(n_chains, n_steps)
        row = {**g, "number_density": gas.number_density, "volume_fraction": gas.volume_fraction, **pred}
        for name in ("hertz", "hard"):
            ref, ref_se = pred[f"d_{name}_boltzmann"], pred[f"d_{name}_boltzmann_se"]
            row[f"ratio_{name}"] = g["D"] / ref
            lo = hi = np.nan
            if g["n_runs"] > 1:        # both errors: the runs' mean and the theory's Monte Carlo
                _, lo, hi, _ = fieller_from_means(g["D"], g["stderr"] ** 2, g["n_runs"] - 1,
                                                  ref, ref_se ** 2, n_chains - 1, dof=g["n_runs"] - 1)
            row[f"ratio_{name}_ci_low"], row[f"ratio_{name}_ci_high"] = lo, hi
        out.append(row)
    out.sort(key=lambda r: (r["youngs_modulus"], r["source"]))
    return out


def write(specs, path=os.path.join(RESULTS, "sphere_gas.csv"), **kw):
    return write_rows(rows(specs, **kw), path)


def write_rows(rs, path):
    """Write rows of :func:`rows` to the CSV ``path`` (atomically); returns them."""
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


def main(argv=None):
    import argparse
    ap = argparse.ArgumentParser(description="The study's sphere gas against kinetic theory (results/sphere_gas.csv).")
    ap.add_argument("--spec", action="append", default=[], metavar="SPEC",
                    help="read these specs' sphere runs instead (a diagnostic spec with in_results = false); "
                         "the table goes to the first spec's results directory")
    ap.add_argument("--out", default=None, help="the CSV to write")
    a = ap.parse_args(argv)
    log = lambda s: print(s, file=sys.stderr)   # noqa: E731
    if a.spec:
        try:
            specs = [study_spec.load(p) for p in a.spec]
        except (OSError, study_spec.SpecError) as e:
            ap.exit(2, f"sphere_gas: {e}\n")
        out = a.out or os.path.join(study_spec.results_dir(specs[0]), "sphere_gas.csv")
        rs = rows(specs, log=log, first_version=False)
        if not rs:
            ap.exit(1, f"sphere_gas: no finished sphere runs in {', '.join(a.spec)}: nothing written\n")
        write_rows(rs, out)
    else:
        from .effects import results_specs
        out = a.out or os.path.join(RESULTS, "sphere_gas.csv")
        rs = write(results_specs(), out, log=log)
    for r in rs:
        print(f"{r['source']}: E = {r['youngs_modulus']:g} Pa, N = {r['n_particles']}, {r['n_runs']} run{'s' * (r['n_runs'] != 1)}: "
              f"D = {r['D']:.4g} [{r['ci_low']:.4g}, {r['ci_high']:.4g}] m^2/s; Hertz-Boltzmann "
              f"{r['d_hertz_boltzmann']:.4g}: D/D_Hertz - 1 = {100 * (r['ratio_hertz'] - 1):+.2f} % "
              f"[{100 * (r['ratio_hertz_ci_low'] - 1):+.2f}, {100 * (r['ratio_hertz_ci_high'] - 1):+.2f}] %; "
              f"hard-sphere Boltzmann {r['d_hard_boltzmann']:.4g} (ratio {r['ratio_hard']:.4f}); "
              f"time step {100 * r['dt_effect']:+.3f} %")
    print(f"wrote {out}", file=sys.stderr)


if __name__ == "__main__":
    main()
