"""What is wrong with the mass properties a file states: overlap error, reference point, frame.

:func:`diagnose` compares a :class:`clumpprops.io.stated.Stated` record with the exact values
and names the cause of a difference:

* overlap error: the stated mass matches the summed spheres (overlaps counted twice), not the
  union;
* wrong reference point: the engine takes the stated point as the centre of mass (and the
  tensor about it) while the clump's centre of mass is elsewhere; when the stated tensor
  equals the exact one moved to that point (parallel-axis theorem) it was computed about the
  file's origin;
* frame not principal: the engine uses only the diagonal (DEME's ``moi``) but the tensor in
  the clump's frame has off-diagonal terms, so the engine's principal moments are wrong.
"""
from __future__ import annotations

import numpy as np

#: Relative agreement that counts as "the same value" (files carry 7 or more digits).
MATCH = 1e-5


def _shifted(I_com, mass, d):
    """Inertia tensor about a point displaced by -d from the centre of mass (parallel axes)."""
    d = np.asarray(d, float)
    return I_com + mass * (d @ d * np.eye(3) - np.outer(d, d))


def _close(a, b, scale):
    return bool(np.max(np.abs(np.asarray(a) - np.asarray(b))) <= MATCH * scale)


def diagnose(stated, exact, summed) -> dict:
    """Errors of stated values and their causes.

    Parameters
    ----------
    stated : clumpprops.io.stated.Stated
        What the file states.
    exact, summed : clumpprops.audit.methods.Estimate
        Exact and summed-sphere values of the same clump (``extra["inertia"]``: tensor about the
        centre of mass).

    Returns
    -------
    dict
        ``mass_error`` (relative), ``moment_errors`` (relative, ascending principal moments as
        the engine uses them), ``com_offset`` (m), and ``findings``: a list of one-line causes.
    """
    out = {"engine": stated.engine, "source": stated.source, "findings": []}
    f = out["findings"]
    if stated.mass is not None:
        out["mass"] = stated.mass
        out["mass_error"] = stated.mass / exact.mass - 1.0
        if abs(stated.mass / summed.mass - 1.0) <= MATCH < abs(summed.mass / exact.mass - 1.0):
            f.append(f"overlap error: the mass is the summed spheres' ({100 * out['mass_error']:+.3g} %)")
    if stated.mass is None and stated.inertia is None:
        f.append("states no mass or inertia: the engine computes them itself (its method's row above)")
        return out
    offset = exact.com - stated.reference
    out["com_offset"] = float(np.linalg.norm(offset))
    size = float(np.sqrt(np.max(exact.moments) / exact.mass))
    if out["com_offset"] > MATCH * size:
        f.append(f"wrong reference point: the engine takes the centre of mass at {stated.reference.tolist()}, "
                 f"it is at {exact.com.tolist()} ({out['com_offset']:.3g} m away)")
    if stated.inertia is None:
        return out
    used = np.diag(np.diag(stated.inertia)) if stated.diagonal_only else stated.inertia
    moments = np.linalg.eigvalsh(used)
    out["principal_moments"] = moments.tolist()
    out["moment_errors"] = (moments / exact.moments - 1.0).tolist()
    I_c = exact.extra["inertia"]
    scale = float(np.max(exact.moments))
    for name, est in (("exact", exact), ("summed spheres", summed)):
        T = est.extra["inertia"]
        if out["com_offset"] > MATCH * size and _close(stated.inertia, _shifted(T, est.mass, offset), scale):
            f.append(f"the tensor is the {name} one about {stated.reference.tolist()}, not about the centre of mass")
        elif name == "summed spheres" and _close(stated.inertia, T, scale) and not _close(T, I_c, scale):
            f.append("overlap error: the tensor is the summed spheres'")
    if not any("tensor" in x for x in f):
        near = nearest_tensor(stated.inertia, exact, summed, stated.reference)
        if near is not None:
            f.append(near)
    off = np.max(np.abs(I_c - np.diag(np.diag(I_c))))
    if stated.diagonal_only and off > MATCH * scale:
        f.append(f"frame not principal: the engine keeps only the diagonal, the off-diagonal terms reach "
                 f"{off / scale:.3g} of the largest moment")
    if not f and max(abs(e) for e in out["moment_errors"] + [out.get("mass_error", 0.0)]) <= MATCH:
        f.append("agrees with the exact values")
    return out


#: A stated tensor within this relative distance of a candidate, and ten times closer to it than
#: to the exact tensor about the centre of mass, is named as that candidate (a file's values may
#: come from a sampled estimate, good to a few per mille).
NEAR = 0.02


def _swap_xy_yz(T):
    """The tensor with its xy and yz products exchanged (a six-value line read in the other order)."""
    T = np.array(T, float)
    T[0, 1], T[1, 2] = T[1, 2], T[0, 1]
    T[1, 0], T[2, 1] = T[0, 1], T[1, 2]
    return T


def nearest_tensor(stated_inertia, exact, summed, reference):
    """Which wrong tensor a stated one is, when it is near none exactly.

    Parameters
    ----------
    stated_inertia : array_like, shape (3, 3)
        The stated tensor.
    exact, summed : clumpprops.audit.methods.Estimate
        Exact and summed-sphere values (``extra["inertia"]``: tensor about the centre of mass).
    reference : array_like, shape (3,)
        The point the file states as the centre of mass.

    Returns
    -------
    str or None
        One line naming the nearest of: the exact or summed tensor about the file's origin or
        about the stated point, as it is or with its xy and yz products exchanged; None when the stated tensor is nearest to the exact one about
        the centre of mass, or near none of them.
    """
    S = np.asarray(stated_inertia, float)
    origin, reference = np.zeros(3), np.asarray(reference, float)
    cands = {"the exact one about the centre of mass": exact.extra["inertia"]}
    for name, est in (("exact", exact), ("summed spheres'", summed)):
        for where, point in (("the file's origin [0, 0, 0]", origin), ("the stated point", reference)):
            T = _shifted(est.extra["inertia"], est.mass, est.com - point)
            cands[f"the {name} one about {where}"] = T
            cands[f"the {name} one about {where} with Ixy and Iyz swapped (written as Ixy Ixz Iyz, read in "
                  f"Voigt order Iyz Ixz Ixy)"] = _swap_xy_yz(T)
    dist = {k: float(np.max(np.abs(S - T)) / np.max(np.abs(T))) for k, T in cands.items()}
    best = min(dist, key=dist.get)
    base = dist["the exact one about the centre of mass"]
    if best == "the exact one about the centre of mass" or dist[best] > NEAR or dist[best] * 10 > base:
        return None
    return (f"the tensor is {best} (to {100 * dist[best]:.2g} %), not about the centre of mass "
            f"({100 * base:.3g} % from the exact one there)")
