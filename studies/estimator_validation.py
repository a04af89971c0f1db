"""Validation of the self-diffusion estimators on Ornstein-Uhlenbeck walkers with known D.

Each replica: 864 independent OU walkers (3-D), velocity correlation time tau (25 s),
sigma_v^2 = 0.629 m^2/s^2 (the gas's translational energy per clump: D = sigma_v^2 tau =
15.7 m^2/s), sampled at frames 0.25 s apart (velocities exactly; positions by the trapezoidal rule on
those velocities, whose D differs from sigma_v^2 tau by 8e-6).  Every replica gives a 400 s
run; to fit the CPU budget of a shared 2-core machine only replicas 0-49 and every 5th
after them are 1000 s long (their first 400 s are their 400 s run).  From the frames, exactly as the engine will:
the VACF (time-origin and particle averaged, 16 particle groups, lags to 150 s) and the
MSD (lags to 175 s, per group).  Estimators:

  GK c=...   Green-Kubo, integral to c tau_hat + exponential tail (studies.diffusion),
             per-run 95 % interval: jackknife over the 16 groups, t with 15 dof
  OLS a-b    today's: slope/6 of the MSD on lags a..b s, same jackknife interval

Reported: relative bias (mean D_hat / D - 1) with its standard error, sd of D_hat / D,
coverage of the per-run 95 % interval, and of the study's published interval (Student-t
over n runs = seeds) for n = 8 (disjoint groups of replicas, and resampled), and for
paired differences (a partner run with tau_B = 1.04 tau sharing the initial velocities and
half the noise) with 8 and 40 pairs.  Then the sequential design (optional stopping on the
spread) on normal and on the bank of GK pair differences.

    OMP_NUM_THREADS=1 nice -n 5 .venv/bin/python -m studies estimator-validation [--replicas 500]

Writes results/estimator/estimator.json (its printed tables: results/estimator/estimator.txt).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time

import numpy as np

from . import correlation, diffusion, equilibration, intervals, sequential, synthetic
from .spec import ROOT

N = 864
DT = 0.25
SIGMA_V2 = 0.629
GROUPS = 16
MAX_LAG_VACF = 600        # frames: 150 s
MAX_LAG_MSD = 700         # frames: 175 s
LENGTHS = (400.0, 1000.0)
GK_VARIANTS = {"GK c=1": 1.0, "GK c=2": 2.0, "GK c=3": 3.0}
OLS_WINDOWS = {"OLS 60-100": (60.0, 100.0), "OLS 125-175": (125.0, 175.0)}
PRIMARY = "GK c=2"
PAIR_RATIO = 1.04
PAIR_RHO = 0.5
Q15 = None


def analyse(vel, pos, lag_v, lag_m, jackknife=True):
    """{estimator: (D, se)} of one run (the jackknife SE for the primary GK variant and OLS)."""
    out = {}
    c, cg = correlation.vacf_fft(vel, MAX_LAG_VACF, groups=GROUPS)
    for name, ct in GK_VARIANTS.items():
        try:
            dfull = diffusion.diffusion_green_kubo(lag_v, c, c_trunc=ct)
            se = diffusion.green_kubo_stderr(lag_v, cg, c_trunc=ct) if jackknife and name == PRIMARY else np.nan
            out[name] = (dfull, se)
        except ValueError:
            out[name] = (np.nan, np.nan)
    if pos is not None:
        m, mg = correlation.msd_fft(pos, MAX_LAG_MSD, groups=GROUPS)
        for name, (lo, hi) in OLS_WINDOWS.items():
            out[name] = (float(diffusion.ols_msd(lag_m, m, lo, hi)), diffusion.ols_msd_stderr(lag_m, mg, lo, hi))
    return out


def summarise(d, se, truth, q):
    r = d / truth
    ok = np.isfinite(r)
    r, s = r[ok], (se / truth)[ok]
    out = dict(n=int(ok.sum()), bias=float(r.mean() - 1), bias_se=float(r.std(ddof=1) / math.sqrt(len(r))),
               sd=float(r.std(ddof=1)), coverage=None, coverage_se=None, mean_se_over_sd=None)
    if np.all(np.isfinite(s)):
        cover = np.abs(r - 1) <= q * s
        out.update(coverage=float(cover.mean()),
                   coverage_se=float(math.sqrt(cover.mean() * (1 - cover.mean()) / len(r))),
                   mean_se_over_sd=float(s.mean() / r.std(ddof=1)))
    return out


def _pct(v):
    return "  n/a" if v is None else f"{100 * v:5.1f}"


def seed_coverage(x, truth, n, rng, n_resample=20000):
    """Coverage of the Student-t interval over n runs: disjoint groups, and resampled."""
    x = x[np.isfinite(x)]
    k = len(x) // n
    hits = []
    for g in range(k):
        _, lo, hi, _, _ = intervals.t_interval(x[g * n:(g + 1) * n])
        hits.append(lo <= truth <= hi)
    idx = rng.integers(0, len(x), size=(n_resample, n))
    s = x[idx]
    m = s.mean(1)
    h = intervals.t_quantile(0.95, n - 1) * s.std(1, ddof=1) / math.sqrt(n)
    res = np.abs(m - truth) <= h
    return dict(n_runs=n, disjoint_groups=k, coverage_disjoint=float(np.mean(hits)) if k else None,
                coverage_resampled=float(res.mean()), mean_halfwidth_rel=float(h.mean() / abs(truth)))


def sequential_sim(draw, truth, target, rng, n_sim=4000, min_n=8, batch=2, max_n=400, stop_on_mean=False):
    """Run the sequential design n_sim times; coverage of the final interval, n used."""
    hits, ns, met = [], [], []
    for _ in range(n_sim):
        x = list(draw(rng, min_n))
        while True:
            st = sequential.sequential_status(x, target, min_n=min_n, max_n=max_n)
            if stop_on_mean:       # the wrong rule (control): stop once the interval excludes 0
                _, lo, hi, _, _ = intervals.t_interval(x)
                stop = (lo > 0 or hi < 0) or len(x) >= max_n
            else:
                stop = st["met"] or len(x) >= max_n
            if stop:
                break
            k = sequential.next_batch(st, batch=batch, max_n=max_n) if not stop_on_mean else batch
            x.extend(draw(rng, max(k, 1)))
        _, lo, hi, _, _ = intervals.t_interval(x)
        hits.append(lo <= truth <= hi)
        ns.append(len(x))
        met.append(st["met"])
    hits = np.array(hits)
    return dict(coverage=float(hits.mean()), coverage_se=float(math.sqrt(hits.mean() * (1 - hits.mean()) / n_sim)),
                n_mean=float(np.mean(ns)), n_median=float(np.median(ns)), n_max=int(np.max(ns)),
                met_fraction=float(np.mean(met)), n_sim=n_sim)


def relaxing_share(rng, t_end, amp, dt=0.25, tau_relax=28.4, sd=0.0105, corr=28.4):
    """Rotational share 0.4 - amp exp(-t/tau_relax) + stationary AR(1) noise (the gas's:
    Beta(864, 1296) has sd 0.0105; fluctuations decay at the relaxation rate)."""
    from scipy.signal import lfilter

    t = np.arange(0.0, t_end + dt / 2, dt)
    a = math.exp(-dt / corr)
    z = rng.normal(size=t.size) * sd * math.sqrt(1 - a * a)
    z[0] = rng.normal() * sd
    return t, 0.4 - amp * np.exp(-t / tau_relax) + lfilter([1.0], [1.0, -a], z)


def _parser():
    ap = argparse.ArgumentParser(prog="python -m studies estimator-validation", description=__doc__.split("\n")[0])
    ap.add_argument("--replicas", type=int, default=500)
    ap.add_argument("--tau", type=float, default=25.0)
    ap.add_argument("--seed", type=int, default=20261123)
    ap.add_argument("--out", default=os.path.join(ROOT, "results", "estimator", "estimator.json"))
    ap.add_argument("--raw", default="/tmp/bench_estimator_raw.npz",
                    help="per-replica results, saved every 25 replicas (resumed from if present)")
    ap.add_argument("--long-first", type=int, default=50, help="replicas 0..k-1 are 1000 s runs (+ their first 400 s)")
    ap.add_argument("--long-every", type=int, default=5, help="after those, every k-th replica is a 1000 s run")
    ap.add_argument("--first", type=int, default=0, help="first replica of this worker (to split the work)")
    ap.add_argument("--merge", nargs="*", default=[], help="other workers' --raw files to add before summarising")
    ap.add_argument("--summarise-only", action="store_true", help="summarise the replicas in --raw so far")
    return ap


NAMES = list(GK_VARIANTS) + list(OLS_WINDOWS)


def _key(L, k):
    return f"{L:g}|{k}"


class Bank:
    """The per-replica estimates: ``D[L][k]`` and ``S[L][k]`` (D and its per-run SE of estimator
    ``k`` on the run of length ``L`` s), ``DB[k]`` (the paired partner's D, 400 s); NaN where not run.
    Saved to and resumed from an ``.npz`` file (``--raw``)."""

    def __init__(self, replicas, seed, tau):
        self.seed, self.tau = seed, tau
        self.D = {L: {k: np.full(replicas, np.nan) for k in NAMES} for L in LENGTHS}
        self.S = {L: {k: np.full(replicas, np.nan) for k in NAMES} for L in LENGTHS}
        self.DB = {k: np.full(replicas, np.nan) for k in GK_VARIANTS}

    def load(self, path, resume):
        """Add the replicas of ``path``: (replicas done, wall s) or None for another seed or tau."""
        z = np.load(path, allow_pickle=False)
        if int(z["seed"]) != self.seed or float(z["tau"]) != self.tau:
            print(f"ignoring {path}: other seed or tau")
            return None
        a, b = (int(z["first"]) if "first" in z.files else 0), int(z["done"])
        for L in LENGTHS:
            for k in NAMES:
                self.D[L][k][a:b] = z["D|" + _key(L, k)][a:b]
                self.S[L][k][a:b] = z["S|" + _key(L, k)][a:b]
        for k in GK_VARIANTS:
            self.DB[k][a:b] = z["DB|" + k][a:b]
        print(f"{'resuming after' if resume else 'merged'} replicas {a}-{b - 1} from {path}")
        return b, float(z["wall"])

    def save(self, path, first, done, wall):
        arrs = {"D|" + _key(L, k): self.D[L][k] for L in LENGTHS for k in NAMES}
        arrs.update({"S|" + _key(L, k): self.S[L][k] for L in LENGTHS for k in NAMES})
        arrs.update({"DB|" + k: self.DB[k] for k in GK_VARIANTS})
        tmp = path + ".tmp.npz"
        np.savez(tmp, seed=self.seed, tau=self.tau, first=first, done=done, wall=wall, **arrs)
        os.replace(tmp, path)


def _replica(bank, r, args, frames, lag_v, lag_m):
    """Replica ``r``: its runs (400 s, and 1000 s for the long ones) and its paired partner."""
    tau = args.tau
    rng = np.random.default_rng([args.seed, r])
    long_run = r < args.long_first or r % args.long_every == 0     # CPU budget: see --long-every
    lengths = LENGTHS if long_run else (400.0,)
    vel, pos = synthetic.simulate_ou(rng, N, frames[max(lengths)], DT, tau, math.sqrt(SIGMA_V2),
                             positions="trapezoid")
    for L in lengths:
        res = analyse(vel[:frames[L]], pos[:frames[L]], lag_v, lag_m)
        for k, (d, s_) in res.items():
            bank.D[L][k][r], bank.S[L][k][r] = d, s_
    # paired partner: same initial velocities, noise correlated rho, tau_B = 1.04 tau (400 s)
    nb = frames[400.0]
    z_a = (vel[1:nb] - math.exp(-DT / tau) * vel[:nb - 1]).transpose(1, 2, 0) / math.sqrt(
        SIGMA_V2 * (1 - math.exp(-2 * DT / tau)))
    z_b = PAIR_RHO * z_a + math.sqrt(1 - PAIR_RHO ** 2) * rng.standard_normal(z_a.shape)
    vb, _ = synthetic.simulate_ou(rng, N, nb, DT, tau * PAIR_RATIO, math.sqrt(SIGMA_V2), positions=False,
                          v0=vel[0], noise=(z_b, None))
    resb = analyse(vb, None, lag_v, lag_m, jackknife=False)
    for k in GK_VARIANTS:
        bank.DB[k][r] = resb[k][0]


def _simulate(bank, args):
    """Fill the bank: resume from ``--raw``, merge ``--merge``, run the replicas left; wall seconds."""
    lag_v = np.arange(MAX_LAG_VACF + 1) * DT
    lag_m = np.arange(MAX_LAG_MSD + 1) * DT
    frames = {L: int(round(L / DT)) + 1 for L in LENGTHS}
    start, wall0 = args.first, 0.0
    if os.path.exists(args.raw):
        got = bank.load(args.raw, True)
        if got:
            start, wall0 = got
    for path in args.merge:
        bank.load(path, False)
    t0 = time.time() - wall0
    todo = range(start, args.replicas) if not args.summarise_only else range(0)
    for r in todo:
        _replica(bank, r, args, frames, lag_v, lag_m)
        if (r + 1) % 25 == 0 or r + 1 == args.replicas:
            bank.save(args.raw, args.first, r + 1, time.time() - t0)
            print(f"  {r + 1}/{args.replicas} replicas, {time.time() - t0:.0f} s", flush=True)
    return time.time() - t0


def _estimator_table(bank, truth, q15, rng):
    """Per run length and estimator: bias, spread, coverage (printed)."""
    table = {}
    hdr = (f"{'run':>6} {'estimator':<12} {'bias %':>14} {'sd %':>6} {'cover 95':>9} {'SE/sd':>6} "
           f"{'t8 disj':>8} {'t8 res':>7}")
    print(hdr)
    for L in LENGTHS:
        for k in NAMES:
            s = summarise(bank.D[L][k], bank.S[L][k], truth, q15)
            s["seeds8"] = seed_coverage(bank.D[L][k], truth, 8, rng)
            table[f"{L:g}s|{k}"] = s
            print(f"{L:>5g}s {k:<12} {100 * s['bias']:+6.2f} ± {100 * s['bias_se']:4.2f} {100 * s['sd']:6.2f} "
                  f"{_pct(s['coverage']):>8}% {'  n/a' if s['mean_se_over_sd'] is None else format(s['mean_se_over_sd'], '5.2f'):>6} "
                  f"{_pct(s['seeds8']['coverage_disjoint']):>7}% {_pct(s['seeds8']['coverage_resampled']):>6}%")
    return table


def _paired_table(bank, truth, truth_b, rng):
    """Paired differences D_B - D_A (400 s): spread and t-interval coverage (printed)."""
    pairs = {}
    print(f"\npaired differences (400 s, D_B / D_A = {PAIR_RATIO}, noise correlation {PAIR_RHO}): "
          f"true D_B - D_A = {truth_b - truth:.4f} m^2/s")
    D400, DB = bank.D[400.0], bank.DB
    for k in GK_VARIANTS:
        diff = DB[k] - D400[k]
        diff = diff[np.isfinite(diff)]
        p = dict(n=len(diff), mean=float(diff.mean()), sd=float(diff.std(ddof=1)),
                 bias_rel_to_truth=float(diff.mean() / (truth_b - truth) - 1),
                 corr=float(np.corrcoef(*[a[np.isfinite(DB[k] - D400[k])] for a in (DB[k], D400[k])])[0, 1]))
        for n in (8, 40):
            p[f"t{n}"] = seed_coverage(diff, truth_b - truth, n, rng)
        pairs[k] = p
        print(f"  {k:<10} mean {p['mean']:+.4f} sd {p['sd']:.4f} (corr A,B {p['corr']:.2f}); "
              f"t-interval coverage: 8 pairs {_pct(p['t8']['coverage_disjoint'])}% disjoint "
              f"({p['t8']['disjoint_groups']}) / {_pct(p['t8']['coverage_resampled'])}% resampled; "
              f"40 pairs {_pct(p['t40']['coverage_disjoint'])}% ({p['t40']['disjoint_groups']}) / "
              f"{_pct(p['t40']['coverage_resampled'])}%")
    return pairs


def _sequential_table(bank, sd_pair, rng):
    """The sequential design's coverage and sample sizes on normal, skewed and banked draws (printed)."""
    print("\nsequential design (batches of 2 from next_batch, stop when the 95 % half-width <= target):")
    seq = {}
    bank_diff = (bank.DB[PRIMARY] - bank.D[400.0][PRIMARY])
    bank_diff = bank_diff[np.isfinite(bank_diff)]
    normal = lambda g, n: g.normal(0.0, 1.0, n)                       # noqa: E731
    gamma = lambda g, n: (g.gamma(4.0, 1.0, n) - 4.0) / 2.0           # noqa: E731  skewness 1
    cases = {   # name: (draw, truth, target half-width, stop on the mean?, min_n)
        "normal, target sd/2 (fixed n 18), min_n 8": (normal, 0.0, 0.5, False, 8),
        "normal, target sd/2 (fixed n 18), min_n 12": (normal, 0.0, 0.5, False, 12),
        "normal, target sd/4 (fixed n 64), min_n 8": (normal, 0.0, 0.25, False, 8),
        "normal, target sd/4 (fixed n 64), min_n 12": (normal, 0.0, 0.25, False, 12),
        "skewed (gamma, skewness 1), sd/2, min_n 12": (gamma, 0.0, 0.5, False, 12),
        "GK pair-difference bank, sd/2, min_n 12": (lambda g, n: g.choice(bank_diff, n), float(bank_diff.mean()),
                                                    0.5 * sd_pair, False, 12),
        "control: stop when interval excludes 0": (normal, 0.0, 0.5, True, 8),
    }
    for name, (draw, tru, target, wrong, min_n) in cases.items():
        r = sequential_sim(draw, tru, target, rng, n_sim=2000 if wrong else 3000, stop_on_mean=wrong,
                           max_n=60 if wrong else 400, min_n=min_n)
        r["min_n"] = min_n
        seq[name] = r
        print(f"  {name:<48} coverage {100 * r['coverage']:5.1f}% ± {100 * r['coverage_se']:.1f}, "
              f"n mean {r['n_mean']:.1f} (max {r['n_max']}), met {100 * r['met_fraction']:.0f}%")
    return seq


def _equilibration_table(seed):
    """The equilibration cut on the paper's relaxation with the gas's share noise (printed)."""
    print("\nequilibration cut: share = 0.4 - 0.36 exp(-t/28.4 s) + AR(1) noise (sd 0.0105, correlation 28.4 s)")
    eq = {}
    for t_end in (400.0, 1000.0):
        for amp in (0.36, 0.0):
            cuts, oks = [], []
            for sd_seed in range(200):
                t, y = relaxing_share(np.random.default_rng([seed, 7, int(t_end), int(amp > 0), sd_seed]),
                                      t_end, amp)
                res = equilibration.detect_equilibration(t, y, 0.4)
                cuts.append(res["t_cut"])
                oks.append(res["ok"])
            cuts = np.array(cuts)
            key = f"{t_end:g}s|{'relaxing' if amp else 'stationary'}"
            pct = np.nanpercentile(cuts, [5, 50, 95]) if np.isfinite(cuts).any() else [np.nan] * 3
            eq[key] = dict(n=len(cuts), cut_p5=float(pct[0]), cut_median=float(pct[1]), cut_p95=float(pct[2]),
                           no_cut=float(np.mean(~np.isfinite(cuts))), ok=float(np.mean(oks)))
            print(f"  {key:<18} cut 5/50/95 % = {pct[0]:5.0f} {pct[1]:5.0f} {pct[2]:5.0f} s, ok {100 * np.mean(oks):5.1f} %")
    return eq


def main(argv=None):
    """``python -m studies estimator-validation [options]``: simulate (or resume), print the tables,
    write ``--out``."""
    args = _parser().parse_args(argv)
    from scipy import stats

    q15 = float(stats.t.ppf(0.975, GROUPS - 1))
    tau = args.tau
    truth = SIGMA_V2 * tau
    truth_b = SIGMA_V2 * tau * PAIR_RATIO
    bank = Bank(args.replicas, args.seed, tau)
    wall = _simulate(bank, args)
    args.replicas = int(np.isfinite(bank.D[400.0][PRIMARY]).sum())     # replicas present (400 s runs)

    rng = np.random.default_rng(args.seed + 1)
    n_long = int(np.isfinite(bank.D[1000.0][PRIMARY]).sum())
    print(f"\nOU walkers: N = {N}, dt = {DT} s, tau = {tau} s, D = {truth:.4f} m^2/s, "
          f"{args.replicas} replicas of 400 s, {n_long} of 1000 s, {wall:.0f} s wall (this worker)")
    table = _estimator_table(bank, truth, q15, rng)
    pairs = _paired_table(bank, truth, truth_b, rng)
    seq = _sequential_table(bank, pairs[PRIMARY]["sd"], rng)
    eq = _equilibration_table(args.seed)
    out = dict(
        config=dict(N=N, dt_s=DT, tau_s=tau, sigma_v2=SIGMA_V2, D_true=truth, replicas=args.replicas,
                    replicas_1000s=n_long,
                    lengths_s=list(LENGTHS), groups=GROUPS, max_lag_vacf_s=MAX_LAG_VACF * DT,
                    max_lag_msd_s=MAX_LAG_MSD * DT, pair_ratio=PAIR_RATIO, pair_noise_corr=PAIR_RHO,
                    seed=args.seed, gk_fit_window=list(diffusion.GK_FIT_WINDOW), primary=PRIMARY),
        estimators=table, pairs=pairs, sequential=seq, equilibration=eq,
        per_run={f"{L:g}s|{k}": [None if not np.isfinite(v) else round(float(v), 6) for v in bank.D[L][k]]
                 for L in LENGTHS for k in (PRIMARY, *OLS_WINDOWS)},
        wall_s=round(wall, 1), machine=dict(python=platform.python_version(), numpy=np.__version__,
                                            date=time.strftime("%Y-%m-%d %H:%M")),
    )
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    tmp = args.out + ".tmp"
    with open(tmp, "w") as f:
        json.dump(out, f, indent=1)
    os.replace(tmp, args.out)
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
