"""The homogeneous cooling state (HCS) of one run: temperatures, Haff's law, T_rot/T_tr, scaled MSD, homogeneity.

A dissipative run (``[material] restitution < 1`` or ``friction > 0``) starts from an equilibrated
elastic state (``gas.start = "equipartition"``) and cools from t = 0.  From its recorded frames
(``yade_scripts/granular_gas.py``'s npz) and its run file this module gives:

* :func:`temperatures`: per-particle temperatures in joules (Boltzmann's k = 1, the convention of
  :mod:`studies.hcs_theory`, T = m <v_x^2>): T_tr = 2 E_tr / (3 N), T_rot = 2 E_rot / (f_rot N), with
  f_rot the rotational degrees of freedom (:func:`rotational_dof`): 3 for spheres and aspherical
  clumps, 2 for linear clumps on the isotropic route (no spin about the axis).
* :func:`fit_haff`: T0 and tau0 of Haff's law T(t) = T0 / (1 + t / tau0)^2 by least squares on ln T
  over a window; the cooling rate at T0 is zeta0 = 2 / tau0 (zeta = -d ln T / dt, as in
  :func:`studies.hcs_theory.haff_cooling_rate`).
* :func:`temperature_ratio`: the HCS ratio T_rot / T_tr averaged over a window after its transient.
* :func:`fit_scaled_msd`: D0 from the MSD against the scaled time s = ln(1 + t / tau0), whose slope
  is 6 D0 tau0 in the HCS (Brilliantov and Poeschel 2000, :func:`studies.hcs_theory.hcs_msd`).
* :func:`msd_grid` and :func:`fit_scaled_msd_grid`: the same D0 from the MSD between every pair of
  a grid of frames (many time origins): in the HCS the displacement over a scaled-time interval
  depends on its length only, so every origin in the window measures the same slope.
* :func:`count_variance_ratio` and :func:`homogeneous_until`: the variance of particle counts in
  sub-cells over the binomial variance of a homogeneous gas, per frame, and the time it first rises
  above its sampling noise (the analysed window ends there: clusters have formed).
* :func:`haff_theory`: tau0 and zeta0 from kinetic theory for a sphere gas (Enskog frequency with
  the Carnahan-Starling contact value, Sonine-corrected Haff rate).

SI units throughout (m, kg, s, J).
"""
from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from . import hcs_theory

__all__ = ["rotational_dof", "temperatures", "fit_haff", "haff_amplitude", "temperature_ratio", "scaled_time", "msd_from_start",
           "fit_scaled_msd", "msd_grid", "fit_scaled_msd_grid", "count_variance_ratio", "homogeneous_until", "haff_theory", "series",
           "analyse_series", "analyse", "effect_observables", "CLUMP_TRANSIENT"]


def rotational_dof(run_input):
    """Rotational degrees of freedom f_rot of a run's particles.

    Parameters
    ----------
    run_input : dict
        The run file (:func:`studies.spec.run_input`).

    Returns
    -------
    int
        3 for spheres and aspherical clumps, 2 for linear clumps on the isotropic route.
    """
    body = run_input["body"]
    if body["builder"] == "sphere" or body["route"] == "aspherical":
        return 3
    return 2


def temperatures(e_trans, e_rot, n_particles, rot_dof):
    """Per-particle translational and rotational temperatures (J).

    Parameters
    ----------
    e_trans, e_rot : array_like
        Translational and rotational kinetic energy of the whole gas per frame (J).
    n_particles : int
        Number of particles N.
    rot_dof : int
        Rotational degrees of freedom f_rot of one particle.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        T_tr = 2 E_tr / (3 N) and T_rot = 2 E_rot / (f_rot N).
    """
    if n_particles < 1 or rot_dof not in (2, 3):
        raise ValueError(f"need n_particles >= 1 and rot_dof 2 or 3, got {n_particles}, {rot_dof}")
    t_tr = 2.0 * np.asarray(e_trans, float) / (3.0 * n_particles)
    t_rot = 2.0 * np.asarray(e_rot, float) / (rot_dof * n_particles)
    return t_tr, t_rot


def _window(t, t_lo, t_hi):
    t = np.asarray(t, float)
    hi = t[-1] if t_hi is None else t_hi
    sel = (t >= t_lo - 1e-12) & (t <= hi + 1e-12)
    if sel.sum() < 4:
        raise ValueError(f"the window [{t_lo:g}, {hi:g}] s holds {int(sel.sum())} frames; need >= 4")
    return sel


