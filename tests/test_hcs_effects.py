"""studies.hcs_effects on synthetic cooling runs whose effects are known (no YADE)."""
import csv
import math

import numpy as np
import pytest

from studies import hcs, hcs_effects as H

from _hcs_clumps import rough_dimer_runs

N, BOX, MASS = 200, 8.0, 2.0


def _series(rng, tau0, ratio, d0, transient=True):
    """A clump gas's HCS series: Haff's cooling with time tau0 after a transient of 5 s in which
    T_rot / T_tr relaxes from 1 to ``ratio`` and T_tr cools at another rate; MSD = 6 D0 tau0 s."""
    t = np.linspace(0.0, 40.0, 801)
    temp = 2.0 / (1 + t / tau0) ** 2
    r = np.full_like(t, ratio)
    if transient:
        early = t < 5.0
        temp = np.where(early, temp * (1 + 0.3 * (5.0 - t) / 5.0), temp)
        r = np.where(early, ratio + (1 - ratio) * np.exp(-3 * t), r)
    msd = 6 * d0 * tau0 * np.log1p(t / tau0) * (1 + 1e-3 * rng.normal(size=t.size))
    return {"t": t.tolist(), "e_trans": (1.5 * N * temp).tolist(), "e_rot": (1.5 * N * r * temp).tolist(),
            "msd": msd.tolist(), "count_ratio": (1 + 0.05 * rng.normal(size=t.size)).tolist(),
            "cells_per_side": 4, "n_particles": N, "rot_dof": 3, "box_length": BOX, "builder": "clumpprops",
            "mass": MASS, "diameter": None, "restitution": 0.9, "friction": 0.5}


def _records(effect, seeds=(1, 2, 3, 4), spread=0.05, transient=True):
    """Exact and uncorrected runs of the hcs_clumps spec's rough dimer, the uncorrected case's
    observables ``(1 + effect[o])`` times the exact ones of its seed; seeds differ by ``spread``."""
    rng = np.random.default_rng(7)
    out = []
    for r in rough_dimer_runs(seeds):
        p = r["params"]
        srng = np.random.default_rng(p["seed"])
        tau0, ratio, d0 = (x * (1 + spread * srng.normal()) for x in (8.0, 0.6, 0.05))
        if p["case"] == "uncorrected":
            tau0 /= 1 + effect["cooling_rate"]
            ratio *= 1 + effect["temperature_ratio"]
            d0 *= 1 + effect["diffusion"]
        out.append({"params": p, "seed": p["seed"], "case": p["case"], "yade_version": "2025.2",
                    "rot_algorithm": "delValle2023", "hcs": _series(rng, tau0, ratio, d0, transient)})
    return out


def test_known_effects_are_recovered_past_a_transient():
    effect = {"cooling_rate": 0.03, "temperature_ratio": -0.05, "diffusion": 0.02}
    rows = H.rows(_records(effect))
    assert {r["observable"] for r in rows} == set(H.OBSERVABLES) and all(r["n_pairs"] == 4 for r in rows)
    for r in rows:
        assert r["relative"] == pytest.approx(effect[r["observable"]], abs=2e-3), r
        assert r["relative_ci_low"] - 1e-9 <= effect[r["observable"]] <= r["relative_ci_high"] + 1e-9
        assert (r["shape"], r["n_spheres"], r["friction"], r["restitution"], r["case"]) == ("dimer", 2, 0.5, 0.9,
                                                                                             "uncorrected")
        assert r["mass_error"] == pytest.approx(0.185, abs=2e-3)        # the paper's dimer: summed mass +18.5 %


def test_the_transient_biases_the_cooling_rate_unless_left_out():
    """The fit starts after the transient (fitted from t = 0 the same runs give another zeta0), and
    zeta is taken at the start temperature: T_tr starts 1.3 times the Haff curve's T0 here."""
    recs = _records({"cooling_rate": 0.0, "temperature_ratio": 0.0, "diffusion": 0.0}, seeds=(1,))
    s = next(r["hcs"] for r in recs if r["case"] == "exact")
    tau0 = 8.0 * (1 + 0.05 * np.random.default_rng(1).normal())
    assert H.observables(s)["cooling_rate"] == pytest.approx(2 / tau0 * math.sqrt(1.3), rel=1e-6)
    assert hcs.analyse_series(s, fit_from=5.0)["haff"]["zeta0"] == pytest.approx(2 / tau0, rel=1e-6)
    assert abs(hcs.analyse_series(s)["haff"]["zeta0"] / (2 / tau0) - 1) > 0.02


def test_runs_without_their_exact_seed_are_left_out_and_the_csv_has_the_fixed_columns(tmp_path):
    recs = [r for r in _records({o: 0.0 for o in H.OBSERVABLES}) if not (r["case"] == "exact" and r["seed"] == 4)]
    rows = H.rows(recs)
    assert all(r["n_pairs"] == 3 for r in rows)
    path = tmp_path / "hcs_effects.csv"
    H.write(str(path), rows)
    with open(path) as f:
        got = list(csv.DictReader(f))
    assert tuple(got[0]) == H.COLUMNS and len(got) == 3
    assert math.isclose(float(got[0]["relative"]), rows[0]["relative"], rel_tol=1e-9)
    assert not H.rows([r for r in recs if r["case"] == "uncorrected"])


