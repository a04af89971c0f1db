"""YADE 2025.2 without root: scripts/debian13.sh run enters the Debian 13 root through an
unprivileged user namespace when the caller is not root."""
import os
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
D13 = os.path.join(ROOT, "scripts", "debian13.sh")


def _root_ready():
    path = subprocess.run(["bash", D13, "path"], capture_output=True, text=True).stdout.strip()
    return os.path.exists(os.path.join(path, ".clumpprops-ready"))


pytestmark = pytest.mark.skipif(os.environ.get("CLUMPPROPS_IN_DEBIAN13") == "1" or os.geteuid() != 0
                                or not _root_ready(),
                                reason="needs the Debian 13 root, and root here to become another user")


def _as_nobody(cmd):
    return subprocess.run(["su", "-s", "/bin/bash", "nobody", "-c", f"cd {ROOT} && {cmd}"],
                          capture_output=True, text=True, timeout=300)


def test_a_user_without_root_runs_yade_2025_in_the_debian13_root():
    r = _as_nobody(f"bash {D13} run yade --version")
    assert r.returncode == 0, r.stderr[-2000:]
    assert "2025.2" in r.stdout
    # and simulates: a sphere falls for 100 steps under YADE 2025.2's default integrator
    script = ("import sys; sys.path.insert(0, '/usr/lib/x86_64-linux-gnu/yade-double/py'); "
              "from yade import *; from yade import utils; "
              "O.bodies.append(utils.sphere((0, 0, 0), 0.1)); "
              "O.engines = [ForceResetter(), NewtonIntegrator(gravity=(0, 0, -10), damping=0)]; O.dt = 1e-3; O.run(100, True); "
              "print('state', O.iter, O.time, O.bodies[0].state.vel[2], NewtonIntegrator().rotAlgorithm)")
    r = _as_nobody(f"bash {D13} run env OMP_NUM_THREADS=1 python3 -c \"{script}\"")
    assert r.returncode == 0, r.stderr[-2000:]
    n, t, vz, algo = r.stdout.split()[-4:]
    assert int(n) == 100 and float(vz) == pytest.approx(-10 * float(t), rel=1e-9) and algo == "delValle2023"


def test_without_a_root_a_user_is_told_in_one_line_how_to_get_one():
    r = _as_nobody(f"CLUMPPROPS_DEBIAN13=/nonexistent bash {D13} run yade --version")
    assert r.returncode == 1 and r.stdout == ""
    assert len(r.stderr.strip().splitlines()) == 1 and "as root, once" in r.stderr


def test_without_root_the_command_in_the_root_dies_with_its_caller():
    """The user namespace's child (YADE in a sweep) must not outlive a killed caller: a driver's
    stop would otherwise leave YADE running beside the next attempt of the same run."""
    import signal
    import time
    p = subprocess.Popen(["su", "-s", "/bin/bash", "nobody", "-c",
                          f"cd {ROOT} && exec bash {D13} run sleep 300"], start_new_session=True)
    try:
        deadline = time.time() + 60
        while time.time() < deadline and not _sleepers():
            time.sleep(0.2)
        assert _sleepers(), "the command never started"
        unshare = [pid for pid in _pids() if _cmdline(pid).startswith("unshare") and "--kill-child" in _cmdline(pid)]
        assert unshare
        for pid in unshare:
            os.kill(pid, signal.SIGKILL)            # the caller's side, as a killed driver's worker
        deadline = time.time() + 10
        while time.time() < deadline and _sleepers():
            time.sleep(0.2)
        assert not _sleepers()
    finally:
        try:
            os.killpg(p.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        for pid in _sleepers():
            os.kill(pid, signal.SIGKILL)


def _pids():
    return [int(d) for d in os.listdir("/proc") if d.isdigit()]


def _cmdline(pid):
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return f.read().replace(b"\0", b" ").decode(errors="replace").strip()
    except OSError:
        return ""


def _sleepers():
    return [pid for pid in _pids() if _cmdline(pid) == "sleep 300"]
