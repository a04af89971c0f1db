"""Execute one run: write its run file, run YADE (natively or in the Debian 13 root), reduce.

:func:`execute` is what a Dask task calls on a worker: it needs only the run dict of
:func:`studies.spec.runs` and a settings dict, and shares nothing with the driver but the
results directory.  It is idempotent: a run whose reduced record is already there returns it.
Every file it leaves is written atomically (temporary name, then ``os.replace``), so a worker
killed at any moment leaves no partial record; scratch files of an attempt live in their own
directory under ``scratch`` and are removed when the attempt ends.
"""
from __future__ import annotations

import ctypes
import dataclasses
import glob
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import uuid

import numpy as np

from . import reduce as red
from .reduce import is_complete, record_path  # noqa: F401  (the record's place and test, kept here for callers)
from .spec import ROOT, run_input

SCRIPT = os.path.join(ROOT, "yade_scripts", "granular_gas.py")
DEBIAN13 = os.path.join(ROOT, "scripts", "debian13.sh")
_VERSION_CACHE = {}


class RunError(RuntimeError):
    """A run that did not produce its record (YADE crashed, timed out, or was refused)."""


def write_atomic(path, text):
    d = os.path.dirname(path)
    os.makedirs(d, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=os.path.basename(path) + ".", suffix=".tmp", dir=d)
    with os.fdopen(fd, "w") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)          # mkstemp makes 0600; results are ordinary files
    os.replace(tmp, path)


def _version_of(cmd):
    """YADE version string that ``cmd --version`` prints (cached), or None."""
    key = tuple(cmd)
    if key not in _VERSION_CACHE:
        try:
            out = subprocess.run(list(cmd) + ["--version"], capture_output=True, text=True, timeout=120).stdout
            m = re.search(r"Yade version:\s*(\S+)", out)
            _VERSION_CACHE[key] = m.group(1) if m else None
        except (OSError, subprocess.TimeoutExpired):
            _VERSION_CACHE[key] = None
    return _VERSION_CACHE[key]


def _matches(found, wanted):
    return found is not None and (found == wanted or found.startswith(wanted + "."))


def yade_command(wanted, setting="auto"):
    """(command list, chrooted?) of a YADE whose version is ``wanted``.

    ``setting``: ``"auto"`` (the native ``yade`` if its version matches, else the Debian 13 root
    of ``scripts/debian13.sh`` for 2025.x), ``"debian13"``, or a command/path (``"yade"``,
    ``"/opt/yade/bin/yade"``).  Raises RunError if none gives the wanted version.
    """
    cands = []
    if setting in ("auto", None):
        if shutil.which("yade"):
            cands.append((["yade"], False))
        cands.append(([DEBIAN13, "run", "yade"], True))
    elif setting == "debian13":
        cands.append(([DEBIAN13, "run", "yade"], True))
    else:
        cands.append((setting.split(), False))
    seen = []
    for cmd, chroot in cands:
        v = _version_of(cmd)
        seen.append(f"{' '.join(cmd)} -> {v}")
        if _matches(v, wanted):
            return cmd, chroot, v
    raise RunError(f"no YADE {wanted} found ({'; '.join(seen)}); for 2025.2 on Debian 12, scripts/debian13.sh build "
                   f"makes a Debian 13 root (as root, once; runs in it need no root), or pass --yade a YADE 2025.2 command")


def _die_with_parent():
    os.setsid()
    try:
        ctypes.CDLL("libc.so.6").prctl(1, signal.SIGKILL)   # PR_SET_PDEATHSIG: die with the worker thread
    except OSError:
        pass


def git_state():
    try:
        c = subprocess.run(["git", "-C", ROOT, "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
        d = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no", "--",
                            "yade_scripts", "studies", "clumpprops"], capture_output=True, text=True).stdout.strip()
        return c, bool(d)
    except OSError:
        return "unknown", True


DRAIN = ".drain"    # a file in the results directory: the sweep drains (studies.engine.sweep)
DRAIN_MARGIN = 1.15  # under a deadline drain a run starts only if 1.15 x its expected wall time fits


def drain_deadline(results_dir):
    """The drain asked of the sweep writing to ``results_dir`` (``scripts/sweep.sh drain``): None
    (no drain file), 0.0 (drain now: an empty file), or the UNIX time [s] the file holds (``BY=HH:MM``):
    the runs must end by then, and a run that cannot does not start.  An unreadable file drains now."""
    try:
        with open(os.path.join(results_dir, DRAIN)) as f:
            text = f.read().strip()
    except FileNotFoundError:
        return None
    except OSError:
        return 0.0
    try:
        return float(text) if text else 0.0
    except ValueError:
        return 0.0


