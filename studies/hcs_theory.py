"""Kinetic theory of the homogeneous cooling state (HCS): the references the dissipative gases are checked against.

A dilute gas of inelastic spheres (diameter sigma, mass m, moment of inertia I, number density n)
cools homogeneously until clusters form.  In the Maxwellian approximation (the velocity and
angular-velocity distributions are Gaussians of temperatures T_tr and T_rot; T = m <v_x^2>, in
joules) the collision frequency of one sphere is the Enskog frequency

    omega = 4 sqrt(pi) n sigma^2 chi sqrt(T_tr / m)

and every rate below is omega times a number that depends on the collision rule alone.

Smooth spheres (normal restitution e, no friction):

* ``haff_cooling_rate``: zeta = (1 - e^2) omega / 3, times (1 + 3 a2 / 16) with the second Sonine
  coefficient ``sonine_a2`` (van Noije and Ernst, Granular Matter 1, 57 (1998)).
* ``haff_temperature``: Haff's law T(t) = T0 / (1 + t / tau0)^2 with tau0 = 2 / zeta(T0).

Rough spheres with a constant tangential restitution beta (-1 smooth, +1 perfectly rough) and the
reduced moment of inertia kappa = 4 I / (m sigma^2) (2/5 for a solid sphere), after Huthmann and
Zippelius, PRE 56, R6275 (1997) and Luding, Huthmann, McNamara and Zippelius, PRE 58, 3416 (1998):

    dT_tr/dt  = -G sqrt(T_tr) (A T_tr - B T_rot)
    dT_rot/dt =  G sqrt(T_tr) (B T_tr - C T_rot),          G sqrt(T_tr) = (4/3) omega

with eta = kappa (1 + beta) / (2 (1 + kappa)), A = (1 - e^2)/4 + eta (1 - eta), B = eta^2 / kappa,
C = (eta / kappa)(1 - eta / kappa) (``rough_coefficients``).  The HCS ratio r = T_rot / T_tr is the
positive root of B r^2 + (C - A) r - B = 0 (``hcs_temperature_ratio``).  (In three dimensions
both temperatures carry three degrees of freedom, so one G serves both equations and a perfectly
rough elastic gas conserves T_tr + T_rot.)

Self-diffusion in the HCS (Brilliantov and Poeschel, PRE 61, 1716 (2000); Bodrova and
Brilliantov, Granular Matter 14, 85 (2012) for rough spheres): the tagged sphere's velocity
relaxes at nu_D = (2/3) omega ((1 + e)/2 + eta), the temperature decays at zeta, and

    D(t) = T_tr(t) / (m (nu_D - zeta / 2)),   MSD(t) = 6 D(0) tau0 ln(1 + t / tau0)

(``hcs_diffusion``, ``hcs_msd``): the MSD is linear in the scaled time ln(1 + t / tau0).

Any other collision rule (Walton's Coulomb friction, ``walton_rule``) enters through
``collision_averages``: a Monte Carlo average of the energy and momentum changes over collisions of
Maxwellian pairs, weighted by the approach speed, which is exact in the Maxwellian approximation up
to its standard error; ``hcs_ratio_for_rule`` solves for the HCS temperature ratio.  The constant-beta
closed forms above are the special case (tests/test_hcs_theory.py checks one against the other).

Accuracy of the Maxwellian approximation (stated by the sources): the HCS temperature ratio within
a few per cent of the Sonine result for e >= 0.8 (Santos, Kremer and dos Santos, Phys. Fluids 23,
030604 (2011)); a2 changes zeta by 3 a2 / 16, which is below 0.3 % for e = 0.9.

Nothing here knows YADE or the study engine.  SI units throughout (m, kg, s, J).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

__all__ = [
    "enskog_frequency", "sonine_a2", "haff_cooling_rate", "haff_temperature", "rough_coefficients",
    "hcs_temperature_ratio", "hcs_cooling_rate", "velocity_relaxation_rate", "hcs_diffusion", "hcs_msd",
    "constant_beta_rule", "walton_rule", "collide", "CollisionAverages", "collision_averages", "hcs_ratio_for_rule",
]


def enskog_frequency(n, sigma, m, t_tr, chi=1.0):
    """Collisions per unit time of one sphere in a Maxwellian gas.

    :param n: number density (1/m^3)
    :param sigma: diameter (m)
    :param m: mass (kg)
    :param t_tr: translational temperature m <v_x^2> (J)
    :param chi: Enskog contact factor (1 in the dilute limit)
    :returns: omega = 4 sqrt(pi) n sigma^2 chi sqrt(t_tr / m) (1/s)
    """
    return 4.0 * math.sqrt(math.pi) * n * sigma ** 2 * chi * np.sqrt(t_tr / m)


def sonine_a2(e):
    """Second Sonine coefficient of the smooth-sphere HCS, d = 3 (van Noije and Ernst 1998).

    :param e: normal restitution, 0 <= e <= 1
    :returns: a2 = 16 (1 - e)(1 - 2 e^2) / (81 - 17 e + 30 e^2 (1 - e))
    """
    e = float(e)
    return 16.0 * (1.0 - e) * (1.0 - 2.0 * e * e) / (81.0 - 17.0 * e + 30.0 * e * e * (1.0 - e))


def haff_cooling_rate(e, omega, sonine=True):
    """Cooling rate zeta = -d ln T / dt of smooth inelastic spheres.

    :param e: normal restitution
    :param omega: Enskog collision frequency (``enskog_frequency``)
    :param sonine: include the second Sonine correction (1 + 3 a2 / 16)
    :returns: zeta (1/s)
    """
    zeta = (1.0 - e * e) * omega / 3.0
    return zeta * (1.0 + 3.0 * sonine_a2(e) / 16.0) if sonine else zeta


def haff_temperature(t, t0, tau0):
    """Haff's law T(t) = T0 / (1 + t / tau0)^2, tau0 = 2 / zeta(T0)."""
    return t0 / (1.0 + np.asarray(t, dtype=float) / tau0) ** 2


