"""Export speed: 10^5 clumps to every engine (a printed figure, not a timed test).

    .venv/bin/python -m benchmarks.bench_io [--n 100000] [--spheres 2]

Random clumps (the paper's dimer shape, d = 0.1333 m, D = d/2, randomly placed and
oriented; with --spheres K > 2, K overlapping spheres) are written to a YADE textClumps
file, read back, computed once (exact method, one batch call) and exported into a
temporary folder: all N clumps to the single-file outputs (YADE textClumps, LAMMPS
infile + data file, DEME JSON), and the first --templates-n clumps to the formats with one
file (or folder) per clump (LIGGGHTS sphere files, LAMMPS molecule files, DEME CSVs,
MClump folders), whose cost is file creation.  Prints seconds per stage and writes
benchmarks/results/io.json.

    .venv/bin/python -m benchmarks.bench_io --read-lines 1000000 [--formats textclumps,yade,...]

measures the readers instead: one file of N spheres per format (textClumps with dimers and
as one N-sphere clump, CSV, LIGGGHTS, MClump, LAMMPS .mol), each read in a fresh process
by the vectorised route and by the line-by-line validators (the route every line took
before the numpy readers), side by side: wall and CPU seconds, the peak memory the read
adds (peak resident set minus the resident set after the imports) and its ratio to the
file's size.  Writes benchmarks/results/io_read.json.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from clumpprops.io import Clump, compute, export, read

from .harness import write


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


READ_FORMATS = ("textclumps", "textclumps-one-clump", "yade", "csv", "liggghts", "mclump", "lammps")

# run in a fresh process per (route, format): the peak resident set then belongs to this read alone
_MEASURE = r"""
import json, sys, time
route, fmt, path = sys.argv[1:4]
from clumpprops import textclumps as tc
from clumpprops.io import readers as R
if route == "line-by-line":
    tc._fast_chunk = lambda *a: False
    R._fast_spheres = lambda *a, **k: None
    R._mol_fast = lambda *a, **k: None
def status(key):
    return next(int(l.split()[1]) for l in open("/proc/self/status") if l.startswith(key + ":")) * 1024
base = status("VmRSS")
t, c = time.perf_counter(), time.process_time()
if fmt.startswith("textclumps"):
    out = tc.read_text_clumps(path)
    n = len(out.radii)
else:
    out = R.read(path, fmt=fmt)
    n = sum(k.n_spheres for k in out)
wall, cpu = time.perf_counter() - t, time.process_time() - c
print(json.dumps({"seconds": wall, "cpu_seconds": cpu, "spheres": n, "clumps": len(out),
                  "peak_bytes": status("VmHWM") - base}))
"""


def write_read_inputs(n, folder, formats, seed=2):
    """One file of n random spheres per format; returns {format: path}."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(0, 100, (n, 4))
    a[:, 3] = rng.uniform(0.01, 0.07, n)
    rows = [f"{x!r} {y!r} {z!r} {r!r}" for x, y, z, r in a.tolist()]
    ids = np.arange(1, n + 1).tolist()
    texts = {
        "textclumps": lambda: ["#format x_y_z_r_clumpId"] + [f"{w} {i // 2}" for w, i in zip(rows, ids)],
        "textclumps-one-clump": lambda: ["#format x_y_z_r_clumpId"] + [f"{w} 0" for w in rows],
        "yade": lambda: ["#format x_y_z_r_clumpId"] + [f"{w} {i // 2}" for w, i in zip(rows, ids)],
        "csv": lambda: ["x,y,z,r"] + [w.replace(" ", ",") for w in rows],
        "liggghts": lambda: ["# x y z r"] + rows,
        "mclump": lambda: [w.replace(" ", ",") for w in rows],
        "lammps": lambda: (["molecule", "", f"{n} atoms", "", "Coords", ""]
                           + [f"{i} {x!r} {y!r} {z!r}" for i, (x, y, z) in zip(ids, a[:, :3].tolist())]
                           + ["", "Types", ""] + [f"{i} 1" for i in ids]
                           + ["", "Diameters", ""] + [f"{i} {2 * r!r}" for i, r in zip(ids, a[:, 3].tolist())]
                           + ["", "Masses", ""] + [f"{i} {1140 * 4 / 3 * np.pi * r ** 3!r}" for i, r in zip(ids, a[:, 3].tolist())]),
    }
    names = {"csv": "spheres.csv", "liggghts": "spheres.multisphere", "mclump": "Clump.txt", "lammps": "spheres.mol"}
    paths = {}
    for fmt in formats:
        paths[fmt] = folder / names.get(fmt, f"{fmt}.txt")
        paths[fmt].write_text("\n".join(texts[fmt]()) + "\n")
    return paths