def may_start(run, results_dir, now=None):
    """False when a drain forbids ``run`` to start: a drain now, or a deadline that the run's expected
    wall time times :data:`DRAIN_MARGIN` would overshoot.  The expected wall time [s] is
    ``run["expected_wall_s"]`` if given, else from the records under ``results_dir`` finished by
    now (:func:`studies.cost.expected_wall_s_in`): the median of the runs like it, or, before the
    first of them, an upper bound from the runs at another stiffness or length.  A run of unknown
    length never fits a deadline."""
    deadline = drain_deadline(results_dir)
    if deadline is None:
        return True
    now = time.time() if now is None else now
    if deadline <= now:
        return False
    expected = run.get("expected_wall_s")
    if expected is None and "params" in run:      # from the records finished by now, not at queueing
        from .cost import expected_wall_s_in
        expected = expected_wall_s_in(results_dir, run["params"])
    return expected is not None and now + DRAIN_MARGIN * float(expected) <= deadline


def progress_path(results_dir, run_key):
    """The progress file of a run in flight: written by :func:`execute`, read by the driver (its
    progress lines, and a drain's test of "started"), removed when the run ends."""
    return os.path.join(results_dir, ".progress", run_key + ".json")


def _progress(path, **kw):
    try:
        write_atomic(path, json.dumps(dict(kw, wall=time.time(), **_owner())))
    except OSError:
        pass


def _owner():
    """Who writes a progress file or owns a scratch folder: this host and process."""
    return {"host": socket.gethostname(), "pid": os.getpid()}


def is_alive(info, stale_s=120.0):
    """True while the process that wrote ``info`` (a dict with host, pid and wall) may still run: on
    this host, while that process exists; on another host, while ``wall`` is under ``stale_s`` old."""
    if info.get("host") == socket.gethostname() and info.get("pid"):
        try:
            os.kill(int(info["pid"]), 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            pass
        try:                # a killed process its parent has not reaped yet is gone too
            with open(f"/proc/{int(info['pid'])}/stat") as f:
                return f.read().rsplit(")", 1)[1].split()[0] != "Z"
        except (OSError, IndexError):
            return True
    return time.time() - float(info.get("wall", 0.0)) < stale_s


def in_flight(results_dir, run_key):
    """The run's progress (a dict) while an attempt of it is alive (:func:`is_alive`), else None."""
    try:
        with open(progress_path(results_dir, run_key)) as f:
            p = json.load(f)
    except (OSError, ValueError):
        return None
    return p if is_alive(p, stale_s=3 * float(p.get("period", 20.0)) + 10.0) else None


def starts_path(results_dir, run_key):
    """One line per start of an attempt of the run (:func:`execute`), until the driver counts them."""
    return os.path.join(results_dir, ".attempts", run_key)


def _count_start(results_dir, run_key):
    path = starts_path(results_dir, run_key)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "a") as f:
        f.write(json.dumps(dict(_owner(), wall=time.time())) + "\n")


def take_starts(results_dir, run_key):
    """The number of attempts of the run started since the driver last counted (the scheduler's
    own retries after a lost worker included); the count is then cleared."""
    path = starts_path(results_dir, run_key)
    try:
        with open(path) as f:
            n = sum(1 for line in f if line.strip())
        os.remove(path)
    except FileNotFoundError:
        return 0
    return n


def clean_scratch(scratch_root):
    """Remove the scratch folders of attempts whose process is gone (a killed worker's); returns how many."""
    n = 0
    try:
        names = os.listdir(scratch_root)
    except FileNotFoundError:
        return 0
    for name in names:
        d = os.path.join(scratch_root, name)
        try:
            with open(os.path.join(d, "owner.json")) as f:
                owner = json.load(f)
        except (OSError, ValueError):
            continue
        if not is_alive(owner, stale_s=float("inf")):
            shutil.rmtree(d, ignore_errors=True)
            n += 1
    return n


def scratch_root_of(settings):
    return settings.get("scratch") or os.path.join(tempfile.gettempdir(), "clumpprops-runs")


def execute(run, settings):
    """Run one study run and write its reduced record; returns a small summary dict, or
    ``{"drained": True}`` without running anything when a drain forbids it to start (:func:`may_start`).

    ``settings``: ``results_dir``, ``yade`` (see :func:`yade_command`), ``cuts`` (analysis window
    starts, s), ``max_lag`` (s), ``energy_tol``, ``momentum_tol``, ``progress_period`` (s),
    ``keep_raw`` (bool), ``scratch`` (directory for attempt files), ``timeout`` (s or None).
    """
    out = record_path(settings["results_dir"], run)
    if is_complete(out, run["key"], (settings["cuts"], settings["max_lag"])):
        with open(out) as f:
            return _summary(json.load(f), reused=True)
    if is_complete(out, run["key"]):            # a record for another analysis: the new one keeps its windows too
        settings = _widened(settings, out)
    attempt = _start(run, settings)
    if attempt is None:
        return {"drained": True}
    try:
        rin = run_input(run["params"], progress_period=settings.get("progress_period", 20.0))
        table = _write_run_files(attempt, rin)
        wall, cpu = _run_yade(attempt, table, settings.get("timeout"))
        rec = _record(run, attempt, rin, settings, wall, cpu)
        if settings.get("keep_raw"):
            _keep_raw(attempt, rin, run, settings["results_dir"])
        write_atomic(out, json.dumps(rec, separators=(",", ":")))
        return _summary(rec, reused=False)
    finally:
        shutil.rmtree(attempt.work, ignore_errors=True)
        _remove(attempt.progress)


