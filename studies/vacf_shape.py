"""The shape of a real gas's velocity autocorrelation, and what it does to the Green-Kubo estimator.

The study's estimator (docs/estimator.md) integrates the VACF to 2 tau and adds an exponential
tail fitted on 1-3 tau.  On a real N-body gas (``studies.hard_sphere_md``: event-driven hard
spheres at the sphere gas's state point) it reads ~0.2 % below the exact Green-Kubo integral.  The
suspected cause is a VACF that is a mixture of decay rates (slow spheres collide less often), so
that its local decay time grows with the lag and an exponential fitted on 1-3 tau falls off too
fast beyond 2 tau.  This script measures that directly:

* R runs of the hard-sphere gas (864 spheres, 1,000 s, the first 50 s dropped, 0.25 s frames), each
  giving its VACF to 150 s (``correlation.vacf_fft``) and its exact integral to 150 s
  (``hard_sphere_md.exact_integral``: no quadrature, no tail model);
* the local decay time -1/(d ln C / dt) of the runs' mean VACF on lag windows of 0-0.5, 1-2, 2-3
  and 3-4 tau, with delete-one-run jackknife errors (the runs are the independent units);
* the estimator with other truncations and tail-fit windows against the exact integral: the ratio
  of the means with a paired delta-method error, and the sd of D per run.

    .venv/bin/python -m studies vacf-shape [--runs 200] [--seed 10000]

Writes results/estimator/vacf_shape_md.json.  About 3 CPU-s per run.
"""
from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

from . import correlation, diffusion, intervals
from . import hard_sphere_md as H
from .spec import ROOT

T_EQ, T_END, MAX_LAG = 50.0, 1000.0, 150.0
WINDOWS = ((0.0, 0.5), (1.0, 2.0), (2.0, 3.0), (3.0, 4.0))       # in units of tau_hat
RECORD = "t_c = 2 tau, fit 1-3 tau (the estimator of record)"
VARIANTS = {                                                     # name: (truncation, tail-fit window) in tau_hat
    RECORD: (diffusion.GK_C_TRUNC, diffusion.GK_FIT_WINDOW),
    "t_c = 1 tau, fit 1-3 tau": (1.0, (1.0, 3.0)),
    "t_c = 2 tau, fit 1.5-3.5 tau": (2.0, (1.5, 3.5)),
    "t_c = 2 tau, fit 2-4 tau": (2.0, (2.0, 4.0)),
    "t_c = 3 tau, fit 3-5 tau": (3.0, (3.0, 5.0)),
}


def local_decay_times(lag_s, vacf, tau, windows=WINDOWS):
    """-1 / slope of ln C(t) fitted by least squares on each lag window [a, b] * tau (s).

    ``vacf`` (L,) must be positive on the windows.  A single exponential gives its decay time on
    every window; a mixture of exponentials gives times that grow with the lag."""
    out = []
    for a, b in windows:
        if lag_s[-1] < b * tau - 1e-9:
            raise ValueError(f"window {a}-{b} tau ends past the largest lag {lag_s[-1]:g} s")
        sel = (lag_s >= a * tau - 1e-9) & (lag_s <= b * tau + 1e-9)
        if sel.sum() < 5:
            raise ValueError(f"window {a}-{b} tau holds {sel.sum()} lags (need >= 5)")
        if not np.all(np.isfinite(vacf[sel])) or np.any(vacf[sel] <= 0):
            raise ValueError(f"VACF not finite and positive on {a}-{b} tau")
        out.append(-1.0 / np.polyfit(lag_s[sel], np.log(vacf[sel]), 1)[0])
    return np.array(out)


def jackknife(values_fn, data):
    """Delete-one jackknife over the rows of ``data``: (estimate on all rows, standard errors)."""
    n = len(data)
    full = np.asarray(values_fn(data.sum(axis=0) / n))
    total = data.sum(axis=0)
    loo = np.array([values_fn((total - data[i]) / (n - 1)) for i in range(n)])
    se = np.sqrt((n - 1) / n * np.sum((loo - loo.mean(axis=0)) ** 2, axis=0))
    return full, se


def one_run(seed, lib):
    out, _ = H.equilibrated_run(seed, t_end=T_END, t_eq=T_EQ, lib=lib)
    c = correlation.vacf_fft(out["vel"], int(round(MAX_LAG / H.FRAME_DT)))
    return c, H.exact_integral(out["pos"], out["vel"], H.FRAME_DT, MAX_LAG)


