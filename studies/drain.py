"""The study's lock and drain: one driver per results directory, and how a sweep is asked to end.

A file :data:`DRAIN` in a study's results directory (``scripts/sweep.sh drain``) drains its sweep:
the runs in flight finish, the queued ones are cancelled and stay to do.  A drain file holding a
UNIX time is a deadline (:func:`studies.runner.drain_deadline`, :func:`studies.runner.may_start`).
"""
from __future__ import annotations

import fcntl
import os
import time

from . import runner

DRAIN = runner.DRAIN    # a file in the results directory: finish the runs in flight, start no more, end


class DriverLock:
    """The lock of a study's results directory, held by one driver at a time (a context manager).

    A second driver on the same directory exits with a message; ``locked_at`` is the time the lock
    was taken.
    """

    def __init__(self, rdir):
        self.rdir = rdir
        self.locked_at = None
        self._file = None

    def __enter__(self):
        self._file = open(os.path.join(self.rdir, ".driver.lock"), "w")
        try:
            fcntl.flock(self._file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._file.close()
            raise SystemExit(f"[study] another driver is running on {self.rdir}")
        self.locked_at = time.time()
        return self

    def __exit__(self, *exc):
        fcntl.flock(self._file, fcntl.LOCK_UN)
        self._file.close()
        return False


class Drain:
    """The drain policy of a sweep, asked through the file :data:`DRAIN` in its results directory
    (:func:`studies.runner.drain_deadline`).

    A drain now (an empty file, or a deadline reached) lets the runs in flight finish, cancels the
    queued ones and ends the sweep; before a deadline, only the runs that fit start
    (:func:`studies.runner.may_start`, decided by each run).  ``draining`` is True once the sweep drains.
    """

    def __init__(self, rdir, log):
        self.rdir = rdir
        self.log = log
        self.draining = False
        self._deadline_seen = None

    def forget_earlier(self, locked_at):
        """Remove a drain file asked of an earlier driver; one asked of this driver since it took
        its lock (at ``locked_at``) stays."""
        path = os.path.join(self.rdir, DRAIN)
        try:        # (0.1 s of margin: a file system stamps times from a coarse clock)
            if os.path.getmtime(path) < locked_at - 0.1:
                os.remove(path)
        except FileNotFoundError:
            pass

    def before_submission(self, n_todo):
        """True (and said) when the sweep drains before it submits its ``n_todo`` runs."""
        if not _drain_now(runner.drain_deadline(self.rdir)):
            return False
        self.draining = True
        self.log(f"[study] draining ({DRAIN} found): {n_todo} run(s) to do not submitted")
        return True

    def begins(self):
        """Read the drain file while runs are in flight (a new deadline is said); True once: when
        the sweep must drain now."""
        deadline = runner.drain_deadline(self.rdir)
        if deadline is not None and deadline > time.time() and deadline != self._deadline_seen:
            self._deadline_seen = deadline
            self.log(f"[study] drain by {time.strftime('%H:%M:%S UTC', time.gmtime(deadline))} ({DRAIN} found): "
                     "only runs expected to finish by then start; the others stay to do")
        if not self.draining and _drain_now(deadline):
            self.draining = True
            return True
        return False


def _drain_now(deadline):
    """True when the sweep must drain now, given :func:`studies.runner.drain_deadline`: a drain file
    without a deadline (0.0), or one past its deadline."""
    return deadline is not None and deadline <= time.time()
