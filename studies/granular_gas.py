"""Driver for the paper's granular-gas study (issue 5): sweep, analysis, figures.

    .venv/bin/python -m studies.granular_gas run                 # quick Fig. 2 (~13 min, 2 cores)
    .venv/bin/python -m studies.granular_gas run --scale paper   # the committed results (~80 min)
    .venv/bin/python -m studies.granular_gas status --scale paper
    .venv/bin/python -m studies.granular_gas analyze --scale paper   # CSVs from finished runs
    .venv/bin/python -m studies.granular_gas plot --out results/granular_gas  # PNGs from CSVs

``run`` = sweep + analyze + plot.  Each run is one ``yade -n -x yade_scripts/granular_gas.py``
process (one thread) fed through ``YADE_BATCH=<table>:<line>`` (readParamsFromTable);
``--jobs`` of them run side by side.  A run is identified by its parameters and the code
version (hash of the YADE script and studies/gas_model.py): finished runs are skipped,
a run's files are written atomically (JSON last = the completion marker), the children die
with the driver (PR_SET_PDEATHSIG), and a restarted sweep redoes only what is missing.
"""
from __future__ import annotations

import argparse
import ctypes
import fcntl
import hashlib
import json
import os
import re
import signal
import subprocess
import sys
import time

from . import gas_model as gm

ROOT = gm.repo_root()
SCRIPT = os.path.join(ROOT, "yade_scripts", "granular_gas.py")
DEFAULT_OUT = os.path.join(ROOT, "results", "granular_gas")

MAIN = ("exact", "uncorrected", "spheres")
SECONDARY = ("mass_only", "inertia_only")

# a group = (cases, protocol, seeds); every group shares n_particles, t_end, ...
SCALES = {
    # smoke/test scale: 27 particles in a box at volume fraction 0.02 (collisions happen)
    "tiny": dict(n_particles=27, volume_fraction=0.02, t_end=20.0, rec_interval=0.25,
                 groups=[(MAIN + SECONDARY, "paired", [1, 2]), (("uncorrected",), "equal_energy", [1, 2])],
                 t_eq=2.0, fit_lo=5.0, fit_hi=9.0),
    # quick Fig. 2: the paper's gas, 2 seeds x 5 cases x 250 s (~13 min on 2 free cores);
    # its D comes from lags 60-100 s, before the MSD is fully linear: indicative only
    "quick": dict(n_particles=864, volume_fraction=gm.VOLUME_FRACTION, t_end=250.0, rec_interval=0.25,
                  groups=[(MAIN + SECONDARY, "paired", [1, 2])],
                  t_eq=50.0, fit_lo=60.0, fit_hi=100.0),
    # paper scale (the committed results): 400 s per run; groups in priority order (a sweep
    # stopped early still has the main comparison): 3 seeds of exact/uncorrected/spheres, then
    # 2 seeds of the open-question cases and of the equal-energy protocol, then 5 more main
    # seeds (~80 min on 2 free cores)
    "paper": dict(n_particles=864, volume_fraction=gm.VOLUME_FRACTION, t_end=400.0, rec_interval=0.25,
                  groups=[(MAIN, "paired", [1, 2, 3]), (SECONDARY, "paired", [1, 2]),
                          (("uncorrected", "inertia_only"), "equal_energy", [1, 2]),
                          (MAIN, "paired", [4, 5, 6, 7, 8])],
                  t_eq=50.0, fit_lo=125.0, fit_hi=175.0,
                  # robustness of D to the analysis choices: (t_eq, fit_lo, fit_hi)
                  sensitivity=[[50.0, 125.0, 175.0], [100.0, 100.0, 150.0], [50.0, 75.0, 175.0],
                               [0.0, 125.0, 200.0]]),
}
RUN_FIELDS = ("case", "protocol", "seed", "n_particles", "volume_fraction", "energy_per_particle",
              "t_end", "rec_interval", "dt_factor", "energy_tol", "momentum_tol", "builder")


def scale_config(scale: str, **over):
    cfg = json.loads(json.dumps(SCALES[scale]))
    cfg.update({k: v for k, v in over.items() if v is not None})
    cfg.setdefault("energy_per_particle", gm.ENERGY_PER_PARTICLE)
    cfg.setdefault("dt_factor", 0.5)
    cfg.setdefault("energy_tol", 1e-3)
    cfg.setdefault("momentum_tol", 1e-9)
    cfg.setdefault("builder", "auto")
    cfg["scale"] = scale
    return cfg


