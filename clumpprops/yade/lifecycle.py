"""The clump's life: release, add, erase and update that keep corrected clumps exact.

YADE's own release, add, erase and update recompute a clump with whatever members it then has, so
the correction would go stale (or the summed mass reach zero and YADE abort).  These functions
neutralise the correction, let YADE do the operation and correct the clump again.  They mirror
``O.bodies`` methods; :func:`erase` and :func:`update_clump_properties` keep YADE's camelCase
keywords (``eraseClumpMembers``, ``excludeList``) so that a call written for YADE works unchanged.
"""
from __future__ import annotations

import numpy as np

from ._loader import ClumpAdapterError, _raw, _vec, _Y
from .build import _apply, _method_of, _plan_entry
from .correction import _neutralize
from .registry import _registry, _save_registry
from .scene import _body, _clump_density, _has_correction, _keep_field, _split_members, _velocity_field, is_correction, sphere_member_ids


def release(body_id, clump_id, discretization=0):
    """``O.bodies.releaseFromClump(body_id, clump_id)`` that keeps the clump exact.

    Parameters
    ----------
    body_id : int
        Id of the sphere member to release.
    clump_id : int
        Id of its clump.
    discretization : int, optional
        Ignored for a corrected clump (its result is exact); passed to YADE for an uncorrected
        one.

    Returns
    -------
    None
        As YADE's ``releaseFromClump``.

    Raises
    ------
    ClumpAdapterError
        Before anything changes, where YADE would refuse (an id is not a body, ``clump_id`` is
        not a clump of spheres, the body is not a member, fewer than two spheres would remain)
        or for the correction member itself.

    Notes
    -----
    The released sphere becomes a free body moving with the clump's rigid-body velocity field;
    the clump is corrected for its remaining spheres with the method it was corrected with.
    """
    Y = _Y.load()
    bid = _body(body_id).id
    cb, spheres, corr = _plan_entry(clump_id)
    cid = cb.id
    if bid not in [b.id for b in spheres]:
        if corr is not None and bid == corr.id:
            raise ClumpAdapterError(f"clump #{cid}: body #{bid} is its correction member and cannot be released")
        raise ClumpAdapterError(f"clump #{cid}: body #{bid} is not a member; nothing released")
    if len(spheres) - 1 < 2:
        raise ClumpAdapterError(
            f"clump #{cid}: releasing body #{bid} would leave {len(spheres) - 1} sphere (YADE keeps at least 2); nothing released"
        )
    if corr is None:
        return _raw(Y, "releaseFromClump", bid, cid, discretization=discretization, what=f"clump #{cid}")
    method = _method_of(cid, None)
    c0, v0, w0 = _velocity_field(cb)
    x = _vec(Y.O.bodies[bid].state.pos)
    _neutralize(Y, corr)
    _raw(Y, "releaseFromClump", bid, cid, discretization=0, what=f"clump #{cid}")
    b = Y.O.bodies[bid]
    b.state.vel = Y.Vector3(*(v0 + np.cross(w0, x - c0)).tolist())
    b.state.angVel = Y.Vector3(*w0.tolist())
    cb.state.vel, cb.state.angVel = Y.Vector3(*v0.tolist()), Y.Vector3(*w0.tolist())
    _keep_field(Y, cb, c0, v0, w0)
    _apply([_plan_entry(cid)], method)



