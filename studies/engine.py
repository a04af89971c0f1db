"""The study driver: runs a spec's missing runs as Dask tasks, keeps the manifest, shows progress.

Each run is one Dask task (:func:`studies.runner.execute`), each task one single-threaded YADE
process.  By default a ``LocalCluster`` with one worker per core runs in the driver's process
(threads that wait on YADE processes; a YADE process dies with the driver); ``scheduler`` names
an existing Dask cluster (``tcp://HOST:PORT``) whose workers share the results directory.

The manifest (``<results>/manifest.csv``) lists every run of the spec with its key, status
(``done``, ``flagged`` (finished, failed its checks: never used), ``failed`` (crashed: retried on
the next invocation up to ``study.max_attempts``), ``todo``), attempts, error and record file.
Only the driver writes it (atomically).  A run is done when its reduced record is in
``<results>/runs/``: after a ``kill -9`` of the driver the same command finds the finished records
and runs the rest; a worker that dies mid-run has its task rescheduled by Dask and leaves no
partial record.
"""
from __future__ import annotations

import csv
import fcntl
import io
import json
import os
import shutil
import statistics
import time

from . import reduce as red
from . import runner
from . import spec as S

MANIFEST_FIELDS = ("key", "name", "group", "shape", "case", "protocol", "seed", "status", "attempts", "error",
                   "record", "yade_version", "rot_algorithm", "energy_drift", "steps_per_s", "wall_s", "updated")


results_dir = S.results_dir          # kept here for callers of engine


def read_manifest(rdir):
    path = os.path.join(rdir, "manifest.csv")
    if not os.path.exists(path):
        return {}
    with open(path, newline="") as f:
        return {r["key"]: r for r in csv.DictReader(f)}


def write_manifest(rdir, rows):
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=MANIFEST_FIELDS, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: r.get(k, "") for k in MANIFEST_FIELDS})
    runner.write_atomic(os.path.join(rdir, "manifest.csv"), buf.getvalue())


def settings_of(spec, rdir, yade="auto", keep_raw=False, scratch=None, timeout=None):
    r = spec["run"]
    cuts, max_lag = S.analysis_windows(spec)
    return {"results_dir": rdir, "yade": yade, "cuts": cuts, "max_lag": max_lag,
            "energy_tol": r["energy_tol"], "momentum_tol": r["momentum_tol"],
            "progress_period": r["progress_period"], "keep_raw": keep_raw, "scratch": scratch,
            "timeout": timeout}


def _row(run, old=None):
    row = {k: run[k] for k in ("key", "name", "group", "shape", "case", "protocol", "seed")}
    row.update(status="todo", attempts=0, error="", record="")
    if old:
        row.update({k: old.get(k, "") for k in MANIFEST_FIELDS if k not in row or k in
                    ("status", "attempts", "error", "record", "yade_version", "rot_algorithm", "energy_drift",
                     "steps_per_s", "wall_s", "updated")})
        row["attempts"] = int(old.get("attempts") or 0)
    return row


def reconcile(spec, runs, rdir):
    """Manifest rows of the spec's runs: records on disk win (a record is a finished run)."""
    old = read_manifest(rdir)
    needs = S.analysis_windows(spec)
    rows = {}
    for run in runs:
        row = _row(run, old.get(run["key"]))
        path = runner.record_path(rdir, run)
        if runner.is_complete(path, run["key"], needs):
            if row["status"] not in ("done", "flagged"):
                with open(path) as f:
                    rec = json.load(f)
                _fill_done(row, rec, rdir)
        elif runner.is_complete(path, run["key"]):
            # a finished run whose record lacks a window the analysis now reads: run it again (its
            # record stays until the new one, which keeps every window of the old, replaces it)
            row.update(status="todo", record="", error=f"rerun: {red.why_not_served(path, needs)}")
        elif row["status"] in ("done", "flagged"):
            row.update(status="todo", record="")      # record deleted: run again
        if row["status"] == "running" and runner.in_flight(rdir, run["key"]) is None:
            row["status"] = "todo"                    # its attempt is gone (a killed worker or driver)
        rows[run["key"]] = row
    return rows


