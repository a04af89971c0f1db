"""Reader for YADE's ``ymport.textClumps`` text format (no YADE import).

Format, as read by YADE's ``yade.ymport.textClumps`` (and written by
``yade.export.textClumps``, which starts the file with ``#format x_y_z_r_clumpId``)::

    # comment
    x  y  z  r  clumpId
    ...

* one sphere per line: centre ``x y z`` (m), radius ``r`` (m), integer ``clumpId``,
  separated by any whitespace;
* a line whose first word starts with ``#`` is a comment;
* consecutive lines with the same ``clumpId`` form one clump; a line with a
  different ``clumpId`` starts a new clump.  Like YADE, an id that comes back
  after another id starts a *new* clump (ids ``0 0 1 0`` are three clumps);
  :attr:`Clump.repeated_id <clumpprops.io.Clump>` flags that case so callers can warn;
* words after the fifth are ignored, as YADE ignores them (so a trailing
  ``# comment`` is allowed).

Differences from YADE, all stricter or friendlier, never a different grouping:
blank lines are skipped (YADE stops with an IndexError); a short line, a word
that is not a number, a non-finite value, a radius <= 0 or a non-integer
``clumpId`` raise :class:`~clumpprops.io.ClumpFileError` with the line number (YADE raises a bare
``ValueError`` or silently builds a broken clump).  ``clumpId`` must be an integer, as
YADE's ``int()`` demands, so ``3.0`` is rejected.  Numbers are ASCII only
(:mod:`clumpprops._numtext`): ``1_0`` and non-ASCII digits such as ``١٠``, which Python's
``float()`` and ``int()`` (and so YADE) read as 10, are rejected; a UTF-8 byte order mark at
the start of the file is skipped.  Ids >= 10**6 written
as plain integers are fine.  ``export.textClumps`` writes ids with ``%g``, which turns
ids >= 10**6 into exponent form rounded to 6 significant digits (``1234567`` becomes
``1.23457e+06``, ``1234568`` too), so neighbouring clumps can merge: such ids are
refused with a message saying so (``ymport.textClumps`` cannot read them either);
write the file with integer ids (``clumpprops.yade.export_text_clumps``).

``scale`` and ``shift`` behave as in ``ymport.textClumps``: position
``shift + scale * (x, y, z)``, radius ``scale * r``.

Large files: blocks of 65536 lines are parsed by numpy's C reader into flat typed arrays
(40 bytes per sphere); a block numpy refuses is read again line by line, which raises the
error with its line number.  The clumps returned are light views into those arrays, so a
file of 10**6 lines parses in a few seconds and holds the arrays and one block of text
(benchmarks/bench_io.py --read-lines measures both).
"""
from __future__ import annotations

import itertools
import math
import sys
import warnings
from array import array
from collections import abc
from typing import Iterable, Optional, Sequence

import numpy as np

from ._clumps import Clump, ClumpFileError
from ._numtext import BOM, fast_table, float_columns, is_float, strict_float, strict_int

__all__ = ["TextClumps", "parse_text_clumps", "read_text_clumps"]


_DEPRECATED = {"TextClump": Clump, "TextClumpsError": ClumpFileError}


def __getattr__(name):
    """``TextClump`` and ``TextClumpsError``: deprecated aliases of :class:`clumpprops.io.Clump` and
    :class:`clumpprops.io.ClumpFileError` (the same classes; a DeprecationWarning says so)."""
    if name in _DEPRECATED:
        new = _DEPRECATED[name]
        warnings.warn(f"clumpprops.textclumps.{name} is deprecated: it is clumpprops.io.{new.__name__}, "
                      "the clump record and file error of every reader", DeprecationWarning, stacklevel=2)
        return new
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class TextClumps(abc.Sequence):
    """The clumps of a file: a read-only sequence of :class:`~clumpprops.io.Clump`, backed by flat arrays.

    ``centers`` (S, 3), ``radii`` (S,), ``lines`` (S,) for all S spheres in file order;
    ``starts`` (M + 1,) the first sphere of each clump (and S); ``ids`` (M,) the clump ids;
    ``repeated`` (M,) bool; ``source`` the file's name.  Item k is a ``Clump`` whose ``centers``
    and ``radii`` are views into the flat arrays, with its ``clump_id``, ``repeated_id`` and
    ``lines``, named ``clump``.
    """

    def __init__(self, centers, radii, lines, starts, ids, repeated, source="<text>"):
        self.centers, self.radii, self.lines = centers, radii, lines
        self.starts, self.ids, self.repeated = starts, ids, repeated
        self.source = source
        for a in (centers, radii, lines, starts, ids, repeated):
            a.flags.writeable = False

    def __len__(self):
        return len(self.ids)

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        n = len(self)
        if k < 0:
            k += n
        if not 0 <= k < n:
            raise IndexError("clump index out of range")
        a, b = int(self.starts[k]), int(self.starts[k + 1])
        return Clump(self.centers[a:b], self.radii[a:b], "clump", self.source, tuple(self.lines[a:b].tolist()),
                     int(self.ids[k]), bool(self.repeated[k]))


