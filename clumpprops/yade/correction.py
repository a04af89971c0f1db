"""The correction member: targets and the correction's state (through the compiled core), and the
YADE body that carries it.

``Clump::updateProperties`` sums each NON-spherical member with its own ``state.mass``,
``state.pos``, ``state.inertia`` and ``state.ori``.  The correction is such a member whose state
holds exactly "target minus summed spheres" (the package docstring has the details).  Both
computations run in the compiled core: ``_core.adapter_clump`` (target and correction of a clump
in one call, for the methods the core computes) and ``_core.adapter_correction`` (the correction
for a given target: the baseline methods, and the wording of a refusal).
"""
from __future__ import annotations

import numpy as np

from ..api import _CORE, mass_properties
from ..core import _core
from ._loader import ClumpAdapterError

_adapter_clump = _core.adapter_clump  # module-level so a test can wrap them
_adapter_correction = _core.adapter_correction

_STRICT = ("exact", "pairwise", "sum")  # methods whose target is the union of the spheres
_HEAVY, _OUTSIDE = 1, 2  # adapter_correction's refusals (_core.cpp, CorrectionStatus)


def _heavy_error(k, mass, m_s):
    return ClumpAdapterError(
        f"clump {k} of the batch: target mass {mass!r} exceeds the summed spheres' {m_s!r}; "
        "the union of the spheres cannot be heavier (library error)"
    )


def _outside_error(k, norm, reach):
    return ClumpAdapterError(
        f"clump {k} of the batch: the correction's centroid would lie {norm:.6g} m from the centre of "
        f"mass, outside the clump (reach {reach:.6g} m); the target centre of mass is inconsistent "
        "with the spheres (library error)"
    )


def _correction(k, pts, radii, rhos, target, strict):
    """The correction of clump ``k`` of a batch for ``target`` (mass, com (3), inertia (9, row-major),
    ...): the 20 floats m_c, offset (3), moments (3), axes (9, row-major, right-handed columns),
    orientation (w, x, y, z); raises :class:`ClumpAdapterError` naming ``k`` where it cannot be made."""
    out = _adapter_correction(pts, radii, rhos, target, strict)
    if out is None:
        raise ClumpAdapterError(f"clump {k} of the batch: its spheres or target are not finite numbers")
    if out[0] == _HEAVY:
        raise _heavy_error(k, target[0], out[1])
    if out[0] == _OUTSIDE:
        raise _outside_error(k, out[1], out[2])
    if out[0]:
        raise ClumpAdapterError(f"clump {k} of the batch: clump properties could not be computed (the "
                                "correction is not finite)")
    return out[1:]


def correction_terms(centers, radii, densities, mass, com, inertia, strict=True):
    """State of the correction members of a batch of clumps.

    Parameters
    ----------
    centers : list of (N_m, 3) array_like
        World positions of the member spheres of each clump.
    radii, densities : list of (N_m,) array_like
        Radii and material densities (as YADE reads them) of those spheres.
    mass, com, inertia : array_like, shapes (M,), (M, 3), (M, 3, 3)
        The target (exact) properties.
    strict : bool
        The target is a union of the spheres (the exact methods "exact", "pairwise", "sum"): the
        excess "summed minus union" is a non-negative distribution inside the clump, so ``m_c <= 0``
        and ``|offset| <=`` the clump's reach about its centre of mass.  A target that breaks either
        is a library error and raises; nothing is clamped.

    Returns
    -------
    mass_c : (M,) ndarray
    offset_c : (M, 3) ndarray
        The correction sits at ``com + offset_c``.
    moments_c : (M, 3) ndarray
    axes_c : (M, 3, 3) ndarray
        Right-handed columns.  Spheres + correction sum, the way ``Clump::updateProperties`` sums
        them, to the target.

    Raises
    ------
    ClumpAdapterError
        Naming the clump (index in the batch) whose correction cannot be made.

    Notes
    -----
    All sums are taken about the target centre of mass, so nothing is lost to cancellation however
    far the clump is from the origin.  The correction's offset cancels the spheres' first moment:
    ``m_c * offset = -S``.  Where ``|m_c| * reach`` is below the round-off of ``S`` (no real overlap:
    touching or separate spheres, one sphere) the offset is 0, which moves the centre of mass by
    round-off only.  Both tests allow for a density spread between the spheres (accepted up to
    1e-12; the target uses the first sphere's density): it adds sum m_i |rho_i - rho_0| / rho_i to
    the round-off of m_c, and that times |d_i| + r_i to the round-off of S.  Computed by
    ``_core.adapter_correction``.
    """
    M = len(radii)
    mass = np.asarray(mass, float).reshape(M)
    com = np.asarray(com, float).reshape(M, 3)
    inertia = np.asarray(inertia, float).reshape(M, 9)
    rows = []
    for k in range(M):
        target = [float(mass[k]), *com[k].tolist(), *inertia[k].tolist()]
        rows.append(_correction(k, np.asarray(centers[k], float).reshape(-1, 3).tolist(),
                                np.asarray(radii[k], float).ravel().tolist(),
                                np.asarray(densities[k], float).ravel().tolist(), target, strict))
    t = np.array(rows, dtype=float).reshape(M, 20)
    return t[:, 0], t[:, 1:4], t[:, 4:7], t[:, 7:16].reshape(M, 3, 3)


