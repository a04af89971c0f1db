"""Kinetic theory of the Hertz sphere gas (studies/kinetic.py), each piece against an independent route.

* the deflection angle against the raw orbit integral done by scipy's adaptive quadrature with a
  bracketing root finder (no substitution), against the hard-sphere closed form in the stiff
  limit, and against a binary collision integrated by YADE itself (a second engine);
* the collision integral against the hard-sphere closed form and against adaptive quadrature
  (over impact parameters, then over the Maxwellian of relative speeds);
* the closed-form mean relative speed against Monte Carlo;
* the Boltzmann D: its standard error against the spread of independent replicas (coverage), and
  the hard-sphere ratio D/[D]_1 against the Sonine-series value of Chapman and Cowling (~1.019).
"""
import math

import numpy as np
import pytest
from scipy import integrate, optimize

from studies import kinetic as K

M = 2.3858201565553436      # kg: the paper's sphere case carries the exact dimer mass
SIGMA = 0.2                 # m: sphere diameter = contact distance
MU = 0.5 * M
KN = K.hertz_kn(1e7, 0.4, 0.1, 0.1)


def chi_orbit_quad(b, g, kn):
    """chi = pi - 2 b int_r0^inf dr / (r^2 sqrt(1 - b^2/r^2 - U/E)), by scipy.quad and brentq."""
    e = 0.5 * MU * g * g

    def f(r):
        u = 0.4 * kn * (SIGMA - r) ** 2.5 if r < SIGMA else 0.0
        return 1.0 - (b / r) ** 2 - u / e

    def fprime(r):
        return 2 * b * b / r ** 3 + kn * (SIGMA - r) ** 1.5 / e

    r0 = optimize.brentq(f, 1e-9, SIGMA, xtol=1e-15, rtol=1e-15)

    def slope(r):  # f(r) / (r - r0), with its limit f'(r0) where the difference cancels
        return f(r) / (r - r0) if r - r0 > 1e-7 * (SIGMA - r0) else fprime(r0)

    # integrable 1/sqrt singularity at r0: quad's algebraic weight (r - r0)^-1/2
    inner, _ = integrate.quad(lambda r: b / (r * r * math.sqrt(slope(r))),
                              r0, SIGMA, weight="alg", wvar=(-0.5, 0.0), epsabs=1e-12, epsrel=1e-11, limit=200)
    outer = math.asin(b / SIGMA)   # int_sigma^inf b dr / (r^2 sqrt(1 - b^2/r^2))
    return math.pi - 2.0 * (inner + outer)


@pytest.mark.parametrize("beta", [0.0, 0.1, 0.5, 0.9, 0.99, 0.9999])
@pytest.mark.parametrize("g", [0.05, 1.0, 6.0])
def test_deflection_matches_raw_orbit_integral(beta, g):
    got = K.deflection_angle(beta * SIGMA, g, SIGMA, MU, KN)[()]
    assert abs(got - chi_orbit_quad(beta * SIGMA, g, KN)) < 1e-9


def test_deflection_hard_limit_and_no_contact():
    beta = np.linspace(0, 0.999, 50)
    hard = 2 * np.arccos(beta)
    soft = K.deflection_angle(beta * SIGMA, 1.0, SIGMA, MU, KN)
    stiff = K.deflection_angle(beta * SIGMA, 1.0, SIGMA, MU, KN * 1e8)
    assert np.max(np.abs(stiff - hard)) < 2e-3           # overlap ~ kn^-2/5: 1e8 -> 6e-4 of sigma
    assert np.max(np.abs(soft - hard)) > 2e-2             # and the soft contact is visibly different
    assert np.all(soft[1:] < hard[1:])                    # a soft sphere deflects less
    assert np.all(K.deflection_angle([SIGMA, 2 * SIGMA], 1.0, SIGMA, MU, KN) == 0)
    assert K.deflection_angle(0.0, 1.0, SIGMA, MU, KN)[()] == pytest.approx(np.pi, abs=1e-12)


def test_deflection_refuses_bad_speed():
    with pytest.raises(ValueError, match="speeds must be > 0"):
        K.deflection_angle(0.05, 0.0, SIGMA, MU, KN)