_COLUMNS = ("x", "y", "z", "r")
_ID_MAX = 2**63 - 1


def _id_error(word: str) -> str:
    try:
        v = strict_float(word)
    except ValueError:
        return f"clumpId must be an integer, got {word!r}"
    if math.isfinite(v) and v == int(v) and "e" in word.lower():
        return (
            f"clumpId {word!r} is in exponent form: YADE's export.textClumps writes ids with %g, which rounds "
            "ids >= 10**6 to 6 significant digits (1234567 and 1234568 both become '1.23457e+06'), so "
            "neighbouring clumps may merge; ymport.textClumps cannot read it either. Write the file with "
            "integer ids (clumpprops.yade.export_text_clumps) or renumber the clumps below 10**6"
        )
    return f"clumpId must be an integer, got {word!r}"


def _first_bad_value(vals: np.ndarray, lines, source):
    """Raise for the first row (x, y, z, r) that is not finite or has r <= 0, if any."""
    if len(vals) == 0:
        return
    a = vals.reshape(-1, 4)
    bad = ~np.isfinite(a)
    bad_r = ~(a[:, 3] > 0)
    rows = np.flatnonzero(bad.any(axis=1) | bad_r)
    if len(rows) == 0:
        return
    i = int(rows[0])
    lineno = int(lines[i])
    for k in range(4):
        if bad[i, k]:
            raise ClumpFileError(f"{_COLUMNS[k]} is not finite: {a[i, k]!r}", source, lineno)
    raise ClumpFileError(f"radius must be > 0 (m), got {a[i, 3]!r}", source, lineno)


def parse_text_clumps(
    lines: Iterable[str],
    source: str = "<text>",
    scale: float = 1.0,
    shift: Sequence[float] = (0.0, 0.0, 0.0),
) -> TextClumps:
    """Parse textClumps lines (see the module docstring) into a sequence of :class:`~clumpprops.io.Clump`.

    ``source`` names the input in error messages.  Raises :class:`~clumpprops.io.ClumpFileError`
    for malformed lines (the first one in file order) and for input without any sphere.
    """
    scale = float(scale)
    if not math.isfinite(scale) or scale <= 0:
        raise ClumpFileError(f"scale must be a positive finite number, got {scale!r}", source)
    shift = np.asarray(shift, dtype=np.float64)
    if shift.shape != (3,) or not np.all(np.isfinite(shift)):
        raise ClumpFileError(f"shift must be 3 finite numbers, got {shift.tolist()!r}", source)

    vals = array("d")  # x, y, z, r per sphere
    ids = array("q")
    lns = array("q")
    it = _without_bom(iter(lines))
    lineno = 0
    try:
        while True:
            chunk = list(itertools.islice(it, _CHUNK))
            if not chunk:
                break
            if not _fast_chunk(chunk, lineno, vals, ids, lns):
                _slow_chunk(chunk, lineno, vals, ids, lns, source)
            lineno += len(chunk)
    except ClumpFileError:
        # an earlier line may hold a non-finite value or a bad radius: report the first error in the file
        _first_bad_value(np.frombuffer(vals, dtype=np.float64), np.frombuffer(lns, dtype=np.int64), source)
        raise
    a = np.frombuffer(vals, dtype=np.float64).reshape(-1, 4)
    line_arr = np.frombuffer(lns, dtype=np.int64)
    _first_bad_value(a.ravel(), line_arr, source)
    if len(a) == 0:
        raise ClumpFileError("no spheres found (expected lines 'x y z r clumpId')", source)
    id_arr = np.frombuffer(ids, dtype=np.int64)
    starts = np.concatenate(([0], np.flatnonzero(id_arr[1:] != id_arr[:-1]) + 1, [len(id_arr)]))
    clump_ids = id_arr[starts[:-1]]
    _, first, inverse = np.unique(clump_ids, return_index=True, return_inverse=True)
    repeated = first[inverse] != np.arange(len(clump_ids))
    centers = a[:, :3] * scale + shift if (scale != 1.0 or np.any(shift)) else a[:, :3].copy()
    radii = a[:, 3] * scale if scale != 1.0 else a[:, 3].copy()
    return TextClumps(centers, radii, line_arr.copy(), starts, clump_ids.copy(), repeated, source)


