"""Direct search over the spheres-through-one-point classes of tests/test_exact_degenerate.py.

    OMP_NUM_THREADS=1 .venv/bin/python tests/search_near_point.py [--kind near_coplanar] [--clumps 3000]
        [--seed 0] [--offsets -12 -6] [--reference 3] [--worst 5] [--json out.json]

(as a script: Python puts tests/ on sys.path, so the test module it reuses finds its own helpers as
under pytest; clumpprops is the installed package, the repository's own in the editable install
``make setup`` makes.)

Draws clumps with ``_through_one_point(rng, kind)`` (kinds "collinear", "coplanar", "near_coplanar":
3-5 spheres whose surfaces pass through one point p, centres near one line / in one plane / within
10^U(-12, -6) rad of one plane through p, plus 0-3 general spheres) and measures each one's change
under a random rotation + translation with ``motion_error`` (the same draw and tolerance as
``test_spheres_through_one_point_class_is_invariant``: 1e-12 plus the translation's round-off).
Prints the number of clumps above the tolerance and the largest error; with ``--reference K`` the K
worst clumps are also compared with the slicing reference (tests/reference_slicing.py, ~2 s each) in
their drawn position.  Uses the compiled core (``method="exact"``); ``CLUMPPROPS_CORE_DIR`` selects
another build of it.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from test_exact_degenerate import _through_one_point, exact, extent, motion_error, rel, slicing_ref


def search(kind="near_coplanar", n_clumps=3000, seed=0, offsets=(-12.0, -6.0)):
    """[(err, tol, c, r)] of n_clumps clumps of the class, in draw order."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n_clumps):
        c, r = _through_one_point(rng, kind, offsets)
        err, tol = motion_error(rng, c, r)
        out.append((float(err), float(tol), c, r))
    return out


def reference_error(c, r):
    """Largest relative difference of exact() from the slicing reference (mass, COM / extent, inertia)."""
    m, com, inertia = slicing_ref(c, r)
    a = exact(c, r)
    return max(abs(a.mass / m - 1), float(np.max(np.abs(a.center_of_mass - com))) / extent(c, r), rel(a.inertia, inertia))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kind", default="near_coplanar", choices=["collinear", "coplanar", "near_coplanar"])
    ap.add_argument("--offsets", type=float, nargs=2, default=(-12.0, -6.0), metavar=("LO", "HI"),
                    help="near_coplanar: log10 range of the out-of-plane offsets (default -12 -6)")
    ap.add_argument("--clumps", type=int, default=3000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--reference", type=int, default=0, help="compare the K worst clumps with the slicing reference")
    ap.add_argument("--worst", type=int, default=5, help="print the K worst clumps")
    ap.add_argument("--json", help="write the worst clumps (--worst) to this file")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    res = search(args.kind, args.clumps, args.seed, tuple(args.offsets))
    errs = np.array([e for e, _, _, _ in res])
    over = int(sum(e > t for e, t, _, _ in res))
    what = f"kind {args.kind}" + (f" (offsets 10^U({args.offsets[0]:g}, {args.offsets[1]:g}))" if args.kind == "near_coplanar" else "")
    print(f"{what}, seed {args.seed}: {over} of {len(res)} clumps above the tolerance, "
          f"largest {errs.max():.2e}, median {np.median(errs):.1e} ({time.perf_counter() - t0:.0f} s)")
    worst = sorted(range(len(res)), key=lambda k: -res[k][0])[: max(args.worst, args.reference)]
    rows = []
    for rank, k in enumerate(worst):
        err, tol, c, r = res[k]
        row = dict(index=k, err=err, tol=tol, c=c.tolist(), r=r.tolist())
        if rank < args.reference:
            row["reference_error"] = reference_error(c, r)
        rows.append(row)
        if rank < args.worst:
            ref = f", slicing {row['reference_error']:.2e}" if "reference_error" in row else ""
            print(f"  #{k}: {err:.2e}{ref}  c={c.tolist()} r={r.tolist()}")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
