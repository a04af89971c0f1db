"""The compiled core (issue 9) against the numpy implementation it replaced, side by side in one run.

Run:  OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_core [--quick]

Writes benchmarks/results/core.json and benchmarks/results/core_k_scaling.png.  Figures:

 1. one 10-sphere clump with triple overlaps, one Python call (median of many calls):
    the core vs the numpy route (``_input.normalize`` + ``_exact_numpy`` + ``finish``,
    which is what ``mass_properties`` ran before the core); also method="sum";
 2. a batch of 10-sphere clumps: clumps/s;
 3. one 1,000-sphere clump with ~4 overlapping neighbours per sphere: ms (median CPU time of 300
    calls; with CLUMPPROPS_BENCH_BEFORE=<dir of another _core build>, that core alternately);
 4. time per sphere against K, the number of caps per sphere (dense clumps of 150 spheres
    with ~K overlapping neighbours each), with the fitted exponent and the ratio to K^2 log K;
 5. 10^6 random dimers, principal axes included: sum, pairwise, exact in dimers/s.

Times: wall clock (perf_counter) and CPU time of this process (process_time); the machine is
shared, so CPU time is the steadier figure and both are recorded.
"""
from __future__ import annotations

import json
import os
import platform
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import clumpprops as cp  # noqa: E402
from clumpprops import _exact_numpy, _input, api  # noqa: E402
from clumpprops._properties import finish  # noqa: E402

QUICK = "--quick" in sys.argv
# another build of the core (a directory holding _core*.so), measured alternately with this one in section 3
BEFORE = os.environ.get("CLUMPPROPS_BENCH_BEFORE")
HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "results", "core.json")
PNG = os.path.join(HERE, "results", "core_k_scaling.png")
RHO = 1140.0
res: dict = {"machine": platform.platform(), "python": sys.version.split()[0], "numpy": np.__version__,
             "clumpprops": cp.__version__, "quick": QUICK, "date": time.strftime("%Y-%m-%d %H:%M"),
             "loadavg_start": os.getloadavg()}


def numpy_exact(c, r, rho=RHO):
    """What mass_properties(method="exact") ran before the core."""
    sph = _input.normalize(c, r)
    V, S, Q = _exact_numpy.exact_moments(sph)
    return finish(V, S, Q, sph.origin, rho, "exact", sph.batched)


def load_core(directory):
    """The _core extension module built in `directory` (loaded beside the package's own)."""
    import glob
    import importlib.machinery
    import importlib.util

    path = sorted(glob.glob(os.path.join(directory, "_core*.so")))[0]
    loader = importlib.machinery.ExtensionFileLoader("_core", path)
    spec = importlib.util.spec_from_file_location("_core", path, loader=loader)
    mod = importlib.util.module_from_spec(spec)
    loader.exec_module(mod)
    return mod


def per_call(f, n):
    """Median wall and median CPU seconds of n calls of f."""
    w, c = [], []
    for _ in range(n):
        t0, p0 = time.perf_counter(), time.process_time()
        f()
        w.append(time.perf_counter() - t0)
        c.append(time.process_time() - p0)
    return float(np.median(w)), float(np.median(c))


def once(f, repeat=3):
    """Best wall and best CPU seconds of `repeat` runs of f."""
    w, c = [], []
    for _ in range(repeat):
        t0, p0 = time.perf_counter(), time.process_time()
        f()
        w.append(time.perf_counter() - t0)
        c.append(time.process_time() - p0)
    return min(w), min(c)


def grain_clumps(M, N, rng, overlap_neighbours=4.0):
    """M clumps of N spheres in a 3:1.5:1 ellipsoid, each sphere overlapping ~overlap_neighbours
    others (as benchmarks/bench_massprops.py)."""
    n = overlap_neighbours / (4.0 / 3.0 * np.pi * 8.0)
    a = (N / n / (4.0 / 3.0 * np.pi * 4.5)) ** (1.0 / 3.0)
    u = rng.normal(size=(M, N, 3))
    u /= np.linalg.norm(u, axis=-1)[..., None]
    u *= rng.random((M, N, 1)) ** (1.0 / 3.0)
    return u * (np.array([3.0, 1.5, 1.0]) * a), rng.uniform(0.8, 1.2, (M, N))


def mean_caps(c, r):
    D = np.linalg.norm(c[:, None] - c[None], axis=-1)
    return float(((D < r[:, None] + r[None]) & ~np.eye(len(r), dtype=bool)).sum(axis=1).mean())


