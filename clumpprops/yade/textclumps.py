"""textClumps files: reading them into exact clumps, writing them back without loss."""
from __future__ import annotations

from ..api import DEFAULT_METHOD
from ..textclumps import read_text_clumps
from ._loader import _rotation, _vec, _Y
from .build import append_clumps


def text_clumps(fileName, shift=None, discretization=0, orientation=None, scale=1.0, method=DEFAULT_METHOD, **kw):
    """Drop-in for ``ymport.textClumps(fileName, shift, discretization, orientation, scale, **kw)``: exact clumps.

    Mirrors ``ymport.textClumps``: the same arguments in the same order, and ``fileName`` keeps
    YADE's camelCase name, so a call written for YADE works unchanged.

    Parameters
    ----------
    fileName : str or path-like
        The textClumps file (``x y z r clumpId`` per line, lengths in the file's unit).
    shift : array_like, shape (3,), optional
        Translation added after rotation and scaling, in m; None for none.
    discretization : int, optional
        Accepted for compatibility and irrelevant: the clumps get the library's values.
    orientation : yade.Quaternion, optional
        Rotation applied to the file's coordinates; None for none.
    scale : float, optional
        Factor applied to the file's coordinates and radii (to m).
    method : str, optional
        Name of the method of :func:`clumpprops.mass_properties` (``"exact"``, the default,
        ``"pairwise"``, ``"sum"``, ``"montecarlo"`` or ``"voxel"``).
    **kw
        Passed to ``utils.sphere`` for every sphere (``material``, ``color``, ``mask``, ...).

    Returns
    -------
    list of (int, list of int)
        ``(clump_id, member_ids)`` per clump, in file order, as YADE returns them
        (``member_ids`` without the correction member).

    Raises
    ------
    OSError
        If the file cannot be read.
    clumpprops.io.ClumpFileError
        If a line is malformed (the message gives its line number), before anything is added.
    ClumpAdapterError
        For the clumps :func:`append_clumps` refuses (e.g. a method that cannot compute one),
        before anything is added.

    Notes
    -----
    Same grouping as YADE (a new clump whenever the id column changes), the same transform
    (``shift + scale * (orientation * x)``), and the clump's mask set to its first member's.
    The file is read by the project's own parser (:mod:`clumpprops.textclumps`).
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
    ``%.17g`` and ``%d``.

    Parameters
    ----------
    filename : str or path-like
        The file to write (overwritten).
    comment : str, optional
        Written as a ``# comment`` line after the format line; empty for none.
    mask : int, optional
        Write only the spheres whose mask shares a bit with ``mask``; negative (the default)
        writes every sphere member.

    Returns
    -------
    n_clumps : int
        Number of clumps in the scene (each one counted, even if the mask selects none of its
        spheres), as YADE's ``export.textClumps`` counts them.
    n_spheres : int
        Number of sphere lines written.

    Raises
    ------
    OSError
        If the file cannot be written.
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

