"""The study engine with real YADE runs on tiny gases (each run: a few seconds).

Physics of a run (conservation, flagging, the clump properties YADE integrates, ballistic flight
with unwrapped positions), and the engine's promises: a tiny study on a LocalCluster of 2
workers, a real Dask scheduler with 2 workers of which one is killed mid-study, a driver killed
with ``kill -9`` and resumed, a crashed run recorded and retried, and the asymmetric clump that
needs YADE 2025.2.
"""
import json
import re
import math
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest
import tomllib

from studies import engine, eta, runner
from studies import spec as S
from studies.correlation import msd_fft

ROOT = S.ROOT
assert shutil.which("yade"), "the yade executable is missing: run scripts/setup.sh"
NATIVE_YADE = runner._version_of(["yade"])       # 2023.02a on Debian 12, 2025.2 on Debian 13
# the tiny gases run on the native YADE, so `make test` exercises both versions (Debian 12 host,
# Debian 13 root)
NATIVE = "2023.02a" if runner._matches(NATIVE_YADE, "2023.02a") else "2025.2"


def yade_2025():
    """A YADE 2025.2: the native one (Debian 13), else the Debian 13 root that `make test` builds."""
    try:
        return runner.yade_command("2025.2")
    except runner.RunError as e:
        pytest.fail(f"no YADE 2025.2: {e}")


def _tiny_analysis(t_end):
    """Analysis settings that fit a test-scale run of ``t_end`` s (the spec refuses lags longer than
    the analysed window)."""
    t_eq = min(0.4, 0.1 * t_end)
    window = t_end - t_eq
    return dict(t_eq=t_eq, fit_lo=min(1.0, 0.3 * window), fit_hi=min(2.5, 0.6 * window), max_lag=min(3.5, 0.9 * window))


def tiny(tmp, t_end=6.0, seeds=(1,), cases=("exact", "uncorrected", "spheres"), extra=None, **over):
    """A test-scale spec written to tmp (27 particles, volume fraction 0.02) and its results dir."""
    r = _raw_tiny(tmp, t_end, seeds, cases)
    r["groups"] += list(extra or [])
    for k, v in over.items():
        t, key = k.split("__")
        r[t][key] = v
    sp = S.validate(r)
    sp["path"] = "tiny"
    return sp


def settings(sp, **kw):
    return engine.settings_of(sp, engine.results_dir(sp), **kw)


def run_one(sp, case, protocol="paired", seed=1, **kw):
    run = next(r for r in S.runs(sp) if r["case"] == case and r["protocol"] == protocol and r["seed"] == seed)
    summ = runner.execute(run, settings(sp, **kw))
    with open(runner.record_path(engine.results_dir(sp), run)) as f:
        rec = json.load(f)
    rec["_results"] = engine.results_dir(sp)
    return summ, rec, run


@pytest.fixture(scope="module")
def small_gas(tmp_path_factory):
    """Four cases of one seed, 8 s each, through runner.execute (what a Dask task calls)."""
    tmp = tmp_path_factory.mktemp("gas")
    sp = tiny(tmp, t_end=8.0, cases=("exact", "uncorrected", "spheres"),
              extra=[{"shape": "dimer", "cases": ["uncorrected"], "protocol": "equal_energy", "seeds": [1]}])
    return {(c, p): run_one(sp, c, p, keep_raw=True) for c, p in
            [("exact", "paired"), ("uncorrected", "paired"), ("spheres", "paired"), ("uncorrected", "equal_energy")]}


@pytest.mark.parametrize("key", [("exact", "paired"), ("uncorrected", "paired"), ("spheres", "paired"),
                                 ("uncorrected", "equal_energy")])
