"""scripts/sweep.sh, sweeps that outlive the machine's working period: ``refresh`` brings a sweep's clone to the committed
HEAD and keeps every finished record it holds, ``collect`` copies new records back and never
overwrites one, and both refuse to touch a clone whose driver is running.  All in a throwaway
clone of this repository (nothing here runs YADE)."""
from __future__ import annotations

import fcntl
import json
import os
import shutil
import subprocess
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SPEC = "sphere_gas"                     # a spec with committed records
RUNS = Path("results/sphere_gas/runs")


def _git(repo, *args):
    return subprocess.run(["git", "-C", str(repo), "-c", "user.name=t", "-c", "user.email=t@t", *args],
                          check=True, capture_output=True, text=True).stdout.strip()


def _sweep(repo, *args):
    return subprocess.run(["bash", str(repo / "scripts" / "sweep.sh"), *args], capture_output=True, text=True)


@pytest.fixture
def repo(tmp_path):
    r = tmp_path / "repo"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(r)], check=True)
    shutil.copy(ROOT / "scripts" / "sweep.sh", r / "scripts" / "sweep.sh")   # the script as it is here
    _git(r, "add", "scripts/sweep.sh")
    _git(r, "commit", "-q", "--allow-empty", "-m", "the script under test")
    return r


def test_refresh_keeps_finished_records_and_collect_never_overwrites(repo, tmp_path):
    sw = tmp_path / "sw"
    committed = sorted(p.name for p in (repo / RUNS).glob("*.json"))
    assert committed, "the spec needs committed records for this test"
    p = _sweep(repo, "refresh", SPEC, str(sw))
    assert p.returncode == 0, p.stderr
    assert _git(sw, "rev-parse", "HEAD") == _git(repo, "rev-parse", "HEAD")
    assert sorted(q.name for q in (sw / RUNS).glob("*.json")) == committed

    # the sweep finishes two runs; one is collected and committed, then the code moves on
    (sw / RUNS / "new-s98.json").write_text(json.dumps({"seed": 98}))
    (sw / RUNS / "new-s99.json").write_text(json.dumps({"seed": 99}))
    (sw / RUNS / committed[0]).write_text("changed in the sweep")       # must never come back
    (sw / RUNS.parent / "manifest.csv").write_text("key,status\nx,done\n")
    p = _sweep(repo, "collect", SPEC, str(sw))
    assert p.returncode == 0 and "2 new records of sphere_gas" in p.stdout, p.stdout + p.stderr
    assert json.loads((repo / RUNS / "new-s98.json").read_text()) == {"seed": 98}
    assert (repo / RUNS / committed[0]).read_text() != "changed in the sweep"
    assert (repo / RUNS.parent / "manifest.csv").read_text() == "key,status\nx,done\n"
    (repo / RUNS / "new-s99.json").unlink()                            # only s98 is committed
    (repo / "NOTE").write_text("a later commit\n")
    _git(repo, "add", "-A")
    _git(repo, "commit", "-qm", "results and code")
    (sw / RUNS / "new-s100.json").write_text(json.dumps({"seed": 100}))  # finished after the collect

    # refresh: the new HEAD (its s98 is now tracked: a plain checkout would refuse), every record kept
    p = _sweep(repo, "refresh", SPEC, str(sw))
    assert p.returncode == 0, p.stderr
    assert _git(sw, "rev-parse", "HEAD") == _git(repo, "rev-parse", "HEAD") and (sw / "NOTE").exists()
    have = {q.name for q in (sw / RUNS).glob("*.json")}
    assert {"new-s98.json", "new-s99.json", "new-s100.json"} | set(committed) == have
    assert _git(sw, "status", "--porcelain", "--", "studies", "clumpprops", "yade_scripts") == ""
    assert (sw / RUNS / committed[0]).read_text() == (repo / RUNS / committed[0]).read_text()


def test_a_running_sweep_is_left_alone(repo, tmp_path):
    sw = tmp_path / "sw"
    assert _sweep(repo, "refresh", SPEC, str(sw)).returncode == 0
    lock = sw / RUNS.parent / ".driver.lock"
    with open(lock, "w") as f:
        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)                   # as studies.engine.sweep holds it
        for cmd in ("refresh", "start"):
            p = _sweep(repo, cmd, SPEC, str(sw))
            assert p.returncode == 1 and "running in" in p.stderr, (cmd, p.stderr)
    assert _sweep(repo, "refresh", SPEC, str(sw)).returncode == 0      # released: free again


def test_bad_use_is_refused():
    p = _sweep(ROOT, "start", "no_such_spec")
    assert p.returncode == 2 and "no spec studies/specs/no_such_spec.toml" in p.stderr
    p = _sweep(ROOT, "start")
    assert p.returncode == 2 and "refresh SPEC [DIR]" in p.stderr


def _spec(repo, name):
    """A spec of a name no real sweep has (stop and the queue look at every process on the machine)."""
    (repo / "studies" / "specs" / f"{name}.toml").write_text(f'[study]\nname = "{name}"\nresults = "results/{name}"\n')
    _git(repo, "add", "-A")
    _git(repo, "commit", "-qm", f"spec {name}")


def _until(cond, what, timeout=30.0):
    t0 = time.monotonic()
    while not cond():
        assert time.monotonic() - t0 < timeout, f"timed out waiting for {what}"
        time.sleep(0.1)


@pytest.fixture
def names():
    """Two spec names of this test's own; any queue of them still alive at the end is ended (a
    failed assertion must not leave one behind to start a real sweep on this machine)."""
    a, b = f"qa{os.getpid()}", f"qb{os.getpid()}"
    yield a, b
    for pid in subprocess.run(["pgrep", "-f", f"_queue .*q[ab]{os.getpid()}"], capture_output=True,
                              text=True).stdout.split():
        subprocess.run(["kill", "--", f"-{pid}"], capture_output=True)


