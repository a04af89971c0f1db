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
energy.csv             case, seed, t, e_trans, e_rot, e_elastic (J, whole gas; paired protocol;
                       energy_equal_energy.csv: the same for the equal-energy runs)
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
from dataclasses import astuple, dataclass

import numpy as np

from . import design, engine, manifest, runner
from . import spec as study_spec
from .diffusion import ols_msd
from .intervals import t_interval

ESTIMATOR = design.ESTIMATOR   # D per run: Green-Kubo (docs/estimator.md); OLS on the MSD kept for comparison
CASE_ORDER = ("exact", "uncorrected", "mass_only", "inertia_only", "spheres")


@dataclass(frozen=True)
class SeedRun:
    """One run that passed its checks: its MSD from the analysis cut on, its Green-Kubo D, its record."""
    lag_s: np.ndarray
    msd: np.ndarray
    diffusion_coefficient: float
    record: dict


@dataclass(frozen=True)
class RunEstimates:
    """What ``runs.csv`` adds to a run's record: the jackknife SE, the cuts and the OLS D."""
    diffusion_stderr: float
    t_cut: float
    t_cut_detected: float | None
    diffusion_coefficient_ols: float


@dataclass(frozen=True)
class CaseSummary:
    """One row of ``protocols.csv``: D of a (case, protocol) over seeds."""
    case: str
    protocol: str
    n_seeds: int
    diffusion_coefficient: float
    ci_low: float
    ci_high: float
    stderr: float
    max_energy_drift: float
    hard_particle_prediction_from_paired: float


@dataclass(frozen=True)
class PairedDifference:
    """One row of ``diff_D.csv``: D_case - D_exact paired by seed, absolute and relative to D_exact."""
    case: str
    protocol: str
    n_seeds: int
    d_minus_d_exact: float
    ci_low: float
    ci_high: float
    stderr: float
    relative: float
    relative_ci_low: float
    relative_ci_high: float


@dataclass(frozen=True)
class ProtocolEffect:
    """One row of ``protocol_effect.csv``: D_equal_energy / D_paired of a case, paired by seed."""
    case: str
    n_seeds: int
    d_equal_energy_over_d_paired: float
    ci_low: float
    ci_high: float
    hard_particle_prediction: float


@dataclass(frozen=True)
class RatioOfD:
    """One row of ``ratio_D.csv``: (D_case - D_exact) / (D_spheres - D_exact), paired by seed."""
    case: str
    n_seeds: int
    ratio: float
    ci_low: float
    ci_high: float
    stderr: float


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


def _write_records(path, records, cls):
    """``records`` (instances of the dataclass ``cls``) as a CSV, the field names as its header."""
    _write_csv(path, list(cls.__dataclass_fields__), [astuple(r) for r in records])


def label(case, protocol):
    return case if protocol == "paired" else f"{case}@{protocol}"


def load_records(spec):
    """(manifest rows, records by key) of a spec's runs, from the results directory."""
    rdir = engine.results_dir(spec)
    recs = design.load_records(spec, rdir)
    extra = design.plan(spec, rdir, recs)[0] if any(g.get("target") for g in spec["groups"]) else {}
    return manifest.reconcile(spec, study_spec.runs(spec, extra_seeds=extra), rdir), recs


def gas_labels(spec):
    """One label per distinct gas the spec's groups run: shape, material, gas table, run table
    (a group's own ``dt_factor`` counts; the study's ``dt_factor`` and ``legacy_dt`` do not: those
    pairs pool, docs/timestep.md)."""
    out = {}                   # gas key -> label, in the groups' order
    for g in spec["groups"]:
        mat, gas, run = study_spec.group_tables(spec, g)
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
        where = f"in its run records ({os.path.relpath(engine.results_dir(spec), study_spec.ROOT)}/runs), which no table reads"
    return (f"{spec['study']['name']}: its groups run {len(labels)} different gases ({'; '.join(labels)}), and "
            f"the Fig. 2 tables (summary.csv, diff_D.csv, ...) describe one; read its answers {where}")


