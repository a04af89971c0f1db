"""Command-line tool: mass properties of the sphere clumps in a file of any format :func:`clumpprops.io.read` reads.

Usage (see ``docs/cli.md``)::

    python -m clumpprops FILE [--method M] [--density RHO] [--format table|csv|json]
                              [--samples N] [--seed S] [--discretization K] [--scale F]
                              [--shape] [--from FMT] [--diameter D]

FILE's format is detected from its content (:mod:`clumpprops.io.detect`: YADE textClumps,
CLUMP/MClump ``x,y,z,r`` tables, LIGGGHTS sphere files and input scripts, LAMMPS molecule
files, the DEME JSON and MClump folders ``clumpprops export`` writes), or named with
``--from FMT``; ``-`` reads textClumps (:mod:`clumpprops.textclumps`) from standard input.
For every clump of FILE it prints the number
of spheres, mass (kg), volume (m^3), centre of mass (m), ascending principal moments
of inertia (kg m^2) and the overlap correction: how much the summed-sphere mass
(YADE's default clump, LAMMPS ``fix rigid``) overestimates the method's mass, in %,
i.e. ``100 (m_sum / m - 1)`` (the paper's eq. 4 against the plain sum of spheres).
``--format json`` adds the full inertia tensor and principal axes.

All quantities are SI.  The density defaults to 1000 kg/m^3, the default density
of a YADE material (``FrictMat().density``), so that the masses match what
``ymport.textClumps`` would build with default materials; pass the real density.

Errors (unreadable file, malformed line, geometry the method cannot handle) print
one line ``clumpprops: error: ...`` on stderr and exit with status 1; bad
command-line options exit with status 2.
"""
from __future__ import annotations

import argparse
import csv
import io
import json
import sys
import textwrap
from typing import Optional, Sequence

import numpy as np

from . import DEFAULT_METHOD, METHODS, ClumpGeometryError, __version__, mass_properties
from ._argtypes import _int, _positive_float, _positive_int, add_input_options
from ._clumps import Clump, ClumpFileError
from .io.detect import FORMATS
from .textclumps import read_text_clumps

DEFAULT_DENSITY = 1000.0  # kg/m^3, YADE's default material density

PROG = "clumpprops"
MAX_WARNINGS = 5  # repeated-id warnings printed before a count


#: The subcommands of ``clumpprops``: name -> (module with ``main(argv)``, one line for ``--help``).
SUBCOMMANDS = {
    "export": ("clumpprops.io.cli", "write the files LIGGGHTS, LAMMPS, DEM-Engine, MercuryDPM or YADE read, "
               "with the exact values"),
    "show": ("clumpprops.show", "draw a clump with its principal axes into a PNG file"),
    "audit": ("clumpprops.audit.cli", "compare each engine's own mass properties (sums, voxels, Monte Carlo, stated "
              "values) with the exact ones; samples or voxels needed for a tolerance"),
    "fit": ("clumpprops.fit", "fit a clump of N spheres to a closed triangle mesh (STL, OBJ, ...); writes 'x y z r', "
            "prints its exact properties against the mesh's"),
}


