"""Self-diffusion coefficient D of one run: Green-Kubo on the VACF (the estimator of record) and
the least-squares slope of the MSD, each with a delete-one-group jackknife error.

Pure functions (numpy/scipy only, no I/O, no YADE).  Units: time in s, the velocity
autocorrelation (VACF) in m^2/s^2, the MSD in m^2, D in m^2/s (any consistent unit works:
nothing is hard-wired except the default tuning constants, which are in units of the VACF's own
correlation time).

Green-Kubo: :func:`diffusion_green_kubo`
----------------------------------------
``D = (1/3) int_0^inf <v(0).v(t)> dt`` (3-D dot product).  Per run:

1. tau_hat = the VACF's e-folding time (first lag where C(t)/C(0) <= 1/e, linearly
   interpolated), a data-driven correlation time;
2. the VACF is integrated by the trapezoidal rule from 0 to t_c = c * tau_hat (c = 2, rounded
   to the frame grid);
3. the tail beyond t_c is an exponential A exp(-t/tau_t) fitted by least squares to the VACF
   on [a, b] * tau_hat (a = 1, b = 3) and integrated analytically: A tau_t exp(-t_c/tau_t).

Why: the time-origin averaged VACF is an unbiased estimate of C(t) at every lag, so the
trapezoid part has no bias beyond the O(dt^2/tau^2) quadrature error (1e-5 at dt = 0.25 s,
tau = 25 s); the tail (~e^-2 = 14 % of D for an exponential VACF) carries only the small
second-order bias of a nonlinear fit.  Integrating the raw VACF further would add noise
(its variance grows linearly with the upper limit) without removing bias.  The MSD slope
(:func:`ols_msd`) on a fixed lag window is biased low by ~exp(-lag/tau) (4 % on 60-100 s at
tau = 25 s) and noisier (the MSD at long lags uses fewer independent time origins);
a GLS line on early lags is biased by the MSD's curvature.  ``benchmarks/bench_estimator.py``
and ``docs/estimator.md`` give the validation on Ornstein-Uhlenbeck walkers.

Per-run standard error: :func:`green_kubo_stderr`, a delete-one-group jackknife over G
disjoint particle groups (the particles are the nearly independent units inside a run; the
time origins are strongly correlated, which is why a block bootstrap over time origins
underestimates the error).  The jackknife re-runs the whole estimator, tau_hat included.
Across runs, seeds are the independent units: :mod:`studies.intervals`.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from .intervals import t_quantile

__all__ = [
    "correlation_time", "initial_decay_time", "vacf_integral", "diffusion_green_kubo",
    "green_kubo_jackknife", "green_kubo_stderr", "green_kubo_interval", "ols_msd", "ols_msd_stderr",
    "GK_C_TRUNC", "GK_FIT_WINDOW",
]

GK_C_TRUNC = 2.0              # integrate the VACF to GK_C_TRUNC * tau_hat
GK_FIT_WINDOW = (1.0, 3.0)    # fit the exponential tail on [a, b] * tau_hat


def _check_lags(lag_s, c):
    lag = np.asarray(lag_s, dtype=np.float64)
    c = np.asarray(c, dtype=np.float64)
    if lag.ndim != 1 or c.shape[-1] != lag.shape[0] or lag.shape[0] < 3:
        raise ValueError(f"lag_s (L,) and vacf (..., L) with L >= 3 expected, got {lag.shape}, {c.shape}")
    if abs(lag[0]) > 1e-12:
        raise ValueError("lag_s must start at 0")
    d = np.diff(lag)
    if np.any(d <= 0) or np.ptp(d) > 1e-6 * d[0]:
        raise ValueError("lag_s must be evenly spaced and increasing")
    return lag, c


def correlation_time(lag_s, vacf):
    """e-folding time tau_hat (s) of a VACF: first lag with C(t) <= C(0)/e, interpolated.

    Raises ValueError if C(0) <= 0 or the VACF does not fall to C(0)/e within its lags.
    """
    lag, c = _check_lags(lag_s, vacf)
    if c[0] <= 0:
        raise ValueError("VACF at lag 0 must be > 0")
    r = c / c[0]
    below = np.nonzero(r <= math.exp(-1.0))[0]
    if len(below) == 0:
        raise ValueError(f"VACF does not decay to 1/e within the largest lag {lag[-1]:g} s")
    k = int(below[0])
    r0, r1 = r[k - 1], r[k]
    return float(lag[k - 1] + (r0 - math.exp(-1.0)) / (r0 - r1) * (lag[k] - lag[k - 1]))


def initial_decay_time(lag_s, vacf, t_fit=2.0):
    """Velocity relaxation time tau (s) from the first ``t_fit`` seconds of a VACF: the least-squares
    slope of ln(C(t)/C(0)) = -t/tau through the origin over 0 < t <= t_fit.

    In a dilute gas 1/tau is the collision rate times the mean fractional momentum loss per
    collision, set by binary collisions alone (the first Chapman-Enskog approximation), so it
    compares a gas with a collision map (studies/maps.py, relaxation_time_n) without any
    model of the VACF's tail.  Needs C > 0 on the fit lags and at least 2 of them."""
    lag, c = _check_lags(lag_s, vacf)
    if c[0] <= 0:
        raise ValueError("VACF at lag 0 must be > 0")
    sel = (lag > 0) & (lag <= t_fit + 1e-9)
    if sel.sum() < 2:
        raise ValueError(f"fewer than 2 lags in (0, {t_fit:g}] s")
    if np.any(c[sel] <= 0):
        raise ValueError(f"VACF not positive within the first {t_fit:g} s")
    t, y = lag[sel], np.log(c[sel] / c[0])
    return float(-np.dot(t, t) / np.dot(t, y))


