"""Building exact clumps: new ones from sphere bodies, and corrections of clumps already in the scene.

Every build computes all targets and corrections first (bad input raises before the scene changes),
builds each clump around the origin and moves it back (:func:`_restore`), records the corrections in
the registry and compares YADE's resulting state with the target.
"""
from __future__ import annotations

import contextlib
import gc
import math
import re

import numpy as np

from ..api import DEFAULT_METHOD
from ._loader import ClumpAdapterError, _raw, _vec, _yade_method, _Y
from .correction import _corrections, _new_correction, _correction_mask, _set_correction_state
from .registry import _fingerprint, _fp, _fps, _registry, _save_registry
from .scene import (_body, _clump_density, _geometry, _split_members, _state_row, _velocity_field, _verify,
                    set_clump_velocity)

_SMALL = 2  # batches up to this many clumps leave the garbage collector alone and fingerprint one by one


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



def _batch_index(message):
    """(k, the rest of the message) of an error naming "clump k of the batch: ...", else (None, message)."""
    m = re.match(r"clump (\d+) of the batch: ", message)
    return (int(m.group(1)), message[m.end():]) if m else (None, message)


def _checked_corrections(pts, radii, rhos, method, label):
    """:func:`~clumpprops.yade.correction._corrections` with its errors worded for the caller: a
    refused clump ``k`` is named ``label(k)``."""
    try:
        return _corrections(pts, radii, rhos, method)
    except ClumpAdapterError as exc:
        k, what = _batch_index(str(exc))
        raise ClumpAdapterError(f"{label(k)}: {what}" if k is not None else what) from exc
    except ValueError as exc:
        raise ClumpAdapterError(f"clump properties could not be computed: {exc}") from exc


def _recorrect(Y, cb, spheres, corr, x, row):
    """Give the clump ``cb`` (spheres at ``x``) the correction of ``row`` (from ``_corrections``): a new
    correction member, or ``corr`` updated.  Keeps the rigid-body velocity field.  Returns the
    correction's id."""
    cid = cb.id
    c_old, v_old, w_old = _velocity_field(cb)
    o = np.array(row[1:4], dtype=float)
    m_c, off, w_c, q = row[14], row[15:18], row[18:21], row[30:34]
    _place(Y, spheres, x - o)  # update around the origin, then move back (see _restore)
    if corr is None:
        corr = _new_correction(Y, spheres)
        _set_correction_state(Y, corr.state, m_c, off, w_c, q)
        (corr_id,) = Y.O.bodies.append([corr])
        corr = Y.O.bodies[corr_id]
        _raw(Y, "addToClump", [corr_id], cid, discretization=0, what=f"clump #{cid}")
    else:
        corr.bounded = False
        corr.mask = _correction_mask(spheres)
        _set_correction_state(Y, corr.state, m_c, off, w_c, q)
        if len(spheres) >= 2:  # release and re-add: YADE updates this clump only
            _raw(Y, "releaseFromClump", corr.id, cid, discretization=0, what=f"clump #{cid}")
            _set_correction_state(Y, corr.state, m_c, off, w_c, q)
            _raw(Y, "addToClump", [corr.id], cid, discretization=0, what=f"clump #{cid}")
        else:  # YADE refuses to release from a clump of < 2 members: update this clump alone
            others = [b.id for b in Y.O.bodies if b is not None and b.isClump and b.id != cid]
            _raw(Y, "updateClumpProperties", excludeList=others, discretization=0, what=f"clump #{cid}")
    _restore(Y, cb, spheres, x, corr, np.array(off, dtype=float), o)
    # updateProperties zeroes vel and angVel (not angMom): restore the rigid-body velocity
    # field, with angMom consistent with the new tensor
    c_new = _vec(cb.state.pos)
    set_clump_velocity(cid, v_old + np.cross(w_old, c_new - c_old), w_old)
    return corr.id


def _apply(plan, method):
    """Make the clumps of ``plan`` [(clump body, sphere bodies, correction body or None), ...] exact.

    Computes every target first (raises before any change), then per clump: builds around the
    origin, updates YADE's clump with the correction in place, moves it back, restores the
    rigid-body velocity field, and finally records the corrections in the registry and compares
    YADE's state with the target.  Returns the correction ids.
    """
    Y = _Y.load()
    if not plan:
        return []
    xs, rhos = [], []
    for cb, spheres, _ in plan:
        xs.append(_geometry(spheres))
        rhos.append(_clump_density(f"clump #{cb.id}", spheres))
    rows = _checked_corrections([x.tolist() for x, _ in xs], [r.tolist() for _, r in xs], rhos, method,
                                lambda k: f"clump #{plan[k][0].id}")
    # ---- from here on the scene is modified
    reg = _registry()
    out = []
    for (cb, spheres, corr), (x, _), row in zip(plan, xs, rows):
        out.append(_recorrect(Y, cb, spheres, corr, x, row))
        reg[cb.id] = (out[-1], _fingerprint(spheres), method)
    _save_registry(reg)
    cids = [cb.id for cb, _, _ in plan]
    _verify(cids, [_state_row(Y.O.bodies[cid].state) for cid in cids], rows)
    return out