def _fill_done(row, rec, rdir):
    c = rec["checks"]
    row.update(status="done" if c["ok"] else "flagged", error="; ".join(c["fail_reasons"]),
               record=os.path.relpath(runner.record_path(rdir, rec), rdir),
               yade_version=rec["yade_version"], rot_algorithm=rec["rot_algorithm"],
               energy_drift=f"{c['energy_drift']:.3g}", steps_per_s=f"{rec['facts']['steps_per_s']:.0f}",
               wall_s=f"{rec['wall_s']:.1f}", updated=time.strftime("%Y-%m-%dT%H:%M:%S"))
    if not row.get("attempts") and not os.path.exists(runner.starts_path(rdir, rec["key"])):
        row["attempts"] = 1       # a record from before attempts were counted (the driver counts the starts)


def _fmt_s(s):
    if s is None or s != s:
        return "?"
    s = int(s)
    return f"{s // 3600}h{s % 3600 // 60:02d}m" if s >= 3600 else f"{s // 60}m{s % 60:02d}s"


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
    from distributed import wait

    rdir = results_dir(spec)
    os.makedirs(os.path.join(rdir, "runs"), exist_ok=True)
    lock = open(os.path.join(rdir, ".driver.lock"), "w")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        raise SystemExit(f"[study] another driver is running on {rdir}")
    t_locked = time.time()
    # progress files left by a driver that was killed: no run of this study is in flight while we
    # hold the lock, so they would only show as phantom running runs
    shutil.rmtree(os.path.join(rdir, ".progress"), ignore_errors=True)
    drain_path = os.path.join(rdir, DRAIN)
    try:    # a drain asked of an earlier driver; one asked of this driver since it took its lock stays
        # (0.1 s of margin: a file system stamps times from a coarse clock)
        if os.path.getmtime(drain_path) < t_locked - 0.1:
            os.remove(drain_path)
    except FileNotFoundError:
        pass
    draining = False
    deadline_seen = None
    commit, dirty = runner.git_state()
    if dirty and not allow_dirty:
        raise SystemExit("[study] the tree has uncommitted changes under clumpprops/, studies/ or yade_scripts/: "
                         "runs must come from a committed revision (commit, use a clean `git worktree`, "
                         "or pass --allow-dirty for a throw-away study)")
    max_att = spec["study"]["max_attempts"]
    schedule = spec["study"]["schedule"]
    client = cluster = None
    t_start = time.time()
    n_ok = n_flag = n_fail = n_sub = n_cancel = 0
    attempted = set()
    expected = {}             # run key -> expected wall seconds (the cost model), for the ETAs
    scratch_root = runner.scratch_root_of({"scratch": scratch})
    done_walls = []           # wall seconds of the runs this sweep finished
    first = True
    try:
        while True:
            runs, _ = _plan(spec, rdir, log)
            rows = reconcile(spec, runs, rdir)
            if first:         # attempts a killed driver's workers started and nobody counted
                for r in runs:
                    rows[r["key"]]["attempts"] = int(rows[r["key"]]["attempts"] or 0) + runner.take_starts(rdir, r["key"])
                runner.clean_scratch(scratch_root)
                first = False
            # the cap is on failures: starts that were killed (a stopped driver, a lost worker) count
            # as attempts but never leave a run undone
            todo = [r for r in runs if r["key"] not in attempted and (rows[r["key"]]["status"] == "todo" or (
                    rows[r["key"]]["status"] == "failed" and int(rows[r["key"]]["attempts"]) < max_att))]
            given_up = [r for r in runs if rows[r["key"]]["status"] == "failed"
                        and int(rows[r["key"]]["attempts"]) >= max_att]
            todo.sort(key=lambda r: -_priority(r, schedule))     # --max-runs keeps the first in the schedule
            if max_runs is not None:
                todo = todo[:max(0, max_runs - n_sub)]
            write_manifest(rdir, [rows[r["key"]] for r in runs])
            if n_sub == 0:
                n_done = sum(rows[r["key"]]["status"] in ("done", "flagged") for r in runs)
                log(f"[study] {spec['study']['name']} ({spec['path']}): {len(runs)} runs, {n_done} already complete, "
                    f"{len(todo)} to do, {len(given_up)} given up after {max_att} attempts; commit {commit[:10]}"
                    f"{' (dirty)' if dirty else ''}; results in {os.path.relpath(rdir, S.ROOT)}")
                for r in given_up:
                    log(f"[study]   given up: {r['name']}: {rows[r['key']]['error'][:200]}")
            if not todo:
                break
            if _drain_now(runner.drain_deadline(rdir)):
                draining = True
                log(f"[study] draining ({DRAIN} found): {len(todo)} run(s) to do not submitted")
                break
            if client is None:
                workers = workers or os.cpu_count() or 1
                client, cluster = _client(scheduler, workers)
                settings = settings_of(spec, rdir, yade, keep_raw, scratch, timeout)
                cost = _cost_model(spec, rdir)        # once: a re-plan's new runs are submitted at once
            futs, pending = {}, set()

            def submit(batch):
                nonlocal n_sub
                expected.update({r["key"]: cost(r["params"]) for r in batch})
                for run in batch:
                    f = client.submit(runner.execute, run, settings, key=f"run-{run['key']}-{int(t_start)}-{n_sub}",
                                      pure=False, priority=_priority(run, schedule), retries=0)
                    futs[f] = run
                    pending.add(f)
                    attempted.add(run["key"])
                    n_sub += 1
                log(f"[study] {len(batch)} runs submitted to {scheduler or f'a LocalCluster of {workers} worker(s)'}")

            submit(todo)
            last = time.time()
            sequential = any(g.get("target") for g in spec["groups"])
            while pending:
                deadline = runner.drain_deadline(rdir)
                if deadline is not None and deadline > time.time() and deadline != deadline_seen:
                    deadline_seen = deadline
                    log(f"[study] drain by {time.strftime('%H:%M:%S UTC', time.gmtime(deadline))} ({DRAIN} found): "
                        "only runs expected to finish by then start; the others stay to do")
                if not draining and _drain_now(deadline):
                    draining = True
                    queued = {f for f in pending
                              if not f.done() and not os.path.exists(runner.progress_path(rdir, futs[f]["key"]))}
                    client.cancel(list(queued))
                    pending -= queued
                    n_cancel += len(queued)
                    log(f"[study] draining ({DRAIN} found): {len(pending)} run(s) in flight finish, "
                        f"{len(queued)} queued run(s) cancelled (they stay to do)")
                    if not pending:
                        break
                try:
                    done, pending = wait(pending, timeout=min(progress_every, 5.0), return_when="FIRST_COMPLETED")
                except TimeoutError:       # nothing finished within the timeout (asyncio's, an OSError subclass)
                    done = set()
                for f in done:
                    run = futs[f]
                    row = rows[run["key"]]
                    try:
                        summ, err = f.result(), None
                    except Exception as e:  # noqa: BLE001 - recorded below
                        summ, err = None, e
                    if isinstance(summ, dict) and summ.get("drained"):
                        n_cancel += 1        # began after the drain and did nothing: it stays to do
                        continue
                    row["attempts"] = int(row["attempts"] or 0) + max(1, runner.take_starts(rdir, run["key"]))
                    try:
                        if err is not None:
                            raise err
                        with open(runner.record_path(rdir, run)) as fh:
                            _fill_done(row, json.load(fh), rdir)
                        if not summ.get("reused"):   # the runs still queued: this sweep's measured pace
                            done_walls.append(float(summ["wall_s"]))
                            expected.update({futs[q]["key"]: statistics.median(done_walls) for q in pending})
                        flag = "ok" if summ["ok"] else "FLAGGED " + "; ".join(summ["fail_reasons"])
                        n_ok += summ["ok"]
                        n_flag += not summ["ok"]
                        log(f"[study] done {run['name']}: {flag}, energy drift {summ['energy_drift']:.2g}, "
                            f"{summ['steps_per_s']:.0f} steps/s, {summ['wall_s']:.0f} s, YADE {summ['yade_version']} "
                            f"({summ['rot_algorithm']})")
                    except Exception as e:  # noqa: BLE001 - any failure of a run is recorded, never lost
                        n_fail += 1
                        msg = f"{type(e).__name__}: {e}"
                        row.update(status="failed", error=msg.replace("\n", " | ")[:2000],
                                   updated=time.strftime("%Y-%m-%dT%H:%M:%S"))
                        log(f"[study] FAILED {run['name']} (attempt {row['attempts']}/{max_att}): {msg[:600]}")
                    write_manifest(rdir, [rows[r["key"]] for r in runs])
                if done and sequential and not draining:
                    # A sequential group whose batch just finished may need more seeds now: plan
                    # again and queue its new runs at their group's priority, ahead of the later
                    # groups' queued runs, instead of after every run submitted so far.
                    old_rows = rows
                    runs, _ = _plan(spec, rdir, log)
                    rows = reconcile(spec, runs, rdir)
                    # a plan can shrink (the budget ran out since a batch was added): runs already
                    # submitted stay in the manifest and are still collected when they finish
                    for r in futs.values():
                        if r["key"] not in rows:
                            runs.append(r)
                            rows[r["key"]] = old_rows[r["key"]]
                    new = sorted((r for r in runs if rows[r["key"]]["status"] == "todo" and r["key"] not in attempted),
                                 key=lambda r: -_priority(r, schedule))
                    if max_runs is not None:
                        new = new[:max(0, max_runs - n_sub)]
                    write_manifest(rdir, [rows[r["key"]] for r in runs])
                    if new:
                        submit(new)
                if _mark_running(rdir, rows, [futs[f] for f in pending]):
                    write_manifest(rdir, [rows[r["key"]] for r in runs])
                now = time.time()
                if pending and now - last >= progress_every:
                    last = now
                    log(_progress_line(rdir, futs, pending, expected, n_workers(client, workers), now - t_start,
                                       len(futs) - len(pending) - n_cancel, len(futs) - n_cancel))
            if draining:
                write_manifest(rdir, [rows[r["key"]] for r in runs])
                break
        if draining or n_cancel:
            log(f"[study] drained: the runs in flight finished; {spec['study']['name']} resumes with "
                "`scripts/sweep.sh start` (or `python -m studies sweep`)")
        if n_sub:
            log(f"[study] finished {n_sub - n_cancel} runs in {_fmt_s(time.time() - t_start)}: {n_ok} ok, "
                f"{n_flag} flagged, {n_fail} failed" + (f"; {n_cancel} cancelled by the drain" if n_cancel else ""))
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
        runner.clean_scratch(scratch_root)     # a killed attempt's folders
        fcntl.flock(lock, fcntl.LOCK_UN)
        lock.close()
    return rows


