"""Export speed: 10^5 clumps to every engine (a printed figure, not a timed test).

    .venv/bin/python benchmarks/bench_io.py [--n 100000] [--spheres 2]

Random clumps (the paper's dimer shape, d = 0.1333 m, D = d/2, randomly placed and
oriented; with --spheres K > 2, K overlapping spheres) are written to a YADE textClumps
file, read back, computed once (exact method, one batch call) and exported into a
temporary folder: all N clumps to the single-file outputs (YADE textClumps, LAMMPS
infile + data file, DEME JSON), and the first --templates-n clumps to the formats with one
file (or folder) per clump (LIGGGHTS sphere files, LAMMPS molecule files, DEME CSVs,
MClump folders), whose cost is file creation.  Prints seconds per stage and writes
benchmarks/results/io.json.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from clumpprops.io import Clump, compute, export, read  # noqa: E402


def make_clumps(n, k, seed=1):
    rng = np.random.default_rng(seed)
    d = 0.1333
    if k == 2:
        axis = rng.normal(size=(n, 3))
        axis /= np.linalg.norm(axis, axis=1)[:, None]
        pos = rng.uniform(0, 100, (n, 3))
        centers = np.stack([pos - axis * d / 4, pos + axis * d / 4], axis=1)
        radii = np.full((n, 2), d / 2)
    else:
        pos = rng.uniform(0, 100, (n, 1, 3))
        centers = pos + rng.uniform(-d / 2, d / 2, (n, k, 3))
        radii = rng.uniform(d / 4, d / 2, (n, k))
    return [Clump(c, r, name=f"c{i}") for i, (c, r) in enumerate(zip(centers, radii))]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=100000)
    ap.add_argument("--spheres", type=int, default=2)
    ap.add_argument("--templates-n", type=int, default=10000)
    args = ap.parse_args()
    res = {"n_clumps": args.n, "spheres_per_clump": args.spheres, "seconds": {}, "cpu_seconds": {}}
    tmp = Path(tempfile.mkdtemp(prefix="bench_io_"))
    try:
        clumps = make_clumps(args.n, args.spheres)
        mp = compute(clumps, 1140.0)
        export(clumps, "yade", tmp, density=1140.0, mp=mp, stem="input")
        t, c = time.perf_counter(), time.process_time()
        clumps = read(tmp / "input_textclumps.txt")
        res["seconds"]["read textClumps"] = time.perf_counter() - t
        res["cpu_seconds"]["read textClumps"] = time.process_time() - c
        t, c = time.perf_counter(), time.process_time()
        mp = compute(clumps, 1140.0)
        res["seconds"]["compute (exact, one batch)"] = time.perf_counter() - t
        res["cpu_seconds"]["compute (exact, one batch)"] = time.process_time() - c
        runs = [("yade", True, args.n), ("lammps", False, args.n), ("deme", False, args.n)]
        runs += [(e, True, min(args.templates_n, args.n)) for e in ("liggghts", "lammps", "deme", "mclump")]
        for engine, templates, n in runs:
            label = f"{engine}{'' if engine == 'yade' else '' if templates else '/no-templates'}"
            label = f"{label} ({n} clumps{', per-clump files' if templates and engine != 'yade' else ''})"
            out = tmp / f"{engine}_{templates}"
            t, c = time.perf_counter(), time.process_time()
            paths = export(clumps[:n], engine, out, density=1140.0, mp=mp if n == args.n else mp[:n], templates=templates)
            res["seconds"][f"write {label}"] = time.perf_counter() - t
            res["cpu_seconds"][f"write {label}"] = time.process_time() - c
            res.setdefault("files", {})[label] = len(paths)
            shutil.rmtree(out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"{args.n} clumps of {args.spheres} spheres (exact method, SI, 17 digits); wall and CPU seconds")
    for k, v in res["seconds"].items():
        extra = f"  [{res['files'][k[6:]]} files]" if k.startswith("write") else ""
        print(f"  {k:58s} {v:7.2f} s  cpu {res['cpu_seconds'][k]:6.2f} s{extra}")
    total = res["seconds"]["read textClumps"] + res["seconds"]["compute (exact, one batch)"]
    ctotal = res["cpu_seconds"]["read textClumps"] + res["cpu_seconds"]["compute (exact, one batch)"]
    for k, v in res["seconds"].items():
        if k.startswith("write") and f"({args.n} clumps)" in k:
            print(f"  read + compute + {k:41s} {total + v:7.2f} s  cpu {ctotal + res['cpu_seconds'][k]:6.2f} s")
    res["load_average_1min"] = os.getloadavg()[0]
    print(f"  (load average {res['load_average_1min']:.1f} on {os.cpu_count()} cores)")
    outdir = Path(__file__).resolve().parent / "results"
    outdir.mkdir(exist_ok=True)
    res["when"] = time.strftime("%Y-%m-%d %H:%M")
    res["cpu"] = os.cpu_count()
    (outdir / f"io{'' if args.spheres == 2 else f'_{args.spheres}'}.json").write_text(json.dumps(res, indent=1) + "\n")


if __name__ == "__main__":
    main()
