"""studies.hcs_settling on synthetic cooling runs whose bin-by-bin effects are known (no YADE)."""
import csv
import math

import numpy as np
import pytest

from studies import hcs_settling as HS
from studies import spec as S

from _hcs_clumps import rough_dimer_runs

N = 200


def _series(tau0, ratio, t_end=60.0, clusters_at=None, noise=0.0, rng=None, dt=0.05):
    """Haff's cooling T_tr = 2 / (1 + t / tau0)^2 with T_rot / T_tr = ratio(t) (a number or a function
    of t), frames ``dt`` apart; ``noise``: independent relative noise on E_rot frame by frame; the
    count-variance ratio leaves its homogeneous band at ``clusters_at``."""
    t = np.arange(0.0, t_end + 1e-9, dt)
    temp = 2.0 / (1 + t / tau0) ** 2
    r = ratio(t) if callable(ratio) else np.full_like(t, ratio)
    if noise:
        r = r * (1 + noise * rng.normal(size=t.size))
    count = np.ones_like(t) if clusters_at is None else np.where(t < clusters_at, 1.0, 3.0)
    return {"t": t.tolist(), "e_trans": (1.5 * N * temp).tolist(), "e_rot": (1.5 * N * r * temp).tolist(),
            "count_ratio": count.tolist(), "cells_per_side": 4, "n_particles": N, "rot_dof": 3}


def _records(case_series, seeds=(1, 2, 3, 4), spread=0.05):
    """Exact and uncorrected runs of hcs_clumps' rough dimer; ``case_series(seed_rng, tau0, ratio)``
    gives the uncorrected run's series from the exact run's tau0 and ratio."""
    out = []
    for r in rough_dimer_runs(seeds):
        p = r["params"]
        srng = np.random.default_rng(p["seed"])
        tau0, ratio = 8.0 * (1 + spread * srng.normal()), 0.6 * (1 + spread * srng.normal())
        s = _series(tau0, ratio) if p["case"] == "exact" else case_series(srng, tau0, ratio)
        out.append({"params": p, "seed": p["seed"], "case": p["case"], "hcs": s})
    return out


def _by_bin(rows, observable):
    return {round(r["s_low"], 6): r for r in rows if r["observable"] == observable}


def test_constant_effects_come_back_in_every_bin():
    """A case cooling 3 % faster (tau0 / 1.03 from the same start temperature) with a ratio 5 % lower
    reads +3 % and -5 % in every bin: the bin rate at the start temperature is Haff's 2 / tau0."""
    rows = HS.rows(_records(lambda rng, tau0, ratio: _series(tau0 / 1.03, 0.95 * ratio)), "synthetic")
    for o, effect in (("cooling_rate", 0.03), ("temperature_ratio", -0.05)):
        bins = _by_bin(rows, o)
        assert len(bins) >= 8, bins          # s reaches ln(1 + 60 / 8) > 2: ten bins of 0.2
        for r in bins.values():
            assert r["n_pairs"] == 4 and r["study"] == "synthetic" and r["case"] == "uncorrected"
            assert r["relative"] == pytest.approx(effect, abs=1e-3), r


def test_a_bin_rate_is_haffs_rate_at_the_start_temperature():
    """Closed form: T = T0 / (1 + t / tau0)^2 cools at zeta = 2 sqrt(T / T0) / tau0."""
    s = _series(8.0, 0.6)
    t = np.asarray(s["t"])
    sc = np.log1p(t / 8.0)
    for lo in (0.2, 0.8, 1.6):
        v = HS.bin_values(s, (sc >= lo) & (sc < lo + 0.2))
        # the least-squares slope weights the rate parabolically over the bin, the denominator
        # uniformly: for Haff's law the ratio is 1 - w^2 / 30 for a bin w wide in s, wherever it lies
        assert v["cooling_rate"] == pytest.approx(2 / 8.0 * (1 - 0.2 ** 2 / 30), rel=2e-4)
        assert v["temperature_ratio"] == pytest.approx(0.6, rel=1e-12)


