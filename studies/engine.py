"""The study driver: runs a spec's missing runs as Dask tasks, keeps the manifest, shows progress.

Each run is one Dask task (:func:`studies.runner.execute`), each task one single-threaded YADE
process.  By default a ``LocalCluster`` with one worker per core runs in the driver's process
(threads that wait on YADE processes; a YADE process dies with the driver); ``scheduler`` names
an existing Dask cluster (``tcp://HOST:PORT``) whose workers share the results directory.

The manifest (``<results>/manifest.csv``, :mod:`studies.manifest`) lists every run of the spec with
its key, status (``done``, ``flagged`` (finished, failed its checks: never used), ``failed``
(crashed: retried on the next invocation up to ``study.max_attempts``), ``todo``), attempts, error
and record file.  Only the driver writes it (atomically).  A run is done when its reduced record is
in ``<results>/runs/``: after a ``kill -9`` of the driver the same command finds the finished
records and runs the rest; a worker that dies mid-run has its task rescheduled by Dask and leaves
no partial record.

The driver (:class:`Driver`, what :func:`sweep` runs) holds the study's lock (:class:`DriverLock`),
plans the runs, submits them (:class:`Submissions`), collects each finished one into the manifest,
and drains when asked (:class:`Drain`).
"""
from __future__ import annotations

import dataclasses
import json
import os
import shutil
import statistics
import time
from typing import Callable

from . import runner
from . import spec as S
from .drain import DRAIN, Drain, DriverLock
from .eta import fmt_s as _fmt_s, n_workers, progress_line as _progress_line
from .manifest import fill_done as _fill_done, mark_running as _mark_running, now_stamp, reconcile, write_manifest

results_dir = S.results_dir          # kept here for callers of engine


def settings_of(spec, rdir, yade="auto", keep_raw=False, scratch=None, timeout=None):
    """The settings dict :func:`studies.runner.execute` takes, for the runs of ``spec``."""
    r = spec["run"]
    cuts, max_lag = S.analysis_windows(spec)
    return {"results_dir": rdir, "yade": yade, "cuts": cuts, "max_lag": max_lag,
            "energy_tol": r["energy_tol"], "momentum_tol": r["momentum_tol"],
            "progress_period": r["progress_period"], "keep_raw": keep_raw, "scratch": scratch,
            "timeout": timeout}


def _client(scheduler, workers):
    from distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler, timeout="30s"), None
    import logging
    logging.getLogger("distributed.worker").setLevel(logging.ERROR)   # failed runs are reported by sweep()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=False, dashboard_address=":0")
    return Client(cluster), cluster


def _plan(spec, rdir, log):
    """Runs of the spec now, sequential groups extended by :func:`studies.design.plan`."""
    if not any(g.get("target") for g in spec["groups"]):
        return S.runs(spec), {}
    from . import design

    recs = design.load_records(spec, rdir)      # every finished run, any seed the design could add
    extra, status = design.plan(spec, rdir, recs)
    for gi, st in status.items():
        log("[study] " + design.describe(gi, spec["groups"][gi], st))
    runs = S.runs(spec, extra_seeds=extra)
    # runs of seeds an earlier plan added and this one does not (the budget ran out while they ran)
    # stay listed while their records are on disk: the manifest lists every finished run
    have = {r["key"] for r in runs}
    runs += [r for r in S.runs(spec, extra_seeds=design.possible_extra_seeds(spec))
             if r["key"] not in have and r["key"] in recs]
    return runs, status


def status(spec, log=print):
    """Manifest rows (dict by key) of every run the spec asks for now, a sequential group's added
    seeds included (each group's state is logged), as recorded under its results directory.
    Reads only; writes nothing."""
    rdir = results_dir(spec)
    runs, _ = _plan(spec, rdir, log)
    return reconcile(spec, runs, rdir)


def sweep(spec, scheduler=None, workers=None, yade="auto", keep_raw=False, allow_dirty=False, max_runs=None,
          progress_every=30.0, log=print, scratch=None, timeout=None):
    """Run every missing run of ``spec`` (sequential groups: until their targets are met, their
    ``max_seeds`` reached or the budget spent); returns the manifest rows (dict by key).

    A file :data:`DRAIN` in the results directory (``scripts/sweep.sh drain``) drains the sweep: runs
    already started (a progress file under ``.progress``) finish and are recorded, queued ones are
    cancelled and stay to do, and the driver ends.  A drain file holding a UNIX time (``BY=HH:MM
    scripts/sweep.sh drain``) is a deadline: until then only runs expected to finish by it start
    (:func:`studies.runner.may_start`, each run's expected wall time from the finished runs like it
    when it is about to start), the others return untried and stay to do (for the next driver); at
    the deadline it drains as above.  A new driver removes a drain file written before it took its
    lock."""
    options = SweepOptions(scheduler=scheduler, workers=workers, yade=yade, keep_raw=keep_raw,
                           allow_dirty=allow_dirty, max_runs=max_runs, progress_every=progress_every, log=log,
                           scratch=scratch, timeout=timeout)
    return Driver(spec, options).run()