def _log_run_state(rows_m, spec, log):
    """Log the runs that need a rerun or are not finished; return the names of the unfinished ones."""
    missing = [r["name"] for r in rows_m.values() if r["status"] not in ("done", "flagged")]
    rerun = [r["name"] for r in rows_m.values() if str(r.get("error", "")).startswith("rerun:")]
    if rerun:
        log(f"[analyze] {len(rerun)} runs need a rerun for this analysis (their records lack a window it reads; "
            f"python -m studies sweep {spec.get('path', 'SPEC')} reruns them): {', '.join(rerun[:4])}...")
    if missing:
        log(f"[analyze] {len(missing)} runs not finished (analysing the rest): {', '.join(missing[:4])}...")
    return missing


def estimate_runs(good, analysis_options):
    """MSD and D of every good run: ``(by_case, estimates)`` with ``by_case`` (case, protocol) ->
    {seed: :class:`SeedRun`} and ``estimates`` run name -> :class:`RunEstimates`."""
    by_case, estimates = {}, {}
    for rec in good:
        gk = design.run_d(rec, analysis_options["t_eq"])
        lag, msd = run_msd(rec, gk["t_cut"])
        try:
            d_ols = ols_msd(lag, msd, analysis_options["fit_lo"], analysis_options["fit_hi"])
        except ValueError:
            d_ols = np.nan
        estimates[rec["name"]] = RunEstimates(gk["D_stderr"], gk["t_cut"], gk["t_cut_detected"], d_ols)
        by_case.setdefault((rec["case"], rec["protocol"]), {})[rec["seed"]] = SeedRun(lag, msd, gk["D"], rec)
    return by_case, estimates


def write_runs_table(out, records, by_case, estimates):
    """``runs.csv``: every run, its checks and (for the good ones) its D, SE, cuts and OLS D."""
    rows = []
    no_estimate = RunEstimates(np.nan, np.nan, None, np.nan)
    for rec in records:
        seed_run = by_case.get((rec["case"], rec["protocol"]), {}).get(rec["seed"])
        checks, facts = rec["checks"], rec["facts"]
        est = estimates.get(rec["name"], no_estimate)
        rows.append([rec["case"], rec["protocol"], rec["seed"], rec["name"], bool(checks["ok"]),
                     "; ".join(checks["fail_reasons"]), checks["energy_drift"], checks["momentum_drift"],
                     np.nan if seed_run is None else seed_run.diffusion_coefficient, est.diffusion_stderr,
                     est.diffusion_coefficient_ols, est.t_cut,
                     np.nan if est.t_cut_detected is None else est.t_cut_detected,
                     facts["steps_per_s"], facts["wall_run_s"], facts["builder"],
                     rec["git_commit"] + ("-dirty" if rec["git_dirty"] else ""),
                     rec["yade_version"], rec["rot_algorithm"], rec["key"]])
    _write_csv(os.path.join(out, "runs.csv"),
               ["case", "protocol", "seed", "run", "ok", "fail_reasons", "energy_drift", "momentum_drift",
                "diffusion_coefficient", "diffusion_stderr_run", "diffusion_coefficient_ols", "t_cut", "t_cut_detected",
                "steps_per_s", "wall_run_s", "builder", "git_commit", "yade_version",
                "rot_algorithm", "key"], rows)


def _common_seeds(*seed_maps):
    return sorted(set.intersection(*(set(m) for m in seed_maps)))   # the seeds every map has


