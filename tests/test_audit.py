"""clumpprops.audit: the engines' sampled estimates against their own error models, the tolerance
advice against repeated runs, the voxel against the library's YADE grid, and the command line."""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.stats import binom

from clumpprops import mass_properties
from clumpprops._input import normalize
from clumpprops.audit import advice, audit_clump, methods
from clumpprops.audit.cli import main
from clumpprops.baselines import voxel_moments

# three overlapping spheres of different radii: no two principal moments equal
CENTERS = np.array([[0.0, 0.0, 0.0], [0.9, 0.1, 0.0], [0.3, 0.8, 0.2]])
RADII = np.array([0.6, 0.45, 0.5])
RHO = 1140.0


def _within_binomial(hits, n, p=0.95):
    lo, hi = binom.interval(0.999, n, p)
    return lo <= hits <= hi


@pytest.fixture(scope="module")
def exact():
    return methods.exact(CENTERS, RADII, RHO)


def test_exact_row_is_the_library_exact_method(exact):
    mp = mass_properties(CENTERS, RADII, density=RHO)
    assert exact.mass == pytest.approx(float(mp.mass), rel=1e-15)
    assert np.allclose(exact.moments, mp.principal_moments, rtol=1e-14)


def test_montecarlo_errors_agree_with_its_standard_errors(exact):
    ntry, seeds = 4000, range(240)
    covered = np.zeros(4)
    for s in seeds:
        est = methods.liggghts_montecarlo(CENTERS, RADII, RHO, ntry, seed=s)
        err = np.abs(advice.relative_errors(est, exact))
        covered += err <= 1.959963984540054 * est.extra["rel_sd"] / np.sqrt(ntry)
    for k in range(4):
        assert _within_binomial(covered[k], len(seeds)), (k, covered)


def test_montecarlo_mass_is_unbiased_and_its_spread_is_the_binomial_one(exact):
    ntry = 5000
    masses = np.array([methods.liggghts_montecarlo(CENTERS, RADII, RHO, ntry, seed=s).mass for s in range(200)])
    lo, hi = methods._box(CENTERS, RADII)
    p = exact.volume / np.prod(hi - lo)
    sd = exact.mass * np.sqrt((1 - p) / (p * ntry))
    assert abs(masses.mean() - exact.mass) < 4 * sd / np.sqrt(len(masses))
    assert 0.8 < masses.std(ddof=1) / sd < 1.2


def test_qmc_errors_agree_with_their_scramble_standard_error(exact):
    n, seeds = 1024, range(200)
    ref = np.concatenate([[exact.mass], np.diag(exact.extra["inertia"])])
    errs = np.array([np.concatenate([[e.mass], e.extra["diagonal"]]) / ref - 1.0
                     for e in (methods.halton_qmc(CENTERS, RADII, RHO, n, seed=s) for s in seeds)])
    se = errs.std(axis=0, ddof=1)
    assert np.all(np.abs(errs.mean(axis=0)) < 4 * se / np.sqrt(len(seeds)))  # scrambling removes the bias
    for k in range(4):
        assert _within_binomial(int(np.sum(np.abs(errs[:, k]) <= 1.959963984540054 * se[k])), len(seeds)), k
    # quasi-Monte Carlo beats plain Monte Carlo at the same N
    mc = methods.liggghts_montecarlo(CENTERS, RADII, RHO, 4000, seed=0)
    assert se[0] < mc.extra["rel_sd"][0] / np.sqrt(n)


@pytest.mark.parametrize("k", [3, 5, 17])
def test_voxel_is_the_baselines_yade_grid(k):
    V, S, Q = voxel_moments(normalize(CENTERS, RADII), k)
    est = methods.yade_voxel(CENTERS, RADII, RHO, k)
    assert est.volume == pytest.approx(float(np.ravel(V)[0]), rel=1e-14)
    assert est.mass == pytest.approx(RHO * float(np.ravel(V)[0]), rel=1e-14)


def test_recommended_montecarlo_ntry_meets_the_tolerance_in_95_percent_of_seeds(exact):
    tol = 0.02
    pilot = methods.liggghts_montecarlo(CENTERS, RADII, RHO, 20000, seed=12345)
    (adv,) = advice.montecarlo(pilot, exact, [tol])
    runs = 120
    ok = sum(np.max(np.abs(advice.relative_errors(methods.liggghts_montecarlo(CENTERS, RADII, RHO, adv.setting, seed=s),
                                                  exact))) <= tol for s in range(runs))
    assert ok >= 0.95 * runs, (ok, adv.setting)


