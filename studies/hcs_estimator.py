"""Bias and coverage of the cooling gases' estimators on synthetic runs with a known answer.

``python -m studies hcs-estimator`` makes paired studies of DSMC rough-sphere gases
(:mod:`studies.hcs_dsmc`) shaped like the clump runs of ``hcs_clumps.toml`` (1000 particles, an
equipartition start, a transient left out, a stop at a sixteenfold fall of T_tr) whose "case"
changes the reduced moment of inertia kappa as an inertia-only error does, and asks of each
estimator of :mod:`studies.hcs_effects`: is the mean of its per-seed relative effect the true
one, and does its 95 % Student-t interval over the seeds contain the truth 95 % of the time?

The truth comes from another route: long runs of many more particles per case, started at the
two-temperature balance of Maxwellian pairs (close to the HCS), whose cooling rate is the energy
the collisions take out (counted collision by collision) over the kinetic energy, per
sqrt(T_tr), whose T_rot / T_tr is the late window's mean, and whose self-diffusion is the MSD's
growth over the late window over 6 times the integral of sqrt(T_tr) dt (D scales as sqrt(T_tr)),
with no Haff fit and no scaled time.

Two cooling-rate estimators are compared: Haff's fit to T_tr (``t_tr``) and Haff's time from the
total kinetic energy with T_tr's amplitude at that time (``energy``, the one
:func:`studies.hcs_effects.observables` uses): in the HCS both decay at one rate, but the total
energy changes only by dissipation, not by the exchange between translation and rotation.  Two
self-diffusion estimators: the MSD from the first frame against the scaled time (``origin``) and
the multi-origin MSD grid a reduced record keeps (``grid``, :func:`studies.hcs.fit_scaled_msd_grid`).
Writes ``results/estimator/hcs_cooling.csv``.

The same truth also checks the kinetic theory the predictor (:mod:`studies.predict_cooling`) rests
on: the Maxwellian approximation, in which T_rot / T_tr balances the two temperatures' loss rates
and zeta and the velocity relaxation nu_v are averages of the collision rule over Maxwellian pairs
(:func:`studies.hcs_theory.collision_averages`), D0 proportional to 1 / (nu_v - zeta / 2).  The DSMC
solves the Boltzmann equation without that approximation, so :func:`maxwellian_rows` measure how
far the approximation moves each relative effect (``results/estimator/hcs_maxwellian.csv``).
"""
from __future__ import annotations

import math
import os
import sys
import time

import numpy as np

from . import hcs, hcs_dsmc, hcs_effects, hcs_theory
from .hcs_effects import OBSERVABLES
from .intervals import t_interval

COLUMNS = ("setting", "observable", "estimator", "n_seeds", "n_studies", "truth", "truth_se", "mean", "bias", "bias_se",
           "sd_per_seed", "mean_halfwidth", "coverage", "coverage_low", "coverage_high")
# the clump runs' inertia-only error of the paper's dimer: summed k^2 -15.6 %
KAPPA, KAPPA_CASE = 0.4, 0.4 * (1.0 - 0.15625)
SETTINGS = {
    # Coulomb friction mu = 0.5 (Walton's rule): T_rot / T_tr settles within a few mean free times
    "rough": {"rule": hcs_theory.walton_rule(0.9, 0.5, 0.4), "e": 0.9, "mu": 0.5},
    # weak coupling (constant beta = -0.6): T_rot / T_tr relaxes over many Haff times, as in the
    # smooth clump gases where only the shape couples rotation to translation
    "weakly_rough": {"rule": hcs_theory.constant_beta_rule(0.9, -0.6), "e": 0.9, "mu": float("nan")},
}
N_PARTICLES, COOLING_STOP, T_TRANSIENT = 1000, 16.0, 5.0
MAXWELLIAN_COLUMNS = ("setting", "observable", "truth", "truth_se", "maxwellian", "maxwellian_se", "difference",
                      "difference_se")


