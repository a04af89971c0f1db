"""YADE adapter: clumps that carry the exact mass properties from the moment they are built.

YADE (2023.02a) builds a clump's mass, centre of mass and inertia by summing its
member spheres (``discretization=0``: overlaps counted twice) or by voxelising
them (``discretization>0``: approximate and slow).  This module swaps one call
for the YADE one and the clump in the simulation has the properties
:func:`clumpprops.mass_properties` gives for the union of its spheres.

How (the *correction member*)
-----------------------------
``Clump::updateProperties`` sums each NON-spherical member with its own
``state.mass``, ``state.pos``, ``state.inertia`` and ``state.ori``.  Every
corrected clump gets one extra member, the correction: a body with the bare base
class ``Shape`` (no ``Bo1`` functor exists for it) and ``bounded=False``, so it
never has a bound, never enters collision detection and never makes a contact.
Its state holds exactly the difference "exact minus summed spheres":

* mass ``m_c = m_exact - sum(m_i)`` (negative where spheres overlap),
* position ``p_c`` such that the first moments add up to the exact centre of mass,
* principal moments and orientation such that the summed inertia tensor about the
  exact centre of mass equals the exact tensor (eigenvalues may be negative).

YADE then computes mass, centre of mass, principal moments and axes itself, so the
correction is part of the scene: it is saved by ``O.save``/``O.saveTmp``, and a
later ``O.bodies.updateClumpProperties(discretization=0)`` reproduces the exact
values.  Member spheres are not touched: they keep their material (true density),
radius and world position.  Forces applied per member through the body's mass
(``GravityEngine``) act on the correction member too, so the clump receives the
exact weight ``m_exact g`` through the exact centre of mass.

Limits (YADE's, documented in docs/yade_adapter.md): ``updateClumpProperties``
with ``discretization > 0`` (its default is 5!) voxelises the spheres only and
ignores the correction; call :func:`correct_all_clumps` (or
``updateClumpProperties(discretization=0)``) afterwards to restore the exact values.

Nothing here is imported by ``import clumpprops``; YADE itself is imported inside
the functions, so this module works both in scripts run by the ``yade``
executable and after a plain ``import yade``.
"""
from __future__ import annotations

import math

import numpy as np

from .api import DEFAULT_METHOD, mass_properties

__all__ = [
    "append_clump",
    "append_clumps",
    "correct_clump",
    "correct_clumps",
    "correct_all_clumps",
    "replace_by_clumps",
    "text_clumps",
    "correction_id",
    "sphere_member_ids",
    "is_correction",
    "exact_properties",
    "clump_errors",
    "set_clump_velocity",
    "ClumpAdapterError",
]


class ClumpAdapterError(ValueError):
    """Bad input to the YADE adapter; the message names the offending body id.

    Raised before anything in the scene is modified.
    """


# --------------------------------------------------------------------------- YADE access (lazy)


class _Y:
    """The handful of YADE objects used here, imported on first use."""

    _loaded = False

    @classmethod
    def load(cls):
        if not cls._loaded:
            import yade  # noqa: F401  (initialises YADE on a plain import)
            from yade import wrapper
            from yade.minieigenHP import Matrix3, Quaternion, Vector3

            cls.O = yade.O
            cls.Body = wrapper.Body
            cls.Shape = wrapper.Shape
            cls.Sphere = wrapper.Sphere
            cls.Clump = wrapper.Clump
            cls.Vector3 = Vector3
            cls.Quaternion = Quaternion
            cls.Matrix3 = Matrix3
            cls._loaded = True
        return cls


def is_correction(body) -> bool:
    """True if ``body`` is a correction member made by this module.

    A correction is a clump member whose shape is exactly the base class ``Shape``
    (no YADE body has that for any other purpose: it has no bound, collision or
    rendering functor) and which is not bounded.
    """
    Y = _Y.load()
    return body is not None and type(body.shape) is Y.Shape and not body.bounded and body.isClumpMember


def _vec(v):
    return np.array([float(v[0]), float(v[1]), float(v[2])])


def _rotation(q):
    """Rotation matrix (numpy) of a minieigen quaternion."""
    m = q.toRotationMatrix()
    return np.array([[float(m[i, j]) for j in range(3)] for i in range(3)])


# --------------------------------------------------------------------------- the correction member (no YADE objects)


