"""The driver's progress lines: runs done and running, each running run's pace and the study's ETA.

A run's remaining time comes from the cost model (:func:`studies.engine._cost_model`) until a
tenth of it is done, then from its own pace (:func:`remaining_s`); the study's ETA is the sum over
the runs left, over the workers.
"""
from __future__ import annotations

import time

from . import runner


def fmt_s(s):
    """Seconds as ``1h02m`` or ``3m04s``; ``?`` for None or NaN."""
    if s is None or s != s:
        return "?"
    s = int(s)
    return f"{s // 3600}h{s % 3600 // 60:02d}m" if s >= 3600 else f"{s // 60}m{s % 60:02d}s"


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
    """The Dask cluster's workers now (at least 1); the asked number ``workers`` if it does not answer."""
    try:
        return max(1, len(client.scheduler_info()["workers"]))
    except Exception:  # noqa: BLE001 - a scheduler that does not answer: the asked number
        return max(1, int(workers or 1))


def progress_line(rdir, futs, pending, expected, n_workers, elapsed, n_done, n_all):
    """The progress line of a sweep: ``futs`` maps futures to runs, ``pending`` holds those not
    finished, ``expected`` the runs' expected wall seconds by key."""
    parts, left, now = [], 0.0, time.time()
    for f in pending:
        run = futs[f]
        p = runner.in_flight(rdir, run["key"])
        rem = remaining_s(expected.get(run["key"], float("nan")), p, now)
        left += rem
        if p:
            parts.append(f"{run['name'].rsplit('-', 1)[0]} t={p['t']:.0f}/{p['t_end']:.0f} s "
                         f"{p['steps_per_s']:.0f} steps/s eta {fmt_s(rem)}")
    eta = left / n_workers if left == left else None
    return (f"[study] {n_done}/{n_all} runs done, {len(parts)} running, {fmt_s(elapsed)} elapsed, "
            f"study eta {fmt_s(eta)}" + ("" if not parts else " | " + " | ".join(parts)))