def test_collision_integral_hard_closed_form_and_nested_quadrature():
    kT = 2.5
    n = 0.4778
    assert K.d_first_approximation(n, kT, M, SIGMA, None) == pytest.approx(
        K.d_hard_spheres_first(n, kT, M, SIGMA), rel=1e-13)
    # Hertz: the transport cross-section Q1(g) against adaptive quadrature over b ...
    for g in [0.3, 1.5, 5.0]:
        val, _ = integrate.quad(lambda b: (1 - math.cos(K.deflection_angle(b, g, SIGMA, MU, KN)[()])) * b,
                                0, SIGMA, epsabs=1e-14, epsrel=1e-10, limit=200)
        assert K.transport_cross_section([g], SIGMA, MU, KN)[0] == pytest.approx(2 * math.pi * val, rel=1e-12)
    # ... and Omega11's Gauss-Laguerre rule against adaptive quadrature over the Maxwellian
    def integrand(y):
        g = y * math.sqrt(2 * kT / MU)
        return math.exp(-y * y) * y ** 5 * K.transport_cross_section([g], SIGMA, MU, KN)[0]
    ref = math.sqrt(kT / (2 * math.pi * MU)) * integrate.quad(integrand, 0, 8, epsrel=1e-10)[0]
    assert K.omega11(kT, MU, SIGMA, KN) == pytest.approx(ref, rel=2e-9)


def test_mean_relative_speed_against_monte_carlo():
    rng = np.random.default_rng(3)
    s = 0.7
    w = rng.normal(0, s, (400_000, 3))
    for speed in [0.0, 1e-9, 0.3, 1.0, 4.0]:
        v = np.array([speed, 0, 0])
        d = np.linalg.norm(v - w, axis=1)
        assert K.mean_relative_speed(speed, s) == pytest.approx(d.mean(), abs=4 * d.std() / math.sqrt(d.size))


def test_boltzmann_standard_error_is_honest():
    """20 independent replicas: their spread agrees with the reported standard errors (chi^2 test)."""
    n, kT = 0.4778, 2.5
    runs = [K.d_boltzmann(n, kT, M, SIGMA, None, n_chains=60, n_steps=200, seed=s) for s in range(20)]
    d = np.array([r[0] for r in runs])
    se = np.array([r[1] for r in runs])
    z = (d - d.mean()) / se
    chi2 = float(np.sum(z ** 2))                       # ~ chi^2 with 19 dof if the SEs are right
    assert 6.8 < chi2 < 38.6                           # its 0.5 % and 99.5 % quantiles


def test_boltzmann_hard_spheres_sonine_limit():
    """Hard spheres: D/[D]_1 = 1.019 (Chapman & Cowling's Sonine series), not 1 (first order)."""
    n, kT = 0.4778, 2.5
    d, se = K.d_boltzmann(n, kT, M, SIGMA, None, n_chains=1000, n_steps=1600, seed=7)
    ratio = d / K.d_hard_spheres_first(n, kT, M, SIGMA)
    assert se / d < 3e-3
    assert abs(ratio - 1.019) < 4 * se / d + 1e-3, (ratio, se / d)
    assert ratio - 1.0 > 4 * se / d                     # the higher orders are resolved


def test_boltzmann_hertz_softer_diffuses_faster():
    n, kT = 0.4778, 2.5
    d_soft, se_soft = K.d_boltzmann(n, kT, M, SIGMA, KN, n_chains=200, n_steps=600, seed=1)
    d_hard, se_hard = K.d_boltzmann(n, kT, M, SIGMA, None, n_chains=200, n_steps=600, seed=1)
    assert d_soft - d_hard > 4 * math.hypot(se_soft, se_hard)


def test_enskog_chi_and_gas():
    assert K.enskog_chi(0.0) == 1.0
    assert K.enskog_chi(0.002) == pytest.approx(1 + 2.5 * 0.002, rel=1e-4)
    # Carnahan-Starling's series (1 - phi/2) sum_k C(k+2, 2) phi^k = 1 + 5/2 phi + 9/2 phi^2 + 7 phi^3
    # + 10 phi^4 + ...: pins the second-order term first-order Enskog (1 + 5/2 phi) lacks
    phi = 0.01
    assert K.enskog_chi(phi) == pytest.approx(1 + 2.5 * phi + 4.5 * phi ** 2 + 7 * phi ** 3 + 10 * phi ** 4, rel=1e-8)
    with pytest.raises(ValueError, match="volume fraction"):
        K.enskog_chi(0.6)
    gas = K.SphereGas(864, 12.18284909686642, 0.2, M, 2.5, 1e7, 0.4)
    assert gas.volume_fraction == pytest.approx(864 * math.pi * 0.2 ** 3 / 6 / 12.18284909686642 ** 3)
    assert gas.kn == pytest.approx(4 / 3 * 1e7 / (2 * (1 - 0.16)) * math.sqrt(0.05))


