"""``clumpprops show FILE -o FILE.png``: a picture of a clump with its principal axes.

    clumpprops show FILE -o OUT.png [--clump N] [--size PX] [--from FMT] [--diameter D] [--scale S] [--force]

Draws the clump's spheres, shaded, and its principal axes as arrows from the centre of mass
along the positive axis directions, each as long as the union reaches along it and labelled
with its principal moment (density 1000 kg/m^3 unless ``--density``).  Drawn with matplotlib's
Agg backend (``pip install clumpprops[plot]``).  Never writes over an existing file without
``--force``.  Errors are one line, exit status 1; bad options exit with status 2.
"""
from __future__ import annotations

import argparse
import os
import sys
from dataclasses import dataclass
from typing import List, Optional, Sequence

import numpy as np

from ._argtypes import _positive_float, add_input_options
from .mesh import principal_extents

PROG = "clumpprops show"
__all__ = ["Arrow", "principal_arrows", "draw", "main"]


@dataclass(frozen=True)
class Arrow:
    """One principal axis as drawn: from the centre of mass to the union's edge along the axis.

    Attributes
    ----------
    start : ndarray (3,)
        The centre of mass, m.
    end : ndarray (3,)
        ``start + reach * direction``, m.
    direction : ndarray (3,)
        The principal axis, a unit vector.
    moment : float
        Its principal moment, kg m^2.
    label : str
        The text drawn at the arrow's tip.
    """

    start: np.ndarray
    end: np.ndarray
    direction: np.ndarray
    moment: float
    label: str


def principal_arrows(centers, radii, mp) -> List[Arrow]:
    """The three principal axes of a clump as arrows from its centre of mass.

    Parameters
    ----------
    centers : array_like, shape (N, 3)
        Sphere centres, m.
    radii : array_like, shape (N,)
        Sphere radii, m.
    mp : clumpprops.MassProperties
        The clump's mass properties (one clump).

    Returns
    -------
    list of Arrow
        One per principal axis, in ascending order of the principal moment; each reaches from
        the centre of mass to the union's largest coordinate along the axis.
    """
    com = np.asarray(mp.center_of_mass, dtype=np.float64)
    axes = np.asarray(mp.principal_axes, dtype=np.float64)
    moments = np.asarray(mp.principal_moments, dtype=np.float64)
    _, hi = principal_extents(centers, radii, com, axes)
    return [Arrow(com, com + hi[k] * axes[:, k], axes[:, k].copy(), float(moments[k]),
                  f"I{k + 1} = {moments[k]:.4g} kg m²") for k in range(3)]


def _sphere_surfaces(ax, centers, radii, resolution=20):
    """Draw each sphere as a shaded surface on the 3-D axes `ax`."""
    u = np.linspace(0.0, 2.0 * np.pi, 2 * resolution)
    v = np.linspace(0.0, np.pi, resolution)
    x, y, z = np.outer(np.cos(u), np.sin(v)), np.outer(np.sin(u), np.sin(v)), np.outer(np.ones_like(u), np.cos(v))
    for c, r in zip(centers, radii):
        ax.plot_surface(c[0] + r * x, c[1] + r * y, c[2] + r * z, color="lightsteelblue", shade=True,
                        linewidth=0, antialiased=False, alpha=0.35)


#: The axes are drawn this many times their reach inside the union (:func:`principal_arrows`).
OUTSIDE = 1.6