def correction_terms(centers, radii, densities, mass, com, inertia):
    """State of the correction members of a batch of clumps (no YADE objects; arithmetic in the core).

    centers: list of (N_m, 3) world positions of the member spheres; radii: list of (N_m,);
    densities: list of (N_m,) material densities (as YADE reads them);
    mass (M,), com (M, 3), inertia (M, 3, 3): the target (exact) properties.

    Returns (mass_c (M,), offset_c (M, 3), moments_c (M, 3), axes_c (M, 3, 3) right-handed
    columns): the correction sits at ``com + offset_c`` and spheres + correction sum, the
    way ``Clump::updateProperties`` sums them, to the target.  All sums are taken about the
    target centre of mass, so nothing is lost to cancellation however far the clump is from
    the origin.
    """
    from .core import _core  # the same arithmetic, compiled (one call for the batch)

    M = len(centers)
    counts = np.fromiter(map(len, radii), np.int64, M)
    starts = np.zeros(M + 1, np.int64)
    np.cumsum(counts, out=starts[1:])
    x = np.ascontiguousarray(np.concatenate([np.asarray(c, float).reshape(-1, 3) for c in centers]))
    r = np.ascontiguousarray(np.concatenate([np.asarray(a, float).ravel() for a in radii]))
    rho = np.ascontiguousarray(np.concatenate([np.asarray(a, float).ravel() for a in densities]))
    mass = np.ascontiguousarray(mass, float).reshape(M)
    com = np.ascontiguousarray(com, float).reshape(M, 3)
    inertia = np.ascontiguousarray(inertia, float).reshape(M, 3, 3)
    m_c, off, w, V = np.empty(M), np.empty((M, 3)), np.empty((M, 3)), np.empty((M, 3, 3))
    # sums about the target COM; off = -S / m_c clamped to the clump's reach (in exact arithmetic
    # the excess "summed minus union" is a non-negative distribution inside the clump);
    # J = inertia - I_spheres - m_c (|off|^2 1 - off off^T), symmetrised, right-handed eigenvectors
    _core.correction(x, r, rho, starts, mass, com, inertia, m_c, off, w, V)
    return m_c, off, w, V


# --------------------------------------------------------------------------- reading the scene


def _body(bid, what="body"):
    Y = _Y.load()
    try:
        i = int(bid)
    except (TypeError, ValueError):
        raise ClumpAdapterError(f"{what} id {bid!r} is not an integer") from None
    if isinstance(bid, float) and bid != i:
        raise ClumpAdapterError(f"{what} id {bid!r} is not an integer")
    if i < 0 or i >= len(Y.O.bodies) or Y.O.bodies[i] is None:
        raise ClumpAdapterError(f"body #{i} does not exist (O.bodies has {len(Y.O.bodies)} slots)")
    return Y.O.bodies[i]


def _split_members(clump_body):
    """(sphere member bodies, correction member or None) of a clump; raises on anything else."""
    Y = _Y.load()
    cid = clump_body.id
    spheres, corr = [], []
    for mid in sorted(int(k) for k in clump_body.shape.members.keys()):
        b = Y.O.bodies[mid]
        if b is None:
            raise ClumpAdapterError(f"clump #{cid}: member #{mid} does not exist")
        if type(b.shape) is Y.Sphere or isinstance(b.shape, Y.Sphere):
            if b.material is None:
                raise ClumpAdapterError(f"clump #{cid}: sphere member #{mid} has no material (density unknown)")
            spheres.append(b)
        elif is_correction(b):
            corr.append(b)
        else:
            kind = type(b.shape).__name__ if b.shape is not None else "no shape"
            raise ClumpAdapterError(
                f"clump #{cid}: member #{mid} is not a sphere ({kind}); only clumps of spheres can be corrected"
            )
    if not spheres:
        raise ClumpAdapterError(f"clump #{cid} has no sphere members")
    if len(corr) > 1:
        raise ClumpAdapterError(f"clump #{cid} has {len(corr)} correction members {[b.id for b in corr]}; expected at most one")
    return spheres, (corr[0] if corr else None)


def _clump_density(label, bodies):
    rho = [float(b.material.density) for b in bodies]
    r0 = rho[0]
    if not all(math.isfinite(p) and p > 0 for p in rho):
        bad = [b.id for b, p in zip(bodies, rho) if not (math.isfinite(p) and p > 0)]
        raise ClumpAdapterError(f"{label}: sphere(s) {bad} have non-positive density")
    if any(abs(p - r0) > 1e-12 * r0 for p in rho):
        raise ClumpAdapterError(
            f"{label}: member spheres have different densities {sorted(set(rho))} "
            f"(ids {[b.id for b in bodies]}); the exact union needs one density"
        )
    return rho