def _yade_collisions(g, betas, x0=0.3, dt=None, t_run=0.6):
    """One collision per impact parameter b = beta sigma of two frictionless Hertz spheres in YADE
    (the gas's contact law), bodies x0 apart along x closing at g; dt None: 0.02 P-wave steps.
    Returns (outgoing relative velocities v_A - v_B (n, 3), the step used)."""
    pytest.importorskip("yade")
    from yade import O, utils
    from yade.wrapper import (Bo1_Sphere_Aabb, ForceResetter, FrictMat, Ig2_Sphere_Sphere_ScGeom,
                              InsertionSortCollider, InteractionLoop, Ip2_FrictMat_FrictMat_MindlinPhys,
                              Law2_ScGeom_MindlinPhys_Mindlin, NewtonIntegrator)
    from yade.minieigenHP import Vector3
    O.reset()
    rho = M / (math.pi * SIGMA ** 3 / 6)
    mat = O.materials.append(FrictMat(young=1e7, poisson=0.4, density=rho, frictionAngle=0.0))
    pairs = []
    for k, beta in enumerate(betas):
        z = 10.0 * k
        a = O.bodies.append(utils.sphere((-0.5 * x0, 0, z), 0.1, material=mat))
        b = O.bodies.append(utils.sphere((0.5 * x0, beta * SIGMA, z), 0.1, material=mat))
        O.bodies[a].state.vel = Vector3(0.5 * g, 0, 0)
        O.bodies[b].state.vel = Vector3(-0.5 * g, 0, 0)
        pairs.append((a, b))
    O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb()]),
                 InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_MindlinPhys()],
                                 [Law2_ScGeom_MindlinPhys_Mindlin()]),
                 NewtonIntegrator(damping=0.0, gravity=(0, 0, 0))]
    O.dt = dt if dt is not None else 0.02 * utils.PWaveTimeStep()
    O.run(int(t_run / O.dt), True)
    assert O.interactions.countReal() == 0                      # every collision is over
    gout = np.array([np.array(O.bodies[a].state.vel) - np.array(O.bodies[b].state.vel) for a, b in pairs])
    used = float(O.dt)
    O.reset()
    return gout, used


def test_deflection_against_yade_binary_collision():
    """Two frictionless Hertz spheres in YADE (the gas's contact law), one collision each at
    several impact parameters: the outgoing relative velocity's angle matches chi(b, g)."""
    g = 1.5
    betas = [0.0, 0.3, 0.6, 0.9, 0.97]
    # 0.3 m closing at 1.5 m/s: 0.2 s to contact, contact ~0.05 s
    gout_all, _ = _yade_collisions(g, betas, t_run=0.6)
    assert len(gout_all) == len(betas)
    for gout, beta in zip(gout_all, betas):
        chi_yade = math.acos(np.clip(gout[0] / np.linalg.norm(gout), -1, 1))
        chi = K.deflection_angle(beta * SIGMA, g, SIGMA, MU, KN)[()]
        assert abs(chi_yade - chi) < 5e-7, (beta, chi_yade, chi)   # measured <= 7.6e-8 at this dt
        assert np.linalg.norm(gout) == pytest.approx(g, rel=1e-5)


def test_leapfrog_collision_converges_to_the_orbit_at_second_order():
    """The integrated collision against the quadrature deflection (an independent route): the
    phase-averaged error falls 4x per halving of dt, and the step's energy error vanishes."""
    b = np.array([0.0, 0.3, 0.6, 0.9, 0.97]) * SIGMA
    g = np.array([0.3, 2.5, 6.0])[:, None, None]
    ph = ((np.arange(16) + 0.5) / 16)[None, None, :]
    exact = K.deflection_angle(b[None, :], g[:, :, 0], SIGMA, MU, KN)
    dt1 = 0.06665 * math.sqrt(1140.0 / 1e7)           # the sphere gas's step at E = 1e7 Pa
    errs = []
    for f in (1.0, 0.5, 0.25):
        chi, ratio = K.leapfrog_collision(b[None, :, None], g, SIGMA, MU, KN, f * dt1, ph)
        errs.append(np.abs(chi.mean(2) - exact).max())
        assert np.abs(ratio ** 2 - 1).max() < 1e-2 * f ** 2
    assert 1e-5 < errs[0] < 1e-3                        # visible at the gas's step, and small
    for e_big, e_small in zip(errs, errs[1:]):
        assert 3.5 < e_big / e_small < 4.5


