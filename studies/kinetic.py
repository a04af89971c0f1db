"""Kinetic theory of the dilute sphere gas: the reference the study's sphere case is checked against.

The gas script's spheres are frictionless, elastic and interact with YADE's Hertz law
(``Ip2_FrictMat_FrictMat_MindlinPhys`` + ``Law2_ScGeom_MindlinPhys_Mindlin``): a normal force
F = k_n delta^(3/2) at overlap delta, with k_n = (4/3) E* sqrt(R*), E* = E / (2 (1 - nu^2)) for one
material and R* = R1 R2 / (R1 + R2).  That is a central pair potential

    U(r) = (2/5) k_n (sigma - r)^(5/2) for r < sigma = R1 + R2,   0 beyond,

so the self-diffusion coefficient of the dilute gas follows from the Boltzmann equation with the
deflection angle chi(b, g) of this potential (Chapman and Cowling, *The mathematical theory of
non-uniform gases*, ch. 9-10):

* ``deflection_angle``: chi(b, g) by the classical orbit integral, a 1-D Gauss-Legendre quadrature
  after a substitution that removes the turning-point singularity; hard spheres: 2 arccos(b/sigma).
* ``d_first_approximation``: the first Chapman-Enskog approximation
  [D]_1 = 3 kT / (8 n m Omega11) with the collision integral Omega11 (Gauss-Laguerre over the
  Maxwellian of relative speeds, Gauss-Legendre over impact parameters).  Hard spheres:
  (3 / (8 n sigma^2)) sqrt(kT / (pi m)).
* ``d_boltzmann``: D of the linear Boltzmann equation for a tagged particle in the equilibrium gas
  (infinite, or the periodic gas of N particles with zero total momentum) with no Sonine truncation, by sampling the tagged particle's velocity Markov chain at its
  collisions (partners drawn from the Maxwellian weighted by the relative speed, impact
  parameters uniform over the disc) and summing its Green-Kubo series over collisions, with the
  mean free flight 1/lambda(v) of each velocity state in place of the sampled flight (a
  conditional expectation: same mean, smaller variance); lambda(v) = n pi sigma^2 E_w|v - w|
  has a closed form (``mean_relative_speed``).  For hard spheres it gives D/[D]_1 = 1.019, the
  Sonine-series limit of Chapman and Cowling.
* ``leapfrog_collision``: one collision as YADE's leapfrog integrates it at a time step dt
  (tested against YADE to round-off), and ``timestep_shift``: the relative change of D that the
  step makes through the collision map (first order in delta Omega/Omega, as docs/timestep.md).
* ``enskog_chi``: the Enskog factor chi = (1 - phi/2) / (1 - phi)^3 (Carnahan-Starling contact
  value) that divides the dilute D at volume fraction phi (1.005 at phi = 0.002).

Nothing here knows YADE or the study engine; ``studies.report`` reads the table that
``python -m studies.sphere_gas`` writes.  SI units throughout (m, kg, s, J, Pa).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.special import erf, roots_genlaguerre, roots_legendre

__all__ = ["hertz_kn", "deflection_angle", "transport_cross_section", "omega11",
           "d_first_approximation", "d_hard_spheres_first", "d_boltzmann", "enskog_chi",
           "mean_relative_speed", "leapfrog_collision", "timestep_shift", "SphereGas"]

_U, _WU = roots_legendre(64)
_U = 0.5 * (_U + 1.0)          # Gauss-Legendre nodes/weights on [0, 1]
_WU = 0.5 * _WU


def hertz_kn(youngs_modulus, poisson, r1, r2):
    """YADE's Hertz coefficient k_n [N m^-3/2] (F = k_n delta^1.5) for two spheres of one material."""
    if not (youngs_modulus > 0 and 0 <= poisson < 0.5 and r1 > 0 and r2 > 0):
        raise ValueError(f"need E > 0, 0 <= nu < 0.5 and positive radii, got E={youngs_modulus}, "
                         f"nu={poisson}, r1={r1}, r2={r2}")
    e_star = youngs_modulus / (2.0 * (1.0 - poisson ** 2))
    return 4.0 / 3.0 * e_star * math.sqrt(r1 * r2 / (r1 + r2))


