"""Command line of the gas studies: ``python -m studies COMMAND SPEC [options]``.

    run      sweep (the spec's missing runs, on Dask) + analyze + plot: the study's tables, figures
             and its own report page <results>/README.md (the project's headline report, results/README.md,
             is python -m studies.report)
    sweep    only the runs
    status   the manifest: runs done, flagged, failed, to do
    analyze  tables from the manifest and the reduced records
    plot     figures and the study's report page <results>/README.md from the tables
    prepare  write run files and a yade-batch table for running by hand (yade-batch)
    plan     validate the spec, list the runs still to do and estimate their CPU-hours (runs nothing)
    rereduce  the cooling runs whose raw frames were kept (--keep-raw, <results>/raw): the
             current reduction's HCS series in their records

SPEC is a study spec (``studies/specs/*.toml``; a bare name like ``quick`` means
``studies/specs/quick.toml``).

The studies beside the gas sweeps, each with its own options (``python -m studies NAME --help``):

    timestep              time-step convergence: collision maps and gas energy drift (results/timestep/)
    case-map              each case's effect on D from binary collisions (results/collision_map/)
    hcs-validation        cooling sphere gases against kinetic theory (results/hcs_theory.csv)
    hcs-effects           each case's effect on cooling clump gases (results/hcs_effects.csv)
    hcs-settling          each case's effect on cooling clump gases, bin by bin of scaled time (results/hcs_settling.csv)
    hcs-estimator         the cooling estimators' bias and coverage on DSMC gases (results/estimator/)
    law                   the effect as a formula in the mass and k^2 errors, checked on the gas (results/law.csv)
    gk-sensitivity        D of committed runs under other Green-Kubo truncations and tail fits (printed)
    gk-boltzmann          the estimator on the linear Boltzmann equation's VACF (results/estimator/)
    vacf-shape            the hard-sphere gas's VACF shape and the tail fit (results/estimator/)
    estimator-validation  the estimators on Ornstein-Uhlenbeck walkers with known D (results/estimator/)
    pair-correlation      the correlation over seeds of D in paired runs (printed; results/pairing/)
    predict               each case's effect for a spec's shapes from binary collisions (results/predictions.csv)

``make science`` reruns those that write results (CPU-hours; docs/benchmarks.md lists them).
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
import time

from . import spec as S


# python -m studies NAME ...: the module whose main(argv) runs study NAME
STUDIES = {"timestep": ".timestep.study", "case-map": ".maps", "gk-sensitivity": ".gk_sensitivity",
           "gk-boltzmann": ".gk_boltzmann", "vacf-shape": ".vacf_shape",
           "estimator-validation": ".estimator_validation", "pair-correlation": ".pair_correlation", "predict": ".predict",
           "hcs-validation": ".hcs_validation", "hcs-effects": ".hcs_effects", "law": ".law",
           "hcs-estimator": ".hcs_estimator", "hcs-settling": ".hcs_settling"}


def _sweep(a, spec):
    """Run the spec's missing runs (``sweep``, and the first step of ``run``); False when ``run``
    must stop there: the sweep was drained with runs left to do (a deadline drain that refused
    nothing leaves none)."""
    from . import engine

    rows = engine.sweep(spec, scheduler=a.scheduler, workers=a.workers, yade=a.yade, keep_raw=a.keep_raw,
                        allow_dirty=a.allow_dirty, max_runs=a.max_runs, progress_every=a.progress_every)
    if (a.command == "run" and os.path.exists(os.path.join(engine.results_dir(spec), engine.DRAIN))
            and any(r["status"] == "todo" for r in rows.values())):
        print(f"[run] the sweep was drained ({engine.DRAIN} in the results directory): runs remain to do, "
              "so no analysis; run again to resume", file=sys.stderr)
        return False
    return True


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and argv[0] in STUDIES:
        return importlib.import_module(STUDIES[argv[0]], __package__ or "studies").main(argv[1:]) or 0
    ap = argparse.ArgumentParser(prog="python -m studies", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", choices=("run", "sweep", "status", "analyze", "plot", "prepare", "plan",
                                           "rereduce"))
    ap.add_argument("spec", help="study spec file or name (studies/specs/NAME.toml)")
    ap.add_argument("--scheduler", default=None, help="tcp://HOST:PORT of a running Dask scheduler "
                    "(default: a LocalCluster in this process, one worker per core)")
    ap.add_argument("--workers", type=int, default=None, help="LocalCluster workers (default: cores)")
    ap.add_argument("--yade", default=os.environ.get("CLUMPPROPS_YADE", "auto"),
                    help="YADE command: auto (native yade, else the Debian 13 root for 2025.x), debian13, "
                         "or a command/path (env CLUMPPROPS_YADE)")
    ap.add_argument("--results", default=None, help="results directory (default: the spec's study.results)")
    ap.add_argument("--allow-dirty", action="store_true", help="run from a tree with uncommitted changes")
    ap.add_argument("--keep-raw", action="store_true", help="keep raw trajectories in <results>/raw (untracked)")
    ap.add_argument("--max-runs", type=int, default=None, help="run at most this many of the missing runs")
    ap.add_argument("--progress-every", type=float, default=30.0, help="seconds between progress lines")
    ap.add_argument("--out", default=None, help="prepare: directory for run files")
    a = ap.parse_args(argv)
    try:
        spec = S.load(S.spec_path(a.spec))
    except S.SpecError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if a.results:
        spec["study"]["results"] = os.path.abspath(a.results)
    from . import engine, eta

    t0 = time.time()
    if a.command == "plan":
        from . import plan
        plan.plan(spec)
        return 0
    if a.command == "prepare":
        from . import prepare
        prepare.write(spec, a.out or "runs_prepared")
        return 0
    if a.command == "rereduce":
        from . import runner
        n, skipped = runner.rereduce(engine.results_dir(spec))
        print(f"[rereduce] {n} record(s) refreshed from kept raw frames; {skipped} without raw frames left as they are")
        return 0
    if a.command in ("run", "sweep") and not _sweep(a, spec):
        return 1
    if a.command == "status":
        rows = engine.status(spec)
        from collections import Counter
        c = Counter(r["status"] for r in rows.values())
        print(f"{spec['study']['name']}: {len(rows)} runs: " + ", ".join(f"{k} {v}" for k, v in sorted(c.items())))
        for r in rows.values():
            if r["status"] in ("failed", "flagged"):
                print(f"  {r['status']}: {r['name']} (attempts {r['attempts']}): {r['error'][:200]}")
        return 0
    if a.command in ("run", "analyze", "plot"):
        from . import analysis
        problem = analysis.single_gas_problem(spec)
        if problem:        # the runs are done and kept; only the one-gas tables do not apply
            print(f"[{a.command}] no Fig. 2 tables: {problem}", file=sys.stderr)
            return 0 if a.command == "run" else 1
    if a.command in ("run", "analyze"):
        analysis.analyze(spec)
    if a.command in ("run", "plot"):
        from . import gas_plots
        from . import study_page
        gas_plots.plot_all(engine.results_dir(spec))
        study_page.write(engine.results_dir(spec))
    if a.command == "run":
        print(f"[run] total wall time {eta.fmt_s(time.time() - t0)}; results in "
              f"{os.path.relpath(engine.results_dir(spec), S.ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
