"""Gas-study benchmarks, side by side in one run.

1. Recording overhead: the paper's 864-dimer gas (case ``exact``) from one run file, with
   recording (``record: true``) and bare (no recording PyRunner), two YADE processes side by
   side on the two cores, repeated with the start order swapped.  Target: recorded steps/s
   >= 0.95 x bare.
2. Correction bodies: the exact dimer as the study builds it now (``appendClumped`` with the
   exact mass and I_perp set: 3 bodies per clump) against the first version's build
   (``clumpprops.yade.append_clump``: one extra correction member per clump), side by side.
2b. Collider padding: the study's ``verletDist`` (three bounding radii, capped by the cell and
   the member spacing, set by the gas script)
   against YADE's default (run file ``verlet_dist = -0.5``), side by side; the trajectories are
   the same to the last bit (tests/test_study_engine.py), so this is speed only.
3. Driver + Dask overhead per run: a sweep of N tiny runs (27 particles, 1.5 s) on a
   LocalCluster of one worker; overhead = (sweep wall - sum of the YADE processes' wall) / N.
   Target: <= 1 s per run.
4. MSD analysis cost vs trajectory length T (864 particles): the FFT routine against the
   O(T^2) definition; fitted exponents.

    .venv/bin/python -m benchmarks.bench_gas [--t-end 20] [--repeats 2] [--n-runs 8] [--skip-yade]
                                             [--parts recording,collider,correction,driver,msd]

Writes benchmarks/results/bench_gas.json (the parts run replace theirs; the others are kept) and
prints a Markdown table.  The machine is
shared: steps/s depend on what else runs; the side-by-side pairs see the same load.
"""
from __future__ import annotations

import argparse
import copy
import json
import os
import subprocess
import tempfile
import time
import tomllib

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
from studies import engine, manifest
from studies import spec as S
from studies.correlation import msd_bruteforce, msd_fft

from .harness import read, write

SCRIPT = os.path.join(ROOT, "yade_scripts", "granular_gas.py")


def paper_run_input(t_end):
    sp = S.load(os.path.join(S.SPEC_DIR, "paper.toml"))
    run = next(r for r in S.runs(sp) if r["case"] == "exact" and r["seed"] == 1)
    p = copy.deepcopy(run["params"])
    p["run"]["t_end"] = t_end
    return S.run_input(p, progress_period=1000.0)


def start(tmp, name, rin):
    path = os.path.join(tmp, name + ".run.json")
    with open(path, "w") as f:
        json.dump(rin, f)
    table = os.path.join(tmp, name + ".table")
    with open(table, "w") as f:
        f.write(f"run out\n{path!r} {os.path.join(tmp, name)!r}\n")
    env = dict(os.environ, OMP_NUM_THREADS="1", YADE_BATCH=f"{table}:2")
    return subprocess.Popen(["yade", "-n", "-x", SCRIPT], env=env, cwd=tmp, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)


def side_by_side(t_end, repeats, variants):
    """steps/s of two run-file variants {label: run_input} run as simultaneous pairs."""
    rows = []
    labels = list(variants)
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(repeats):
            order = labels if r % 2 == 0 else labels[::-1]
            procs = {lab: start(tmp, f"{lab}{r}", variants[lab]) for lab in order}
            cpu = {}
            for lab, p in procs.items():
                _, status, ru = os.wait4(p.pid, 0)      # the process's own CPU time: robust to a loaded machine
                p.returncode = os.waitstatus_to_exitcode(status)
                if p.returncode != 0:
                    raise RuntimeError(f"yade run {lab}{r} failed")
                cpu[lab] = ru.ru_utime + ru.ru_stime
            res = {}
            for lab in labels:
                with open(os.path.join(tmp, f"{lab}{r}.json")) as f:
                    res[lab] = json.load(f)
            row = {"repeat": r, "steps": res[labels[0]]["n_steps"]}
            for lab in labels:
                row[f"steps_per_s_{lab}"] = res[lab]["steps_per_s"]
                row[f"bodies_{lab}"] = res[lab]["n_bodies"]
                row[f"cpu_s_{lab}"] = cpu[lab]
            row["ratio"] = res[labels[0]]["steps_per_s"] / res[labels[1]]["steps_per_s"]
            row["cpu_ratio"] = cpu[labels[0]] / cpu[labels[1]]     # whole process, YADE's start-up included
            rows.append(row)
            print(f"[bench] pair {r}: " + ", ".join(f"{lab} {row[f'steps_per_s_{lab}']:.0f} steps/s, "
                                                   f"{cpu[lab]:.1f} CPU-s" for lab in labels)
                  + f"; {labels[0]}/{labels[1]}: steps/s {row['ratio']:.3f}, CPU {row['cpu_ratio']:.3f}", flush=True)
    return rows


