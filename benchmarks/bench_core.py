"""The compiled core's speed: one call, batches, dense clumps and their scaling, side by side in one run.

Run:  OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_core [--quick]

Writes benchmarks/results/core.json (not with --quick) and benchmarks/results/core_k_scaling.png.  Figures:

 1. one 10-sphere clump with triple overlaps, one Python call (median of many calls):
    method="exact" against method="sum" (the summed spheres) on the same clump;
 2. a batch of 10-sphere clumps: clumps/s;
 3. one 1,000-sphere clump with ~4 overlapping neighbours per sphere: ms (median CPU time of 300
    calls; with CLUMPPROPS_BENCH_BEFORE=<dir of another _core build>, that core alternately);
 4. time per sphere against K, the number of caps per sphere (dense clumps of 150 spheres
    with ~K overlapping neighbours each), with the fitted exponent and the ratio to K^2 log K;
 5. 10^6 random dimers, principal axes included: sum, pairwise, exact in dimers/s.

Times: wall clock and CPU time of this process (benchmarks/harness.py).
"""
from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import clumpprops as cp  # noqa: E402
from clumpprops import api  # noqa: E402

from .harness import RESULTS, best_of, grain_clumps, machine, mean_caps, per_call, random_dimers, section, write  # noqa: E402

# another build of the core (a directory holding _core*.so), measured alternately with this one in section 3
BEFORE = os.environ.get("CLUMPPROPS_BENCH_BEFORE")
PNG = os.path.join(RESULTS, "core_k_scaling.png")
RHO = 1140.0


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


def one_call(rng, quick):
    """1. one 10-sphere clump with triple overlaps, one Python call: exact against sum."""
    section("1. one 10-sphere clump with triple overlaps, one Python call")
    while True:
        c10, r10 = grain_clumps(1, 10, rng, 4.0)
        c10, r10 = c10[0], r10[0]
        try:
            cp.mass_properties(c10, r10, method="pairwise")
        except cp.ClumpGeometryError:
            break  # has triple overlaps
    n_core = 300 if quick else 3000
    tw_core, tc_core = per_call(lambda: cp.mass_properties(c10, r10, RHO), n_core)
    tw_sum, tc_sum = per_call(lambda: cp.mass_properties(c10, r10, RHO, method="sum"), n_core)
    print(f"  core exact {tw_core * 1e6:7.1f} us wall ({tc_core * 1e6:.1f} us CPU)   core sum {tw_sum * 1e6:.1f} us "
          f"({tc_sum * 1e6:.1f} us CPU)   exact / sum {tw_core / tw_sum:.1f}x wall")
    return {"core_exact_us_wall": tw_core * 1e6, "core_exact_us_cpu": tc_core * 1e6,
            "core_sum_us_wall": tw_sum * 1e6, "core_sum_us_cpu": tc_sum * 1e6,
            "exact_over_sum_wall": tw_core / tw_sum, "mean_caps_per_sphere": mean_caps(c10, r10)}


def batch(rng, quick):
    """2. a batch of 10-sphere clumps: clumps/s, exact against sum."""
    section("2. batch of 10-sphere clumps (~4 overlapping neighbours per sphere)")
    M = 20_000 if quick else 100_000
    cb, rb = grain_clumps(M, 10, rng, 4.0)
    tw, tc, _ = best_of(lambda: cp.mass_properties(cb, rb, RHO))
    tws, tcs, _ = best_of(lambda: cp.mass_properties(cb, rb, RHO, method="sum"))
    print(f"  exact {M / tw:12,.0f} clumps/s wall ({M / tc:,.0f} /s CPU);  sum {M / tws:,.0f} clumps/s wall")
    return {"clumps": M, "core_per_s_wall": M / tw, "core_per_s_cpu": M / tc, "sum_per_s_wall": M / tws}


def _alternating(cores, cl, rl, n):
    """CPU and wall seconds of ``n`` calls per core on clump (cl, rl), the cores called alternately
    (after 5 warm-up calls each) through the same API, so that all see the same load."""
    samples = {k: ([], []) for k in cores}
    for k, mod in cores.items():
        api._core = mod
        for _ in range(5):
            cp.mass_properties(cl, rl, RHO)
    for _ in range(n):
        for k, mod in cores.items():
            api._core = mod
            t0, p0 = time.perf_counter(), time.process_time()
            cp.mass_properties(cl, rl, RHO)
            samples[k][0].append(time.perf_counter() - t0)
            samples[k][1].append(time.process_time() - p0)
    api._core = cores["core"]
    return samples


