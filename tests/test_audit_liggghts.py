"""The audit's LIGGGHTS Monte Carlo model against Debian's liggghts 3.8.0 itself: over seeds, the
masses LIGGGHTS reports have the mean and the spread the model (and its binomial standard error)
predicts.  Runs liggghts (tests/engine_errors.py drives it), so it is in the SLOW set."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chi2

from clumpprops.audit import methods
from clumpprops.io.liggghts import seeds

from engine_errors import RHO, liggghts_mc, ten_sphere_clump
from _engines import LIGGGHTS

NTRY = 20000
RUNS = 12

pytestmark = pytest.mark.skipif(not os.access(LIGGGHTS, os.X_OK), reason="needs Debian's liggghts")


@pytest.fixture(scope="module")
def reported():
    clump = ten_sphere_clump()
    with tempfile.TemporaryDirectory() as d:
        return clump, np.array([liggghts_mc(clump, NTRY, s, Path(d))[0] for s in seeds(RUNS)])


def test_liggghts_masses_match_the_audit_model(reported):
    clump, masses = reported
    exact = methods.exact(clump.centers, clump.radii, RHO)
    lo, hi = methods._box(clump.centers, clump.radii)
    p = exact.volume / np.prod(hi - lo)
    sd = exact.mass * np.sqrt((1 - p) / (p * NTRY))  # the model's standard deviation of one run
    assert abs(masses.mean() - exact.mass) <= 3.3 * sd / np.sqrt(RUNS), (masses.mean(), exact.mass, sd)
    ratio = masses.var(ddof=1) / sd**2
    lo_q, hi_q = chi2.ppf([0.0005, 0.9995], RUNS - 1) / (RUNS - 1)
    assert lo_q <= ratio <= hi_q, ratio
    model = np.array([methods.liggghts_montecarlo(clump.centers, clump.radii, RHO, NTRY, seed=s).mass
                      for s in range(RUNS)])
    assert abs(model.mean() - masses.mean()) <= 3.3 * sd * np.sqrt(2.0 / RUNS)
    est = methods.liggghts_montecarlo(clump.centers, clump.radii, RHO, NTRY, seed=0)
    assert est.extra["rel_sd"][0] / np.sqrt(NTRY) == pytest.approx(sd / exact.mass, rel=0.05)