def test_leapfrog_collision_refuses_bad_input():
    for kw in ({"b": SIGMA}, {"g": 0.0}, {"phase": 1.0}, {"dt": 0.0}):
        args = {**dict(b=0.1, g=1.0, sigma=SIGMA, mu=MU, kn=KN, dt=1e-4, phase=0.5), **kw}
        with pytest.raises(ValueError, match="need (g|dt)"):
            K.leapfrog_collision(**args)
    with pytest.raises(RuntimeError):
        K.leapfrog_collision(0.1, 1.0, SIGMA, MU, KN, 1e-4, max_steps=10)


def test_leapfrog_collision_is_yades_integrator():
    """Two frictionless Hertz spheres in YADE at the sphere gas's own time step: the outgoing
    relative velocity matches :func:`studies.kinetic.leapfrog_collision` at the same contact phase
    to round-off, while it differs from the exact orbit by the step's error (~1e-4 rad)."""
    g, x0 = 4.0, 0.3
    betas = [0.0, 0.3, 0.6, 0.9, 0.97]
    dt = 0.06665 * math.sqrt(1140.0 / 1e7)
    gout_all, used = _yade_collisions(g, betas, x0=x0, dt=dt, t_run=0.3)
    assert used == dt
    beta = np.array(betas)
    t_contact = (x0 - SIGMA * np.sqrt(1 - beta ** 2)) / g      # free-flight contact time
    phase = t_contact / dt - np.floor(t_contact / dt)          # last contact-free step: t_contact - phase dt
    chi_lf, ratio_lf = K.leapfrog_collision(beta * SIGMA, g, SIGMA, MU, KN, dt, phase)
    chi_exact = K.deflection_angle(beta * SIGMA, g, SIGMA, MU, KN)
    for i, gout in enumerate(gout_all):
        chi_yade = math.atan2(abs(gout[1]), gout[0])
        assert abs(chi_yade - chi_lf[i]) < 1e-12, (betas[i], chi_yade, chi_lf[i])   # measured <= 1.4e-15
        assert np.linalg.norm(gout) / g == pytest.approx(ratio_lf[i], abs=1e-12)
    assert np.abs(chi_lf - chi_exact)[1:].max() > 1e-4       # the step's own error (measured 8e-4) is visible


def test_timestep_shift_against_monte_carlo_and_its_order():
    """The quadrature of the step's effect on D against plain Monte Carlo over the same law of
    collisions (x = mu g^2/2kT ~ Gamma(3): the g^5-weighted Maxwellian of Omega11; b^2 uniform on
    [0, sigma^2]; phase uniform), with common random numbers for the exact and stepped maps, at
    an exaggerated step (4x the gas's) where the shift is ~0.6 %; and the shift's second order at the gas's step."""
    kT = 2.5
    dt1 = 0.06665 * math.sqrt(1140.0 / 1e7)
    quad = K.timestep_shift(kT, MU, SIGMA, KN, 4 * dt1)
    rng = np.random.default_rng(3)
    n = 40000
    g = np.sqrt(2 * kT / MU * rng.gamma(3.0, 1.0, n))
    b = SIGMA * np.sqrt(rng.uniform(size=n))
    b = np.minimum(b, SIGMA * (1 - 1e-12))
    chi, ratio = K.leapfrog_collision(b, g, SIGMA, MU, KN, 4 * dt1, rng.uniform(size=n))
    q_ex = 1 - np.cos(K.deflection_angle(b, g, SIGMA, MU, KN))
    dq = (1 - ratio * np.cos(chi)) - q_ex
    mc = -dq.mean() / q_ex.mean()
    se = dq.std(ddof=1) / math.sqrt(n) / q_ex.mean()
    assert 1e-3 < -quad < 1e-2
    assert abs(quad - mc) < 3.5 * se, (quad, mc, se)
    assert se < 0.1 * abs(quad)                      # the comparison can fail
    r = K.timestep_shift(kT, MU, SIGMA, KN, dt1) / K.timestep_shift(kT, MU, SIGMA, KN, dt1 / 2)
    assert 3.5 < r < 4.5