def case_summaries(by_case, masses, m_exact):
    """D per (case, protocol) with a t-interval over seeds, paired protocol first, cases in
    :data:`CASE_ORDER`; an equal-energy case also gets the hard-particle prediction from its paired D:
    velocities x sqrt(m_exact/m), so D x sqrt(m_exact/m)."""
    out = []
    for (case, protocol), seeds in sorted(by_case.items(),
                                          key=lambda kv: (kv[0][1] != "paired", CASE_ORDER.index(kv[0][0]))):
        mean, lo, hi, se, n = t_interval([run.diffusion_coefficient for run in seeds.values()])
        drift = max(run.record["checks"]["energy_drift"] for run in seeds.values())
        prediction = np.nan
        if protocol == "equal_energy" and (case, "paired") in by_case:
            paired = by_case[(case, "paired")]
            common = _common_seeds(seeds, paired)
            prediction = float(np.mean([paired[k].diffusion_coefficient for k in common])
                               * np.sqrt(m_exact / masses[case]))
        out.append(CaseSummary(case, protocol, n, mean, lo, hi, se, drift, prediction))
    return out


def paired_differences(by_case):
    """``diff_D.csv`` rows: D_case - D_exact paired by seed, for every case but exact/paired."""
    out = []
    for case, protocol, seeds, exact, common in _paired_with_exact(by_case):
        mean, lo, hi, se, n = t_interval([seeds[k].diffusion_coefficient - exact[k].diffusion_coefficient
                                          for k in common])
        d_exact = float(np.mean([exact[k].diffusion_coefficient for k in common]))
        out.append(PairedDifference(case, protocol, n, mean, lo, hi, se, mean / d_exact, lo / d_exact, hi / d_exact))
    return out


def protocol_effects(by_case, masses, m_exact):
    """``protocol_effect.csv`` rows: D_equal_energy / D_paired of the same case, paired by seed."""
    out = []
    for (case, protocol), seeds in by_case.items():
        if protocol != "equal_energy" or (case, "paired") not in by_case:
            continue
        paired = by_case[(case, "paired")]
        mean, lo, hi, se, n = t_interval([seeds[k].diffusion_coefficient / paired[k].diffusion_coefficient
                                          for k in _common_seeds(seeds, paired)])
        out.append(ProtocolEffect(case, n, mean, lo, hi, float(np.sqrt(m_exact / masses[case]))))
    return out


def sensitivity_rows(good, sensitivity):
    """``diffusion_sensitivity.csv`` rows: OLS D and D - D_exact for each (t_eq, fit_lo, fit_hi)."""
    rows = []
    for t_eq, fit_lo, fit_hi in sensitivity:
        d_by_case = {}
        for rec in good:
            lag, msd = run_msd(rec, t_eq)
            d_by_case.setdefault((rec["case"], rec["protocol"]), {})[rec["seed"]] = ols_msd(lag, msd, fit_lo, fit_hi)
        exact = d_by_case.get(("exact", "paired"), {})
        for (case, protocol), seeds in d_by_case.items():
            mean, lo, hi, _, n = t_interval(list(seeds.values()))
            diff, diff_lo, diff_hi, _, _ = t_interval([seeds[k] - exact[k] for k in _common_seeds(seeds, exact)])
            rows.append([case, protocol, t_eq, fit_lo, fit_hi, n, mean, lo, hi, diff, diff_lo, diff_hi])
    return rows


def msd_rows(by_case):
    """``msd.csv`` rows: the mean MSD over seeds and its standard error on a log grid of lags."""
    rows = []
    for (case, protocol), seeds in by_case.items():
        lag = min((run.lag_s for run in seeds.values()), key=len)
        msds = np.array([run.msd[:len(lag)] for run in seeds.values()])
        idx = np.unique(np.concatenate([np.round(np.geomspace(1, len(lag) - 1, 160)).astype(int), [len(lag) - 1]]))
        mean = msds.mean(0)
        se = msds.std(0, ddof=1) / np.sqrt(len(msds)) if len(msds) > 1 else np.full(len(lag), np.nan)
        for i in idx:
            rows.append([case, protocol, float(lag[i]), float(mean[i]), float(se[i]), len(msds)])
    return rows


