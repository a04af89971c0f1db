"""Checking the scene: every clump against its exact properties, stale and orphaned corrections."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ._loader import ClumpAdapterError, _Y
from .correction import _correction_mask, _target_rows
from .registry import _fingerprint_matches, _registry
from .scene import _clump_density, _geometry, _has_correction, _split_members, _state_errors, _state_row


@dataclass
class CheckReport:
    """Result of :func:`check`: the scene's clumps sorted by what the check found.

    Every parameter is an attribute of the same name; ``str(report)`` is a readable summary.

    Parameters
    ----------
    exact : list of int, optional
        Ids of the corrected clumps whose YADE state equals the library's (within ``rtol``).
    uncorrected : list of int, optional
        Ids of the clumps without a correction and without a registry entry (YADE's own, not an
        error).
    stale : list of (int, str), optional
        ``(clump id, reason)`` of corrected clumps that no longer match (state off, sphere set
        changed since the correction, correction lost).
    orphaned : list of (int, str), optional
        ``(body id, reason)`` of corrections without their clump (a free correction body, a
        registry entry for a missing clump).
    invalid : list of (int, str), optional
        ``(body id, reason)`` of dynamic bodies that are not clump members with a mass or a
        principal moment that is not positive (YADE divides by them; a correction left free by
        YADE's own erase is one).
    masks : list of (int, str), optional
        ``(clump id, reason)`` of corrections whose mask is not the union of their spheres'
        masks (a mask changed after the build: :func:`correct_clump` sets it again).
    max_error : float, optional
        The largest relative error found over the exact and stale clumps (dimensionless).
    """

    exact: list = field(default_factory=list)
    uncorrected: list = field(default_factory=list)
    stale: list = field(default_factory=list)
    orphaned: list = field(default_factory=list)
    invalid: list = field(default_factory=list)
    masks: list = field(default_factory=list)
    max_error: float = 0.0

    @property
    def ok(self) -> bool:
        """True if nothing is stale, orphaned, invalid or masked wrongly (uncorrected clumps are fine)."""
        return not (self.stale or self.orphaned or self.invalid or self.masks)

    def __str__(self):
        lines = [f"clumpprops check: {len(self.exact)} exact, {len(self.uncorrected)} uncorrected, "
                 f"{len(self.stale)} stale, {len(self.orphaned)} orphaned, {len(self.invalid)} invalid, "
                 f"{len(self.masks)} mask mismatches (max relative error {self.max_error:.2g})"]
        lines += [f"  stale clump #{c}: {why}" for c, why in self.stale]
        lines += [f"  orphaned #{c}: {why}" for c, why in self.orphaned]
        lines += [f"  invalid body #{c}: {why}" for c, why in self.invalid]
        lines += [f"  mask of clump #{c}: {why}" for c, why in self.masks]
        return "\n".join(lines)



def check(rtol=1e-9, raise_on_error=False):
    """Verify every clump of the scene against its exact properties; report stale or orphaned corrections.

    Parameters
    ----------
    rtol : float, optional
        Relative tolerance of mass, centre of mass and inertia tensor (see
        :func:`clump_errors` for the scales).
    raise_on_error : bool, optional
        Raise instead of returning a report that is not ``ok``.

    Returns
    -------
    CheckReport
        The clumps and bodies sorted by what was found.

    Raises
    ------
    ClumpAdapterError
        With ``raise_on_error=True``, if the report is not ``ok``; the message lists the
        problems.

    Notes
    -----
    For each corrected clump: the correction is the one recorded in the registry
    (``O.tags["clumpprops.corrections*"]``, saved with the scene), the sphere set has the recorded
    fingerprint (ids, radii, densities), and YADE's mass, centre of mass and inertia tensor equal
    the library's for the spheres where they are now (relative ``rtol``; clumps corrected with
    ``montecarlo`` are checked for their fingerprint only).  Also reports correction bodies that
    are not in a clump (e.g. left by YADE's own ``erase`` of a corrected clump: a free body of
    negative mass), registry entries whose clump is gone or has lost its correction, clumps that
    hold a correction with no sphere or with a non-sphere member (stale), dynamic bodies outside
    clumps with a mass or principal moment that is not positive (``invalid``) and corrections whose
    mask is not the union of their spheres' masks (``masks``).
    """
    Y = _Y.load()
    reg = _registry()
    rep = CheckReport()
    seen = set()
    pending = []  # corrected clumps with a registry entry: (id, spheres, method, reasons)
    for b in Y.O.bodies:
        if b is None:
            continue
        if type(b.shape) is Y.Shape and not b.bounded and not b.isClump and not b.isClumpMember:
            rep.orphaned.append((b.id, f"correction body outside any clump (free body, mass {float(b.state.mass):.6g} kg)"))
            continue
        if not b.isClump:
            continue
        cid = b.id
        seen.add(cid)
        rec = reg.get(cid)
        try:
            spheres, corr = _split_members(b)
        except ClumpAdapterError as exc:
            if rec is not None or _has_correction(Y, b):  # e.g. a correction clumped alone or with other shapes
                rep.stale.append((cid, str(exc)))
            else:
                rep.uncorrected.append(cid)
            continue
        if corr is None:
            if rec is not None:
                rep.stale.append((cid, f"the registry records correction #{rec[0]} but the clump has none (YADE's summed values)"))
            else:
                rep.uncorrected.append(cid)
            continue
        if rec is None:
            rep.stale.append((cid, f"correction #{corr.id} is not in the registry"))
            continue
        why = []
        if rec[0] != corr.id:
            why.append(f"correction is #{corr.id}, the registry records #{rec[0]}")
        if not _fingerprint_matches(rec[1], spheres):
            why.append("its sphere set changed since it was corrected (fingerprint differs)")
        _check_mask(rep, cid, spheres, corr)
        pending.append((cid, spheres, rec[2], why))
    _compare_states(Y, rep, pending, rtol)
    for cid, rec in reg.items():
        if cid not in seen:
            rep.orphaned.append((cid, f"registry entry for clump #{cid} (correction #{rec[0]}), which no longer exists"))
    _check_dynamic_mass(Y, rep)
    rep.exact.sort()
    rep.stale.sort()
    if raise_on_error and not rep.ok:
        raise ClumpAdapterError(str(rep))
    return rep



def _compare_states(Y, rep, pending, rtol):
    """YADE's state of each pending clump [(id, spheres, method, reasons)] against the library, one
    batch per method (``montecarlo``: the fingerprint only); fills ``rep.exact``, ``rep.stale`` and
    ``rep.max_error``."""
    by_method = {}
    for item in pending:
        by_method.setdefault(item[2], []).append(item)
    for method, items in by_method.items():
        if method != "montecarlo":
            try:
                pts, radii, rhos = [], [], []
                for cid, spheres, _, _ in items:
                    x, r = _geometry(spheres)
                    pts.append(x)
                    radii.append(r)
                    rhos.append(_clump_density(f"clump #{cid}", spheres))
                targets = _target_rows(pts, radii, rhos, method)
            except (ValueError, ImportError) as exc:
                for _, _, _, why in items:
                    why.append(f"exact properties could not be computed: {exc}")
            else:
                rows = [_state_row(Y.O.bodies[it[0]].state) for it in items]
                e_m, e_c, e_i = _state_errors(rows, targets)
                for k, (_, _, _, why) in enumerate(items):
                    e = max(e_m[k], e_c[k], e_i[k])
                    rep.max_error = max(rep.max_error, float(e))
                    if not e <= rtol:
                        why.append(
                            f"YADE's state differs from the exact properties (relative: mass {e_m[k]:.2g}, "
                            f"centre of mass {e_c[k]:.2g}, inertia {e_i[k]:.2g})"
                        )
        for cid, _, _, why in items:
            if why:
                rep.stale.append((cid, "; ".join(why)))
            else:
                rep.exact.append(cid)


def _check_mask(rep, cid, spheres, corr):
    """Report a correction whose mask is not the union of its spheres' (see :func:`_correction_mask`)."""
    want = _correction_mask(spheres)
    if int(corr.mask) != want:
        rep.masks.append((cid, f"correction #{corr.id} has mask {int(corr.mask):#x}, its spheres' union is {want:#x} "
                               f"(a mask-selected engine would weigh the clump wrongly); run cy.correct_clump({cid})"))



def _check_dynamic_mass(Y, rep):
    """Report every dynamic body outside clumps (clumps and free bodies: what NewtonIntegrator moves)
    whose mass or a principal moment is not positive and finite."""
    for b in Y.O.bodies:
        if b is None or b.isClumpMember or not b.dynamic:
            continue
        st = b.state
        m = float(st.mass)
        inertia = [float(st.inertia[k]) for k in range(3)]
        if not (0.0 < m < math.inf and all(0.0 < i < math.inf for i in inertia)):
            kind = "clump" if b.isClump else type(b.shape).__name__ if b.shape is not None else "no shape"
            rep.invalid.append((b.id, f"dynamic {kind} with mass {m:.6g} kg and principal moments "
                                      f"{', '.join(f'{i:.6g}' for i in inertia)} (must be positive)"))
    rep.invalid.sort()

