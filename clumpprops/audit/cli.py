"""``clumpprops audit FILE``: each engine's mass properties of the file's clumps against the exact ones.

Reads FILE with :func:`clumpprops.io.read` (any format it reads) or, when FILE states values
(a LIGGGHTS input script with ``particletemplate/multisphere``, a LAMMPS molecule file with a
``mass``/``inertia`` header, a DEME JSON, an MClump folder; :mod:`clumpprops.io.stated`), the
clumps those values belong to.  Prints a table per clump; ``--json`` prints one JSON document;
``--plot FILE.png`` writes the error against samples or voxels (never over an existing file
without ``--force``).  Errors are one line ``clumpprops audit: error: ...`` with exit status 1.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from .._argtypes import _int, _positive_float, _positive_int
from ..io import ClumpFileError, read
from ..io.stated import read_stated
from . import audit_clump, methods

PROG = "clumpprops audit"


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def _fraction(text: str) -> float:
    x = _positive_float(text)
    if x >= 1.0:
        raise argparse.ArgumentTypeError(f"a tolerance is a fraction below 1 (0.01 for 1 %), got {text}")
    return x


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``clumpprops audit``.

    Returns
    -------
    argparse.ArgumentParser
    """
    p = _Parser(prog=PROG, description=(
        "How far each engine's own mass properties of the clumps in FILE are from the exact ones: the summed "
        "spheres (YADE appendClumped, LAMMPS fix rigid, MClump mode 1, PFC), YADE's voxel grid, LIGGGHTS' Monte "
        "Carlo (also with 3.8.0's Iyz defect), a Halton quasi-Monte Carlo (DEM-Engine), and the values FILE "
        "states; and the samples or voxels each sampled method needs for each tolerance. Reads FILE; writes only "
        "the --plot PNG. SI units."))
    p.add_argument("file", metavar="FILE", help="a clump file clumpprops.io.read reads, or a file that states values "
                   "(LIGGGHTS input script, LAMMPS molecule file, DEME JSON, MClump folder)")
    p.add_argument("--tolerance", type=_fraction, nargs="+", default=[0.01, 0.001], metavar="TOL",
                   help="relative tolerances on mass and each principal moment (default: 0.01 0.001)")
    p.add_argument("--density", type=_positive_float, metavar="RHO",
                   help="kg/m^3 (default: the density FILE states, e.g. LIGGGHTS' 'density constant', else 1000)")
    p.add_argument("--seed", type=_int, metavar="S", help="seed of the sampled methods (default: fresh entropy)")
    p.add_argument("--ntry", type=_positive_int, default=methods.LIGGGHTS_NTRY, help="LIGGGHTS ntry shown (default %(default)s, the value of LIGGGHTS' multisphere example; LIGGGHTS has no default)")
    p.add_argument("--discretization", type=_positive_int, default=methods.YADE_DISCRETIZATION,
                   help="YADE discretization shown (default %(default)s, updateClumpProperties' default)")
    p.add_argument("--stated", metavar="FILE2", help="also diagnose the values FILE2 states (e.g. a fix rigid infile), one body per clump of FILE")
    p.add_argument("--json", action="store_true", help="print JSON instead of the table")
    p.add_argument("--plot", metavar="PNG", help="write relative error against samples/voxels, log-log")
    p.add_argument("--force", action="store_true", help="allow --plot to replace an existing file")
    return p


def _load(path: str, stated_path: Optional[str]):
    """[(clump, [stated, ...]), ...] for the file."""
    stated = read_stated(path) if Path(path).exists() else []
    if stated and all(s.clump is not None for s in stated):
        pairs = [(s.clump, [s]) for s in stated]
    elif stated:
        raise ClumpFileError("states mass properties but no spheres: pass the clump file as FILE and this one "
                             "as --stated", path, None)
    else:
        pairs = [(c, []) for c in read(path)]
    if stated_path:
        extra = read_stated(stated_path)
        if len(extra) != len(pairs):
            raise ClumpFileError(f"states {len(extra)} bodies for {len(pairs)} clumps", stated_path, None)
        for (clump, lst), s in zip(pairs, extra):
            s.clump = s.clump or clump
            lst.append(s)
    return pairs


def _density(given, stated, default=1000.0):
    """--density, else the density the file states, else YADE's default material density."""
    if given is not None:
        return given
    return next((s.density for s in stated if s.density is not None), default)


def _pct(x):
    return f"{'-':>9}" if x is None or x != x else f"{100 * x:+9.3g}"