def test_a_relaxing_effect_shows_as_a_trend_over_the_bins():
    """The case's ratio relaxes from the exact one's to 10 % below it over the scaled time
    (1 - exp(-s)): early bins read near 0, late bins near -10 % times the relaxed fraction."""
    def case(rng, tau0, ratio):
        return _series(tau0, lambda t: ratio * (1 - 0.1 * (1 - np.exp(-np.log1p(t / tau0)))))
    recs = _records(case)
    bins = _by_bin(HS.rows(recs), "temperature_ratio")
    first, last = bins[0.0], bins[max(bins)]
    for b in (first, last):
        # the closed form, frame by frame on each seed's own clock (its tau0 as built), then over the seeds
        want = []
        for r in recs:
            if r["case"] == "exact":
                t = np.asarray(r["hcs"]["t"])
                tau0 = 8.0 * (1 + 0.05 * np.random.default_rng(r["seed"]).normal())
                sc = np.log1p(t / tau0)
                inside = (sc >= b["s_low"]) & (sc < b["s_high"])
                want.append(np.mean(-0.1 * (1 - np.exp(-sc[inside]))))
        assert b["relative"] == pytest.approx(np.mean(want), abs=2e-4)
    assert last["relative_ci_high"] < first["relative_ci_low"]
    # its change from the first bin past the 5 s transient is resolved and has the closed form's sign
    assert last["change"] < 0 and last["change_ci_high"] < 0 and last["change_pairs"] == 4
    ref = next(r for r in bins.values() if r["s_low"] == last["reference_s"])
    assert ref["t_low"] >= 5.0 and all(r["t_low"] < 5.0 for r in bins.values() if r["s_low"] < ref["s_low"])
    assert last["change"] == pytest.approx(last["relative"] - ref["relative"], abs=1e-12)


def test_the_case_is_cut_at_the_exact_runs_times():
    """A case cooling 3 % faster, on another frame grid, whose ratio steps 10 % down at t = 20 s:
    the bins of the exact run's clock read 0 before the step, -10 % after it, and the bin holding
    it the step times the share of its frames at t >= 20 s.  Bins on the case's own clock would put
    the step into another bin."""
    def case(rng, tau0, ratio):
        s = _series(tau0 / 1.03, lambda t: np.where(t < 20.0, ratio, 0.9 * ratio), dt=0.07)
        return s
    recs = _records(case, spread=0.0)
    bins = _by_bin(HS.rows(recs), "temperature_ratio")
    t = np.asarray(next(r for r in recs if r["case"] == "exact")["hcs"]["t"])
    sc = np.log1p(t / 8.0)
    step = math.log1p(20.0 / 8.0)
    for lo, r in bins.items():
        inside = (sc >= lo) & (sc < lo + 0.2)
        t_case = np.arange(0.0, 60.0 + 1e-9, 0.07)
        in_case = (t_case >= t[inside][0] - 1e-9) & (t_case <= t[inside][-1] + 1e-9)
        want = -0.1 * np.mean(t_case[in_case] >= 20.0)
        assert r["relative"] == pytest.approx(want, abs=1e-9), (lo, step)
    assert bins[0.0]["relative"] == pytest.approx(0.0, abs=1e-12) and bins[max(bins)]["relative"] == pytest.approx(-0.1)
    assert any(-0.1 < r["relative"] < -1e-3 for r in bins.values())       # the bin holding the step
    # the cooling rate, on the case's own frames, away from the step (a jump of E_rot is no cooling)
    rates = [r for lo, r in _by_bin(HS.rows(recs), "cooling_rate").items() if not lo <= step < lo + 0.2]
    assert len(rates) >= 8
    assert all(r["relative"] == pytest.approx(0.03, abs=1e-3) and r["n_pairs"] == 4 for r in rates)


def test_intervals_contain_zero_for_noisy_cases_without_an_effect():
    def case(rng, tau0, ratio):
        return _series(tau0, ratio, noise=0.01, rng=rng)
    recs = _records(case, seeds=tuple(range(1, 9)))
    rows = HS.rows(recs)
    assert rows and all(r["n_pairs"] == 8 for r in rows)
    inside = [r["relative_ci_low"] <= 0 <= r["relative_ci_high"] for r in rows]
    assert sum(inside) >= 0.8 * len(inside), rows
    # the ratio's half-width from the noise alone: a bin of k frames reads each run's ratio to
    # 0.01 / sqrt(k), a pair's effect to 0.01 sqrt(2 / k); over 8 seeds t_7 sd / sqrt(8)
    t = np.asarray(next(r for r in recs if r["case"] == "exact")["hcs"]["t"])
    for r in rows:
        if r["observable"] != "temperature_ratio":
            continue
        k = np.count_nonzero((t >= r["t_low"]) & (np.log1p(t / 8.0) < r["s_high"]))
        expected = 2.365 * 0.01 * math.sqrt(2.0 / k) / math.sqrt(8)
        assert 0.3 < (r["relative_ci_high"] - r["relative_ci_low"]) / 2 / expected < 2.0, (r, k)