def _check_new_spheres(Y, k, spheres, seen):
    """Validate one input clump; returns (bodies, positions [(x, y, z)], radii, densities, material of
    the first sphere, union of the masks, the bodies' states).  ``seen``: ids of the Body objects of
    the clumps checked before (a Body given twice is refused)."""
    try:
        spheres = list(spheres)
    except TypeError:
        raise ClumpAdapterError(f"clump {k} of the input is not a list of bodies") from None
    if not spheres:
        raise ClumpAdapterError(f"clump {k} of the input is empty")
    Body, Sphere = Y.Body, Y.Sphere
    xs, rs, rho, states = [], [], [], []
    mask = 0
    mat0 = None
    inf = math.inf
    for j, b in enumerate(spheres):
        if not isinstance(b, Body):
            raise ClumpAdapterError(f"clump {k} of the input, item {j}: not a yade Body ({type(b).__name__})")
        if b.id >= 0:
            raise ClumpAdapterError(f"clump {k} of the input, item {j}: body #{b.id} is already in a scene")
        shape = b.shape
        if not isinstance(shape, Sphere):
            kind = type(shape).__name__ if shape is not None else "no shape"
            raise ClumpAdapterError(f"clump {k} of the input, item {j}: not a sphere ({kind})")
        mat = b.material
        if mat is None:
            raise ClumpAdapterError(f"clump {k} of the input, item {j}: sphere has no material (density unknown)")
        r = shape.radius
        if not 0.0 < r < inf:  # NaN fails too
            raise ClumpAdapterError(f"clump {k} of the input, item {j}: radius {r} is not positive")
        n_seen = len(seen)
        seen.add(id(b))
        if len(seen) == n_seen:
            raise ClumpAdapterError(f"clump {k} of the input, item {j}: the same Body object is given twice")
        st = b.state
        states.append(st)
        p = st.pos
        xs.append((p[0], p[1], p[2]))
        rs.append(r)
        rho.append(mat.density)
        mask |= b.mask
        if mat0 is None:
            mat0 = mat
    r0 = rho[0]
    if not 0.0 < r0 < inf or rho.count(r0) != len(rho):
        _clump_density(f"clump {k} of the input", spheres)  # raises with the details (or accepts a 1e-12 spread)
    return spheres, xs, rs, rho, mat0, mask, states



@contextlib.contextmanager
def _no_gc(n):
    """Python's cyclic garbage collector paused while a batch of ``n`` > _SMALL clumps is built: the
    build allocates only acyclic objects (lists, tuples, floats, YADE wrappers), so collections
    during it find nothing to free, yet each full collection walks every object of the process
    (the user's sphere lists included: about 25 % of a 10^4-dimer build).  Reference counting
    still frees everything as usual; the collector's state is restored afterwards."""
    if n <= _SMALL or not gc.isenabled():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.enable()



def append_clumps(clumps, method=DEFAULT_METHOD):
    """Append many exact clumps at once (one library call for the whole batch).

    Parameters
    ----------
    clumps : iterable of lists of yade.Body
        One list of sphere bodies per clump, as made by ``utils.sphere`` and not yet in a
        scene; the spheres of a clump share one density (their material's, in kg/m^3).
    method : str, optional
        Name of the method of :func:`clumpprops.mass_properties` that gives the clump's
        properties (``"exact"``, the default, ``"pairwise"``, ``"sum"``, ``"montecarlo"`` or
        ``"voxel"``, with their default options); recorded with the correction.

    Returns
    -------
    list of (int, list of int)
        ``(clump_id, member_ids)`` per clump, in input order.  ``member_ids`` are the sphere
        members only; the correction member of each clump is ``correction_id(clump_id)``.

    Raises
    ------
    ClumpAdapterError
        Before anything in the scene changes, if a clump is not a list of bodies or is empty,
        an item is not a yade Body, is already in a scene, is given twice, is not a sphere, has
        no material or a radius that is not positive, the densities of a clump differ or are
        not positive, or the method cannot compute a clump.  The message names the clump
        (``clump k of the input``) and the item.  Also if YADE's state after the build differs
        from the target (relative 1e-10).

    See Also
    --------
    append_clump : The same for one clump.
    """
    clumps = list(clumps)
    with _no_gc(len(clumps)):
        return _append_clumps(clumps, method)