class CLIError(Exception):
    """A user-facing error: printed as one line, exit status 1."""


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=PROG,
        description=textwrap.fill(
            "Mass, volume, centre of mass and principal moments of inertia of the sphere clumps "
            "in a clump file: YADE textClumps (lines 'x y z r clumpId', '#' comments), CLUMP/MClump "
            "'x,y,z,r' tables, LIGGGHTS sphere files and input scripts, LAMMPS molecule files, "
            "the DEME and MClump files 'clumpprops export' writes; the format is detected from "
            "the content (--from names it). SI units: "
            "lengths in m, density in kg/m^3, mass in kg, inertia in kg m^2."
        ),
        epilog=textwrap.fill(
            "The overlap column is 100*(m_sum/m - 1): how much summing the member spheres "
            "(YADE's default clump) overestimates the mass. Exit status: 0 ok, 1 error in the "
            "input or geometry, 2 bad options."
        ) + "\n\nsubcommands ('clumpprops NAME --help' says what each reads and writes):\n" + "\n".join(
            textwrap.fill(text, initial_indent=f"  {name:<9}", subsequent_indent=" " * 11)
            for name, (_, text) in SUBCOMMANDS.items()),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("file", metavar="FILE", help="clump file (any format of --from), or '-' for a textClumps "
                   "file on standard input")
    add_input_options(p, FORMATS)
    p.add_argument(
        "--method",
        choices=METHODS,
        default=DEFAULT_METHOD,
        help=f"how overlaps are handled (default: {DEFAULT_METHOD}): exact = exact union of the spheres; "
        "pairwise = the paper's eqs. 1-7 (fails on triple overlaps); sum = overlaps counted twice; "
        "montecarlo / voxel = sampled estimates",
    )
    p.add_argument(
        "--density",
        type=_positive_float,
        default=DEFAULT_DENSITY,
        metavar="RHO",
        help=f"solid density in kg/m^3 (default: {DEFAULT_DENSITY:g}, YADE's default material density)",
    )
    p.add_argument("--format", choices=("table", "csv", "json"), default="table", help="output format (default: table)")
    p.add_argument("--samples", type=_positive_int, metavar="N", help="montecarlo: number of sample points (default: the library's, 10**6)")
    p.add_argument("--seed", type=_int, metavar="S", help="montecarlo: random seed (default: nondeterministic)")
    p.add_argument("--discretization", type=_positive_int, metavar="K", help="voxel: cells along the shortest AABB side")
    p.add_argument(
        "--scale",
        type=_positive_float,
        default=1.0,
        metavar="F",
        help="multiply coordinates and radii by F (as ymport.textClumps(scale=F)), e.g. 0.001 for files in mm",
    )
    p.add_argument("--shape", action="store_true",
                   help="add the exact shape descriptors of each union: surface area, volume-equivalent diameter, "
                   "sphericity, kappa = 4I/(m d_v^2), principal extents, Zingg ratios, bounding sphere (docs/shape.md)")
    p.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    return p


def _method_options(args, parser) -> dict:
    opts = {}
    if args.samples is not None or args.seed is not None:
        if args.method != "montecarlo":
            parser.error("--samples/--seed apply only to --method montecarlo")
        if args.samples is not None:
            opts["n_samples"] = args.samples
        if args.seed is not None:
            opts["seed"] = args.seed
    if args.discretization is not None:
        if args.method != "voxel":
            parser.error("--discretization applies only to --method voxel")
        opts["discretization"] = args.discretization
    return opts


def _label(clump: Clump):
    """The clump's id in the output: textClumps' clumpId, else the clump's name."""
    return clump.clump_id if clump.clump_id is not None else clump.name


def _describe(clump: Clump) -> str:
    lo, hi = clump.first_line, clump.last_line
    where = f"line {lo}" if lo == hi else f"lines {lo}-{hi}"
    what = f"clump id {clump.clump_id}" if clump.clump_id is not None else f"clump {clump.name}"
    return f"{what} ({where})"


def compute(clumps: Sequence[Clump], method: str, density: float, options: dict):
    """Library results for the method and for the summed spheres, as batches over the clumps.

    The library's documented errors become :class:`CLIError` (one line, exit status 1):
    ``ClumpGeometryError`` (a method that cannot handle the geometry; the clump and its lines
    are named) and ``ValueError`` for input it rejects (e.g. moments that overflow float64).
    Anything else is a bug and propagates with its traceback.
    """
    centers = [c.centers for c in clumps]
    radii = [c.radii for c in clumps]
    try:
        mp = mass_properties(centers, radii, density=density, method=method, **options)
    except ClumpGeometryError as exc:
        # find the offending clump to point at the file's lines
        for c in clumps:
            try:
                mass_properties(c.centers, c.radii, density=density, method=method, **options)
            except ClumpGeometryError as one:
                raise CLIError(f"{_describe(c)}: {one}") from None
        raise CLIError(str(exc)) from None
    except ValueError as exc:  # the library's documented input error
        raise CLIError(str(exc)) from None
    try:
        summed = mass_properties(centers, radii, density=density, method="sum")
    except ValueError as exc:
        raise CLIError(str(exc)) from None
    return mp, summed