def test_bins_past_the_homogeneous_window_are_left_out():
    """A case whose gas clusters at t = 20 s (s = ln(1 + 20 / 8) = 1.25) gives no bin beyond s = 1.2."""
    rows = HS.rows(_records(lambda rng, tau0, ratio: _series(tau0, ratio, clusters_at=20.0), spread=0.0))
    assert rows and max(r["s_high"] for r in rows) == pytest.approx(1.2)
    # the exact run's window ends the bins as well
    recs = _records(lambda rng, tau0, ratio: _series(tau0, ratio), spread=0.0)
    for r in recs:
        if r["case"] == "exact":
            r["hcs"] = _series(8.0, 0.6, clusters_at=20.0)
    assert max(r["s_high"] for r in HS.rows(recs)) == pytest.approx(1.2)
    full = HS.rows(_records(lambda rng, tau0, ratio: _series(tau0, ratio), spread=0.0))
    assert max(r["s_high"] for r in full) == pytest.approx(2.0)      # ln(1 + 60 / 8) = 2.14


def test_a_lone_pair_gives_no_interval_and_bad_input_is_refused():
    assert HS.rows(_records(lambda rng, tau0, ratio: _series(tau0, ratio), seeds=(1,))) == []
    # an exact run that does not cool gives its seed no bin, and the pair is named
    recs = _records(lambda rng, tau0, ratio: _series(tau0, ratio), seeds=(1, 2, 3))
    flat = next(r for r in recs if r["case"] == "exact" and r["seed"] == 1)
    next(r for r in recs if r["case"] == "uncorrected" and r["seed"] == 1)["name"] = "rough-uncorrected-s1"
    flat["hcs"] = dict(flat["hcs"], e_trans=[1.0] * len(flat["hcs"]["t"]), e_rot=[0.6] * len(flat["hcs"]["t"]))
    left = []
    rows = HS.rows(recs, left_out=left)
    assert rows and all(r["n_pairs"] == 2 for r in rows)
    assert [name for name, _ in left] == ["rough-uncorrected-s1"] and "short of a whole bin" in left[0][1]
    with pytest.raises(ValueError, match="width"):
        HS.rows([], width=0.0)
    s = _series(8.0, 0.6)
    with pytest.raises(ValueError, match="frames"):
        HS.bin_values(s, np.arange(len(s["t"])) < 3)


def test_the_command_writes_the_fixed_columns_from_the_committed_runs(tmp_path):
    out = tmp_path / "hcs_settling.csv"
    assert HS.main(["hcs_clumps", "--out", str(out)]) == 0
    with open(out) as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == HS.COLUMNS
    assert {r["shape"] for r in rows} >= {"dimer", "tetrahedron"}
    for r in rows:
        assert int(r["n_pairs"]) >= 2 and float(r["t_low"]) >= 0
        # Haff: T_tr falls by cooling_stop at s = ln(sqrt(cooling_stop)); no bin reaches past it by a bin
        assert float(r["s_high"]) <= 0.5 * math.log(float(r["cooling_stop"])) + 0.2 + 1e-9
        if r["change"]:
            assert float(r["s_low"]) > float(r["reference_s"]) and int(r["change_pairs"]) >= 2
    with pytest.raises(SystemExit):
        HS.main(["hcs_clumps", "--width", "0", "--out", str(out)])


def test_the_settling_runs_repeat_the_clump_runs_of_their_seeds_frame_by_frame():
    """hcs_settling's runs are hcs_clumps' frictional runs of the same seeds and starts, run on to a
    64-fold fall: one-threaded YADE repeats a run exactly, so up to the shorter run's stop both
    records hold the same energies and MSD, and the longer run goes on past it."""
    from studies.effects import shape_name
    from studies.hcs_effects import load_records

    clumps = {(shape_name(r["params"]["shape"]["definition"]), r["case"], r["seed"], r["params"]["material"].get("friction")): r
              for r in load_records(S.results_dir(S.load(f"{S.SPEC_DIR}/hcs_clumps.toml")))}
    long_runs = load_records(S.results_dir(S.load(f"{S.SPEC_DIR}/hcs_settling.toml")))
    assert len(long_runs) >= 8
    for r in long_runs:
        short = clumps[(shape_name(r["params"]["shape"]["definition"]), r["case"], r["seed"], 0.5)]
        n = len(short["hcs"]["t"])
        assert len(r["hcs"]["t"]) > 1.5 * n
        for q in ("t", "e_trans", "e_rot", "msd"):
            assert r["hcs"][q][:n] == short["hcs"][q][:n], (r["name"], q)