def fit_haff(t, temperature, t_lo=0.0, t_hi=None):
    """Fit Haff's law T(t) = T0 / (1 + t / tau0)^2 to a cooling curve.

    The fit is least squares on ln T (every frame weighs the same relative error), time measured
    from the start of the cooling.

    Parameters
    ----------
    t : array_like
        Times of the frames (s), 0 at the start of the cooling.
    temperature : array_like
        T_tr per frame (J).
    t_lo, t_hi : float, optional
        The window fitted (s); ``t_hi`` None: to the last frame.

    Returns
    -------
    dict
        ``t0`` (J), ``tau0`` (s), ``zeta0`` = 2 / tau0 (1/s), their standard errors ``t0_se``,
        ``tau0_se``, ``zeta0_se``, and ``rms_log`` the rms residual of ln T.

    Raises
    ------
    ValueError
        If the window holds fewer than 4 frames or a temperature is not positive.
    """
    t, temp = np.asarray(t, float), np.asarray(temperature, float)
    sel = _window(t, t_lo, t_hi)
    ts, ys = t[sel], temp[sel]
    if np.any(ys <= 0):
        raise ValueError("temperatures must be > 0")
    ly = np.log(ys)
    # first guess from the two ends: T^-1/2 is linear in t under Haff's law
    q = ys ** -0.5
    slope, icpt = np.polyfit(ts, q, 1)
    tau_guess = icpt / slope if slope > 0 else 10.0 * (ts[-1] - ts[0] + 1.0)

    def model(x, log_t0, log_tau0):
        return log_t0 - 2.0 * np.log1p(x / math.exp(log_tau0))

    p0 = (math.log(icpt ** -2) if icpt > 0 else ly[0], math.log(max(tau_guess, 1e-9)))
    par, cov = optimize.curve_fit(model, ts, ly, p0=p0, maxfev=10000)
    t0, tau0 = math.exp(par[0]), math.exp(par[1])
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    resid = ly - model(ts, *par)
    return {"t0": t0, "tau0": tau0, "zeta0": 2.0 / tau0, "t0_se": t0 * float(se[0]),
            "tau0_se": tau0 * float(se[1]), "zeta0_se": 2.0 / tau0 * float(se[1]),
            "rms_log": float(np.sqrt(np.mean(resid ** 2)))}


def haff_amplitude(t, temperature, tau0, t_lo=0.0, t_hi=None):
    """T0 of Haff's law T(t) = T0 / (1 + t / tau0)^2 with tau0 given: the geometric mean of
    T (1 + t / tau0)^2 over a window (least squares on ln T in the one free parameter).

    Parameters
    ----------
    t, temperature : array_like
        Times (s) and temperatures (J) per frame.
    tau0 : float
        Haff's time (s).
    t_lo, t_hi : float, optional
        The window (s); ``t_hi`` None: to the last frame.

    Returns
    -------
    float
        T0 (J).
    """
    t, temp = np.asarray(t, float), np.asarray(temperature, float)
    sel = _window(t, t_lo, t_hi)
    if np.any(temp[sel] <= 0) or not tau0 > 0:
        raise ValueError("temperatures and tau0 must be > 0")
    return float(np.exp(np.mean(np.log(temp[sel]) + 2.0 * np.log1p(t[sel] / tau0))))