def _geometry(bodies):
    x = np.array([[p[0], p[1], p[2]] for p in (b.state.pos for b in bodies)], dtype=float)
    r = np.array([b.shape.radius for b in bodies], dtype=float)
    return x, r


def exact_properties(clump_id, method=DEFAULT_METHOD):
    """The library's :class:`~clumpprops.MassProperties` of a clump's member spheres, where they are now."""
    cb = _body(clump_id, "clump")
    if not cb.isClump:
        raise ClumpAdapterError(f"body #{cb.id} is not a clump")
    spheres, _ = _split_members(cb)
    rho = _clump_density(f"clump #{cb.id}", spheres)
    x, r = _geometry(spheres)
    return mass_properties(x, r, density=rho[0], method=method)


def _batch_properties(xs, rs, rhos, method):
    """mass, com, inertia arrays for a ragged batch, calling the library once per density."""
    M = len(xs)
    d0 = rhos[0][0]
    if all(rho[0] == d0 for rho in rhos):  # one density (the usual case): one call
        mp = mass_properties(xs, rs, density=d0, method=method)
        return mp.mass, mp.center_of_mass, mp.inertia
    mass = np.empty(M)
    com = np.empty((M, 3))
    inertia = np.empty((M, 3, 3))
    dens = np.array([rho[0] for rho in rhos])
    for value in np.unique(dens):
        idx = np.flatnonzero(dens == value)
        mp = mass_properties([xs[i] for i in idx], [rs[i] for i in idx], density=value, method=method)
        mass[idx] = mp.mass
        com[idx] = mp.center_of_mass
        inertia[idx] = mp.inertia
    return mass, com, inertia


def _make_correction(Y, material, mask, m, p, w, V):
    b = Y.Body()
    b.shape = Y.Shape()
    b.material = material
    b.bounded = False
    b.mask = mask  # engines that select bodies by mask (GravityEngine) must see it like the spheres
    st = b.state
    st.mass = float(m)
    st.pos = Y.Vector3(float(p[0]), float(p[1]), float(p[2]))
    st.inertia = Y.Vector3(float(w[0]), float(w[1]), float(w[2]))
    # Clump::updateProperties adds R^T diag(w) R with R = ori.toRotationMatrix(); we want V diag(w) V^T
    st.ori = Y.Quaternion(Y.Matrix3(*[float(a) for a in V.T.ravel()]))
    st.ori.normalize()
    return b


# --------------------------------------------------------------------------- building


def _place(Y, bodies, positions):
    V3 = Y.Vector3
    for b, x in zip(bodies, np.asarray(positions, dtype=float).tolist()):
        b.state.pos = V3(*x)


def _restore(Y, clump, spheres, positions, corr, offset, origin):
    """Move a clump built around the origin back to ``origin``; spheres to their exact positions.

    ``Clump::updateProperties`` sums inertia about the WORLD origin and then subtracts
    M (|c|^2 1 - c c^T): a clump at distance |c| from the origin loses about
    eps (|c| / size)^2 of its inertia to cancellation (2e-10 for a 0.13 m dimer 30 m away).
    So the clump is built with its member spheres shifted by -origin (origin = the exact
    centre of mass), where the sums are exact to eps, then translated back: member offsets
    and orientations relative to the clump are translation-invariant, so they stay valid.
    The spheres get back their original coordinates bit for bit.
    """
    c = clump.state.pos
    clump.state.pos = Y.Vector3(float(origin[0]) + float(c[0]), float(origin[1]) + float(c[1]), float(origin[2]) + float(c[2]))
    _place(Y, spheres, positions)
    _place(Y, [corr], [origin + offset])


