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
    off = np.max(np.abs(I_c - np.diag(np.diag(I_c))))
    if stated.diagonal_only and off > MATCH * scale:
        f.append(f"frame not principal: the engine keeps only the diagonal, the off-diagonal terms reach "
                 f"{off / scale:.3g} of the largest moment")
    if not f and max(abs(e) for e in out["moment_errors"] + [out.get("mass_error", 0.0)]) <= MATCH:
        f.append("agrees with the exact values")
    return out