@dataclasses.dataclass
class Attempt:
    """One attempt of a run on a worker: its YADE, scratch folder and progress file."""

    run: dict
    cmd: list            # the YADE command
    chroot: bool         # True for the Debian 13 root's YADE
    work: str            # the attempt's scratch folder
    progress: str        # its progress file (:func:`progress_path`)
    started: float       # UNIX time [s] the attempt started
    period: float        # seconds between progress lines

    @property
    def prefix(self):
        """Where YADE writes the run's outputs (``.json`` facts, ``.npz`` frames)."""
        return os.path.join(self.work, "out")

    def note_progress(self, **kw):
        _progress(self.progress, name=self.run["name"], started=self.started, period=self.period, **kw)


def _widened(settings, record):
    """``settings`` whose analysis windows also keep those of the existing record at ``record``."""
    old_cuts, old_lag = red.stored_windows(record)
    return dict(settings, cuts=sorted(set(settings["cuts"]) | set(old_cuts)), max_lag=max(settings["max_lag"], old_lag))


def _start(run, settings):
    """Start an attempt of ``run`` (its progress file, start count, YADE and scratch folder), or
    None when a drain forbids it."""
    # the progress file marks the run as started (a draining driver cancels only runs that have
    # none, studies.engine.Driver); written first, then the drain file checked, so that a run the
    # driver cancels as queued never starts YADE, even if Dask had already begun it
    rdir = settings["results_dir"]
    prog = progress_path(rdir, run["key"])
    started = time.time()
    period = settings.get("progress_period", 20.0)
    _progress(prog, name=run["name"], t=0.0, t_end=run["params"]["run"]["t_end"], steps_per_s=0.0, eta_s=None,
              state="starting", started=started, period=period)
    if not may_start(run, rdir):
        _remove(prog)
        return None
    _count_start(rdir, run["key"])
    try:
        cmd, chroot, _ = yade_command(run["params"]["yade"], settings.get("yade", "auto"))
        scratch_root = scratch_root_of(settings)
        clean_scratch(scratch_root)                 # what killed attempts left behind
        work = os.path.join(scratch_root, f"{run['name']}-{uuid.uuid4().hex[:8]}")
        os.makedirs(work)
        with open(os.path.join(work, "owner.json"), "w") as f:
            json.dump(dict(_owner(), wall=started), f)
    except BaseException:
        _remove(prog)
        raise
    return Attempt(run, cmd, chroot, work, prog, started, period)


def _write_run_files(attempt, rin):
    """Write the run file and its one-line yade-batch table in the attempt's folder; returns the table's path."""
    rin_path = os.path.join(attempt.work, "run.json")
    with open(rin_path, "w") as f:
        json.dump(rin, f)
    table = os.path.join(attempt.work, "run.table")
    with open(table, "w") as f:
        f.write(f"run out\n{rin_path!r} {attempt.prefix!r}\n")
    return table


def _yade_invocation(attempt, table):
    """(command, environment) that runs ``yade_scripts/granular_gas.py`` on the batch table ``table``."""
    env = dict(os.environ, OMP_NUM_THREADS="1", YADE_BATCH=f"{table}:2", CLUMPPROPS_ROOT=ROOT)
    cmd, script = attempt.cmd, SCRIPT
    if attempt.chroot:      # the repository is /repo inside the root; /tmp is shared
        import glob
        if not glob.glob(os.path.join(ROOT, "clumpprops", "core", "_core.cpython-313*.so")):
            raise RunError("the Debian 13 root has no build of clumpprops' compiled core (Python 3.13): "
                           "run `make setup-debian13` once")
        script = "/repo/yade_scripts/granular_gas.py"
        cmd = cmd[:2] + ["env", f"YADE_BATCH={table}:2"] + cmd[2:]
    return cmd + ["-n", "-x", script], env


