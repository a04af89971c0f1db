"""Clump shapes of the gas studies: member spheres of one clump, and their mass properties.

Pure numpy + :func:`clumpprops.mass_properties` (no YADE).  A shape is a dict from a study
spec (``[[shapes]]`` tables of ``studies/specs/*.toml``):

* ``dimer``            two spheres of diameter ``sphere_diameter`` with centres
                       D = ``overlap`` x d_s apart (the paper: d_s = 0.1333 m, D/d_s = 0.5);
* ``trimer_linear``    three spheres on a line, neighbours D apart;
* ``trimer_triangle``  three spheres on an equilateral triangle of side D;
* ``tetrahedron``      four spheres on a regular tetrahedron of edge D;
* ``file``             one clump of a YADE ``textClumps`` file (``path``, relative to the
                       repository or absolute; ``scale`` multiplies lengths).

``overlap`` is the ratio D/d_s of the centre distance of touching neighbours to the sphere
diameter ("overlap ratio" in the paper's sense: 1 = tangent, smaller = deeper overlap).
Every shape is returned centred on its exact centre of mass (``members``), so the position of
a particle in the gas is the position of its exact centre of mass.
"""
from __future__ import annotations

import functools
import json
import os

import numpy as np

KINDS = ("dimer", "trimer_linear", "trimer_triangle", "tetrahedron", "file")


def _unit_layout(kind):
    """Member centres (n, 3) for unit neighbour distance, centred on the origin."""
    if kind == "dimer":
        x = np.array([[0.0, 0.0, -0.5], [0.0, 0.0, 0.5]])
    elif kind == "trimer_linear":
        x = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    elif kind == "trimer_triangle":
        r = 1.0 / np.sqrt(3.0)           # circumradius of a unit equilateral triangle
        a = np.deg2rad([90.0, 210.0, 330.0])
        x = np.stack([r * np.cos(a), r * np.sin(a), np.zeros(3)], axis=1)
    elif kind == "tetrahedron":
        x = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float) / (2 * np.sqrt(2.0))
    else:
        raise ValueError(f"unknown shape kind {kind!r}; choose from {', '.join(KINDS)}")
    return x


def _read_template(path, scale, root):
    from clumpprops.textclumps import read_text_clumps

    p = path if os.path.isabs(path) else os.path.join(root, path)
    clumps = read_text_clumps(p)
    if len(clumps) != 1:
        raise ValueError(f"shape file {path}: expected one clump, found {len(clumps)}")
    c = clumps[0]
    return np.asarray(c.centers, float) * scale, np.asarray(c.radii, float) * scale


def raw_members(shape, root=None):
    """Member centres (n, 3) in m and radii (n,) in m of a shape dict, before centring."""
    kind = shape["kind"]
    if kind == "file":
        return _read_template(shape["path"], float(shape.get("scale", 1.0)), root or _repo_root())
    d = float(shape["sphere_diameter"])
    D = float(shape["overlap"]) * d
    x = _unit_layout(kind) * D
    return x, np.full(len(x), d / 2)


def _repo_root():
    return os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def is_linear(centers, tol=1e-12):
    """True if every member centre lies on one line (an axisymmetric clump)."""
    c = np.asarray(centers, float)
    if len(c) <= 2:
        return True
    d = c - c[0]
    scale = max(np.max(np.linalg.norm(d, axis=1)), 1e-300)
    s = np.linalg.svd(d / scale, compute_uv=False)
    return bool(s[1] <= tol)


def body_frame(centers, radii, density):
    """Rotation (3, 3) whose columns are the body axes of a clump, in the input frame.

    Linear clumps: z along the line of centres (the symmetry axis).  Others: the exact principal
    axes, ascending moments on x, y, z.  Generated shapes are already in their body frame
    (identity up to the order of equal moments)."""
    import clumpprops

    c = np.asarray(centers, float)
    if is_linear(c):
        if len(c) == 1:
            return np.eye(3)
        d = c - c.mean(axis=0)
        return rotations_z_to(np.linalg.svd(d)[2][:1])[0]
    mp = clumpprops.mass_properties(c, radii, density=density, method="exact")
    m = np.asarray(mp.principal_moments)
    if np.ptp(m) <= 1e-12 * m.max():        # isotropic (e.g. the tetrahedron): keep the input axes
        return np.eye(3)
    return np.asarray(mp.principal_axes)


