"""The clump record and the file error every reader shares (``clumpprops.io`` and textClumps).

:class:`Clump` is what a reader returns for one clump of a file; :class:`ClumpFileError` is what
it raises for a bad file.  The public names are ``clumpprops.io.Clump`` and
``clumpprops.io.ClumpFileError``; ``clumpprops.textclumps.TextClump`` and
``clumpprops.textclumps.TextClumpsError`` are aliases of the same two classes.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

__all__ = ["Clump", "ClumpFileError"]


class ClumpFileError(ValueError):
    """A bad input file, reported as one line ``FILE:LINE: reason``.

    The message is ``FILE: reason`` where the error is not tied to a line.

    Parameters
    ----------
    reason : str
        What is wrong; runs of whitespace (and line breaks) become one space.
    source : str, optional
        The file's name as the user gave it.
    lineno : int or None, optional
        The 1-based line, or None where the error is not tied to a line.

    Attributes
    ----------
    source : str
        The file's name, as given.
    lineno : int or None
        The 1-based line, or None.
    reason : str
        What is wrong, as given.
    """

    def __init__(self, reason: str, source: str = "<input>", lineno: Optional[int] = None):
        self.source, self.lineno, self.reason = str(source), lineno, reason
        where = f"{source}:{lineno}: " if lineno is not None else f"{source}: "
        super().__init__(where + " ".join(str(reason).split()))


@dataclass(frozen=True, repr=False)
class Clump:
    """One clump of spheres read from a file (or made by hand).

    Parameters
    ----------
    centers : numpy.ndarray, shape (N, 3)
        Sphere centres, m.
    radii : numpy.ndarray, shape (N,)
        Sphere radii, m.
    name : str, optional
        The stem of the names of exported files.
    source : str, optional
        The file the clump came from.
    lines : tuple of int, optional
        The 1-based line of each sphere in `source`, 0 for a sphere not tied to a line;
        empty where the clump is not tied to lines.
    clump_id : int or None, optional
        The file's integer id of the clump (textClumps' ``clumpId``); None where the format
        has none.
    repeated_id : bool, optional
        True if `clump_id` already labelled an earlier, separate clump of the file.

    Notes
    -----
    The record is frozen: its fields do not change once made.  A reader fills `source`,
    `lines` and `clump_id`, so that later errors can name the file and line.
    """

    centers: np.ndarray
    radii: np.ndarray
    name: str = "clump"
    source: str = "<input>"
    lines: tuple = field(default=())
    clump_id: Optional[int] = None
    repeated_id: bool = False

    @property
    def n_spheres(self) -> int:
        """The number of spheres, N."""
        return len(self.radii)

    @property
    def first_line(self) -> int:
        """The line of the first sphere (0 where not tied to a line)."""
        return self.lines[0] if self.lines else 0

    @property
    def last_line(self) -> int:
        """The line of the last sphere (0 where not tied to a line)."""
        return self.lines[-1] if self.lines else 0

    def __repr__(self):
        where = f", lines {self.first_line}-{self.last_line}" if self.lines else ""
        cid = f", clump_id={self.clump_id}" if self.clump_id is not None else ""
        return f"Clump(name={self.name!r}{cid}, n_spheres={self.n_spheres}, source={self.source!r}{where})"