def _eta(beta, kappa):
    return kappa * (1.0 + beta) / (2.0 * (1.0 + kappa))


def rough_coefficients(e, beta, kappa):
    """The coefficients (A, B, C) of the two-temperature cooling equations (module docstring).

    :param e: normal restitution
    :param beta: tangential restitution, -1 (smooth) to +1 (perfectly rough)
    :param kappa: reduced moment of inertia 4 I / (m sigma^2)
    :returns: (A, B, C)
    """
    eta = _eta(beta, kappa)
    a = (1.0 - e * e) / 4.0 + eta * (1.0 - eta)
    b = eta * eta / kappa
    c = (eta / kappa) * (1.0 - eta / kappa)
    return a, b, c


def hcs_temperature_ratio(e, beta, kappa):
    """T_rot / T_tr in the homogeneous cooling state of rough spheres (Huthmann and Zippelius 1997).

    :raises ValueError: for smooth spheres (beta = -1), whose rotation never couples to translation
    """
    a, b, c = rough_coefficients(e, beta, kappa)
    if b <= 0.0:
        raise ValueError("smooth spheres (beta = -1) have no HCS temperature ratio: rotation does not couple")
    p = a - c
    return (p + math.sqrt(p * p + 4.0 * b * b)) / (2.0 * b)


def hcs_cooling_rate(e, beta, kappa, omega):
    """zeta = -d ln T_tr / dt in the HCS of rough spheres (omega at the current T_tr)."""
    a, b, _ = rough_coefficients(e, beta, kappa)
    r = hcs_temperature_ratio(e, beta, kappa) if b > 0.0 else 0.0
    return 4.0 / 3.0 * omega * (a - b * r)


def velocity_relaxation_rate(e, beta, kappa, omega):
    """nu_D = (2/3) omega ((1 + e)/2 + eta): the tagged sphere's velocity decorrelation rate."""
    return 2.0 / 3.0 * omega * ((1.0 + e) / 2.0 + _eta(beta, kappa))