def _fit_exponential(t, y, tau0):
    """Least-squares A exp(-t/tau) to (t, y) (unweighted, in C itself, not its log).

    Gauss-Newton in (A, 1/tau) from tau0; falls back to a bounded 1-D search over log tau
    with A profiled out if Gauss-Newton does not converge.  Returns (A at t = 0, tau).
    """
    s = t - t[0]

    def amp(tau):
        e = np.exp(-s / tau)
        return float(np.dot(e, y) / np.dot(e, e)), e

    k = 1.0 / tau0
    a, _ = amp(tau0)
    ok = False
    for _ in range(50):
        e = np.exp(-k * s)
        r = y - a * e
        j1, j2 = e, -a * s * e                      # d(model)/dA, d(model)/dk
        m11, m12, m22 = j1 @ j1, j1 @ j2, j2 @ j2
        g1, g2 = j1 @ r, j2 @ r
        det = m11 * m22 - m12 * m12
        if not det > 0:
            break
        da = (m22 * g1 - m12 * g2) / det
        dk = (m11 * g2 - m12 * g1) / det
        a, k = a + da, k + dk
        if not (np.isfinite(a) and np.isfinite(k) and k > 0):
            break
        if abs(dk) <= 1e-10 * k and abs(da) <= 1e-10 * abs(a):
            ok = True
            break
    if not ok:
        def sse(logtau):
            aa, ee = amp(math.exp(logtau))
            return float(np.sum((y - aa * ee) ** 2))

        lo, hi = math.log(tau0) - math.log(10.0), math.log(tau0) + math.log(10.0)
        res = optimize.minimize_scalar(sse, bounds=(lo, hi), method="bounded", options={"xatol": 1e-8})
        k = math.exp(-res.x)
        a, _ = amp(1.0 / k)
    tau = 1.0 / k
    return a * math.exp(t[0] / tau), tau          # amplitude at t = 0


def vacf_integral(lag_s, vacf, dim=3):
    """(1/dim) int_0^L C dt (m^2/s) of a VACF over all its lags (trapezoidal rule, no tail model):
    the plain Green-Kubo integral to the largest lag L.  ``lag_s`` (L,) evenly spaced from 0 (s)."""
    lag, c = _check_lags(lag_s, vacf)
    return float((np.sum(c) - 0.5 * (c[0] + c[-1])) * (lag[1] - lag[0]) / dim)


def diffusion_green_kubo(lag_s, vacf, c_trunc=GK_C_TRUNC, fit_window=GK_FIT_WINDOW, dim=3,
                         tau_hat=None, full_output=False):
    """Self-diffusion coefficient (m^2/s) from a VACF by Green-Kubo with an exponential tail.

    ``lag_s`` (L,) = 0, dt, 2 dt, ... (s); ``vacf`` (L,) = <v(0).v(t)> (m^2/s^2, the
    ``dim``-dimensional dot product).  D = (1/dim) [int_0^t_c C dt + A tau_t exp(-t_c/tau_t)]:

    * tau_hat = :func:`correlation_time` (the e-folding time), unless given;
    * t_c = ``c_trunc`` * tau_hat rounded to the nearest lag; trapezoidal rule on [0, t_c];
    * A exp(-t/tau_t) fitted (least squares, linear in C) to the lags in
      ``fit_window`` * tau_hat (s), clipped to the available lags (at least 5 needed).

    Needs max lag >= fit_window[1] * tau_hat (about 3 tau, ~90 s in the gas) for the
    default window; otherwise the window is clipped to the lags there are.  With
    ``full_output`` returns a dict (D, tau_hat, t_c, integral, tail, A, tau_tail).
    Raises ValueError when the VACF does not decay (no tau_hat) or the window is too short.
    """
    lag, c = _check_lags(lag_s, vacf)
    if tau_hat is None:
        tau_hat = correlation_time(lag, c)
    dt = lag[1] - lag[0]
    kc = int(round(c_trunc * tau_hat / dt))
    if kc < 1 or kc >= len(lag):
        raise ValueError(f"truncation {c_trunc} x {tau_hat:.3g} s outside the lags (max {lag[-1]:g} s)")
    t_c = lag[kc]
    integral = float(np.sum(c[:kc + 1]) - 0.5 * (c[0] + c[kc])) * dt
    sel = (lag >= fit_window[0] * tau_hat - 1e-9) & (lag <= fit_window[1] * tau_hat + 1e-9)
    if sel.sum() < 5:
        raise ValueError(f"tail fit window {fit_window} x tau_hat has {sel.sum()} lags (need >= 5)")
    a, tau_t = _fit_exponential(lag[sel], c[sel], tau_hat)
    tail = a * tau_t * math.exp(-t_c / tau_t) if a > 0 else 0.0
    d = (integral + tail) / dim
    if full_output:
        return dict(D=d, tau_hat=tau_hat, t_c=float(t_c), integral=integral / dim, tail=tail / dim,
                    A=a, tau_tail=tau_t)
    return d


