"""studies/gk_sensitivity.py (python -m studies gk-sensitivity) on synthetic runs with a known answer (no YADE).

Ornstein-Uhlenbeck walkers have an exactly exponential velocity autocorrelation, so every
Green-Kubo variant is unbiased, the plain integral to the largest stored lag L misses exactly the
fraction exp(-L / tau) of D, and the long-lag MSD slope is D.
"""
import math
from pathlib import Path

import numpy as np
import pytest

from test_study_analysis import D_TRUE, TAU, frames_of, spec_for, write_record

from studies import engine
from studies import gk_sensitivity as gks
from studies import spec as S
from studies.__main__ import main


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


def test_refuses_fewer_than_two_runs(tmp_path):
    with pytest.raises(SystemExit, match="need at least 2"):
        gks.main([str(tmp_path)])


def _two_cases(tmp_path, d_scale, max_lag, seeds=range(1, 9), skip_b=()):
    """Synthetic exact and uncorrected runs, uncorrected with D = d_scale x exact's.  Each seed scales
    both of its runs' D by its own factor (0.8-1.2), so only runs paired by seed give a tight ratio;
    ``skip_b`` seeds have no uncorrected run."""
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": list(seeds)}],
                  max_lag=max_lag)
    rdir = engine.results_dir(sp)
    rng = np.random.default_rng(11)
    for run in S.runs(sp):
        if run["case"] == "uncorrected" and run["seed"] in skip_b:
            continue
        seed_scale = 0.8 + 0.4 * (run["seed"] % 5) / 4
        fr, v0 = frames_of(rng, 432, 600.0, 0.25,
                           D_scale=seed_scale * (d_scale if run["case"] == "uncorrected" else 1.0))
        write_record(rdir, run, fr, v0, [0.0], max_lag)
    return gks.run_table(sorted((Path(rdir) / "runs").glob("*.json"))), rdir


def test_pair_recovers_a_known_ratio_seed_by_seed_and_a_unit_shape_factor(tmp_path):
    rows, _ = _two_cases(tmp_path, 1.10, 100.0, skip_b=(8,))
    res, sets = gks.paired(rows, "dimer-exact-paired", "dimer-uncorrected-paired")
    m, lo, hi, n, clipped = res["D"]
    assert n == 7 and clipped == 0 and lo < m < hi                # seed 8 has no pair; 3 x 25 s < 100 s
    hw = (hi - lo) / 2
    assert 0.005 < hw < 0.05                                 # a real interval from 7 pairs, not a point
    assert abs(m - 0.10) < 2 * hw, (m, lo, hi)               # the known +10 %
    for name in (gks.FIRST_SECONDS, "t_c = 1 tau, fit 1-2 tau"):
        m2, lo2, hi2, n2, _ = res[name]
        assert n2 == 7 and abs(m2 - 0.10) < (hi2 - lo2), (name, m2, lo2, hi2)
    # an exponential VACF has D = C(0) tau / 3 exactly: the shape factors' ratio is 1 within its interval
    m3, lo3, hi3, n3, _ = res[gks.SHAPE_FACTOR]
    assert n3 == 7 and lo3 < 0.0 < hi3 and hi3 - lo3 < 0.05, (m3, lo3, hi3)
    for lab in ("dimer-exact-paired", "dimer-uncorrected-paired"):
        tau, f, k = sets[lab]
        assert k == 7 and abs(tau / TAU - 1) < 0.05 and abs(f - 1) < 0.03, (lab, sets[lab])


def test_pair_counts_clipped_windows_leaves_out_truncations_beyond_the_lags_and_refuses_ambiguity(
        tmp_path, capsys):
    rows, rdir = _two_cases(tmp_path, 1.0, 70.0, seeds=range(1, 4))   # 70 s of lags, tau 25 s
    res, _ = gks.paired(rows, "dimer-exact-paired", "dimer-uncorrected-paired")
    assert res["t_c = 3 tau, fit 2-4 tau"][3] == 0                    # t_c = 75 s: no value
    two_four = res["t_c = 2 tau, fit 2-4 tau"]                        # fit on 50-70 s: clipped, a value
    assert two_four[3] == 3 and two_four[4] == 3 and np.isfinite(two_four[0])
    assert res["t_c = 1 tau, fit 1-2 tau"][3:] == (3, 0)              # 25-50 s: inside the lags
    assert res["D"][4] == 3                                           # 1-3 tau = 25-75 s: clipped
    main(["gk-sensitivity", str(rdir), "--pair", "dimer-exact-paired", "dimer-uncorrected-paired"])
    out = capsys.readouterr().out
    line = lambda key: next(x for x in out.splitlines() if x.strip().startswith(key))  # noqa: E731
    assert "| n/a: 0 pair(s)" in line("t_c = 3 tau, fit 2-4 tau")
    assert line("t_c = 2 tau, fit 2-4 tau").endswith("3 pairs; fit window clipped at the last lag in 3")
    assert line("t_c = 1 tau, fit 1-2 tau").endswith("| 3 pairs")
    with pytest.raises(SystemExit, match="no finished run labelled 'tet-exact-paired'; labels here: dimer-exact"):
        gks.paired(rows, "tet-exact-paired", "dimer-exact-paired")
    with pytest.raises(SystemExit, match="share 1 seed"):
        gks.paired([r for r in rows if r["run"].split("-s")[1][0] == "1" or "exact" in r["run"]],
                   "dimer-exact-paired", "dimer-uncorrected-paired")
    dup = dict(rows[0], run=rows[0]["run"][:-8] + "0" * 8)           # a second run of one seed, other parameters
    with pytest.raises(SystemExit, match="two runs of dimer-exact-paired seed 1"):
        gks.paired(rows + [dup], "dimer-exact-paired", "dimer-uncorrected-paired")
    with pytest.raises(ValueError, match="not <label>-s<seed>-<key>"):
        gks.label_seed("dimer-exact-paired")
