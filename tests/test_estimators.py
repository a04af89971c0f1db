"""studies.correlation, diffusion, intervals, synthetic, equilibration, sequential: VACF, Green-Kubo D with jackknife errors, OLS, equilibration, sequential design.

Synthetic data with known answers (Ornstein-Uhlenbeck walkers, a relaxing energy share with
correlated noise), fixed seeds.  The statistical checks run a scaled-down gas (128 walkers,
tau = 5 s, 16 tau per run: the study's 400 s / 25 s) so that 250 replicas take seconds;
``python -m studies estimator-validation`` runs the full size.  Each statistical test also checks
that its criterion rejects a wrong estimator (the test can fail).
"""
import math

import numpy as np
import pytest
from scipy import stats

from studies import correlation, diffusion, equilibration, intervals, sequential, synthetic

# ---- VACF and MSD by FFT against the definitions -------------------------------------


@pytest.mark.parametrize("T,N,L", [(2, 1, 5), (7, 3, 6), (64, 5, 20), (301, 9, 300), (50, 16, 49)])
def test_vacf_fft_equals_bruteforce(T, N, L):
    rng = np.random.default_rng(T + 7 * N)
    v = rng.normal(size=(T, N, 3)) + rng.normal(size=(1, N, 3))
    np.testing.assert_allclose(correlation.vacf_fft(v, L), correlation.vacf_bruteforce(v, L), rtol=1e-10, atol=1e-12)


def test_vacf_groups_equal_bruteforce_per_group_and_weighted_mean():
    rng = np.random.default_rng(11)
    T, N, G = 120, 37, 5                      # unequal groups (8, 8, 7, 7, 7)
    v = rng.normal(size=(T, N, 3))
    c, cg = correlation.vacf_fft(v, 40, groups=G)
    labels = correlation.group_labels(N, G)
    assert cg.shape == (G, 41)
    for g in range(G):
        np.testing.assert_allclose(cg[g], correlation.vacf_bruteforce(v[:, labels == g], 40), rtol=1e-10, atol=1e-12)
    w = np.bincount(labels)
    np.testing.assert_allclose(c, w @ cg / N, rtol=1e-12)
    # a wrong grouping gives different group VACFs (the comparison can fail)
    _, cg2 = correlation.vacf_fft(v, 40, groups=np.arange(N) % G)
    assert not np.allclose(cg, cg2)


def test_msd_fft_groups_equal_the_definition_per_group():
    rng = np.random.default_rng(3)
    x = np.cumsum(rng.normal(size=(400, 20, 3)), axis=0) + 100.0
    m, mg = correlation.msd_fft(x, 150, groups=4)
    assert m.shape == (151,) and mg.shape == (4, 151)
    np.testing.assert_allclose(m, correlation.msd_bruteforce(x)[:151], rtol=1e-9, atol=1e-9)
    for g, idx in enumerate(np.array_split(np.arange(20), 4)):
        np.testing.assert_allclose(mg[g], correlation.msd_bruteforce(x[:, idx])[:151], rtol=1e-9, atol=1e-9)


def test_ou_walkers_have_the_exact_vacf_and_msd():
    tau, sv, dt = 4.0, 1.3, 0.25
    rng = np.random.default_rng(5)
    v, x = synthetic.simulate_ou(rng, 2000, 401, dt, tau, sv)
    lag = np.arange(61) * dt
    c = correlation.vacf_fft(v, 60)
    np.testing.assert_allclose(c, 3 * sv ** 2 * np.exp(-lag / tau), atol=0.03 * 3 * sv ** 2)
    m = correlation.msd_fft(x, 60)
    exact = 6 * sv ** 2 * tau * (lag - tau * (1 - np.exp(-lag / tau)))
    np.testing.assert_allclose(m[1:], exact[1:], rtol=0.05)


# ---- Green-Kubo --------------------------------------------------------------------------


@pytest.mark.parametrize("c_trunc,dt", [(1.0, 0.25), (2.0, 0.25), (3.0, 0.25), (2.0, 0.5)])
def test_green_kubo_exact_on_a_noise_free_exponential(c_trunc, dt):
    tau = 25.0
    lag = np.arange(int(150 / dt) + 1) * dt
    vacf = 3 * 0.629 * np.exp(-lag / tau)
    r = diffusion.diffusion_green_kubo(lag, vacf, c_trunc=c_trunc, full_output=True)
    assert r["tau_hat"] == pytest.approx(tau, rel=1e-4)
    assert r["D"] == pytest.approx(0.629 * tau, rel=1e-4)
    assert r["tau_tail"] == pytest.approx(tau, rel=1e-4)
    # without its tail the truncated integral is far off (what the tail is for)
    assert r["integral"] < 0.97 * 0.629 * tau