def test_energy_and_momentum_conserved(small_gas, key):
    summ, rec, _ = small_gas[key]
    c = rec["checks"]
    assert c["ok"], c["fail_reasons"]
    assert c["energy_drift"] < 1e-3 and c["momentum_drift"] < 1e-9
    e = {k: np.asarray(v) for k, v in rec["energy"].items()}
    z = np.load(os.path.join(rec["_results"], "raw", small_gas[key][2]["name"] + ".npz"))
    assert z["e_elastic"].max() > 0                         # the gas did collide (every frame, 0.25 s)
    # the translational energy the drift is made of is the bodies' own, with the case's mass
    m = rec["case_body"]["mass"]
    np.testing.assert_allclose(0.5 * m * np.sum(z["vel"].astype(np.float64) ** 2, axis=(1, 2)), z["e_trans"], rtol=1e-6)
    etot = z["e_trans"] + z["e_rot"] + z["e_elastic"]          # ... and the drift is of those energies
    assert np.max(np.abs(etot / etot[0] - 1)) == pytest.approx(c["energy_drift"], rel=1e-12)
    idx = np.searchsorted(z["t"], e["t"] - 1e-9)
    np.testing.assert_allclose(z["t"][idx], e["t"], rtol=1e-9)                # the record's 1 s series
    np.testing.assert_allclose(e["e_trans"], z["e_trans"][idx], rtol=1e-9)
    if key[0] != "spheres":
        assert e["e_rot"][-1] > 0.05 * c["e_total_initial"]    # rotation was excited by collisions
        assert rec["facts"]["axial_spin_max"] < 1e-8 * max(rec["facts"]["angvel_rms"], 1.0)
    else:
        assert e["e_rot"].max() < 1e-20 * c["e_total_initial"]
    assert runner._matches(rec["yade_version"], NATIVE) and rec["rot_algorithm"].startswith("isotropic")


def test_bodies_carry_the_case_mass_and_inertia(small_gas):
    import clumpprops
    d = 0.1333
    mp = clumpprops.mass_properties([[0, 0, -d / 4], [0, 0, d / 4]], [d / 2, d / 2], density=1140.0)
    ms = clumpprops.mass_properties([[0, 0, -d / 4], [0, 0, d / 4]], [d / 2, d / 2], density=1140.0, method="sum")
    ex = small_gas[("exact", "paired")][1]["facts"]
    un = small_gas[("uncorrected", "paired")][1]["facts"]
    assert ex["body_mass"] == pytest.approx(mp.mass, rel=1e-14)
    assert ex["body_inertia"] == pytest.approx([mp.principal_moments[2]] * 3, rel=1e-14)
    assert un["body_mass"] == pytest.approx(ms.mass, rel=1e-14)
    assert un["body_mass"] / ex["body_mass"] == pytest.approx(32 / 27, rel=1e-12)     # the paper's dimer
    # the exact body's moment, independently: the union integrated disc by disc along its axis
    # (``_clump_reference``, no clumpprops code)
    import _clump_reference as ref
    _, _, qc = ref.pair_body([0, 0, -d / 4], d / 2, [0, 0, d / 4], d / 2, "union")
    assert ex["body_inertia"][0] == pytest.approx(ref.inertia(qc, 1140.0)[0, 0], rel=1e-11)
    # the exact dimer needs no correction bodies (isotropic route): 27 clumps x (1 + 2 spheres)
    assert ex["n_bodies"] == 27 * 3 and ex["builder"] == "appendClumped"


def test_identical_initial_state_within_a_seed(small_gas):
    raws = {k: np.load(os.path.join(v[1]["_results"], "raw", v[2]["name"] + ".npz")) for k, v in small_gas.items()}
    z0 = raws[("exact", "paired")]
    for k, z in raws.items():
        np.testing.assert_allclose(z["pos0"], z0["pos0"], atol=1e-12)     # same centres of mass
    v0 = z0["vel"][0].astype(float)
    np.testing.assert_array_equal(raws[("uncorrected", "paired")]["vel"][0], z0["vel"][0])
    e0 = small_gas[("exact", "paired")][1]["checks"]["e_total_initial"]
    assert e0 == pytest.approx(27 * 3.75, rel=1e-12)
    ee = small_gas[("uncorrected", "equal_energy")][1]["checks"]["e_total_initial"]
    assert ee == pytest.approx(27 * 3.75, rel=1e-12)                     # equal energy, own mass
    un = small_gas[("uncorrected", "paired")][1]["checks"]["e_total_initial"]
    assert un == pytest.approx(27 * 3.75 * 32 / 27, rel=1e-12)           # paired velocities, heavier
    assert np.abs(v0.sum(0)).max() < 1e-5


def test_bad_run_is_flagged(tmp_path):
    # must be able to fail: 4 x the P-wave step (about 7 steps per contact) breaks the energy
    sp = tiny(tmp_path, t_end=10.0, cases=("exact",), run__dt_factor=4.0)
    summ, rec, _ = run_one(sp, "exact")
    assert not rec["checks"]["ok"]
    assert any("energy drift" in r for r in rec["checks"]["fail_reasons"])


