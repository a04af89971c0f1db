"""The granular-gas YADE script and driver on small gases (each run: a few seconds).

Conservation, flagging of a bad run, identical initial conditions within a seed, the
ballistic MSD of a collision-free gas with unwrapped positions across the periodic
boundary, and a sweep killed and restarted that ends with the same results.
"""
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # `studies` without -m

import numpy as np
import pytest

from studies import gas_model as gm
from studies.msd import msd_fft

ROOT = gm.repo_root()
SCRIPT = os.path.join(ROOT, "yade_scripts", "granular_gas.py")
assert shutil.which("yade"), "the yade executable is missing: run scripts/setup.sh"


def run_yade(tmp, name, **params):
    """One run of the YADE script through readParamsFromTable; returns (json, npz)."""
    params = dict(params, out=str(tmp / name), progress_period=1000.0)
    table = tmp / f"{name}.table"
    table.write_text(" ".join(params) + "\n" + " ".join(repr(v) for v in params.values()) + "\n")
    env = dict(os.environ, OMP_NUM_THREADS="1", YADE_BATCH=f"{table}:2")
    env.pop("CLUMPPROPS_ROOT", None)          # the script must find the repo by itself
    p = subprocess.run(["yade", "-n", "-x", SCRIPT], env=env, cwd=tmp, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    with open(tmp / f"{name}.json") as f:
        res = json.load(f)
    z = np.load(tmp / f"{name}.npz") if res["params"]["record"] else None
    return res, z


@pytest.fixture(scope="module")
def small_gas(tmp_path_factory):
    """27 particles at volume fraction 0.02 (frequent collisions), 10 s, several cases."""
    tmp = tmp_path_factory.mktemp("gas")
    common = dict(n_particles=27, volume_fraction=0.02, t_end=10.0, seed=7)
    out = {}
    for case, prot in [("exact", "paired"), ("uncorrected", "paired"), ("spheres", "paired"),
                       ("uncorrected", "equal_energy")]:
        out[(case, prot)] = run_yade(tmp, f"{case}_{prot}", case=case, protocol=prot, **common)
    out["other_seed"] = run_yade(tmp, "exact_seed8", case="exact", **dict(common, seed=8, t_end=0.5))
    return out


@pytest.mark.parametrize("key", [("exact", "paired"), ("uncorrected", "paired"), ("spheres", "paired"),
                                 ("uncorrected", "equal_energy")])
def test_energy_and_momentum_conserved(small_gas, key):
    res, z = small_gas[key]
    assert res["ok"], res["fail_reasons"]
    assert res["energy_drift"] < 1e-3
    assert res["momentum_drift"] < 1e-9
    e = z["e_trans"] + z["e_rot"] + z["e_elastic"]
    assert np.max(np.abs(e / e[0] - 1)) == pytest.approx(res["energy_drift"])
    # the gas did collide: contacts stored energy and (clumps) rotation was excited
    assert z["e_elastic"].max() > 0
    if key[0] != "spheres":
        assert z["e_rot"][-1] > 0.05 * e[0]
        assert res["axial_spin_max"] < 1e-8 * max(res["angvel_rms"], 1.0)
    else:
        assert z["e_rot"].max() < 1e-20 * e[0]          # spheres never spin (round-off only)
    assert np.allclose(z["momentum"], 0.0, atol=1e-9 * res["e_total_initial"])


def test_clump_properties_come_from_clumpprops(small_gas):
    res, _ = small_gas[("exact", "paired")]
    assert res["builder"] == "clumpprops.yade.append_clump"
    ex = gm.case_properties("exact")
    unc = gm.case_properties("uncorrected")
    assert res["properties"]["mass"] == ex["mass"] and res["properties"]["inertia"] == ex["inertia"]
    assert small_gas[("uncorrected", "paired")][0]["properties"]["mass"] == unc["mass"]
    assert unc["mass"] / ex["mass"] == pytest.approx(1.185, abs=1e-3)     # the +18.5 % of the facts


def test_bad_run_is_flagged(tmp_path):
    # must be able to fail: 4 x the P-wave step (about 7 steps per contact) breaks the energy
    res, _ = run_yade(tmp_path, "bad", case="exact", n_particles=27, volume_fraction=0.02, t_end=10.0,
                      seed=7, dt_factor=4.0)
    assert not res["ok"]
    assert any("energy drift" in r for r in res["fail_reasons"])


def test_identical_initial_conditions_within_a_seed(small_gas):
    _, z0 = small_gas[("exact", "paired")]
    m = {c: gm.case_properties(c)["mass"] for c in gm.CASES}
    for key in [("uncorrected", "paired"), ("spheres", "paired"), ("uncorrected", "equal_energy")]:
        _, z = small_gas[key]
        np.testing.assert_allclose(z["pos0"], z0["pos0"], atol=1e-12)
        np.testing.assert_array_equal(z["axes0"], z0["axes0"])
        scale = 1.0 if key[1] == "paired" else np.sqrt(m["exact"] / m[key[0]])
        np.testing.assert_allclose(z["vel0"], scale * z0["vel0"], rtol=1e-13, atol=1e-15)
        expected = z0["e_trans"][0] * m[key[0]] / m["exact"] * scale ** 2
        assert z["e_trans"][0] == pytest.approx(expected, rel=1e-12)
        if key[1] == "equal_energy":
            assert z["e_trans"][0] == pytest.approx(z0["e_trans"][0], rel=1e-12)
    assert np.abs(z0["vel0"].sum(0)).max() < 1e-12                     # zero total momentum
    assert z0["e_trans"][0] == pytest.approx(27 * gm.ENERGY_PER_PARTICLE, rel=1e-12)
    assert np.all(np.asarray(z0["e_rot"][0]) == 0)                      # zero angular velocity
    _, zs = small_gas["other_seed"]
    assert np.abs(zs["pos0"] - z0["pos0"]).max() > 0.1                 # another seed differs


def test_ballistic_msd_and_unwrapped_positions(tmp_path):
    """8 dimers at volume fraction 1e-6 for 20 s: no collision, straight unwrapped flights."""
    res, z = run_yade(tmp_path, "free", case="exact", n_particles=8, volume_fraction=1e-6, t_end=20.0,
                      seed=3, rec_interval=0.5)
    assert res["ok"]
    assert z["e_elastic"].max() == 0.0                                  # collision-free
    t, v0 = z["t"], z["vel0"]
    np.testing.assert_allclose(z["disp"], t[:, None, None] * v0[None], rtol=0, atol=2e-5)
    # frame 0 is the state at t = 0, frames k >= 1 are at (k n_rec + 1) dt (the PyRunner fires
    # after the integrator): the time-origin average needs the evenly spaced frames 1, 2, ...
    assert np.ptp(np.diff(t[1:])) < 1e-9
    msd = msd_fft(z["disp"][1:])
    lag = t[1:] - t[1]
    np.testing.assert_allclose(msd[1:], np.mean(np.sum(v0 ** 2, 1)) * lag[1:] ** 2, rtol=1e-5)
    # positions are unwrapped: particles left the box [0, L) and kept going
    L = res["box_length"]
    pos = z["pos0"][None] + z["disp"]
    assert ((pos < 0) | (pos >= L)).any()
    assert np.abs(z["disp"]).max() > 1.0 * L


def _sweep_cmd(out, *extra):
    return [sys.executable, "-m", "studies.granular_gas", "sweep", "--scale", "tiny", "--t-end", "3",
            "--seeds", "1", "--out", str(out), *extra]


def _results(out):
    runs = os.path.join(out, "runs")
    res = {}
    for f in sorted(os.listdir(runs)):
        if f.endswith(".json"):
            with open(os.path.join(runs, f)) as fh:
                j = json.load(fh)
            z = np.load(os.path.join(runs, f[:-5] + ".npz"))
            res[f] = (j["ok"], j["energy_drift"], z["disp"].copy(), z["e_trans"].copy())
    return res


def test_killed_and_restarted_sweep_gives_the_same_results(tmp_path):
    ref, cut = tmp_path / "ref", tmp_path / "cut"
    subprocess.run(_sweep_cmd(ref), cwd=ROOT, check=True, capture_output=True, timeout=300)
    p = subprocess.Popen(_sweep_cmd(cut), cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)
    runs = cut / "runs"
    t0 = time.time()
    while time.time() - t0 < 120:                   # kill -9 the driver after its first finished run
        if runs.exists() and any(f.endswith(".json") for f in os.listdir(runs)):
            break
        time.sleep(0.05)
    n_before = sum(f.endswith(".json") for f in os.listdir(runs))
    os.kill(p.pid, signal.SIGKILL)
    p.wait()
    time.sleep(1.0)                                # children die with the driver (PDEATHSIG)
    n_killed = sum(f.endswith(".json") for f in os.listdir(runs))
    r = subprocess.run(_sweep_cmd(cut), cwd=ROOT, check=True, capture_output=True, text=True, timeout=300)
    assert "already complete" in r.stdout
    a, b = _results(ref), _results(cut)
    assert 1 <= n_before <= n_killed < len(a) == 6          # really interrupted, really resumed
    assert sorted(a) == sorted(b)
    for k in a:
        assert a[k][0] and b[k][0]
        assert a[k][1] == b[k][1]
        np.testing.assert_array_equal(a[k][2], b[k][2])
        np.testing.assert_array_equal(a[k][3], b[k][3])
    assert not [f for f in os.listdir(runs) if ".tmp" in f]
    # a third call has nothing to do
    r = subprocess.run(_sweep_cmd(cut), cwd=ROOT, check=True, capture_output=True, text=True, timeout=300)
    assert "6 already complete, 0 to do" in r.stdout


def test_analysis_excludes_flagged_runs(tmp_path):
    from studies import gas_analysis, granular_gas as gg

    out = tmp_path / "an"
    subprocess.run(_sweep_cmd(out, "--t-end", "6"), cwd=ROOT, check=True, capture_output=True, timeout=300)
    cfg = gg.scale_config("tiny", t_end=6.0)
    cfg["groups"] = [(c, p, [1]) for c, p, _ in cfg["groups"]]
    cfg.update(t_eq=0.5, fit_lo=1.0, fit_hi=2.5)
    spec = [s for s in gg.run_specs(cfg) if s["case"] == "uncorrected" and s["protocol"] == "paired"][0]
    jpath = out / "runs" / (gg.run_name(spec) + ".json")
    j = json.loads(jpath.read_text())
    j.update(ok=False, fail_reasons=["energy drift (test)"])
    jpath.write_text(json.dumps(j))
    msgs = []
    gas_analysis.analyze(cfg, str(out), log=msgs.append)
    assert any("EXCLUDED uncorrected-paired-s1" in m for m in msgs)
    import pandas as pd

    s = pd.read_csv(out / "summary.csv")
    assert list(s.columns) == ["case", "n_seeds", "diffusion_coefficient", "ci_low", "ci_high", "max_energy_drift"]
    assert "uncorrected" not in set(s.case) and "exact" in set(s.case)
    runs = pd.read_csv(out / "runs.csv")
    assert not runs[(runs.case == "uncorrected") & (runs.protocol == "paired")].ok.iloc[0]
    e = pd.read_csv(out / "energy.csv")
    assert list(e.columns) == ["case", "seed", "t", "e_trans", "e_rot", "e_elastic"]
    assert "uncorrected" not in set(e.case)