def draw(centers, radii, mp, path, size: int = 800, title: str = "") -> None:
    """Draw a clump's spheres and principal axes into a PNG file of `size` x `size` pixels.

    Parameters
    ----------
    centers : array_like, shape (N, 3)
        Sphere centres, m.
    radii : array_like, shape (N,)
        Sphere radii, m.
    mp : clumpprops.MassProperties
        The clump's mass properties.
    path : str or os.PathLike
        The PNG file to write (replaced if it exists: the command line checks first).
    size : int, optional
        Width and height of the image in pixels.
    title : str, optional
        A title above the picture.

    Raises
    ------
    ImportError
        If matplotlib is missing (``pip install clumpprops[plot]``).
    """
    try:
        from matplotlib.figure import Figure
        from matplotlib.backends.backend_agg import FigureCanvasAgg
    except ImportError:
        raise ImportError("show needs matplotlib: pip install clumpprops[plot]") from None
    c = np.asarray(centers, dtype=np.float64).reshape(-1, 3)
    r = np.asarray(radii, dtype=np.float64).reshape(-1)
    fig = Figure(figsize=(size / 100.0, size / 100.0), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d")
    ax.computed_zorder = False   # drawn in the order added: the axes over the spheres
    _sphere_surfaces(ax, c, r)
    arrows = principal_arrows(c, r, mp)
    for arrow, colour in zip(arrows, ("tab:red", "tab:green", "tab:blue")):
        d = OUTSIDE * (arrow.end - arrow.start)   # past the surface, so that the tip shows
        ax.quiver(*arrow.start, *d, color=colour, linewidth=2.5, arrow_length_ratio=0.12)
        ax.text(*(arrow.start + 1.05 * d), arrow.label, color=colour, fontsize=10)
    ax.scatter(*arrows[0].start, color="black", s=25)
    tips = np.array([a.start + OUTSIDE * (a.end - a.start) for a in arrows])
    lo = np.minimum((c - r[:, None]).min(axis=0), tips.min(axis=0))
    hi = np.maximum((c + r[:, None]).max(axis=0), tips.max(axis=0))
    mid, half = (lo + hi) / 2.0, 0.6 * float((hi - lo).max())
    ax.set(xlim=(mid[0] - half, mid[0] + half), ylim=(mid[1] - half, mid[1] + half),
           zlim=(mid[2] - half, mid[2] + half), xlabel="x (m)", ylabel="y (m)", zlabel="z (m)")
    ax.set_box_aspect((1, 1, 1))
    if title:
        ax.set_title(title)
    fig.savefig(path, format="png", dpi=100)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line, status 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``clumpprops show``.

    Returns
    -------
    argparse.ArgumentParser
        Its options are the module docstring's.
    """
    from .io import FORMATS

    p = _Parser(prog=PROG, description="Draw one clump of FILE (any format `clumpprops export` reads) with its "
                "principal axes as arrows from the centre of mass, labelled with the principal moments, into a PNG "
                "file. Never writes over an existing file without --force.")
    p.add_argument("file", metavar="FILE")
    p.add_argument("-o", "--output", required=True, metavar="OUT.png", help="the PNG file to write")
    p.add_argument("--clump", type=int, default=0, metavar="N", help="which clump of FILE, from 0 (default: 0)")
    p.add_argument("--size", type=int, default=800, metavar="PX", help="image width and height in pixels (default: 800)")
    p.add_argument("--density", type=_positive_float, default=1000.0, metavar="RHO",
                   help="density in kg/m^3 for the moments in the labels (default: 1000)")
    p.add_argument("--scale", type=_positive_float, default=1.0, metavar="S", help="multiply lengths by S")
    add_input_options(p, FORMATS)
    p.add_argument("--force", action="store_true", help="replace OUT.png if it exists")
    return p


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run ``clumpprops show``; see the module docstring.

    Parameters
    ----------
    argv : sequence of str or None, optional
        The arguments after ``show``; None for ``sys.argv[2:]``.

    Returns
    -------
    int
        0 on success, 1 on an error (printed as one line on stderr).
    """
    from . import mass_properties
    from .io import ClumpFileError, read

    parser = build_parser()
    args = parser.parse_args(sys.argv[2:] if argv is None else argv)
    if not 16 <= args.size <= 10000:
        parser.error(f"--size must be between 16 and 10000 pixels, got {args.size}")
    if os.path.exists(args.output) and not args.force:
        return _fail(f"{args.output}: exists; nothing written (--force replaces it)")
    try:
        clumps = read(args.file, args.fmt, scale=args.scale, diameter=args.diameter)
        if not 0 <= args.clump < len(clumps):
            return _fail(f"{args.file}: --clump {args.clump} out of range: the file holds {len(clumps)} clump(s)")
        c = clumps[args.clump]
        mp = mass_properties(c.centers, c.radii, density=args.density)
        draw(c.centers, c.radii, mp, args.output, args.size, title=f"{c.name}: {c.n_spheres} spheres")
    except (ClumpFileError, ImportError) as exc:
        return _fail(str(exc))
    except ValueError as exc:
        return _fail(f"{args.file}: {exc}")
    except OSError as exc:
        return _fail(f"cannot write {args.output}: {exc.strerror or exc}")
    print(args.output)
    return 0


def _fail(message: str) -> int:
    print("clumpprops: error: " + " ".join(str(message).split()), file=sys.stderr)
    return 1