def _without_bom(it):
    """The lines, a UTF-8 byte order mark at the start of the first one removed."""
    first = next(it, None)
    if first is None:
        return iter(())
    return itertools.chain([first[len(BOM):] if first.startswith(BOM) else first], it)


_CHUNK = 1 << 16  # lines per block: bounded memory for the text, whatever the file size
_ROW = np.dtype([("x", "f8"), ("y", "f8"), ("z", "f8"), ("r", "f8"), ("id", "i8")])


def _fast_chunk(chunk, offset, vals, ids, lns) -> bool:
    """Parse a block of lines with numpy's C reader (ASCII numbers only, ids plain integers: '3.0',
    '1e+06', '1_0' and out-of-range ids fail); False (nothing appended) if any line needs the
    line-by-line path, which then raises the error with its line number."""
    keep = [i for i, line in enumerate(chunk) if line.lstrip()[:1] not in ("#", "")]
    if not keep:
        return True
    data = chunk if len(keep) == len(chunk) else [chunk[i] for i in keep]
    rows = fast_table(data, _ROW, usecols=range(5))
    if rows is None:
        return False
    vals.frombytes(float_columns(rows, _COLUMNS).tobytes())
    ids.frombytes(np.ascontiguousarray(rows["id"]).tobytes())
    lns.frombytes((np.asarray(keep, dtype=np.int64) + offset + 1).tobytes())
    return True


def _slow_chunk(chunk, offset, vals, ids, lns, source):
    """The reference parser, one line at a time (YADE's rules; first error raised with its line)."""
    extend, add_id, add_line = vals.extend, ids.append, lns.append
    for lineno, line in enumerate(chunk, start=offset + 1):
        data = line.split()
        if not data or data[0][0] == "#":
            continue
        if len(data) < 5:
            raise ClumpFileError(
                f"expected 5 columns 'x y z r clumpId', got {len(data)}: {line.strip()!r}", source, lineno
            )
        try:
            extend((strict_float(data[0]), strict_float(data[1]), strict_float(data[2]), strict_float(data[3])))
        except ValueError:
            k = next(k for k in range(4) if not is_float(data[k]))
            raise ClumpFileError(f"{_COLUMNS[k]} is not a number: {data[k]!r}", source, lineno) from None
        try:
            cid = strict_int(data[4])
        except ValueError:
            del vals[-4:]
            raise ClumpFileError(_id_error(data[4]), source, lineno) from None
        if not -_ID_MAX <= cid <= _ID_MAX:
            del vals[-4:]
            raise ClumpFileError(f"clumpId {data[4]!r} is out of range (|id| < 2**63)", source, lineno)
        add_id(cid)
        add_line(lineno)


def read_text_clumps(path, scale: float = 1.0, shift: Sequence[float] = (0.0, 0.0, 0.0)) -> TextClumps:
    """Read a textClumps file (``path``, or ``"-"`` for standard input); see :func:`parse_text_clumps`.

    Raises ``OSError`` if the file cannot be read and :class:`~clumpprops.io.ClumpFileError` if it is malformed.
    """
    if str(path) == "-":
        return parse_text_clumps(sys.stdin, "<stdin>", scale, shift)
    try:
        with open(path, "r", encoding="utf-8") as f:
            return parse_text_clumps(f, str(path), scale, shift)
    except UnicodeDecodeError as exc:
        raise ClumpFileError(f"not a text file ({exc.reason})", str(path)) from None
