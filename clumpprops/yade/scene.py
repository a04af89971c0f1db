"""Reading the scene: bodies by id, a clump's members, its YADE state against a target, velocities."""
from __future__ import annotations

import math

import numpy as np

from ..api import DEFAULT_METHOD, mass_properties
from ..core import _core
from ._loader import ClumpAdapterError, _rotation, _vec, _Y


def is_correction(body) -> bool:
    """Whether a body is a correction member made by this package.

    Parameters
    ----------
    body : yade.Body or None
        Any body of the scene (None, an erased slot, gives False).

    Returns
    -------
    bool
        True for a correction member.

    Notes
    -----
    A correction is a clump member whose shape is exactly the base class ``Shape``
    (no YADE body has that for any other purpose: it has no bound, collision or
    rendering functor) and which is not bounded.
    """
    Y = _Y.load()
    return body is not None and type(body.shape) is Y.Shape and not body.bounded and body.isClumpMember


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


def _has_correction(Y, cb):
    for mid in cb.shape.members.keys():
        mb = Y.O.bodies[int(mid)]
        if mb is not None and type(mb.shape) is Y.Shape and not mb.bounded:
            return True
    return False


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


def _clump_body(clump_id):
    cb = _body(clump_id, "clump")
    if not cb.isClump:
        raise ClumpAdapterError(f"body #{cb.id} is not a clump")
    return cb


def exact_properties(clump_id, method=DEFAULT_METHOD):
    """The library's mass properties of a clump's member spheres, where they are now.

    Parameters
    ----------
    clump_id : int
        Id of a clump in ``O.bodies``.
    method : str, optional
        Name of the method of :func:`clumpprops.mass_properties` (``"exact"``, the default,
        ``"pairwise"``, ``"sum"``, ``"montecarlo"`` or ``"voxel"``).

    Returns
    -------
    MassProperties
        The properties of the union of the sphere members (the correction member left out),
        with their material's density.

    Raises
    ------
    ClumpAdapterError
        If ``clump_id`` is not an integer, not a body or not a clump, or the clump has a member
        that is neither a sphere with a material nor a correction, no sphere member, or more
        than one correction.
        Also if the spheres' densities differ or are not positive.
    ValueError
        If the method cannot compute the clump (e.g. :class:`~clumpprops.ClumpGeometryError`
        for ``"pairwise"`` with a triple overlap).
    """
    cb = _clump_body(clump_id)
    spheres, _ = _split_members(cb)
    rho = _clump_density(f"clump #{cb.id}", spheres)
    x, r = _geometry(spheres)
    return mass_properties(x, r, density=rho[0], method=method)


def correction_id(clump_id):
    """Id of a clump's correction member.

    Parameters
    ----------
    clump_id : int
        Id of a clump in ``O.bodies``.

    Returns
    -------
    int or None
        The id, or None if the clump is not corrected.

    Raises
    ------
    ClumpAdapterError
        If ``clump_id`` is not an integer, not a body or not a clump, or the clump has a member
        that is neither a sphere with a material nor a correction, no sphere member, or more
        than one correction.
    """
    _, corr = _split_members(_clump_body(clump_id))
    return None if corr is None else corr.id


def sphere_member_ids(clump_id):
    """Ids of a clump's sphere members, without the correction member.

    Parameters
    ----------
    clump_id : int
        Id of a clump in ``O.bodies``.

    Returns
    -------
    list of int
        The ids, ascending.

    Raises
    ------
    ClumpAdapterError
        As :func:`correction_id`.
    """
    spheres, _ = _split_members(_clump_body(clump_id))
    return [b.id for b in spheres]


# --------------------------------------------------------------------------- YADE's state against a target


def _state_row(st):
    """(mass, pos, inertia, ori as x, y, z, w) of a YADE state, as floats (indexing, not iteration:
    iterating minieigen objects goes through IndexError, which is slow)."""
    p, w, q = st.pos, st.inertia, st.ori
    return (st.mass, p[0], p[1], p[2], w[0], w[1], w[2], q[0], q[1], q[2], q[3])