@pytest.mark.parametrize("n_particles", [None, 5, 30])
def test_tagged_chain_finite_gas_keeps_its_stationary_law(n_particles):
    """The periodic gas of N particles with zero total momentum: partners drawn from the conditional
    Maxwellian (mean -v/(N-1)) and the pair collision must keep the tagged particle's law, so the
    chain's states follow the Maxwellian weighted by the collision rate lambda(v).  Checked on
    <|v|^2> and <lambda> over 2,000 chains x 150 collisions against 1-D quadrature over the speed,
    and the closed form of <lambda> over the Maxwellian that d_boltzmann uses."""
    kT, n = 2.5, 0.48
    s = math.sqrt(kT / M)
    chain = K._tagged_chain(n, kT, M, SIGMA, KN, 2000, 3, None, n_particles)
    v2, lam = [], []
    for step in range(170):
        v, la = next(chain)
        if step >= 20:
            v2.append(np.einsum("ij,ij->i", v, v))
            lam.append(la)
    v2, lam = np.array(v2).mean(0), np.array(lam).mean(0)          # per chain
    big = n_particles
    shift = 0.0 if big is None else 1 / (big - 1)
    s_w = s if big is None else s * math.sqrt(big * (big - 2)) / (big - 1)
    n_p = n if big is None else n * (big - 1) / big

    def rate(u):
        return n_p * math.pi * SIGMA ** 2 * K.mean_relative_speed(u * (1 + shift), s_w)

    def f0(u):                                   # Maxwell speed density of the tagged particle
        return math.sqrt(2 / math.pi) * u * u / s ** 3 * math.exp(-u * u / (2 * s * s))

    lam_f0 = integrate.quad(lambda u: rate(u) * f0(u), 0, 12 * s)[0]
    v2_pi = integrate.quad(lambda u: u * u * rate(u) * f0(u), 0, 12 * s)[0] / lam_f0
    lam_pi = integrate.quad(lambda u: rate(u) ** 2 * f0(u), 0, 12 * s)[0] / lam_f0
    for got, want in ((v2, v2_pi), (lam, lam_pi)):
        se = got.std(ddof=1) / math.sqrt(got.size)
        assert abs(got.mean() - want) < 4 * se, (got.mean(), want, se)
    closed = n_p * math.pi * SIGMA ** 2 * math.sqrt(16 * kT / (math.pi * M)) * (
        1.0 if big is None else math.sqrt(big / (big - 1)))
    assert lam_f0 == pytest.approx(closed, rel=1e-9)
    if big == 5:        # the smallest gas's stationary law differs measurably from the infinite one's
        inf_rate = integrate.quad(lambda u: n * math.pi * SIGMA ** 2 * K.mean_relative_speed(u, s) ** 2 * f0(u),
                                  0, 12 * s)[0] / (n * math.pi * SIGMA ** 2 * math.sqrt(16 * kT / (math.pi * M)))
        assert abs(lam.mean() - inf_rate) > 10 * lam.std(ddof=1) / math.sqrt(lam.size)


def test_boltzmann_finite_gas_refuses_bad_size_and_tends_to_the_infinite_one():
    with pytest.raises(ValueError, match="n_particles must be an integer"):
        K.d_boltzmann(0.48, 2.5, M, SIGMA, KN, n_chains=10, n_steps=30, n_particles=2)
    with pytest.raises(ValueError, match="n_particles must be an integer"):
        K.d_boltzmann(0.48, 2.5, M, SIGMA, KN, n_chains=10, n_steps=30, n_particles=100.0)
    d_inf, se = K.d_boltzmann(0.48, 2.5, M, SIGMA, KN, n_chains=200, n_steps=200, seed=4)
    d_big, _ = K.d_boltzmann(0.48, 2.5, M, SIGMA, KN, n_chains=200, n_steps=200, seed=4, n_particles=10 ** 7)
    assert abs(d_big / d_inf - 1) < 1e-4 < se / d_inf       # same random numbers: the same chains