def _run_yade(attempt, table, timeout):
    """Run YADE on the attempt's run file, relaying its progress lines; returns (wall s, CPU s).
    Raises RunError when YADE fails or writes no outputs."""
    cmd, env = _yade_invocation(attempt, table)
    log_path = os.path.join(attempt.work, "yade.log")
    t0 = time.time()
    with open(log_path, "w") as log:
        p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                             env=env, cwd=attempt.work, text=True, preexec_fn=_die_with_parent)
        for line in p.stdout:
            log.write(line)
            m = re.match(r"PROGRESS t=([\d.]+) t_end=([\d.]+) steps_per_s=(\d+) eta_s=(\d+)", line)
            if m:
                t, te, sps, eta = (float(x) for x in m.groups())
                attempt.note_progress(t=t, t_end=te, steps_per_s=sps, eta_s=eta, state="running")
            if timeout and time.time() - t0 > timeout:
                os.killpg(p.pid, signal.SIGKILL)
        p.stdout.close()
        _, status, usage = os.wait4(p.pid, 0)       # the YADE process's own CPU time
        rc = p.returncode = os.waitstatus_to_exitcode(status)
    wall = time.time() - t0
    if rc != 0 or not os.path.exists(attempt.prefix + ".json"):
        with open(log_path, errors="replace") as f:
            tail = f.read()[-1500:]
        raise RunError(f"YADE exited with code {rc} after {wall:.0f} s; log tail:\n{tail}")
    return wall, usage.ru_utime + usage.ru_stime


def _record(run, attempt, rin, settings, wall, cpu):
    """The reduced record of a run from YADE's outputs in the attempt's folder."""
    with open(attempt.prefix + ".json") as f:
        facts = json.load(f)
    with np.load(attempt.prefix + ".npz") as z:
        frames = {k: z[k] for k in z.files}
    rec = red.reduce_run(frames, rin, settings["cuts"], settings["max_lag"], settings["energy_tol"],
                         settings["momentum_tol"])
    commit, dirty = git_state()
    rec.update(key=run["key"], name=run["name"], shape=run["shape"], case=run["case"],
               protocol=run["protocol"], seed=run["seed"], params=run["params"], facts=facts,
               yade_version=facts["yade_version"], rot_algorithm=facts["rot_algorithm"],
               host=socket.gethostname(), wall_s=wall, cpu_s=cpu, git_commit=commit, git_dirty=dirty,
               box_length=rin["box_length"], rot_dof=rin["rot_dof"], case_body=rin["case"],
               exact_mass=rin["exact_mass"], python=sys.version.split()[0])
    return rec


def _keep_raw(attempt, rin, run, results_dir):
    """Move the raw frames and the run file to ``<results>/raw`` (``--keep-raw``)."""
    raw = os.path.join(results_dir, "raw")
    os.makedirs(raw, exist_ok=True)
    os.replace(attempt.prefix + ".npz", os.path.join(raw, run["name"] + ".npz"))
    with open(os.path.join(raw, run["name"] + ".run.json"), "w") as f:
        json.dump(rin, f)


def rereduce(results_dir):
    """Refresh the ``hcs`` part of every cooling record whose raw frames were kept
    (:func:`studies.reduce.refresh_hcs`); each record is rewritten atomically.

    Parameters
    ----------
    results_dir : str
        A study's results folder (``runs/*.json``, ``raw/NAME.npz`` and ``raw/NAME.run.json``).

    Returns
    -------
    (int, int)
        Records refreshed (those whose series changed), and cooling records without raw frames
        (left as they are).
    """
    done = skipped = 0
    for path in sorted(glob.glob(os.path.join(results_dir, "runs", "*.json"))):
        with open(path) as f:
            rec = json.load(f)
        if "hcs" not in rec:
            continue
        raw = os.path.join(results_dir, "raw", rec["name"])
        if not (os.path.exists(raw + ".npz") and os.path.exists(raw + ".run.json")):
            skipped += 1
            continue
        with np.load(raw + ".npz") as z:
            frames = {k: z[k] for k in z.files}
        with open(raw + ".run.json") as f:
            rin = json.load(f)
        new = red.refresh_hcs(rec, frames, rin)
        if new["hcs"] != rec["hcs"]:          # the current reduction's series already there: no rewrite
            write_atomic(path, json.dumps(new, separators=(",", ":")))
            done += 1
    return done, skipped


def _remove(path):
    try:
        os.remove(path)
    except OSError:
        pass


def _summary(rec, reused):
    c = rec["checks"]
    return {"key": rec["key"], "name": rec["name"], "ok": c["ok"], "fail_reasons": c["fail_reasons"],
            "energy_drift": c["energy_drift"], "steps_per_s": rec["facts"]["steps_per_s"],
            "wall_s": rec["wall_s"], "yade_version": rec["yade_version"], "rot_algorithm": rec["rot_algorithm"],
            "reused": reused}