def run_specs(cfg):
    """All runs of a configuration in priority order: group by group, seed by seed."""
    specs, seen = [], set()
    for cases, protocol, ss in cfg["groups"]:
        for seed in ss:
            for case in cases:
                spec = {k: cfg[k] for k in RUN_FIELDS if k in cfg}
                spec.update(case=case, protocol=gm.effective_protocol(case, protocol), seed=seed)
                key = run_key(spec)
                if key not in seen:
                    seen.add(key)
                    specs.append(spec)
    return specs


def run_key(spec, version=None):
    payload = json.dumps({k: spec[k] for k in RUN_FIELDS}, sort_keys=True) + (version or gm.code_version())
    return hashlib.sha256(payload.encode()).hexdigest()[:12]


def run_name(spec, version=None):
    return f"{spec['case']}-{spec['protocol']}-s{spec['seed']}-{run_key(spec, version)}"


def is_complete(runs_dir, spec, version=None):
    path = os.path.join(runs_dir, run_name(spec, version) + ".json")
    if not os.path.exists(path):
        return False
    try:
        with open(path) as f:
            res = json.load(f)
    except (OSError, ValueError):
        return False
    if res.get("code_version") != (version or gm.code_version()):
        return False
    if res.get("params", {}).get("record", 1) and not res.get("crashed"):
        return os.path.exists(os.path.join(runs_dir, run_name(spec, version) + ".npz"))
    return True


def write_atomic(path, text):
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _die_with_parent():
    try:
        ctypes.CDLL("libc.so.6").prctl(1, signal.SIGTERM)   # PR_SET_PDEATHSIG
    except OSError:
        pass


def _table_value(v):
    # readParamsFromTable eval()s each whitespace-separated cell
    r = repr(v)
    if any(c.isspace() for c in r):
        raise ValueError(f"table value {r} contains whitespace")
    return r


def launch(spec, runs_dir, name, progress_period=20.0):
    """Start one YADE process for ``spec``; returns the Popen."""
    table = os.path.join(runs_dir, name + ".table")
    cols = list(RUN_FIELDS) + ["out", "progress_period"]
    vals = [spec[k] for k in RUN_FIELDS] + [os.path.join(runs_dir, name), progress_period]
    write_atomic(table, " ".join(cols) + "\n" + " ".join(_table_value(v) for v in vals) + "\n")
    env = dict(os.environ, OMP_NUM_THREADS="1", YADE_BATCH=f"{table}:2", CLUMPPROPS_ROOT=ROOT)
    log = open(os.path.join(runs_dir, name + ".log"), "w")
    return subprocess.Popen(["yade", "-n", "-x", SCRIPT], stdout=log, stderr=subprocess.STDOUT,
                            stdin=subprocess.DEVNULL, env=env, cwd=runs_dir, preexec_fn=_die_with_parent)


def last_progress(log_path):
    try:
        with open(log_path, "rb") as f:
            f.seek(0, 2)
            f.seek(max(0, f.tell() - 4000))
            tail = f.read().decode(errors="replace")
    except OSError:
        return None
    m = re.findall(r"PROGRESS t=([\d.]+) t_end=([\d.]+) steps_per_s=(\d+) eta_s=(\d+)", tail)
    return tuple(float(x) for x in m[-1]) if m else None


def _fmt_s(s):
    s = int(s)
    return f"{s // 3600}h{s % 3600 // 60:02d}m" if s >= 3600 else f"{s // 60}m{s % 60:02d}s"