def msd_relative_rows(by_case):
    """``msd_relative.csv`` rows: MSD_case / MSD_exact - 1 paired by seed, with its t-interval."""
    rows = []
    for case, protocol, seeds, exact, common in _paired_with_exact(by_case):
        n = min([len(seeds[k].lag_s) for k in common] + [len(exact[k].lag_s) for k in common])
        lag = exact[common[0]].lag_s[:n]
        with np.errstate(invalid="ignore", divide="ignore"):
            rel = np.array([seeds[k].msd[:n] / exact[k].msd[:n] - 1 for k in common])
        for i in np.unique(np.round(np.geomspace(1, n - 1, 120)).astype(int)):
            mean, lo, hi, _, n_seeds = t_interval(rel[:, i])
            rows.append([case, protocol, float(lag[i]), mean, lo, hi, n_seeds])
    return rows


def paper_ratio(by_case):
    """The paper's ratio (X_case - X_exact) / (X_spheres - X_exact) paired by seed, for X = MSD
    (``ratio.csv`` rows, with gap_rel = (MSD_spheres - MSD_exact) / MSD_exact) and X = D
    (:class:`RatioOfD`).  Returns ``(msd_rows, d_ratios)``."""
    msd_ratio_rows, d_ratios = [], []
    exact, spheres = by_case.get(("exact", "paired"), {}), by_case.get(("spheres", "paired"), {})
    for (case, protocol), seeds in by_case.items():
        if case in ("exact", "spheres"):
            continue
        common = _common_seeds(seeds, exact, spheres)
        if not common:
            continue
        n = min(len(m[k].lag_s) for m in (seeds, exact, spheres) for k in common)
        lag = exact[common[0]].lag_s[:n]
        with np.errstate(invalid="ignore", divide="ignore"):      # lag 0 is 0/0
            ratio = np.array([(seeds[k].msd[:n] - exact[k].msd[:n]) / (spheres[k].msd[:n] - exact[k].msd[:n])
                              for k in common])
        gap = np.mean([(spheres[k].msd[:n] - exact[k].msd[:n]) / np.maximum(exact[k].msd[:n], 1e-300)
                       for k in common], axis=0)
        for i in np.unique(np.round(np.geomspace(1, n - 1, 120)).astype(int)):
            mean, lo, hi, _, n_seeds = t_interval(ratio[:, i])
            msd_ratio_rows.append([label(case, protocol), float(lag[i]), mean, lo, hi, n_seeds, float(gap[i])])
        d_ratio = [(seeds[k].diffusion_coefficient - exact[k].diffusion_coefficient)
                   / (spheres[k].diffusion_coefficient - exact[k].diffusion_coefficient) for k in common]
        mean, lo, hi, se, n_seeds = t_interval(d_ratio)
        d_ratios.append(RatioOfD(label(case, protocol), n_seeds, mean, lo, hi, se))
    return msd_ratio_rows, d_ratios


def write_energy_tables(out, good):
    """``energy.csv``, ``energy_equal_energy.csv`` (the energies of every run) and
    ``energy_partition.csv`` (the seed-mean translational and rotational shares)."""
    energy_rows = {"paired": [], "equal_energy": []}
    shares = {}          # (case, protocol) -> [(t, translational share, rotational share) per run]
    for rec in good:
        energies = {k: np.asarray(v) for k, v in rec["energy"].items()}
        for row in zip(energies["t"], energies["e_trans"], energies["e_rot"], energies["e_elastic"]):
            energy_rows[rec["protocol"]].append([rec["case"], rec["seed"]] + [float(v) for v in row])
        e_total = energies["e_trans"] + energies["e_rot"] + energies["e_elastic"]
        shares.setdefault((rec["case"], rec["protocol"]), []).append((energies["t"], energies["e_trans"] / e_total,
                                                                        energies["e_rot"] / e_total))
    header = ["case", "seed", "t", "e_trans", "e_rot", "e_elastic"]
    _write_csv(os.path.join(out, "energy.csv"), header, energy_rows["paired"])
    if energy_rows["equal_energy"]:
        _write_csv(os.path.join(out, "energy_equal_energy.csv"), header, energy_rows["equal_energy"])
    _write_csv(os.path.join(out, "energy_partition.csv"),
               ["case", "protocol", "t", "trans_fraction", "trans_fraction_stderr", "rot_fraction",
                "rot_fraction_stderr", "n_seeds"], _partition_rows(shares))


