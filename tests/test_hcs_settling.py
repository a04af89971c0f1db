"""studies.hcs_settling on synthetic cooling runs whose bin-by-bin effects are known (no YADE)."""
import csv
import math

import numpy as np
import pytest

from studies import hcs_settling as HS
from studies import spec as S

N = 200


def _series(tau0, ratio, t_end=60.0, clusters_at=None, noise=0.0, rng=None):
    """Haff's cooling T_tr = 2 / (1 + t / tau0)^2 with T_rot / T_tr = ratio(t) (a number or a function
    of t); the count-variance ratio leaves its homogeneous band at ``clusters_at``."""
    t = np.linspace(0.0, t_end, int(round(t_end / 0.05)) + 1)
    temp = 2.0 / (1 + t / tau0) ** 2
    r = ratio(t) if callable(ratio) else np.full_like(t, ratio)
    if noise:
        temp = temp * (1 + noise * rng.normal(size=t.size))
    count = np.ones_like(t) if clusters_at is None else np.where(t < clusters_at, 1.0, 3.0)
    return {"t": t.tolist(), "e_trans": (1.5 * N * temp).tolist(), "e_rot": (1.5 * N * r * temp).tolist(),
            "count_ratio": count.tolist(), "cells_per_side": 4, "n_particles": N, "rot_dof": 3}


def _records(case_series, seeds=(1, 2, 3, 4), spread=0.05):
    """Exact and uncorrected runs of hcs_clumps' rough dimer; ``case_series(seed_rng, tau0, ratio)``
    gives the uncorrected run's series from the exact run's tau0 and ratio."""
    spec = S.load(f"{S.SPEC_DIR}/hcs_clumps.toml")
    runs = [r for r in S.runs(spec) if r["params"]["shape"]["definition"]["kind"] == "dimer"
            and "friction" in r["params"]["material"] and r["params"]["case"] in ("exact", "uncorrected")
            and r["params"]["seed"] in seeds]
    out = []
    for r in runs:
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
        assert v["cooling_rate"] == pytest.approx(2 / 8.0, rel=2e-3)
        assert v["temperature_ratio"] == pytest.approx(0.6, rel=1e-12)


def test_a_relaxing_effect_shows_as_a_trend_over_the_bins():
    """The case's ratio relaxes from the exact one's to 10 % below it over the scaled time
    (1 - exp(-s)): early bins read near 0, late bins near -10 % times the relaxed fraction."""
    def case(rng, tau0, ratio):
        return _series(tau0, lambda t: ratio * (1 - 0.1 * (1 - np.exp(-np.log1p(t / tau0)))))
    bins = _by_bin(HS.rows(_records(case)), "temperature_ratio")
    first, last = bins[0.0], bins[max(bins)]
    assert first["relative"] == pytest.approx(-0.1 * (1 - math.exp(-0.1)), abs=3e-3)
    assert last["relative"] == pytest.approx(-0.1 * (1 - math.exp(-(max(bins) + 0.1))), abs=3e-3)
    assert last["relative_ci_high"] < first["relative_ci_low"]


def test_intervals_contain_zero_for_noisy_cases_without_an_effect():
    def case(rng, tau0, ratio):
        return _series(tau0, ratio, noise=0.01, rng=rng)
    rows = HS.rows(_records(case, seeds=tuple(range(1, 9))))
    assert rows and all(r["n_pairs"] == 8 for r in rows)
    inside = [r["relative_ci_low"] <= 0 <= r["relative_ci_high"] for r in rows]
    assert sum(inside) >= 0.8 * len(inside), rows


def test_bins_past_the_homogeneous_window_are_left_out():
    """A case whose gas clusters at t = 20 s (s = ln(1 + 20 / 8) = 1.25) gives no bin beyond s = 1.2."""
    rows = HS.rows(_records(lambda rng, tau0, ratio: _series(tau0, ratio, clusters_at=20.0), spread=0.0))
    assert rows and max(r["s_high"] for r in rows) == pytest.approx(1.2)
    full = HS.rows(_records(lambda rng, tau0, ratio: _series(tau0, ratio), spread=0.0))
    assert max(r["s_high"] for r in full) == pytest.approx(2.0)      # ln(1 + 60 / 8) = 2.14


def test_a_lone_pair_gives_no_interval_and_bad_input_is_refused():
    assert HS.rows(_records(lambda rng, tau0, ratio: _series(tau0, ratio), seeds=(1,))) == []
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
    assert all(int(r["n_pairs"]) >= 2 and float(r["relative_ci_low"]) <= float(r["relative"])
               <= float(r["relative_ci_high"]) for r in rows)
    with pytest.raises(SystemExit):
        HS.main(["hcs_clumps", "--width", "0", "--out", str(out)])
