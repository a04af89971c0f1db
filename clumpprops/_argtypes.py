"""Argument types of the command lines (``clumpprops``, ``clumpprops export``): each turns one
string into a number or raises :class:`argparse.ArgumentTypeError` with a one-line reason, so
argparse prints it as a usage error.  Kept apart so the two command lines share them without
importing each other."""
from __future__ import annotations

import argparse
import math


def _positive_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive finite number, got {text!r}")
    return v


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if v <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return v


def _int(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None


def add_input_options(parser: argparse.ArgumentParser, formats) -> None:
    """Add the input options every command that reads a clump file shares: ``--from FMT`` (the
    format, detected from the file's content by default) and ``--diameter D`` (LAMMPS molecule
    files without a ``Diameters`` section)."""
    parser.add_argument("--from", dest="fmt", choices=formats, metavar="FMT",
                        help=f"input format, one of {', '.join(formats)} (default: detected from the content)")
    parser.add_argument("--diameter", type=_positive_float, metavar="D",
                        help="LAMMPS molecule file without a Diameters section: every atom's diameter, in the "
                        "file's length units")