def _partition_rows(shares):
    rows = []
    for (case, protocol), runs in shares.items():
        n = min(len(t) for t, _, _ in runs)
        trans = np.array([tr[:n] for _, tr, _ in runs])
        rot = np.array([ro[:n] for _, _, ro in runs])
        k = len(runs)
        for i in range(n):
            rows.append([case, protocol, float(runs[0][0][i]), float(trans[:, i].mean()),
                         float(trans[:, i].std(ddof=1) / np.sqrt(k)) if k > 1 else np.nan,
                         float(rot[:, i].mean()), float(rot[:, i].std(ddof=1) / np.sqrt(k)) if k > 1 else np.nan, k])
    return rows


def study_params(spec, records, good, n_manifest, n_missing):
    """``params.json``: the spec's tables and what the runs were (versions, commits, time steps, wall time)."""
    options = spec["analysis"]
    any_run = good[0] if good else (records[0] if records else {})
    return {
        "study": spec["study"], "spec": spec["path"],
        "command": f".venv/bin/python -m studies run {spec['path']}",
        "material": spec["material"], "gas": spec["gas"], "run": spec["run"], "analysis": spec["analysis"],
        "shapes": spec["shapes"], "groups": spec["groups"], "spheres": spec["spheres"],
        "n_particles": spec["gas"]["n_particles"], "box_length": any_run.get("box_length"),
        "t_end": spec["run"]["t_end"], "dt": any_run.get("facts", {}).get("dt"), "t_eq": options["t_eq"],
        # every time step of the runs (several when the study raised run.dt_factor, run.legacy_dt)
        "dts": sorted({r["facts"]["dt"] for r in records if "dt" in r.get("facts", {})}),
        "fit_window_s": [options["fit_lo"], options["fit_hi"]], "estimator": ESTIMATOR,
        "case_bodies": {r["case"]: r["case_body"] for r in records},
        "model_version": study_spec.MODEL_VERSION,
        "yade_versions": sorted({r["yade_version"] for r in records}),
        "rot_algorithms": sorted({r["rot_algorithm"] for r in records}),
        "clumpprops_versions": sorted({r["params"]["clumpprops_version"] for r in records}),
        "git_commits": sorted({r["git_commit"] + ("-dirty" if r["git_dirty"] else "") for r in records}),
        "n_runs": n_manifest, "n_runs_ok": len(good), "n_runs_excluded": len(records) - len(good),
        "n_runs_missing": n_missing,
        "wall_run_s_total": float(sum(r["facts"]["wall_run_s"] for r in records)),
    }


def _log_answers(log, summaries, differences, effects, d_ratios):
    for s in summaries:
        log(f"[analyze]   D[{label(s.case, s.protocol)}] = {s.diffusion_coefficient:.5g} m^2/s  "
            f"95% CI [{s.ci_low:.5g}, {s.ci_high:.5g}]  (n={s.n_seeds}, max energy drift {s.max_energy_drift:.2g})")
    for d in differences:
        log(f"[analyze]   D[{label(d.case, d.protocol)}] - D[exact] = {d.d_minus_d_exact:+.4f} m^2/s  "
            f"95% CI [{d.ci_low:+.4f}, {d.ci_high:+.4f}] ({100 * d.relative:+.2f} %, n={d.n_seeds} paired seeds)")
    for e in effects:
        log(f"[analyze]   D[{e.case}@equal_energy] / D[{e.case}] = {e.d_equal_energy_over_d_paired:.4f}  "
            f"95% CI [{e.ci_low:.4f}, {e.ci_high:.4f}] "
            f"(hard-particle scaling sqrt(m_exact/m) = {e.hard_particle_prediction:.4f}, n={e.n_seeds})")
    for r in d_ratios:
        log(f"[analyze]   ratio_D[{r.case}] = {r.ratio:.3f}  95% CI [{r.ci_low:.3f}, {r.ci_high:.3f}] (n={r.n_seeds})")


