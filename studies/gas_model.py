"""The periodic granular gas of the studies: cases, initial conditions, energies (any clump shape).

Pure numpy (no YADE).  The driver resolves one run of a study spec with these functions and
hands the YADE script everything it needs (member spheres, masses, inertia, initial state) in
one JSON file, so the script knows nothing of specs, shapes or the driver.

The paper's gas (Parteli, DISCUSSION section): two equal spheres of diameter d_s = 0.1333 m
with centres D = d_s/2 apart, density 1140 kg/m^3, E = 1e7 Pa, nu = 0.40, 864 particles in a
cubic periodic box at volume fraction 0.001 of the exact clump volume, translational kinetic
energy 3.24 kJ, zero spin, Hertz-Mindlin normal force only, no damping.  Reference gas:
spheres of diameter 0.20 m whose mass is set to the exact clump mass.

Cases (defined for any shape; masses and inertia from :func:`clumpprops.mass_properties`):

=============  ======================  =====================================================
case           mass                    centre of mass and inertia tensor
=============  ======================  =====================================================
exact          union of the spheres    union (clumpprops.yade clumps)
uncorrected    summed spheres          summed spheres (YADE's appendClumped)
mass_only      union                   summed spheres
inertia_only   summed spheres          union
spheres        ``[spheres] mass``      a sphere of ``[spheres] diameter`` (no torque ever)
=============  ======================  =====================================================

Rotation: a *linear* clump (all centres on one line) with frictionless contacts and zero spin
about its axis moves exactly like a body of isotropic inertia I_perp (every contact force passes
through the axis), so it runs as YADE's non-aspherical body on any YADE; its rotational
degrees of freedom are 2.  With friction a tangential force has a torque about the axis, so a
linear clump then runs as any other clump does.  Any other clump is a full aspherical rigid body (3 rotational
degrees of freedom) and needs a YADE with a conservative aspherical integrator (>= 2025,
``rotAlgorithm='delValle2023'``).
"""
from __future__ import annotations

import numpy as np

from .shapes import rotations_z_to

# ---- the paper's numbers (defaults of the specs and the tests) -------------------------------
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
PAPER_DIMER = {"kind": "dimer", "sphere_diameter": D_SPHERE, "overlap": 0.5}

CASES = ("exact", "uncorrected", "mass_only", "inertia_only", "spheres")
# case -> (mass source, COM/inertia source); "exact" = union, "sum" = summed spheres
CASE_SOURCES = {
    "exact": ("exact", "exact"),
    "uncorrected": ("sum", "sum"),
    "mass_only": ("exact", "sum"),
    "inertia_only": ("sum", "exact"),
}
PROTOCOLS = ("paired", "equal_energy")
SPIN_PAIRINGS = ("own", "same")          # see initial_state
STARTS = ("zero_spin", "equipartition")


def dimer_properties(method: str):
    """(mass kg, volume m^3, I_axial, I_perp kg m^2, method) of the paper's dimer (tests)."""
    from . import shapes

    p = shapes.properties(PAPER_DIMER, DENSITY)[method if method != "pairwise" else "exact"]
    pm = p["principal_moments"]
    return p["mass"], p["volume"], pm[0], pm[2], method


def resolve_case(props, case, spheres=None, friction=0.0):
    """Body of one case: what the YADE script builds and which mass and inertia it gets.

    ``props``: :func:`studies.shapes.properties` of the shape; ``spheres``: the spec's
    ``[spheres]`` table (``diameter`` in m or ``"equal_volume"``; ``mass`` ``"exact"`` (the
    exact clump mass) or ``"density"`` (the sphere's own volume x density)) with ``density``;
    ``friction``: the contact's Coulomb coefficient (with friction a linear clump takes the
    aspherical route).

    Returns a dict: ``body`` ("clump" | "sphere"); ``mass`` kg; ``moments`` (3,) kg m^2 (the
    principal moments the body integrates with; isotropic for frictionless linear clumps and spheres);
    ``route`` ("isotropic" | "aspherical"); ``builder`` ("appendClumped" | "clumpprops");
    ``rot_dof`` (0, 2 or 3); ``radius`` (spheres only).
    """
    if case not in CASES:
        raise ValueError(f"unknown case {case!r}; choose from {', '.join(CASES)}")
    ex = props["exact"]
    if case == "spheres":
        sp = spheres or {}
        dia = sp.get("diameter", "equal_volume")
        if dia == "equal_volume":
            dia = 2.0 * (3.0 * ex["volume"] / (4.0 * np.pi)) ** (1.0 / 3.0)
        dia = float(dia)
        msrc = sp.get("mass", "exact")
        mass = ex["mass"] if msrc == "exact" else float(sp["density"]) * np.pi / 6.0 * dia ** 3
        i0 = 0.4 * mass * (dia / 2) ** 2
        return {"case": case, "body": "sphere", "mass": float(mass), "moments": [i0, i0, i0],
                "route": "isotropic", "builder": "sphere", "rot_dof": 0, "radius": dia / 2,
                "mass_source": msrc, "inertia_source": None}
    msrc, isrc = CASE_SOURCES[case]
    mass = props[msrc]["mass"]
    pm = props[isrc]["principal_moments"]
    com_shift = np.linalg.norm(np.asarray(props["sum"]["com"])) / max(props["radii"])
    if props["linear"] and not friction:
        i_perp = pm[2]
        moments = [i_perp] * 3
        route, dof = "isotropic", 2
        # no correction bodies for the isotropic route: appendClumped gives the members and the
        # summed COM, which is the exact one for symmetric clumps; else clumpprops places it
        builder = "clumpprops" if (isrc == "exact" and com_shift > 1e-12) else "appendClumped"
    else:
        moments = list(pm)
        route, dof = "aspherical", 3
        builder = "clumpprops" if isrc == "exact" else "appendClumped"
    return {"case": case, "body": "clump", "mass": float(mass), "moments": [float(x) for x in moments],
            "route": route, "builder": builder, "rot_dof": dof, "mass_source": msrc,
            "inertia_source": isrc}