def _check_new_spheres(Y, k, spheres, seen):
    """Validate one input clump; returns (bodies, positions [(x, y, z)], radii, densities)."""
    label = f"clump {k} of the input"
    try:
        spheres = list(spheres)
    except TypeError:
        raise ClumpAdapterError(f"{label} is not a list of bodies") from None
    if not spheres:
        raise ClumpAdapterError(f"{label} is empty")
    Body, Sphere = Y.Body, Y.Sphere
    xs, rs, rho = [], [], []
    for j, b in enumerate(spheres):
        if not isinstance(b, Body):
            raise ClumpAdapterError(f"{label}, item {j}: not a yade Body ({type(b).__name__})")
        if b.id >= 0:
            raise ClumpAdapterError(f"{label}, item {j}: body #{b.id} is already in a scene")
        shape = b.shape
        if not isinstance(shape, Sphere):
            kind = type(shape).__name__ if shape is not None else "no shape"
            raise ClumpAdapterError(f"{label}, item {j}: not a sphere ({kind})")
        mat = b.material
        if mat is None:
            raise ClumpAdapterError(f"{label}, item {j}: sphere has no material (density unknown)")
        r = shape.radius
        if not (r > 0 and math.isfinite(r)):
            raise ClumpAdapterError(f"{label}, item {j}: radius {r} is not positive")
        key = id(b)
        if key in seen:
            raise ClumpAdapterError(f"{label}, item {j}: the same Body object is given twice")
        seen.add(key)
        p = b.state.pos
        xs.append((p[0], p[1], p[2]))
        rs.append(r)
        rho.append(mat.density)
    r0 = rho[0]
    if not (math.isfinite(r0) and r0 > 0) or any(p != r0 for p in rho):
        _clump_density(label, spheres)  # raises with the details (or accepts a 1e-12 spread)
    return spheres, xs, rs, rho


def append_clumps(clumps, method=DEFAULT_METHOD):
    """Append many clumps at once (one library call); returns ``[(clump_id, member_ids), ...]``.

    ``clumps`` is a list of lists of sphere bodies (as made by ``utils.sphere``), one list per
    clump.  ``member_ids`` are the sphere members only (the correction member of each clump is
    ``correction_id(clump_id)``).  Validates everything before the scene is touched.
    """
    Y = _Y.load()
    seen = set()
    checked = [_check_new_spheres(Y, k, s, seen) for k, s in enumerate(clumps)]
    if not checked:
        return []
    xs = [np.array(c[1], dtype=float) for c in checked]
    rs = [np.array(c[2], dtype=float) for c in checked]
    rhos = [c[3] for c in checked]
    try:
        mass, com, inertia = _batch_properties(xs, rs, rhos, method)
    except ValueError as exc:
        raise ClumpAdapterError(f"clump properties could not be computed: {exc}") from exc
    m_c, off, w_c, V_c = correction_terms(xs, rs, rhos, mass, com, inertia)
    # python floats from here: the per-clump loop talks to YADE only
    V3, Q, M3 = Y.Vector3, Y.Quaternion, Y.Matrix3
    com_l, off_l, w_l, m_l = com.tolist(), off.tolist(), w_c.tolist(), m_c.tolist()
    rows_l = np.swapaxes(V_c, 1, 2).reshape(-1, 9).tolist()  # V^T, row by row (see _make_correction)
    append = Y.O.bodies.appendClumped
    out = []
    for k, (spheres, pos, _, _) in enumerate(checked):
        ox, oy, oz = com_l[k]
        for b, (x, y, z) in zip(spheres, pos):  # build near the origin: see _restore
            b.state.pos = V3(x - ox, y - oy, z - oz)
        corr = Y.Body()
        corr.shape = Y.Shape()
        corr.material = spheres[0].material
        corr.bounded = False
        corr.mask = spheres[0].mask
        st = corr.state
        st.mass = m_l[k]
        st.pos = V3(*off_l[k])
        st.inertia = V3(*w_l[k])
        q = Q(M3(*rows_l[k]))
        q.normalize()
        st.ori = q
        cid, mids = append(spheres + [corr], 0)
        c = Y.O.bodies[cid].state
        p = c.pos
        c.pos = V3(ox + p[0], oy + p[1], oz + p[2])
        for b, xyz in zip(spheres, pos):
            b.state.pos = V3(*xyz)
        dx, dy, dz = off_l[k]
        st.pos = V3(ox + dx, oy + dy, oz + dz)
        out.append((cid, list(mids[: len(spheres)])))
    return out


def append_clump(spheres, method=DEFAULT_METHOD):
    """Drop-in for ``O.bodies.appendClumped(spheres)``: returns ``(clump_id, member_ids)``.

    The clump's ``state.mass``, ``state.pos`` and inertia (``state.inertia``, ``state.ori``)
    are the library's values for the union of the spheres (``method``, default exact).
    ``member_ids`` lists the spheres; the clump also holds one collision-free correction
    member (see the module docstring).
    """
    return append_clumps([spheres], method=method)[0]