def truth(setting, n_particles=32000, t_lo=20.0, seeds=tuple(range(91, 99))):
    """The relative effects of KAPPA_CASE against KAPPA in the HCS, from long runs of many particles.

    Parameters
    ----------
    setting : str
        A key of :data:`SETTINGS`.
    n_particles : int, optional
        Particles of each reference run.
    t_lo : float, optional
        Mean free times of the start left out (the relaxation from equipartition).
    seeds : sequence of int, optional
        The reference runs' seeds (paired, as the studies).

    Returns
    -------
    dict
        ``cooling_rate``, ``temperature_ratio`` and ``diffusion``: case / exact - 1 (the mean over
        the seeds), and their standard errors ``cooling_rate_se``, ... .
    """
    return _mean_and_se([_truth_one(setting, n_particles, t_lo, seed) for seed in seeds])


def _mean_and_se(per_seed):
    """``{observable: mean over the seeds, observable_se: its standard error}`` of per-seed dicts."""
    out = {k: float(np.mean([d[k] for d in per_seed])) for k in OBSERVABLES}
    out.update({k + "_se": float(np.std([d[k] for d in per_seed], ddof=1) / math.sqrt(len(per_seed)))
                for k in OBSERVABLES})
    return out


def _truth_one(setting, n_particles, t_lo, seed):
    st = SETTINGS[setting]
    state = hcs_dsmc.initial_state(n_particles, seed)
    out = {}
    for tag, kappa in (("exact", KAPPA), ("case", KAPPA_CASE)):
        # started at the two-temperature balance of Maxwellian pairs, close to the HCS, so that the
        # late window holds the settled state even where T_rot / T_tr relaxes slowly
        r0 = hcs_theory.hcs_ratio_for_rule(st["rule"], kappa, size=200_000, seed=seed)[0]
        s = hcs_dsmc.simulate(state, st["rule"], kappa, t_end=1e4, spin_ratio=r0, cooling_stop=200.0, seed=seed)
        t = np.asarray(s["t"])
        e_tr, e_rot, lost = (np.asarray(s[k]) for k in ("e_trans", "e_rot", "e_dissipated"))
        t_tr, t_rot = hcs.temperatures(e_tr, e_rot, n_particles, 3)
        sel = t >= t_lo
        dt = np.diff(t[sel])
        mid = 0.5 * ((e_tr + e_rot)[sel][1:] + (e_tr + e_rot)[sel][:-1])
        sq = 0.5 * (np.sqrt(t_tr[sel][1:]) + np.sqrt(t_tr[sel][:-1]))
        msd = np.asarray(s["msd"])[sel]
        # zeta / sqrt(T_tr): dissipated power over kinetic energy, per sqrt(T_tr); D / sqrt(T_tr):
        # d MSD / dt = 6 D, so the MSD's growth over 6 times the integral of sqrt(T_tr) dt
        out[tag] = {"cooling_rate": float(np.sum(np.diff(lost[sel])) / np.sum(mid * sq * dt)),
                    "temperature_ratio": float(np.mean(t_rot[sel] / t_tr[sel])),
                    "diffusion": float((msd[-1] - msd[0]) / (6.0 * np.sum(sq * dt)))}
    return {k: out["case"][k] / out["exact"][k] - 1.0 for k in OBSERVABLES}


def estimates(series, t_transient=T_TRANSIENT):
    """One run's observables by each estimator compared.

    Parameters
    ----------
    series : dict
        The run's HCS series.
    t_transient : float, optional
        Frames before it are left out.

    Returns
    -------
    dict
        ``{(observable, estimator): value}``.
    """
    x = hcs_effects.observables(series, t_transient)
    t, e_tr, e_rot = (np.asarray(series[k], float) for k in ("t", "e_trans", "e_rot"))
    t_tr, _ = hcs.temperatures(e_tr, e_rot, int(series["n_particles"]), int(series["rot_dof"]))
    h = hcs.fit_haff(t, t_tr, t_transient)
    return {("cooling_rate", "energy"): x["cooling_rate"],
            ("cooling_rate", "t_tr"): h["zeta0"] * math.sqrt(t_tr[0] / h["t0"]),
            ("temperature_ratio", "mean"): x["temperature_ratio"],
            ("diffusion", "origin"): x["diffusion"], ("diffusion", "grid"): x["diffusion_grid"]}