def add_to_clump(body_ids, clump_id, discretization=0, method=None):
    """``O.bodies.addToClump(body_ids, clump_id)`` with an exact result.

    Parameters
    ----------
    body_ids : int or iterable of int
        Standalone spheres and/or clumps of spheres.  A clump's spheres join and its body is
        erased, as YADE does; its correction is dropped.  All spheres must share the clump's
        density.
    clump_id : int
        Id of the clump to add to.
    discretization : int, optional
        Accepted for compatibility with YADE's call and irrelevant: the clump is corrected.
    method : str, optional
        Name of the method of :func:`clumpprops.mass_properties` for the grown clump; None (the
        default) keeps the one the clump was corrected with (``"exact"`` for an uncorrected
        clump).

    Raises
    ------
    ClumpAdapterError
        Before anything changes, if ``body_ids`` is empty, a body does not exist, is already in
        this clump, is a member of another clump, is not a sphere or a clump of spheres, or has
        another density than the clump.

    Notes
    -----
    The clump keeps its rigid-body velocity field (the added bodies adopt it) and is corrected
    for all its spheres.
    """
    Y = _Y.load()
    cb, spheres, corr = _plan_entry(clump_id)
    cid = cb.id
    ids = [body_ids] if np.ndim(body_ids) == 0 else list(body_ids)
    if not ids:
        raise ClumpAdapterError(f"clump #{cid}: no bodies to add")
    added = []
    for i in ids:
        b = _body(i)
        if b.id == cid or b.clumpId == cid:
            raise ClumpAdapterError(f"clump #{cid}: body #{b.id} is already part of it; nothing added")
        if b.isClumpMember:
            raise ClumpAdapterError(f"clump #{cid}: body #{b.id} is a member of clump #{b.clumpId}; add that clump instead")
        if b.isClump:
            sph, c2 = _split_members(b)
        elif isinstance(b.shape, Y.Sphere) and b.material is not None:
            sph = [b]
        else:
            kind = type(b.shape).__name__ if b.shape is not None else "no shape"
            raise ClumpAdapterError(f"clump #{cid}: body #{b.id} is not a sphere or a clump of spheres ({kind})")
        _clump_density(f"clump #{cid} with body #{b.id}", spheres[:1] + sph)
        added.append(b.id)
    method = _method_of(cid, method)
    c0, v0, w0 = _velocity_field(cb)
    _neutralize(Y, corr)
    reg = _registry()
    # clumps to add are dissolved first and their spheres added one by one: YADE's own
    # addToClump(clump) leaves the merged members with clumpId -1 (seen in 2023.02a), after which
    # erasing one of them leaves a dangling entry in the clump's member list
    sphere_ids = []
    for i in added:
        b = Y.O.bodies[i]
        if b.isClump:
            sph, c2 = _split_members(b)
            _neutralize(Y, c2)
            _raw(Y, "erase", i, False, what=f"clump #{i}")
            if c2 is not None and Y.O.bodies[c2.id] is not None:
                _raw(Y, "erase", c2.id, False, what=f"clump #{i}")
            reg.pop(i, None)
            sphere_ids += [s.id for s in sph]
        else:
            sphere_ids.append(i)
    _save_registry(reg)
    _raw(Y, "addToClump", sphere_ids, cid, discretization=0, what=f"clump #{cid}")
    _keep_field(Y, cb, c0, v0, w0)
    _apply([_plan_entry(cid)], method)
    for b in sphere_member_ids(cid):  # the members adopt the clump's field (YADE leaves them as they were)
        st = Y.O.bodies[b].state
        st.vel = Y.Vector3(*(v0 + np.cross(w0, _vec(st.pos) - c0)).tolist())
        st.angVel = Y.Vector3(*w0.tolist())