# --------------------------------------------------------------------------- correcting existing clumps


def _velocity_field(cb):
    st = cb.state
    return _vec(st.pos), _vec(st.vel), _vec(st.angVel)


def set_clump_velocity(clump_id, vel=None, ang_vel=None):
    """Set a clump's linear and angular velocity (world frame), consistently for YADE 2023 and 2025.

    Sets ``state.vel``, ``state.angVel`` and ``state.angMom = R diag(I) R^T angVel`` (YADE 2023
    integrates ``angMom`` for aspherical bodies, YADE 2025 integrates ``angVel``).
    """
    Y = _Y.load()
    b = _body(clump_id)
    st = b.state
    if vel is not None:
        st.vel = Y.Vector3(*[float(a) for a in vel])
    if ang_vel is not None:
        w = np.asarray(ang_vel, float).reshape(3)
        R = _rotation(st.ori)
        L = R @ (_vec(st.inertia) * (R.T @ w))
        st.angVel = Y.Vector3(*w.tolist())
        st.angMom = Y.Vector3(*L.tolist())


def correct_clumps(clump_ids, method=DEFAULT_METHOD):
    """Make existing clumps exact (built by ``clump``, ``appendClumped``, ``replaceByClumps``, ...).

    Idempotent: a clump already corrected gets its correction recomputed for the spheres'
    current positions.  The rigid-body velocity field is kept (members keep their velocities;
    the clump's velocity is re-referred to the new centre of mass).  Returns the correction
    member ids.  Every id is checked before anything is modified.
    """
    Y = _Y.load()
    ids = [clump_ids] if np.ndim(clump_ids) == 0 else list(clump_ids)
    plan = []
    seen = set()
    for cid in ids:
        cb = _body(cid, "clump")
        if not cb.isClump:
            what = f"a member of clump #{cb.clumpId}" if cb.isClumpMember else "standalone"
            raise ClumpAdapterError(f"body #{cb.id} is not a clump ({what})")
        if cb.id in seen:
            continue
        seen.add(cb.id)
        spheres, corr = _split_members(cb)
        rho = _clump_density(f"clump #{cb.id}", spheres)
        plan.append((cb, spheres, corr, rho))
    if not plan:
        return []
    xs, rs, rhos = [], [], []
    for _, spheres, _, rho in plan:
        x, r = _geometry(spheres)
        xs.append(x)
        rs.append(r)
        rhos.append(rho)
    try:
        mass, com, inertia = _batch_properties(xs, rs, rhos, method)
    except ValueError as exc:
        raise ClumpAdapterError(f"clump properties could not be computed: {exc}") from exc
    m_c, off, w_c, V_c = correction_terms(xs, rs, rhos, mass, com, inertia)
    # ---- from here on the scene is modified
    out = []
    for k, (cb, spheres, corr, _) in enumerate(plan):
        c_old, v_old, w_old = _velocity_field(cb)
        o = com[k]
        _place(Y, spheres, xs[k] - o)  # update around the origin, then move back (see _restore)
        new = _make_correction(Y, spheres[0].material, spheres[0].mask, m_c[k], off[k], w_c[k], V_c[k])
        if corr is None:
            (corr_id,) = Y.O.bodies.append([new])
            Y.O.bodies.addToClump([corr_id], cb.id, discretization=0)
        else:
            corr_id = corr.id
            Y.O.bodies.releaseFromClump(corr_id, cb.id, discretization=0)
            st, ns = corr.state, new.state
            st.mass, st.pos, st.inertia, st.ori = ns.mass, ns.pos, ns.inertia, ns.ori
            corr.bounded = False
            Y.O.bodies.addToClump([corr_id], cb.id, discretization=0)
        _restore(Y, cb, spheres, xs[k], Y.O.bodies[corr_id], off[k], o)
        # updateProperties zeroes vel and angVel (not angMom): restore the rigid-body velocity
        # field, with angMom consistent with the new tensor
        c_new = _vec(cb.state.pos)
        set_clump_velocity(cb.id, v_old + np.cross(w_old, c_new - c_old), w_old)
        out.append(corr_id)
    return out


def correct_clump(clump_id, method=DEFAULT_METHOD):
    """Make one existing clump exact; returns the id of its correction member."""
    return correct_clumps([clump_id], method=method)[0]