def test_ballistic_msd_and_unwrapped_positions(tmp_path):
    """8 dimers at volume fraction 1e-6 for 20 s: no collision, straight unwrapped flights."""
    sp = tiny(tmp_path, t_end=20.0, cases=("exact",), gas__n_particles=8, gas__volume_fraction=1e-6,
              run__rec_interval=0.5)
    summ, rec, run = run_one(sp, "exact", keep_raw=True)
    z = np.load(os.path.join(engine.results_dir(sp), "raw", run["name"] + ".npz"))
    assert rec["checks"]["ok"] and z["e_elastic"].max() == 0.0
    t, v0 = z["t"], z["vel"][0].astype(float)
    np.testing.assert_allclose(z["disp"], t[:, None, None] * v0[None], rtol=0, atol=5e-5)
    assert np.ptp(np.diff(t[1:])) < 1e-9
    w = rec["windows"][0]
    lag = np.asarray(w["msd_lag_s"])
    np.testing.assert_allclose(np.asarray(w["msd"])[1:], np.mean(np.sum(v0 ** 2, 1)) * lag[1:] ** 2, rtol=1e-4)
    np.testing.assert_allclose(w["vacf"], np.mean(np.sum(v0 ** 2, 1)), rtol=1e-5)   # constant velocities
    L = rec["box_length"]
    pos = z["pos0"][None] + z["disp"]
    assert ((pos < 0) | (pos >= L)).any() and np.abs(z["disp"]).max() > L


def _driver(sp_path, *extra, **kw):
    return [sys.executable, "-m", "studies", "sweep", str(sp_path), "--allow-dirty", "--progress-every", "1", *extra]


def _write_spec(tmp, sp_dict):
    from _spec_toml import _toml
    p = tmp / "spec.toml"
    p.write_text(_toml(sp_dict))
    return p


def _raw_tiny(tmp, t_end, seeds, cases=("exact", "uncorrected", "spheres")):
    with open(os.path.join(S.SPEC_DIR, "test.toml"), "rb") as f:
        r = tomllib.load(f)
    r["study"]["results"] = str(tmp / "results")
    r["study"]["yade"] = NATIVE
    r["run"]["t_end"] = t_end
    r["analysis"].update(_tiny_analysis(t_end))
    r["groups"] = [{"shape": "dimer", "cases": list(cases), "seeds": list(seeds)}]
    return r


def _manifest(tmp):
    return pd.read_csv(tmp / "results" / "manifest.csv")


def _records(tmp):
    d = tmp / "results" / "runs"
    out = {}
    for f in sorted(os.listdir(d)):
        rec = json.loads((d / f).read_text())
        out[f] = (rec["checks"], rec["windows"], rec["energy"])
    return out