def analyze(spec, log=print):
    """Tables of a spec's finished runs (one gas: the Fig. 2 tables; see the module docstring).
    Raises ValueError for a spec whose groups run several gases (:func:`single_gas_problem`)."""
    problem = single_gas_problem(spec)
    if problem:
        raise ValueError(problem)
    t0 = time.time()
    out = engine.results_dir(spec)
    manifest_rows, records_by_key = load_records(spec)
    missing = _log_run_state(manifest_rows, spec, log)
    records = [records_by_key[k] for k in manifest_rows if k in records_by_key]
    good = [r for r in records if r["checks"]["ok"]]
    for r in records:
        if not r["checks"]["ok"]:
            log(f"[analyze] EXCLUDED {r['name']}: {'; '.join(r['checks']['fail_reasons'])}")

    by_case, estimates = estimate_runs(good, spec["analysis"])
    write_runs_table(out, records, by_case, estimates)
    masses = {r["case"]: r["case_body"]["mass"] for r in records}
    m_exact = next((r["exact_mass"] for r in records), np.nan)
    summaries = case_summaries(by_case, masses, m_exact)
    _write_csv(os.path.join(out, "summary.csv"),
               ["case", "n_seeds", "diffusion_coefficient", "ci_low", "ci_high", "max_energy_drift"],
               [[s.case, s.n_seeds, s.diffusion_coefficient, s.ci_low, s.ci_high, s.max_energy_drift]
                for s in summaries if s.protocol == "paired"])
    _write_records(os.path.join(out, "protocols.csv"), summaries, CaseSummary)
    differences = paired_differences(by_case)
    _write_records(os.path.join(out, "diff_D.csv"), differences, PairedDifference)
    effects = protocol_effects(by_case, masses, m_exact)
    if effects:
        _write_records(os.path.join(out, "protocol_effect.csv"), effects, ProtocolEffect)
    sensitivity = sensitivity_rows(good, spec["analysis"]["sensitivity"])
    if sensitivity:
        _write_csv(os.path.join(out, "diffusion_sensitivity.csv"),
                   ["case", "protocol", "t_eq", "fit_lo", "fit_hi", "n_seeds", "diffusion_coefficient", "ci_low",
                    "ci_high", "d_minus_d_exact", "diff_ci_low", "diff_ci_high"], sensitivity)
    _write_csv(os.path.join(out, "msd.csv"), ["case", "protocol", "lag_s", "msd_mean", "msd_stderr", "n_seeds"],
               msd_rows(by_case))
    _write_csv(os.path.join(out, "msd_relative.csv"),
               ["case", "protocol", "lag_s", "rel_diff", "ci_low", "ci_high", "n_seeds"], msd_relative_rows(by_case))
    msd_ratio, d_ratios = paper_ratio(by_case)
    _write_csv(os.path.join(out, "ratio.csv"), ["case", "lag_s", "ratio", "ci_low", "ci_high", "n_seeds", "gap_rel"],
               msd_ratio)
    _write_records(os.path.join(out, "ratio_D.csv"), d_ratios, RatioOfD)
    write_energy_tables(out, good)

    params = study_params(spec, records, good, len(manifest_rows), len(missing))
    params["wall_analysis_s"] = time.time() - t0
    runner.write_atomic(os.path.join(out, "params.json"), json.dumps(params, indent=1, default=float))
    log(f"[analyze] {len(good)} runs used, {len(records) - len(good)} excluded, {len(missing)} missing; "
        f"{time.time() - t0:.0f} s; tables in {out}")
    _log_answers(log, summaries, differences, effects, d_ratios)
    return params