def _turning_point(beta, eps):
    """Largest root rho0 in (0, 1] of F(rho) = 1 - beta^2/rho^2 - (1 - rho)^2.5 / eps (bisection)."""
    lo = np.zeros_like(beta)
    hi = np.ones_like(beta)
    for _ in range(80):                       # F is increasing in rho: 80 halvings reach round-off
        mid = 0.5 * (lo + hi)
        with np.errstate(divide="ignore"):
            f = 1.0 - (beta / mid) ** 2 - (1.0 - mid) ** 2.5 / eps
        up = f > 0
        hi = np.where(up, mid, hi)
        lo = np.where(up, lo, mid)
    return hi


def deflection_angle(b, g, sigma, mu, kn=None):
    """Deflection chi [rad] of the relative velocity in one binary collision of Hertz spheres.

    b: impact parameter [m] (array), g: relative speed [m/s] (array, broadcast with b), sigma:
    contact distance R1 + R2 [m], mu: reduced mass [kg], kn: Hertz coefficient [N m^-3/2]
    (``hertz_kn``); None means hard spheres, chi = 2 arccos(b/sigma).  b >= sigma gives 0.

    chi = pi - 2 (arcsin(b/sigma) + I), with I the orbit integral inside the contact,
    I = int_rho0^1 beta drho / (rho^2 sqrt(F(rho))), beta = b/sigma, rho = r/sigma,
    F = 1 - beta^2/rho^2 - (1 - rho)^2.5 / eps, eps = (mu g^2/2) / ((2/5) kn sigma^2.5).
    With rho = rho0 + (1 - rho0) u^2 and F written as its difference from F(rho0) = 0,
    F = u^2 G(u) with G smooth and positive, so I is a regular integral (64-point Gauss-Legendre;
    the (1 - u^2)^2.5 endpoint term converges as N^-7).
    """
    b, g = np.broadcast_arrays(np.asarray(b, float), np.asarray(g, float))
    beta = np.clip(b / sigma, 0.0, 1.0)
    out = np.zeros(beta.shape)
    inside = beta < 1.0
    if kn is None:
        out[inside] = 2.0 * np.arccos(beta[inside])
        return out
    if not np.all(g > 0):
        raise ValueError("relative speeds must be > 0")
    bt = beta[inside]
    eps = (0.5 * mu * g[inside] ** 2) / (0.4 * kn * sigma ** 2.5)
    rho0 = _turning_point(bt, eps)
    a = 1.0 - rho0
    u = _U[:, None]
    u2 = u * u
    rho = rho0 + a * u2
    with np.errstate(divide="ignore", invalid="ignore"):
        h = np.where(u2 > 0, -np.expm1(2.5 * np.log1p(-np.minimum(u2, 1.0))) / u2, 2.5)
    G = a * bt ** 2 * (rho + rho0) / (rho0 ** 2 * rho ** 2) + a ** 2.5 * h / eps
    integrand = 2.0 * a * bt / (rho ** 2 * np.sqrt(G))
    inner = _WU @ integrand
    out[inside] = np.pi - 2.0 * (np.arcsin(bt) + inner)
    return out