def format_table(reports) -> str:
    """The audit as text, one block per clump.

    Parameters
    ----------
    reports : list of (str, dict)
        Clump name and :func:`~clumpprops.audit.audit_clump` result.

    Returns
    -------
    str
    """
    out = []
    for name, rep in reports:
        ex = rep["exact"]
        out.append(f"# clump {name}, density {rep['density']:g} kg/m^3: exact mass {ex['mass']:.10g} kg, volume {ex['volume']:.10g} m^3, com "
                   + " ".join(f"{x:.6g}" for x in ex["com"]) + " m, principal moments "
                   + " ".join(f"{x:.10g}" for x in ex["principal_moments"]) + " kg m^2")
        out.append(f"{'method':<32} {'setting':<22} {'mass %':>9} {'I1 %':>9} {'I2 %':>9} {'I3 %':>9} {'seconds':>8}")
        for m in rep["methods"]:
            out.append(f"{m['method']:<32} {m['setting'] or 'default':<22} {_pct(m['mass_error'])} "
                       + " ".join(_pct(e) for e in m["moment_errors"]) + f" {m['seconds']:8.3f}")
        if rep.get("shape"):
            sh = rep["shape"]
            out.append(f"# shape: surface area {sh['surface_area']:.10g} m^2, d_v {sh['diameter']:.6g} m, sphericity "
                       f"{sh['sphericity']:.4f}, kappa " + " ".join(f"{k:.4f}" for k in sh["kappa"])
                       + f", elongation {sh['elongation']:.4f}, flatness {sh['flatness']:.4f}, bounding radius "
                       f"{sh['bounding_radius']:.6g} m")
        for s in rep["stated"]:
            errs = s.get("moment_errors", [float("nan")] * 3)
            out.append(f"{'stated: ' + s['engine']:<55} {_pct(s.get('mass_error', float('nan')))} "
                       + " ".join(_pct(e) for e in errs))
            out.extend(f"    {f}" for f in s["findings"])
        out.append(f"{'needed for 95 % within':<32} {'tolerance':>10} {'setting':>14} {'cost':>14} {'seconds':>10}")
        for a in rep["advice"]:
            if a["setting"] is None:
                out.append(f"{a['method']:<32} {a['tolerance']:>10.3g} {a['note']}")
            else:
                out.append(f"{a['method']:<32} {a['tolerance']:>10.3g} {a['setting']:>14d} {a['cost']:>14d} "
                           f"{a['seconds']:>10.3g}" + (f"  ({a['note'].split('; ', 1)[1]})" if "; " in a["note"] else ""))
        out.append(f"# audit {rep['seconds']['audit']:.3f} s, exact values alone {rep['seconds']['exact']:.4f} s")
        out.append("")
    return "\n".join(out)


def plot(reports, tolerances, path) -> None:
    """Relative error against samples or voxels per method, log-log, with the tolerance lines.

    Parameters
    ----------
    reports : list of (str, dict)
        As for :func:`format_table`.
    tolerances : sequence of float
        Drawn as horizontal lines.
    path : str or os.PathLike
        The PNG to write.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for name, rep in reports:
        for method, curve in rep["curves"].items():
            if curve:
                x, y = np.array(curve, float).T
                ax.loglog(x, y, marker="o", ms=3, label=f"{name}: {method}" if len(reports) > 1 else method)
    for tol in tolerances:
        ax.axhline(tol, color="k", ls="--", lw=0.8)
        ax.text(ax.get_xlim()[0], tol, f" {100 * tol:g} %", va="bottom", fontsize=8)
    ax.set_xlabel("samples or voxels")
    ax.set_ylabel("largest relative error (95 %), mass and principal moments")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return x


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of ``clumpprops audit``; returns the exit status.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments after ``audit``.

    Returns
    -------
    int
        0 on success, 1 on an input error (one line on stderr).
    """
    args = build_parser().parse_args(argv)
    if args.plot and Path(args.plot).exists() and not args.force:
        return _fail(f"{args.plot} exists; pass --force to replace it")
    if args.plot:
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            return _fail("--plot needs matplotlib (pip install 'clumpprops[studies]')")
    try:
        pairs = _load(args.file, args.stated)
        reports = [(c.name or str(i + 1), audit_clump(c.centers, c.radii, _density(args.density, st), args.tolerance,
                                                       args.seed, args.ntry, args.discretization, stated=st))
                   for i, (c, st) in enumerate(pairs)]
    except ClumpFileError as exc:
        return _fail(str(exc))
    except OSError as exc:
        return _fail(f"cannot read {exc.filename or args.file}: {exc.strerror or exc}")
    except (ValueError, ArithmeticError) as exc:
        return _fail(str(exc))
    if args.plot:
        plot(reports, args.tolerance, args.plot)
    if args.json:
        sys.stdout.write(json.dumps(_jsonable({"file": args.file,
                                               "clumps": [dict(rep, name=n) for n, rep in reports]}), indent=1) + "\n")
    else:
        sys.stdout.write(format_table(reports))
    return 0


def _fail(message: str) -> int:
    print(f"{PROG}: error: " + " ".join(str(message).split()), file=sys.stderr)
    return 1