def test_queue_starts_each_spec_after_the_one_before_and_stop_ends_it(repo, tmp_path, monkeypatch, names):
    a, b = names
    for n in (a, b):
        _spec(repo, n)
        assert _sweep(repo, "refresh", n).returncode == 0                  # default DIR: ../sweep-NAME
    log = tmp_path / "sweep-queue.log"
    monkeypatch.setenv("SWEEP_POLL", "0.1")
    locks = {}
    for n in (a, b):                                                      # both "running"
        locks[n] = open(tmp_path / f"sweep-{n}" / "results" / n / ".driver.lock", "w")
        fcntl.flock(locks[n], fcntl.LOCK_EX | fcntl.LOCK_NB)
    alive = lambda: subprocess.run(["pgrep", "-f", f"_queue {a} {b}"], capture_output=True).returncode == 0

    p = _sweep(repo, "queue", a, f"studies/specs/{b}.toml")                # a name or a spec's path
    assert p.returncode == 0 and f"queued {a} {b}" in p.stdout, p.stdout + p.stderr
    _until(lambda: log.exists() and f"{a} did not start" in log.read_text(), "the queue to reach a")
    time.sleep(0.5)
    assert f"UTC: {b}" not in log.read_text() and alive()                # a still runs: b waits
    locks.pop(a).close()                                                  # a ends
    _until(lambda: f"{b} did not start" in log.read_text(), "the queue to move on to b")
    assert alive()
    p = _sweep(repo, "stop", b)                                           # ends the queue, first
    assert f"ended the queue of {a} {b}" in p.stdout, p.stdout + p.stderr
    _until(lambda: not alive(), "the queue to end")
    locks.pop(b).close()
    time.sleep(0.3)
    assert "done" not in log.read_text()

    # a queue whose specs all end runs to its end; wait returns at once when nothing runs
    with open(tmp_path / f"sweep-{a}" / "results" / a / ".driver.lock", "w") as f:
        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        assert _sweep(repo, "queue", a).returncode == 0
        _until(lambda: log.read_text().count(f"{a} did not start") == 2, "the second queue")
    _until(lambda: log.read_text().rstrip().endswith("done"), "the queue to finish")
    assert _sweep(repo, "wait", b).returncode == 0
    assert _sweep(repo, "queue", a, "no_such_spec").returncode == 2      # every spec checked first


def test_drain_asks_the_running_driver_and_ends_the_queue_first(repo, tmp_path, monkeypatch, names):
    a, b = names
    for n in (a, b):
        _spec(repo, n)
        assert _sweep(repo, "refresh", n).returncode == 0
    res = tmp_path / f"sweep-{a}" / "results" / a
    drain = res / ".drain"                                                # studies.engine.DRAIN
    p = _sweep(repo, "drain", a)                                          # nothing runs: nothing to ask
    assert p.returncode == 0 and f"no sweep of {a} running" in p.stdout and not drain.exists(), p.stdout
    log = tmp_path / "sweep-queue.log"
    monkeypatch.setenv("SWEEP_POLL", "0.1")
    with open(res / ".driver.lock", "w") as f:
        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)                     # a's driver "runs"
        assert _sweep(repo, "queue", a, b).returncode == 0
        _until(lambda: log.exists() and f"{a} did not start" in log.read_text(), "the queue to reach a")
        p = _sweep(repo, "drain", a)
        assert p.returncode == 0 and f"ended the queue of {a} {b}" in p.stdout and "draining" in p.stdout, p.stdout
        assert drain.exists()
        _until(lambda: subprocess.run(["pgrep", "-f", f"_queue {a} {b}"], capture_output=True).returncode != 0,
               "the queue to end")
    time.sleep(0.3)
    assert f"UTC: {b}" not in log.read_text()                            # b never started


def test_drain_by_a_deadline_writes_the_time_the_driver_reads(repo, tmp_path, names):
    from studies import runner
    a, _ = names
    _spec(repo, a)
    assert _sweep(repo, "refresh", a).returncode == 0
    res = tmp_path / f"sweep-{a}" / "results" / a
    env = dict(os.environ)
    with open(res / ".driver.lock", "w") as f:
        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)                     # a's driver "runs"
        for bad, why in (("yesterday 10:00", "is past"), ("not a time", "not a time")):
            p = subprocess.run(["bash", str(repo / "scripts" / "sweep.sh"), "drain", a], capture_output=True, text=True,
                               env=dict(env, BY=bad))
            assert p.returncode == 2 and why in p.stderr and not (res / ".drain").exists(), (p.stdout, p.stderr)
        t0 = time.time()
        p = subprocess.run(["bash", str(repo / "scripts" / "sweep.sh"), "drain", a], capture_output=True, text=True,
                           env=dict(env, BY="+1 hour"))
        assert p.returncode == 0 and "draining" in p.stdout and " by " in p.stdout, (p.stdout, p.stderr)
        deadline = runner.drain_deadline(str(res))
        assert t0 + 3600 - 5 <= deadline <= time.time() + 3600 + 5
        assert not (res / ".drain.tmp").exists()
        p = _sweep(repo, "drain", a)                          # a plain drain over it: now, not the deadline
        assert p.returncode == 0 and runner.drain_deadline(str(res)) == 0.0, (p.stdout, p.stderr)


def test_engine_names_the_drain_file_the_script_writes():
    from studies import engine
    assert f'$results/{engine.DRAIN}"' in (ROOT / "scripts" / "sweep.sh").read_text()