def test_the_relaxation_rows_flag_a_ratio_still_moving_in_the_window():
    """Runs whose T_rot / T_tr keeps falling through the window (no transient modelled) against runs
    settled after 5 s: the drift interval excludes 0 only for the first."""
    recs = _records({o: 0.0 for o in H.OBSERVABLES})
    moving = []
    for r in recs:
        s = dict(r["hcs"])
        t = np.asarray(s["t"])
        s["e_rot"] = (np.asarray(s["e_rot"]) * (1 - 0.01 * t)).tolist()      # ratio falls 1 % per second
        moving.append(dict(r, hcs=s))
    for rows, still in ((H.relaxation_rows(recs), False), (H.relaxation_rows(moving), True)):
        assert {r["case"] for r in rows} == {"exact", "uncorrected"} and all(r["n_runs"] == 4 for r in rows)
        for r in rows:
            assert (r["drift_ci_high"] < 0) == still, r
            assert r["window_start"] == 5.0 and r["window_end"] == 40.0


def test_the_relaxation_rows_tell_a_growing_flow_field_from_a_still_one():
    """Series whose flow ratio stays at 1.05 give a growth interval around 0; ones whose flow ratio
    grows 3 % per second (vortices forming) give one above 0; runs without it are not counted."""
    rng = np.random.default_rng(11)
    recs = _records({"cooling_rate": 0.0, "temperature_ratio": 0.0, "diffusion": 0.0})

    def with_flow(rec, rate):
        s = dict(rec["hcs"])
        t = np.asarray(s["t"])
        s["flow_ratio"] = (1.05 * (1 + rate * t) + rng.normal(0, 0.03, len(t))).tolist()
        return dict(rec, hcs=s)

    for rate, growing in ((0.0, False), (0.03, True)):
        rows = H.relaxation_rows([with_flow(r, rate) for r in recs])
        for r in rows:
            assert r["flow_runs"] == 4 and (r["flow_growth_ci_low"] > 0) == growing, r
            assert r["flow_ratio"] > 1.0
    bare = H.relaxation_rows(recs)
    assert all(r["flow_runs"] == 0 and math.isnan(r["flow_growth"]) for r in bare)


def _noisy(rec, rng, scale=2e-3):
    """The record with T_rot and T_tr scattered frame by frame (relative ``scale``)."""
    s = dict(rec["hcs"])
    for k in ("e_trans", "e_rot"):
        v = np.asarray(s[k])
        s[k] = (v * (1 + scale * rng.normal(size=v.size))).tolist()
    return dict(rec, hcs=s)


def test_the_window_check_finds_an_effect_that_moves_with_the_window_and_none_in_the_hcs():
    """In the HCS dropping the window's first quarter moves no effect; a case whose T_rot / T_tr
    still relaxes slowly (about 10 % above its value, decaying over 10 s) reads a smaller ratio
    effect from the later window, and the check's interval says so."""
    rng = np.random.default_rng(5)
    recs = [_noisy(r, rng) for r in _records({"cooling_rate": 0.03, "temperature_ratio": -0.05, "diffusion": 0.02})]
    rows = H.window_rows(recs)
    assert len(rows) == 3 and all(r["n_pairs"] == 4 for r in rows)
    for r in rows:
        assert r["shift_ci_low"] <= 0.0 <= r["shift_ci_high"] and r["shift_ci_high"] - r["shift_ci_low"] < 0.01, r
        assert r["window_start"] == 5.0 and r["later_start"] == pytest.approx(5.0 + 0.25 * 35.0) and r["drop"] == 0.25
    slow = []
    for r in recs:
        s = dict(r["hcs"])
        if r["case"] == "uncorrected":
            t = np.asarray(s["t"])
            amp = 0.1 * (1 + 0.3 * np.random.default_rng(r["seed"]).normal())
            s["e_rot"] = (np.asarray(s["e_rot"]) * (1 + amp * np.exp(-t / 10.0))).tolist()
        slow.append(dict(r, hcs=s))
    ratio = next(r for r in H.window_rows(slow) if r["observable"] == "temperature_ratio")
    assert ratio["shift_ci_high"] < 0 and ratio["shift_ci_low"] < ratio["shift"] < -0.005
    with pytest.raises(ValueError, match="drop"):
        H.window_rows(recs, drop=1.0)