@dataclasses.dataclass
class SweepOptions:
    """How a sweep runs (the parameters of :func:`sweep`)."""

    scheduler: str | None = None
    workers: int | None = None
    yade: str = "auto"
    keep_raw: bool = False
    allow_dirty: bool = False
    max_runs: int | None = None
    progress_every: float = 30.0
    log: Callable[[str], object] = print
    scratch: str | None = None
    timeout: float | None = None


@dataclasses.dataclass
class Tally:
    """What a sweep did: runs submitted, finished ok, flagged, failed, and cancelled by a drain."""

    submitted: int = 0
    ok: int = 0
    flagged: int = 0
    failed: int = 0
    cancelled: int = 0


class Driver:
    """One sweep of a spec (:func:`sweep`): plan, submit, collect into the manifest, until no run
    is left to do or a drain ends it.  :meth:`run` returns the manifest rows (dict by key)."""

    def __init__(self, spec, options):
        self.spec = spec
        self.options = options
        self.log = options.log
        self.rdir = results_dir(spec)
        self.max_attempts = spec["study"]["max_attempts"]
        self.schedule = spec["study"]["schedule"]
        self.sequential = any(g.get("target") for g in spec["groups"])
        self.drain = Drain(self.rdir, self.log)
        self.tally = Tally()
        self.scratch_root = runner.scratch_root_of({"scratch": options.scratch})
        self.workers = options.workers
        self.runs, self.rows = [], {}       # the runs planned now and their manifest rows (by key)
        self.futs, self.pending = {}, set()  # this round's futures (to their runs) and those not finished
        self.attempted = set()              # keys of the runs submitted by this sweep
        self.expected = {}                  # run key -> expected wall seconds (the cost model), for the ETAs
        self.done_walls = []                # wall seconds of the runs this sweep finished
        self.client = self.cluster = self.settings = self.cost = None
        self.commit, self.dirty, self.t_start = None, None, None

    def run(self):
        """Sweep under the study's lock; returns the manifest rows (dict by key)."""
        os.makedirs(os.path.join(self.rdir, "runs"), exist_ok=True)
        with DriverLock(self.rdir) as lock:
            # progress files left by a driver that was killed: no run of this study is in flight while
            # we hold the lock, so they would only show as phantom running runs
            shutil.rmtree(os.path.join(self.rdir, ".progress"), ignore_errors=True)
            self.drain.forget_earlier(lock.locked_at)
            self._check_tree()
            self.t_start = time.time()
            try:
                self._rounds()
                self._log_end()
            finally:
                self._close()
        return self.rows

    def _check_tree(self):
        self.commit, self.dirty = runner.git_state()
        if self.dirty and not self.options.allow_dirty:
            raise SystemExit("[study] the tree has uncommitted changes under clumpprops/, studies/ or yade_scripts/: "
                             "runs must come from a committed revision (commit, use a clean `git worktree`, "
                             "or pass --allow-dirty for a throw-away study)")

    def _rounds(self):
        """Plan, submit and collect until nothing is left to do (a round ends when its runs have)."""
        first = True
        while True:
            self._replan()
            if first:
                self._count_lost_starts()
                first = False
            todo, given_up = self._todo()
            self._write_manifest()
            if self.tally.submitted == 0:
                self._log_opening(todo, given_up)
            if not todo or self.drain.before_submission(len(todo)):
                return
            self._start_client()
            self.futs, self.pending = {}, set()
            self._submit(todo)
            self._collect()
            if self.drain.draining:
                self._write_manifest()
                return

    def _replan(self):
        self.runs, _ = _plan(self.spec, self.rdir, self.log)
        self.rows = reconcile(self.spec, self.runs, self.rdir)

    def _count_lost_starts(self):
        """Count the attempts a killed driver's workers started and nobody counted; clear their scratch."""
        for r in self.runs:
            row = self.rows[r["key"]]
            row["attempts"] = int(row["attempts"] or 0) + runner.take_starts(self.rdir, r["key"])
        runner.clean_scratch(self.scratch_root)

    def _todo(self):
        """(runs to submit, highest priority first; runs given up after ``max_attempts`` failures)."""
        # the cap is on failures: starts that were killed (a stopped driver, a lost worker) count
        # as attempts but never leave a run undone
        def wanted(row):
            return row["status"] == "todo" or (row["status"] == "failed" and int(row["attempts"]) < self.max_attempts)

        todo = [r for r in self.runs if r["key"] not in self.attempted and wanted(self.rows[r["key"]])]
        given_up = [r for r in self.runs if self.rows[r["key"]]["status"] == "failed"
                    and int(self.rows[r["key"]]["attempts"]) >= self.max_attempts]
        return self._queue(todo), given_up

    def _queue(self, runs):
        """``runs`` in the schedule's order, cut to what ``max_runs`` still allows this sweep to
        submit (``--max-runs`` keeps the first in the schedule)."""
        runs = sorted(runs, key=lambda r: -_priority(r, self.schedule))
        if self.options.max_runs is None:
            return runs
        return runs[:max(0, self.options.max_runs - self.tally.submitted)]

    def _write_manifest(self):
        write_manifest(self.rdir, [self.rows[r["key"]] for r in self.runs])

    def _log_opening(self, todo, given_up):
        n_done = sum(self.rows[r["key"]]["status"] in ("done", "flagged") for r in self.runs)
        self.log(f"[study] {self.spec['study']['name']} ({self.spec['path']}): {len(self.runs)} runs, {n_done} "
                 f"already complete, {len(todo)} to do, {len(given_up)} given up after {self.max_attempts} attempts; "
                 f"commit {self.commit[:10]}{' (dirty)' if self.dirty else ''}; results in "
                 f"{os.path.relpath(self.rdir, S.ROOT)}")
        for r in given_up:
            self.log(f"[study]   given up: {r['name']}: {self.rows[r['key']]['error'][:200]}")

    def _start_client(self):
        """The Dask client, the runs' settings and the cost model, once (a re-plan's runs are submitted at once)."""
        if self.client is not None:
            return
        o = self.options
        self.workers = o.workers or os.cpu_count() or 1
        self.client, self.cluster = _client(o.scheduler, self.workers)
        self.settings = settings_of(self.spec, self.rdir, o.yade, o.keep_raw, o.scratch, o.timeout)
        self.cost = _cost_model(self.spec, self.rdir)

    def _submit(self, batch):
        """Submit the runs ``batch`` as Dask tasks at their schedule's priority."""
        self.expected.update({r["key"]: self.cost(r["params"]) for r in batch})
        for run in batch:
            f = self.client.submit(runner.execute, run, self.settings,
                                   key=f"run-{run['key']}-{int(self.t_start)}-{self.tally.submitted}",
                                   pure=False, priority=_priority(run, self.schedule), retries=0)
            self.futs[f] = run
            self.pending.add(f)
            self.attempted.add(run["key"])
            self.tally.submitted += 1
        where = self.options.scheduler or f"a LocalCluster of {self.workers} worker(s)"
        self.log(f"[study] {len(batch)} runs submitted to {where}")

    def _collect(self):
        """Collect this round's runs as they finish: the manifest, re-plans, drains and progress lines."""
        from distributed import wait

        every = self.options.progress_every
        last = time.time()
        while self.pending:
            if self.drain.begins():
                self._cancel_queued()
                if not self.pending:
                    return
            try:
                done, self.pending = wait(self.pending, timeout=min(every, 5.0), return_when="FIRST_COMPLETED")
            except TimeoutError:       # nothing finished within the timeout (asyncio's, an OSError subclass)
                done = set()
            for f in done:
                self._collect_one(f)
            if done and self.sequential and not self.drain.draining:
                self._replan_in_flight()
            if _mark_running(self.rdir, self.rows, [self.futs[f] for f in self.pending]):
                self._write_manifest()
            now = time.time()
            if self.pending and now - last >= every:
                last = now
                self.log(self._progress_line(now))

    def _cancel_queued(self):
        """Cancel the submitted runs that have not started (no progress file): they stay to do."""
        queued = {f for f in self.pending
                  if not f.done() and not os.path.exists(runner.progress_path(self.rdir, self.futs[f]["key"]))}
        self.client.cancel(list(queued))
        self.pending -= queued
        self.tally.cancelled += len(queued)
        self.log(f"[study] draining ({DRAIN} found): {len(self.pending)} run(s) in flight finish, "
                 f"{len(queued)} queued run(s) cancelled (they stay to do)")

    def _collect_one(self, future):
        """Record one finished task in the manifest: its run done, flagged or failed."""
        run = self.futs[future]
        row = self.rows[run["key"]]
        try:
            summary, err = future.result(), None
        except Exception as e:  # noqa: BLE001 - recorded below
            summary, err = None, e
        if isinstance(summary, dict) and summary.get("drained"):
            self.tally.cancelled += 1        # began after the drain and did nothing: it stays to do
            return
        row["attempts"] = int(row["attempts"] or 0) + max(1, runner.take_starts(self.rdir, run["key"]))
        try:
            if err is not None:
                raise err
            self._record_finished(run, row, summary)
        except Exception as e:  # noqa: BLE001 - any failure of a run is recorded, never lost
            self._record_failure(run, row, e)
        self._write_manifest()

    def _record_finished(self, run, row, summary):
        with open(runner.record_path(self.rdir, run)) as fh:
            _fill_done(row, json.load(fh), self.rdir)
        if not summary.get("reused"):   # the runs still queued: this sweep's measured pace
            self.done_walls.append(float(summary["wall_s"]))
            self.expected.update({self.futs[q]["key"]: statistics.median(self.done_walls) for q in self.pending})
        flag = "ok" if summary["ok"] else "FLAGGED " + "; ".join(summary["fail_reasons"])
        self.tally.ok += summary["ok"]
        self.tally.flagged += not summary["ok"]
        self.log(f"[study] done {run['name']}: {flag}, energy drift {summary['energy_drift']:.2g}, "
                 f"{summary['steps_per_s']:.0f} steps/s, {summary['wall_s']:.0f} s, YADE {summary['yade_version']} "
                 f"({summary['rot_algorithm']})")

    def _record_failure(self, run, row, error):
        self.tally.failed += 1
        msg = f"{type(error).__name__}: {error}"
        row.update(status="failed", error=msg.replace("\n", " | ")[:2000], updated=now_stamp())
        self.log(f"[study] FAILED {run['name']} (attempt {row['attempts']}/{self.max_attempts}): {msg[:600]}")

    def _replan_in_flight(self):
        """Plan again after a batch finished and submit a sequential group's new runs at once.

        They are queued at their group's priority, ahead of the later groups' queued runs, instead
        of after every run submitted so far.  A plan can shrink (the budget ran out since a batch
        was added): runs already submitted stay in the manifest and are still collected.
        """
        old_rows = self.rows
        self._replan()
        for r in self.futs.values():
            if r["key"] not in self.rows:
                self.runs.append(r)
                self.rows[r["key"]] = old_rows[r["key"]]
        new = self._queue([r for r in self.runs
                           if self.rows[r["key"]]["status"] == "todo" and r["key"] not in self.attempted])
        self._write_manifest()
        if new:
            self._submit(new)

    def _progress_line(self, now):
        n_cancel = self.tally.cancelled
        return _progress_line(self.rdir, self.futs, self.pending, self.expected, n_workers(self.client, self.workers),
                              now - self.t_start, len(self.futs) - len(self.pending) - n_cancel,
                              len(self.futs) - n_cancel)

    def _log_end(self):
        t = self.tally
        if self.drain.draining or t.cancelled:
            self.log(f"[study] drained: the runs in flight finished; {self.spec['study']['name']} resumes with "
                     "`scripts/sweep.sh start` (or `python -m studies sweep`)")
        if t.submitted:
            self.log(f"[study] finished {t.submitted - t.cancelled} runs in {_fmt_s(time.time() - self.t_start)}: "
                     f"{t.ok} ok, {t.flagged} flagged, {t.failed} failed"
                     + (f"; {t.cancelled} cancelled by the drain" if t.cancelled else ""))

    def _close(self):
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()
        runner.clean_scratch(self.scratch_root)     # a killed attempt's folders


def _priority(run, schedule="in_order"):
    """Dask priority of a run (higher first).

    ``in_order``: group by group, seed by seed, in the spec's order, so runs a sequential group adds
    later still go before the later groups' runs.  ``round_robin``: the k-th seed of every group
    (``run["rank"]``, its place in the group's seed list) before any group's (k+1)-th, groups in the
    spec's order within a round.
    """
    if schedule == "round_robin":
        return -(int(run["rank"]) * 10**5 + int(run["group"]))
    return -(int(run["group"]) * 10**7 + int(run["seed"]) * 10)


def _cost_model(spec, rdir):
    """A function of a run's parameters giving its expected wall seconds: from the study's own like
    runs, else the per-body-step cost model (:func:`studies.cost.estimate`; the records as they are
    when the sweep starts); what the ETAs start from before a run has measured its pace."""
    from . import cost, design
    own = design.load_records(spec, rdir)
    per = cost.seconds_per_body_step(cost.committed_records())
    return lambda params: cost.estimate(params, own, per)[0]