def measure_read(route, fmt, path):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    p = subprocess.run([sys.executable, "-c", _MEASURE, route, fmt, str(path)], capture_output=True, text=True,
                       env=env, cwd=str(Path(__file__).resolve().parents[1]))
    if p.returncode != 0:
        raise RuntimeError(f"{route} {fmt}: {p.stderr.strip().splitlines()[-1]}")
    return json.loads(p.stdout)


def bench_read(n, formats):
    """Each format's file read by both routes, printed side by side with the ratios."""
    res = {"n_spheres": n, "formats": {}}
    tmp = Path(tempfile.mkdtemp(prefix="bench_read_"))
    try:
        paths = write_read_inputs(n, tmp, formats)
        for fmt in formats:
            size = paths[fmt].stat().st_size
            row = {"file_bytes": size}
            for route in ("vectorised", "line-by-line"):
                row[route] = measure_read(route, fmt, paths[fmt])
            res["formats"][fmt] = row
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    mb = 1e6
    print(f"read {n} spheres per file; peak = memory the read adds (peak RSS - RSS after imports), x = / file size")
    print(f"  {'format':22s} {'file MB':>8s} | {'vectorised s':>12s} {'cpu':>6s} {'peak MB':>8s} {'x':>5s} | "
          f"{'line-by-line s':>14s} {'cpu':>6s} {'peak MB':>8s} {'x':>5s} | {'speed-up':>8s} {'memory':>6s}")
    for fmt, row in res["formats"].items():
        v, s = row["vectorised"], row["line-by-line"]
        size = row["file_bytes"]
        print(f"  {fmt:22s} {size / mb:8.1f} | {v['seconds']:12.2f} {v['cpu_seconds']:6.2f} {v['peak_bytes'] / mb:8.0f} "
              f"{v['peak_bytes'] / size:5.1f} | {s['seconds']:14.2f} {s['cpu_seconds']:6.2f} {s['peak_bytes'] / mb:8.0f} "
              f"{s['peak_bytes'] / size:5.1f} | {s['seconds'] / v['seconds']:7.1f}x {s['peak_bytes'] / v['peak_bytes']:5.1f}x")
    res["load_average_1min"] = os.getloadavg()[0]
    print(f"  (load average {res['load_average_1min']:.1f} on {os.cpu_count()} cores)")
    write("io_read.json", res)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=100000)
    ap.add_argument("--spheres", type=int, default=2)
    ap.add_argument("--templates-n", type=int, default=10000)
    ap.add_argument("--read-lines", type=int, default=0,
                    help="benchmark the readers on files of this many spheres instead of the exporters")
    ap.add_argument("--formats", default=",".join(READ_FORMATS), help="with --read-lines: formats to read")
    args = ap.parse_args()
    if args.read_lines:
        formats = [f for f in args.formats.split(",") if f]
        unknown = sorted(set(formats) - set(READ_FORMATS))
        if unknown:
            ap.error(f"unknown format(s) {', '.join(unknown)}; choose from {', '.join(READ_FORMATS)}")
        bench_read(args.read_lines, formats)
        return
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
    res["when"] = time.strftime("%Y-%m-%d %H:%M")
    res["cpu"] = os.cpu_count()
    write(f"io{'' if args.spheres == 2 else f'_{args.spheres}'}.json", res)


if __name__ == "__main__":
    main()
