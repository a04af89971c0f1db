"""Synthetic inputs of the gas study: Ornstein-Uhlenbeck walkers with a known D (for validating
the estimators) and angular velocities at equipartition (for a gas's initial state).

Pure functions of a numpy ``Generator``; units: s, m, m/s, kg m^2, J.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["simulate_ou", "equipartition_angular_velocities"]


def simulate_ou(rng, n_particles, n_frames, dt, tau, sigma_v, positions="exact", dim=3,
                v0=None, noise=None):
    """Exact samples of independent Ornstein-Uhlenbeck walkers at frames 0, dt, 2 dt, ...

    dv = -v/tau dt + sqrt(2/tau) sigma_v dW per component, started stationary
    (v(0) ~ N(0, sigma_v^2)) unless ``v0`` (N, dim) is given.  Per component
    <v(0) v(t)> = sigma_v^2 exp(-|t|/tau), so the 3-D VACF is dim sigma_v^2 exp(-t/tau) and
    D = sigma_v^2 tau (m^2/s).  Returns ``(vel, pos)`` each (n_frames, N, dim) (pos = None
    without ``positions``; pos[0] = 0), sampled from the exact joint Gaussian transition of
    (x, v) over one frame, so no time-step error.  ``positions="trapezoid"`` integrates the
    sampled velocities instead (half the random numbers; its D is sigma_v^2 tau
    (h/2) coth(h/2) = sigma_v^2 tau (1 + h^2/12 + ...), h = dt/tau: +8e-6 at h = 0.01);
    ``positions=False`` returns velocities only.  The arrays are transposed views of
    (N, dim, n_frames) memory (time contiguous, as the FFTs want it).  ``noise``
    (2, N, dim, n_frames-1) of standard normals may be given (to correlate two runs).
    """
    from scipy.signal import lfilter

    e = math.exp(-dt / tau)
    s2 = sigma_v ** 2
    var_v = s2 * (1 - e * e)
    var_x = 2 * s2 * tau * (dt - 2 * tau * (1 - e) + 0.5 * tau * (1 - e * e))
    cov_xv = s2 * tau * (1 - e) ** 2
    shape = (n_particles, dim, n_frames - 1)
    if noise is None:
        z1 = rng.standard_normal(shape)
        z2 = rng.standard_normal(shape) if positions == "exact" else None
    else:
        z1, z2 = noise[0], noise[1]
    if v0 is None:
        v0 = sigma_v * rng.standard_normal((n_particles, dim))
    # v_{k+1} = e v_k + sqrt(var_v) z1_k  as a linear filter along time
    drive = np.concatenate([np.asarray(v0, dtype=np.float64)[..., None], math.sqrt(var_v) * z1], axis=-1)
    vel = lfilter([1.0], [1.0, -e], drive, axis=-1)
    if not positions:
        return vel.transpose(2, 0, 1), None
    pos = np.zeros((n_particles, dim, n_frames))
    if positions == "trapezoid":
        np.cumsum(0.5 * dt * (vel[..., :-1] + vel[..., 1:]), axis=-1, out=pos[..., 1:])
        return vel.transpose(2, 0, 1), pos.transpose(2, 0, 1)
    if positions != "exact":
        raise ValueError(f"positions must be 'exact', 'trapezoid' or False, got {positions!r}")
    beta = cov_xv / var_v
    resid = math.sqrt(max(var_x - cov_xv ** 2 / var_v, 0.0))
    dx = (tau * (1 - e) - beta * e) * vel[..., :-1] + beta * vel[..., 1:] + resid * z2
    np.cumsum(dx, axis=-1, out=pos[..., 1:])
    return vel.transpose(2, 0, 1), pos.transpose(2, 0, 1)


def equipartition_angular_velocities(rng, inertia_principal, kT_per_dof, n, inactive=None):
    """Angular velocities (n, 3) rad/s in the body (principal) frame at equipartition.

    omega_j ~ N(0, kT_per_dof / I_j) for each active principal moment I_j (kg m^2), so that
    <I_j omega_j^2 / 2> = kT_per_dof / 2 (kT_per_dof in J: the mean of I w^2 per degree of
    freedom; for the gas, 2 E_trans / (3 N)).  ``inertia_principal`` (3,) or (n, 3).
    Axes with zero moment (<= 1e-12 of the largest), and axes marked in ``inactive``
    (bool (3,), e.g. the symmetry axis of a frictionless dimer, whose spin is never
    exchanged in collisions), get omega = 0.  Rotate with the principal axes for the lab frame.
    """
    I = np.broadcast_to(np.asarray(inertia_principal, dtype=np.float64), (n, 3))
    if np.any(I < 0) or not np.all(np.isfinite(I)):
        raise ValueError("principal moments must be finite and >= 0")
    if kT_per_dof < 0:
        raise ValueError("kT_per_dof must be >= 0")
    active = I > 1e-12 * I.max(axis=1, keepdims=True)
    if inactive is not None:
        active = active & ~np.asarray(inactive, dtype=bool)[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        sd = np.where(active, np.sqrt(kT_per_dof / np.where(active, I, 1.0)), 0.0)
    return sd * rng.standard_normal((n, 3))
