"""benchmarks/gk_sensitivity.py on synthetic runs with a known answer (no YADE).

Ornstein-Uhlenbeck walkers have an exactly exponential velocity autocorrelation, so every
Green-Kubo variant is unbiased, the plain integral to the largest stored lag L misses exactly the
fraction exp(-L / tau) of D, and the long-lag MSD slope is D.
"""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import gk_sensitivity as gks  # noqa: E402
from test_study_analysis import D_TRUE, TAU, frames_of, spec_for, write_record  # noqa: E402

from studies import engine  # noqa: E402
from studies import spec as S  # noqa: E402


def test_variants_agree_and_the_plain_integral_misses_the_exponential_tail(tmp_path):
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact"], "seeds": list(range(1, 9))}])
    rdir = engine.results_dir(sp)
    rng = np.random.default_rng(7)
    for run in S.runs(sp):
        fr, v0 = frames_of(rng, 432, 600.0, 0.25)
        write_record(rdir, run, fr, v0, [0.0], 100.0)
    rows = gks.run_table(sorted((Path(rdir) / "runs").glob("*.json")))
    assert len(rows) == 8
    d = np.array([r["D"] for r in rows])
    assert abs(d.mean() / D_TRUE - 1) < 3 * d.std(ddof=1) / math.sqrt(8) + 1e-3
    for name in gks.VARIANTS:
        rel = np.array([r[name] / r["D"] - 1 for r in rows])
        assert abs(rel.mean()) < 0.01, (name, rel)
    plain = np.array([r["plain integral to 100 s"] / r["D"] - 1 for r in rows])
    missed = -math.exp(-100.0 / TAU)                       # -1.8 %
    assert abs(plain.mean() - missed) < 4 * plain.std(ddof=1) / math.sqrt(8) + 2e-3, (plain.mean(), missed)
    assert plain.mean() < -0.008                           # the missing tail is seen
    msd = np.array([r["MSD slope, lags >= 4 tau"] for r in rows])
    assert np.all(np.isfinite(msd)) and abs(msd.mean() / D_TRUE - 1) < 0.05


def test_refuses_fewer_than_two_runs(tmp_path, monkeypatch):
    monkeypatch.setattr(sys, "argv", ["gk_sensitivity.py", str(tmp_path)])
    with pytest.raises(SystemExit, match="need at least 2"):
        gks.main()


def _two_cases(tmp_path, d_scale, max_lag, seeds=range(1, 9)):
    """Synthetic exact and uncorrected runs, paired by seed, uncorrected with D = d_scale x exact's."""
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": list(seeds)}],
                  max_lag=max_lag)
    rdir = engine.results_dir(sp)
    rng = np.random.default_rng(11)
    for run in S.runs(sp):
        fr, v0 = frames_of(rng, 432, 600.0, 0.25, D_scale=d_scale if run["case"] == "uncorrected" else 1.0)
        write_record(rdir, run, fr, v0, [0.0], max_lag)
    return gks.run_table(sorted((Path(rdir) / "runs").glob("*.json"))), rdir


def test_pair_recovers_a_known_ratio_and_a_unit_shape_factor(tmp_path):
    rows, _ = _two_cases(tmp_path, 1.10, 100.0)
    res = gks.paired(rows, "dimer-exact-paired", "dimer-uncorrected-paired")
    m, lo, hi, n = res["D"]
    assert n == 8 and lo < m < hi
    hw = (hi - lo) / 2
    assert 0.005 < hw < 0.05                                 # a real interval from 8 pairs, not a point
    assert abs(m - 0.10) < 2 * hw, (m, lo, hi)               # the known +10 %
    for name in (gks.FIRST_SECONDS, "t_c = 1 tau, fit 1-2 tau"):
        m2, lo2, hi2, n2 = res[name]
        assert n2 == 8 and abs(m2 - 0.10) < (hi2 - lo2), (name, m2, lo2, hi2)
    # an exponential VACF has D = C(0) tau / 3 exactly: the shape factors' ratio is 1 within its interval
    m3, lo3, hi3, n3 = res[gks.SHAPE_FACTOR]
    assert n3 == 8 and lo3 < 0.0 < hi3 and hi3 - lo3 < 0.05, (m3, lo3, hi3)


def test_pair_leaves_out_windows_beyond_the_stored_lags_and_names_unknown_labels(tmp_path, monkeypatch, capsys):
    rows, rdir = _two_cases(tmp_path, 1.0, 70.0, seeds=range(1, 4))   # 70 s of lags: 3 tau = 75 s does not fit
    res = gks.paired(rows, "dimer-exact-paired", "dimer-uncorrected-paired")
    assert res["t_c = 3 tau, fit 2-4 tau"][3] == 0
    assert res["t_c = 2 tau, fit 2-4 tau"][3] == 3 and np.isfinite(res["t_c = 2 tau, fit 2-4 tau"][0])
    monkeypatch.setattr(sys, "argv", ["gk_sensitivity.py", str(rdir), "--pair",
                                      "dimer-exact-paired", "dimer-uncorrected-paired"])
    gks.main()
    out = capsys.readouterr().out
    assert "t_c = 3 tau, fit 2-4 tau | n/a" in out and "3 pairs" in out
    with pytest.raises(SystemExit, match="no finished run labelled 'tet-exact-paired'; labels here: dimer-exact"):
        gks.paired(rows, "tet-exact-paired", "dimer-exact-paired")
    with pytest.raises(ValueError, match="not <label>-s<seed>-<key>"):
        gks.label_seed("dimer-exact-paired")