def hcs_diffusion(t_tr, m, nu_d, zeta):
    """Self-diffusion coefficient in the HCS, D = T_tr / (m (nu_D - zeta / 2)) (m^2/s)."""
    return t_tr / (m * (nu_d - zeta / 2.0))


def hcs_msd(t, d0, tau0):
    """Mean-square displacement in the HCS: 6 D(0) tau0 ln(1 + t / tau0) (m^2)."""
    return 6.0 * d0 * tau0 * np.log1p(np.asarray(t, dtype=float) / tau0)


def constant_beta_rule(e, beta):
    """A collision rule with constant normal and tangential restitution (for ``collision_averages``)."""
    def rule(g_n, g_t, kappa):
        return np.full_like(g_n, e), np.full_like(g_n, beta)
    return rule


def walton_rule(e, mu, beta0):
    """Walton's rule for Coulomb friction: beta = min(beta0, -1 + mu (1 + e)(1 + 1/kappa) g_n / |g_t|).

    Sticking impacts rebound with beta0; sliding ones lose the tangential impulse that Coulomb's
    law allows (Walton, Mech. Mater. 16, 239 (1993); Luding et al. 1998).

    :param e: normal restitution
    :param mu: friction coefficient
    :param beta0: tangential restitution of sticking impacts
    """
    def rule(g_n, g_t, kappa):
        with np.errstate(divide="ignore", invalid="ignore"):
            sliding = -1.0 + mu * (1.0 + e) * (1.0 + 1.0 / kappa) * g_n / g_t
        return np.full_like(g_n, e), np.minimum(beta0, sliding)
    return rule


@dataclasses.dataclass(frozen=True)
class CollisionAverages:
    """Per-collision averages over Maxwellian pairs (T = m <v_x^2>, joules), with standard errors.

    ``d_e_tr``, ``d_e_rot``: mean change of the pair's translational and rotational energy per
    collision; ``d_v_dot_v``: mean of (v1' - v1) . v1, the tagged sphere's momentum loss.
    """
    d_e_tr: float
    d_e_tr_se: float
    d_e_rot: float
    d_e_rot_se: float
    d_v_dot_v: float
    d_v_dot_v_se: float


def _weighted_mean(w, x):
    s = w.sum()
    mean = float((w * x).sum() / s)
    return mean, float(math.sqrt((w * w * (x - mean) ** 2).sum()) / s)


def _maxwellian_pairs(rng, size):
    return {"v1": rng.standard_normal((size, 3)), "v2": rng.standard_normal((size, 3)),
            "w1": rng.standard_normal((size, 3)), "w2": rng.standard_normal((size, 3)),
            "n": _unit_vectors(rng, size)}


def _unit_vectors(rng, size):
    x = rng.standard_normal((size, 3))
    return x / np.linalg.norm(x, axis=1)[:, None]


def collide(v1, v2, w1, w2, n, rule, kappa, m=1.0, sigma=1.0):
    """Post-collision velocities of equal rough spheres (arrays of shape (k, 3), one row a pair).

    Sphere 2 touches sphere 1 at x1 + (sigma/2) n.  The contact points' relative velocity is
    g = v1 - v2 + (sigma/2)(w1 + w2) x n; the rule gives (e, beta) and the impulse on sphere 1,
    P = -m (1 + e) g_n n / 2 - m eta g_t with eta = kappa (1 + beta) / (2 (1 + kappa)), turns the
    normal part of g into -e g_n and the tangential part into -beta g_t.  Pairs that do not
    approach (g_n <= 0) are returned unchanged.

    :param rule: ``rule(g_n, |g_t|, kappa) -> (e, beta)`` (``constant_beta_rule``, ``walton_rule``)
    :param kappa: reduced moment of inertia 4 I / (m sigma^2)
    :returns: (v1', v2', w1', w2', g_n) with g_n the approach speed of each pair
    """
    a = sigma / 2.0
    inertia = kappa * m * a * a
    g = v1 - v2 + a * np.cross(w1 + w2, n)
    g_n = np.einsum("ij,ij->i", g, n)
    g_t = g - g_n[:, None] * n
    e, beta = rule(np.maximum(g_n, 0.0), np.linalg.norm(g_t, axis=1), kappa)
    impulse = -m * ((1.0 + e) / 2.0 * g_n)[:, None] * n - m * _eta(beta, kappa)[:, None] * g_t
    impulse[g_n <= 0.0] = 0.0
    dw = a * np.cross(n, impulse) / inertia      # (a n) x P on sphere 1 and (-a n) x (-P) on sphere 2
    return v1 + impulse / m, v2 - impulse / m, w1 + dw, w2 + dw, g_n