def rotations_z_to(u):
    """Rotation matrices (n, 3, 3) taking e_z to the unit vectors u (n, 3) (Rodrigues' formula
    from +z for u_z >= 0, from -z composed with a half turn about x otherwise: no cancellation)."""
    u = np.asarray(u, float)
    flip = u[:, 2] < 0
    w = np.where(flip[:, None], -u, u)              # w_z >= 0
    v = np.stack([-w[:, 1], w[:, 0], np.zeros(len(w))], axis=1)     # e_z x w
    vx = np.zeros((len(w), 3, 3))
    vx[:, 0, 1], vx[:, 0, 2] = -v[:, 2], v[:, 1]
    vx[:, 1, 0], vx[:, 1, 2] = v[:, 2], -v[:, 0]
    vx[:, 2, 0], vx[:, 2, 1] = -v[:, 1], v[:, 0]
    R = np.eye(3) + vx + vx @ vx / (1.0 + w[:, 2])[:, None, None]
    R[flip] = -R[flip] @ np.diag([-1.0, 1.0, 1.0])     # takes e_z to -w = u, det +1
    return R


@functools.lru_cache(maxsize=None)
def _props_cached(key):
    import clumpprops

    shape = json.loads(key)
    c, r = raw_members(shape)
    density = shape["_density"]
    if shape["kind"] == "file":               # rotate a template into its body frame
        ex0 = clumpprops.mass_properties(c, r, density=density, method="exact")
        c = (c - np.asarray(ex0.center_of_mass)) @ body_frame(c, r, density)
    ex = clumpprops.mass_properties(c, r, density=density, method="exact")
    sm = clumpprops.mass_properties(c, r, density=density, method="sum")
    com = np.asarray(ex.center_of_mass)
    members = c - com
    return {
        "members": members.tolist(), "radii": r.tolist(),
        "linear": is_linear(c),
        "exact": _summary(ex, com),
        "sum": _summary(sm, com),
        "clumpprops_version": clumpprops.__version__,
    }


def _summary(mp, com_ref):
    """Mass (kg), volume (m^3), COM relative to the exact COM (m), inertia tensor about its own
    COM in the shape's axes (kg m^2), ascending principal moments and axes (columns)."""
    return {"mass": float(mp.mass), "volume": float(mp.volume),
            "com": (np.asarray(mp.center_of_mass) - com_ref).tolist(),
            "inertia": np.asarray(mp.inertia).tolist(),
            "principal_moments": np.asarray(mp.principal_moments).tolist(),
            "principal_axes": np.asarray(mp.principal_axes).tolist()}


def properties(shape, density):
    """Members (in the body frame, centred on the exact COM), radii, and exact / summed mass properties of a shape.

    Returns a dict: ``members`` (n, 3) m, ``radii`` (n,) m, ``linear`` (bool), ``exact`` and
    ``sum`` (each: mass kg, volume m^3, com m relative to the exact COM, inertia (3, 3) kg m^2
    about its own COM, principal_moments (3,) ascending, principal_axes (3, 3) columns),
    ``clumpprops_version``.  The summed values are YADE's ``appendClumped`` (overlaps counted
    twice); the exact ones are the union of the spheres (clumpprops' exact method).
    """
    key = dict(shape, _density=float(density))
    return _props_cached(json.dumps(key, sort_keys=True))


def bounding_radius(shape, density):
    """Largest distance (m) from the exact COM to a point of the clump."""
    p = properties(shape, density)
    return float(np.max(np.linalg.norm(np.asarray(p["members"]), axis=1) + np.asarray(p["radii"])))


def mass_error(shape, density, mass="sum"):
    """m / m_exact - 1 of a body whose mass comes from ``mass`` ("sum": the summed spheres, the
    relative mass error of summing them; "exact": 0).  Dimensionless."""
    p = properties(shape, density)
    return p[_source(mass)]["mass"] / p["exact"]["mass"] - 1.0


def _source(name):
    if name not in ("sum", "exact"):
        raise ValueError(f"mass or inertia source must be 'sum' or 'exact', not {name!r}")
    return name


def k2_error(shape, density, mass="sum", inertia="sum"):
    """Relative error of the squared radius of gyration k^2 = I/m of a body whose mass comes from
    ``mass`` and whose inertia from ``inertia`` ("sum" | "exact"; the defaults: the summed clump,
    YADE's appendClumped) against the exact clump's (inertia about each body's own COM).

    I is the mean principal moment over the axes a contact between frictionless spheres can
    turn the clump about: a linear clump's two transverse axes (its axial moment never enters
    its motion: a frictionless contact's force passes through a member's centre, on the axis),
    all three axes otherwise, i.e. tr(I)/3.  For a dimer this is I_perp/m, the number the
    collision maps report as "largest moment over mass" (studies/maps.py).  The summed
    clump's I is eq. 6 of the paper without its overlap term; the exact one, eqs. 3-7.
    Dimensionless."""
    p = properties(shape, density)

    def moment(s):
        inertia = np.asarray(s["inertia"], float)        # body frame: a linear clump's axis is z
        return (inertia[0, 0] + inertia[1, 1]) / 2 if p["linear"] else np.trace(inertia) / 3

    ex = p["exact"]
    k2 = moment(p[_source(inertia)]) / p[_source(mass)]["mass"]
    return float(k2 / (moment(ex) / ex["mass"]) - 1.0)
