"""Analysis of the granular-gas runs: MSD, diffusion coefficients, the paper's ratio, energies.

Reads only the manifest (``<results>/manifest.csv``) and the reduced run records it lists
(``<results>/runs/*.json``), never a live simulation or a raw trajectory, and writes tidy CSVs and
``params.json`` into the results directory:

summary.csv            case, n_seeds, diffusion_coefficient, ci_low, ci_high, max_energy_drift
                       (paired protocol, one row per case; D in m^2/s, 95 % t-interval over seeds)
protocols.csv          the same for every (case, protocol) plus the hard-particle prediction of the
                       equal-energy D from the paired one
runs.csv               every run: flags, drifts, per-seed D; failed runs are listed, never used
msd.csv                case, protocol, lag_s, msd_mean, msd_stderr, n_seeds (log-spaced lags)
msd_relative.csv       case, protocol, lag_s, rel_diff = MSD_case / MSD_exact - 1 (paired by seed), CI
ratio.csv              case, lag_s, ratio, ci_low, ci_high, n_seeds:
                       (MSD_case - MSD_exact) / (MSD_spheres - MSD_exact), paired by seed;
                       gap_rel = (MSD_spheres - MSD_exact) / MSD_exact (the ratio is undefined
                       where the sphere and clump curves cross, gap_rel ~ 0)
ratio_D.csv            the same ratio for the diffusion coefficients
diff_D.csv             D_case - D_exact paired by seed, with a t-interval (absolute and relative)
protocol_effect.csv    D_equal_energy / D_paired of a case, paired by seed, vs sqrt(m_exact / m)
diffusion_sensitivity.csv  OLS D and D - D_exact for other equilibration cuts / fit windows
energy.csv             case, seed, t, e_trans, e_rot, e_elastic (J, whole gas; paired protocol)
energy_equal_energy.csv  the same for the equal-energy runs
energy_partition.csv   case, protocol, t, trans_fraction, rot_fraction (+ stderr), seed means

MSD: time-origin averaged (FFT, :func:`studies.correlation.msd_fft`) over the record's analysis window from
t_eq on (``analysis.t_eq``, or "auto": detected from the rotational share of kinetic energy,
:func:`studies.design.analysis_cut`).  D per seed: Green-Kubo on the window's velocity
autocorrelation (:func:`studies.design.run_d`, docs/estimator.md); ``runs.csv`` also lists the
per-run jackknife SE, the cut, and the first version's estimator (slope / 6 of a least-squares
line through MSD(lag) for lag in [fit_lo, fit_hi]), which ``diffusion_sensitivity.csv`` uses for
other cuts and windows.  The case's D is the mean over seeds with a Student-t 95 % interval
(seeds are independent; particles within a run are not).
"""
from __future__ import annotations

import csv
import json
import os
import time

import numpy as np

from . import design, engine, runner
from .diffusion import ols_msd
from .intervals import t_interval
from . import spec as S

ESTIMATOR = design.ESTIMATOR   # D per run: Green-Kubo (docs/estimator.md); OLS on the MSD kept for comparison


def _paired_with_exact(per):
    """(case, protocol, runs, exact runs, seeds both have) for every case except exact/paired itself."""
    ex = per.get(("exact", "paired"), {})
    for (case, prot), seeds in per.items():
        if case == "exact" and prot == "paired":
            continue
        common = sorted(set(seeds) & set(ex))
        if common:
            yield case, prot, seeds, ex, common


def run_msd(rec, t_cut):
    """(lags_s, msd) of one run record from t_cut on (log-spaced lags)."""
    w = design.window_of(rec, t_cut)
    return np.asarray(w["msd_lag_s"]), np.asarray(w["msd"])


def _write_csv(path, header, rows):
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for r in rows:
            w.writerow([f"{v:.10g}" if isinstance(v, float) else v for v in r])
    os.replace(tmp, path)


def label(case, protocol):
    return case if protocol == "paired" else f"{case}@{protocol}"


def load_records(spec):
    """(manifest rows, records by key) of a spec's runs, from the results directory."""
    rdir = engine.results_dir(spec)
    recs = design.load_records(spec, rdir)
    extra = design.plan(spec, rdir, recs)[0] if any(g.get("target") for g in spec["groups"]) else {}
    return engine.reconcile(spec, S.runs(spec, extra_seeds=extra), rdir), recs