def _group_weights(G, weights):
    w = np.ones(G) if weights is None else np.asarray(weights, dtype=np.float64)
    if w.shape != (G,) or np.any(w <= 0):
        raise ValueError("weights must be (G,) and > 0 (e.g. particles per group)")
    return w


def green_kubo_jackknife(lag_s, vacf_groups, weights=None, **kw):
    """Delete-one-group jackknife of :func:`diffusion_green_kubo`.

    ``vacf_groups`` (G, L): the VACF of G disjoint particle groups; ``weights`` (G,): the
    particles per group (equal by default).  Returns ``(D_full, D_minus)`` with D_full the
    estimate from the weighted mean VACF and D_minus (G,) the estimates with one group
    left out (each re-estimates tau_hat).  ``kw`` go to :func:`diffusion_green_kubo`.
    """
    lag, cg = _check_lags(lag_s, vacf_groups)
    if cg.ndim != 2 or cg.shape[0] < 2:
        raise ValueError("vacf_groups must be (G, L) with G >= 2")
    G = cg.shape[0]
    w = _group_weights(G, weights)
    tot = w @ cg
    full = diffusion_green_kubo(lag, tot / w.sum(), **kw)
    minus = np.array([diffusion_green_kubo(lag, (tot - w[g] * cg[g]) / (w.sum() - w[g]), **kw)
                      for g in range(G)])
    return full, minus


def green_kubo_stderr(lag_s, vacf_groups, weights=None, **kw):
    """Jackknife standard error (m^2/s) of the Green-Kubo D of one run, over particle groups.

    SE^2 = (G-1)/G sum_g (D_-g - mean D_-g)^2, with D_-g the estimate without group g.
    Use with G-1 degrees of freedom (:func:`green_kubo_interval`).  The groups must be
    disjoint sets of particles (the run records' ``vacf_groups``: ``reduce.N_GROUPS`` = 8 groups
    of 108 particles)."""
    _, minus = green_kubo_jackknife(lag_s, vacf_groups, weights, **kw)
    G = len(minus)
    return float(np.sqrt((G - 1) / G * np.sum((minus - minus.mean()) ** 2)))


def green_kubo_interval(lag_s, vacf, vacf_groups, conf=0.95, weights=None, **kw):
    """(D, low, high, stderr) of one run: Green-Kubo D from ``vacf`` with a Student-t
    interval on G-1 degrees of freedom around it, SE from :func:`green_kubo_stderr`."""
    d = diffusion_green_kubo(lag_s, vacf, **kw)
    se = green_kubo_stderr(lag_s, vacf_groups, weights, **kw)
    G = np.shape(vacf_groups)[0]
    h = t_quantile(conf, G - 1) * se
    return d, d - h, d + h, se


def ols_msd(lag, msd, lo, hi, dim=3):
    """D (m^2/s) = slope / (2 dim) of a least-squares line through MSD(lag) (m^2) for lags in
    [lo, hi] (s) (dim = 3: slope / 6).
    ``msd`` may be (..., L): one D per leading index."""
    lag = np.asarray(lag, dtype=np.float64)
    msd = np.asarray(msd, dtype=np.float64)
    sel = (lag >= lo) & (lag <= hi)
    if sel.sum() < 3:
        raise ValueError(f"fit window [{lo}, {hi}] s has {sel.sum()} lags (max lag {lag[-1]:.1f} s)")
    x = lag[sel] - lag[sel].mean()
    y = msd[..., sel]
    slope = (y @ x) / (x @ x)
    return slope / (2.0 * dim)


def ols_msd_stderr(lag, msd_groups, lo, hi, weights=None, dim=3):
    """Delete-one-group jackknife SE (m^2/s) of :func:`ols_msd` from per-group MSDs (G, L)."""
    mg = np.asarray(msd_groups, dtype=np.float64)
    G = mg.shape[0]
    w = _group_weights(G, weights)
    tot = w @ mg
    minus = ols_msd(lag, (tot[None, :] - w[:, None] * mg) / (w.sum() - w)[:, None], lo, hi, dim)
    return float(np.sqrt((G - 1) / G * np.sum((minus - minus.mean()) ** 2)))