def test_green_kubo_rejects_a_vacf_that_does_not_decay():
    lag = np.arange(100) * 0.25
    with pytest.raises(ValueError, match="decay"):
        diffusion.diffusion_green_kubo(lag, np.ones(100))
    with pytest.raises(ValueError, match="evenly"):
        diffusion.diffusion_green_kubo(np.r_[0.0, 0.3, np.arange(2, 100) * 0.25], np.exp(-np.arange(100) / 4.0))


def _scaled_gas_replicas(n_rep, seed, n=128, tau=5.0, dt=0.25, run_tau=16.0, sv=0.8):
    """D, jackknife SE (16 groups) and a naive truncated-integral D for n_rep OU runs."""
    T = int(round(run_tau * tau / dt)) + 1
    L = int(round(6 * tau / dt))
    lag = np.arange(L + 1) * dt
    out = np.empty((n_rep, 3))
    for r in range(n_rep):
        rng = np.random.default_rng([seed, r])
        v, _ = synthetic.simulate_ou(rng, n, T, dt, tau, sv, positions=False)
        c, cg = correlation.vacf_fft(v, L, groups=16)
        d, lo, hi, se = diffusion.green_kubo_interval(lag, c, cg)
        k = int(round(diffusion.correlation_time(lag, c) / dt))
        naive = (np.sum(c[:k + 1]) - 0.5 * (c[0] + c[k])) * dt / 3    # integral to tau_hat, no tail
        out[r] = d, se, naive
    return out, sv ** 2 * tau


def test_green_kubo_unbiased_with_honest_interval_on_ou_walkers():
    res, truth = _scaled_gas_replicas(250, seed=2026)
    rel = res[:, 0] / truth
    bias, bias_se = rel.mean() - 1, rel.std(ddof=1) / math.sqrt(len(rel))
    q = stats.t.ppf(0.975, 15)
    cover = np.mean(np.abs(res[:, 0] - truth) <= q * res[:, 1])
    assert abs(bias) < max(3 * bias_se, 0.01), (bias, bias_se)
    assert 0.92 <= cover <= 0.98, cover
    # the jackknife SE matches the replica-to-replica spread
    assert 0.85 < np.mean(res[:, 1]) / np.std(res[:, 0], ddof=1) < 1.2
    # the same criteria reject a biased estimator (the truncated integral without a tail)
    nrel = res[:, 2] / truth
    assert abs(nrel.mean() - 1) > 10 * nrel.std(ddof=1) / math.sqrt(len(nrel))
    ncover = np.mean(np.abs(res[:, 2] - truth) <= q * res[:, 1])
    assert ncover < 0.5


def test_jackknife_stderr_scales_like_one_over_sqrt_particles():
    tau, dt, T = 5.0, 0.25, 321
    lag = np.arange(121) * dt
    ses = []
    for n in (64, 256):
        s = []
        for r in range(30):
            v, _ = synthetic.simulate_ou(np.random.default_rng([n, r]), n, T, dt, tau, 1.0, positions=False)
            _, cg = correlation.vacf_fft(v, 120, groups=16)
            s.append(diffusion.green_kubo_stderr(lag, cg))
        ses.append(np.mean(s))
    assert ses[0] / ses[1] == pytest.approx(2.0, rel=0.15)


# ---- today's OLS estimator -----------------------------------------------------------------


def test_ols_msd_is_the_least_squares_slope_over_6():
    from scipy.stats import linregress

    def fit_d(lag, msd, lo, hi):          # an independent least-squares route (scipy's linregress)
        sel = (lag >= lo) & (lag <= hi)
        return linregress(lag[sel], msd[sel]).slope / 6

    rng = np.random.default_rng(9)
    lag = np.arange(801) * 0.25
    msd = 90.0 * lag + 50 * np.sin(lag / 7) + rng.normal(0, 20, lag.size)
    for lo, hi in [(60, 100), (125, 175), (5, 9)]:
        assert diffusion.ols_msd(lag, msd, lo, hi) == pytest.approx(fit_d(lag, msd, lo, hi), rel=1e-10)
    with pytest.raises(ValueError, match="has 0 lags"):
        diffusion.ols_msd(lag, msd, 300, 400)