def test_recommended_qmc_n_meets_the_tolerance_in_95_percent_of_scrambles(exact):
    tol = 0.005
    (adv,), _ = advice.qmc(CENTERS, RADII, RHO, exact, [tol], seed=7)
    ref = np.concatenate([[exact.mass], np.diag(exact.extra["inertia"])])
    runs = 100
    ok = 0
    for s in range(1000, 1000 + runs):
        e = methods.halton_qmc(CENTERS, RADII, RHO, adv.setting, seed=s)
        ok += np.max(np.abs(np.concatenate([[e.mass], e.extra["diagonal"]]) / ref - 1.0)) <= tol
    assert ok >= 0.95 * runs, (ok, adv.setting)


def test_recommended_voxel_discretization_meets_the_tolerance(exact):
    advs, curve = advice.voxel(CENTERS, RADII, RHO, exact, [0.05, 0.01])
    for a in advs:
        est = methods.yade_voxel(CENTERS, RADII, RHO, a.setting)
        assert np.max(np.abs(advice.relative_errors(est, exact))) <= a.tolerance
        coarser = [err for k, _, err in curve if k < a.setting]
        assert all(err > a.tolerance for err in coarser)


def test_iyz_defect_changes_only_iyz_and_sets_an_unreachable_tolerance(exact):
    est = methods.liggghts_montecarlo(CENTERS, RADII, RHO, 20000, seed=1)
    bad = methods.with_iyz_defect(est)
    T, B = est.extra["inertia"], bad.extra["inertia"]
    assert B[1, 2] == B[2, 1] == pytest.approx(0.5 * (T[1, 2] + T[0, 2]))
    mask = np.ones((3, 3), bool)
    mask[1, 2] = mask[2, 1] = False
    assert np.array_equal(B[mask], T[mask])
    (a,) = advice.montecarlo(bad, exact, [0.001], iyz_bias=0.01)
    assert a.setting is None and "unreachable" in a.note


def test_audit_clump_lists_every_method_and_both_tolerances():
    rep = audit_clump(CENTERS, RADII, RHO, (0.01, 0.001), seed=3, ntry=20000)
    names = [m["method"] for m in rep["methods"]]
    assert names[0].startswith("summed") and "YADE voxel" in names and "Halton QMC (DEME)" in names
    assert sum(n.startswith("LIGGGHTS") for n in names) == 2
    assert {(a["method"], a["tolerance"]) for a in rep["advice"]} >= {("YADE voxel", 0.01), ("YADE voxel", 0.001)}
    summed = rep["methods"][0]
    assert summed["mass_error"] > 0.02  # the overlaps counted twice


def test_cli_json_and_plot(tmp_path, capsys):
    f = tmp_path / "tri.csv"
    f.write_text("x,y,z,r\n" + "\n".join(",".join(map(str, [*c, r])) for c, r in zip(CENTERS, RADII)) + "\n")
    png = tmp_path / "err.png"
    assert main([str(f), "--json", "--seed", "1", "--ntry", "20000", "--plot", str(png), "--tolerance", "0.01"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["clumps"][0]["exact"]["mass"] == pytest.approx(methods.exact(CENTERS, RADII, 1000.0).mass)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    before = png.read_bytes()
    assert main([str(f), "--ntry", "20000", "--plot", str(png)]) == 1
    assert "exists" in capsys.readouterr().err and png.read_bytes() == before


def test_cli_missing_file_is_one_line_error(tmp_path, capsys):
    assert main([str(tmp_path / "nope.csv")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("clumpprops audit: error:")


def test_the_compiled_hit_test_is_the_distance_test():
    """The core's point-in-union loop against numpy's distances, on points spread over the box
    and on points placed just inside and just outside single spheres."""
    from clumpprops.core import _core
    rng = np.random.default_rng(3)
    c, r = rng.uniform(-1, 1, (12, 3)), rng.uniform(0.2, 0.5, 12)
    x = rng.uniform(-1.6, 1.6, (20000, 3))
    d = rng.normal(size=(2000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    k = rng.integers(0, 12, 2000)
    edge = np.concatenate([c[k] + (1 - 1e-9) * r[k, None] * d, c[k] + (1 + 1e-9) * r[k, None] * d])
    for pts in (x, edge):
        want = (np.linalg.norm(pts[:, None, :] - c[None], axis=2) < r).any(axis=1)
        assert np.array_equal(_core.union_hits(pts, c, r), want)
    assert _core.union_hits(x, c, r).mean() > 0.05     # the test sees both answers
    with pytest.raises(ValueError, match="union_hits"):
        _core.union_hits(x[:, :2].copy(), c, r)