def study(setting, n_seeds, first_seed):
    """Per-seed relative effects of one synthetic paired study.

    Returns
    -------
    dict
        ``{(observable, estimator): [case / exact - 1 per seed]}``.
    """
    st = SETTINGS[setting]
    out = {}
    for seed in range(first_seed, first_seed + n_seeds):
        state = hcs_dsmc.initial_state(N_PARTICLES, seed)
        runs = [estimates(hcs_dsmc.simulate(state, st["rule"], k, t_end=1e4, cooling_stop=COOLING_STOP, seed=seed,
                                                  grid=True))
                for k in (KAPPA, KAPPA_CASE)]
        for key in runs[0]:
            out.setdefault(key, []).append(runs[1][key] / runs[0][key] - 1.0)
    return out


def coverage_rows(setting, n_studies, n_seeds=4, truth_=None, progress=None):
    """Rows of ``hcs_cooling.csv`` for one setting.

    Parameters
    ----------
    setting : str
        A key of :data:`SETTINGS`.
    n_studies : int
        Synthetic studies of ``n_seeds`` seeds each.
    n_seeds : int, optional
        Seeds per study (the clump studies have 3-4).
    truth_ : dict, optional
        :func:`truth` (computed when None).
    progress : callable, optional
        Called with the number of studies done.

    Returns
    -------
    list of dict
    """
    tr = truth(setting) if truth_ is None else truth_
    per = {}
    for k in range(n_studies):
        for key, vals in study(setting, n_seeds, 1000 + k * n_seeds).items():
            per.setdefault(key, []).append(vals)
        if progress:
            progress(k + 1)
    rows = []
    for (obs, est), studies_ in sorted(per.items()):
        vals = np.asarray(studies_)
        ivs = [t_interval(v) for v in vals]
        hits = np.array([lo <= tr[obs] <= hi for _, lo, hi, _, _ in ivs])
        cov = float(hits.mean())
        # Wilson's score interval of a binomial proportion (stays in [0, 1], right at 0 and 1 hits)
        z, k = 1.96, len(hits)
        centre = (cov + z * z / (2 * k)) / (1 + z * z / k)
        half = z / (1 + z * z / k) * math.sqrt(cov * (1 - cov) / k + z * z / (4 * k * k))
        flat = vals.ravel()
        rows.append({"setting": setting, "observable": obs, "estimator": est, "n_seeds": n_seeds,
                     "n_studies": n_studies, "truth": tr[obs], "truth_se": tr.get(obs + "_se", 0.0),
                     "mean": float(flat.mean()), "bias": float(flat.mean() - tr[obs]),
                     # the studies' mean and the truth's own error
                     "bias_se": math.hypot(float(flat.std(ddof=1) / math.sqrt(flat.size)), tr.get(obs + "_se", 0.0)),
                     "sd_per_seed": float(flat.std(ddof=1)),
                     "mean_halfwidth": float(np.mean([(hi - lo) / 2 for _, lo, hi, _, _ in ivs])),
                     "coverage": cov, "coverage_low": centre - half, "coverage_high": centre + half})
    return rows


def maxwellian(setting, size=500_000, seeds=(1, 2, 3, 4)):
    """The relative effects of KAPPA_CASE against KAPPA in the Maxwellian approximation.

    Per seed (its own Maxwellian pairs): the HCS ratio r* (:func:`studies.hcs_theory.hcs_ratio_for_rule`),
    and at r* the collision averages giving zeta = -<dE_tr> / 3 and nu_v = -<(v1' - v1) . v1> / 3 in
    units of the collision frequency (T_tr = m = 1), which the cases share.

    Returns
    -------
    dict
        ``cooling_rate``, ``temperature_ratio``, ``diffusion``: case / exact - 1 (the mean over the
        seeds), and their standard errors (``..._se``, over the seeds).
    """
    st = SETTINGS[setting]
    per_seed = []
    for seed in seeds:
        x = {}
        for tag, kappa in (("exact", KAPPA), ("case", KAPPA_CASE)):
            r, _ = hcs_theory.hcs_ratio_for_rule(st["rule"], kappa, size=size, seed=seed)
            avg = hcs_theory.collision_averages(st["rule"], 1.0, r, kappa, size=size,
                                                rng=np.random.default_rng([seed, 7]))
            zeta, nu_v = -avg.d_e_tr / 3.0, -avg.d_v_dot_v / 3.0
            x[tag] = {"temperature_ratio": r, "cooling_rate": zeta, "diffusion": 1.0 / (nu_v - zeta / 2.0)}
        per_seed.append({k: x["case"][k] / x["exact"][k] - 1.0 for k in OBSERVABLES})
    return _mean_and_se(per_seed)


