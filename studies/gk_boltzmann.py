"""The study's Green-Kubo estimator on the sphere gas's own velocity autocorrelation, from kinetic theory.

The estimator (docs/estimator.md: integrate the VACF to 2 tau, then an exponential tail fitted on
1-3 tau) was validated on Ornstein-Uhlenbeck walkers, whose VACF is one exponential.  A dilute gas's
VACF is not: in the Boltzmann picture a sphere's velocity jumps at collisions whose rate lambda(v)
grows with its speed, so slow spheres keep their velocity longer and the VACF is a mixture of decay
rates.  Here the tagged particle of the linear Boltzmann equation (``studies.kinetic._tagged_chain``:
the same collision chain whose Green-Kubo sum gives ``d_boltzmann``) is run in continuous time, with
exponential free flights of rate lambda(v), from the time-stationary Maxwellian: one "run" is 864
particles x 1,000 s at 0.25 s frames, as the study's sphere runs (E = 1e7 Pa, the measured kT, n).
Per run: D by the study's estimator (``diffusion.diffusion_green_kubo`` with its defaults) and by
the plain integral of the same VACF to 150 s (~10 tau, no tail model).  The reference is
``d_boltzmann`` of the same (infinite) gas with many chains.

    .venv/bin/python -m studies gk-boltzmann [--runs 200] [--ref-chains 8000] [--seed 2]

Prints the mean bias of the estimator against the reference and against the plain integral, with
standard errors over the runs (the independent units), and writes
results/estimator/gk_boltzmann_vacf.json.  About 1.5 CPU-s per run and 3-5 CPU-min for the reference.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

from . import correlation, diffusion
from . import kinetic as K
from .spec import ROOT

# the sphere gas of studies/specs/sphere_gas.toml at E = 1e7 Pa (results/sphere_gas.csv)
MASS = 2.3858201565553436        # kg: the exact dimer's mass
SIGMA = 0.2                      # m
BOX = 12.18284909686642          # m
N = 864
KT = 1.4998                      # J: measured translational temperature
E_MOD, NU = 1.0e7, 0.40
DT, T_END, MAX_LAG = 0.25, 1000.0, 150.0


def one_run(seed, n=N, t_end=T_END, dt=DT, max_lag=MAX_LAG):
    """(D by the study's Green-Kubo estimator, D by the plain integral to max_lag) of one run."""
    kn = K.hertz_kn(E_MOD, NU, SIGMA / 2, SIGMA / 2)
    rng = np.random.default_rng(seed)
    chain = K._tagged_chain(N / BOX ** 3, KT, MASS, SIGMA, kn, n, seed=seed + 7)
    times, states, t = [], [], np.zeros(n)
    while True:                     # the chain starts in the Maxwellian, the time-stationary law
        v, lam = next(chain)
        times.append(t.copy())
        states.append(v.copy())
        if t.min() > t_end:
            break
        t = t + rng.exponential(1.0 / lam)      # free flight of rate lambda(v)
    times, states = np.array(times), np.array(states)
    nf = int(round(t_end / dt)) + 1
    grid = np.arange(nf) * dt
    vel = np.empty((nf, n, 3))
    for b in range(n):
        vel[:, b] = states[np.searchsorted(times[:, b], grid, side="right") - 1, b]
    c = correlation.vacf_fft(vel, int(round(max_lag / dt)))
    lag = np.arange(len(c)) * dt
    return diffusion.diffusion_green_kubo(lag, c), diffusion.vacf_integral(lag, c)


def main(argv=None):
    """``python -m studies gk-boltzmann [options]``: prints the biases and writes ``--out``."""
    ap = argparse.ArgumentParser(prog="python -m studies gk-boltzmann", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--ref-chains", type=int, default=8000)
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--out", default=os.path.join(ROOT, "results", "estimator", "gk_boltzmann_vacf.json"))
    a = ap.parse_args(argv)
    t0 = time.time()
    rows = []
    for r in range(a.runs):
        rows.append(one_run(a.seed * 100000 + r))
        if (r + 1) % 20 == 0:
            print(f"[gk_vacf] {r + 1}/{a.runs} runs, {time.time() - t0:.0f} s", file=sys.stderr, flush=True)
    o = np.array(rows)
    kn = K.hertz_kn(E_MOD, NU, SIGMA / 2, SIGMA / 2)
    d_ref, se_ref = K.d_boltzmann(N / BOX ** 3, KT, MASS, SIGMA, kn, n_chains=a.ref_chains, n_steps=3000,
                                  seed=a.seed + 11)
    gk, integ = o[:, 0], o[:, 1]
    n = len(gk)
    res = {"runs": n, "particles": N, "t_end_s": T_END, "frame_s": DT, "max_lag_s": MAX_LAG,
           "d_reference": d_ref, "d_reference_se": se_ref, "ref_chains": a.ref_chains,
           "gk_mean": float(gk.mean()), "gk_se": float(gk.std(ddof=1) / math.sqrt(n)),
           "gk_sd_per_run": float(gk.std(ddof=1) / gk.mean()),
           "integral_mean": float(integ.mean()), "integral_se": float(integ.std(ddof=1) / math.sqrt(n)),
           "gk_over_integral_minus_1": float(np.mean(gk / integ - 1)),
           "gk_over_integral_se": float(np.std(gk / integ - 1, ddof=1) / math.sqrt(n)),
           "argv": sys.argv[1:] if argv is None else argv, "date": time.strftime("%Y-%m-%d %H:%M")}
    res["gk_bias"] = res["gk_mean"] / d_ref - 1
    res["gk_bias_se"] = math.hypot(res["gk_se"] / d_ref, se_ref * res["gk_mean"] / d_ref ** 2)
    res["integral_bias"] = res["integral_mean"] / d_ref - 1
    res["integral_bias_se"] = math.hypot(res["integral_se"] / d_ref, se_ref * res["integral_mean"] / d_ref ** 2)
    os.makedirs(os.path.dirname(a.out), exist_ok=True)
    with open(a.out, "w") as f:
        json.dump(res, f, indent=1)
    print(f"{n} runs of {N} spheres x {T_END:g} s: the study's Green-Kubo D {res['gk_mean']:.4f} ± {res['gk_se']:.4f} "
          f"m^2/s (sd per run {100 * res['gk_sd_per_run']:.2f} %); the plain integral to {MAX_LAG:g} s "
          f"{res['integral_mean']:.4f} ± {res['integral_se']:.4f}; the Boltzmann D {d_ref:.4f} ± {se_ref:.4f}")
    print(f"bias of the estimator: {100 * res['gk_bias']:+.3f} % ± {100 * res['gk_bias_se']:.3f} % (against the "
          f"Boltzmann D), {100 * res['gk_over_integral_minus_1']:+.3f} % ± {100 * res['gk_over_integral_se']:.3f} % "
          f"(against the same VACF's plain integral, paired by run); the plain integral "
          f"{100 * res['integral_bias']:+.3f} % ± {100 * res['integral_bias_se']:.3f} %")


if __name__ == "__main__":
    main()