def _build_one(Y, checked, row):
    """Append one clump and its correction member (the scene changes here).  ``checked``: the tuple
    of :func:`_check_new_spheres`; ``row``: its target and correction from ``_corrections``.
    The clump is built around the origin and moved back (see :func:`_restore`).  Returns (clump id,
    sphere member ids, correction id, YADE's resulting state as read by :func:`_state_row`)."""
    spheres, pos, _, _, mat, mask, states = checked
    ox, oy, oz = row[1:4]
    m_c, (dx, dy, dz), w, q = row[14], row[15:18], row[18:21], row[30:34]
    for sb, (x, y, z) in zip(states, pos):  # build near the origin
        sb.pos = (x - ox, y - oy, z - oz)
    corr = _new_correction(Y, spheres, mat, mask)
    st = corr.state
    st.mass = m_c
    st.pos = (dx, dy, dz)
    st.inertia = (w[0], w[1], w[2])
    st.ori = Y.Quaternion(q[0], q[1], q[2], q[3])
    cid, mids = _yade_method(Y, "appendClumped")(Y.O.bodies, spheres + [corr], 0)
    c = Y.O.bodies[cid].state
    p = c.pos
    cx, cy, cz = ox + p[0], oy + p[1], oz + p[2]
    c.pos = (cx, cy, cz)
    for sb, xyz in zip(states, pos):  # the spheres' own coordinates, bit for bit
        sb.pos = xyz
    st.pos = (ox + dx, oy + dy, oz + dz)
    w, q = c.inertia, c.ori  # YADE's result (and the position just set), verified by the caller
    return cid, mids[: len(spheres)], corr.id, (c.mass, cx, cy, cz, w[0], w[1], w[2], q[0], q[1], q[2], q[3])


def _input_label(k):
    return f"clump {k} of the input"


def _append_clumps(clumps, method):
    Y = _Y.load()
    seen = set()
    checked = [_check_new_spheres(Y, k, s, seen) for k, s in enumerate(clumps)]
    if not checked:
        return []
    rows = _checked_corrections([c[1] for c in checked], [c[2] for c in checked], [c[3] for c in checked], method,
                                _input_label)
    # ---- from here on the scene is modified; python floats and YADE objects only
    out, states, corr_ids = [], [], []
    for c, row in zip(checked, rows):
        cid, mids, corr_id, state = _build_one(Y, c, row)
        states.append(state)
        corr_ids.append(corr_id)
        out.append((cid, mids))
    if len(checked) <= _SMALL:
        fps = [_fp(mids, c[2], c[3]) for (_, mids), c in zip(out, checked)]
    else:
        fps = _fps([i for _, mids in out for i in mids], [r for c in checked for r in c[2]],
                   [p for c in checked for p in c[3]], [len(c[2]) for c in checked])
    reg = _registry()
    reg.set_many([cid for cid, _ in out], corr_ids, fps, method)
    _save_registry(reg)
    _verify([cid for cid, _ in out], states, rows)
    return out


def append_clump(spheres, method=DEFAULT_METHOD):
    """Drop-in for ``O.bodies.appendClumped(spheres)`` that builds an exact clump.

    The clump's ``state.mass``, ``state.pos`` and inertia (``state.inertia``, ``state.ori``)
    are the library's values for the union of the spheres.

    Parameters
    ----------
    spheres : list of yade.Body
        Sphere bodies not yet in a scene (as made by ``utils.sphere``), of one density.
    method : str, optional
        The method, as for :func:`append_clumps` (default ``"exact"``).

    Returns
    -------
    clump_id : int
        Id of the new clump body.
    member_ids : list of int
        Ids of the sphere members.  The clump also holds one collision-free correction member
        (see the package docstring), not listed here.

    Raises
    ------
    ClumpAdapterError
        Before anything in the scene changes, for the bad input :func:`append_clumps` refuses;
        also if YADE's state after the build differs from the target (relative 1e-10).

    Notes
    -----
    The steps of :func:`append_clumps` for one clump, without the bookkeeping of a batch (this
    is the call a script makes once per clump).
    """
    Y = _Y.load()
    checked = _check_new_spheres(Y, 0, spheres, set())
    (row,) = _checked_corrections([checked[1]], [checked[2]], [checked[3]], method, _input_label)
    cid, mids, corr_id, state = _build_one(Y, checked, row)
    reg = _registry()
    reg[cid] = (corr_id, _fp(mids, checked[2], checked[3]), method)
    _save_registry(reg)
    _verify((cid,), (state,), (row,))
    return cid, mids