def gas_labels(spec):
    """One label per distinct gas the spec's groups run: shape, material, gas table, run table
    (a group's own ``dt_factor`` counts; the study's ``dt_factor`` and ``legacy_dt`` do not: those
    pairs pool, docs/timestep.md)."""
    out = {}                   # gas key -> label, in the groups' order
    for g in spec["groups"]:
        mat, gas, run = S.group_tables(spec, g)
        run = {k: v for k, v in run.items() if k not in ("dt_factor", "legacy_dt")}
        key = json.dumps([g["shape"], mat, gas, run, g.get("dt_factor")], sort_keys=True, default=str)
        out.setdefault(key, f"{g['shape']} at E = {mat['youngs_modulus']:g} Pa, N = {gas['n_particles']}"
                       + (f", dt factor {g['dt_factor']:g}" if g.get("dt_factor") is not None else ""))
    return list(out.values())


def single_gas_problem(spec):
    """None if the spec's groups run one gas (what the Fig. 2 tables describe: they are keyed by
    case, protocol and seed); else a one-line message saying which gases and where their answers are."""
    labels = gas_labels(spec)
    if len(labels) <= 1:
        return None
    spheres_only = all(list(g["cases"]) == ["spheres"] for g in spec["groups"])
    if spheres_only:
        where = ("with python -m studies.sphere_gas" if spec["study"]["in_results"]
                 else f"with python -m studies.sphere_gas --spec {spec['path']}")
    elif spec["study"]["in_results"]:
        where = "in results/effects.csv and results/README.md (python -m studies.report)"
    else:
        where = f"in its run records ({os.path.relpath(engine.results_dir(spec), S.ROOT)}/runs), which no table reads"
    return (f"{spec['study']['name']}: its groups run {len(labels)} different gases ({'; '.join(labels)}), and "
            f"the Fig. 2 tables (summary.csv, diff_D.csv, ...) describe one; read its answers {where}")