def test_ols_bias_on_the_exact_ou_msd_is_the_known_4_percent():
    # the prior finding "OLS on lags 60-100 s is 4.3 % low" is the MSD's curvature at tau = 25 s
    tau, D = 25.0, 15.7
    lag = np.arange(801) * 0.25
    msd = 6 * D * (lag - tau * (1 - np.exp(-lag / tau)))
    b60 = diffusion.ols_msd(lag, msd, 60, 100) / D - 1
    b125 = diffusion.ols_msd(lag, msd, 125, 175) / D - 1
    assert -0.050 < b60 < -0.040
    assert -0.005 < b125 < 0


def test_t_interval_matches_scipy():
    from scipy import stats

    x = np.random.default_rng(4).normal(15, 0.6, 8)
    m, lo, hi, se, n = intervals.t_interval(x)
    ref = stats.t.interval(0.95, 7, loc=x.mean(), scale=stats.sem(x))
    np.testing.assert_allclose([m, lo, hi, se], [x.mean(), ref[0], ref[1], stats.sem(x)], rtol=1e-12)
    assert n == 8


# ---- equilibration -----------------------------------------------------------------------


def _relaxing_share(seed, t_end=400.0, dt=0.25, tau_relax=28.4, sd=0.0105, corr=28.4, target=0.4, amp=0.36):
    """0.4 - 0.36 exp(-t/28.4 s) + stationary Gaussian AR(1) noise.  Defaults as in the gas:
    the share of 864 dimers fluctuates like Beta(864, 1296) (sd 0.0105) and its fluctuations
    decay at the relaxation rate (fluctuation-dissipation)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, t_end + dt / 2, dt)
    a = math.exp(-dt / corr)
    z = rng.normal(size=t.size) * sd * math.sqrt(1 - a * a)
    z[0] = rng.normal() * sd
    from scipy.signal import lfilter
    noise = lfilter([1.0], [1.0, -a], z)
    return t, target - amp * np.exp(-t / tau_relax) + noise


def test_equilibration_cut_on_the_papers_relaxation():
    cuts, oks = [], []
    for seed in range(10):
        t, y = _relaxing_share(seed)
        r = equilibration.detect_equilibration(t, y, 0.4)
        oks.append(r["ok"])
        cuts.append(r["t_cut"])
        # after the cut the deterministic transient is within the equilibrium band
        assert 0.36 * math.exp(-r["t_cut"] / 28.4) < r["band"] + 3 * r["sd"]     # + block noise
        assert abs(r["late_mean"] - 0.4) < 0.02
    assert sum(oks) >= 8
    # 0.36 exp(-t/28.4) meets the band (~3 sd = 0.03) at ~70 s; a late false alarm is flagged
    assert 50 <= np.median(cuts) <= 110, cuts
    assert all(c <= 200 for c, ok in zip(cuts, oks) if ok), (cuts, oks)
    # fast, small noise: the cut follows the deterministic crossing closely
    for seed in range(5):
        t, y = _relaxing_share(50 + seed, sd=0.002, corr=1.0)
        r = equilibration.detect_equilibration(t, y, 0.4)
        cross = 28.4 * math.log(0.36 / r["band"])
        assert r["ok"] and cross - 15 <= r["t_cut"] <= cross + 15, (r["t_cut"], cross)


def test_equilibration_stationary_series_cut_early_and_wrong_target_fails():
    early = []
    for seed in range(10):
        t, y = _relaxing_share(100 + seed, amp=0.0)
        early.append(equilibration.detect_equilibration(t, y, 0.4)["t_cut"])
    assert np.median(early) <= 20.0, early
    t, y = _relaxing_share(7)
    bad = equilibration.detect_equilibration(t, y, 0.5)         # 3 rotational dof expected, 2 present
    assert not bad["ok"] and math.isnan(bad["t_cut"])
    t, y = _relaxing_share(8, tau_relax=2000.0)     # never relaxes within the run
    assert not equilibration.detect_equilibration(t, y, 0.4)["ok"]


def test_equipartition_angular_velocities():
    rng = np.random.default_rng(1)
    I = np.array([0.0045, 0.0078, 0.0078])           # kg m^2, the paper's dimer
    kT = 1.5
    w = synthetic.equipartition_angular_velocities(rng, I, kT, 200000)
    np.testing.assert_allclose(np.mean(I * w ** 2, axis=0), kT, rtol=0.01)
    w2 = synthetic.equipartition_angular_velocities(rng, I, kT, 50000, inactive=[True, False, False])
    assert np.all(w2[:, 0] == 0)
    np.testing.assert_allclose(np.mean(I[1:] * w2[:, 1:] ** 2, axis=0), kT, rtol=0.02)
    w3 = synthetic.equipartition_angular_velocities(rng, [0.0, 2.0, 2.0], kT, 1000)   # a linear clump
    assert np.all(w3[:, 0] == 0) and np.all(np.isfinite(w3))
    Ib = rng.uniform(0.1, 1.0, size=(30000, 3))
    w4 = synthetic.equipartition_angular_velocities(rng, Ib, kT, 30000)
    np.testing.assert_allclose(np.mean(Ib * w4 ** 2, axis=0), kT, rtol=0.03)


# ---- sequential design -------------------------------------------------------------------


def test_sequential_status_met_and_projection():
    x = np.random.default_rng(2).normal(0.2, 1.0, 10)
    s = np.std(x, ddof=1)
    hw = stats.t.ppf(0.975, 9) * s / math.sqrt(10)
    st = sequential.sequential_status(x, hw * 1.01, min_n=8)
    assert st["met"] and st["more"] == 0 and sequential.next_batch(st) == 0
    assert st["halfwidth"] == pytest.approx(hw)
    st = sequential.sequential_status(x, hw / 2, min_n=8)
    assert not st["met"]
    n = st["n_needed"]
    assert stats.t.ppf(0.975, n - 1) * s / math.sqrt(n) <= hw / 2 < stats.t.ppf(0.975, n - 2) * s / math.sqrt(n - 1)
    assert 28 <= n <= 40                       # ~ 4x the pairs for half the width (t quantile shrinks)
    assert st["more"] == n - 10
    k = sequential.next_batch(st, batch=4)
    assert k >= st["more"] and k % 4 == 0
    assert sequential.next_batch(st, batch=4, max_n=20) == 10
    assert sequential.sequential_status(x[:5], 10.0, min_n=8)["met"] is False     # min_n guards
    assert sequential.sequential_status(x, hw / 2, max_n=20)["capped"]
    assert sequential.sequential_status(x, hw * 1.01)["more"] == 2        # default pilot: 12 pairs


def test_sequential_stopping_on_the_spread_keeps_coverage():
    rng = np.random.default_rng(12)
    q = {n: stats.t.ppf(0.975, n - 1) for n in range(2, 400)}
    hits, ns = [], []
    for _ in range(1000):
        x = list(rng.normal(1.0, 1.0, 12))
        while True:
            st = sequential.sequential_status(x, 0.5)
            k = sequential.next_batch(st, batch=2, max_n=300)
            if k == 0:
                break
            x.extend(rng.normal(1.0, 1.0, k))
        m, s, n = np.mean(x), np.std(x, ddof=1), len(x)
        hits.append(abs(m - 1.0) <= q[n] * s / math.sqrt(n))
        ns.append(n)
    cover = np.mean(hits)
    assert 0.925 <= cover <= 0.97, cover
    assert 16 <= np.mean(ns) <= 26            # fixed-n design needs 18


@pytest.mark.parametrize("A,sa,na,B,sb,nb", [
    (0.011, 0.014, 9, -0.384, 0.006, 6),     # the study's: uncorrected (9 pairs) over the sphere gap (6)
    (0.02, 0.03, 12, -0.20, 0.05, 8),        # a noisy denominator (|B| / se_B ~ 11)
])
def test_fieller_ratio_covers_the_true_ratio(A, sa, na, B, sb, nb):
    """Normal samples of the study's sizes: the 95 % Fieller interval of mean(a)/mean(b) covers A/B
    in 93.5-96.5 % of 4000 replicas (binomial sd 0.34 %), and its centre is the ratio of means."""
    rng = np.random.default_rng(11)
    truth, hit, n_unb = A / B, 0, 0
    for _ in range(4000):
        a, b = rng.normal(A, sa, na), rng.normal(B, sb, nb)
        th, lo, hi, dof, _, _ = intervals.fieller_ratio(a, b)
        assert th == pytest.approx(a.mean() / b.mean(), rel=1e-12)
        if np.isnan(lo):
            n_unb += 1
            hit += 1          # an unbounded set covers everything
            continue
        assert lo <= th <= hi and min(na, nb) - 1 <= dof + 1e-9 and dof <= na + nb - 2 + 1e-9
        hit += lo <= truth <= hi
    assert n_unb < 40
    assert 0.935 <= hit / 4000 <= 0.965, hit / 4000


@pytest.mark.parametrize("n_runs,sd_run,se_theory,naive_below", [
    (15, 0.0075, 0.0012, 0.925),   # the sphere gas at 1e7 Pa: 15 runs of sd 0.75 %, theory's MC error 0.12 %
    (4, 0.015, 0.0012, None),      # 4 runs (1e8, 1e9 Pa)
])
def test_fieller_from_means_covers_measured_over_monte_carlo_theory(n_runs, sd_run, se_theory, naive_below):
    """The sphere gas's interval: D_measured/D_theory from a mean over runs and a Monte Carlo theory
    whose standard error comes from 1999 dof, with the runs' n - 1 dof (as studies/sphere_gas.py
    calls it): covers the true ratio 1 in 94.5-96.8 % of 10,000 replicas (binomial sd 0.22 %;
    measured 95.8 % and 95.7 %; Welch-Satterthwaite's dof gave 94.8 % and 94.1 %), where the
    interval that ignores the theory's error covers 90.9 % at the 1e7 Pa gas's sizes."""
    rng = np.random.default_rng(5)
    n_rep, hit, hit_naive = 10000, 0, 0
    for _ in range(n_rep):
        d = rng.normal(1.0, sd_run, n_runs)
        th_mc = rng.normal(1.0, se_theory)
        se_mc = se_theory * math.sqrt(rng.chisquare(1999) / 1999)
        th, lo, hi, dof = intervals.fieller_from_means(d.mean(), d.var(ddof=1) / n_runs, n_runs - 1, th_mc, se_mc ** 2, 1999,
                                               dof=n_runs - 1)
        assert th == pytest.approx(d.mean() / th_mc, rel=1e-12) and dof == n_runs - 1
        hit += lo <= 1.0 <= hi
        if naive_below:
            _, lo_t, hi_t, _, _ = intervals.t_interval(d / th_mc)
            hit_naive += lo_t <= 1.0 <= hi_t
    assert 0.945 <= hit / n_rep <= 0.968, hit / n_rep
    if naive_below:
        assert hit_naive / n_rep < naive_below, hit_naive / n_rep


def test_fieller_from_means_agrees_with_samples_and_refuses_bad_input():
    rng = np.random.default_rng(4)
    a, b = rng.normal(2.0, 0.1, 7), rng.normal(3.0, 0.2, 9)
    assert intervals.fieller_from_means(a.mean(), a.var(ddof=1) / 7, 6, b.mean(), b.var(ddof=1) / 9, 8) == \
        pytest.approx(intervals.fieller_ratio(a, b)[:4], rel=1e-14)
    # the bounds are the roots of Fieller's quadratic (ma - theta mb)^2 = t^2 (va + theta^2 vb), with
    # Welch-Satterthwaite's dof at theta-hat, computed here from scipy's t quantile
    from scipy import stats
    ma, va, mb, vb = a.mean(), a.var(ddof=1) / 7, b.mean(), b.var(ddof=1) / 9
    th, lo, hi, dof = intervals.fieller_from_means(ma, va, 6, mb, vb, 8)
    r = ma / mb
    assert dof == pytest.approx((va + r * r * vb) ** 2 / (va * va / 6 + (r * r * vb) ** 2 / 8), rel=1e-12)
    q = stats.t.ppf(0.975, dof)
    for x in (lo, hi):
        assert (ma - x * mb) ** 2 == pytest.approx(q * q * (va + x * x * vb), rel=1e-10)
    assert th == pytest.approx(r, rel=1e-15) and lo < th < hi
    with pytest.raises(ValueError, match="need dof > 0"):
        intervals.fieller_from_means(1.0, 0.1, 0, 1.0, 0.1, 5)
    with pytest.raises(ValueError, match="variances >= 0"):
        intervals.fieller_from_means(1.0, -0.1, 3, 1.0, 0.1, 5)
    with pytest.raises(ValueError, match="need finite means"):
        intervals.fieller_from_means(float("nan"), 0.1, 3, 1.0, 0.1, 5)
    # no variance at all: the interval is the point, never NaN from round-off
    for ma, mb in [(0.3, 0.7), (1.0, 3.0), (2.0, 0.9), (1e-3, 7.0)]:
        th, lo, hi, _ = intervals.fieller_from_means(ma, 0.0, 3, mb, 0.0, 5)
        assert lo == pytest.approx(th, rel=1e-5) and hi == pytest.approx(th, rel=1e-5)


def test_fieller_ratio_is_unbounded_when_the_denominator_is_not_resolved():
    rng = np.random.default_rng(2)
    a, b = rng.normal(0.01, 0.01, 8), rng.normal(0.0, 0.05, 8)
    b = b - b.mean() + 0.005           # mean(b) well inside its noise
    th, lo, hi, *_ = intervals.fieller_ratio(a, b)
    assert np.isfinite(th) and np.isnan(lo) and np.isnan(hi)
    with pytest.raises(ValueError, match="at least 2 values"):
        intervals.fieller_ratio([0.1], [0.2, 0.3])


def test_initial_decay_time_exact_on_an_exponential_and_unbiased_on_ou_walkers():
    """On C = 3 exp(-t/tau) it is tau to round-off; on OU walkers (864, tau = 37.6 s, 0.25 s frames,
    1,000 s: the tetrahedron gas) its mean over 40 replicas is within 3 standard errors of tau and
    its spread is about the 0.5 % per run the gas records show."""
    lag = np.arange(400) * 0.25
    assert diffusion.initial_decay_time(lag, 3.0 * np.exp(-lag / 37.6)) == pytest.approx(37.6, rel=1e-12)
    rng = np.random.default_rng(12)
    est = []
    for _ in range(40):
        vel, _ = synthetic.simulate_ou(rng, 864, 4001, 0.25, 37.6, 0.58, positions=False)
        est.append(diffusion.initial_decay_time(lag[:12], correlation.vacf_fft(vel, 11)))
    est = np.array(est)
    se = est.std(ddof=1) / math.sqrt(len(est))
    assert abs(est.mean() - 37.6) < 3 * se, (est.mean(), se)
    assert 0.003 < est.std(ddof=1) / 37.6 < 0.009     # 0.57 % at this seed; the gas records show ~0.5 %
    with pytest.raises(ValueError, match="fewer than 2 lags"):
        diffusion.initial_decay_time(lag, 3.0 * np.exp(-lag / 37.6), t_fit=0.2)


def test_ratio_of_means_is_the_jackknifed_ratio_and_refuses_bad_input():
    """The delta-method error of mean(a)/mean(b) - 1 against the jackknife of the same ratio (an
    independent route), on paired samples whose common noise cancels; bad input raises."""
    rng = np.random.default_rng(3)
    a = rng.normal(10.0, 0.3, 200)
    b = a * 1.02 + rng.normal(0.0, 0.05, 200)
    m, s = intervals.ratio_of_means(a, b)
    assert m == pytest.approx(a.mean() / b.mean() - 1.0, rel=1e-14)
    n = len(a)
    loo = np.array([(a.sum() - a[i]) / (b.sum() - b[i]) for i in range(n)])
    s_jk = math.sqrt((n - 1) / n * np.sum((loo - loo.mean()) ** 2))
    assert s == pytest.approx(s_jk, rel=2e-3)
    unpaired = math.sqrt(np.var(a / a.mean(), ddof=1) + np.var(b / b.mean(), ddof=1)) / math.sqrt(n)
    assert s < 0.2 * unpaired                          # paired: the common noise cancels
    assert intervals.ratio_of_means(a, a) == (0.0, 0.0)
    for bad in ((a, b[:-1]), (a[:1], b[:1]), (np.r_[a[:-1], np.nan], b), (a, 0.0 * b)):
        with pytest.raises(ValueError, match="a and b must be"):
            intervals.ratio_of_means(*bad)


def test_vacf_integral_is_the_trapezoid_of_an_exponential_to_its_last_lag():
    """(1/3) int_0^L A e^(-t/tau) dt = A tau (1 - e^(-L/tau)) / 3, to the trapezoid's dt^2/(12 tau^2)."""
    dt, tau, a = 0.25, 14.0, 3.0
    lag = np.arange(601) * dt
    got = diffusion.vacf_integral(lag, a * np.exp(-lag / tau))
    exact = a * tau * (1 - math.exp(-lag[-1] / tau)) / 3
    assert got == pytest.approx(exact, rel=2 * dt ** 2 / (12 * tau ** 2))
    assert got != pytest.approx(exact, rel=1e-7)                    # the trapezoid's own error is there
    assert diffusion.vacf_integral(lag, a * np.exp(-lag / tau), dim=1) == pytest.approx(3 * got, rel=1e-14)
    with pytest.raises(ValueError, match="must start at 0"):
        diffusion.vacf_integral(lag[::-1], np.exp(-lag / tau))