def sweep(cfg, out, jobs=2, progress_every=30.0, log=print):
    """Run every missing run of ``cfg`` into ``out/runs``; returns the number of runs made."""
    runs_dir = os.path.join(out, "runs")
    os.makedirs(runs_dir, exist_ok=True)
    lock = open(os.path.join(runs_dir, ".sweep.lock"), "w")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        raise SystemExit(f"another sweep is running in {runs_dir}")
    for f in os.listdir(runs_dir):          # debris of a killed sweep: partial temp files
        if ".tmp" in f:
            os.remove(os.path.join(runs_dir, f))
    version = gm.code_version()
    specs = run_specs(cfg)
    todo = [s for s in specs if not is_complete(runs_dir, s, version)]
    log(f"[sweep] {len(specs)} runs in {cfg['scale']} scale, {len(specs) - len(todo)} already complete, "
        f"{len(todo)} to do, {jobs} at a time; code version {version}; results in {runs_dir}")
    running = {}
    done = 0
    t_start = time.time()
    last_report = 0.0
    sim_total = sum(s["t_end"] for s in todo)
    sim_done = 0.0

    def stop(signum, frame):
        for p, _ in running.values():
            p.terminate()
        raise SystemExit(f"[sweep] stopped by signal {signum}; finished runs are kept, rerun to resume")

    old = {s: signal.signal(s, stop) for s in (signal.SIGTERM, signal.SIGINT)}
    try:
        while todo or running:
            while todo and len(running) < jobs:
                spec = todo.pop(0)
                name = run_name(spec, version)
                running[name] = (launch(spec, runs_dir, name), spec)
                log(f"[sweep] start {name}")
            time.sleep(1.0)
            for name, (p, spec) in list(running.items()):
                rc = p.poll()
                if rc is None:
                    continue
                del running[name]
                sim_done += spec["t_end"]
                done += 1
                jpath = os.path.join(runs_dir, name + ".json")
                if rc != 0 or not os.path.exists(jpath):
                    res = {"params": spec, "code_version": version, "ok": False, "crashed": True,
                           "fail_reasons": [f"yade exited with code {rc} (see {name}.log)"]}
                    write_atomic(jpath, json.dumps(res, indent=1))
                    log(f"[sweep] FAILED {name}: yade exited with code {rc}")
                else:
                    with open(jpath) as f:
                        res = json.load(f)
                    flag = "ok" if res.get("ok", True) else "FLAGGED " + "; ".join(res.get("fail_reasons", []))
                    log(f"[sweep] done {name}: {flag}, energy drift {res.get('energy_drift', float('nan')):.2g}, "
                        f"{res.get('steps_per_s', 0):.0f} steps/s, {res.get('wall_run_s', 0):.0f} s wall")
            now = time.time()
            if running and now - last_report >= progress_every:
                last_report = now
                parts, sim_now = [], sim_done
                for name, (p, spec) in running.items():
                    pr = last_progress(os.path.join(runs_dir, name + ".log"))
                    if pr:
                        t, t_end, sps, eta = pr
                        sim_now += t
                        parts.append(f"{spec['case']}/{spec['protocol'][:5]}/s{spec['seed']} "
                                     f"t={t:.0f}/{t_end:.0f}s {sps:.0f} steps/s eta {_fmt_s(eta)}")
                    else:
                        parts.append(f"{spec['case']}/s{spec['seed']} starting")
                el = now - t_start
                eta = el / sim_now * (sim_total - sim_now) if sim_now > 0 else float("nan")
                eta_s = _fmt_s(eta) if eta == eta else "?"
                log(f"[sweep] {done}/{done + len(todo) + len(running)} runs done, {_fmt_s(el)} elapsed, "
                    f"sweep eta {eta_s} | " + " | ".join(parts))
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        fcntl.flock(lock, fcntl.LOCK_UN)
        lock.close()
    log(f"[sweep] finished {done} runs in {_fmt_s(time.time() - t_start)}")
    return done


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m studies.granular_gas", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", choices=("run", "sweep", "analyze", "plot", "status"))
    ap.add_argument("--scale", choices=tuple(SCALES), default="quick")
    ap.add_argument("--out", default=None, help="results folder (default results/granular_gas, "
                    "or results/granular_gas_quick for --scale quick)")
    ap.add_argument("--jobs", type=int, default=2, help="YADE processes side by side (1 thread each)")
    ap.add_argument("--t-end", type=float, default=None, help="override simulated seconds per run")
    ap.add_argument("--n-particles", type=int, default=None)
    ap.add_argument("--seeds", type=str, default=None, help="comma-separated subset of the scale's seeds")
    a = ap.parse_args(argv)
    cfg = scale_config(a.scale, t_end=a.t_end, n_particles=a.n_particles)
    if a.seeds:
        keep = {int(x) for x in a.seeds.split(",")}
        cfg["groups"] = [(c, p, [s for s in ss if s in keep]) for c, p, ss in cfg["groups"]]
    out = a.out or (DEFAULT_OUT if a.scale == "paper" else f"{DEFAULT_OUT}_{a.scale}")
    t0 = time.time()
    if a.command in ("run", "sweep"):
        sweep(cfg, out, jobs=a.jobs)
    if a.command == "status":
        runs_dir = os.path.join(out, "runs")
        specs = run_specs(cfg)
        n = sum(is_complete(runs_dir, s) for s in specs)
        print(f"{n}/{len(specs)} runs complete in {runs_dir}")
        return 0
    if a.command in ("run", "analyze"):
        from . import gas_analysis
        gas_analysis.analyze(cfg, out, wall_sweep_s=(time.time() - t0) if a.command == "run" else None)
    if a.command in ("run", "plot"):
        from . import gas_plots
        gas_plots.plot_all(out)
    if a.command == "run":
        print(f"[run] total wall time {_fmt_s(time.time() - t0)}; results in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
