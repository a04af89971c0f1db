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
  :attr:`TextClump.repeated_id` flags that case so callers can warn;
* words after the fifth are ignored, as YADE ignores them (so a trailing
  ``# comment`` is allowed).

Differences from YADE, all stricter or friendlier, never a different grouping:
blank lines are skipped (YADE stops with an IndexError); a short line, a word
that is not a number, a non-finite value, a radius <= 0 or a non-integer
``clumpId`` raise :class:`TextClumpsError` with the line number (YADE raises a bare
``ValueError`` or silently builds a broken clump).  ``clumpId`` is parsed with
Python's ``int()`` exactly as YADE does, so ``3.0`` or ``1.23457e+06`` are
rejected (``export.textClumps`` writes ids with ``%g``, which turns ids >= 10**6
into such strings and can merge neighbouring clumps: renumber them first).

``scale`` and ``shift`` behave as in ``ymport.textClumps``: position
``shift + scale * (x, y, z)``, radius ``scale * r``.
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from typing import Iterable, List, Optional, Sequence

import numpy as np

__all__ = ["TextClump", "TextClumpsError", "parse_text_clumps", "read_text_clumps"]


class TextClumpsError(ValueError):
    """A malformed line in a textClumps file; ``lineno`` is 1-based (None if not tied to a line)."""

    def __init__(self, message: str, source: str = "<text>", lineno: Optional[int] = None):
        self.source = source
        self.lineno = lineno
        self.reason = message
        where = f"{source}:{lineno}: " if lineno is not None else f"{source}: "
        super().__init__(where + message)


@dataclass(frozen=True)
class TextClump:
    """One clump read from the file.

    ``clump_id`` the file's integer id; ``centers`` (N, 3) m and ``radii`` (N,) m after
    ``scale``/``shift``; ``lines`` (N,) the 1-based line number of each sphere;
    ``repeated_id`` True if the same id already labelled an earlier, separate clump.
    """

    clump_id: int
    centers: np.ndarray
    radii: np.ndarray
    lines: tuple
    repeated_id: bool = False

    @property
    def n_spheres(self) -> int:
        return len(self.radii)


_COLUMNS = ("x", "y", "z", "r")


def parse_text_clumps(
    lines: Iterable[str],
    source: str = "<text>",
    scale: float = 1.0,
    shift: Sequence[float] = (0.0, 0.0, 0.0),
) -> List[TextClump]:
    """Parse textClumps lines (see the module docstring) into a list of :class:`TextClump`.

    ``source`` names the input in error messages.  Raises :class:`TextClumpsError`
    for malformed lines and for input without any sphere.
    """
    scale = float(scale)
    if not math.isfinite(scale) or scale <= 0:
        raise TextClumpsError(f"scale must be a positive finite number, got {scale!r}", source)
    shift = np.asarray(shift, dtype=np.float64)
    if shift.shape != (3,) or not np.all(np.isfinite(shift)):
        raise TextClumpsError(f"shift must be 3 finite numbers, got {shift.tolist()!r}", source)

    clumps: List[TextClump] = []
    seen = set()
    cur_id = None
    cur_rows: list = []
    cur_lines: list = []

    def flush():
        if cur_rows:
            a = np.array(cur_rows, dtype=np.float64)
            clumps.append(
                TextClump(
                    clump_id=cur_id,
                    centers=shift + scale * a[:, :3],
                    radii=scale * a[:, 3],
                    lines=tuple(cur_lines),
                    repeated_id=cur_id in seen,
                )
            )
            seen.add(cur_id)

    for lineno, line in enumerate(lines, start=1):
        data = line.split()
        if not data or data[0][0] == "#":
            continue
        if len(data) < 5:
            raise TextClumpsError(
                f"expected 5 columns 'x y z r clumpId', got {len(data)}: {line.strip()!r}", source, lineno
            )
        row = []
        for name, word in zip(_COLUMNS, data[:4]):
            try:
                v = float(word)
            except ValueError:
                raise TextClumpsError(f"{name} is not a number: {word!r}", source, lineno) from None
            if not math.isfinite(v):
                raise TextClumpsError(f"{name} is not finite: {word!r}", source, lineno)
            row.append(v)
        if row[3] <= 0:
            raise TextClumpsError(f"radius must be > 0 (m), got {data[3]!r}", source, lineno)
        try:
            cid = int(data[4])
        except ValueError:
            raise TextClumpsError(f"clumpId must be an integer, got {data[4]!r}", source, lineno) from None
        if cid != cur_id:
            flush()
            cur_id, cur_rows, cur_lines = cid, [], []
        cur_rows.append(row)
        cur_lines.append(lineno)
    flush()
    if not clumps:
        raise TextClumpsError("no spheres found (expected lines 'x y z r clumpId')", source)
    return clumps


def read_text_clumps(path, scale: float = 1.0, shift: Sequence[float] = (0.0, 0.0, 0.0)) -> List[TextClump]:
    """Read a textClumps file (``path``, or ``"-"`` for standard input); see :func:`parse_text_clumps`.

    Raises ``OSError`` if the file cannot be read and :class:`TextClumpsError` if it is malformed.
    """
    if str(path) == "-":
        return parse_text_clumps(sys.stdin, "<stdin>", scale, shift)
    try:
        with open(path, "r", encoding="utf-8") as f:
            return parse_text_clumps(f, str(path), scale, shift)
    except UnicodeDecodeError as exc:
        raise TextClumpsError(f"not a text file ({exc.reason})", str(path)) from None
