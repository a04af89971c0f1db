"""Cost of building exact YADE clumps vs YADE's own appendClumped, measured in one run.

    OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_yade_build            # 10^4 dimers, 10^3 20-sphere clumps
    OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_yade_build --quick    # 10x fewer

For each clump set (the same clumps in every variant, each variant in a fresh scene) it times
the whole build a user runs: creating the sphere bodies (``utils.sphere``) and clumping them,
and separately the clumping call alone (spheres made beforehand).  Variants:

  yade d=0          O.bodies.appendClumped(spheres)                  (the baseline: summed, wrong)
  yade d=10         O.bodies.appendClumped(spheres, discretization=10)  (voxelised, approximate)
  append_clump      clumpprops.yade.append_clump(spheres), one call per clump
  append_clumps     clumpprops.yade.append_clumps(list of sphere lists), one call for all
  yade + correct    appendClumped(d=0) for all, then clumpprops.yade.correct_all_clumps()

Times are CPU seconds of this process (time.process_time; the machine is shared), the minimum
over ``--repeat`` rounds (default 3; each round runs every variant once, so a change of load hits
all variants), ratios are to "yade d=0" in the same run; "(rounds)" is the median over the rounds
of the full-build ratio taken round by round; every sample is kept in the JSON.  The error
columns compare each clump's YADE state with the exact library values: max relative mass error
and max |I - I_exact| / max(I_exact) over the set.
"""
import argparse
import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
import yade
from yade import utils
from yade.wrapper import FrictMat

import clumpprops
from clumpprops import yade as cy

from .harness import write

O = yade.O
RHO = 1140.0


def dimers(n, rng):
    d = 0.1333
    out = []
    for k in range(n):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        c0 = np.array([k % 100, (k // 100) % 100, k // 10000], float) * 0.3
        out.append((c0 + np.outer([-0.5, 0.5], u) * d / 2, np.array([d / 2, d / 2])))
    return out


def big_clumps(n, rng, n_spheres=20, scale=0.05):
    out = []
    for k in range(n):
        c, r = [np.zeros(3)], [scale * rng.uniform(0.6, 1.0)]
        while len(c) < n_spheres:
            j = rng.integers(len(c))
            rn = scale * rng.uniform(0.4, 1.0)
            u = rng.normal(size=3)
            u /= np.linalg.norm(u)
            c.append(c[j] + u * (r[j] + rn) * rng.uniform(0.3, 0.8))
            r.append(rn)
        c0 = np.array([k % 30, (k // 30) % 30, k // 900], float) * 1.0
        out.append((np.array(c) + c0, np.array(r)))
    return out


def fresh():
    O.reset()
    O.materials.append(FrictMat(density=RHO, young=1e7, poisson=0.4, label="m"))


def spheres_of(geo):
    return [[utils.sphere(tuple(x), float(rr), material="m") for x, rr in zip(c, r)] for c, r in geo]


def build(variant, lists):
    if variant == "yade d=0":
        return [O.bodies.appendClumped(s)[0] for s in lists]
    if variant == "yade d=10":
        return [O.bodies.appendClumped(s, discretization=10)[0] for s in lists]
    if variant == "append_clump":
        return [cy.append_clump(s)[0] for s in lists]
    if variant == "append_clumps":
        return [c for c, _ in cy.append_clumps(lists)]
    if variant == "yade + correct":
        ids = [O.bodies.appendClumped(s)[0] for s in lists]
        cy.correct_all_clumps()
        return ids
    raise ValueError(variant)


def errors(ids, ref):
    em = ei = 0.0
    for k, cid in enumerate(ids):
        st = O.bodies[cid].state
        m = st.ori.toRotationMatrix()
        R = np.array([[float(m[i, j]) for j in range(3)] for i in range(3)])
        I = R @ np.diag([float(a) for a in st.inertia]) @ R.T
        em = max(em, abs(float(st.mass) / ref.mass[k] - 1))
        ei = max(ei, float(np.max(np.abs(I - ref.inertia[k])) / np.max(ref.principal_moments[k])))
    return em, ei


VARIANTS = ["yade d=0", "yade d=10", "append_clump", "append_clumps", "yade + correct"]


def bench(name, geo, variants=VARIANTS, repeat=3):
    ref = clumpprops.mass_properties([c for c, _ in geo], [r for _, r in geo], RHO)
    print(f"\n{name}: {len(geo)} clumps ({sum(len(r) for _, r in geo)} spheres), method='exact', "
          f"min of {repeat} rounds")
    samples = {v: {"full": [], "call": []} for v in variants}
    errs = {}
    for _ in range(repeat):
        for v in variants:
            # (1) the whole build: make the spheres and clump them
            fresh()
            t0 = time.process_time()
            ids = build(v, spheres_of(geo))
            samples[v]["full"].append(time.process_time() - t0)
            if v not in errs:
                errs[v] = errors(ids, ref)
            # (2) the clumping call alone (spheres made before the clock starts)
            fresh()
            lists = spheres_of(geo)
            t0 = time.process_time()
            build(v, lists)
            samples[v]["call"].append(time.process_time() - t0)
    print(f"{'variant':>16} {'full build [s]':>15} {'ratio':>7} {'(rounds)':>9} {'clump call [s]':>15} {'ratio':>7} "
          f"{'mass err':>9} {'inertia err':>11}")
    base = {k: min(samples["yade d=0"][k]) for k in ("full", "call")}
    rows = {}
    for v in variants:
        full, call = min(samples[v]["full"]), min(samples[v]["call"])
        # the same ratio round by round (variant and baseline measured minutes apart at most): its median
        per_round = float(np.median(np.array(samples[v]["full"]) / np.array(samples["yade d=0"]["full"])))
        rows[v] = {"full": full, "call": call, "ratio_full": full / base["full"], "ratio_call": call / base["call"],
                   "ratio_full_median_of_rounds": per_round,
                   "samples": samples[v], "mass_err": errs[v][0], "inertia_err": errs[v][1]}
        print(f"{v:>16} {full:15.3f} {full / base['full']:7.2f} {per_round:9.2f} {call:15.3f} {call / base['call']:7.2f} "
              f"{errs[v][0]:9.1e} {errs[v][1]:11.1e}", flush=True)
    O.reset()
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="10x fewer clumps")
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--repeat", type=int, default=3, help="rounds; the minimum CPU time of each variant is reported")
    a = ap.parse_args()
    f = 10 if a.quick else 1
    rng = np.random.default_rng(a.seed)
    print(f"YADE {yade.config.version}, clumpprops {clumpprops.__version__}, python {sys.version.split()[0]}, "
          f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS')}, CPU times (time.process_time)")
    out = {"yade": str(yade.config.version), "clumpprops": clumpprops.__version__, "quick": a.quick,
           "date": time.strftime("%Y-%m-%d %H:%M"), "loadavg_start": os.getloadavg(),
           "repeat": a.repeat,
           "columns": "variant: full/call = min CPU s over the rounds (whole build / clumping call alone), "
                      "ratio_* to 'yade d=0', samples = every round, *_err = max relative error vs the library"}
    out["dimers"] = bench("paper dimers (d = 0.1333 m, D = d/2)", dimers(10_000 // f, rng), repeat=a.repeat)
    out["clumps20"] = bench("20-sphere clumps (triple overlaps)", big_clumps(1_000 // f, rng), repeat=a.repeat)
    out["loadavg_end"] = os.getloadavg()
    if not a.quick:
        write("yade_build.json", out)


if __name__ == "__main__":
    main()
