"""Dense clumps: time and peak memory of the exact method where every sphere overlaps every other.

Run:  OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_dense [--before DIR] [--shell 100,400,1000]
                                                                   [--identical 1000,10000,100000]

Cases (each in its own process, so that its peak memory is its own):

* ``identical N``: N copies of one sphere (the union is one ball);
* ``shell N``: N spheres of radius 1.2 centred on the unit sphere, every pair overlapping, every
  sphere partly exposed (the worst case for the arrangement: N - 1 caps on each sphere).

Prints CPU time (process_time) and peak resident memory (ru_maxrss) per case and the fitted
exponent of time against N.  With ``--before DIR`` (a directory holding another build of
``clumpprops.core._core``, e.g. one built from an older commit) each case also runs on that
core, side by side.  The targets: 1,000 mutually overlapping spheres in <= 10 s;
10^5 identical spheres in <= 1 s with memory linear in N.  Timing only: nothing is asserted.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

CHILD = r"""
import json, resource, sys, time
import numpy as np
import clumpprops as cp
kind, n = sys.argv[1], int(sys.argv[2])
if kind == "identical":
    c, r = np.zeros((n, 3)), np.ones(n)
else:
    u = np.random.default_rng(0).normal(size=(n, 3))
    c, r = u / np.linalg.norm(u, axis=1)[:, None], np.full(n, 1.2)
t = time.process_time()
mp = cp.mass_properties(c, r)
cpu = time.process_time() - t
print(json.dumps({"cpu_s": cpu, "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "mass": mp.mass}))
"""


def run(kind, n, core_dir=None, timeout=1800):
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=ROOT)
    if core_dir:
        env["CLUMPPROPS_CORE_DIR"] = core_dir
    try:
        out = subprocess.run([sys.executable, "-c", CHILD, kind, str(n)], env=env, capture_output=True,
                             text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"over {timeout} s"}
    if out.returncode:
        return {"error": (out.stderr.strip().splitlines() or ["?"])[-1][:80]}
    return json.loads(out.stdout)


def fmt(res):
    if "error" in res:
        return f"{res['error']:>28}"
    return f"{res['cpu_s']:10.3f} s {res['peak_mb']:8.0f} MB"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", help="directory of another _core build, run side by side")
    ap.add_argument("--shell", default="100,400,1000")
    ap.add_argument("--identical", default="1000,10000,100000")
    args = ap.parse_args()
    for kind, sizes in (("identical", args.identical), ("shell", args.shell)):
        ns = [int(x) for x in sizes.split(",") if x]
        times = []
        print(f"{kind:>10} {'N':>7} {'this core':>24}" + (f" {'before':>24}" if args.before else ""))
        for n in ns:
            now = run(kind, n)
            line = f"{kind:>10} {n:7d} {fmt(now)}"
            if args.before:
                line += f" {fmt(run(kind, n, args.before))}"
            print(line, flush=True)
            if "cpu_s" in now and now["cpu_s"] > 0.05:
                times.append((n, now["cpu_s"]))
        if len(times) >= 2:
            x, y = np.log([t[0] for t in times]), np.log([t[1] for t in times])
            print(f"{kind:>10} time ~ N^{np.polyfit(x, y, 1)[0]:.2f} over N = {times[0][0]}..{times[-1][0]}")


if __name__ == "__main__":
    main()
