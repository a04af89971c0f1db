"""The paper's periodic granular gas: parameters, cases, initial conditions, energies.

Pure numpy (no YADE import), shared by the YADE script ``yade_scripts/granular_gas.py``,
the driver/analysis in :mod:`studies.granular_gas` and the tests.

Set-up (Parteli, DISCUSSION section): two equal spheres of diameter d_s = 0.1333 m with
centres D = d_s/2 apart, density 1140 kg/m^3, E = 1e7 Pa, nu = 0.40, 864 particles in a
cubic periodic box at volume fraction 0.001 of the exact clump volume, total kinetic
energy 3.24 kJ, Hertz-Mindlin normal force only, no damping.  Reference gas: spheres of
diameter 0.20 m whose mass is set to the exact clump mass.

Every mass, moment of inertia and volume below comes from :func:`clumpprops.mass_properties`.
"""
from __future__ import annotations

import functools
import hashlib
import os

import numpy as np

# ---- the paper's numbers -------------------------------------------------------------
D_SPHERE = 0.1333            # m, diameter of a clump member
R_SPHERE = D_SPHERE / 2      # m
CENTRE_DISTANCE = D_SPHERE / 2   # m, D = d_s / 2
D_BIG = 0.20                 # m, the reference spheres
DENSITY = 1140.0             # kg/m^3
YOUNG = 1.0e7                # Pa
POISSON = 0.40
N_PAPER = 864
VOLUME_FRACTION = 0.001
KINETIC_ENERGY_PAPER = 3240.0            # J, whole gas of 864
ENERGY_PER_PARTICLE = KINETIC_ENERGY_PAPER / N_PAPER   # 3.75 J

# half-length of the dimer = D/2 + d_s/2 = 0.1 m = radius of the reference sphere, so one
# exclusion radius serves every case when placing particles
BOUNDING_RADIUS = max(CENTRE_DISTANCE / 2 + R_SPHERE, D_BIG / 2)

# case -> (shape, mass source, inertia source); "exact"/"sum" are clumpprops methods
CASES = {
    "exact": ("dimer", "exact", "exact"),
    "uncorrected": ("dimer", "sum", "sum"),
    "mass_only": ("dimer", "exact", "sum"),
    "inertia_only": ("dimer", "sum", "exact"),
    "spheres": ("sphere", "exact", None),
}
PROTOCOLS = ("paired", "equal_energy")


def dimer_members(axis=(0.0, 0.0, 1.0)):
    """Member centres (2, 3) relative to the dimer centre, and radii (2,)."""
    u = np.asarray(axis, float)
    u = u / np.linalg.norm(u)
    h = CENTRE_DISTANCE / 2
    return np.array([-h * u, h * u]), np.array([R_SPHERE, R_SPHERE])


@functools.lru_cache(maxsize=None)
def dimer_properties(method: str):
    """(mass kg, volume m^3, I_axial, I_perp kg m^2, method actually used) of the dimer.

    ``method="exact"`` falls back to the paper's ``"pairwise"`` (identical for two
    spheres) while the exact module is not available.
    """
    import clumpprops

    c, r = dimer_members()
    used = method
    try:
        mp = clumpprops.mass_properties(c, r, density=DENSITY, method=method)
    except (ImportError, ModuleNotFoundError):
        if method != "exact":
            raise
        used = "pairwise"
        mp = clumpprops.mass_properties(c, r, density=DENSITY, method="pairwise")
    pm = np.asarray(mp.principal_moments, float)    # ascending: axial, perp, perp
    if not np.isclose(pm[1], pm[2], rtol=1e-12):
        raise AssertionError(f"dimer is not axisymmetric: {pm}")
    return float(mp.mass), float(mp.volume), float(pm[0]), float(pm[2]), used


