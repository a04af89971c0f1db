"""Granular-gas study benchmarks (issue 5).

1. Recording overhead: the paper's 864-dimer gas (case ``exact``) run by
   yade_scripts/granular_gas.py with recording + checks (``record=1``) and bare
   (``record=0``: same scene and engines, no recording PyRunner), the two processes side
   by side on the two cores, repeated with the roles' start order swapped.
2. MSD analysis cost vs trajectory length T (864 particles): the FFT routine against the
   O(T^2) definition; fitted exponents.
3. Wall times of the study commands, read from the sweeps' params.json when present.

    .venv/bin/python benchmarks/bench_gas.py [--t-end 20] [--repeats 2] [--skip-yade]

Writes benchmarks/results/bench_gas.json and prints a Markdown table.  The machine is
shared: steps/s depend on what else runs; the side-by-side pairs see the same load.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from studies.msd import msd_bruteforce, msd_fft  # noqa: E402

SCRIPT = os.path.join(ROOT, "yade_scripts", "granular_gas.py")


def start(tmp, name, **params):
    params = dict(params, out=os.path.join(tmp, name), progress_period=1000.0)
    table = os.path.join(tmp, name + ".table")
    with open(table, "w") as f:
        f.write(" ".join(params) + "\n" + " ".join(repr(v) for v in params.values()) + "\n")
    env = dict(os.environ, OMP_NUM_THREADS="1", YADE_BATCH=f"{table}:2")
    return subprocess.Popen(["yade", "-n", "-x", SCRIPT], env=env, cwd=tmp, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)


def bench_overhead(t_end, repeats, case="exact"):
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(repeats):
            order = [("rec", 1), ("bare", 0)] if r % 2 == 0 else [("bare", 0), ("rec", 1)]
            procs = {lab: start(tmp, f"{lab}{r}", case=case, t_end=t_end, record=rec) for lab, rec in order}
            for lab, p in procs.items():
                if p.wait() != 0:
                    raise RuntimeError(f"yade run {lab}{r} failed")
            res = {}
            for lab, _ in order:
                with open(os.path.join(tmp, f"{lab}{r}.json")) as f:
                    res[lab] = json.load(f)
            rows.append({"repeat": r, "steps": res["rec"]["n_steps"],
                         "steps_per_s_recorded": res["rec"]["steps_per_s"],
                         "steps_per_s_bare": res["bare"]["steps_per_s"],
                         "overhead": res["bare"]["steps_per_s"] / res["rec"]["steps_per_s"] - 1,
                         "energy_drift": res["rec"]["energy_drift"]})
            print(f"[bench] overhead pair {r}: recorded {rows[-1]['steps_per_s_recorded']:.0f} steps/s, "
                  f"bare {rows[-1]['steps_per_s_bare']:.0f} steps/s, overhead {100 * rows[-1]['overhead']:+.1f} %",
                  flush=True)
    return rows


def bench_msd(lengths=(250, 500, 1000, 2000, 4000, 8000), brute_max=1000, n=864):
    rng = np.random.default_rng(0)
    rows = []
    for T in lengths:
        x = np.cumsum(rng.normal(size=(T, n, 3)), axis=0).astype(np.float32)
        t0 = time.perf_counter()
        a = msd_fft(x)
        t_fft = time.perf_counter() - t0
        t_bf = np.nan
        if T <= brute_max:
            t0 = time.perf_counter()
            b = msd_bruteforce(x)
            t_bf = time.perf_counter() - t0
            assert np.allclose(a, b, rtol=1e-6, atol=1e-6)
        rows.append({"frames": T, "particles": n, "fft_s": t_fft, "bruteforce_s": t_bf})
        print(f"[bench] MSD T={T}: fft {t_fft:.3f} s, brute force {t_bf:.3f} s", flush=True)
    T = np.array([r["frames"] for r in rows], float)
    f = np.array([r["fft_s"] for r in rows])
    b = np.array([r["bruteforce_s"] for r in rows])
    ok = np.isfinite(b)
    exp_fft = float(np.polyfit(np.log(T[T >= 1000]), np.log(f[T >= 1000]), 1)[0])
    exp_bf = float(np.polyfit(np.log(T[ok]), np.log(b[ok]), 1)[0]) if ok.sum() > 1 else np.nan
    return rows, exp_fft, exp_bf


def study_walls():
    out = {}
    for scale, folder in (("quick", "granular_gas_quick"), ("paper", "granular_gas")):
        p = os.path.join(ROOT, "results", folder, "params.json")
        if os.path.exists(p):
            with open(p) as f:
                j = json.load(f)
            out[scale] = {"wall_sweep_s": j.get("wall_sweep_s"), "wall_run_s_total": j.get("wall_run_s_total"),
                          "n_runs": j.get("n_runs"), "t_end": j.get("t_end")}
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--t-end", type=float, default=20.0)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--skip-yade", action="store_true")
    a = ap.parse_args()
    res = {"machine": os.uname().nodename, "cpus": os.cpu_count(),
           "load_avg_at_start": os.getloadavg()}
    if not a.skip_yade:
        rows = bench_overhead(a.t_end, a.repeats)
        res["overhead"] = rows
        res["overhead_mean"] = float(np.mean([r["overhead"] for r in rows]))
    rows, ef, eb = bench_msd()
    res.update(msd=rows, msd_fft_exponent=ef, msd_bruteforce_exponent=eb)
    res["study_walls"] = study_walls()
    os.makedirs(os.path.join(ROOT, "benchmarks", "results"), exist_ok=True)
    with open(os.path.join(ROOT, "benchmarks", "results", "bench_gas.json"), "w") as f:
        json.dump(res, f, indent=1, default=float)
    print("\n| benchmark | result |\n|---|---|")
    if "overhead" in res:
        for r in res["overhead"]:
            print(f"| 864-dimer gas, {r['steps']} steps, pair {r['repeat']} | recorded {r['steps_per_s_recorded']:.0f} "
                  f"steps/s, bare {r['steps_per_s_bare']:.0f} steps/s, overhead {100 * r['overhead']:+.1f} % |")
    for r in res["msd"]:
        bf = f"{r['bruteforce_s']:.2f} s" if np.isfinite(r["bruteforce_s"]) else "-"
        print(f"| MSD, {r['frames']} frames x 864 | FFT {r['fft_s']:.2f} s, brute force {bf} |")
    print(f"| MSD cost exponent (T >= 1000) | FFT {ef:.2f}, brute force {eb:.2f} |")
    for k, v in res["study_walls"].items():
        print(f"| {k} sweep | {v} |")


if __name__ == "__main__":
    main()