def clump_1000(rng, quick):
    """3. one 1,000-sphere clump: median and quartiles of the CPU time (and another core's, alternately)."""
    section("3. one 1,000-sphere clump, ~4 overlapping neighbours per sphere")
    cl, rl = grain_clumps(1, 1000, rng, 4.0)
    cl, rl = cl[0], rl[0]
    # A single ~1.5 ms call is at the mercy of the shared machine: median and quartiles of the CPU time
    # of 300 calls (5 warm-up calls first).  With CLUMPPROPS_BENCH_BEFORE set (a directory holding another
    # build of _core, e.g. the previous commit's), that core is called alternately with this one.
    n1000 = 20 if quick else 300
    cores = {"core": api._core}
    if BEFORE:
        cores["before"] = load_core(BEFORE)
    samples = _alternating(cores, cl, rl, n1000)
    out = {"calls": n1000, "mean_caps_per_sphere": mean_caps(cl, rl)}
    for k, (w, c) in samples.items():
        q = np.percentile(np.array(c) * 1e3, [25, 50, 75])
        tw = float(np.median(w)) * 1e3
        print(f"  {k:6s} {q[1]:.2f} ms CPU (quartiles {q[0]:.2f} .. {q[2]:.2f}), {tw:.2f} ms wall; median of {n1000} calls")
        pre = "core" if k == "core" else "before"
        out.update({f"{pre}_ms_cpu": float(q[1]), f"{pre}_ms_cpu_q25": float(q[0]),
                    f"{pre}_ms_cpu_q75": float(q[2]), f"{pre}_ms_wall": tw})
    if BEFORE:
        out["before_core_dir"] = BEFORE
    print(f"  mean caps/sphere {mean_caps(cl, rl):.2f}")
    return out


def k_scaling(rng, quick):
    """4. time per sphere against K, the caps per sphere, with the fitted exponent and the plot."""
    section("4. time per sphere against K (caps per sphere)")
    rows = []
    Ks = [4, 8, 12, 16, 24, 32, 40] if not quick else [4, 8, 16, 32]
    N = 150
    for K in Ks:
        c, r = grain_clumps(4, N, rng, K)
        k_mean = float(np.mean([mean_caps(c[m], r[m]) for m in range(len(c))]))
        tw, tc, _ = best_of(lambda: cp.mass_properties(c, r, RHO), repeat=3)
        rows.append({"K_target": K, "K_mean": k_mean, "us_per_sphere_wall": tw / (4 * N) * 1e6,
                     "us_per_sphere_cpu": tc / (4 * N) * 1e6})
        print(f"  K ~ {k_mean:5.1f}: {tw / (4 * N) * 1e6:8.2f} us/sphere wall ({tc / (4 * N) * 1e6:.2f} CPU)")
    K_arr = np.array([x["K_mean"] for x in rows])
    t_arr = np.array([x["us_per_sphere_cpu"] for x in rows])
    big = K_arr >= 8
    slope = float(np.polyfit(np.log(K_arr[big]), np.log(t_arr[big]), 1)[0])
    ratio = t_arr / (K_arr**2 * np.log(K_arr))
    print(f"  fitted exponent (K >= 8): {slope:.2f};  time / (K^2 log K): {', '.join(f'{x:.3g}' for x in ratio)}")
    _plot_k_scaling(K_arr, t_arr, big, slope)
    return {"rows": rows, "spheres_per_clump": N, "fitted_exponent_K_ge_8": slope,
            "time_over_K2logK": ratio.tolist()}


def _plot_k_scaling(K_arr, t_arr, big, slope):
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


def dimers(rng, quick):
    """5. random dimers, principal axes included: sum, pairwise, exact in dimers/s."""
    section("5. 10^6 random dimers, principal axes included")
    M = 200_000 if quick else 1_000_000
    c, r = random_dimers(M, rng)
    row = {}
    for method in ("sum", "pairwise", "exact"):
        tw, tc, _ = best_of(lambda: cp.mass_properties(c, r, RHO, method=method), repeat=3)
        mp = cp.mass_properties(c[:10], r[:10], RHO, method=method)
        assert mp.principal_axes.shape == (10, 3, 3)
        row[method] = {"per_s_wall": M / tw, "per_s_cpu": M / tc}
        print(f"  {method:9s} {M / tw:12,.0f} dimers/s wall ({M / tc:,.0f} /s CPU)")
    return row


def main(argv=None):
    """``python -m benchmarks.bench_core [--quick]``."""
    quick = "--quick" in (sys.argv[1:] if argv is None else argv)
    res = machine(quick=quick)
    rng = np.random.default_rng(9)
    res["one_call_10_spheres"] = one_call(rng, quick)
    res["batch_10_spheres"] = batch(rng, quick)
    res["clump_1000"] = clump_1000(rng, quick)
    res["k_scaling"] = k_scaling(rng, quick)
    res["dimers"] = dimers(rng, quick)
    res["loadavg_end"] = os.getloadavg()
    if not quick:
        write("core.json", res)


if __name__ == "__main__":
    main()