def _plan_entry(cid, what="clump"):
    """(clump body, sphere members, correction or None) of an existing clump; raises on bad input."""
    cb = _body(cid, what)
    if not cb.isClump:
        kind = f"a member of clump #{cb.clumpId}" if cb.isClumpMember else "standalone"
        raise ClumpAdapterError(f"body #{cb.id} is not a clump ({kind})")
    spheres, corr = _split_members(cb)
    _clump_density(f"clump #{cb.id}", spheres)
    return cb, spheres, corr



def _method_of(cid, method):
    """The method a clump was corrected with (registry), unless one is given."""
    if method is not None:
        return method
    rec = _registry().get(int(cid))
    return rec[2] if rec is not None else DEFAULT_METHOD



def correct_clumps(clump_ids, method=DEFAULT_METHOD):
    """Make existing clumps exact (built by ``clump``, ``appendClumped``, ``replaceByClumps``, ...).

    Parameters
    ----------
    clump_ids : int or iterable of int
        Ids of clumps of spheres in ``O.bodies`` (an id given twice is corrected once).
    method : str, optional
        The method, as for :func:`append_clumps` (default ``"exact"``).

    Returns
    -------
    list of int
        Ids of the correction members, one per distinct clump, in input order.

    Raises
    ------
    ClumpAdapterError
        Before anything in the scene changes, if an id is not an integer or not a body, the body
        is not a clump, a member is neither a sphere with a material nor a correction, the
        spheres' densities differ or are not positive, or the method cannot compute a clump
        (e.g. ``"pairwise"`` with a triple overlap).  Also if YADE's state after the update
        differs from the target (relative 1e-10).

    Notes
    -----
    Idempotent: a clump already corrected gets its correction recomputed for the spheres'
    current positions.  The rigid-body velocity field is kept (members keep their velocities;
    the clump's velocity is re-referred to the new centre of mass).  Every id is checked
    before anything is modified.
    """
    ids = [clump_ids] if np.ndim(clump_ids) == 0 else list(clump_ids)
    plan, seen = [], set()
    for cid in ids:
        entry = _plan_entry(cid)
        if entry[0].id not in seen:
            seen.add(entry[0].id)
            plan.append(entry)
    return _apply(plan, method)



def correct_clump(clump_id, method=DEFAULT_METHOD):
    """Make one existing clump exact.

    Parameters
    ----------
    clump_id : int
        Id of a clump of spheres in ``O.bodies``.
    method : str, optional
        The method, as for :func:`append_clumps` (default ``"exact"``).

    Returns
    -------
    int
        Id of the clump's correction member.

    Raises
    ------
    ClumpAdapterError
        For the bad input :func:`correct_clumps` refuses, before anything changes.
    """
    return correct_clumps([clump_id], method=method)[0]



def correct_all_clumps(method=DEFAULT_METHOD):
    """Make every clump in the scene exact.

    Parameters
    ----------
    method : str, optional
        The method, as for :func:`append_clumps` (default ``"exact"``).

    Returns
    -------
    list of int
        Ids of the clumps (not of their corrections), in ``O.bodies`` order.

    Raises
    ------
    ClumpAdapterError
        Before anything changes, if some clump is not a clump of spheres of one density (see
        :func:`correct_clumps`).
    """
    Y = _Y.load()
    ids = [b.id for b in Y.O.bodies if b is not None and b.isClump]
    correct_clumps(ids, method=method)
    return ids



def replace_by_clumps(templates, amounts, discretization=0, method=DEFAULT_METHOD):
    """Drop-in for ``O.bodies.replaceByClumps(templates, amounts, discretization)`` that makes exact clumps.

    Parameters
    ----------
    templates : list of yade clump templates
        As for YADE (``clumpTemplate`` objects).
    amounts : list of float
        Fraction of the spheres replaced by each template, as for YADE.
    discretization : int, optional
        Accepted for compatibility and irrelevant: the new clumps get the library's values.
    method : str, optional
        The method, as for :func:`append_clumps` (default ``"exact"``).

    Returns
    -------
    list of (int, list of int)
        YADE's return value: ``(clump_id, member_ids)`` per new clump.

    Raises
    ------
    ClumpAdapterError
        If YADE refuses the replacement (its warning becomes the message), or a new clump
        cannot be corrected (see :func:`correct_clumps`).

    Notes
    -----
    YADE places the clumps (same rules); each new clump is then corrected.  Clumps already in
    the scene are not touched.
    """
    Y = _Y.load()
    before = {b.id for b in Y.O.bodies if b is not None and b.isClump}
    ret = _raw(Y, "replaceByClumps", templates, amounts, discretization=0, what="replaceByClumps")
    new = [int(c) for c, _ in ret if int(c) not in before]
    correct_clumps(new, method=method)
    return [(int(c), [int(m) for m in mids]) for c, mids in ret]

