"""``clumpprops export FILE --to ENGINE``: clump files with exact values for a DEM engine.

    clumpprops export FILE --to {liggghts,lammps,deme,mclump,yade,vtk,stl} [--out DIR]
                      [--density RHO] [--method M] [--scale S] [--from FMT] [--diameter D] [--name STEM]
                      [--no-templates] [--force] [--deck [--velocity VX VY VZ] [--spin WX WY WZ]
                      [--steps N] [--dt DT]] [--tolerance REL]

Prints one line per file written and a short summary per clump on stdout; warnings (DEME
float32 precision) on stderr.  Errors are one line ``clumpprops: error: FILE:LINE: reason``,
exit status 1; bad options exit with status 2.  See docs/engines.md.
"""
from __future__ import annotations

import argparse
import math
import sys
from typing import Optional, Sequence

from .. import DEFAULT_METHOD, METHODS, ClumpGeometryError, __version__
from .._argtypes import _positive_float, add_input_options
from . import ENGINES, FORMATS, ClumpFileError, compute, export, read

PROG = "clumpprops export"

FILES = """files written into --out (STEM = --name, else the clump's name for one clump, else 'clumps'):
  liggghts  NAME_spheres.multisphere  per clump of 2+ spheres: 'x y z r' lines (m), centred on the
                                      centre of mass, input axes, no comments
            STEM_liggghts.in          one 'fix particletemplate/multisphere ... mass M inertia_tensor
                                      ... use_density' per clump (particletemplate/sphere for a
                                      one-sphere clump) and 'fix pdd1 particledistribution/discrete';
                                      names its sphere files relative to --out: run LIGGGHTS there
  lammps    STEM.rigid                fix rigid infile: mass, centre of mass, inertia tensor (and
                                      with --deck the initial velocity and angular momentum)
            STEM.data                 the member spheres (atom_style hybrid sphere molecular)
            NAME.mol                  per clump: molecule file with mass, com, inertia (not with
                                      --no-templates); one-sphere clumps are refused
  deme      STEM_deme.json            per clump mass, principal moments, radii, relPos, com, axes
            NAME_deme.csv             per clump: 'x,y,z,r' in the principal frame (not with
                                      --no-templates)
  mclump    NAME/Clump/Clump.txt, NAME/Inertia/{Mass,TOI,PD}.txt, NAME/clumpprops.txt
                                      per clump: MClump's folder (principal frame), and the frame
  yade      STEM_textclumps.txt       'x y z r clumpId' lines; exact values in the comments (load
                                      with clumpprops.yade.text_clumps)
  vtk       NAME.vtu                  per clump: sphere centres with radius/diameter arrays (ParaView
                                      glyphs), centre of mass, principal axes as lines
  stl       NAME.stl                  per clump: watertight mesh of the union, volume and area within
                                      --tolerance of the exact ones
with --deck (liggghts, lammps, yade), run in --out:
  liggghts  STEM_deck_liggghts.in     liggghts -in STEM_deck_liggghts.in; writes
                                      STEM_liggghts_start.dump and STEM_liggghts_end.dump
  lammps    STEM_deck_lammps.in       lmp -in STEM_deck_lammps.in; writes STEM_lammps.dump
  yade      STEM_deck_yade.py         yade -x STEM_deck_yade.py; prints mass, tensor, momentum
Nothing is written over FILE, nor over an existing file without --force; a refused export
writes nothing."""


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line (``clumpprops export: error: ...``), status 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog=PROG, epilog=FILES, formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Write the files a DEM engine reads for the clumps in FILE, with the clumps' exact mass, "
        "centre of mass and inertia (SI units). Input formats: " + ", ".join(FORMATS) + " (from the file's first "
        "lines: comma tables = csv, 'N atoms' = LAMMPS molecule, 'x y z r id' = YADE textClumps, 'x y z r' = "
        "LIGGGHTS; else from the extension: .csv, .multisphere/.ms/.spheres, Clump.txt or an MClump folder, .txt, "
        ".mol/.molecule). Writes the engine's files into --out (their names are listed on stdout); never over "
        "FILE, and over existing files only with --force.",
    )
    p.add_argument("file", metavar="FILE")
    p.add_argument("--to", required=True, choices=ENGINES, help="target engine")
    p.add_argument("--out", default=".", metavar="DIR", help="output folder (default: current folder)")
    p.add_argument("--density", type=_positive_float, default=1000.0, metavar="RHO",
                   help="solid density in kg/m^3 (default: 1000); written into every file")
    p.add_argument("--method", choices=METHODS, default=DEFAULT_METHOD, help=f"default: {DEFAULT_METHOD}")
    p.add_argument("--scale", type=_positive_float, default=1.0, metavar="S",
                   help="multiply coordinates and radii by S, e.g. 0.001 for a file in mm (outputs are in m)")
    add_input_options(p, FORMATS)
    p.add_argument("--name", metavar="STEM", help="stem of the output files that hold all clumps")
    p.add_argument("--no-templates", action="store_true",
                   help="lammps, deme: skip the per-clump .mol / .csv files (large batches: the .rigid/.data or the "
                   "JSON hold every clump)")
    p.add_argument("--force", action="store_true",
                   help="replace output files that exist (never the input FILE itself); without it nothing is written "
                   "when any output file exists")
    p.add_argument("--deck", action="store_true",
                   help="liggghts, lammps, yade: also write a runnable deck: the clumps in an empty box without "
                   "gravity, run for --steps steps (docs/engines.md)")
    p.add_argument("--velocity", type=float, nargs=3, default=(0.0, 0.0, 0.0), metavar=("VX", "VY", "VZ"),
                   help="with --deck: initial velocity of every clump, m/s (default: 0 0 0)")
    p.add_argument("--spin", type=float, nargs=3, default=(0.0, 0.0, 0.0), metavar=("WX", "WY", "WZ"),
                   help="with --deck: initial angular velocity of every clump, rad/s, space frame (default: 0 0 0)")
    p.add_argument("--steps", type=int, default=1000, metavar="N", help="with --deck: steps to run (default: 1000)")
    p.add_argument("--dt", type=_positive_float, metavar="DT",
                   help="with --deck: timestep in s (default: a fifth of the smallest sphere's Rayleigh time, "
                   "at most 0.01 rad per step)")
    p.add_argument("--tolerance", type=_positive_float, default=1e-3, metavar="REL",
                   help="stl: relative tolerance on the mesh's volume and area (default: 1e-3)")
    p.add_argument("--version", action="version", version=f"clumpprops {__version__}")
    return p


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.no_templates and args.to not in ("lammps", "deme"):
        parser.error(f"--no-templates applies to --to lammps and deme; {args.to} needs its per-clump files")
    _check_deck_options(parser, args)
    warnings = []
    try:
        clumps = read(args.file, args.fmt, scale=args.scale, diameter=args.diameter)
        mp = compute(clumps, args.density, args.method)
        paths = export(clumps, args.to, args.out, args.density, args.method, source=args.file, scale=args.scale,
                       stem=args.name, mp=mp, warn=warnings.append,
                       templates=not args.no_templates, force=args.force, deck=args.deck,
                       velocity=args.velocity, spin=args.spin, steps=args.steps, dt=args.dt,
                       tolerance=args.tolerance)
    except ClumpGeometryError as exc:
        for c in clumps:  # point at the clump and its lines
            try:
                compute([c], args.density, args.method)
            except ClumpGeometryError as one:
                one = str(one).replace(" of clump 0 ", " ")  # a batch of one: the library's index says nothing
                line = c.lines[0] if c.lines else None
                return _fail(f"{c.source}:{line}: clump {c.name}: {one}" if line else f"{c.source}: clump {c.name}: {one}")
        return _fail(f"{args.file}: {exc}")
    except ClumpFileError as exc:
        return _fail(str(exc))
    except ImportError as exc:  # the optional mesh libraries
        return _fail(str(exc))
    except OSError as exc:
        return _fail(f"cannot write to {args.out}: {exc.strerror or exc}")
    except ValueError as exc:  # library input validation
        return _fail(f"{args.file}: {exc}")
    for w in warnings:
        print(f"clumpprops: warning: {w}", file=sys.stderr)
    out = sys.stdout
    out.write(f"# {len(clumps)} clump(s) from {args.file}, method={args.method}, density={args.density:g} kg/m^3"
              f"{', scale=%g' % args.scale if args.scale != 1.0 else ''} -> {args.to}\n")
    if len(clumps) <= 20:
        for k, c in enumerate(clumps):
            m = mp[k]
            out.write(f"# {c.name}: {c.n_spheres} spheres, mass {m.mass:.10g} kg, principal moments "
                      + " ".join(f"{x:.10g}" for x in m.principal_moments) + " kg m^2\n")
    if len(paths) <= 50:
        for p in paths:
            out.write(f"{p}\n")
    else:
        out.write(f"{len(paths)} files written under {args.out}\n")
    return 0


def _check_deck_options(parser, args):
    """Exit with status 2 on deck options without --deck, a deck for an engine without one, or bad values."""
    from .decks import DECK_ENGINES

    zero = (0.0, 0.0, 0.0)
    given = [name for name, unset in (("--velocity", tuple(args.velocity) == zero), ("--spin", tuple(args.spin) == zero),
                                      ("--steps", args.steps == 1000), ("--dt", args.dt is None)) if not unset]
    if given and not args.deck:
        parser.error(f"{given[0]} applies with --deck")
    if args.deck and args.to not in DECK_ENGINES:
        parser.error(f"--deck applies to --to {', '.join(DECK_ENGINES)}; {args.to} has documented snippets in "
                     "docs/engines.md")
    if args.steps < 2:
        parser.error(f"--steps must be at least 2, got {args.steps}")
    bad = [x for x in (*args.velocity, *args.spin) if not math.isfinite(x)]
    if bad:
        parser.error(f"--velocity and --spin take finite numbers, got {bad[0]}")


def _fail(message: str) -> int:
    print("clumpprops: error: " + " ".join(str(message).split()), file=sys.stderr)
    return 1