def section(t):
    print(f"\n== {t}", flush=True)


rng = np.random.default_rng(9)

# 1 ------------------------------------------------------------------------------------
section("1. one 10-sphere clump with triple overlaps, one Python call")
while True:
    c10, r10 = grain_clumps(1, 10, rng, 4.0)
    c10, r10 = c10[0], r10[0]
    try:
        cp.mass_properties(c10, r10, method="pairwise")
    except cp.ClumpGeometryError:
        break  # has triple overlaps
a = cp.mass_properties(c10, r10, RHO)
b = numpy_exact(c10, r10)
assert abs(a.mass / b.mass - 1) < 1e-13
n_core = 300 if QUICK else 3000
tw_core, tc_core = per_call(lambda: cp.mass_properties(c10, r10, RHO), n_core)
tw_sum, tc_sum = per_call(lambda: cp.mass_properties(c10, r10, RHO, method="sum"), n_core)
tw_np, tc_np = per_call(lambda: numpy_exact(c10, r10), 30 if QUICK else 200)
print(f"  core exact {tw_core * 1e6:7.1f} us wall ({tc_core * 1e6:.1f} us CPU)   core sum {tw_sum * 1e6:.1f} us")
print(f"  numpy exact {tw_np * 1e6:7.0f} us wall ({tc_np * 1e6:.0f} us CPU)   speed-up {tw_np / tw_core:.0f}x wall, {tc_np / max(tc_core, 1e-9):.0f}x CPU")
res["one_call_10_spheres"] = {"core_exact_us_wall": tw_core * 1e6, "core_exact_us_cpu": tc_core * 1e6,
                              "core_sum_us_wall": tw_sum * 1e6, "numpy_exact_us_wall": tw_np * 1e6,
                              "numpy_exact_us_cpu": tc_np * 1e6, "speedup_wall": tw_np / tw_core,
                              "mean_caps_per_sphere": mean_caps(c10, r10)}

# 2 ------------------------------------------------------------------------------------
section("2. batch of 10-sphere clumps (~4 overlapping neighbours per sphere)")
M = 20_000 if QUICK else 100_000
cb, rb = grain_clumps(M, 10, rng, 4.0)
tw, tc = once(lambda: cp.mass_properties(cb, rb, RHO))
Mn = 2000
twn, tcn = once(lambda: numpy_exact(cb[:Mn], rb[:Mn]), repeat=1)
print(f"  core {M / tw:12,.0f} clumps/s wall ({M / tc:,.0f} /s CPU);  numpy {Mn / twn:,.0f} clumps/s wall")
res["batch_10_spheres"] = {"clumps": M, "core_per_s_wall": M / tw, "core_per_s_cpu": M / tc,
                           "numpy_per_s_wall": Mn / twn, "numpy_clumps": Mn}

# 3 ------------------------------------------------------------------------------------
section("3. one 1,000-sphere clump, ~4 overlapping neighbours per sphere")
cl, rl = grain_clumps(1, 1000, rng, 4.0)
cl, rl = cl[0], rl[0]
# A single ~1.5 ms call is at the mercy of the shared machine: median and quartiles of the CPU time
# of 300 calls (5 warm-up calls first).  With CLUMPPROPS_BENCH_BEFORE set (a directory holding another
# build of _core, e.g. the previous commit's), that core is called alternately with this one, call
# for call, through the same API, so both see the same load.
n1000 = 20 if QUICK else 300
cores = {"core": api._core}
if BEFORE:
    cores["before"] = load_core(BEFORE)
samples = {k: ([], []) for k in cores}
for k, mod in cores.items():
    api._core = mod
    for _ in range(5):
        cp.mass_properties(cl, rl, RHO)
for _ in range(n1000):
    for k, mod in cores.items():
        api._core = mod
        t0, p0 = time.perf_counter(), time.process_time()
        cp.mass_properties(cl, rl, RHO)
        samples[k][0].append(time.perf_counter() - t0)
        samples[k][1].append(time.process_time() - p0)
