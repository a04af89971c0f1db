"""Numbers in text files: one strict grammar for every file reader (textClumps and the
importers of :mod:`clumpprops.io`), and the vectorised parse.

Python's ``float()`` and ``int()`` accept more than a number file should hold: digit
separators (``1_0`` is 10) and any Unicode decimal digit (Arabic-Indic ``١٠``, full-width
``５``).  The readers accept only ASCII numbers:

* a float is ``[+-]`` digits with an optional ``.`` and fraction (or ``.`` and digits), an
  optional exponent ``e[+-]digits``, or ``nan``, ``inf``, ``infinity`` (any case; the
  readers then reject them as not finite with the line number);
* an integer is ``[+-]`` and ASCII digits.

numpy's text reader (``np.loadtxt``, numpy >= 1.23) parses with the same grammar (it
rejects ``1_0``, non-ASCII digits, ``0x10``; tests/test_io_fast.py checks this token by
token), so the fast path reads a whole table in C and the line-by-line validators only run
to word an error with its line.
"""
from __future__ import annotations

import re
import warnings
from typing import List, Optional, Sequence

import numpy as np

__all__ = ["BOM", "data_line_indices", "fast_table", "is_float", "strict_float", "strict_int", "strip_bom"]

BOM = "\ufeff"
_FLOAT = re.compile(r"[+-]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|inf|infinity|nan)", re.IGNORECASE)
_INT = re.compile(r"[+-]?[0-9]+")


def strict_float(word: str) -> float:
    """``float(word)`` for an ASCII number of the grammar above; ValueError otherwise."""
    if _FLOAT.fullmatch(word) is None:
        raise ValueError(f"not a number: {word!r}")
    return float(word)


def strict_int(word: str) -> int:
    """``int(word)`` for ``[+-]`` and ASCII digits; ValueError otherwise."""
    if _INT.fullmatch(word) is None:
        raise ValueError(f"not an integer: {word!r}")
    return int(word)


def is_float(word: str) -> bool:
    return _FLOAT.fullmatch(word) is not None


def strip_bom(lines: List[str]) -> List[str]:
    """The lines with a UTF-8 byte order mark removed from the start of the first one (in place)."""
    if lines and lines[0].startswith(BOM):
        lines[0] = lines[0][len(BOM):]
    return lines


def data_line_indices(lines: Sequence[str], comment: Optional[str] = "#") -> List[int]:
    """0-based indices of the lines that are neither blank nor (after leading blanks) a comment."""
    skip = ("",) if comment is None else ("", comment)
    return [i for i, line in enumerate(lines) if line.lstrip()[:1] not in skip]


def fast_table(lines: Sequence[str], dtype, delimiter: Optional[str] = None, usecols=None,
               comments: Optional[str] = None) -> Optional[np.ndarray]:
    """All ``lines`` parsed at once by numpy's C reader into a 1-D array of ``dtype`` (one row per
    line), or None if numpy refuses any line (a bad word, a wrong column count, an integer written
    as a float, an overflow): the caller's line-by-line validator then finds and words the error."""
    if not lines:
        return np.zeros(0, dtype=dtype)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            rows = np.loadtxt(lines, dtype=dtype, delimiter=delimiter, usecols=usecols, comments=comments, ndmin=1)
    except Exception:  # noqa: BLE001  (any doubt: the line-by-line validator decides, with the line number)
        return None
    return rows if len(rows) == len(lines) else None


def float_columns(rows: np.ndarray, names: Sequence[str]) -> np.ndarray:
    """The named fields of a structured array as one (n, k) float64 array."""
    out = np.empty((len(rows), len(names)))
    for k, name in enumerate(names):
        out[:, k] = rows[name]
    return out