def _state_errors(rows, targets):
    """Relative errors (mass, centre of mass / radius of gyration, inertia / largest |moment|) of
    clump states ``rows`` (from :func:`_state_row`) against ``targets`` (per clump: mass, com (3),
    inertia (9, row-major), scale = largest |principal moment|, ...): three arrays of shape (M,).
    Computed by ``_core.state_errors``; a NaN anywhere gives a NaN error (never a pass)."""
    errs = [_core.state_errors(row, t) for row, t in zip(rows, targets)]
    if not errs:
        return np.empty(0), np.empty(0), np.empty(0)
    e = np.array(errs, dtype=float)
    return e[:, 0], e[:, 1], e[:, 2]


_VERIFY_RTOL = 1e-10  # YADE's state after a build against the target (relative; round-off is ~1e-15)


def _verify(cids, rows, targets, rtol=_VERIFY_RTOL):
    """YADE's state of each clump (``rows``) equals its target (mass, COM, inertia tensor), else raise."""
    for cid, e_m, e_c, e_i in zip(cids, *_state_errors(rows, targets)):
        if not (e_m <= rtol and e_c <= rtol and e_i <= rtol):  # NaN fails too
            raise _mismatch(cid, e_m, e_c, e_i, rtol)


def _mismatch(cid, e_m, e_c, e_i, rtol):
    return ClumpAdapterError(
        f"clump #{cid}: YADE's state after the build differs from the target (relative errors: mass "
        f"{e_m:.2g}, centre of mass {e_c:.2g}, inertia {e_i:.2g}; tolerance {rtol:g})"
    )


def clump_errors(clump_id, method=DEFAULT_METHOD):
    """Relative differences between a clump's YADE state and the library's values, for checking.

    Parameters
    ----------
    clump_id : int
        Id of a clump in ``O.bodies``.
    method : str, optional
        The method of the library's values, as for :func:`exact_properties`.

    Returns
    -------
    dict
        ``"mass"``: ``|dm| / m``; ``"center_of_mass"``: ``|dc|`` divided by the clump's radius
        of gyration; ``"inertia"``: the largest absolute element of
        ``R diag(state.inertia) R^T - I_exact`` divided by the largest principal moment.  All
        are floats.

    Raises
    ------
    ClumpAdapterError, ValueError
        As :func:`exact_properties`.
    """
    mp = exact_properties(clump_id, method=method)
    target = [float(mp.mass), *mp.center_of_mass.tolist(), *mp.inertia.ravel().tolist(),
              float(np.max(np.abs(mp.principal_moments)))]
    e_m, e_c, e_i = _core.state_errors(_state_row(_body(clump_id).state), target)
    return {"mass": e_m, "center_of_mass": e_c, "inertia": e_i}


# --------------------------------------------------------------------------- velocities


def _velocity_field(cb):
    st = cb.state
    return _vec(st.pos), _vec(st.vel), _vec(st.angVel)


def set_clump_velocity(clump_id, vel=None, ang_vel=None):
    """Set a clump's linear and angular velocity (world frame), consistently for YADE 2023 and 2025.

    Sets ``state.vel``, ``state.angVel`` and ``state.angMom = R diag(I) R^T angVel`` (YADE 2023
    integrates ``angMom`` for aspherical bodies, YADE 2025 integrates ``angVel``).

    Parameters
    ----------
    clump_id : int
        Id of the body (a clump, or any body).
    vel : array_like, shape (3,), optional
        Linear velocity of the centre of mass, in m/s; None leaves it as it is.
    ang_vel : array_like, shape (3,), optional
        Angular velocity, in rad/s; None leaves it (and ``angMom``) as it is.

    Raises
    ------
    ClumpAdapterError
        If ``clump_id`` is not an integer or not a body.
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


def _keep_field(Y, cb, c0, v0, w0):
    """Set a clump's velocity to the rigid field (c0, v0, w0) re-referred to its current centre."""
    c = _vec(cb.state.pos)
    cb.state.vel = Y.Vector3(*(v0 + np.cross(w0, c - c0)).tolist())
    cb.state.angVel = Y.Vector3(*w0.tolist())