def temperature_ratio(t, t_tr, t_rot, t_lo, t_hi=None, n_blocks=8):
    """The HCS ratio T_rot / T_tr averaged over a window after its transient.

    Parameters
    ----------
    t, t_tr, t_rot : array_like
        Times (s) and temperatures (J) per frame.
    t_lo, t_hi : float
        The window (s): ``t_lo`` after the transient; ``t_hi`` None: to the last frame.
    n_blocks : int, optional
        Consecutive blocks whose means give the standard error (frames are correlated).

    Returns
    -------
    dict
        ``ratio`` (the mean of T_rot / T_tr per frame), ``se`` (block standard error), ``n_frames``.
    """
    sel = _window(t, t_lo, t_hi)
    r = np.asarray(t_rot, float)[sel] / np.asarray(t_tr, float)[sel]
    nb = max(2, min(n_blocks, len(r) // 2))
    blocks = np.array([b.mean() for b in np.array_split(r, nb)])
    return {"ratio": float(r.mean()), "se": float(blocks.std(ddof=1) / math.sqrt(nb)), "n_frames": int(len(r))}


def scaled_time(t, tau0):
    """Brilliantov and Poeschel's scaled time s = ln(1 + t / tau0) (dimensionless)."""
    return np.log1p(np.asarray(t, float) / tau0)


def msd_from_start(disp):
    """Mean-square displacement from the first frame, averaged over particles.

    Parameters
    ----------
    disp : array_like, shape (n_frames, N, 3)
        Unwrapped displacements of every particle (m).

    Returns
    -------
    numpy.ndarray
        MSD per frame (m^2).
    """
    d = np.asarray(disp, float)
    return np.mean(np.sum((d - d[0]) ** 2, axis=2), axis=1)


def fit_scaled_msd(t, msd, tau0, t_lo=0.0, t_hi=None):
    """D0, the HCS self-diffusion coefficient at T0, from the MSD against s = ln(1 + t / tau0).

    In the HCS MSD = 6 D0 tau0 s once the ballistic start is over; a straight line a + b s fitted
    over the window gives D0 = b / (6 tau0) (the intercept takes the ballistic offset).

    Parameters
    ----------
    t, msd : array_like
        Times (s) and MSD (m^2) per frame.
    tau0 : float
        Haff's time (s), from :func:`fit_haff`.
    t_lo, t_hi : float, optional
        The window (s).

    Returns
    -------
    dict
        ``d0`` (m^2/s), ``d0_se`` (the slope's OLS standard error, an underestimate for correlated
        frames), ``intercept`` (m^2).
    """
    sel = _window(t, t_lo, t_hi)
    s, y = scaled_time(np.asarray(t, float)[sel], tau0), np.asarray(msd, float)[sel]
    (b, a), cov = np.polyfit(s, y, 1, cov=True)
    return {"d0": float(b / (6.0 * tau0)), "d0_se": float(math.sqrt(max(cov[0, 0], 0.0)) / (6.0 * tau0)),
            "intercept": float(a)}


# frames of the multi-origin MSD grid a reduced record keeps (G (G - 1) / 2 MSD values)
GRID_FRAMES = 48
# the shortest scaled-time lag the multi-origin fit uses: past the velocity's memory, which lasts a
# few collisions, about 0.1 in s at e = 0.9 (shorter lags move the weakly rough DSMC gas's D ratio,
# studies.hcs_estimator)
GRID_MIN_LAG = 0.2


def msd_grid(t, disp, n_grid=GRID_FRAMES):
    """The MSD between every pair of a grid of frames (every grid frame an origin).

    Parameters
    ----------
    t : array_like, shape (n_frames,)
        Times of the frames (s).
    disp : array_like, shape (n_frames, N, 3)
        Unwrapped displacements of every particle (m).
    n_grid : int, optional
        Grid frames, evenly spaced in frame number from the first to the last.

    Returns
    -------
    dict
        ``grid_t`` (G,) the grid frames' times (s), ``grid_msd`` (G (G - 1) / 2,) the MSD between grid
        frames i < j averaged over particles (m^2), row by row: (0, 1), (0, 2), ..., (0, G - 1), (1, 2), ...
    """
    t, d = np.asarray(t, float), np.asarray(disp, float)
    if d.ndim != 3 or len(d) != len(t) or d.shape[2] != 3:
        raise ValueError(f"need disp of shape (n_frames, N, 3) with n_frames = len(t) = {len(t)}, got {d.shape}")
    idx = np.unique(np.round(np.linspace(0, len(t) - 1, min(int(n_grid), len(t)))).astype(int))
    g = d[idx]
    msd = np.concatenate([np.mean(np.sum((g[i + 1:] - g[i]) ** 2, axis=2), axis=1) for i in range(len(idx) - 1)]
                         or [np.zeros(0)])
    return {"grid_t": t[idx], "grid_msd": msd}


def fit_scaled_msd_grid(grid_t, grid_msd, tau0, t_lo=0.0, t_hi=None, min_lag=GRID_MIN_LAG):
    """D0, the HCS self-diffusion coefficient at T0, from the multi-origin MSD of :func:`msd_grid`.

    In the HCS a particle's displacement per unit scaled time s = ln(1 + t / tau0) is stationary
    (dr/ds = v (tau0 + t), and v falls as 1 / (1 + t / tau0)), so the MSD between two times is
    6 D0 tau0 (s2 - s1) + a, with a the ballistic offset, once s2 - s1 is past the velocity's memory.
    A straight line in s2 - s1 fitted over every pair of grid frames inside the window whose lag is at
    least ``min_lag`` gives D0 = slope / (6 tau0): every origin in the window contributes, not the
    first frame alone (:func:`fit_scaled_msd`).  The fit weighs each pair by 1 / lag^2, as the MSD's
    scatter grows in proportion to its lag.

    Parameters
    ----------
    grid_t, grid_msd : array_like
        :func:`msd_grid`'s ``grid_t`` (s) and ``grid_msd`` (m^2).
    tau0 : float
        Haff's time (s).
    t_lo, t_hi : float, optional
        The window (s): both frames of a pair inside it.
    min_lag : float, optional
        The shortest lag in s.

    Returns
    -------
    dict
        ``d0`` (m^2/s), ``intercept`` (m^2), ``n_pairs`` (grid pairs fitted).

    Raises
    ------
    ValueError
        If the grid's sizes disagree, or fewer than 4 pairs with two distinct lags are in the window.
    """
    gt, gm = np.asarray(grid_t, float), np.asarray(grid_msd, float)
    g = len(gt)
    if gm.shape != (g * (g - 1) // 2,):
        raise ValueError(f"a grid of {g} frames has {g * (g - 1) // 2} pair MSDs, got {gm.shape}")
    if not tau0 > 0:
        raise ValueError(f"need tau0 > 0, got {tau0}")
    i, j = np.triu_indices(g, 1)
    s = scaled_time(gt, tau0)
    lag = s[j] - s[i]
    hi = gt[-1] if t_hi is None else t_hi
    sel = (gt[i] >= t_lo - 1e-12) & (gt[j] <= hi + 1e-12) & (lag >= min_lag)
    if sel.sum() < 4 or np.ptp(lag[sel]) <= 0:
        raise ValueError(f"the window [{t_lo:g}, {hi:g}] s holds {int(sel.sum())} grid pairs {min_lag:g} or more "
                         f"apart in scaled time; need >= 4")
    b, a = np.polyfit(lag[sel], gm[sel], 1, w=1.0 / lag[sel])       # polyfit's w multiplies the residuals
    return {"d0": float(b / (6.0 * tau0)), "intercept": float(a), "n_pairs": int(sel.sum())}


def _cells(pos, box, m):
    """The flat index of the cell of each position (..., 3) in a periodic box cut into m^3 cells."""
    idx = np.floor(np.mod(pos, box) / box * m).astype(int) % m
    return (idx[..., 0] * m + idx[..., 1]) * m + idx[..., 2]


def count_variance_ratio(pos, box, cells_per_side):
    """Variance of particle counts in sub-cells over that of a homogeneous (binomial) gas.

    Parameters
    ----------
    pos : array_like, shape (N, 3) or (n_frames, N, 3)
        Positions (m); wrapped into the periodic box here.
    box : float
        Edge of the cubic periodic box (m).
    cells_per_side : int
        The box is cut into cells_per_side^3 cubic cells.

    Returns
    -------
    float or numpy.ndarray
        Var(counts) / (N p (1 - p)), p = 1 / cells_per_side^3: about 1 for a homogeneous gas
        (sampling noise sqrt(2 / (M - 1)) for M cells), above it where particles cluster.
    """
    p = np.asarray(pos, float)
    single = p.ndim == 2
    p = p[None] if single else p
    m = int(cells_per_side)
    flat = _cells(p, box, m)
    n = p.shape[1]
    prob = 1.0 / m ** 3
    out = np.array([np.bincount(f, minlength=m ** 3).var() for f in flat]) / (n * prob * (1 - prob))
    return float(out[0]) if single else out


def flow_energy_ratio(pos, vel, box, cells_per_side):
    """Kinetic energy of the coarse-grained flow over that of a gas without velocity correlations.

    A cooling gas can stay homogeneous in density while its shear modes grow into vortices (the
    first instability of the HCS, Goldhirsch and Zanetti 1993); the energy of the cell-averaged
    velocity field measures them.  In each of the cells_per_side^3 cells the sum of the velocities
    (the gas's mean velocity removed) is S_c over n_c particles; a gas whose particles move
    independently has sum_c |S_c|^2 / n_c = 3 (M' - 1) sigma^2 on average for M' occupied cells, and
    sum_i |v_i|^2 = 3 (N - 1) sigma^2.

    Parameters
    ----------
    pos, vel : array_like, shape (N, 3) or (n_frames, N, 3)
        Positions (m; wrapped into the periodic box here) and translational velocities (m/s).
    box : float
        Edge of the cubic periodic box (m).
    cells_per_side : int
        The box is cut into cells_per_side^3 cubic cells.

    Returns
    -------
    float or numpy.ndarray
        [sum_c |S_c|^2 / n_c / (M' - 1)] / [sum_i |v_i|^2 / (N - 1)]: about 1 without correlations
        (sampling noise sqrt(2 / (3 (M - 1)))), above it where velocities are correlated within a
        cell, and growing with the vortices of a shear instability; NaN for a frame
        with one occupied cell or no motion.
    """
    p, v = np.asarray(pos, float), np.asarray(vel, float)
    if p.shape != v.shape or p.shape[-1] != 3 or p.ndim not in (2, 3):
        raise ValueError(f"positions {p.shape} and velocities {v.shape} must both be (N, 3) or (n_frames, N, 3)")
    if p.shape[-2] < 2 or int(cells_per_side) < 1:
        raise ValueError(f"need 2 or more particles and 1 or more cells per side, got {p.shape[-2]} and {cells_per_side}")
    single = p.ndim == 2
    p, v = (p[None], v[None]) if single else (p, v)
    m = int(cells_per_side)
    flat = _cells(p, box, m)
    n = p.shape[1]
    out = np.full(len(p), np.nan)
    for k, (f, vk) in enumerate(zip(flat, v)):
        vk = vk - vk.mean(axis=0)
        counts = np.bincount(f, minlength=m ** 3)
        sums = np.stack([np.bincount(f, vk[:, d], minlength=m ** 3) for d in range(3)], axis=1)
        occupied = counts > 0
        total = np.sum(vk ** 2)
        if occupied.sum() < 2 or not total > 0:         # one cell, or a gas at rest: no flow to compare
            continue
        flow = np.sum(np.sum(sums[occupied] ** 2, axis=1) / counts[occupied]) / (int(occupied.sum()) - 1)
        out[k] = flow / (total / (n - 1))
    return float(out[0]) if single else out


def homogeneous_until(t, ratio, n_cells, z=3.0, n_consecutive=3, min_duration=1.0):
    """The time the gas stops being homogeneous: the count-variance ratio leaves its noise band.

    Parameters
    ----------
    t, ratio : array_like
        Times (s) and :func:`count_variance_ratio` per frame.
    n_cells : int
        Number of cells M the ratio was computed with.
    z : float, optional
        Band half-width in standard deviations of the ratio of a homogeneous gas, sqrt(2 / (M - 1)).
    n_consecutive : int, optional
        Frames in a row above the band that count as clustering (one noisy frame does not).
    min_duration : float, optional
        And the time (s) they must span: frames a fraction of a mean free time apart are
        correlated, so a fluctuation of the counts lasts several frames and then reverts, while a
        cluster lasts many collision times.

    Returns
    -------
    float
        The time of the first of a run of frames above 1 + z sqrt(2 / (M - 1)) that holds at least
        ``n_consecutive`` frames and spans at least ``min_duration``; the last frame's time if
        the gas stays homogeneous.
    """
    t, r = np.asarray(t, float), np.asarray(ratio, float)
    limit = 1.0 + z * math.sqrt(2.0 / (n_cells - 1))
    above = r > limit
    start = None
    for k, a in enumerate(above):
        start = (k if start is None else start) if a else None
        if start is not None and k - start + 1 >= n_consecutive and t[k] - t[start] >= min_duration - 1e-12:
            return float(t[start])
    return float(t[-1])


def window_end(series):
    """The end (s) of a run's analysed window: :func:`homogeneous_until` of its series."""
    return homogeneous_until(np.asarray(series["t"], float), np.asarray(series["count_ratio"], float),
                             int(series["cells_per_side"]) ** 3)


def haff_theory(n_particles, box, diameter, mass, t0, restitution):
    """Haff's tau0 and zeta0 of smooth inelastic spheres from kinetic theory (:mod:`studies.hcs_theory`).

    Parameters
    ----------
    n_particles : int
        Number of spheres.
    box : float
        Edge of the cubic periodic box (m).
    diameter, mass : float
        The spheres' diameter (m) and mass (kg).
    t0 : float
        Initial translational temperature (J).
    restitution : float
        Normal coefficient of restitution e.

    Returns
    -------
    dict
        ``zeta0`` (1/s, with the Sonine correction), ``tau0`` = 2 / zeta0 (s), ``omega0`` (the Enskog
        collision frequency at T0, 1/s), ``chi`` (Carnahan-Starling contact value) and ``phi``.
    """
    n = n_particles / box ** 3
    phi = n * math.pi / 6.0 * diameter ** 3
    chi = (1.0 - phi / 2.0) / (1.0 - phi) ** 3
    omega = float(hcs_theory.enskog_frequency(n, diameter, mass, t0, chi))
    zeta = hcs_theory.haff_cooling_rate(restitution, omega)
    return {"zeta0": zeta, "tau0": 2.0 / zeta, "omega0": omega, "chi": chi, "phi": phi}


def series(frames, run_input, cells_per_side=4):
    """The per-frame series of a run that :func:`analyse_series` needs: what a reduced run record
    keeps of a dissipative run (:func:`studies.reduce.reduce_run`), so that the analysis needs no
    raw frames.

    Parameters
    ----------
    frames : mapping
        The run's recorded frames (``t``, ``disp``, ``e_trans``, ``e_rot``; ``pos0``, else the run
        file's initial positions).
    run_input : dict
        The run file.
    cells_per_side : int, optional
        Cells per box edge of the homogeneity check.

    Returns
    -------
    dict
        ``t`` (s), ``e_trans`` and ``e_rot`` (J, whole gas), ``msd`` (:func:`msd_from_start`, m^2),
        ``grid_t`` and ``grid_msd`` (:func:`msd_grid`),
        ``count_ratio`` (:func:`count_variance_ratio`), ``flow_ratio`` (:func:`flow_energy_ratio`, when the
        frames hold velocities ``vel``), and ``cells_per_side``, ``n_particles``,
        ``rot_dof``, ``box_length`` (m), the body's ``builder``, ``mass`` (kg) and ``diameter`` (m,
        spheres; None for clumps), the contact's ``restitution`` and ``friction``.
    """
    body, mat = run_input["body"], run_input.get("material", {})
    disp = np.asarray(frames["disp"], float)
    pos0 = np.asarray(frames["pos0"] if "pos0" in frames else run_input["initial"]["pos"], float)
    return {"t": np.asarray(frames["t"], float), "e_trans": np.asarray(frames["e_trans"], float),
            "e_rot": np.asarray(frames["e_rot"], float), "msd": msd_from_start(disp),
            **msd_grid(frames["t"], disp),
            "count_ratio": count_variance_ratio(pos0[None] + disp, float(run_input["box_length"]), cells_per_side),
            **({"flow_ratio": flow_energy_ratio(pos0[None] + disp, frames["vel"], float(run_input["box_length"]),
                                                cells_per_side)} if "vel" in frames else {}),
            "cells_per_side": int(cells_per_side), "n_particles": int(len(pos0)),
            "rot_dof": rotational_dof(run_input), "box_length": float(run_input["box_length"]),
            "builder": body["builder"], "mass": float(body["mass"]),
            "diameter": 2.0 * float(body["radius"]) if body["builder"] == "sphere" else None,
            "restitution": float(mat.get("restitution", 1.0)), "friction": float(mat.get("friction", 0.0))}


def analyse_series(s, t_transient=0.0, fit_from=0.0):
    """The HCS quantities from a run's :func:`series` (or the ``hcs`` part of its reduced record).

    Parameters
    ----------
    s : mapping
        :func:`series` of the run.
    t_transient : float, optional
        Frames before it are left out of the T_rot / T_tr average and the MSD fit (s).
    fit_from : float, optional
        Frames before it are left out of Haff's fit (s): 0 for a gas that starts in its HCS
        (smooth spheres), the transient for one that does not (clumps from equipartition).

    Returns
    -------
    dict
        ``t_end_homogeneous`` (s, where the analysed window ends), ``haff`` (:func:`fit_haff` on
        T_tr up to it), ``ratio`` (:func:`temperature_ratio`, None without rotation), ``msd``
        (:func:`fit_scaled_msd`), ``rot_dof``.
    """
    t, e_trans, e_rot = (np.asarray(s[k], float) for k in ("t", "e_trans", "e_rot"))
    f_rot = int(s["rot_dof"])
    t_tr, t_rot = temperatures(e_trans, e_rot, int(s["n_particles"]), f_rot)
    t_hom = window_end(s)
    haff = fit_haff(t, t_tr, fit_from, t_hom)
    rot = (temperature_ratio(t, t_tr, t_rot, t_transient, t_hom)
           if np.max(e_rot) > 1e-9 * e_trans[0] and t_transient < t_hom else None)
    msd = fit_scaled_msd(t, np.asarray(s["msd"], float), haff["tau0"], min(t_transient, t[-4]), t_hom)
    return {"t_end_homogeneous": t_hom, "haff": haff, "ratio": rot, "msd": msd, "rot_dof": f_rot}


# s of a clump gas's start (equipartition, T_rot = T_tr) left out of every fit: past it the
# frictionless gases' T_rot / T_tr is at its HCS value, while in some frictional groups it still
# relaxes (hcs_relaxation.csv and hcs_settling.csv measure how far; docs/hcs.md)
CLUMP_TRANSIENT = 5.0


def energy_tau0(series, t_transient=CLUMP_TRANSIENT):
    """Haff's tau0 (s) of a run from its total kinetic energy, between ``t_transient`` and the end
    of its homogeneous window (:func:`window_end`).  The total, not T_tr: only the collisions'
    dissipation changes it (T_tr also trades energy with rotation), and in the HCS both decay at
    one rate."""
    t = np.asarray(series["t"], float)
    e = np.asarray(series["e_trans"], float) + np.asarray(series["e_rot"], float)
    return fit_haff(t, e, t_transient, window_end(series))["tau0"]


def effect_observables(series, t_transient=CLUMP_TRANSIENT):
    """The observables whose case / exact ratios are a clump case's effect in the HCS
    (:mod:`studies.hcs_effects`, and the sequential design of cooling groups, :mod:`studies.design`).

    Parameters
    ----------
    series : mapping
        The run's :func:`series` (its record's ``hcs`` part).
    t_transient : float, optional
        Frames before it (s) are left out of every fit.

    Returns
    -------
    dict
        ``cooling_rate`` (1/s) and ``diffusion`` (m^2/s, from the MSD from the first frame) at the start
        temperature, ``temperature_ratio`` (NaN without rotation), ``diffusion_grid`` (m^2/s, from the
        multi-origin MSD grid; NaN when the series has none).
    """
    a = analyse_series(series, t_transient=t_transient, fit_from=t_transient)
    t, e_tr, e_rot = (np.asarray(series[k], float) for k in ("t", "e_trans", "e_rot"))
    t_tr, _ = temperatures(e_tr, e_rot, int(series["n_particles"]), int(series["rot_dof"]))
    t_hom = a["t_end_homogeneous"]
    tau0 = energy_tau0(series, t_transient)
    # zeta and D of a cooling gas scale as sqrt(T_tr): both at the start temperature, which every case
    # of a paired seed shares (per unit mass), not at the fit's T0, which the transient moves
    scale = math.sqrt(t_tr[0] / haff_amplitude(t, t_tr, tau0, t_transient, t_hom))
    msd = fit_scaled_msd(t, np.asarray(series["msd"], float), tau0, min(t_transient, t[-4]), t_hom)
    grid = (fit_scaled_msd_grid(series["grid_t"], series["grid_msd"], tau0, t_transient, t_hom)["d0"] * scale
            if "grid_msd" in series else float("nan"))
    return {"cooling_rate": 2.0 / tau0 * scale,
            "temperature_ratio": a["ratio"]["ratio"] if a["ratio"] is not None else float("nan"),
            "diffusion": msd["d0"] * scale, "diffusion_grid": grid}


def analyse(frames, run_input, t_transient=0.0, cells_per_side=4):
    """The HCS quantities of one run: :func:`analyse_series` of its :func:`series`.

    Parameters
    ----------
    frames : mapping
        The run's recorded frames (``t``, ``disp``, ``e_trans``, ``e_rot``; ``pos0``).
    run_input : dict
        The run file.
    t_transient : float, optional
        Frames before it are left out of the T_rot / T_tr average (s).
    cells_per_side : int, optional
        Cells per box edge of the homogeneity check.

    Returns
    -------
    dict
        As :func:`analyse_series`.
    """
    return analyse_series(series(frames, run_input, cells_per_side), t_transient)
