"""studies.hcs on synthetic data with known answers, and the spec keys of dissipative gases (no YADE)."""
import copy
import math
import tomllib

import numpy as np
import pytest

from studies import hcs
from studies import spec as S

ROOT_SPEC = "studies/specs/hcs_test.toml"


def test_temperatures_follow_the_degrees_of_freedom():
    # 10 particles with 1.5 J translational each: T_tr = 1 J; 2 rotational dof with 1 J each: T_rot = 1 J
    t_tr, t_rot = hcs.temperatures([15.0], [10.0], 10, 2)
    assert t_tr[0] == pytest.approx(1.0) and t_rot[0] == pytest.approx(1.0)
    _, t_rot3 = hcs.temperatures([15.0], [15.0], 10, 3)
    assert t_rot3[0] == pytest.approx(1.0)
    with pytest.raises(ValueError):
        hcs.temperatures([1.0], [1.0], 10, 1)


def test_rotational_dof_of_each_route():
    assert hcs.rotational_dof({"body": {"builder": "sphere", "route": "isotropic"}}) == 3
    assert hcs.rotational_dof({"body": {"builder": "clumpprops", "route": "aspherical"}}) == 3
    assert hcs.rotational_dof({"body": {"builder": "appendClumped", "route": "isotropic"}}) == 2


def test_haff_fit_recovers_a_noisy_cooling_curve():
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 40.0, 400)
    t0, tau0 = 2.5, 12.0
    temp = t0 / (1 + t / tau0) ** 2 * np.exp(rng.normal(0.0, 0.01, t.size))     # 1 % noise per frame
    fit = hcs.fit_haff(t, temp)
    assert fit["tau0"] == pytest.approx(tau0, rel=0.01)
    assert fit["t0"] == pytest.approx(t0, rel=0.005)
    assert fit["zeta0"] == pytest.approx(2.0 / tau0, rel=0.01)
    assert abs(fit["tau0"] - tau0) < 4 * fit["tau0_se"]
    assert fit["rms_log"] == pytest.approx(0.01, rel=0.15)


def test_haff_fit_window_leaves_out_a_late_deviation():
    t = np.linspace(0.0, 30.0, 301)
    temp = 1.0 / (1 + t / 5.0) ** 2
    temp[t > 20] *= np.exp(-0.2 * (t[t > 20] - 20))        # clustering: faster cooling late
    assert hcs.fit_haff(t, temp, 0.0, 20.0)["tau0"] == pytest.approx(5.0, rel=1e-6)
    assert hcs.fit_haff(t, temp)["tau0"] < 4.9
    with pytest.raises(ValueError):
        hcs.fit_haff(t, temp, 29.95, 30.0)


def test_temperature_ratio_after_its_transient():
    rng = np.random.default_rng(5)
    t = np.linspace(0.0, 50.0, 1001)
    t_tr = 1.0 / (1 + t / 10.0) ** 2
    ratio = 0.4 * (1 - np.exp(-t / 1.5)) * (1 + rng.normal(0.0, 0.02, t.size))
    r = hcs.temperature_ratio(t, t_tr, ratio * t_tr, t_lo=10.0)
    assert r["ratio"] == pytest.approx(0.4, abs=3 * r["se"] + 1e-4)
    assert r["se"] < 0.002
    assert hcs.temperature_ratio(t, t_tr, ratio * t_tr, t_lo=0.0)["ratio"] < 0.39     # the transient biases low


def test_scaled_msd_gives_d0():
    t = np.linspace(0.0, 60.0, 601)
    d0, tau0 = 0.03, 8.0
    msd = 6 * d0 * tau0 * np.log1p(t / tau0) - 0.05 + np.random.default_rng(1).normal(0, 1e-3, t.size)
    fit = hcs.fit_scaled_msd(t, msd, tau0, t_lo=5.0)
    assert fit["d0"] == pytest.approx(d0, rel=0.005)
    assert fit["intercept"] == pytest.approx(-0.05, abs=2e-3)
    # a linear MSD (elastic diffusion) read in the scaled time does not give a constant D0
    lin = hcs.fit_scaled_msd(t, 6 * d0 * t, tau0, t_lo=5.0)
    assert lin["d0"] > 1.5 * d0