def erase(body_id, eraseClumpMembers=False):
    """``O.bodies.erase(body_id, eraseClumpMembers)`` that never leaves a correction behind.

    Mirrors ``O.bodies.erase(id, eraseClumpMembers)``: the keyword keeps YADE's camelCase name.

    Parameters
    ----------
    body_id : int
        Id of the body to erase: a clump, a clump member or any other body.
    eraseClumpMembers : bool, optional
        For a clump: erase its spheres too (else they become free bodies), as in YADE.

    Returns
    -------
    bool
        YADE's return value (True).

    Raises
    ------
    ClumpAdapterError
        Before anything changes, if ``body_id`` is not an integer or not a body, or is a
        correction member (erase its clump or its spheres instead).

    Notes
    -----
    * a corrected clump: its correction is erased with it; its spheres become free bodies (or
      are erased too with ``eraseClumpMembers=True``), as in YADE;
    * a sphere of a corrected clump: erased, and the clump is corrected for the spheres left
      (the clump goes when its last sphere goes);
    * the correction member itself: refused (erase the clump, or release spheres instead);
    * anything else: YADE's erase.
    """
    Y = _Y.load()
    b = _body(body_id)
    bid = b.id
    if is_correction(b) or (type(b.shape) is Y.Shape and not b.bounded and not b.isClump):
        raise ClumpAdapterError(
            f"body #{bid} is a clumpprops correction{f' of clump #{b.clumpId}' if b.isClumpMember else ''}: "
            "erase its clump or its spheres instead"
        )
    reg = _registry()
    if b.isClump:
        spheres, corr = _split_members(b)
        if corr is None:
            return _raw(Y, "erase", bid, eraseClumpMembers, what=f"clump #{bid}")
        _neutralize(Y, corr)
        ret = _erase_clump(Y, bid, [s.id for s in spheres] if eraseClumpMembers else [], corr.id)
        reg.pop(bid, None)
        _save_registry(reg)
        return ret
    if b.isClumpMember:
        cb = Y.O.bodies[b.clumpId]
        spheres, corr = _split_members(cb)
        if corr is None:
            return _raw(Y, "erase", bid, eraseClumpMembers, what=f"clump #{cb.id}")
        cid = cb.id
        method = _method_of(cid, None)
        c0, v0, w0 = _velocity_field(cb)
        if len(spheres) == 1:  # the last sphere: the clump and its correction go too
            _neutralize(Y, corr)
            ret = _erase_clump(Y, cid, [s.id for s in spheres], corr.id)
            reg.pop(cid, None)
            _save_registry(reg)
            return ret
        _neutralize(Y, corr)
        ret = _raw(Y, "erase", bid, eraseClumpMembers, what=f"clump #{cid}")
        _keep_field(Y, cb, c0, v0, w0)
        _apply([_plan_entry(cid)], method)
        return ret
    return _raw(Y, "erase", bid, eraseClumpMembers, what=f"body #{bid}")



def _erase_clump(Y, cid, sphere_ids, corr_id):
    """Erase a corrected clump, its correction and the spheres ``sphere_ids`` (the other members become
    free).  YADE's own ``erase(clump, eraseClumpMembers=True)`` erases the clump body a second time from
    inside its loop over the members (when the last member goes) and crashed a test process with a
    segmentation fault (2023.02a; only after some other tests had run).  So the clump is erased alone
    (its members become standalone) and then each body by itself."""
    ret = _raw(Y, "erase", cid, False, what=f"clump #{cid}")
    for i in [*sphere_ids, corr_id]:
        if Y.O.bodies[i] is not None:
            _raw(Y, "erase", i, False, what=f"clump #{cid}")
    return ret



def update_clump_properties(excludeList=(), discretization=5):
    """``O.bodies.updateClumpProperties(excludeList, discretization)`` that keeps corrected clumps exact.

    Mirrors ``O.bodies.updateClumpProperties(excludeList, discretization)``: the keyword keeps
    YADE's camelCase name.

    Parameters
    ----------
    excludeList : iterable of int, optional
        Ids of clumps left as they are.
    discretization : int, optional
        YADE's discretization for the clumps that are not corrected (0 sums the spheres); YADE's
        default, 5.

    Raises
    ------
    ClumpAdapterError
        If a corrected clump is no longer a clump of spheres of one density, or YADE's state
        after the update differs from the target.

    Notes
    -----
    Corrected clumps not in ``excludeList`` are recomputed exactly for where their spheres are,
    each with the method it was corrected with; every other clump gets YADE's own update.
    """
    Y = _Y.load()
    excl = {int(i) for i in excludeList}
    corrected, plain_excl = [], set(excl)
    for b in Y.O.bodies:
        if b is None or not b.isClump or b.id in excl:
            continue
        entry = _plan_entry(b.id) if _has_correction(Y, b) else None
        if entry is not None:
            corrected.append(entry)
            plain_excl.add(b.id)
    _raw(Y, "updateClumpProperties", excludeList=sorted(plain_excl), discretization=discretization,
         what="updateClumpProperties")
    by_method = {}
    for e in corrected:
        by_method.setdefault(_method_of(e[0].id, None), []).append(e)
    for m, plan in by_method.items():
        _apply(plan, m)