def _rows(clumps, mp, summed, shape=None):
    for i, c in enumerate(clumps):
        m = float(mp.mass[i])
        row = {
            "id": _label(c),
            "n_spheres": c.n_spheres,
            "mass": m,
            "volume": float(mp.volume[i]),
            "com": [float(x) for x in mp.center_of_mass[i]],
            "principal_moments": [float(x) for x in mp.principal_moments[i]],
            "overlap_percent": 100.0 * (float(summed.mass[i]) / m - 1.0),
        }
        if mp.standard_error is not None:
            row["mass_standard_error"] = float(mp.standard_error.mass[i])
        if shape is not None:
            row["shape"] = shape[i].to_dict()
        yield i, row


def _zero_noise(com, clump: Clump, rel=1e-13):
    """COM components below rel * (clump size) are round-off: shown as 0 in the table (csv/json keep them)."""
    size = float(np.max(np.linalg.norm(clump.centers - np.asarray(com), axis=1) + clump.radii))
    return [0.0 if abs(x) <= rel * size else x for x in com]


def format_table(clumps, mp, summed, args) -> str:
    out = io.StringIO()
    out.write(
        f"# clumpprops {__version__}: {args.file}, {len(clumps)} clump(s), method={mp.method}, "
        f"density={args.density:g} kg/m^3"
        + (f", scale={args.scale:g}" if args.scale != 1.0 else "")
        + "\n"
    )
    out.write("# SI units: mass kg, volume m^3, COM m, principal moments kg m^2 (ascending);\n")
    out.write("# overlap % = 100*(m_sum/m - 1), the mass excess of summing the member spheres\n")
    sampled = mp.standard_error is not None
    head = ["id", "n", "mass", "volume", "com_x", "com_y", "com_z", "I_1", "I_2", "I_3", "overlap_%"]
    if sampled:
        head.insert(3, "mass_se")
    rows = [head]
    for i, r in _rows(clumps, mp, summed):
        cells = [str(r["id"]), str(r["n_spheres"]), f"{r['mass']:.6g}", f"{r['volume']:.6g}"]
        cells += [f"{x:.6g}" for x in _zero_noise(r["com"], clumps[i])]
        cells += [f"{x:.6g}" for x in r["principal_moments"]]
        cells.append(f"{r['overlap_percent']:.3f}")
        if sampled:
            cells.insert(3, f"{r['mass_standard_error']:.2g}")
        rows.append(cells)
    _write_columns(out, rows)
    if getattr(args, "shape_descriptors", None) is not None:
        _write_shape_table(out, clumps, args.shape_descriptors)
    return out.getvalue()


def _write_columns(out, rows):
    widths = [max(len(row[k]) for row in rows) for k in range(len(rows[0]))]
    for j, row in enumerate(rows):
        line = "  ".join(cell.rjust(w) for cell, w in zip(row, widths))
        out.write(("#" + line[1:] if j == 0 and line.startswith(" ") else line) + "\n")


_SHAPE_HEAD = ["id", "area", "d_v", "sphericity", "kappa_1", "kappa_2", "kappa_3", "elongation", "flatness", "R_bound"]


def _write_shape_table(out, clumps, shape):
    """The shape descriptors as a second table (SI: area m^2, d_v and R_bound m; the rest dimensionless)."""
    out.write("# shape: area m^2, d_v = (6V/pi)^(1/3) m, sphericity pi^(1/3)(6V)^(2/3)/A, "
              "kappa_k = 4 I_k/(m d_v^2), Zingg elongation I/L and flatness S/I, bounding-sphere radius m\n")
    rows = [_SHAPE_HEAD]
    for i, c in enumerate(clumps):
        d = shape[i]
        rows.append([str(_label(c))] + [f"{x:.6g}" for x in (d.surface_area, d.diameter, d.sphericity, *d.kappa,
                                                               d.elongation, d.flatness, d.bounding_radius)])
    _write_columns(out, rows)


