"""How much pairing helps: the correlation of D between a case's run and the exact run of its seed.

    .venv/bin/python -m studies pair-correlation            # every spec in the results
    .venv/bin/python -m studies pair-correlation --min-pairs 12

Reads the committed run records (no simulation; D by Green-Kubo as the report computes it,
``studies.effects.collect``) and prints, per paired comparison (pair key, case, protocol) with at
least ``--min-pairs`` seeds: the run length, Young's modulus and time-step factor, the number of pairs, Pearson's
correlation rho of D_exact and D_case over seeds with its 95 % Fisher-z interval, the relative sd
over seeds of each D, the sd of D_case/D_exact - 1 (the per-pair spread a sequential target
reads), and the spread that uncorrelated runs would give (the two relative sds added in
quadrature, times the ratio of the means).

Why it is here: the stiffness study's first projection scaled the per-pair spread of
`dimer_paired`'s 1,000 s mass_only pairs to 400 s as 1/sqrt(T) (3.2 % a pair), and the 400 s runs
at 1e8 Pa gave 2.0 %.  If a pair's runs, which share their initial state, stay alike for a time
that does not grow with the run, a shorter run's pairs are more correlated and its per-pair spread
falls more slowly than 1/sqrt(T); the table shows what the committed runs say about that (a
hypothesis: run length, stiffness and time step change together between the studies).  The
Fisher-z interval assumes a bivariate normal pair over seeds (coverage 94.7 % and 95.3 % at 16
pairs, rho 0.4 and 0, 2,000 replicas: tests/test_pair_correlation.py).
"""
from __future__ import annotations

import argparse
import sys

import numpy as np
from scipy import stats


def pair_stats(d_exact, d_case):
    """Per-seed D of the exact runs and of the case's runs (m^2/s, arrays of equal length n >= 4):
    dict of n, rho, rho_low, rho_high (95 % Fisher z), sd_exact, sd_case (relative to each mean),
    sd_rel (sd of d_case/d_exact - 1) and sd_uncorrelated (what sd_rel would be at rho = 0 to first
    order: mean(d_case)/mean(d_exact) sqrt(sd_exact^2 + sd_case^2))."""
    a, b = np.asarray(d_exact, float), np.asarray(d_case, float)
    n = len(a)
    if n < 4 or len(b) != n:
        raise ValueError(f"pair_stats: need two equal-length samples of at least 4 seeds, got {len(a)} and {len(b)}")
    rho = float(np.corrcoef(a, b)[0, 1])
    z, h = np.arctanh(rho), stats.norm.ppf(0.975) / np.sqrt(n - 3)
    sa, sb = float(np.std(a, ddof=1) / np.mean(a)), float(np.std(b, ddof=1) / np.mean(b))
    return {"n": n, "rho": rho, "rho_low": float(np.tanh(z - h)), "rho_high": float(np.tanh(z + h)),
            "sd_exact": sa, "sd_case": sb, "sd_rel": float(np.std(b / a - 1.0, ddof=1)),
            "sd_uncorrelated": float(np.mean(b) / np.mean(a) * np.hypot(sa, sb))}


def _shape(p):
    """The shape as effects.csv names it, with its overlap for a dimer: "dimer 0.5"."""
    from . import effects
    d = p["shape"]["definition"]
    return f"{effects.shape_name(d)} {d.get('overlap', '')}".strip()


def main(argv=None):
    """``python -m studies pair-correlation [--min-pairs N]``: prints the table (``make science``
    writes it to results/pairing/pair_correlation.txt)."""
    from . import effects

    ap = argparse.ArgumentParser(prog="python -m studies pair-correlation", description=__doc__.split("\n")[0])
    ap.add_argument("--min-pairs", type=int, default=8, help="leave out comparisons with fewer pairs (default 8)")
    args = ap.parse_args(argv)
    by, facts, _, studies = effects.collect(effects.results_specs())
    print(f"{'shape':<19} {'E Pa':>7} {'T s':>5} {'dt f':>5} {'case':<12} {'protocol':<16} {'pairs':>5} "
          f"{'rho [95 %]':>20} {'sd exact':>9} {'sd case':>8} {'sd pair':>8} {'if rho=0':>8}  studies")
    for pk in sorted(by, key=lambda k: (sorted(studies[k]), facts[k]["run"]["t_end"])):
        p = facts[pk]
        cases = sorted({c for s in by[pk].values() for c in s if c[0] != "exact"})
        for case in cases:
            seeds = [s for s, cs in by[pk].items() if case in cs and ("exact", "paired") in cs]
            if len(seeds) < max(args.min_pairs, 4):
                continue
            st = pair_stats([by[pk][s][("exact", "paired")][0] for s in seeds], [by[pk][s][case][0] for s in seeds])
            print(f"{_shape(p):<19} {p['material']['youngs_modulus']:7.0e} {p['run']['t_end']:5g} {p['run']['dt_factor']:5.3g} "
                  f"{case[0]:<12} {case[1]:<16} {st['n']:5d} {st['rho']:+6.2f} [{st['rho_low']:+.2f}, {st['rho_high']:+.2f}] "
                  f"{100 * st['sd_exact']:8.2f}% {100 * st['sd_case']:7.2f}% {100 * st['sd_rel']:7.2f}% "
                  f"{100 * st['sd_uncorrelated']:7.2f}%  {', '.join(sorted(studies[pk]))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
