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
