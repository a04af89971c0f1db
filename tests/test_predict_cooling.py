"""studies.predict_cooling: the two-temperature balance of YADE binary collisions for clumps."""
import numpy as np
import pytest
from scipy.optimize import brentq

from studies import maps, predict_cooling as pc
from studies.timestep import collisions as tc

needs_2023 = pytest.mark.skipif(not tc.native_yade_version().startswith("2023.02a"),
                                reason="the frictionless dimer's collisions run on YADE 2023.02a (Debian 12)")


def test_the_balance_root_of_known_parabolas_matches_a_root_finder():
    r = np.array(pc.RATIOS)
    tr, rot = -0.4 + 0.35 * r + 0.02 * r ** 2, 0.3 - 0.38 * r - 0.03 * r ** 2
    want = brentq(lambda x: (0.3 - 0.38 * x - 0.03 * x * x) / (2 * x) - (-0.4 + 0.35 * x + 0.02 * x * x) / 3, 0.2, 1.8)
    assert pc.balance_root(tr, rot, 2) == pytest.approx(want, abs=1e-5)
    # one root per trailing column (bootstrap replicates), NaN where F keeps its sign
    got = pc.balance_root(np.stack([tr, tr, tr], -1), np.stack([rot, rot, rot + 5.0], -1), 2)
    assert got[:2] == pytest.approx([want, want], abs=1e-5) and np.isnan(got[2])
    assert pc.at(tr, 0.7) == pytest.approx(-0.4 + 0.35 * 0.7 + 0.02 * 0.49)


def test_spun_scales_the_rotational_temperature():
    base = {"angvel": [[1.0, -2.0, 0.5]], "vel": [[1.0, 0.0, 0.0]]}
    out = pc.spun(base, 0.25)
    assert out["angvel"] == [[0.5, -1.0, 0.25]] and base["angvel"] == [[1.0, -2.0, 0.5]]


@needs_2023
def test_an_elastic_gas_balances_at_equipartition(tmp_path, monkeypatch):
    """Without dissipation the balance's root is T_rot = T_tr (detailed balance): the route's spins,
    energies and degrees of freedom agree, and the cooling rate is zero within its error."""
    monkeypatch.setitem(tc.MATERIAL, "youngs_modulus", 1e8)
    shape = {"kind": "dimer", "sphere_diameter": 0.1333, "overlap": 0.5}
    rows = pc.cooling_predictions(shape, ["uncorrected"], 1500, 3, 0.5, str(tmp_path), "eq", "2023.02a", n_boot=200)
    r = rows[0]
    assert abs(r["ratio_exact"] - 1.0) < 3 * r["ratio_exact_se"] and r["ratio_exact_se"] < 0.1
    assert abs(r["ratio_case"] - 1.0) < 0.15
    assert r["root_check"] < 0.05