def collision_averages(rule, t_tr, t_rot, kappa, m=1.0, sigma=1.0, size=400_000, rng=None, draws=None):
    """Monte Carlo averages of a collision rule over Maxwellian pairs, weighted by the approach speed.

    Pairs are drawn from Maxwellians of temperatures t_tr (velocities) and t_rot (angular
    velocities) with isotropic normals; a pair collides at a rate proportional to its approach
    speed g_n > 0 (``collide``), so the averages are weighted by g_n.

    :param rule: ``rule(g_n, |g_t|, kappa) -> (e, beta)`` arrays (``constant_beta_rule``, ``walton_rule``)
    :param t_tr: translational temperature m <v_x^2> (J)
    :param t_rot: rotational temperature I <w_x^2> (J)
    :param kappa: reduced moment of inertia 4 I / (m sigma^2)
    :param size: number of sampled pairs
    :param rng: a numpy Generator (default: seeded 0)
    :param draws: standard-normal draws to reuse (common random numbers; ``hcs_ratio_for_rule``)
    :returns: CollisionAverages
    """
    if draws is None:
        draws = _maxwellian_pairs(rng if rng is not None else np.random.default_rng(0), size)
    inertia = kappa * m * sigma * sigma / 4.0
    s_v, s_w = math.sqrt(t_tr / m), math.sqrt(t_rot / inertia)
    v1, v2, w1, w2 = s_v * draws["v1"], s_v * draws["v2"], s_w * draws["w1"], s_w * draws["w2"]
    v1n, v2n, w1n, w2n, g_n = collide(v1, v2, w1, w2, draws["n"], rule, kappa, m, sigma)
    hit = g_n > 0.0

    def sq(x):
        return np.einsum("ij,ij->i", x[hit], x[hit])

    d_tr = 0.5 * m * (sq(v1n) - sq(v1) + sq(v2n) - sq(v2))
    d_rot = 0.5 * inertia * (sq(w1n) - sq(w1) + sq(w2n) - sq(w2))
    d_vv = np.einsum("ij,ij->i", (v1n - v1)[hit], v1[hit])
    out = [_weighted_mean(g_n[hit], x) for x in (d_tr, d_rot, d_vv)]
    return CollisionAverages(*(v for pair in out for v in pair))


def hcs_ratio_for_rule(rule, kappa, size=400_000, seed=0, bracket=(1e-3, 10.0)):
    """T_rot / T_tr of the HCS for any collision rule, in the Maxwellian approximation.

    The ratio stays constant when both temperatures decay at the same relative rate:
    <dE_rot> / T_rot = <dE_tr> / T_tr.  Solved with common random numbers (one set of draws
    rescaled), so the residual is a smooth function of the ratio.

    :returns: (ratio, zeta_over_omega): the HCS ratio and the cooling rate -d ln T_tr/dt in units of
        the Enskog frequency omega
    """
    from scipy.optimize import brentq

    draws = _maxwellian_pairs(np.random.default_rng(seed), size)

    def residual(r):
        avg = collision_averages(rule, 1.0, r, kappa, draws=draws)
        return avg.d_e_rot / r - avg.d_e_tr

    ratio = brentq(residual, *bracket, xtol=1e-9, rtol=1e-7)
    avg = collision_averages(rule, 1.0, ratio, kappa, draws=draws)
    return ratio, -avg.d_e_tr / 3.0
