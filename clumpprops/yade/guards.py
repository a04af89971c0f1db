"""Guards on ``O.bodies``: YADE's own methods routed through the adapter for corrected clumps.

YADE's ``releaseFromClump``, ``addToClump``, ``erase`` and ``updateClumpProperties`` recompute a
clump with whatever members it then has: on a corrected clump the correction goes stale, or the
summed mass reaches zero and YADE aborts (``Clump.cpp``: ``Assertion 'M > 0' failed``).
:func:`install_guards` replaces these ``O.bodies`` methods (the class ``BodyContainer``, so for the
whole process) by guards: a call touching a corrected clump goes through
:mod:`clumpprops.yade.lifecycle`; ``deleteClumpMember``/``deleteClumpBody`` through
:func:`~clumpprops.yade.lifecycle.erase`; ``clump``/``appendClumped``/``addToClump`` refuse
corrections and corrected clumps they cannot keep exact; ``clear``/``replace`` empty the registry.
Anything else goes straight to YADE.  Nothing is patched until :func:`install_guards` is called;
:func:`unguarded` gives YADE's own methods back inside a block.
"""
from __future__ import annotations

import contextlib

import numpy as np

from . import lifecycle
from ._loader import _RAW, ClumpAdapterError, _Y
from .registry import _forget_registry
from .scene import _body, _has_correction

_GUARDED = ("releaseFromClump", "addToClump", "erase", "updateClumpProperties",
            "clump", "appendClumped", "deleteClumpMember", "deleteClumpBody", "clear", "replace")
_bypass = [0]
_NOTE = "\n\n[clumpprops] routed through clumpprops.yade for corrected clumps (clumpprops.yade.install_guards)."


def install_guards():
    """Route ``O.bodies``' clump methods through the adapter for corrected clumps (idempotent).

    Replaces ``releaseFromClump``, ``addToClump``, ``erase``, ``updateClumpProperties``, ``clump``,
    ``appendClumped``, ``deleteClumpMember``, ``deleteClumpBody``, ``clear`` and ``replace`` of YADE's
    ``BodyContainer`` (every scene of the process) by guards: a call touching a corrected clump is
    routed through :func:`~clumpprops.yade.release`, :func:`~clumpprops.yade.add_to_clump`,
    :func:`~clumpprops.yade.erase` or :func:`~clumpprops.yade.update_clump_properties`, or refused
    with :class:`~clumpprops.yade.ClumpAdapterError` before YADE sees it; ``clear`` and ``replace``
    also empty the registry.  Calls on anything else go to YADE unchanged.  Importing
    ``clumpprops.yade`` or building clumps never installs them; call this once, in a script that
    also uses YADE's own clump methods.  A second call does nothing.

    Returns
    -------
    bool
        True if this call installed the guards, False if they were installed already.
    """
    Y = _Y.load()
    BC = type(Y.O.bodies)
    if _RAW:
        return False
    for name in _GUARDED:
        _RAW[name] = getattr(BC, name)
    for f in (*_lifecycle_guards(Y), *_membership_guards(Y)):
        f.__doc__ = (_RAW[f.__name__].__doc__ or "") + _NOTE
        setattr(BC, f.__name__, f)
    return True


def guards_installed() -> bool:
    """Whether the guards are installed in this process.

    Returns
    -------
    bool
        True once :func:`install_guards` has replaced YADE's ``O.bodies`` methods.
    """
    return bool(_RAW)


@contextlib.contextmanager
def unguarded():
    """Context manager: YADE's own ``O.bodies`` methods inside the block, as if the guards were not installed.

    For tests and debugging.  Blocks nest; the guards are active again when the outermost one
    ends.  Without installed guards it changes nothing.

    Yields
    ------
    None
    """
    _bypass[0] += 1
    try:
        yield
    finally:
        _bypass[0] -= 1



def _corrected_clump_of(Y, bid):
    """The corrected clump that body ``bid`` is (or is a member of), else None."""
    try:
        b = Y.O.bodies[int(bid)]
    except Exception:
        return None
    if b is None:
        return None
    if b.isClumpMember:
        b = Y.O.bodies[b.clumpId]
    return b if (b is not None and b.isClump and _has_correction(Y, b)) else None



def _lifecycle_guards(Y):
    """Guards for ``releaseFromClump``, ``addToClump``, ``erase`` and ``updateClumpProperties`` (same
    names and keywords as YADE's methods)."""

    def releaseFromClump(self, bid, cid, discretization=0):
        if _bypass[0] or _corrected_clump_of(Y, cid) is None:
            return _RAW["releaseFromClump"](self, bid, cid, discretization)
        return lifecycle.release(bid, cid, discretization)

    def addToClump(self, ids, cid, discretization=0):
        lst = [ids] if np.ndim(ids) == 0 else list(ids)
        if not _bypass[0]:
            _refuse_correction_ids(Y, lst, "O.bodies.addToClump")
        if _bypass[0] or all(_corrected_clump_of(Y, i) is None for i in [cid] + lst):
            return _RAW["addToClump"](self, ids, cid, discretization)
        return lifecycle.add_to_clump(lst, cid, discretization)

    def erase(self, bid, eraseClumpMembers=False):
        if _bypass[0] or _corrected_clump_of(Y, bid) is None:
            return _RAW["erase"](self, bid, eraseClumpMembers)
        return lifecycle.erase(bid, eraseClumpMembers)

    def updateClumpProperties(self, excludeList=[], discretization=5):
        if _bypass[0]:
            return _RAW["updateClumpProperties"](self, excludeList, discretization)
        return lifecycle.update_clump_properties(excludeList, discretization)

    return releaseFromClump, addToClump, erase, updateClumpProperties