api._core = cores["core"]
twn, tcn = once(lambda: numpy_exact(cl, rl), repeat=1)
res["clump_1000"] = {"calls": n1000, "numpy_ms_wall": twn * 1e3, "mean_caps_per_sphere": mean_caps(cl, rl)}
for k, (w, c) in samples.items():
    q = np.percentile(np.array(c) * 1e3, [25, 50, 75])
    tw = float(np.median(w)) * 1e3
    print(f"  {k:6s} {q[1]:.2f} ms CPU (quartiles {q[0]:.2f} .. {q[2]:.2f}), {tw:.2f} ms wall; median of {n1000} calls")
    pre = "core" if k == "core" else "before"
    res["clump_1000"].update({f"{pre}_ms_cpu": float(q[1]), f"{pre}_ms_cpu_q25": float(q[0]),
                              f"{pre}_ms_cpu_q75": float(q[2]), f"{pre}_ms_wall": tw})
if BEFORE:
    res["clump_1000"]["before_core_dir"] = BEFORE
print(f"  numpy {twn * 1e3:.0f} ms; mean caps/sphere {mean_caps(cl, rl):.2f}")

# 4 ------------------------------------------------------------------------------------
section("4. time per sphere against K (caps per sphere)")
rows = []
Ks = [4, 8, 12, 16, 24, 32, 40] if not QUICK else [4, 8, 16, 32]
N = 150
for K in Ks:
    c, r = grain_clumps(4, N, rng, K)
    k_mean = float(np.mean([mean_caps(c[m], r[m]) for m in range(len(c))]))
    tw, tc = once(lambda: cp.mass_properties(c, r, RHO), repeat=3)
    rows.append({"K_target": K, "K_mean": k_mean, "us_per_sphere_wall": tw / (4 * N) * 1e6,
                 "us_per_sphere_cpu": tc / (4 * N) * 1e6})
    print(f"  K ~ {k_mean:5.1f}: {tw / (4 * N) * 1e6:8.2f} us/sphere wall ({tc / (4 * N) * 1e6:.2f} CPU)")
K_arr = np.array([x["K_mean"] for x in rows])
t_arr = np.array([x["us_per_sphere_cpu"] for x in rows])
big = K_arr >= 8
slope = float(np.polyfit(np.log(K_arr[big]), np.log(t_arr[big]), 1)[0])
ratio = t_arr / (K_arr**2 * np.log(K_arr))
print(f"  fitted exponent (K >= 8): {slope:.2f};  time / (K^2 log K): {', '.join(f'{x:.3g}' for x in ratio)}")
res["k_scaling"] = {"rows": rows, "spheres_per_clump": N, "fitted_exponent_K_ge_8": slope,
                    "time_over_K2logK": ratio.tolist()}
try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3.6))
    ax.loglog(K_arr, t_arr, "o-", label="core, CPU time per sphere")
    ref = t_arr[big][0] * (K_arr**2 * np.log(K_arr)) / (K_arr[big][0] ** 2 * np.log(K_arr[big][0]))
    ax.loglog(K_arr, ref, "k--", label=r"$\propto K^2 \log K$")
    ax.set_xlabel("K, caps per sphere (mean)")
    ax.set_ylabel("µs per sphere")
    ax.set_title(f"exact core: fitted exponent {slope:.2f}")
    ax.legend()
    fig.tight_layout()
    fig.savefig(PNG, dpi=120)
except Exception as exc:  # pragma: no cover - plotting is optional
    print("  (no plot:", exc, ")")

# 5 ------------------------------------------------------------------------------------
section("5. 10^6 random dimers, principal axes included")
M = 200_000 if QUICK else 1_000_000
c = np.zeros((M, 2, 3))
axis = rng.normal(size=(M, 3))
axis /= np.linalg.norm(axis, axis=1)[:, None]
r = rng.uniform(0.5, 1.0, (M, 2))
D = rng.uniform(0.3, 0.95, M) * (r[:, 0] + r[:, 1])
c[:, 1] = axis * D[:, None]
c += rng.normal(size=(M, 1, 3))
row = {}
for method in ("sum", "pairwise", "exact"):
    tw, tc = once(lambda: cp.mass_properties(c, r, RHO, method=method), repeat=3)
    mp = cp.mass_properties(c[:10], r[:10], RHO, method=method)
    assert mp.principal_axes.shape == (10, 3, 3)
    row[method] = {"per_s_wall": M / tw, "per_s_cpu": M / tc}
    print(f"  {method:9s} {M / tw:12,.0f} dimers/s wall ({M / tc:,.0f} /s CPU)")
res["dimers"] = row
res["loadavg_end"] = os.getloadavg()
os.makedirs(os.path.dirname(OUT), exist_ok=True)
if not QUICK:
    with open(OUT, "w") as f:
        json.dump(res, f, indent=1)
    print(f"\nwritten {OUT}")