def case_properties(case: str):
    """Dict with shape, mass, inertia (isotropic, kg m^2) and the member layout of a case."""
    if case not in CASES:
        raise ValueError(f"unknown case {case!r}; choose from {', '.join(CASES)}")
    shape, msrc, isrc = CASES[case]
    m_exact, v_exact, _, ip_exact, used = dimer_properties("exact")
    mass = dimer_properties(msrc)[0]
    if shape == "dimer":
        inertia = dimer_properties(isrc)[3]
        radius = R_SPHERE
    else:
        radius = D_BIG / 2
        inertia = 0.4 * mass * radius ** 2      # never used (no torque), kept physical
    return {"case": case, "shape": shape, "mass": mass, "inertia": inertia,
            "radius": radius, "mass_method": msrc, "inertia_method": isrc,
            "exact_method_used": used}


def box_length(n_particles: int, volume_fraction: float = VOLUME_FRACTION) -> float:
    """Cubic box edge so that n exact clumps fill ``volume_fraction`` of it (m)."""
    v = dimer_properties("exact")[1]
    return float((n_particles * v / volume_fraction) ** (1.0 / 3.0))


def effective_protocol(case: str, protocol: str) -> str:
    """``equal_energy`` only differs from ``paired`` for cases whose mass is not exact."""
    if protocol not in PROTOCOLS:
        raise ValueError(f"unknown protocol {protocol!r}")
    return "paired" if CASES[case][1] == "exact" else protocol


def initial_conditions(seed: int, n_particles: int, box: float, case: str, protocol: str = "paired",
                       energy_per_particle: float = ENERGY_PER_PARTICLE, gap: float = 0.02):
    """Centres (n,3) in [0, box), unit axes (n,3), velocities (n,3) of one run.

    Positions, axes and the velocity *directions* depend on ``seed`` only (never on the
    case), so all cases of a seed start from the same state.  Velocities are Maxwellian
    with zero total momentum, scaled so that the translational kinetic energy is
    ``n * energy_per_particle`` with the exact clump mass (``paired``) or with the case's
    own mass (``equal_energy``).
    """
    rng = np.random.default_rng(seed)
    dmin = 2 * BOUNDING_RADIUS + gap
    pos = np.empty((n_particles, 3))
    k = 0
    tries = 0
    while k < n_particles:
        p = rng.uniform(0.0, box, 3)
        d = pos[:k] - p
        d -= box * np.round(d / box)
        if k == 0 or np.min(np.einsum("ij,ij->i", d, d)) > dmin ** 2:
            pos[k] = p
            k += 1
        tries += 1
        if tries > 1000 * n_particles:
            raise RuntimeError("box too small to place the particles")
    axes = rng.normal(size=(n_particles, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    vel = rng.normal(size=(n_particles, 3))
    vel -= vel.mean(axis=0)
    m_exact = dimer_properties("exact")[0]
    m_scale = m_exact if effective_protocol(case, protocol) == "paired" else case_properties(case)["mass"]
    e_target = n_particles * energy_per_particle
    vel *= np.sqrt(e_target / (0.5 * m_scale * np.sum(vel ** 2)))
    return pos, axes, vel


def energies(mass, inertia, vel, angvel):
    """Translational and rotational kinetic energy (J) of the gas; arrays (..., n, 3).

    Rotation uses the case's isotropic inertia (exact for these frictionless dimers,
    see docs/granular_gas.md); YADE's ``O.energy['kinRot']`` is wrong for clumps.
    """
    e_t = 0.5 * mass * np.sum(vel ** 2, axis=(-1, -2))
    e_r = 0.5 * inertia * np.sum(angvel ** 2, axis=(-1, -2))
    return e_t, e_r


def file_sha(path: str) -> str:
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def repo_root() -> str:
    return os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def code_version() -> str:
    """Hash of the code that determines a run's output (YADE script + this module)."""
    root = repo_root()
    h = hashlib.sha256()
    for rel in ("yade_scripts/granular_gas.py", "studies/gas_model.py"):
        h.update(file_sha(os.path.join(root, rel)).encode())
    return h.hexdigest()[:12]