def _shape_csv_cells(d):
    """(header, cells) of one clump's shape descriptors for the csv format."""
    head = ["surface_area_m2", "d_v_m", "sphericity", "kappa_1", "kappa_2", "kappa_3", "kappa_bounding_1",
            "kappa_bounding_2", "kappa_bounding_3", "extent_1_m", "extent_2_m", "extent_3_m", "elongation",
            "flatness", "bounding_x_m", "bounding_y_m", "bounding_z_m", "bounding_radius_m"]
    values = [d.surface_area, d.diameter, d.sphericity, *d.kappa, *d.kappa_bounding, *d.extents, d.elongation,
              d.flatness, *d.bounding_center, d.bounding_radius]
    return head, [repr(float(v)) for v in values]


def format_csv(clumps, mp, summed, args) -> str:
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    sampled = mp.standard_error is not None
    head = ["id", "n_spheres", "mass_kg", "volume_m3", "com_x_m", "com_y_m", "com_z_m", "I1_kgm2", "I2_kgm2", "I3_kgm2", "overlap_percent"]
    if sampled:
        head.append("mass_standard_error_kg")
    shape = getattr(args, "shape_descriptors", None)
    if shape is not None:
        head += _shape_csv_cells(shape[0])[0]
    w.writerow(head)
    for i, r in _rows(clumps, mp, summed):
        cells = [r["id"], r["n_spheres"], repr(r["mass"]), repr(r["volume"])]
        cells += [repr(x) for x in r["com"]] + [repr(x) for x in r["principal_moments"]]
        cells.append(repr(r["overlap_percent"]))
        if sampled:
            cells.append(repr(r["mass_standard_error"]))
        if shape is not None:
            cells += _shape_csv_cells(shape[i])[1]
        w.writerow(cells)
    return out.getvalue()


def format_json(clumps, mp, summed, args) -> str:
    items = []
    for i, r in _rows(clumps, mp, summed, getattr(args, "shape_descriptors", None)):
        r["first_line"], r["last_line"] = clumps[i].first_line, clumps[i].last_line
        r["inertia"] = np.asarray(mp.inertia[i]).tolist()
        r["principal_axes"] = np.asarray(mp.principal_axes[i]).tolist()
        r["mass_sum_of_spheres"] = float(summed.mass[i])
        items.append(r)
    doc = {
        "file": args.file,
        "method": mp.method,
        "density": args.density,
        "scale": args.scale,
        "units": {
            "mass": "kg",
            "volume": "m^3",
            "com": "m",
            "principal_moments": "kg m^2",
            "inertia": "kg m^2 (about the COM, file axes)",
            "principal_axes": "columns are unit axes, right-handed",
            "overlap_percent": "100*(m_sum/m - 1)",
            "shape": "--shape: areas m^2, lengths m (extents along the principal axes, from the COM), "
                     "the rest dimensionless; docs/shape.md",
        },
        "clumps": items,
    }
    return json.dumps(doc, indent=2) + "\n"