def box_length(n_particles, exact_volume, volume_fraction=VOLUME_FRACTION):
    """Cubic box edge (m) so that n exact clumps fill ``volume_fraction`` of it."""
    return float((n_particles * exact_volume / volume_fraction) ** (1.0 / 3.0))


def effective_protocol(case_res, exact_mass, protocol):
    """``equal_energy`` differs from ``paired`` only for a case whose mass is not the exact one."""
    if protocol not in PROTOCOLS:
        raise ValueError(f"unknown protocol {protocol!r}")
    return "paired" if case_res["mass"] == exact_mass and case_res["body"] == "clump" and \
        case_res["mass_source"] == "exact" else protocol


def _rot_z(phi):
    c, s = np.cos(phi), np.sin(phi)
    R = np.zeros((len(phi), 3, 3))
    R[:, 0, 0] = c
    R[:, 0, 1] = -s
    R[:, 1, 0] = s
    R[:, 1, 1] = c
    R[:, 2, 2] = 1.0
    return R



# m between the bounding spheres of two particles at the start
PLACEMENT_GAP = 0.02


def random_sequential_positions(rng, n, box, dmin):
    """(n, 3) positions [m] uniform in the periodic cube of side ``box`` [m], every pair at least
    ``dmin`` [m] apart (minimum image): random sequential addition with ``rng``.  RuntimeError
    after 1000 n tries (the box too small)."""
    pos = np.empty((n, 3))
    k = 0
    tries = 0
    while k < n:
        p = rng.uniform(0.0, box, 3)
        d = pos[:k] - p
        d -= box * np.round(d / box)
        if k == 0 or np.min(np.einsum("ij,ij->i", d, d)) > dmin ** 2:
            pos[k] = p
            k += 1
        tries += 1
        if tries > 1000 * n:
            raise RuntimeError("box too small to place the particles")
    return pos