def leapfrog_collision(b, g, sigma, mu, kn, dt, phase=0.5, max_steps=1_000_000):
    """One binary collision of Hertz spheres as the gas script's integrator resolves it.

    YADE's NewtonIntegrator is a leapfrog: the force from the positions of step k updates the
    half-step velocity, v(k+1/2) = v(k-1/2) + F(x_k) dt / m, then x(k+1) = x_k + v(k+1/2) dt.  For
    two free bodies the scheme is linear, so their relative coordinate r = x_B - x_A follows the
    same leapfrog with the pair force over the reduced mass mu:  F = kn delta^1.5 along r,
    delta = sigma - |r| (``Law2_ScGeom_MindlinPhys_Mindlin``, frictionless).  The collision starts on
    the free-flight course at impact parameter b [m] with relative speed g [m/s]; ``phase`` in
    [0, 1) places the last step before the free-flight contact time t_c at t_c - phase dt (in a gas
    it is uniform).  dt [s]; arrays broadcast.

    Returns (chi [rad], g_out/g): the deflection of the relative velocity and the ratio of the
    outgoing to the incoming relative speed (1 for the exact orbit; the step's energy error is
    g_out^2/g^2 - 1).  As dt -> 0, chi averaged over the phase tends to :func:`deflection_angle`
    at second order (at one fixed phase the error is not monotone in dt).
    """
    b, g, phase = (np.array(a, float) for a in np.broadcast_arrays(b, g, phase))
    if not (dt > 0 and kn > 0 and mu > 0 and sigma > 0):
        raise ValueError(f"need dt, kn, mu and sigma > 0, got dt={dt}, kn={kn}, mu={mu}, sigma={sigma}")
    if not (np.all(g > 0) and np.all((b >= 0) & (b < sigma)) and np.all((phase >= 0) & (phase < 1))):
        raise ValueError("need g > 0, 0 <= b < sigma and 0 <= phase < 1")
    shape = b.shape
    b, g, phase = b.ravel(), g.ravel(), phase.ravel()
    # the relative course along +x at height b; free-flight contact at x = -sqrt(sigma^2 - b^2)
    x = np.stack([-np.sqrt(sigma ** 2 - b ** 2) - phase * g * dt, b], 1)
    v = np.stack([g, np.zeros_like(g)], 1)
    todo = np.arange(b.size)
    for _ in range(max_steps):
        xs, vs = x[todo], v[todo]
        d = np.sqrt(np.einsum("ij,ij->i", xs, xs))
        done = (d >= sigma) & (np.einsum("ij,ij->i", xs, vs) > 0)   # apart and separating: free for ever
        todo, xs, vs, d = todo[~done], xs[~done], vs[~done], d[~done]
        if todo.size == 0:
            break
        delta = np.maximum(sigma - d, 0.0)
        vs = vs + (kn * delta ** 1.5 / (mu * d))[:, None] * xs * dt
        x[todo] = xs + vs * dt
        v[todo] = vs
    else:
        raise RuntimeError(f"{todo.size} collisions unfinished after {max_steps} steps (dt = {dt} s too small?)")
    speed = np.sqrt(np.einsum("ij,ij->i", v, v))
    chi = np.arctan2(np.abs(v[:, 1]), v[:, 0])
    return chi.reshape(shape), (speed / g).reshape(shape)


def transport_cross_section(g, sigma, mu, kn=None, n_b=100):
    """Q1(g) = 2 pi int (1 - cos chi) b db [m^2] for relative speeds g [m/s] (array).

    Gauss-Legendre in s = (1 - (b/sigma)^2)^(1/2) (b db = -sigma^2 s ds), which resolves the grazing
    collisions near b = sigma where chi -> 0.  Hard spheres: pi sigma^2 exactly.
    """
    g = np.atleast_1d(np.asarray(g, float))
    s, w = roots_legendre(n_b)
    s = 0.5 * (s + 1.0)
    w = 0.5 * w
    beta = np.sqrt(1.0 - s ** 2)
    chi = deflection_angle(sigma * beta[None, :], g[:, None], sigma, mu, kn)
    return 2.0 * np.pi * sigma ** 2 * ((1.0 - np.cos(chi)) * s[None, :]) @ w


