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
    """A bad input file, reported as one line ``FILE:LINE: reason`` (``FILE: reason`` if no line).

    Parameters
    ----------
    reason : what is wrong; runs of whitespace (and line breaks) become one space.
    source : the file's name as the user gave it.
    lineno : the 1-based line, or None where the error is not tied to a line.

    Attributes ``source``, ``lineno`` and ``reason`` hold the three.
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
    centers : (N, 3) sphere centres, m.
    radii : (N,) sphere radii, m.
    name : used for the names of exported files.
    source : the file it came from.
    lines : the 1-based line of each sphere in ``source`` (empty, or 0, where not tied to a line).
    clump_id : the file's integer id of the clump (textClumps' ``clumpId``), None where the format has none.
    repeated_id : True if ``clump_id`` already labelled an earlier, separate clump of the file.
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