def _targets(xs, rs, rhos, method):
    """Target properties of a ragged batch: mass (M,), com (M, 3), inertia (M, 3, 3) and the scale of
    each inertia tensor (largest |principal moment|), one library call per density.

    xs: list of (N_m, 3) arrays; rs likewise (N_m,); rhos: per clump, its spheres' densities (equal to
    1e-12: the first one is used)."""
    M = len(xs)
    dens = np.array([rho[0] for rho in rhos], dtype=float)
    mass, com, inertia, scale = np.empty(M), np.empty((M, 3)), np.empty((M, 3, 3)), np.empty(M)
    for value in np.unique(dens):
        idx = np.flatnonzero(dens == value)
        mp = mass_properties([xs[i] for i in idx], [rs[i] for i in idx], density=value, method=method)
        mass[idx] = mp.mass
        com[idx] = mp.center_of_mass
        inertia[idx] = mp.inertia
        scale[idx] = np.max(np.abs(mp.principal_moments), axis=1)
    return mass, com, inertia, scale


def _target_rows(pts, radii, rhos, method):
    """The targets of :func:`_targets` as one list per clump: mass, com (3), inertia (9), scale."""
    mass, com, inertia, scale = _targets([np.array(p, dtype=float) for p in pts],
                                         [np.array(r, dtype=float) for r in radii], rhos, method)
    return [[m, *c, *i, s] for m, c, i, s in zip(mass.tolist(), com.tolist(), inertia.reshape(-1, 9).tolist(),
                                                 scale.tolist())]


def _corrections(pts, radii, rhos, method):
    """Targets and correction terms of a batch, before anything in the scene changes.

    pts, radii, rhos: per clump lists of (x, y, z), of radii and of densities (python floats).
    Returns one tuple of 34 floats per clump, laid out as ``_core.adapter_clump`` returns them:
    mass, com (3), inertia (9, row-major), scale, m_c, offset (3), moments (3), axes (9), orientation
    (w, x, y, z).  A method the core computes takes one ``adapter_clump`` call per clump; the others
    (and anything the core declines) get the library's targets and ``adapter_correction``, which
    names the refused clump (``clump k of the batch: ...``)."""
    strict = method in _STRICT
    M = len(rhos)
    if method in _CORE:
        code = _CORE[method]
        rows = [_adapter_clump(code, pts[k], radii[k], rhos[k], strict) for k in range(M)]
        if None not in rows:
            return rows
    else:
        rows = [None] * M
    targets = _target_rows(pts, radii, rhos, method)  # a core error raises here (ValueError)
    return [row if row is not None else (*targets[k], *_correction(k, pts[k], radii[k], rhos[k], targets[k], strict))
            for k, row in enumerate(rows)]


# --------------------------------------------------------------------------- the correction body in YADE


def _correction_mask(spheres):
    """Bitwise OR of the spheres' masks.  Engines select a body by mask when ``mask & M != 0``
    (``GravityEngine`` and the other field appliers, which weigh clump members one by one): an engine
    that selects every sphere of the clump shares a bit with each of them, hence with their union,
    and so selects the correction too; an engine that selects none of the spheres shares no bit
    with the union and skips the correction.  (``NewtonIntegrator``'s mask looks at the clump body,
    ``VTKRecorder`` never exports the correction.)"""
    m = 0
    for b in spheres:
        m |= int(b.mask)
    return m


def _correction_shape(Y):
    """The bare ``Shape`` every correction body points to (one object: a bare Shape holds no data that
    matters to YADE, it has no bound, collision or rendering functor; sharing it saves a construction
    per clump)."""
    sh = getattr(Y, "corr_shape", None)
    if sh is None:
        sh = Y.corr_shape = Y.Shape()
    return sh


_PLAIN_STATE = {}  # material class -> True if its newAssocState() is a plain State (Body()'s own)


def _new_correction(Y, spheres, mat=None, mask=None):
    """A correction body for a clump of ``spheres``: bare ``Shape``, unbounded, the spheres' material
    with the state class that material expects (``material.newAssocState()``: CpmState for CpmMat,
    JCFpmState for JCFpmMat, ...), the union of the spheres' masks.  Its mass properties are set later.
    ``mat``, ``mask``: the first sphere's material and that mask, if already known."""
    if mat is None:
        mat = spheres[0].material
    b = Y.Body()
    b.shape = _correction_shape(Y)
    b.material = mat
    plain = _PLAIN_STATE.get(type(mat))
    if not plain:  # a new Body() has a plain State already
        st = mat.newAssocState()
        if plain is None:
            _PLAIN_STATE[type(mat)] = type(st) is Y.State
        b.state = st
    b.bounded = False
    b.mask = _correction_mask(spheres) if mask is None else mask
    return b


def _set_correction_state(Y, st, m, p, w, q):
    """Mass ``m``, position ``p`` (3), principal moments ``w`` (3) and orientation ``q`` (w, x, y, z)
    of a correction's state.  ``Clump::updateProperties`` adds R^T diag(w) R with
    R = ori.toRotationMatrix(); ``q`` is the rotation V^T of the axes V, so it adds V diag(w) V^T."""
    V3 = Y.Vector3
    st.mass = float(m)
    st.pos = V3(float(p[0]), float(p[1]), float(p[2]))
    st.inertia = V3(float(w[0]), float(w[1]), float(w[2]))
    st.ori = Y.Quaternion(float(q[0]), float(q[1]), float(q[2]), float(q[3]))


def _neutralize(Y, corr):
    """Zero mass and inertia: YADE's next update of the clump sums its spheres only (positive mass,
    never the `M > 0` abort), whatever members it gains or loses."""
    if corr is not None:
        st = corr.state
        st.mass = 0.0
        st.inertia = Y.Vector3(0.0, 0.0, 0.0)