def omega11(kT, mu, sigma, kn=None, n_g=192, n_b=100):
    """Chapman-Enskog collision integral Omega^(1,1) [m^3/s] at temperature kT [J].

    Omega11 = sqrt(kT / (2 pi mu)) int_0^inf exp(-y^2) y^5 Q1(g) dy, g = y sqrt(2 kT / mu);
    with x = y^2 a generalised Gauss-Laguerre rule (alpha = 2) of n_g points.  Q1 of a Hertz
    contact goes as pi sigma^2 (1 - c x^0.4) at small x (the overlap scales as g^0.8), so the rule
    converges algebraically: relative error 4e-8 at 48 points, 4e-10 at 192 (measured against
    adaptive quadrature, tests/test_kinetic.py); Q1 itself converges to round-off by n_b = 100.
    """
    x, w = roots_genlaguerre(n_g, 2.0)
    g = np.sqrt(2.0 * x * kT / mu)
    q1 = transport_cross_section(g, sigma, mu, kn, n_b)
    return math.sqrt(kT / (2.0 * math.pi * mu)) * 0.5 * float(w @ q1)


def timestep_shift(kT, mu, sigma, kn, dt, n_g=64, n_b=60, n_phase=16):
    """Relative change of D [-] that the integrator's time step dt [s] makes in the dilute gas.

    D depends on dt through the collision map alone (free flight is exact), so to first order
    delta D/D = -delta Omega/Omega, with Omega the Mason-Monchick collision integral
    ~ <g^2 q>, q = 1 - (g'/g) cos chi (= 1 - cos chi for the exact orbit), over the
    collision-rate-weighted Maxwellian (docs/timestep.md).  The collisions are those of
    :func:`leapfrog_collision`, averaged over ``n_phase`` contact phases (midpoints); Gauss-Laguerre
    (``n_g``, weight x^2 e^-x as in :func:`omega11`) x Gauss-Legendre (``n_b``) integrates both maps
    (converged: 128 x 120 points and 32 phases change the 1e7 Pa gas's shift by 1e-3 of itself).
    kT [J], mu: reduced mass [kg], sigma [m], kn [N m^-3/2].
    """
    x, wx = roots_genlaguerre(n_g, 2.0)
    g = np.sqrt(2.0 * x * kT / mu)[:, None]
    s, ws = roots_legendre(n_b)
    s = 0.5 * (s + 1.0)
    ws = 0.5 * ws
    b = sigma * np.sqrt(1.0 - s ** 2)[None, :]
    q_exact = 1.0 - np.cos(deflection_angle(b, g, sigma, mu, kn))
    phase = (np.arange(n_phase) + 0.5) / n_phase
    chi, ratio = leapfrog_collision(b[..., None], g[..., None], sigma, mu, kn, dt, phase)
    q_step = (1.0 - ratio * np.cos(chi)).mean(axis=2)
    om_exact = wx @ ((q_exact * s) @ ws)
    om_step = wx @ ((q_step * s) @ ws)
    return -float(om_step / om_exact - 1.0)


def d_hard_spheres_first(n, kT, m, sigma):
    """[D]_1 of hard spheres [m^2/s]: 3 / (8 n sigma^2) sqrt(kT / (pi m)); n [m^-3], kT [J], m [kg]."""
    return 3.0 / (8.0 * n * sigma ** 2) * math.sqrt(kT / (math.pi * m))


def d_first_approximation(n, kT, m, sigma, kn=None):
    """First Chapman-Enskog approximation of the self-diffusion coefficient [m^2/s]: 3 kT / (8 n m Omega11)."""
    return 3.0 * kT / (8.0 * n * m * omega11(kT, 0.5 * m, sigma, kn))


def enskog_chi(phi):
    """Enskog's pair correlation at contact (Carnahan-Starling): (1 - phi/2) / (1 - phi)^3."""
    if not 0 <= phi < 0.5:
        raise ValueError(f"volume fraction {phi} outside [0, 0.5)")
    return (1.0 - 0.5 * phi) / (1.0 - phi) ** 3


