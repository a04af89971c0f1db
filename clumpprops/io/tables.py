"""The table readers of :mod:`clumpprops.io.readers`: CLUMP/MClump comma tables, LIGGGHTS sphere
files, MClump folders and YADE textClumps, with the line helpers the other readers
(:mod:`clumpprops.io.molecule`, :mod:`clumpprops.io.liggghts_script`) share.

Kept apart from :func:`clumpprops.io.readers.read`, which dispatches to every reader, so that
the readers built on these helpers do not import the dispatcher (no import cycle).
"""
from __future__ import annotations

import contextlib
import gc
import math
from pathlib import Path
from typing import List

import numpy as np

from ._common import Clump, ClumpFileError
from .._numtext import data_line_indices, fast_table, float_columns, is_float, strict_float, strict_int, strip_bom

__all__ = ["read_csv", "read_liggghts", "read_mclump", "read_yade"]

_NAMES = ("x", "y", "z", "r")


def _stem(path) -> str:
    p = Path(path)
    if p.is_dir():
        return p.resolve().name
    if p.name == "Clump.txt":  # <name>/Clump/Clump.txt
        par = p.resolve().parent
        return par.parent.name if par.name == "Clump" else par.name
    return p.stem


def _read_lines(path) -> List[str]:
    """The file's lines (a UTF-8 byte order mark at the start removed)."""
    try:
        with open(path, "r", encoding="utf-8") as f:
            return strip_bom(f.read().splitlines())
    except UnicodeDecodeError as exc:
        raise ClumpFileError(f"not a text file ({exc.reason})", str(path)) from None
    except OSError as exc:
        raise ClumpFileError(f"cannot read: {exc.strerror or exc}", str(path)) from None


def _number(word, what, source, lineno) -> float:
    """A finite number (strict ASCII grammar, :mod:`clumpprops._numtext`) or one ClumpFileError naming the line."""
    try:
        v = strict_float(word)
    except ValueError:
        raise ClumpFileError(f"{what} is not a number: {word!r}", source, lineno) from None
    if not math.isfinite(v):
        raise ClumpFileError(f"{what} is not finite: {word!r}", source, lineno)
    return v


def _sphere(words, source, lineno, names=_NAMES):
    row = [_number(w, name, source, lineno) for name, w in zip(names, words)]
    if row[3] <= 0:
        raise ClumpFileError(f"radius must be > 0, got {words[3]!r}", source, lineno)
    return row


def _make(rows, lines, name, source, scale, nlines=None) -> Clump:
    if len(rows) == 0:
        where = max(1, nlines) if nlines is not None else None
        raise ClumpFileError("end of file and no spheres found (empty clump)", source, where)
    a = np.asarray(rows, dtype=np.float64).reshape(-1, 4) * scale
    return Clump(centers=a[:, :3], radii=a[:, 3], name=name, source=source, lines=tuple(np.asarray(lines).tolist()))


_XYZR = np.dtype([(n, "f8") for n in _NAMES])
_XYZR_TYPE = np.dtype([(n, "f8") for n in _NAMES] + [("type", "i8")])


def _fast_spheres(text, keep, dtype=_XYZR, **table):
    """(rows (n, 4), 1-based line numbers) of the lines ``keep`` parsed at once by numpy, or None
    if any line is refused or holds a non-finite value or a radius <= 0 (the caller's
    line-by-line validator then raises the first error with its line)."""
    rows = fast_table([text[i] for i in keep], dtype, **table)
    if rows is None:
        return None
    a = float_columns(rows, _NAMES)
    if not (np.isfinite(a).all() and (a[:, 3] > 0).all()):
        return None
    return a, np.asarray(keep, dtype=np.int64) + 1


def read_csv(path, scale: float = 1.0) -> List[Clump]:
    """One clump from ``x,y,z,r`` lines; a first row of column names (x,y,z,r) is optional,
    blank lines and lines starting with ``#`` are skipped."""
    src, text = str(path), _read_lines(path)
    keep = data_line_indices(text)
    if keep and [w.strip().lower() for w in text[keep[0]].split(",")] == list(_NAMES):
        keep = keep[1:]
    fast = _fast_spheres(text, keep, delimiter=",")
    rows, lines = fast if fast is not None else _csv_rows(text, src)
    return [_make(rows, lines, _stem(path), src, scale, len(text))]


