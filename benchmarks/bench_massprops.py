"""Benchmarks of the mass-property methods, measured side by side in one run.

Run:  .venv/bin/python -m benchmarks.bench_massprops [--quick]

Prints (and writes to benchmarks/results/massprops.json):
 1. pairwise / exact / sum on 10^6 dimers, including principal axes (one core);
 2. pairwise vs montecarlo at 10^6 samples on the paper's dimer;
 3. pairwise vs YADE's own O.bodies.appendClumped(..., discretization=d), d = 5, 10, 20,
    with YADE's mass and inertia errors (and our voxel baseline's agreement with YADE);
 4. exact on 10-sphere clumps with triple overlaps (clumps/s);
 5. exact time per clump for N = 2, 10, 100, 1,000 spheres;
 6. at matched wall time: error of exact vs montecarlo vs voxel.
Numbers are wall-clock on a shared machine: ratios measured in the same run are the
meaningful figures.  OMP_NUM_THREADS=1 (set below) so numpy/YADE use one core.
"""
from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import clumpprops as cp  # noqa: E402

from .harness import best_of, grain_clumps, machine, random_dimers, section, write  # noqa: E402

RHO = 1140.0
DS = 0.1333
PAPER_DIMER = (np.array([[0.0, 0.0, -DS / 4], [0.0, 0.0, DS / 4]]), np.array([DS / 2, DS / 2]))


def best_time(f, repeat=3):
    """Best wall seconds of ``repeat`` calls of ``f`` and the last call's value."""
    wall, _, out = best_of(f, repeat)
    return wall, out


def rel_err(est, ref):
    """Relative error of mass and of the inertia tensor (Frobenius norm)."""
    return (abs(est.mass - ref.mass) / ref.mass,
            float(np.linalg.norm(np.asarray(est.inertia) - ref.inertia) / np.linalg.norm(ref.inertia)))


def dimers(quick):
    """1. pairwise / exact / sum on 10^6 dimers, principal axes included: dimers/s."""
    section("1. 10^6 dimers, batch, including principal axes (one core)")
    rng = np.random.default_rng(1)
    M = 200_000 if quick else 1_000_000
    c, r = random_dimers(M, rng)
    row = {}
    for method in ("sum", "pairwise", "exact"):
        t, _ = best_time(lambda: cp.mass_properties(c, r, RHO, method=method), repeat=2)
        row[method] = M / t
        print(f"  {method:9s} {M / t:12,.0f} dimers/s   ({t:.2f} s for {M:,})")
    print(f"  pairwise / sum time ratio: {row['sum'] / row['pairwise']:.2f};  exact / pairwise: "
          f"{row['pairwise'] / row['exact']:.2f}")
    return row


def montecarlo_1e6():
    """2. the paper's dimer: pairwise against montecarlo at 10^6 samples, time and error."""
    section("2. paper's dimer: pairwise vs montecarlo at 10^6 samples")
    ref = cp.mass_properties(*PAPER_DIMER, RHO, method="pairwise")
    tp, _ = best_time(lambda: cp.mass_properties(*PAPER_DIMER, RHO, method="pairwise"), repeat=20)
    tm, mc = best_time(lambda: cp.mass_properties(*PAPER_DIMER, RHO, method="montecarlo", n_samples=10**6, seed=7),
                       repeat=1)
    em, ei = rel_err(mc, ref)
    print(f"  pairwise {tp * 1e3:.3f} ms   montecarlo(1e6) {tm * 1e3:.0f} ms   ratio {tm / tp:,.0f}x")
    print(f"  montecarlo error: mass {em:.1e} (1-sigma {mc.standard_error.mass / ref.mass:.1e}), inertia {ei:.1e}")
    return {"pairwise_s": tp, "montecarlo_s": tm, "ratio": tm / tp, "mass_rel_err": em,
            "inertia_rel_err": ei, "mass_rel_sigma": mc.standard_error.mass / ref.mass}


