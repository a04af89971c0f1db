"""The manifest of a study: one row per run of its spec, written only by the driver.

``<results>/manifest.csv`` lists every run with its key, status (``done``, ``flagged`` (finished,
failed its checks: never used), ``failed`` (crashed: retried up to ``study.max_attempts``),
``running``, ``todo``), attempts, error and record file.  The records on disk win over the
manifest: :func:`reconcile` rebuilds the rows from them.
"""
from __future__ import annotations

import csv
import io
import json
import os
import time

from . import reduce
from . import runner
from . import spec as S

MANIFEST_FIELDS = ("key", "name", "group", "shape", "case", "protocol", "seed", "status", "attempts", "error",
                   "record", "yade_version", "rot_algorithm", "energy_drift", "steps_per_s", "wall_s", "updated")
RUN_FIELDS = ("key", "name", "group", "shape", "case", "protocol", "seed")     # a row's copy of its run
CARRIED_FIELDS = ("status", "attempts", "error", "record", "yade_version", "rot_algorithm", "energy_drift",
                  "steps_per_s", "wall_s", "updated")                       # what a row keeps from the old manifest
FINISHED = ("done", "flagged")


def read_manifest(rdir):
    """The manifest rows under results directory ``rdir`` (dict by key; empty without a manifest)."""
    path = os.path.join(rdir, "manifest.csv")
    if not os.path.exists(path):
        return {}
    with open(path, newline="") as f:
        return {r["key"]: r for r in csv.DictReader(f)}


def write_manifest(rdir, rows):
    """Write the manifest rows ``rows`` (in order) atomically under results directory ``rdir``."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=MANIFEST_FIELDS, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: r.get(k, "") for k in MANIFEST_FIELDS})
    runner.write_atomic(os.path.join(rdir, "manifest.csv"), buf.getvalue())


def new_row(run, old=None):
    """The manifest row of ``run``: ``todo`` with no attempts, or what the old row ``old`` says of it."""
    row = {k: run[k] for k in RUN_FIELDS}
    row.update(status="todo", attempts=0, error="", record="")
    if old:
        row.update({k: old.get(k, "") for k in MANIFEST_FIELDS if k not in row or k in CARRIED_FIELDS})
        row["attempts"] = int(old.get("attempts") or 0)
    return row


def reconcile(spec, runs, rdir):
    """Manifest rows of the spec's runs: records on disk win (a record is a finished run)."""
    old = read_manifest(rdir)
    needs = S.analysis_windows(spec)
    rows = {}
    for run in runs:
        row = new_row(run, old.get(run["key"]))
        path = runner.record_path(rdir, run)
        if runner.is_complete(path, run["key"], needs):
            if row["status"] not in FINISHED:
                with open(path) as f:
                    fill_done(row, json.load(f), rdir)
        elif runner.is_complete(path, run["key"]):
            # a finished run whose record lacks a window the analysis now reads: run it again (its
            # record stays until the new one, which keeps every window of the old, replaces it)
            row.update(status="todo", record="", error=f"rerun: {reduce.why_not_served(path, needs)}")
        elif row["status"] in FINISHED:
            row.update(status="todo", record="")      # record deleted: run again
        if row["status"] == "running" and runner.in_flight(rdir, run["key"]) is None:
            row["status"] = "todo"                    # its attempt is gone (a killed worker or driver)
        rows[run["key"]] = row
    return rows


def fill_done(row, rec, rdir):
    """Fill the manifest row ``row`` of a finished run from its record ``rec``."""
    checks = rec["checks"]
    row.update(status="done" if checks["ok"] else "flagged", error="; ".join(checks["fail_reasons"]),
               record=os.path.relpath(runner.record_path(rdir, rec), rdir),
               yade_version=rec["yade_version"], rot_algorithm=rec["rot_algorithm"],
               energy_drift=f"{checks['energy_drift']:.3g}", steps_per_s=f"{rec['facts']['steps_per_s']:.0f}",
               wall_s=f"{rec['wall_s']:.1f}", updated=now_stamp())
    if not row.get("attempts") and not os.path.exists(runner.starts_path(rdir, rec["key"])):
        row["attempts"] = 1       # a record from before attempts were counted (the driver counts the starts)


def mark_running(rdir, rows, runs):
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


def now_stamp():
    """The local time as the manifest's ``updated`` column writes it."""
    return time.strftime("%Y-%m-%dT%H:%M:%S")