def maxwellian_rows(setting, truth_, maxwellian_):
    """Rows of ``hcs_maxwellian.csv`` for one setting: each observable's relative effect in the DSMC
    (:func:`truth`) and in the Maxwellian approximation (:func:`maxwellian`), and their difference."""
    return [{"setting": setting, "observable": k, "truth": truth_[k], "truth_se": truth_[k + "_se"],
             "maxwellian": maxwellian_[k], "maxwellian_se": maxwellian_[k + "_se"],
             "difference": maxwellian_[k] - truth_[k],
             "difference_se": math.hypot(truth_[k + "_se"], maxwellian_[k + "_se"])}
            for k in OBSERVABLES]


def main(argv=None):
    """``python -m studies hcs-estimator``: results/estimator/hcs_cooling.csv and hcs_maxwellian.csv."""
    import argparse

    from . import spec as S

    ap = argparse.ArgumentParser(prog="python -m studies hcs-estimator",
                                 description="Bias and coverage of the cooling gases' estimators on DSMC "
                                             "rough-sphere gases with a known answer.")
    ap.add_argument("--studies", type=int, default=200, help="synthetic studies per setting (default 200)")
    ap.add_argument("--seeds", type=int, default=4, help="seeds per study (default 4)")
    ap.add_argument("--out", default=os.path.join(S.ROOT, "results", "estimator", "hcs_cooling.csv"))
    ap.add_argument("--theory-only", action="store_true",
                    help="only the truth against the Maxwellian approximation (hcs_maxwellian.csv beside --out, "
                         "about a minute a setting)")
    a = ap.parse_args(argv)
    rows, theory = [], []
    for name in SETTINGS:
        t0 = time.time()
        tr = truth(name)
        print(f"[hcs-estimator] {name}: truth " + ", ".join(
            f"{k} {100 * tr[k]:+.2f} ± {100 * tr[k + '_se']:.2f} %" for k in OBSERVABLES)
            + f" ({time.time() - t0:.0f} s)", file=sys.stderr)
        theory += maxwellian_rows(name, tr, maxwellian(name))
        if not a.theory_only:
            rows += coverage_rows(name, a.studies, a.seeds, tr, progress=lambda k: (
                print(f"[hcs-estimator] {name}: {k}/{a.studies} studies", file=sys.stderr) if k % 25 == 0 else None))
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    theory_out = os.path.join(os.path.dirname(os.path.abspath(a.out)), "hcs_maxwellian.csv")
    hcs_effects.write_csv(theory_out, MAXWELLIAN_COLUMNS, theory)
    for r in theory:
        print(f"[hcs-estimator] {r['setting']} {r['observable']}: DSMC {100 * r['truth']:+.2f} ± {100 * r['truth_se']:.2f} %, "
              f"Maxwellian approximation {100 * r['maxwellian']:+.2f} ± {100 * r['maxwellian_se']:.2f} %")
    print(f"[hcs-estimator] wrote {theory_out}")
    if a.theory_only:
        return 0
    hcs_effects.write_csv(a.out, COLUMNS, rows)
    for r in rows:
        print(f"[hcs-estimator] {r['setting']} {r['observable']} ({r['estimator']}): truth {100 * r['truth']:+.2f} %, "
              f"bias {100 * r['bias']:+.2f} ± {100 * r['bias_se']:.2f} %, sd per seed {100 * r['sd_per_seed']:.2f} %, "
              f"coverage {100 * r['coverage']:.1f} % [{100 * r['coverage_low']:.1f}, {100 * r['coverage_high']:.1f}]")
    print(f"[hcs-estimator] wrote {a.out}")
    return 0