def correct_all_clumps(method=DEFAULT_METHOD):
    """Correct every clump in the scene (all must be clumps of spheres); returns their ids."""
    Y = _Y.load()
    ids = [b.id for b in Y.O.bodies if b is not None and b.isClump]
    correct_clumps(ids, method=method)
    return ids


def replace_by_clumps(templates, amounts, method=DEFAULT_METHOD):
    """Drop-in for ``O.bodies.replaceByClumps(templates, amounts)``, producing exact clumps.

    YADE places the clumps (same rules, same return value
    ``[(clump_id, [member_ids]), ...]``); each new clump is then corrected.
    """
    Y = _Y.load()
    ret = Y.O.bodies.replaceByClumps(templates, amounts, discretization=0)
    correct_clumps([int(c) for c, _ in ret], method=method)
    return [(int(c), [int(m) for m in mids]) for c, mids in ret]


def text_clumps(fileName, shift=None, orientation=None, scale=1.0, method=DEFAULT_METHOD, **kw):
    """Drop-in for ``ymport.textClumps(fileName, ...)`` (format ``x y z r clumpId``), producing exact clumps.

    Reads the file like YADE does (lines starting with ``#`` skipped, a new clump whenever the
    id column changes), builds the spheres with ``utils.sphere(..., **kw)`` and appends all
    clumps with :func:`append_clumps`.  Returns ``[(clump_id, [member_ids]), ...]``; each
    clump's mask is set to its first member's (as ``textClumps`` does).
    """
    Y = _Y.load()
    from yade import utils

    shift = Y.Vector3(0, 0, 0) if shift is None else Y.Vector3(*[float(a) for a in shift])
    orientation = Y.Quaternion((0, 1, 0), 0.0) if orientation is None else orientation
    groups, cur, last = [], [], None
    with open(fileName) as fh:
        for n, line in enumerate(fh, 1):
            data = line.split()
            if not data or data[0].startswith("#"):
                continue
            if len(data) < 5:
                raise ClumpAdapterError(f"{fileName}:{n}: expected 'x y z r clumpId', got {line.strip()!r}")
            pos = orientation * Y.Vector3(float(data[0]), float(data[1]), float(data[2]))
            key = int(data[4])
            if last is not None and key != last:
                groups.append(cur)
                cur = []
            cur.append(utils.sphere(shift + scale * pos, scale * float(data[3]), **kw))
            last = key
    if cur:
        groups.append(cur)
    ret = append_clumps(groups, method=method)
    for cid, mids in ret:
        Y.O.bodies[cid].mask = Y.O.bodies[mids[0]].mask
    return ret


# --------------------------------------------------------------------------- inspection


def correction_id(clump_id):
    """Id of the clump's correction member, or None if the clump is not corrected."""
    cb = _body(clump_id, "clump")
    if not cb.isClump:
        raise ClumpAdapterError(f"body #{cb.id} is not a clump")
    _, corr = _split_members(cb)
    return None if corr is None else corr.id


def sphere_member_ids(clump_id):
    """Ids of the clump's sphere members (ascending), without the correction member."""
    cb = _body(clump_id, "clump")
    if not cb.isClump:
        raise ClumpAdapterError(f"body #{cb.id} is not a clump")
    spheres, _ = _split_members(cb)
    return [b.id for b in spheres]


def clump_errors(clump_id, method=DEFAULT_METHOD):
    """Relative differences between the clump's YADE state and the library, for checking.

    Returns a dict: ``mass`` |dm|/m; ``center_of_mass`` |dc| / clump radius of gyration;
    ``inertia`` max-abs of (R diag(state.inertia) R^T - I_exact) / max principal moment.
    """
    mp = exact_properties(clump_id, method=method)
    st = _body(clump_id).state
    R = _rotation(st.ori)
    I_y = R @ np.diag(_vec(st.inertia)) @ R.T
    scale = float(np.max(mp.principal_moments))
    gyr = math.sqrt(float(np.trace(mp.inertia)) / (2.0 * mp.mass))
    return {
        "mass": abs(float(st.mass) - mp.mass) / mp.mass,
        "center_of_mass": float(np.linalg.norm(_vec(st.pos) - mp.center_of_mass)) / gyr,
        "inertia": float(np.max(np.abs(I_y - mp.inertia))) / scale,
    }