def initial_state(seed, n_particles, box, bounding_radius, case_res, exact_mass, exact_inertia=None,
                  case_inertia=None, protocol="paired", energy_per_particle=ENERGY_PER_PARTICLE,
                  start="zero_spin", linear=True, gap=None, spin_pairing="same", spin_ratio=0.0):
    """Initial state of one run: centres (n, 3) m in [0, box), orientations (n, 3, 3) (body to
    world), velocities (n, 3) m/s and angular velocities (n, 3) rad/s (world frame).

    Everything depends on ``seed`` only, never on the case, so all cases of a seed start from
    the same state (the same random draws in the same order: positions, axes, velocities, then
    twist angles and body-frame angular velocities; the first three are those of the paper's
    study since its first version).  Positions: random sequential placement with exclusion
    distance 2 ``bounding_radius`` + ``gap`` (periodic).  Orientation: the body z axis goes to a
    random direction, twisted about it by a random angle.  Velocities: Maxwellian with zero total
    momentum, scaled so that the translational kinetic energy is n x ``energy_per_particle``
    (with the exact mass for ``paired``, the case's own for ``equal_energy``).

    ``start="zero_spin"`` (the paper): no rotation.  ``start="equipartition"``: the total kinetic
    energy per particle is still ``energy_per_particle``, shared as kT/2 per degree of freedom
    (3 translational + 2 (linear clumps, no spin about the axis) or 3 rotational); body-frame
    angular velocities are Gaussian, the same normal draws in every case, set by ``spin_pairing``:

    * ``"own"``: each case starts in equipartition at its own temperature, the one the paper's
      zero-spin start relaxes to.  Covariance kT_c I_c^-1 with the case's inertia ``case_inertia``
      ((3, 3) kg m^2, body frame; a linear clump's is isotropic about its axis, so its draw is
      the exact one rescaled), and rotational energy (m_c / m_scale) x the exact case's: the
      translational energy of the paired velocities scales with the case's mass m_c, and so does
      the rotational.  Thermal speeds are then the same in every case of ``paired``, as from the
      paper's start.
    * ``"same"`` (the first equilibrated runs, kept for their records): every case gets the exact
      case's angular velocities (``paired``), or the exact covariance rescaled to the exact
      rotational energy with ``case_inertia`` (``equal_energy``).  A ``paired`` case whose
      k^2 = I/m differs from exact then starts out of equipartition and relaxes (rotational
      relaxation time ~28 s for the dimer) to thermal speeds that differ from exact: for the
      paper's dimer uncorrected, translational energy per unit mass falls 4.6 %, a bias of
      about -2.3 % in D unrelated to collisions (docs/granular_gas.md).

    For ``exact`` (and, for linear clumps, for ``equal_energy``) the two give the same state.

    A sphere gas gets no spin from ``start``.  ``spin_ratio`` > 0 gives its spheres Gaussian
    angular velocities (the same normal draws a clump's spins use) whose rotational energy is
    ``spin_ratio`` times the translational: T_rot / T_tr = ``spin_ratio`` at t = 0, so that a rough
    gas can approach its HCS ratio from above as well as from below (zero spin).
    """
    if start not in STARTS:
        raise ValueError(f"unknown start {start!r}")
    if spin_pairing not in SPIN_PAIRINGS:
        raise ValueError(f"unknown spin_pairing {spin_pairing!r} (known: {', '.join(SPIN_PAIRINGS)})")
    rng = np.random.default_rng(seed)
    gap = PLACEMENT_GAP if gap is None else gap
    pos = random_sequential_positions(rng, n_particles, box, 2 * bounding_radius + gap)
    axes = rng.normal(size=(n_particles, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    vel = rng.normal(size=(n_particles, 3))
    vel -= vel.mean(axis=0)
    twist = rng.uniform(0.0, 2 * np.pi, n_particles)
    z = rng.normal(size=(n_particles, 3))
    ori = rotations_z_to(axes) @ _rot_z(twist)
    own = effective_protocol(case_res, exact_mass, protocol) == "equal_energy"
    m_scale = case_res["mass"] if own else exact_mass
    rot_dof = 2 if linear else 3
    spin = start == "equipartition" and case_res["body"] == "clump"
    f_dof = 3 + (rot_dof if start == "equipartition" else 0)
    e_total = n_particles * energy_per_particle
    vel *= np.sqrt(e_total * 3.0 / f_dof / (0.5 * m_scale * np.sum(vel ** 2)))
    angvel = np.zeros((n_particles, 3))
    if spin:
        own_spin = spin_pairing == "own"
        # the covariance's shape: a linear clump's perpendicular inertia is isotropic in every case,
        # so its draw is the exact one (rescaled below); an aspherical case's is its own (``own``)
        I = np.asarray(case_inertia if own_spin and not linear else exact_inertia, float)
        if linear:              # body z is the axis: rotation about x and y only
            I2 = I[:2, :2]
            w, V = np.linalg.eigh(I2)
            wb = np.zeros((n_particles, 3))
            wb[:, :2] = (z[:, :2] / np.sqrt(w)) @ V.T
        else:
            w, V = np.linalg.eigh(I)
            wb = (z / np.sqrt(w)) @ V.T             # covariance V diag(1/w) V^T = I^-1
        I_scale = np.asarray(case_inertia if own or own_spin else exact_inertia, float)
        e_rot = e_total * rot_dof / f_dof
        if own_spin:            # the rotational energy scales with the case's mass, as the translational
            e_rot *= case_res["mass"] / m_scale
        wb *= np.sqrt(e_rot / (0.5 * np.einsum("ni,ij,nj->", wb, I_scale, wb)))
        angvel = np.einsum("nij,nj->ni", ori, wb)
    elif spin_ratio > 0 and case_res["body"] == "sphere":
        e_rot = spin_ratio * 0.5 * m_scale * np.sum(vel ** 2)
        angvel = z * np.sqrt(e_rot / (0.5 * case_res["moments"][0] * np.sum(z ** 2)))
    return pos, ori, vel, angvel