def main(argv=None):
    """``python -m studies vacf-shape [--runs R] [--seed S] [--out F]``: prints the tables, writes ``--out``."""
    ap = argparse.ArgumentParser(prog="python -m studies vacf-shape", description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--seed", type=int, default=10000, help="first run's seed (runs use seed, seed + 1, ...)")
    ap.add_argument("--out", default=os.path.join(ROOT, "results", "estimator", "vacf_shape_md.json"))
    a = ap.parse_args(argv)
    if a.runs < 10:
        ap.error("--runs must be at least 10 (the errors are over runs)")
    lib = H.library()
    t0, c0 = time.time(), time.process_time()
    V, X = [], []
    for i in range(a.runs):
        c, x = one_run(a.seed + i, lib)
        V.append(c)
        X.append(x)
        if (i + 1) % 25 == 0 or i + 1 == a.runs:
            print(f"[vacf_shape_md] {i + 1}/{a.runs} runs, {time.time() - t0:.0f} s", flush=True)
    V, X = np.array(V), np.array(X)
    lag = np.arange(V.shape[1]) * H.FRAME_DT
    tau = diffusion.correlation_time(lag, V.mean(axis=0))
    times, times_se = jackknife(lambda c: local_decay_times(lag, c, tau), V)
    rise, rise_se = jackknife(lambda c: (lambda t: t[2] / t[0] - 1.0)(local_decay_times(lag, c, tau)), V)
    print(f"{a.runs} runs of {H.N} hard spheres x {T_END - T_EQ:g} s; tau_hat of the mean VACF {tau:.3f} s")
    print("local decay time of the mean VACF (jackknife SE over runs):")
    for (lo, hi), t, s in zip(WINDOWS, times, times_se):
        print(f"  lags {lo:g}-{hi:g} tau: {t:.3f} +- {s:.3f} s")
    print(f"  2-3 tau over 0-0.5 tau - 1: {100 * rise:+.2f} % +- {100 * rise_se:.2f} %")
    res = {}
    print("estimator variants against the exact integral to 150 s and against the estimator of record, same runs\n"
          "(ratios of means, paired SE; sd of D per run):")
    d_of = {name: np.array([diffusion.diffusion_green_kubo(lag, c, c_trunc=ct, fit_window=fw) for c in V])
            for name, (ct, fw) in VARIANTS.items()}
    d_rec = d_of[RECORD]
    for name, d in d_of.items():
        m, se = intervals.ratio_of_means(d, X)
        mr, ser = intervals.ratio_of_means(d, d_rec)
        sd = float(d.std(ddof=1) / d.mean())
        res[name] = dict(rel_exact=m, rel_exact_se=se, rel_record=mr, rel_record_se=ser, sd_per_run=sd)
        print(f"  {name:52s} {100 * m:+.3f} % +- {100 * se:.3f} % | {100 * mr:+.3f} % +- {100 * ser:.3f} % | "
              f"sd per run {100 * sd:.2f} %")
    plain = np.array([diffusion.vacf_integral(lag, c) for c in V])
    pm, pse = intervals.ratio_of_means(plain, X)
    print(f"  plain trapezoid to 150 s (the quadrature check)            {100 * pm:+.3f} % +- {100 * pse:.3f} %")
    out = dict(about=__doc__.split("\n")[0], runs=a.runs, seed=a.seed, n=H.N, t_eq=T_EQ, t_end=T_END, max_lag=MAX_LAG,
               frame_dt=H.FRAME_DT, tau_hat=tau, windows_tau=[list(w) for w in WINDOWS],
               local_decay_time=times.tolist(), local_decay_time_se=times_se.tolist(),
               rise_2_3_over_0_05=float(rise), rise_se=float(rise_se), variants=res,
               plain_rel_exact=pm, plain_rel_exact_se=pse, d_exact_mean=float(X.mean()),
               cpu_s=time.process_time() - c0, wall_s=time.time() - t0,
               date=time.strftime("%Y-%m-%d"))
    os.makedirs(os.path.dirname(a.out), exist_ok=True)
    with open(a.out, "w") as fh:
        json.dump(out, fh, indent=1)
    print(f"[vacf_shape_md] wrote {os.path.relpath(a.out, ROOT)} ({out['cpu_s']:.0f} CPU-s)")


if __name__ == "__main__":
    main()