def yade_discretization(quick):
    """3. pairwise against YADE's appendClumped(discretization=d): YADE's time and errors (None
    without YADE)."""
    section("3. pairwise vs YADE appendClumped(discretization=d)")
    try:
        import yade  # noqa: F401
        from yade import O, utils
        from yade.wrapper import FrictMat
    except Exception as exc:  # pragma: no cover
        print(f"  YADE not importable ({exc}); skipped")
        return None
    ref = cp.mass_properties(*PAPER_DIMER, RHO, method="pairwise")
    n_cl = 50 if quick else 200
    yrows = []
    tp_one, _ = best_time(lambda: cp.mass_properties(*PAPER_DIMER, RHO, method="pairwise"), repeat=50)
    for d in (0, 5, 10, 20):
        O.reset()
        mat = O.materials.append(FrictMat(young=1e7, poisson=0.4, density=RHO))
        t0 = time.perf_counter()
        for k in range(n_cl):
            off = np.array([k * 1.0, 0.0, 0.0])
            sp = [utils.sphere(tuple(map(float, PAPER_DIMER[0][i] + off)), float(PAPER_DIMER[1][i]), material=mat)
                  for i in range(2)]
            cid, _ = O.bodies.appendClumped(sp, discretization=d)
        ty = (time.perf_counter() - t0) / n_cl
        st = O.bodies[cid].state
        y_mass = st.mass
        y_I = np.sort(np.array(st.inertia))
        em = y_mass / ref.mass - 1
        eI = y_I / ref.principal_moments - 1
        ours = (cp.mass_properties(*PAPER_DIMER, RHO, method="voxel", discretization=d) if d
                else cp.mass_properties(*PAPER_DIMER, RHO, method="sum"))
        agree = abs(ours.mass / y_mass - 1)
        print(f"  d={d:2d}: YADE {ty * 1e3:7.3f} ms/clump ({ty / tp_one:8.1f}x pairwise)   mass err {em:+.2%}   "
              f"I_axial {eI[0]:+.2%}  I_perp {eI[2]:+.2%}   clumpprops voxel/sum vs YADE mass: {agree:.1e}")
        yrows.append({"discretization": d, "yade_s_per_clump": ty, "ratio_to_pairwise": ty / tp_one, "mass_err": em,
                      "I_axial_err": float(eI[0]), "I_perp_err": float(eI[2]), "our_voxel_vs_yade_mass": agree})
    print(f"  (pairwise: {tp_one * 1e3:.3f} ms for one clump; exact error 0 by construction)")
    return yrows


def exact_10_spheres(quick):
    """4. exact on 10-sphere clumps with triple overlaps: clumps/s."""
    section("4. exact on 10-sphere clumps with triple overlaps")
    rng = np.random.default_rng(4)
    M = 500 if quick else 2000
    rows4 = {}
    for label, k in (("grain (~4 overlapping neighbours)", 4.0), ("dense (~8 overlapping neighbours)", 8.0)):
        c, r = grain_clumps(M, 10, rng, overlap_neighbours=k)
        t, _ = best_time(lambda: cp.mass_properties(c, r, RHO), repeat=2)
        try:
            cp.mass_properties(c, r, RHO, method="pairwise")
            triple = "no triple overlaps?!"
        except cp.ClumpGeometryError:
            triple = "pairwise refuses: triple overlaps present"
        print(f"  {label:36s} {M / t:8,.0f} clumps/s   ({triple})")
        rows4[label] = M / t
    return rows4