def test_msd_from_start():
    disp = np.zeros((3, 2, 3))
    disp[1, 0] = [1.0, 0, 0]
    disp[2] = [[1.0, 1.0, 0], [0, 0, 2.0]]
    assert hcs.msd_from_start(disp).tolist() == [0.0, 0.5, 3.0]


def test_count_variance_ratio_uniform_vs_clustered():
    rng = np.random.default_rng(7)
    box, n = 10.0, 4000
    uniform = rng.uniform(0, box, (n, 3))
    r_uni = hcs.count_variance_ratio(uniform, box, 5)
    assert abs(r_uni - 1.0) < 3 * math.sqrt(2 / (125 - 1))
    centres = rng.uniform(0, box, (20, 3))
    clustered = centres[rng.integers(0, 20, n)] + rng.normal(0, 0.3, (n, 3))    # wrapped inside
    assert hcs.count_variance_ratio(clustered, box, 5) > 5.0
    both = hcs.count_variance_ratio(np.stack([uniform, clustered]), box, 5)
    assert both.shape == (2,) and both[0] == pytest.approx(r_uni)


def test_flow_energy_ratio_is_one_without_correlations_and_measures_an_imposed_shear_flow():
    """Independent velocities give 1 within the noise sqrt(2 / (3 (M - 1))); a shear flow
    u_x = A sin(2 pi z / L) on top adds the cells' mean flow, whose energy follows from the cell
    average of the sine (sin(pi/4) / (pi/4) for 4 cells per side): an independent closed form."""
    rng = np.random.default_rng(3)
    box, n, m, sigma = 10.0, 4000, 4, 1.5
    pos = rng.uniform(0, box, (6, n, 3))
    vel = rng.normal(0.0, sigma, (6, n, 3)) + 2.0                        # the gas's mean velocity is removed
    still = hcs.flow_energy_ratio(pos, vel, box, m)
    assert still.shape == (6,) and abs(still.mean() - 1.0) < 3 * math.sqrt(2 / (3 * (m ** 3 - 1))) / math.sqrt(6)
    amp = sigma
    sheared = vel.copy()
    sheared[..., 0] += amp * np.sin(2 * np.pi * pos[..., 2] / box)
    sinc = math.sin(math.pi / m) / (math.pi / m)
    expected = (n * (amp * sinc) ** 2 / 2 / (m ** 3 - 1) + 3 * sigma ** 2) / (3 * sigma ** 2 + amp ** 2 / 2)
    assert hcs.flow_energy_ratio(pos, sheared, box, m).mean() == pytest.approx(expected, rel=0.05)
    assert hcs.flow_energy_ratio(pos[0], vel[0], box, m) == pytest.approx(still[0])
    # particles packed into 8 of the 64 cells, unequally: the normalisation counts occupied cells
    packed = np.concatenate([rng.uniform(0, box / m, (6, n // 2, 3)),
                             rng.uniform(0, box / m, (6, n // 2, 3)) + (box / m) * rng.integers(1, m, (6, n // 2, 1))
                             * np.array([1.0, 0.0, 0.0])], axis=1)
    packed[:, n // 2:, 1:] += (box / m) * rng.integers(0, 2, (6, n // 2, 2))
    occupied = [len(np.unique(hcs._cells(p, box, m))) for p in packed]
    assert all(2 < k < 16 for k in occupied)
    few = hcs.flow_energy_ratio(packed, vel, box, m)
    assert abs(few.mean() - 1.0) < 3 * math.sqrt(2 / (3 * (min(occupied) - 1))) / math.sqrt(6)
    assert math.isnan(hcs.flow_energy_ratio(np.full((5, 3), 1.0), vel[0, :5], box, m))      # one cell
    assert math.isnan(hcs.flow_energy_ratio(pos[0], np.ones((n, 3)), box, m))                # no motion
    with pytest.raises(ValueError, match="velocities"):
        hcs.flow_energy_ratio(pos, vel[:, :10], box, m)
    with pytest.raises(ValueError, match="particles"):
        hcs.flow_energy_ratio(pos[0, :1], vel[0, :1], box, m)


def test_homogeneous_until_marks_the_onset_of_clustering():
    rng = np.random.default_rng(2)
    m = 64
    t = np.arange(100, dtype=float)
    ratio = 1 + rng.normal(0, math.sqrt(2 / (m - 1)), t.size)
    ratio[60:] += np.linspace(0, 5, 40)
    t_end = hcs.homogeneous_until(t, ratio, m)
    assert 60 <= t_end <= 75
    assert hcs.homogeneous_until(t[:55], ratio[:55], m) == 54.0


def test_haff_theory_dilute_limit():
    # phi -> 0: chi -> 1; zeta = (1 - e^2)/3 omega (1 + 3 a2/16) with omega = 4 sqrt(pi) n sigma^2 sqrt(T/m)
    th = hcs.haff_theory(100, 1000.0, 0.2, 1.0, 4.0, 0.9)
    omega = 4 * math.sqrt(math.pi) * 100 / 1e9 * 0.04 * 2.0
    assert th["omega0"] == pytest.approx(omega, rel=1e-6)
    assert th["zeta0"] == pytest.approx(0.19 / 3 * omega, rel=0.005)
    assert th["tau0"] == pytest.approx(2 / th["zeta0"])


def _raw():
    with open(ROOT_SPEC, "rb") as f:
        return tomllib.load(f)


def test_spec_checks_of_the_contact_keys():
    for table, key, bad in (("material", "restitution", 1.2), ("material", "restitution", 0.0),
                            ("material", "tangential_restitution", -0.1), ("material", "friction", -0.5),
                            ("run", "cooling_stop", 1.0)):
        raw = _raw()
        raw[table][key] = bad
        with pytest.raises(S.SpecError, match=f"{table}.{key}"):
            S.validate(raw)


def test_friction_turns_a_linear_clump_aspherical_and_needs_yade_2025():
    raw = _raw()
    raw["groups"][1]["cases"] = ["spheres", "exact"]            # the dimer: a linear clump
    with pytest.raises(S.SpecError, match="has friction .* set study.yade = '2025.2'"):
        S.validate(raw)
    raw["groups"][1]["friction"] = 0.0
    S.validate(raw)
    raw["groups"][1]["friction"] = 0.5
    raw["groups"][0]["cases"] = ["exact"]
    raw["study"]["yade"] = "2025.2"
    runs = {(r["params"]["case"], "friction" in r["params"]["material"]): r["params"] for r in S.runs(S.validate(raw))}
    rough, smooth = S.run_input(runs[("exact", True)]), S.run_input(runs[("exact", False)])
    assert (rough["body"]["route"], rough["rot_dof"]) == ("aspherical", 3)
    assert (smooth["body"]["route"], smooth["rot_dof"]) == ("isotropic", 2)
    # the frictional dimer starts with spin about its axis too (3 rotational degrees of freedom in
    # equipartition); the frictionless one with none
    ori = np.asarray(rough["initial"]["ori"]).reshape(-1, 3, 3)
    axial = np.einsum("nij,ni->nj", ori, np.asarray(rough["initial"]["angvel"]))[:, 2]
    assert np.all(np.abs(axial) > 0)
    ori = np.asarray(smooth["initial"]["ori"]).reshape(-1, 3, 3)
    axial = np.einsum("nij,ni->nj", ori, np.asarray(smooth["initial"]["angvel"]))[:, 2]
    assert np.max(np.abs(axial)) < 1e-12 * np.max(np.abs(smooth["initial"]["angvel"]))
    # the moments are the exact principal ones: the axial one is the smallest, not I_perp
    m = rough["body"]["moments"]
    assert m[0] < m[1] == pytest.approx(m[2])


def test_spin_ratio_starts_a_sphere_gas_at_that_temperature_ratio():
    raw = _raw()
    raw["groups"][1]["spin_ratio"] = 1.0
    rough_spun = [r["params"] for r in S.runs(S.validate(raw))][1]
    rin = S.run_input(rough_spun)
    m, i0 = rin["body"]["mass"], rin["case"]["moments"][0]
    e_tr = 0.5 * m * np.sum(np.asarray(rin["initial"]["vel"]) ** 2)
    e_rot = 0.5 * i0 * np.sum(np.asarray(rin["initial"]["angvel"]) ** 2)
    assert e_rot / e_tr == pytest.approx(1.0, rel=1e-12)
    # the translational start is the one without spins, and the key is absent where not given
    plain = [r["params"] for r in S.runs(S.validate(_raw()))][1]
    assert "spin_ratio" not in plain["gas"] and rough_spun["gas"]["spin_ratio"] == 1.0
    assert np.array_equal(S.run_input(plain)["initial"]["vel"], rin["initial"]["vel"])
    assert not np.any(S.run_input(plain)["initial"]["angvel"])


def test_contact_keys_reach_the_run_file_only_when_given():
    spec = S.validate(_raw())
    smooth, rough = [r["params"] for r in S.runs(spec)]
    assert smooth["material"]["restitution"] == 0.9 and "friction" not in smooth["material"]
    assert rough["material"]["friction"] == 0.5
    assert smooth["run"]["cooling_stop"] == 4.0
    rin = S.run_input(smooth)
    assert rin["material"]["restitution"] == 0.9 and rin["cooling_stop"] == 4.0
    elastic = copy.deepcopy(_raw())
    del elastic["material"]["restitution"], elastic["run"]["cooling_stop"], elastic["groups"][1]["friction"]
    spec = S.validate(elastic)
    for r in S.runs(spec):
        assert set(r["params"]["material"]) == {"density", "youngs_modulus", "poisson"}
        assert set(r["params"]["run"]) == {"t_end", "rec_interval", "dt_factor"}
        assert "cooling_stop" not in S.run_input(r["params"])
    assert set(spec["material"]) == {"density", "youngs_modulus", "poisson"}


def test_a_passing_fluctuation_of_the_counts_is_not_clustering():
    """Frames 0.05 s apart: a 0.25 s excursion above the band that reverts (as a seed of the
    tetrahedron gas shows at 3.5-3.75 s) is noise; one that lasts is a cluster."""
    m = 64
    t = np.arange(0.0, 12.0, 0.05)
    ratio = np.full(t.size, 0.9)
    ratio[(t > 3.5) & (t < 3.8)] = 1.6
    assert hcs.homogeneous_until(t, ratio, m) == t[-1]
    ratio[t > 8.0] = 1.8
    assert hcs.homogeneous_until(t, ratio, m) == pytest.approx(t[t > 8.0][0])


def test_msd_grid_holds_the_msd_between_every_pair_of_grid_frames():
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 9.0, 10)
    disp = np.cumsum(rng.normal(size=(10, 5, 3)), axis=0)
    g = hcs.msd_grid(t, disp, n_grid=4)
    idx = [0, 3, 6, 9]
    assert g["grid_t"].tolist() == t[idx].tolist()
    want = [np.mean(np.sum((disp[b] - disp[a]) ** 2, axis=1)) for k, a in enumerate(idx) for b in idx[k + 1:]]
    assert g["grid_msd"] == pytest.approx(want, rel=1e-12)
    assert len(hcs.msd_grid(t, disp)["grid_t"]) == 10          # fewer frames than the grid: every frame
    with pytest.raises(ValueError, match="shape"):
        hcs.msd_grid(t[:-1], disp)


def _scaled_time_walk(rng, d0, tau0, n=1000, frames=241, t_end=30.0):
    """Walkers whose displacement is Brownian in s = ln(1 + t / tau0) with MSD = 6 D0 tau0 s."""
    t = np.linspace(0.0, t_end, frames)
    ds = np.diff(hcs.scaled_time(t, tau0))
    steps = rng.normal(size=(frames - 1, n, 3)) * np.sqrt(2 * d0 * tau0 * ds)[:, None, None]
    return t, np.concatenate([np.zeros((1, n, 3)), np.cumsum(steps, axis=0)])


def test_the_multi_origin_fit_recovers_d0_and_scatters_less_than_the_first_frame_fit():
    d0, tau0 = 0.02, 6.0
    first, multi = [], []
    for seed in range(12):
        t, disp = _scaled_time_walk(np.random.default_rng(seed), d0, tau0)
        g = hcs.msd_grid(t, disp)
        multi.append(hcs.fit_scaled_msd_grid(g["grid_t"], g["grid_msd"], tau0, t_lo=3.0)["d0"])
        first.append(hcs.fit_scaled_msd(t, hcs.msd_from_start(disp), tau0, t_lo=3.0)["d0"])
    # 1000 walkers: one MSD scatters sqrt(2 / 3000) = 2.6 %; the mean of 12 seeds within 4 of its errors
    assert np.mean(multi) == pytest.approx(d0, abs=4 * np.std(multi, ddof=1) / math.sqrt(12))
    assert np.mean(first) == pytest.approx(d0, abs=4 * np.std(first, ddof=1) / math.sqrt(12))
    assert np.std(multi, ddof=1) < 0.8 * np.std(first, ddof=1)


def test_the_multi_origin_fit_refuses_a_window_without_pairs():
    t, disp = _scaled_time_walk(np.random.default_rng(1), 0.02, 6.0, n=10)
    g = hcs.msd_grid(t, disp)
    with pytest.raises(ValueError, match="grid pairs"):
        hcs.fit_scaled_msd_grid(g["grid_t"], g["grid_msd"], 6.0, t_lo=29.0)
    with pytest.raises(ValueError, match="pair MSDs"):
        hcs.fit_scaled_msd_grid(g["grid_t"], g["grid_msd"][:-1], 6.0)
    with pytest.raises(ValueError, match="tau0"):
        hcs.fit_scaled_msd_grid(g["grid_t"], g["grid_msd"], 0.0)


def test_rereduce_gives_records_without_the_grid_what_the_reduction_stores_now(tmp_path):
    """A record reduced before the multi-origin grid existed gets it from the run's kept raw frames,
    equal to a fresh reduction's, and nothing else in it changes; a record without raw frames stays."""
    import json
    from studies import reduce as red, runner
    rng = np.random.default_rng(2)
    n, nf = 20, 30
    t, disp = _scaled_time_walk(rng, 0.02, 6.0, n=n, frames=nf)
    fr = {"t": t, "disp": disp, "vel": rng.normal(size=(nf, n, 3)), "e_trans": np.linspace(30.0, 10.0, nf),
          "e_rot": np.linspace(30.0, 9.0, nf), "e_elastic": np.zeros(nf), "momentum": np.zeros((nf, 3)),
          "e_dissipated": np.linspace(0.0, 41.0, nf)}
    rin = {"initial": {"pos": rng.uniform(0, 4.0, (n, 3)).tolist(), "vel": fr["vel"][0].tolist()}, "box_length": 4.0,
           "body": {"builder": "clumpprops", "route": "aspherical", "mass": 1.0}, "material": {"restitution": 0.9}}
    fresh = red.reduce_run(fr, rin, [0.0], 1.0, 1.0, 1.0)
    assert {"grid_t", "grid_msd"} <= set(fresh["hcs"])
    old = json.loads(json.dumps(fresh))
    for k in ("grid_t", "grid_msd"):
        del old["hcs"][k]
    (tmp_path / "runs").mkdir()
    (tmp_path / "raw").mkdir()
    for name in ("a", "b"):
        (tmp_path / "runs" / f"{name}.json").write_text(json.dumps({**old, "name": name, "seed": 1}))
    np.savez(tmp_path / "raw" / "a.npz", **fr)
    (tmp_path / "raw" / "a.run.json").write_text(json.dumps(rin))
    assert runner.rereduce(str(tmp_path)) == (1, 1)
    assert runner.rereduce(str(tmp_path)) == (0, 1)                  # already current: not rewritten
    a = json.loads((tmp_path / "runs" / "a.json").read_text())
    assert a == {**json.loads(json.dumps(fresh)), "name": "a", "seed": 1}
    assert "grid_msd" not in json.loads((tmp_path / "runs" / "b.json").read_text())["hcs"]
    with pytest.raises(ValueError, match="times"):
        red.refresh_hcs(old, {**fr, "t": fr["t"] * 2}, rin)


def test_a_sequential_target_names_a_cooling_observable_only_for_a_cooling_gas():
    raw = _raw()
    g = raw["groups"][0]
    g.update(cases=["spheres", "exact"], max_seeds=12,
             target={"case": "spheres", "observable": "temperature_ratio", "halfwidth": 0.01})
    spec = S.validate(copy.deepcopy(raw))
    assert spec["groups"][0]["target"]["observable"] == "temperature_ratio"
    bad = copy.deepcopy(raw)
    bad["groups"][0]["target"]["observable"] = "msd"
    with pytest.raises(S.SpecError, match="target.observable: 'msd' is not one of"):
        S.validate(bad)
    elastic = copy.deepcopy(raw)
    elastic["material"].pop("restitution")
    with pytest.raises(S.SpecError, match="needs a cooling gas"):
        S.validate(elastic)
    elastic["groups"][0]["target"]["observable"] = "diffusion"
    assert S.validate(elastic)["groups"][0]["target"]["observable"] == "diffusion"
    del raw["groups"][0]["target"]["observable"]
    assert S.validate(raw)["groups"][0]["target"]["observable"] == "diffusion"      # the default: D
