"""The homogeneous cooling state (HCS) from binary collisions: the two-temperature balance.

A dilute gas of inelastic or frictional bodies cools; in its HCS the translational and rotational
temperatures T_tr and T_rot = r T_tr decay at one rate.  From binary collisions drawn at (T_tr,
r T_tr) with the collision-flux weight (relative speed g with density ~ g^3 exp(-mu g^2 / 2 T_tr),
impact parameter uniform over the collision disc, spins at equipartition at T_rot), the mean
changes per collision of the pair's translational and rotational energy, <dE_tr> and <dE_rot>,
give the temperatures' rates

    d ln T_tr / dt  = nu <dE_tr>  / (3 T_tr),     d ln T_rot / dt = nu <dE_rot> / (f_rot T_rot),

with nu = n A <g> the collision frequency of one body (A the disc's area, <g> = sqrt(16 T_tr /
(pi m)), f_rot the rotational degrees of freedom).  The HCS ratio r solves
<dE_rot> / (f_rot r) = <dE_tr> / 3 (``hcs_balance``), and the cooling rate is
zeta = -nu <dE_tr> / (3 T_tr), for spheres of diameter sigma in units of the Enskog frequency
omega = n pi sigma^2 <g>: zeta / omega = -<dE_tr> / (3 T_tr).

``sphere_collisions`` is the hard-sphere route: ``studies.hcs_theory.collide`` with a collision
rule (constant restitution, Walton's Coulomb friction), drawn as above; common random numbers across
r make the balance a smooth function of r.  It is independent of ``studies.hcs_theory``'s own
average (which draws Maxwellian pairs and weights by the approach speed), so agreement of the two is
a check of the draw and the balance (tests/test_predict_hcs.py).  Units SI; temperatures in joules.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from . import hcs_theory as ht

__all__ = ["HcsPrediction", "sphere_draws", "sphere_collisions", "hcs_balance"]


@dataclasses.dataclass(frozen=True)
class HcsPrediction:
    """The HCS from binary collisions: ratio r = T_rot / T_tr and zeta / omega, with standard errors."""
    ratio: float
    ratio_se: float
    zeta_over_omega: float
    zeta_over_omega_se: float


def _unit(rng, n):
    u = rng.standard_normal((n, 3))
    return u / np.linalg.norm(u, axis=1)[:, None]


def sphere_draws(n, seed=0):
    """Standard draws of ``n`` flux-weighted sphere collisions, rescaled by ``sphere_collisions``.

    Parameters
    ----------
    n : int
        Number of collisions.
    seed : int
        Seed of the generator.

    Returns
    -------
    dict
        ``x`` (mu g^2 / 2 T_tr, Gamma(2)), ``g_dir`` and ``normal`` (unit vectors: the relative
        velocity's direction and the contact normal from sphere 1 to sphere 2, at an impact
        parameter uniform over the disc), ``z1``, ``z2`` (standard normal spins).
    """
    rng = np.random.default_rng(seed)
    x = rng.gamma(2.0, 1.0, n)
    g_dir = _unit(rng, n)
    side = _unit(rng, n)
    side -= np.einsum("ij,ij->i", side, g_dir)[:, None] * g_dir
    side /= np.linalg.norm(side, axis=1)[:, None]
    s = np.sqrt(rng.uniform(size=n))                      # b / sigma, uniform over the disc
    normal = np.sqrt(1.0 - s * s)[:, None] * g_dir + s[:, None] * side
    return {"x": x, "g_dir": g_dir, "normal": normal,
            "z1": rng.standard_normal((n, 3)), "z2": rng.standard_normal((n, 3))}


def sphere_collisions(rule, kappa, ratio, draws, m=1.0, sigma=1.0, t_tr=1.0):
    """Per-collision energy changes of equal spheres at T_tr = ``t_tr`` and T_rot = ``ratio`` t_tr.

    Parameters
    ----------
    rule : callable
        ``rule(g_n, |g_t|, kappa) -> (e, beta)`` (``studies.hcs_theory.constant_beta_rule``,
        ``walton_rule``).
    kappa : float
        Reduced moment of inertia 4 I / (m sigma^2).
    ratio : float
        T_rot / T_tr.
    draws : dict
        ``sphere_draws``.
    m, sigma, t_tr : float
        Mass (kg), diameter (m), translational temperature (J).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        dE_tr and dE_rot of each collision (J).
    """
    g = np.sqrt(2.0 * t_tr / (m / 2.0) * draws["x"])[:, None] * draws["g_dir"]
    inertia = kappa * m * sigma * sigma / 4.0
    s_w = math.sqrt(ratio * t_tr / inertia)
    v1, v2 = 0.5 * g, -0.5 * g
    w1, w2 = s_w * draws["z1"], s_w * draws["z2"]
    v1n, v2n, w1n, w2n, _ = ht.collide(v1, v2, w1, w2, draws["normal"], rule, kappa, m, sigma)

    def sq(a):
        return np.einsum("ij,ij->i", a, a)

    d_tr = 0.5 * m * (sq(v1n) - sq(v1) + sq(v2n) - sq(v2))
    d_rot = 0.5 * inertia * (sq(w1n) - sq(w1) + sq(w2n) - sq(w2))
    return d_tr, d_rot


def _mean_se(a):
    return float(a.mean()), float(a.std(ddof=1) / math.sqrt(len(a)))


def hcs_balance(energy_changes, rot_dof=3, bracket=(1e-3, 10.0), t_tr=1.0):
    """Solve the two-temperature balance for the HCS ratio and the cooling rate.

    Parameters
    ----------
    energy_changes : callable
        ``energy_changes(ratio) -> (dE_tr, dE_rot)`` per-collision arrays at T_tr = ``t_tr``,
        T_rot = ratio t_tr, from one set of draws (common random numbers).
    rot_dof : int
        Rotational degrees of freedom (3 for spheres and aspherical clumps, 2 for linear ones).
    bracket : (float, float)
        Interval of r holding the root.
    t_tr : float
        The translational temperature of ``energy_changes`` (J).

    Returns
    -------
    HcsPrediction
        r, zeta / (n A <g>) and their standard errors over the collisions (delta method; r's
        through the balance's slope).
    """
    from scipy.optimize import brentq

    def per_collision(r):
        d_tr, d_rot = energy_changes(r)
        return d_rot / (rot_dof * r) - d_tr / 3.0

    ratio = brentq(lambda r: float(per_collision(r).mean()), *bracket, xtol=1e-10, rtol=1e-9)
    h = 1e-4 * ratio
    slope = (per_collision(ratio + h).mean() - per_collision(ratio - h).mean()) / (2.0 * h)
    _, res_se = _mean_se(per_collision(ratio))
    zeta, zeta_se = _mean_se(-energy_changes(ratio)[0] / (3.0 * t_tr))
    return HcsPrediction(ratio, float(res_se / abs(slope)), zeta, zeta_se)


def smooth_cooling(rule, draws, t_tr=1.0):
    """zeta / omega of smooth spheres (no rotation coupling), with its standard error.

    Parameters
    ----------
    rule : callable
        A collision rule with beta = -1 (``studies.hcs_theory.constant_beta_rule(e, -1)``).
    draws : dict
        ``sphere_draws``.
    t_tr : float
        Translational temperature (J).

    Returns
    -------
    (float, float)
        zeta / omega and its standard error.
    """
    d_tr, _ = sphere_collisions(rule, 0.4, 0.0, draws, t_tr=t_tr)
    return _mean_se(-d_tr / (3.0 * t_tr))