def exact_scaling():
    """5. exact: time per clump for N = 2, 10, 100, 1,000 spheres."""
    section("5. exact: time per clump vs sphere count N (grain geometry, ~4 overlapping neighbours)")
    rows5 = []
    for N in (2, 10, 100, 1000):
        reps = 1 if N >= 1000 else 3
        Mb = max(1, 2000 // N)
        c, r = grain_clumps(Mb, N, np.random.default_rng(N), 4.0)
        t, _ = best_time(lambda: cp.mass_properties(c, r, RHO), repeat=reps)
        per = t / Mb
        print(f"  N={N:5d}: {per * 1e3:9.3f} ms per clump  ({per / N * 1e6:7.1f} us per sphere; batch of {Mb})")
        rows5.append({"N": N, "s_per_clump": per})
    return rows5


def _voxel_within(c, r, budget):
    """The largest voxel discretization whose call takes at most ``budget`` s: (d, s, result)."""
    d_match, t_vx, vx = 1, None, None
    for d in range(1, 200):
        t, v = best_time(lambda: cp.mass_properties(c, r, RHO, method="voxel", discretization=d), repeat=1)
        if t > budget and d > 1:
            break
        d_match, t_vx, vx = d, t, v
    return d_match, t_vx, vx


def matched_time():
    """6. at exact's wall time on one 10-sphere clump: the errors of montecarlo and voxel."""
    section("6. matched wall time on one 10-sphere clump: exact vs montecarlo vs voxel")
    c, r = grain_clumps(1, 10, np.random.default_rng(11), 4.0)
    c, r = c[0], r[0]
    t_exact, ex = best_time(lambda: cp.mass_properties(c, r, RHO), repeat=10)
    # montecarlo: calibrate samples per second, then run with the budget of exact
    t_cal, _ = best_time(lambda: cp.mass_properties(c, r, RHO, method="montecarlo", n_samples=20_000, seed=1), repeat=2)
    n_match = max(100, int(20_000 * t_exact / t_cal))
    t_mc, mc = best_time(lambda: cp.mass_properties(c, r, RHO, method="montecarlo", n_samples=n_match, seed=2), repeat=1)
    d_match, t_vx, vx = _voxel_within(c, r, t_exact)
    em_mc, ei_mc = rel_err(mc, ex)
    em_vx, ei_vx = rel_err(vx, ex)
    print(f"  exact:      {t_exact * 1e3:7.2f} ms   error ~1e-15 (see docs/exact_accuracy.md)")
    print(f"  montecarlo: {t_mc * 1e3:7.2f} ms   n_samples={n_match:,}   mass err {em_mc:.1e}  inertia err {ei_mc:.1e}")
    print(f"  voxel:      {t_vx * 1e3:7.2f} ms   discretization={d_match}   mass err {em_vx:.1e}  inertia err {ei_vx:.1e}")
    # and what they need for 1e-3
    t_mc_big, mc_big = best_time(lambda: cp.mass_properties(c, r, RHO, method="montecarlo", n_samples=10**6, seed=3),
                                 repeat=1)
    t_vx_big, vx_big = best_time(lambda: cp.mass_properties(c, r, RHO, method="voxel", discretization=40), repeat=1)
    print(f"  for reference: montecarlo 1e6 samples {t_mc_big:.2f} s, mass err {rel_err(mc_big, ex)[0]:.1e}; "
          f"voxel d=40 {t_vx_big:.2f} s, mass err {rel_err(vx_big, ex)[0]:.1e}")
    return {
        "exact_s": t_exact,
        "montecarlo": {"s": t_mc, "n_samples": n_match, "mass_err": em_mc, "inertia_err": ei_mc},
        "voxel": {"s": t_vx, "discretization": d_match, "mass_err": em_vx, "inertia_err": ei_vx},
        "montecarlo_1e6": {"s": t_mc_big, "mass_err": rel_err(mc_big, ex)[0], "inertia_err": rel_err(mc_big, ex)[1]},
        "voxel_d40": {"s": t_vx_big, "mass_err": rel_err(vx_big, ex)[0], "inertia_err": rel_err(vx_big, ex)[1]},
    }


def main(argv=None):
    """``python -m benchmarks.bench_massprops [--quick]``."""
    quick = "--quick" in (sys.argv[1:] if argv is None else argv)
    results = machine(quick=quick)
    results["dimers_per_s"] = dimers(quick)
    results["montecarlo_1e6"] = montecarlo_1e6()
    yrows = yade_discretization(quick)
    if yrows is not None:
        results["yade_discretization"] = yrows
    results["exact_10_sphere_clumps_per_s"] = exact_10_spheres(quick)
    results["exact_scaling"] = exact_scaling()
    results["matched_time"] = matched_time()
    write("massprops.json", results)


if __name__ == "__main__":
    main()