def test_tiny_study_on_a_local_cluster_of_2_workers_then_analysis(tmp_path):
    p = _write_spec(tmp_path, _raw_tiny(tmp_path, 8.0, [1, 2]))
    r = subprocess.run(_driver(p, "--workers", "2"), cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert "LocalCluster of 2 worker(s)" in r.stdout and "6 ok, 0 flagged, 0 failed" in r.stdout
    m = _manifest(tmp_path)
    assert len(m) == 6 and set(m.status) == {"done"} and m.key.is_unique and (m.attempts == 1).all()
    r = subprocess.run([sys.executable, "-m", "studies", "analyze", str(p)], cwd=ROOT, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    s = pd.read_csv(tmp_path / "results" / "summary.csv")
    assert list(s.columns) == ["case", "n_seeds", "diffusion_coefficient", "ci_low", "ci_high", "max_energy_drift"]
    assert set(s.case) == {"exact", "uncorrected", "spheres"} and (s.n_seeds == 2).all()
    d = pd.read_csv(tmp_path / "results" / "diff_D.csv")
    assert list(d.columns) == ["case", "protocol", "n_seeds", "d_minus_d_exact", "ci_low", "ci_high", "stderr",
                               "relative", "relative_ci_low", "relative_ci_high"]
    e = pd.read_csv(tmp_path / "results" / "energy.csv")
    assert list(e.columns) == ["case", "seed", "t", "e_trans", "e_rot", "e_elastic"]
    # a second invocation has nothing to do
    r = subprocess.run(_driver(p), cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert "6 already complete, 0 to do" in r.stdout


def test_a_changed_t_eq_reruns_the_runs_whose_records_lack_its_window_and_the_analysis_then_works(tmp_path):
    """Changing analysis.t_eq to a time no record stores a window from: the analysis does not fail,
    the driver runs those runs again by itself (nothing deleted by hand), and the new records keep
    the old windows too, so the earlier analysis still works."""
    from studies import analysis
    raw = _raw_tiny(tmp_path, 8.0, [1], cases=("exact", "uncorrected"))
    p = _write_spec(tmp_path, raw)
    subprocess.run(_driver(p), cwd=ROOT, check=True, capture_output=True, timeout=600)
    analysis.analyze(S.load(str(p)), log=lambda s: None)
    raw["analysis"]["t_eq"] = 1.5                          # no record has a window from 1.5 s
    p = _write_spec(tmp_path, raw)
    msgs = []
    analysis.analyze(S.load(str(p)), log=msgs.append)      # no KeyError: the runs are reported, not read
    assert any("2 runs need a rerun" in m for m in msgs), msgs
    st = subprocess.run([sys.executable, "-m", "studies", "status", str(p)], cwd=ROOT, capture_output=True,
                        text=True, timeout=120)
    assert "todo 2" in st.stdout
    r = subprocess.run(_driver(p), cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0 and "0 already complete, 2 to do" in r.stdout, r.stdout[-2000:]
    for f in (tmp_path / "results" / "runs").glob("*.json"):
        cuts = sorted(w["t_cut"] for w in json.loads(f.read_text())["windows"])
        assert cuts == [0.4, 1.5], cuts                    # the old window (t_eq 0.4) kept, the new one added
    msgs = []
    analysis.analyze(S.load(str(p)), log=msgs.append)
    assert not any("need a rerun" in m for m in msgs), msgs
    s = pd.read_csv(tmp_path / "results" / "summary.csv")
    assert set(s.case) == {"exact", "uncorrected"} and (s.n_seeds == 1).all()
    raw["analysis"]["t_eq"] = 0.4                          # back: served by the new records, nothing to run
    r = subprocess.run(_driver(_write_spec(tmp_path, raw)), cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert "2 already complete, 0 to do" in r.stdout


def test_flagged_run_is_excluded_from_the_analysis(tmp_path):
    p = _write_spec(tmp_path, _raw_tiny(tmp_path, 8.0, [1]))
    subprocess.run(_driver(p), cwd=ROOT, check=True, capture_output=True, timeout=600)
    f = next((tmp_path / "results" / "runs").glob("dimer-uncorrected-*.json"))
    rec = json.loads(f.read_text())
    rec["checks"].update(ok=False, fail_reasons=["energy drift (test)"])
    f.write_text(json.dumps(rec))
    m = tmp_path / "results" / "manifest.csv"
    m.write_text(m.read_text().replace(",done,", ",todo,"))          # the driver re-reads records
    from studies import analysis
    msgs = []
    analysis.analyze(S.load(str(p)), log=msgs.append)
    assert any("EXCLUDED dimer-uncorrected-paired-s1" in x for x in msgs)
    s = pd.read_csv(tmp_path / "results" / "summary.csv")
    assert "uncorrected" not in set(s.case) and "exact" in set(s.case)
    r = subprocess.run(_driver(p), cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert "3 already complete, 0 to do" in r.stdout                 # a flagged run is never rerun
    assert (_manifest(tmp_path).status == "flagged").sum() == 1


def test_driver_killed_with_sigkill_resumes(tmp_path):
    ref, cut = tmp_path / "ref", tmp_path / "cut"
    ref.mkdir()
    cut.mkdir()
    pr = _write_spec(ref, _raw_tiny(ref, 4.0, [1, 2]))
    pc = _write_spec(cut, _raw_tiny(cut, 4.0, [1, 2]))
    subprocess.run(_driver(pr, "--workers", "1"), cwd=ROOT, check=True, capture_output=True, timeout=600)
    p = subprocess.Popen(_driver(pc, "--workers", "1"), cwd=ROOT, stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL, start_new_session=True)
    runs = cut / "results" / "runs"
    t0 = time.time()
    while time.time() - t0 < 300:           # kill -9 the driver after its first finished run
        if runs.exists() and any(f.suffix == ".json" for f in runs.iterdir()):
            break
        time.sleep(0.05)
    os.kill(p.pid, signal.SIGKILL)
    p.wait()
    time.sleep(1.0)
    n_killed = len(list(runs.glob("*.json")))
    assert not subprocess.run(["pgrep", "-f", str(cut)], capture_output=True).stdout   # YADE died with it
    # a progress file of the killed driver, for a run it never finished: not a running run on resume
    prog = cut / "results" / ".progress"
    prog.mkdir(exist_ok=True)
    done = {json.loads(f.read_text())["key"] for f in runs.glob("*.json")}
    for run in S.runs(S.load(str(pc))):
        if run["key"] not in done:
            (prog / f"{run['key']}.json").write_text(json.dumps(
                {"name": run["name"], "t": 3.0, "t_end": 4.0, "steps_per_s": 1.0, "eta_s": 1.0, "state": "running"}))
    r = subprocess.run(_driver(pc, "--workers", "1"), cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert f"{n_killed} already complete, {6 - n_killed} to do" in r.stdout, r.stdout
    running = [int(m) for m in re.findall(r"runs done, (\d+) running", r.stdout)]
    assert running and max(running) <= 1, r.stdout      # one worker: never two runs in flight
    assert 1 <= n_killed < 6
    a, b = _records(ref), _records(cut)
    assert sorted(a) == sorted(b)
    for k in a:
        assert a[k] == b[k]                   # bit-identical reduced records
    assert not [f for f in runs.iterdir() if f.suffix != ".json"]
    m = _manifest(cut)
    assert len(m) == 6 and set(m.status) == {"done"}


def test_crashed_run_is_recorded_and_retried_on_the_next_invocation(tmp_path):
    marker = tmp_path / "crashed_once"
    wrapper = tmp_path / "flaky-yade"
    wrapper.write_text(f"""#!/bin/bash
# YADE that crashes on its first real run (not on --version)
if [ "$1" != "--version" ] && [ ! -e {marker} ]; then touch {marker}; echo "simulated crash" >&2; exit 3; fi
exec yade "$@"
""")
    wrapper.chmod(0o755)
    p = _write_spec(tmp_path, _raw_tiny(tmp_path, 2.0, [1], cases=("exact",)))
    r = subprocess.run(_driver(p, "--yade", str(wrapper)), cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert "FAILED dimer-exact-paired-s1" in r.stdout and "simulated crash" in r.stdout
    m = _manifest(tmp_path)
    assert m.status.tolist() == ["failed"] and m.attempts.tolist() == [1] and "exited with code 3" in m.error[0]
    assert not list((tmp_path / "results" / "runs").glob("*.json"))       # nothing partial
    r = subprocess.run(_driver(p, "--yade", str(wrapper)), cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert "0 already complete, 1 to do" in r.stdout
    m = _manifest(tmp_path)
    assert m.status.tolist() == ["done"] and m.attempts.tolist() == [2]


def test_given_up_after_max_attempts(tmp_path):
    wrapper = tmp_path / "broken-yade"
    wrapper.write_text('#!/bin/bash\n[ "$1" = "--version" ] && exec yade --version\nexit 7\n')
    wrapper.chmod(0o755)
    raw = _raw_tiny(tmp_path, 1.0, [1], cases=("exact",))
    raw["study"]["max_attempts"] = 2
    p = _write_spec(tmp_path, raw)
    for _ in range(2):
        subprocess.run(_driver(p, "--yade", str(wrapper)), cwd=ROOT, capture_output=True, timeout=300)
    r = subprocess.run(_driver(p, "--yade", str(wrapper)), cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert "0 to do, 1 given up after 2 attempts" in r.stdout and "exited with code 7" in r.stdout


def test_real_dask_cluster_survives_a_killed_worker(tmp_path):
    """A `dask scheduler` and 2 `dask worker` processes on 127.0.0.1; one worker is killed while
    it runs a task: every run completes exactly once in the manifest."""
    sf = tmp_path / "scheduler.json"
    env = dict(os.environ, PYTHONPATH=ROOT, OMP_NUM_THREADS="1")
    procs = [subprocess.Popen(["dask", "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                               "--scheduler-file", str(sf)], env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, start_new_session=True)]
    try:
        t0 = time.time()
        while not sf.exists() and time.time() - t0 < 60:
            time.sleep(0.1)
        addr = json.loads(sf.read_text())["address"]
        for i in range(2):
            procs.append(subprocess.Popen(["dask", "worker", addr, "--nthreads", "1", "--no-nanny", "--name", f"w{i}",
                                           "--no-dashboard"], env=env, cwd=ROOT, stdout=subprocess.DEVNULL,
                                          stderr=subprocess.DEVNULL, start_new_session=True))
        p = _write_spec(tmp_path, _raw_tiny(tmp_path, 4.0, [1, 2]))
        drv = subprocess.Popen(_driver(p, "--scheduler", addr), cwd=ROOT, stdout=subprocess.PIPE, text=True,
                               stderr=subprocess.STDOUT)
        prog = tmp_path / "results" / ".progress"
        t0 = time.time()
        while time.time() - t0 < 300:       # a run is under way on some worker
            if prog.exists() and any(prog.iterdir()):
                break
            time.sleep(0.05)
        time.sleep(0.5)
        rdir = str(tmp_path / "results")
        w0 = procs[1].pid
        t0 = time.time()
        while time.time() - t0 < 120:          # a run of w0's in flight, shown as running in the manifest
            mine = [f.stem for f in prog.glob("*.json") if json.loads(f.read_text() or "{}").get("pid") == w0]
            m = _manifest(tmp_path)
            if mine and (m.set_index("key").loc[mine[0], "status"] == "running"):
                break
            time.sleep(0.05)
        assert mine, "no run of worker w0 in flight"
        killed = mine[0]
        os.killpg(w0, signal.SIGKILL)     # worker w0 and its YADE child
        t_kill = time.time()
        while time.time() - t_kill < 10:       # within seconds its attempt no longer counts as in flight
            p = runner.in_flight(rdir, killed)
            if p is None or p["pid"] != w0:
                break
            time.sleep(0.2)
        assert time.time() - t_kill < 10
        out, _ = drv.communicate(timeout=600)
        assert drv.returncode == 0, out[-3000:]
        m = _manifest(tmp_path)
        assert len(m) == 6 and m.key.is_unique and set(m.status) == {"done"}, m
        assert len(list((tmp_path / "results" / "runs").glob("*.json"))) == 6
        assert procs[1].poll() is not None and procs[2].poll() is None
        attempts = m.set_index("key").attempts
        assert attempts[killed] == 2 and (attempts.drop(killed) == 1).all(), attempts   # every start counted
        scratch = runner.scratch_root_of({})
        left = [d for d in (os.listdir(scratch) if os.path.isdir(scratch) else [])
                if os.path.exists(os.path.join(scratch, d, "owner.json"))
                and json.load(open(os.path.join(scratch, d, "owner.json")))["pid"] == w0]
        assert left == [], left                                                     # the killed attempt's scratch is gone
    finally:
        for q in procs:
            try:
                os.killpg(q.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


def _tet(tmp, yade, t_end=10.0):
    raw = _raw_tiny(tmp, t_end, [1], cases=("exact", "uncorrected"))
    raw["study"]["yade"] = yade
    raw["run"]["dt_factor"] = 0.25     # energy to 1e-4 in this dense gas (drift ~1e-4 at 0.5, docs/timestep.md)
    raw["gas"]["start"] = "equipartition"
    raw["shapes"] = {"tet": {"kind": "tetrahedron", "sphere_diameter": 0.1333, "overlap": 0.7}}
    raw["groups"][0]["shape"] = "tet"
    return raw


def test_asymmetric_clump_refused_on_yade_2023(tmp_path):
    with pytest.raises(S.SpecError, match="not a linear clump"):
        S.validate(_tet(tmp_path, "2023.02a"))


@pytest.mark.skipif(not runner._matches(NATIVE_YADE, "2023.02a"), reason="the native YADE is not 2023.02a")
def test_yade_script_refuses_an_asymmetric_clump_on_yade_2023(tmp_path):
    # a run file made for 2025.2, given to the native 2023.02a anyway: the script refuses it itself
    sp = S.validate(_tet(tmp_path, "2025.2"))
    run = S.runs(sp)[0]
    run = dict(run, params=dict(run["params"], yade="2023.02a"))
    with pytest.raises(runner.RunError, match="no conservative aspherical integrator"):
        runner.execute(run, settings(sp, yade="yade"))


def test_asymmetric_clump_gas_on_yade_2025_conserves_energy(tmp_path):
    yade_2025()
    sp = S.validate(_tet(tmp_path, "2025.2", t_end=10.0))
    for run in S.runs(sp):
        summ = runner.execute(run, settings(sp, keep_raw=True))
        with open(runner.record_path(engine.results_dir(sp), run)) as f:
            rec = json.load(f)
        z = np.load(os.path.join(engine.results_dir(sp), "raw", run["name"] + ".npz"))
        assert rec["yade_version"].startswith("2025.2") and rec["rot_algorithm"] == "delValle2023"
        assert rec["checks"]["energy_drift"] < 1e-4, rec["checks"]
        assert rec["checks"]["momentum_drift"] < 1e-9
        e = {k: np.asarray(v) for k, v in rec["energy"].items()}
        assert z["e_elastic"].max() > 0                               # collisions (frames every 0.05 s)
        share = e["e_rot"] / (e["e_trans"] + e["e_rot"])
        if run["case"] == "exact":                   # equipartition start, 3 + 3 degrees of freedom
            assert share[0] == pytest.approx(0.5, rel=1e-9)
        else:                                        # paired: the same v and omega, heavier body
            assert e["e_trans"][0] / (27 * 3.75 / 2) == pytest.approx(rec["facts"]["body_mass"] / rec["exact_mass"], rel=1e-9)
        assert rec["facts"]["route"] == "aspherical"


def test_prepare_writes_run_files_a_plain_yade_batch_line_can_run(tmp_path):
    """`python -m studies prepare` + `YADE_BATCH=table:2 yade -n -x` runs one run without the driver."""
    raw = _raw_tiny(tmp_path, 1.0, [3], cases=("exact",))
    p = _write_spec(tmp_path, raw)
    out = tmp_path / "prepared"
    subprocess.run([sys.executable, "-m", "studies", "prepare", str(p), "--out", str(out)], cwd=ROOT, check=True,
                   capture_output=True, timeout=120)
    table = (out / "runs.table").read_text().splitlines()
    assert table[0] == "run out" and len(table) == 2
    env = dict(os.environ, OMP_NUM_THREADS="1", YADE_BATCH=f"{out / 'runs.table'}:2")
    env.pop("CLUMPPROPS_ROOT", None)          # the script finds the repository by itself
    r = subprocess.run(["yade", "-n", "-x", os.path.join(ROOT, "yade_scripts", "granular_gas.py")], env=env,
                       cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    name = next(out.glob("dimer-exact-*.run.json")).name[:-len(".run.json")]
    facts = json.loads((out / f"{name}.json").read_text())
    assert facts["builder"] == "appendClumped" and facts["route"] == "isotropic" and facts["n_particles"] == 27
    z = np.load(out / f"{name}.npz")
    rin = json.loads((out / f"{name}.run.json").read_text())
    assert z["disp"].shape == (rin["n_steps"] // rin["rec_steps"] + 1, 27, 3)    # frame 0 included
    assert rin["n_steps"] * rin["dt"] == pytest.approx(1.0, abs=rin["dt"])
    n_frames = rin["n_steps"] // rin["rec_steps"] + 1
    assert z["t"][-1] == pytest.approx(((n_frames - 1) * rin["rec_steps"] + 1) * rin["dt"], rel=1e-12)


def test_collider_verlet_distance_is_speed_only(tmp_path):
    """The gas script pads the collider's bounds by three bounding radii (fewer re-sorts in the dilute
    gas); contacts still come from the exact geometry every step, so a colliding gas records the same
    trajectory as with YADE's default padding (run file ``verlet_dist = -0.5``), to the last bit."""
    sp = tiny(tmp_path, t_end=6.0, cases=("exact",))
    run = S.runs(sp)[0]
    rin = S.run_input(run["params"])
    outs = {}
    for tag, extra in (("study", {}), ("default", {"verlet_dist": -0.5})):
        d = tmp_path / tag
        d.mkdir()
        (d / "run.json").write_text(json.dumps(dict(rin, **extra)))
        (d / "t").write_text(f"run out\n{str(d / 'run.json')!r} {str(d / 'out')!r}\n")
        env = dict(os.environ, OMP_NUM_THREADS="1", YADE_BATCH=f"{d / 't'}:2", CLUMPPROPS_ROOT=ROOT)
        r = subprocess.run(["yade", "-n", "-x", os.path.join(ROOT, "yade_scripts", "granular_gas.py")], env=env,
                           cwd=d, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
        outs[tag] = (np.load(d / "out.npz"), json.loads((d / "out.json").read_text()))
    (za, fa), (zb, fb) = outs["study"], outs["default"]
    rb, r = 0.0333 + 0.0667, 0.0667                       # the dimer's bounding and member radii
    assert fb["verlet_dist"] == -0.5
    spacing = rin["box_length"] / (2 * len(rin["initial"]["pos"])) ** (1 / 3)   # two members per dimer
    assert fa["verlet_dist"] == pytest.approx(min(3 * rb, rin["box_length"] / 8 - r, spacing / 4), rel=1e-3)
    assert fa["verlet_dist"] > 2 * 0.0333                 # padded well beyond the default 0.033 m
    assert za["e_elastic"].max() > 0                      # the gas collided
    for k in ("disp", "vel", "e_trans", "e_rot", "e_elastic", "momentum"):
        np.testing.assert_array_equal(za[k], zb[k])


def test_the_eta_starts_from_the_cost_model_and_takes_the_runs_own_pace_after_a_tenth():
    """No wild first ETA: before a tenth of a run is done its remaining time is the cost model's
    expected time for the part left (start-up does not dominate it); afterwards the run's own pace."""
    now = 1000.0
    assert eta.remaining_s(600.0, None, now) == 600.0                       # queued: the model
    early = {"t": 2.0, "t_end": 400.0, "started": now - 30.0, "wall": now}      # 0.5 % done after a slow start
    assert eta.remaining_s(600.0, early, now) == pytest.approx(600.0 * (1 - 2.0 / 400.0))
    later = {"t": 100.0, "t_end": 400.0, "started": now - 200.0, "wall": now}   # a quarter in 200 s
    assert eta.remaining_s(600.0, later, now) == pytest.approx(600.0)        # 3 quarters at its pace
    assert math.isnan(eta.remaining_s(float("nan"), early, now))            # no model, no pace yet: unknown


def test_the_first_progress_line_of_a_study_states_the_model_eta(tmp_path):
    """The study ETA of the first line is the cost model's: the expected time of every run left, over the workers."""
    sp = tiny(tmp_path, cases=("exact", "uncorrected"), seeds=(1, 2))
    runs = S.runs(sp)
    futs = {object(): r for r in runs}
    expected = {r["key"]: 100.0 for r in runs}
    line = eta.progress_line(str(tmp_path), futs, set(futs), expected, 2, 1.0, 0, len(runs))
    assert f"study eta {eta.fmt_s(100.0 * len(runs) / 2)}" in line and "0 running" in line


def test_a_second_driver_on_a_results_directory_is_refused_until_the_first_releases_its_lock(tmp_path):
    with engine.DriverLock(str(tmp_path)) as held:
        assert held.locked_at <= time.time()
        with pytest.raises(SystemExit, match="another driver is running on"):
            with engine.DriverLock(str(tmp_path)):
                pass
    with engine.DriverLock(str(tmp_path)) as again:                  # released on leaving the block
        assert again.locked_at >= held.locked_at


def test_the_drain_forgets_an_earlier_drivers_drain_and_says_a_deadline_once(tmp_path):
    lines = []
    drain = engine.Drain(str(tmp_path), lines.append)
    path = tmp_path / engine.DRAIN
    path.write_text("")
    os.utime(path, (time.time() - 60, time.time() - 60))              # asked of an earlier driver
    drain.forget_earlier(time.time())
    assert not path.exists()
    path.write_text("")                                               # asked of this driver: stays
    drain.forget_earlier(time.time() - 60)
    assert path.exists()
    path.write_text(f"{time.time() + 3600:.0f}")                      # a deadline an hour away
    assert not drain.begins() and not drain.begins() and not drain.draining
    assert len(lines) == 1 and lines[0].startswith("[study] drain by ")
    path.write_text(f"{time.time() - 1:.0f}")                         # the deadline has passed
    assert drain.begins() and drain.draining and not drain.begins()  # the drain begins once


def test_a_manifest_row_keeps_the_old_rows_state_and_takes_the_runs_identity():
    from studies import manifest

    run = {"key": "k1", "name": "dimer-exact-paired-s1-k1", "group": 0, "shape": "dimer", "case": "exact",
           "protocol": "paired", "seed": 1, "params": {}}
    assert manifest.new_row(run) == dict({k: run[k] for k in manifest.RUN_FIELDS}, status="todo", attempts=0,
                                         error="", record="")
    old = {"key": "k1", "name": "renamed", "status": "failed", "attempts": "2", "error": "boom", "wall_s": "3.0"}
    row = manifest.new_row(run, old)
    assert row["name"] == run["name"] and row["status"] == "failed" and row["attempts"] == 2
    assert row["error"] == "boom" and row["wall_s"] == "3.0" and row["yade_version"] == ""


def test_max_runs_runs_the_first_runs_of_the_schedule_and_leaves_the_rest_to_do(tmp_path):
    sp = tiny(tmp_path, t_end=1.0, cases=("exact", "uncorrected"), seeds=(1, 2))
    lines = []
    rows = engine.sweep(sp, workers=1, allow_dirty=True, max_runs=1, log=lines.append)
    done = [r["name"] for r in rows.values() if r["status"] == "done"]
    assert done == [next(r["name"] for r in S.runs(sp) if r["seed"] == 1 and r["case"] == "exact")], rows
    assert sum(r["status"] == "todo" for r in rows.values()) == 3
    assert "4 runs, 0 already complete, 1 to do" in lines[0]
    assert lines[-1].startswith("[study] finished 1 runs in ") and lines[-1].endswith(": 1 ok, 0 flagged, 0 failed")