FORMATTERS = {"table": format_table, "csv": format_csv, "json": format_json}


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of ``python -m clumpprops`` and the ``clumpprops`` console script; returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] and argv[0] in SUBCOMMANDS:  # clumpprops NAME ...: the subcommand's own main
        from importlib import import_module

        try:
            status = import_module(SUBCOMMANDS[argv[0]][0]).main(argv[1:])
            sys.stdout.flush()      # here, not at exit, so that a closed pipe is caught below
            return status
        except BrokenPipeError:  # its output piped into head
            sys.stdout = None
            return 0
    parser = build_parser()
    args = parser.parse_args(argv)
    options = _method_options(args, parser)
    try:
        clumps = read_clumps(args.file, args.fmt, args.scale, args.diameter)
    except CLIError as exc:
        return _fail(str(exc))
    except OSError as exc:
        return _fail(f"cannot read {args.file}: {exc.strerror or exc}")
    repeated = np.flatnonzero([c.repeated_id for c in clumps] if isinstance(clumps, list) else clumps.repeated)
    for k in repeated[:MAX_WARNINGS]:
        c = clumps[int(k)]
        print(
            f"{PROG}: warning: {args.file}:{c.first_line}: clump id {c.clump_id} appears again after "
            "other clumps; like YADE's ymport.textClumps this starts a new clump",
            file=sys.stderr,
        )
    if len(repeated) > MAX_WARNINGS:
        print(f"{PROG}: warning: ... and {len(repeated) - MAX_WARNINGS} more clump ids that appear again", file=sys.stderr)
    try:
        mp, summed = compute(clumps, args.method, args.density, options)
        args.shape_descriptors = _shape(clumps) if args.shape else None
    except CLIError as exc:
        return _fail(str(exc))
    # no except around the formatting: an exception there is a bug and shows its traceback
    text = FORMATTERS[args.format](clumps, mp, summed, args)
    try:
        sys.stdout.write(text)
        sys.stdout.flush()
    except BrokenPipeError:  # e.g. piped into head
        try:
            sys.stdout = None  # silence the flush at interpreter exit
        finally:
            return 0
    return 0


def _input_format(path: str, fmt: Optional[str]) -> str:
    """The format FILE is read as: ``--from``, else detected; textClumps for '-' and where nothing is detected."""
    if path == "-":
        if fmt not in (None, "yade"):
            raise CLIError(f"standard input ('-') is read as textClumps only, not as --from {fmt}")
        return "yade"
    if fmt is not None:
        return fmt
    from .io import detect_format

    try:
        return detect_format(path)
    except ClumpFileError:  # no format shown: textClumps, whose reader names what is wrong
        return "yade"


def read_clumps(path: str, fmt: Optional[str] = None, scale: float = 1.0, diameter: Optional[float] = None):
    """The clumps of FILE as the main command reads them.

    Parameters
    ----------
    path : str
        The file, or '-' for a textClumps file on standard input.
    fmt : str or None, optional
        One of :data:`clumpprops.io.FORMATS`; None to detect it from the content.
    scale : float, optional
        Factor on coordinates and radii.
    diameter : float or None, optional
        Every atom's diameter for a LAMMPS molecule file without ``Diameters``.

    Returns
    -------
    clumpprops.textclumps.TextClumps or list of Clump
        The parsed textClumps file, or the clumps :func:`clumpprops.io.read` returns.

    Raises
    ------
    CLIError
        One line ``FILE:LINE: as FORMAT: reason`` for a file the format's reader refuses, or
        for ``--diameter`` with a format other than ``lammps``.
    OSError
        If a textClumps file cannot be read.
    """
    fmt = _input_format(path, fmt)
    if diameter is not None and fmt != "lammps":
        raise CLIError(f"{path}: as {fmt}: --diameter applies only to LAMMPS molecule files (--from lammps)")
    try:
        if fmt == "yade":
            return read_text_clumps(path, scale=scale)
        from .io import read

        return read(path, fmt, scale=scale, diameter=diameter)
    except ClumpFileError as exc:  # names the file, the line and the format tried
        where = f"{exc.source}:{exc.lineno}: " if exc.lineno is not None else f"{exc.source}: "
        raise CLIError(f"{where}as {fmt}: {exc.reason}") from None


def _shape(clumps):
    """The exact shape descriptors of the clumps (a batch); library input errors become CLIError."""
    from .shape import shape_descriptors

    try:
        return shape_descriptors([c.centers for c in clumps], [c.radii for c in clumps])
    except ValueError as exc:
        raise CLIError(str(exc)) from None


def _fail(message: str) -> int:
    message = " ".join(str(message).split())  # one line
    print(f"{PROG}: error: {message}", file=sys.stderr)
    return 1
