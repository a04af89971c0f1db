"""Reading back what ``clumpprops export`` writes for DEM-Engine and MClump, in the source frame.

Both exporters store the spheres in the principal frame, ``x_p = A^T (x - com)`` with the
principal axes ``A`` (columns), and record ``com`` and ``A``; these readers invert that,
``x = com + A x_p``, so that ``read(export(read(f)))`` gives the spheres of ``f`` to round-off.

* DEME: the ``STEM_deme.json`` (``relPos``, ``radii``, ``com``, ``principal_axes`` per clump);
* MClump: the clump folder, or its ``clumpprops.txt`` (``com (source frame) ...`` and the
  three rows after ``principal_axes``), with the spheres of ``Clump/Clump.txt``.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import List, Optional, Tuple

import numpy as np

from ._common import Clump, ClumpFileError

__all__ = ["mclump_frame", "read_deme", "source_frame"]


def source_frame(rel, com, axes) -> np.ndarray:
    """Principal-frame positions back in the source frame: ``x = com + A x_p`` (rows of `rel`)."""
    return np.asarray(com, dtype=np.float64) + np.asarray(rel, dtype=np.float64) @ np.asarray(axes, dtype=np.float64).T


def _array(item, key, shape, src, lineno) -> np.ndarray:
    try:
        a = np.asarray(item[key], dtype=np.float64)
    except KeyError:
        raise ClumpFileError(f"clump has no {key!r}", src, lineno) from None
    except (TypeError, ValueError):
        raise ClumpFileError(f"{key!r} is not a list of numbers", src, lineno) from None
    if any(want is not None and want != got for want, got in zip(shape, a.shape)) or a.ndim != len(shape):
        raise ClumpFileError(f"{key!r} has shape {a.shape}, expected {tuple(s or 'N' for s in shape)}", src, lineno)
    if not np.isfinite(a).all():
        raise ClumpFileError(f"{key!r} holds a value that is not finite", src, lineno)
    return a


def _item_lines(text: str) -> List[int]:
    """The 1-based line of each clump entry (the exporter writes one entry per line)."""
    return [k for k, line in enumerate(text.splitlines(), 1) if line.lstrip().startswith('{"name"')]


def read_deme(path, scale: float = 1.0) -> List[Clump]:
    """The clumps of a ``*_deme.json`` that ``clumpprops export --to deme`` writes, in the source frame.

    Parameters
    ----------
    path : str or os.PathLike
        The JSON file.
    scale : float, optional
        Factor on coordinates and radii.

    Returns
    -------
    list of Clump
        One clump per entry of ``clumps``, named as the entry, centres ``com + principal_axes @ relPos``.

    Raises
    ------
    ClumpFileError
        If the file is not JSON, has no ``clumps`` list, or an entry lacks a field or holds a
        value that is not finite (or a radius <= 0); the message names the file and line.
    """
    src = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise ClumpFileError(f"cannot read: {getattr(exc, 'strerror', None) or exc}", src) from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ClumpFileError(f"not JSON: {exc.msg}", src, exc.lineno) from None
    items = doc.get("clumps") if isinstance(doc, dict) else None
    if not isinstance(items, list) or not items:
        raise ClumpFileError("no 'clumps' list (not a DEME file of clumpprops export)", src, 1)
    lines = _item_lines(text)
    out = []
    for k, item in enumerate(items):
        lineno = lines[k] if len(lines) == len(items) else None
        if not isinstance(item, dict):
            raise ClumpFileError(f"clump entry {k + 1} is not an object", src, lineno)
        radii = _array(item, "radii", (None,), src, lineno)
        rel = _array(item, "relPos", (len(radii), 3), src, lineno)
        com = _array(item, "com", (3,), src, lineno)
        axes = _array(item, "principal_axes", (3, 3), src, lineno)
        if len(radii) == 0 or (radii <= 0).any():
            raise ClumpFileError("'radii' must hold at least one radius, each > 0", src, lineno)
        name = str(item.get("name") or f"{Path(path).stem}_{k + 1}")
        out.append(Clump(source_frame(rel, com, axes) * scale, radii * scale, name, src,
                         tuple([lineno] * len(radii)) if lineno else ()))
    return out


def mclump_frame(path) -> Optional[Tuple[np.ndarray, np.ndarray]]:
    """(com, principal axes) recorded in the ``clumpprops.txt`` of an MClump export, None if absent.

    Parameters
    ----------
    path : str or os.PathLike
        The ``clumpprops.txt`` file.

    Returns
    -------
    tuple of numpy.ndarray or None
        ``com`` (3,) and the axes (3, 3, columns) in m, or None if the file does not exist.

    Raises
    ------
    ClumpFileError
        If the file exists but its ``com`` or ``principal_axes`` lines are missing or bad.
    """
    p = Path(path)
    if not p.is_file():
        return None
    src = str(p)
    text = p.read_text(encoding="utf-8", errors="replace").splitlines()
    com = axes = None
    for k, line in enumerate(text):
        if line.startswith("com (source frame)"):
            com = _numbers(line.split(")", 1)[1].split()[:3], src, k + 1)
        elif line.startswith("principal_axes"):
            axes = np.array([_numbers(text[k + 1 + i].split(), src, k + 2 + i) if k + 1 + i < len(text)
                             else _numbers([], src, k + 1) for i in range(3)])
    if com is None or axes is None:
        raise ClumpFileError("no 'com (source frame)' and 'principal_axes' lines (not an MClump export of clumpprops)",
                             src, max(1, len(text)))
    return com, axes


def _numbers(words, src, lineno) -> np.ndarray:
    try:
        v = [float(w) for w in words]
    except ValueError:
        v = []
    if len(v) != 3 or not all(math.isfinite(x) for x in v):
        raise ClumpFileError(f"expected 3 numbers, got {' '.join(words)!r}", src, lineno)
    return np.array(v)