def bench_driver(n_runs):
    with open(os.path.join(S.SPEC_DIR, "test.toml"), "rb") as f:
        raw = tomllib.load(f)
    with tempfile.TemporaryDirectory() as tmp:
        raw["study"]["results"] = tmp
        raw["run"]["t_end"] = 1.5
        raw["analysis"].update(t_eq=0.0, fit_lo=0.1, fit_hi=0.2, max_lag=0.25, sensitivity=[])
        raw["groups"] = [{"shape": "dimer", "cases": ["exact"], "seeds": list(range(1, n_runs + 1))}]
        sp = S.validate(raw)
        sp["path"] = "bench"
        t0 = time.perf_counter()
        engine.sweep(sp, workers=1, allow_dirty=True, progress_every=1e9, log=lambda *a: None)
        wall = time.perf_counter() - t0
        rows, recs = manifest.read_manifest(tmp), []
        assert all(r["status"] == "done" for r in rows.values()), rows
        for r in rows.values():
            with open(os.path.join(tmp, r["record"])) as f:
                recs.append(json.load(f))
        yade_wall = sum(r["wall_s"] for r in recs)
        yade_inner = sum(r["facts"]["wall_setup_s"] + r["facts"]["wall_run_s"] for r in recs)
    out = {"n_runs": n_runs, "sweep_wall_s": wall, "yade_process_wall_s": yade_wall,
           "yade_in_script_s": yade_inner, "overhead_per_run_s": (wall - yade_wall) / n_runs,
           "yade_startup_per_run_s": (yade_wall - yade_inner) / n_runs}
    print(f"[bench] driver: {n_runs} runs in {wall:.1f} s, YADE processes {yade_wall:.1f} s; driver + Dask "
          f"overhead {out['overhead_per_run_s']:.2f} s per run (YADE's own start-up "
          f"{out['yade_startup_per_run_s']:.2f} s per run, not counted)", flush=True)
    return out


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


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--t-end", type=float, default=20.0)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--n-runs", type=int, default=8)
    ap.add_argument("--skip-yade", action="store_true")
    ap.add_argument("--parts", default="recording,collider,correction,driver,msd",
                    help="which benchmarks to run (comma-separated)")
    a = ap.parse_args()
    parts = set(a.parts.split(","))
    unknown = parts - {"recording", "collider", "correction", "driver", "msd"}
    if unknown:
        ap.error(f"unknown parts: {', '.join(sorted(unknown))}")
    if a.skip_yade:
        parts &= {"msd"}
    res = read("bench_gas.json")      # the parts not run keep their figures
    stamp = {"machine": os.uname().nodename, "cpus": os.cpu_count(), "load_avg_at_start": os.getloadavg(),
             "date": time.strftime("%Y-%m-%d %H:%M")}
    res.setdefault("runs_of_parts", {}).update({p: stamp for p in sorted(parts)})
    rin = paper_run_input(a.t_end) if parts - {"msd", "driver"} else None
    if "recording" in parts:
        bare = dict(rin, record=False)
        res["recording"] = side_by_side(a.t_end, a.repeats, {"recorded": rin, "bare": bare})
        res["recording_ratio_mean"] = float(np.mean([r["ratio"] for r in res["recording"]]))
    if "collider" in parts:
        res["collider"] = side_by_side(a.t_end, a.repeats, {"padded": rin, "default": dict(rin, verlet_dist=-0.5)})
        res["collider_ratio_mean"] = float(np.mean([r["ratio"] for r in res["collider"]]))
        res["collider_cpu_ratio_mean"] = float(np.mean([r["cpu_ratio"] for r in res["collider"]]))
    if "correction" in parts:
        old = copy.deepcopy(rin)
        old["body"]["builder"] = "clumpprops"
        res["correction_bodies"] = side_by_side(a.t_end, a.repeats, {"now": rin, "first_version": old})
        res["correction_ratio_mean"] = float(np.mean([r["ratio"] for r in res["correction_bodies"]]))
    if "driver" in parts:
        res["driver"] = bench_driver(a.n_runs)
    if "msd" in parts:
        rows, ef, eb = bench_msd()
        res.update(msd=rows, msd_fft_exponent=ef, msd_bruteforce_exponent=eb)
    write("bench_gas.json", res, default=float)
    print("\n| benchmark | result |\n|---|---|")
    for r in res.get("recording", []):
        print(f"| 864-dimer gas, {r['steps']} steps, pair {r['repeat']} | recorded {r['steps_per_s_recorded']:.0f} "
              f"steps/s, bare {r['steps_per_s_bare']:.0f} steps/s, ratio {r['ratio']:.3f} (target >= 0.95) |")
    for r in res.get("collider", []):
        print(f"| 864-dimer gas, {r['steps']} steps, pair {r['repeat']} | collider padded by the study's rule "
              f"{r['steps_per_s_padded']:.0f} steps/s, YADE's default {r['steps_per_s_default']:.0f} steps/s, "
              f"ratio {r['ratio']:.3f}; CPU {r['cpu_s_padded']:.1f} s against {r['cpu_s_default']:.1f} s, "
              f"ratio {r['cpu_ratio']:.3f} |")
    for r in res.get("correction_bodies", []):
        print(f"| exact dimer gas, pair {r['repeat']} | now ({r['bodies_now']} bodies) {r['steps_per_s_now']:.0f} "
              f"steps/s, first version ({r['bodies_first_version']} bodies) {r['steps_per_s_first_version']:.0f} "
              f"steps/s, ratio {r['ratio']:.3f} |")
    if "driver" in res:
        d = res["driver"]
        print(f"| driver + Dask overhead | {d['overhead_per_run_s']:.2f} s per run over {d['n_runs']} runs "
              f"(target <= 1 s) |")
    for r in res.get("msd", []):
        bf = f"{r['bruteforce_s']:.2f} s" if r["bruteforce_s"] is not None and np.isfinite(r["bruteforce_s"]) else "-"
        print(f"| MSD, {r['frames']} frames x 864 | FFT {r['fft_s']:.2f} s, brute force {bf} |")
    if "msd_fft_exponent" in res:
        print(f"| MSD cost exponent (T >= 1000) | FFT {res['msd_fft_exponent']:.2f}, brute force "
              f"{res['msd_bruteforce_exponent']:.2f} |")


if __name__ == "__main__":
    main()
