"""textClumps files: reading them into exact clumps, writing them back without loss."""
from __future__ import annotations

from ..api import DEFAULT_METHOD
from ..textclumps import read_text_clumps
from ._loader import _rotation, _vec, _Y
from .build import append_clumps


def text_clumps(fileName, shift=None, discretization=0, orientation=None, scale=1.0, method=DEFAULT_METHOD, **kw):
    """Drop-in for ``ymport.textClumps(fileName, shift, discretization, orientation, scale, **kw)``: exact clumps.

    Same arguments in the same order (``discretization`` is accepted for compatibility and
    irrelevant: the clumps get the library's values), same grouping (a new clump whenever the
    id column changes), same return value ``[(clump_id, [member_ids]), ...]`` and the clump's mask
    set to its first member's; ``**kw`` go to ``utils.sphere`` (material, color, mask, ...).
    The file is read by the project's own parser (:mod:`clumpprops.textclumps`), so a malformed
    line raises :class:`~clumpprops.io.ClumpFileError` with its line number before
    anything is added.  Mirrors ``ymport.textClumps``: ``fileName`` keeps YADE's camelCase name.
    """
    Y = _Y.load()
    from yade import utils

    q = Y.Quaternion((0, 1, 0), 0.0) if orientation is None else orientation
    sh = Y.Vector3(0, 0, 0) if shift is None else Y.Vector3(*[float(a) for a in shift])
    clumps = read_text_clumps(fileName)  # file coordinates; YADE's transform below
    R = _rotation(q)
    shift_np = _vec(sh)
    groups = []
    for c in clumps:
        pos = shift_np + scale * (c.centers @ R.T)  # shift + scale * (orientation * x)
        groups.append([utils.sphere(tuple(p), scale * float(r), **kw) for p, r in zip(pos.tolist(), c.radii.tolist())])
    ret = append_clumps(groups, method=method)
    for cid, mids in ret:
        Y.O.bodies[cid].mask = Y.O.bodies[mids[0]].mask
    return ret



def export_text_clumps(filename, comment="", mask=-1):
    """``export.textClumps`` that can be read back: ids as integers, coordinates to the last bit.

    YADE's writer uses ``%g``: 6 significant digits for positions and radii, and ids >= 10**6 in
    exponent form (``1.23457e+06``), rounded, so neighbouring clumps can merge and
    ``ymport.textClumps`` cannot read the file.  This writes the same format
    (``#format x_y_z_r_clumpId``, one sphere member per line, correction members skipped) with
    ``%.17g`` and ``%d``.  Returns ``(number of clumps, number of spheres)`` like YADE's.
    """
    Y = _Y.load()
    out = ["#format x_y_z_r_clumpId\n"]
    if comment:
        out.append("# " + comment + "\n")
    n_clumps = n = 0
    for b in Y.O.bodies:
        if b is None or not b.isClump:
            continue
        n_clumps += 1
        for mid in b.shape.members.keys():
            m = Y.O.bodies[int(mid)]
            if m is not None and isinstance(m.shape, Y.Sphere) and (mask < 0 or (mask & m.mask) > 0):
                p = m.state.pos
                out.append(f"{float(p[0])!r}\t{float(p[1])!r}\t{float(p[2])!r}\t{float(m.shape.radius)!r}\t{b.id:d}\n")
                n += 1
    with open(filename, "w") as f:
        f.write("".join(out))
    return n_clumps, n