DRAIN = runner.DRAIN    # a file in the results directory: finish the runs in flight, start no more, end


def _drain_now(deadline):
    """True when the sweep must drain now, given :func:`studies.runner.drain_deadline`: a drain file
    without a deadline (0.0), or one past its deadline."""
    return deadline is not None and deadline <= time.time()


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


def remaining_s(expected_s, progress, now=None):
    """Expected wall seconds left of one run: the cost model's ``expected_s`` for the part not done
    until a tenth of the run is done, then the run's own pace (start-up no longer dominates it)."""
    if not progress:
        return expected_s
    frac = min(max(float(progress["t"]) / float(progress["t_end"]), 0.0), 1.0)
    ran = (now or time.time()) - float(progress.get("started", progress["wall"]))
    if frac >= 0.1 and ran > 0:
        return ran * (1 - frac) / frac
    return expected_s * (1 - frac) if expected_s == expected_s else float("nan")


def n_workers(client, workers):
    try:
        return max(1, len(client.scheduler_info()["workers"]))
    except Exception:  # noqa: BLE001 - a scheduler that does not answer: the asked number
        return max(1, int(workers or 1))


def _mark_running(rdir, rows, runs):
    """Rows of runs with a live attempt become ``running``, rows whose attempt died ``todo``; True if any changed."""
    changed = False
    for run in runs:
        row = rows[run["key"]]
        live = runner.in_flight(rdir, run["key"]) is not None
        if live and row["status"] in ("todo", "failed"):
            row["status"], changed = "running", True
        elif not live and row["status"] == "running":
            row["status"], changed = "todo", True
    return changed


def _progress_line(rdir, futs, pending, expected, n_workers, elapsed, n_done, n_all):
    parts, left, now = [], 0.0, time.time()
    for f in pending:
        run = futs[f]
        p = runner.in_flight(rdir, run["key"])
        rem = remaining_s(expected.get(run["key"], float("nan")), p, now)
        left += rem
        if p:
            parts.append(f"{run['name'].rsplit('-', 1)[0]} t={p['t']:.0f}/{p['t_end']:.0f} s "
                         f"{p['steps_per_s']:.0f} steps/s eta {_fmt_s(rem)}")
    eta = left / n_workers if left == left else None
    return (f"[study] {n_done}/{n_all} runs done, {len(parts)} running, {_fmt_s(elapsed)} elapsed, "
            f"study eta {_fmt_s(eta)}" + ("" if not parts else " | " + " | ".join(parts)))