def _csv_rows(text, src):
    """The line-by-line CSV validator: rows and line numbers, or the first error with its line."""
    rows, lines = [], []
    first = True
    for lineno, line in enumerate(text, 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        words = [w.strip() for w in s.split(",")]
        if first:
            first = False
            if [w.lower() for w in words] == list(_NAMES):
                continue
            if any(_is_name(w) for w in words):
                raise ClumpFileError(f"header must be 'x,y,z,r', got {s!r}", src, lineno)
        if len(words) != 4:
            raise ClumpFileError(f"expected 4 comma-separated columns x,y,z,r, got {len(words)}: {s!r}", src, lineno)
        rows.append(_sphere(words, src, lineno))
        lines.append(lineno)
    return rows, lines


def _is_name(w: str) -> bool:
    return not is_float(w) and w.lower() not in ("nan", "inf", "-inf", "+inf", "infinity") and w[:1].isalpha()


def read_liggghts(path, scale: float = 1.0) -> List[Clump]:
    """One clump from a LIGGGHTS ``particletemplate/multisphere`` sphere file ``x y z r [type]``
    (any name, e.g. ``stone1.test``); a first line ``x y z r`` of column names is skipped."""
    src, text = str(path), _read_lines(path)
    keep = data_line_indices(text)
    if keep and _is_header(text[keep[0]]):
        keep = keep[1:]
    fast = None
    if keep:
        five = len(text[keep[0]].split("#", 1)[0].split()) == 5
        fast = _fast_spheres(text, keep, _XYZR_TYPE if five else _XYZR, comments="#")
    rows, lines = fast if fast is not None else _liggghts_rows(text, src)
    return [_make(rows, lines, _stem(path), src, scale, len(text))]


def _is_header(line: str) -> bool:
    """True for a line of column names ``x y z r`` (whitespace-separated, any case)."""
    return [w.lower() for w in line.split("#", 1)[0].split()] == list(_NAMES)


def _liggghts_rows(text, src):
    """The line-by-line LIGGGHTS validator: rows and line numbers, or the first error with its line."""
    rows, lines = [], []
    first = True
    for lineno, line in enumerate(text, 1):
        words = line.split("#", 1)[0].split()
        if not words:
            continue
        if first:
            first = False
            if _is_header(line):
                continue
        if len(words) not in (4, 5):
            raise ClumpFileError(f"expected 4 columns 'x y z r' (or 5 with an atom type), got {len(words)}: {line.strip()!r}", src, lineno)
        if len(words) == 5:
            try:
                strict_int(words[4])
            except ValueError:
                raise ClumpFileError(f"5th column (atom type) must be an integer, got {words[4]!r}", src, lineno) from None
        rows.append(_sphere(words, src, lineno))
        lines.append(lineno)
    return rows, lines


def read_mclump(path, scale: float = 1.0) -> List[Clump]:
    """One clump from MClump's ``Clump.txt`` (``x,y,z,r`` per line), given the file or its clump folder.

    The folder and ``Clump.txt`` give the spheres as written (MClump's principal frame, what
    MercuryDPM loads); the ``clumpprops.txt`` of a folder that ``clumpprops export --to mclump``
    writes gives them back in the source frame it records (:mod:`clumpprops.io.readback`).
    """
    from .readback import mclump_frame, source_frame

    p, frame = Path(path), None
    if p.name == "clumpprops.txt" and p.is_file():
        frame = mclump_frame(p)
        p = path = p.parent
    if p.is_dir():
        cand = [p / "Clump" / "Clump.txt", p / "Clump.txt"]
        found = [c for c in cand if c.is_file()]
        if not found:
            raise ClumpFileError("folder has no Clump/Clump.txt (MClump layout)", str(path))
        p = found[0]
    src, text = str(p), _read_lines(p)
    fast = _fast_spheres(text, data_line_indices(text, comment=None), delimiter=",")
    rows, lines = fast if fast is not None else _mclump_rows(text, src)
    c = _make(rows, lines, _stem(path), src, 1.0, len(text))
    centers = c.centers if frame is None else source_frame(c.centers, *frame)
    return [Clump(centers * scale, c.radii * scale, c.name, c.source, c.lines)]


def _mclump_rows(text, src):
    """The line-by-line MClump validator: rows and line numbers, or the first error with its line."""
    rows, lines = [], []
    for lineno, line in enumerate(text, 1):
        s = line.strip()
        if not s:
            continue
        words = [w.strip() for w in s.split(",")]
        if len(words) != 4:
            raise ClumpFileError(f"expected 4 comma-separated columns x,y,z,r, got {len(words)}: {s!r}", src, lineno)
        rows.append(_sphere(words, src, lineno))
        lines.append(lineno)
    return rows, lines


def read_yade(path, scale: float = 1.0) -> List[Clump]:
    """All clumps of a YADE ``textClumps`` file (``clumpprops.textclumps`` rules: consecutive
    lines with one clumpId form a clump)."""
    from ..textclumps import read_text_clumps

    try:
        tcs = read_text_clumps(path, scale=scale)
    except ClumpFileError as exc:
        if exc.lineno is None and "no spheres" in exc.reason:  # point at the end of the file, as every reader does
            lineno = max(1, len(_read_lines(path)))
            raise ClumpFileError("end of file and no spheres found (empty clump)", exc.source, lineno) from None
        raise
    except OSError as exc:
        raise ClumpFileError(f"cannot read: {exc.strerror or exc}", str(path)) from None
    with _gc_paused():  # 10**5..10**6 new objects, none in a cycle: the collector would only rescan them
        return _clumps_of(tcs, _stem(path), str(path))


def _clumps_of(tcs, stem, src) -> List[Clump]:
    """One Clump per clump of a parsed textClumps file, named STEM_ID (STEM_ID_lineN for a repeated id)."""
    starts, ids, lines = tcs.starts.tolist(), tcs.ids.tolist(), tcs.lines.tolist()
    repeated = tcs.repeated.tolist()
    out, used = [], set()
    for k, cid in enumerate(ids):
        a, b = starts[k], starts[k + 1]
        name = f"{stem}_{cid}" if len(ids) > 1 else stem
        if name in used:  # an id that comes back after other ids starts a new clump (as in YADE)
            name = f"{name}_line{lines[a]}"
        used.add(name)
        out.append(Clump(tcs.centers[a:b], tcs.radii[a:b], name, src, tuple(lines[a:b]), cid, repeated[k]))
    return out


@contextlib.contextmanager
def _gc_paused():
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()