def mean_relative_speed(v, s):
    """E|v - w| for w ~ N(0, s^2 I_3) and speeds |v| [m/s] (array): s (a + 1/a) erf(a/sqrt2) + s sqrt(2/pi) exp(-a^2/2), a = |v|/s."""
    a = np.asarray(v, float) / s
    small = a < 1e-6
    a_safe = np.where(small, 1.0, a)
    val = (a_safe + 1.0 / a_safe) * erf(a_safe / math.sqrt(2.0)) + math.sqrt(2.0 / math.pi) * np.exp(-0.5 * a_safe ** 2)
    return s * np.where(small, 2.0 * math.sqrt(2.0 / math.pi) * (1.0 + a ** 2 / 6.0), val)


def _scatter(gvec, chi, rng):
    """Rotate relative velocities gvec (n, 3) by angles chi (n,) about uniformly random azimuths."""
    gn = np.linalg.norm(gvec, axis=1)
    e = gvec / gn[:, None]
    # an orthonormal pair perpendicular to e
    helper = np.where(np.abs(e[:, :1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    p = np.cross(e, helper)
    p /= np.linalg.norm(p, axis=1)[:, None]
    q = np.cross(e, p)
    phi = rng.uniform(0.0, 2.0 * np.pi, len(gn))
    c, s = np.cos(chi), np.sin(chi)
    new = c[:, None] * e + s[:, None] * (np.cos(phi)[:, None] * p + np.sin(phi)[:, None] * q)
    return gn[:, None] * new


def _partner_law(n, kT, m, n_particles=None):
    """The law of a tagged particle's collision partners (:func:`d_boltzmann`): (shift, s_w,
    n_partners, g_mean).  Given the tagged velocity v, partners are Gaussian with mean -shift v and
    sd s_w per component [m/s], at number density n_partners [m^-3]; g_mean [m/s] is the mean
    relative speed E|v - w| over the tagged particle's Maxwellian.  n_particles None: the infinite
    gas (shift 0, s_w = sqrt(kT/m), n); N: the periodic gas of N particles with zero momentum."""
    if n_particles is not None and not (isinstance(n_particles, (int, np.integer)) and n_particles >= 3):
        raise ValueError(f"n_particles must be an integer >= 3 (or None: infinite gas), got {n_particles!r}")
    s = math.sqrt(kT / m)                  # thermal speed per component
    g_mean = math.sqrt(16.0 * kT / (math.pi * m))
    if n_particles is None:
        return 0.0, s, n, g_mean
    big_n = int(n_particles)
    # v - w is Gaussian with variance (kT/m) 2N/(N-1) per component over the tagged Maxwellian
    return (1.0 / (big_n - 1), s * math.sqrt(big_n * (big_n - 2)) / (big_n - 1), n * (big_n - 1) / big_n,
            g_mean * math.sqrt(big_n / (big_n - 1.0)))


def _tagged_chain(n, kT, m, sigma, kn, n_chains, seed, deflection=None, n_particles=None):
    """The tagged particles' velocities at successive collisions (:func:`d_boltzmann`): yields
    (v (n_chains, 3) [m/s], lambda(v) (n_chains,) [1/s], the collision rate of each state), started
    from the tagged particle's Maxwellian; the chain's stationary law is that Maxwellian weighted by
    lambda(v)."""
    shift, s_w, n_partners, _ = _partner_law(n, kT, m, n_particles)   # partners' mean velocity: -shift v
    rng = np.random.default_rng(seed)
    s = math.sqrt(kT / m)                  # thermal speed per component
    w_cap = 7.0 * s_w                      # partners further than 7 s_w from their mean (P ~ 1e-10) are redrawn
    area = math.pi * sigma ** 2
    mu = 0.5 * m
    if deflection is None:
        def deflection(b, g):
            return deflection_angle(b, g, sigma, mu, kn)
    v = rng.normal(0.0, s, (n_chains, 3))
    while True:
        speed = np.linalg.norm(v, axis=1)
        rel = speed * (1.0 + shift)        # |v - mean partner velocity|
        yield v, n_partners * area * mean_relative_speed(rel, s_w)
        # partner w ~ its Maxwellian given v, weighted by |v - w| (rejection against |v - c| + w_cap)
        w = np.empty_like(v)
        todo = np.arange(n_chains)
        while todo.size:
            dev = rng.normal(0.0, s_w, (todo.size, 3))
            cand = dev - shift * v[todo]
            g = np.linalg.norm(v[todo] - cand, axis=1)
            ok = (np.linalg.norm(dev, axis=1) <= w_cap) & (rng.uniform(size=todo.size) * (rel[todo] + w_cap) < g)
            w[todo[ok]] = cand[ok]
            todo = todo[~ok]
        gvec = v - w
        b = sigma * np.sqrt(rng.uniform(size=n_chains))     # uniform over the disc
        chi = deflection(b, np.linalg.norm(gvec, axis=1))
        v = 0.5 * (v + w) + 0.5 * _scatter(gvec, chi, rng)


def d_boltzmann(n, kT, m, sigma, kn=None, n_chains=2000, n_steps=1000, window=12, burn_in=20,
                seed=0, deflection=None, n_particles=None):
    """Self-diffusion coefficient [m^2/s] of the dilute gas from the linear Boltzmann equation.

    Returns (D, standard error).  ``n_chains`` independent tagged-particle chains of ``n_steps``
    collisions each, after ``burn_in`` collisions.  Green-Kubo over the collision chain:
    with x_j = v_j / lambda(v_j) (velocity state j times its mean free flight),

        D = (1/3) <lambda>_f0 E_pi[ x_0 . sum_{k=0..window} x_k ],

    where E_pi is over the chain's stationary law (the Maxwellian weighted by the collision rate
    lambda(v), hence the factor <lambda>_f0 = n pi sigma^2 sqrt(16 kT / (pi m))) and every state
    of a chain serves as a time origin.  The velocity memory falls by ~0.41 per collision, so
    ``window`` = 12 leaves ~1e-5 of D out.  The standard error is the spread over the
    independent chains.  ``deflection(b, g)`` replaces the Hertz/hard-sphere deflection (tests);
    a particle interacts whenever b < sigma.

    ``n_particles`` = N: the periodic gas of N particles with zero total momentum, with n = N/V and
    kT from the mean kinetic energy per particle, as the runs measure them.  Its equilibrium is the
    Maxwellian conditioned on sum v = 0, so a tagged particle at v meets N - 1 others (partner density
    n (N-1)/N: its own images move with it and never collide) whose velocities are Gaussian with mean
    -v/(N-1) and variance (kT/m) N (N-2)/(N-1)^2 per component; the pair collision conserves that law.
    The two 1/N effects have opposite signs (fewer partners: D up; partners recoiling against the
    tagged particle's momentum: D down).  None: the infinite gas.
    """
    if not (n > 0 and kT > 0 and m > 0 and sigma > 0):
        raise ValueError("n, kT, m and sigma must be > 0")
    if not (n_chains >= 2 and n_steps > window >= 0 and burn_in >= 0):
        raise ValueError("need n_chains >= 2 and n_steps > window >= 0")
    _, _, n_partners, g_mean = _partner_law(n, kT, m, n_particles)
    # the last window + 1 states in a ring buffer (memory O(window n_chains), not O(n_steps n_chains)):
    # state s pairs with the origins s - k, k = 0..window, that are among the first n_steps - window
    origins = n_steps - window
    ring = np.empty((window + 1, n_chains, 3))
    per_chain = np.zeros(n_chains)
    chain = _tagged_chain(n, kT, m, sigma, kn, n_chains, seed, deflection, n_particles)
    for step in range(burn_in + n_steps):
        v, lam = next(chain)
        if step < burn_in:
            continue
        s = step - burn_in
        x = v / lam[:, None]
        ring[s % (window + 1)] = x
        for k in range(min(window, s) + 1):
            if s - k < origins:
                per_chain += np.einsum("ci,ci->c", ring[(s - k) % (window + 1)], x)
    per_chain /= origins
    per_chain *= n_partners * math.pi * sigma ** 2 * g_mean / 3.0      # <lambda> over the tagged Maxwellian
    return float(per_chain.mean()), float(per_chain.std(ddof=1) / math.sqrt(n_chains))


@dataclasses.dataclass(frozen=True)
class SphereGas:
    """A dilute gas of identical frictionless Hertz spheres (the study's ``spheres`` case).

    n_particles, box_length [m] (cubic periodic box), diameter [m], mass [kg], kT [J] (the
    translational temperature: 2/3 of the mean translational kinetic energy per particle),
    youngs_modulus [Pa], poisson, dt: the integrator's time step [s] (None: not known).
    """
    n_particles: int
    box_length: float
    diameter: float
    mass: float
    kT: float
    youngs_modulus: float
    poisson: float
    dt: float | None = None

    @property
    def number_density(self):
        return self.n_particles / self.box_length ** 3

    @property
    def volume_fraction(self):
        return self.number_density * math.pi * self.diameter ** 3 / 6.0

    @property
    def kn(self):
        r = 0.5 * self.diameter
        return hertz_kn(self.youngs_modulus, self.poisson, r, r)

    def predictions(self, n_chains=2000, n_steps=3000, seed=0):
        """Dict of the kinetic-theory D's [m^2/s] for this gas (dilute Boltzmann, / Enskog chi): the
        full Boltzmann D's for its N particles with zero total momentum (1/N effects: -0.1 % at N = 864,
        within their Monte Carlo error), the first Chapman-Enskog ones for the infinite gas (at that
        order the two 1/N effects cancel)."""
        n, kT, m, sig = self.number_density, self.kT, self.mass, self.diameter
        chi = enskog_chi(self.volume_fraction)
        d_hs1 = d_hard_spheres_first(n, kT, m, sig)
        d_hz1 = d_first_approximation(n, kT, m, sig, self.kn)
        # the Boltzmann D of this periodic gas: N particles, zero total momentum (d_boltzmann)
        big_n = int(self.n_particles)
        d_hs, se_hs = d_boltzmann(n, kT, m, sig, None, n_chains, n_steps, seed=seed, n_particles=big_n)
        d_hz, se_hz = d_boltzmann(n, kT, m, sig, self.kn, n_chains, n_steps, seed=seed + 1, n_particles=big_n)
        # softness: the log-derivative of D in E (first order, central difference over +-10 %).  At
        # fixed velocities, masses scaled by lambda act as kn / lambda, so a mass error x changes D
        # by about -dlnD_dlnE * ln(1 + x); hard spheres (dlnD_dlnE = 0) do not see it.
        d_lo = d_first_approximation(n, kT, m, sig, self.kn / 1.1)
        d_hi = d_first_approximation(n, kT, m, sig, self.kn * 1.1)
        slope = math.log(d_hi / d_lo) / (2.0 * math.log(1.1))
        # the step's own effect on D (the collision map as YADE integrates it); the predictions
        # above are for the exact orbit
        dt_effect = (timestep_shift(kT, 0.5 * m, sig, self.kn, self.dt) if self.dt is not None else math.nan)
        return {"enskog_chi": chi, "dt_effect": dt_effect, "d_hard_first": d_hs1 / chi, "d_hertz_first": d_hz1 / chi,
                "dlnD_dlnE": slope,
                "d_hard_boltzmann": d_hs / chi, "d_hard_boltzmann_se": se_hs / chi,
                "d_hertz_boltzmann": d_hz / chi, "d_hertz_boltzmann_se": se_hz / chi}