def analyze(spec, log=print):
    """Tables of a spec's finished runs (one gas: the Fig. 2 tables; see the module docstring).
    Raises ValueError for a spec whose groups run several gases (:func:`single_gas_problem`)."""
    problem = single_gas_problem(spec)
    if problem:
        raise ValueError(problem)
    t0 = time.time()
    a = spec["analysis"]
    out = engine.results_dir(spec)
    rows_m, recs = load_records(spec)
    t_eq = a["t_eq"]
    missing = [r["name"] for r in rows_m.values() if r["status"] not in ("done", "flagged")]
    rerun = [r["name"] for r in rows_m.values() if str(r.get("error", "")).startswith("rerun:")]
    if rerun:
        log(f"[analyze] {len(rerun)} runs need a rerun for this analysis (their records lack a window it reads; "
            f"python -m studies sweep {spec.get('path', 'SPEC')} reruns them): {', '.join(rerun[:4])}...")
    if missing:
        log(f"[analyze] {len(missing)} runs not finished (analysing the rest): {', '.join(missing[:4])}...")
    runs = [(r, r["name"], r) for r in (recs[k] for k in rows_m if k in recs)]
    good = [(s, n, r) for s, n, r in runs if r["checks"]["ok"]]
    bad = [(s, n, r) for s, n, r in runs if not r["checks"]["ok"]]
    for s, n, r in bad:
        log(f"[analyze] EXCLUDED {n}: {'; '.join(r['checks']['fail_reasons'])}")

    # ---- MSD and D per run ----
    per = {}          # (case, protocol) -> {seed: (lag, msd, D, run)}
    extra = {}        # run name -> (D_stderr, t_cut, detected cut, D_ols)
    for s, n, r in good:
        g = design.run_d(r, t_eq)
        lag, msd = run_msd(r, g["t_cut"])
        try:
            d_ols = ols_msd(lag, msd, a["fit_lo"], a["fit_hi"])
        except ValueError:
            d_ols = np.nan
        extra[n] = (g["D_stderr"], g["t_cut"], g["t_cut_detected"], d_ols)
        per.setdefault((s["case"], s["protocol"]), {})[s["seed"]] = (lag, msd, g["D"], r)

    rows = []
    for s, n, r in runs:
        d = per.get((s["case"], s["protocol"]), {}).get(s["seed"], (None, None, np.nan))[2]
        c = r["checks"]
        se, t_cut, t_det, d_ols = extra.get(n, (np.nan, np.nan, None, np.nan))
        rows.append([s["case"], s["protocol"], s["seed"], n, bool(c["ok"]), "; ".join(c["fail_reasons"]),
                     c["energy_drift"], c["momentum_drift"], d, se, d_ols, t_cut,
                     np.nan if t_det is None else t_det, r["facts"]["steps_per_s"], r["facts"]["wall_run_s"],
                     r["facts"]["builder"], r["git_commit"] + ("-dirty" if r["git_dirty"] else ""),
                     r["yade_version"], r["rot_algorithm"], r["key"]])
    _write_csv(os.path.join(out, "runs.csv"),
               ["case", "protocol", "seed", "run", "ok", "fail_reasons", "energy_drift", "momentum_drift",
                "diffusion_coefficient", "diffusion_stderr_run", "diffusion_coefficient_ols", "t_cut", "t_cut_detected",
                "steps_per_s", "wall_run_s", "builder", "git_commit", "yade_version",
                "rot_algorithm", "key"], rows)

    # ---- D per case with a t-interval ----
    masses = {r["case"]: r["case_body"]["mass"] for _, _, r in runs}
    m_exact = next((r["exact_mass"] for _, _, r in runs), np.nan)
    order = list(("exact", "uncorrected", "mass_only", "inertia_only", "spheres"))
    stats_d = {}
    prow = []
    for (case, prot), seeds in sorted(per.items(), key=lambda kv: (kv[0][1] != "paired", order.index(kv[0][0]))):
        ds = [v[2] for v in seeds.values()]
        mean, lo, hi, se, n = t_interval(ds)
        drift = max(v[3]["checks"]["energy_drift"] for v in seeds.values())
        stats_d[(case, prot)] = (mean, lo, hi, se, n, drift)
        pred = np.nan
        if prot == "equal_energy" and (case, "paired") in per:
            # hard-particle scaling: velocities x sqrt(m_exact/m) -> D x sqrt(m_exact/m)
            common = sorted(set(seeds) & set(per[(case, "paired")]))
            pred = float(np.mean([per[(case, "paired")][k][2] for k in common]) * np.sqrt(m_exact / masses[case]))
        prow.append([case, prot, n, mean, lo, hi, se, drift, pred])
    _write_csv(os.path.join(out, "summary.csv"),
               ["case", "n_seeds", "diffusion_coefficient", "ci_low", "ci_high", "max_energy_drift"],
               [[r[0], r[2], r[3], r[4], r[5], r[7]] for r in prow if r[1] == "paired"])
    _write_csv(os.path.join(out, "protocols.csv"),
               ["case", "protocol", "n_seeds", "diffusion_coefficient", "ci_low", "ci_high", "stderr",
                "max_energy_drift", "hard_particle_prediction_from_paired"], prow)

    # ---- D differences from the exact clumps, paired by seed ----
    drows = []
    for case, prot, seeds, ex, common in _paired_with_exact(per):
        diff = [seeds[k][2] - ex[k][2] for k in common]
        m, lo, hi, se, n = t_interval(diff)
        dex = float(np.mean([ex[k][2] for k in common]))
        drows.append([case, prot, n, m, lo, hi, se, m / dex, lo / dex, hi / dex])
    _write_csv(os.path.join(out, "diff_D.csv"),
               ["case", "protocol", "n_seeds", "d_minus_d_exact", "ci_low", "ci_high", "stderr",
                "relative", "relative_ci_low", "relative_ci_high"], drows)

    # ---- protocol effect: D_equal_energy / D_paired of the same case, paired by seed ----
    perows = []
    for (case, prot), seeds in per.items():
        if prot != "equal_energy" or (case, "paired") not in per:
            continue
        pp = per[(case, "paired")]
        common = sorted(set(seeds) & set(pp))
        m, lo, hi, se, n = t_interval([seeds[k][2] / pp[k][2] for k in common])
        perows.append([case, n, m, lo, hi, float(np.sqrt(m_exact / masses[case]))])
    if perows:
        _write_csv(os.path.join(out, "protocol_effect.csv"),
                   ["case", "n_seeds", "d_equal_energy_over_d_paired", "ci_low", "ci_high",
                    "hard_particle_prediction"], perows)

    # ---- sensitivity of D to the equilibration cut and the fit window ----
    srows = []
    for t_eq_s, lo, hi in a["sensitivity"]:
        alt = {}
        for s, n, r in good:
            lag, msd = run_msd(r, t_eq_s)
            alt.setdefault((s["case"], s["protocol"]), {})[s["seed"]] = ols_msd(lag, msd, lo, hi)
        ex_alt = alt.get(("exact", "paired"), {})
        for (case, prot), seeds in alt.items():
            mean, clo, chi, se, n = t_interval(list(seeds.values()))
            common = sorted(set(seeds) & set(ex_alt))
            dm, dlo, dhi, _, _ = t_interval([seeds[k] - ex_alt[k] for k in common])
            srows.append([case, prot, t_eq_s, lo, hi, n, mean, clo, chi, dm, dlo, dhi])
    if srows:
        _write_csv(os.path.join(out, "diffusion_sensitivity.csv"),
                   ["case", "protocol", "t_eq", "fit_lo", "fit_hi", "n_seeds", "diffusion_coefficient", "ci_low",
                    "ci_high", "d_minus_d_exact", "diff_ci_low", "diff_ci_high"], srows)

    # ---- MSD tables (log-spaced lags) ----
    mrows = []
    for (case, prot), seeds in per.items():
        lag = min((v[0] for v in seeds.values()), key=len)
        M = np.array([v[1][:len(lag)] for v in seeds.values()])
        idx = np.unique(np.concatenate([np.round(np.geomspace(1, len(lag) - 1, 160)).astype(int), [len(lag) - 1]]))
        mean = M.mean(0)
        se = M.std(0, ddof=1) / np.sqrt(len(M)) if len(M) > 1 else np.full(len(lag), np.nan)
        for i in idx:
            mrows.append([case, prot, float(lag[i]), float(mean[i]), float(se[i]), len(M)])
    _write_csv(os.path.join(out, "msd.csv"), ["case", "protocol", "lag_s", "msd_mean", "msd_stderr", "n_seeds"], mrows)

    # ---- MSD relative to the exact clumps, paired by seed ----
    mdrows = []
    for case, prot, seeds, ex, common in _paired_with_exact(per):
        n = min([len(seeds[k][0]) for k in common] + [len(ex[k][0]) for k in common])
        lag = ex[common[0]][0][:n]
        with np.errstate(invalid="ignore", divide="ignore"):
            Q = np.array([seeds[k][1][:n] / ex[k][1][:n] - 1 for k in common])
        idx = np.unique(np.round(np.geomspace(1, n - 1, 120)).astype(int))
        for i in idx:
            m, lo, hi, se, nn = t_interval(Q[:, i])
            mdrows.append([case, prot, float(lag[i]), m, lo, hi, nn])
    _write_csv(os.path.join(out, "msd_relative.csv"),
               ["case", "protocol", "lag_s", "rel_diff", "ci_low", "ci_high", "n_seeds"], mdrows)

    # ---- the paper's ratio, paired by seed ----
    rrows, rdrows = [], []
    ex, sp = per.get(("exact", "paired"), {}), per.get(("spheres", "paired"), {})
    for (case, prot), seeds in per.items():
        if case in ("exact", "spheres"):
            continue
        common = sorted(set(seeds) & set(ex) & set(sp))
        if not common:
            continue
        n = min(len(seeds[k][0]) for k in common)
        n = min([n] + [len(ex[k][0]) for k in common] + [len(sp[k][0]) for k in common])
        lag = ex[common[0]][0][:n]
        with np.errstate(invalid="ignore", divide="ignore"):      # lag 0 is 0/0
            R = np.array([(seeds[k][1][:n] - ex[k][1][:n]) / (sp[k][1][:n] - ex[k][1][:n]) for k in common])
        gap = np.mean([(sp[k][1][:n] - ex[k][1][:n]) / np.maximum(ex[k][1][:n], 1e-300) for k in common], axis=0)
        idx = np.unique(np.round(np.geomspace(1, n - 1, 120)).astype(int))
        for i in idx:
            m, lo, hi, se, nn = t_interval(R[:, i])
            rrows.append([label(case, prot), float(lag[i]), m, lo, hi, nn, float(gap[i])])
        rd = [(seeds[k][2] - ex[k][2]) / (sp[k][2] - ex[k][2]) for k in common]
        m, lo, hi, se, nn = t_interval(rd)
        rdrows.append([label(case, prot), nn, m, lo, hi, se])
    _write_csv(os.path.join(out, "ratio.csv"), ["case", "lag_s", "ratio", "ci_low", "ci_high", "n_seeds", "gap_rel"], rrows)
    _write_csv(os.path.join(out, "ratio_D.csv"), ["case", "n_seeds", "ratio", "ci_low", "ci_high", "stderr"], rdrows)

    # ---- energies ----
    erows = {"paired": [], "equal_energy": []}
    part = {}
    for s, n, r in good:
        e = {k: np.asarray(v) for k, v in r["energy"].items()}
        for row in zip(e["t"], e["e_trans"], e["e_rot"], e["e_elastic"]):
            erows[s["protocol"]].append([s["case"], s["seed"]] + [float(v) for v in row])
        etot = e["e_trans"] + e["e_rot"] + e["e_elastic"]
        part.setdefault((s["case"], s["protocol"]), []).append((e["t"], e["e_trans"] / etot, e["e_rot"] / etot))
    hdr = ["case", "seed", "t", "e_trans", "e_rot", "e_elastic"]
    _write_csv(os.path.join(out, "energy.csv"), hdr, erows["paired"])
    if erows["equal_energy"]:
        _write_csv(os.path.join(out, "energy_equal_energy.csv"), hdr, erows["equal_energy"])
    prow2 = []
    for (case, prot), lst in part.items():
        n = min(len(x[0]) for x in lst)
        tr = np.array([x[1][:n] for x in lst])
        ro = np.array([x[2][:n] for x in lst])
        k = len(lst)
        for i in range(n):
            prow2.append([case, prot, float(lst[0][0][i]), float(tr[:, i].mean()),
                          float(tr[:, i].std(ddof=1) / np.sqrt(k)) if k > 1 else np.nan,
                          float(ro[:, i].mean()), float(ro[:, i].std(ddof=1) / np.sqrt(k)) if k > 1 else np.nan, k])
    _write_csv(os.path.join(out, "energy_partition.csv"),
               ["case", "protocol", "t", "trans_fraction", "trans_fraction_stderr", "rot_fraction",
                "rot_fraction_stderr", "n_seeds"], prow2)

    # ---- params.json ----
    any_run = good[0][2] if good else (runs[0][2] if runs else {})
    params = {
        "study": spec["study"], "spec": spec["path"],
        "command": f".venv/bin/python -m studies run {spec['path']}",
        "material": spec["material"], "gas": spec["gas"], "run": spec["run"], "analysis": spec["analysis"],
        "shapes": spec["shapes"], "groups": spec["groups"], "spheres": spec["spheres"],
        "n_particles": spec["gas"]["n_particles"], "box_length": any_run.get("box_length"),
        "t_end": spec["run"]["t_end"], "dt": any_run.get("facts", {}).get("dt"), "t_eq": t_eq,
        # every time step of the runs (several when the study raised run.dt_factor, run.legacy_dt)
        "dts": sorted({r["facts"]["dt"] for _, _, r in runs if "dt" in r.get("facts", {})}),
        "fit_window_s": [a["fit_lo"], a["fit_hi"]], "estimator": ESTIMATOR,
        "case_bodies": {r["case"]: r["case_body"] for _, _, r in runs},
        "model_version": S.MODEL_VERSION,
        "yade_versions": sorted({r["yade_version"] for _, _, r in runs}),
        "rot_algorithms": sorted({r["rot_algorithm"] for _, _, r in runs}),
        "clumpprops_versions": sorted({r["params"]["clumpprops_version"] for _, _, r in runs}),
        "git_commits": sorted({r["git_commit"] + ("-dirty" if r["git_dirty"] else "") for _, _, r in runs}),
        "n_runs": len(rows_m), "n_runs_ok": len(good), "n_runs_excluded": len(bad), "n_runs_missing": len(missing),
        "wall_run_s_total": float(sum(r["facts"]["wall_run_s"] for _, _, r in runs)),
    }
    params["wall_analysis_s"] = time.time() - t0
    runner.write_atomic(os.path.join(out, "params.json"), json.dumps(params, indent=1, default=float))
    log(f"[analyze] {len(good)} runs used, {len(bad)} excluded, {len(missing)} missing; "
        f"{time.time() - t0:.0f} s; tables in {out}")
    for r in prow:
        log(f"[analyze]   D[{label(r[0], r[1])}] = {r[3]:.5g} m^2/s  95% CI [{r[4]:.5g}, {r[5]:.5g}]  "
            f"(n={r[2]}, max energy drift {r[7]:.2g})")
    for r in drows:
        log(f"[analyze]   D[{label(r[0], r[1])}] - D[exact] = {r[3]:+.4f} m^2/s  95% CI [{r[4]:+.4f}, {r[5]:+.4f}] "
            f"({100 * r[7]:+.2f} %, n={r[2]} paired seeds)")
    for r in perows:
        log(f"[analyze]   D[{r[0]}@equal_energy] / D[{r[0]}] = {r[2]:.4f}  95% CI [{r[3]:.4f}, {r[4]:.4f}] "
            f"(hard-particle scaling sqrt(m_exact/m) = {r[5]:.4f}, n={r[1]})")
    for r in rdrows:
        log(f"[analyze]   ratio_D[{r[0]}] = {r[2]:.3f}  95% CI [{r[3]:.3f}, {r[4]:.3f}] (n={r[1]})")
    return params