def test_the_window_check_starts_both_runs_of_a_seed_together_and_names_a_seed_it_leaves_out():
    """A seed whose uncorrected run stops being homogeneous at 21 s: both its runs start their later
    window at 5 + (21 - 5) / 4 = 9 s; a seed whose window ends 0.15 s past the transient has no
    later window to fit, is named, and its pair leaves the shift but not hcs_effects.csv."""
    rng = np.random.default_rng(6)
    recs = [_noisy(r, rng) for r in _records({"cooling_rate": 0.03, "temperature_ratio": -0.05, "diffusion": 0.02})]

    def ending(rec, t_end):
        s = dict(rec["hcs"])
        s["count_ratio"] = np.where(np.asarray(s["t"]) >= t_end, 10.0, 1.0).tolist()
        return dict(rec, hcs=s)

    recs = [ending(r, 21.0) if (r["seed"], r["case"]) == (2, "uncorrected") else r for r in recs]
    rows = H.window_rows(recs)
    assert rows[0]["later_start"] == pytest.approx(np.mean([5.0 + 0.25 * 35.0] * 3 + [9.0]))
    short = [ending(r, 5.15) if (r["seed"], r["case"]) == (3, "uncorrected") else r for r in recs]
    left = []
    rows = H.window_rows(short, left_out=left)
    assert all(r["n_pairs"] == 3 for r in rows) and len(left) >= 1
    assert all(r["n_pairs"] == 4 for r in H.rows(short))


def _with_grid(rec, d0_grid_factor):
    """The record with a multi-origin MSD grid whose D0 is ``d0_grid_factor`` times its first-frame MSD's."""
    s = dict(rec["hcs"])
    t = np.asarray(s["t"])
    tau0 = hcs.fit_haff(t, np.asarray(s["e_trans"]) + np.asarray(s["e_rot"]), 5.0)["tau0"]
    d0 = hcs.fit_scaled_msd(t, np.asarray(s["msd"]), tau0, 5.0)["d0"]
    gt = t[::20]
    i, j = np.triu_indices(len(gt), 1)
    sc = hcs.scaled_time(gt, tau0)
    s.update(grid_t=gt.tolist(), grid_msd=(6 * d0 * d0_grid_factor * tau0 * (sc[j] - sc[i]) - 0.01).tolist())
    return dict(rec, hcs=s)


def test_the_diffusion_row_reads_the_msd_from_the_first_frame_even_where_every_pair_has_a_grid():
    """Grids that read the uncorrected case's D0 4 % higher than its first-frame MSD does (a grid
    biased by the velocity's memory): the row stays the first-frame MSD's 2 % effect."""
    effect = {"cooling_rate": 0.0, "temperature_ratio": 0.0, "diffusion": 0.02}
    recs = [_with_grid(r, 1.04 if r["case"] == "uncorrected" else 1.0) for r in _records(effect)]
    pairs = H.paired(recs)
    grid = next(iter(pairs.values()))["relative"]["diffusion_grid"]
    assert np.mean(grid) == pytest.approx(1.02 * 1.04 - 1, abs=2e-3)      # the grid is read, and differs
    row = {r["observable"]: r for r in H.rows(recs)}["diffusion"]
    assert row["n_pairs"] == 4 and row["relative"] == pytest.approx(0.02, abs=2e-3)


def test_a_run_whose_window_ends_before_its_transient_is_named_and_its_pair_left_out(capsys):
    recs = _records({o: 0.0 for o in H.OBSERVABLES})
    short = []
    for r in recs:
        if r["case"] == "uncorrected" and r["seed"] == 2:
            s = dict(r["hcs"])
            s["count_ratio"] = [1.0] * 60 + [9.0] * (len(s["t"]) - 60)      # clustered from t = 3 s on
            r = dict(r, hcs=s, name="rough-uncorrected-paired-s2")
        short.append(r)
    left_out = []
    rows = H.rows(short, left_out=left_out)
    assert all(r["n_pairs"] == 3 for r in rows)
    assert [name for name, _ in left_out] == ["rough-uncorrected-paired-s2"] and "frames" in left_out[0][1]
    with pytest.raises(ValueError, match="frames"):
        H.observables(next(r for r in short if r.get("name") == "rough-uncorrected-paired-s2")["hcs"])


def test_the_sequential_design_reads_a_cooling_groups_target_observable():
    """design.paired_relative on cooling records: each seed's effect on the target's observable
    (the synthetic runs' known -5 % on T_rot / T_tr, +3 % on the cooling rate); a pair whose run
    fails its checks or cannot be analysed is left out."""
    from studies import design
    effect = {"cooling_rate": 0.03, "temperature_ratio": -0.05, "diffusion": 0.02}
    recs = _records(effect)
    by_key, runs = {}, []
    for r in recs:
        key = f"{r['case']}-{r['seed']}"
        by_key[key] = dict(r, checks={"ok": not (r["case"] == "exact" and r["seed"] == 3)})
        runs.append({"key": key, "case": r["case"], "seed": r["seed"]})
    for obs in ("temperature_ratio", "cooling_rate", "diffusion"):
        got = design.paired_relative(by_key, runs, "uncorrected", 0.0, obs)
        assert [s for s, _ in got] == [1, 2, 4]
        assert [v for _, v in got] == pytest.approx([effect[obs]] * 3, abs=2e-3)
    clustered = dict(by_key["uncorrected-2"]["hcs"], count_ratio=[9.0] * 801)
    by_key["uncorrected-2"] = dict(by_key["uncorrected-2"], hcs=clustered)
    assert [s for s, _ in design.paired_relative(by_key, runs, "uncorrected", 0.0, "cooling_rate")] == [1, 4]