def _looks_like_correction(Y, b):
    """A body made as a clumpprops correction (bare ``Shape``, unbounded), inside a clump or not."""
    return b is not None and type(b.shape) is Y.Shape and not b.bounded and not b.isClump



def _refuse_clump_ids(Y, ids, call):
    """Raise (nothing changed) if ``O.bodies.clump(ids)`` would touch a corrected clump.

    YADE's ``clump`` takes each body out of its old clump without updating that clump, then sums
    the new one: a correction in the list can make a clump of negative or zero mass (``Clump.cpp``
    ``Assertion 'M > 0' failed``: the process aborts), a sphere of a corrected clump leaves that
    clump with a stale correction, a corrected clump brings its correction into the new one."""
    for i in ids:
        b = _body(i)
        if _looks_like_correction(Y, b):
            where = f" of clump #{b.clumpId}" if b.isClumpMember else ""
            raise ClumpAdapterError(
                f"{call}: body #{b.id} is a clumpprops correction{where} and cannot be clumped "
                "(its mass is negative); clump spheres only, or add them with O.bodies.addToClump"
            )
        cb = _corrected_clump_of(Y, b.id)
        if cb is None:
            continue
        if b.isClump:
            raise ClumpAdapterError(
                f"{call}: body #{b.id} is a corrected clump; join clumps with O.bodies.addToClump([...], {b.id}) "
                "(exact) instead"
            )
        raise ClumpAdapterError(
            f"{call}: body #{b.id} is a sphere of corrected clump #{cb.id}; release it first with "
            f"O.bodies.releaseFromClump({b.id}, {cb.id}) (or cy.release)"
        )



def _refuse_correction_ids(Y, ids, call):
    """Raise if one of ``ids`` is a correction body (in a clump or left over, e.g. by YADE's own erase):
    added to a clump, its negative mass is summed with the clump's (YADE can abort on ``M > 0``)."""
    for i in ids:
        try:
            b = Y.O.bodies[int(i)]
        except Exception:
            continue  # YADE reports a bad id itself
        if _looks_like_correction(Y, b):
            where = f" of clump #{b.clumpId}" if b.isClumpMember else " (outside any clump)"
            raise ClumpAdapterError(f"{call}: body #{b.id} is a clumpprops correction{where}; it cannot join a clump")



def _refuse_corrections(Y, bodies, call):
    """Raise if a body to be appended is a correction body: only the adapter builds those."""
    for j, b in enumerate(bodies):
        if isinstance(b, Y.Body) and _looks_like_correction(Y, b):
            raise ClumpAdapterError(
                f"{call}: item {j} is a clumpprops correction body (bare Shape, bounded=False); "
                "corrections are made by cy.append_clump / cy.correct_clump only"
            )



def _membership_guards(Y):
    """Guards for ``clump``, ``appendClumped``, ``deleteClumpMember``, ``deleteClumpBody``, ``clear`` and
    ``replace`` (same names and keywords as YADE's methods)."""

    def clump(self, ids, discretization=0):
        if not _bypass[0]:
            _refuse_clump_ids(Y, [ids] if np.ndim(ids) == 0 else list(ids), "O.bodies.clump")
        return _RAW["clump"](self, ids, discretization)

    def appendClumped(self, bodies, discretization=0):
        if not _bypass[0]:
            bodies = list(bodies)
            _refuse_corrections(Y, bodies, "O.bodies.appendClumped")
        return _RAW["appendClumped"](self, bodies, discretization)

    def deleteClumpMember(self, clumpBody, memberBody):
        if _bypass[0] or clumpBody is None or _corrected_clump_of(Y, clumpBody.id) is None:
            return _RAW["deleteClumpMember"](self, clumpBody, memberBody)
        if memberBody is None or memberBody.clumpId != clumpBody.id or not memberBody.isClumpMember:
            mid = None if memberBody is None else memberBody.id
            raise ClumpAdapterError(f"O.bodies.deleteClumpMember: body #{mid} is not a member of clump #{clumpBody.id}")
        lifecycle.erase(memberBody.id)  # erasing the correction itself is refused there

    def deleteClumpBody(self, clumpBody):
        if _bypass[0] or clumpBody is None or _corrected_clump_of(Y, clumpBody.id) is None:
            return _RAW["deleteClumpBody"](self, clumpBody)
        lifecycle.erase(clumpBody.id, True)

    def clear(self):
        ret = _RAW["clear"](self)
        if not _bypass[0]:
            _forget_registry(Y)
        return ret

    def replace(self, bodies):
        ret = _RAW["replace"](self, bodies)
        if not _bypass[0]:
            _forget_registry(Y)
        return ret

    return clump, appendClumped, deleteClumpMember, deleteClumpBody, clear, replace

