"""The time-step study's collision map (studies/timestep, python -m studies timestep): the sampled collisions
follow the gas's distributions, a head-on dimer collision ends as the exact 1-D elastic
exchange with a second-order energy error, and free rotation of the triangle trimer on
YADE 2025.2 keeps its energy and angular momentum to second order once the initial angular
velocity is carried back half a step (a few seconds of YADE each)."""
import json
import math
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

from studies import shapes as shp
from studies.timestep import collisions as tc
from studies.timestep import study as ts

ROOT = Path(__file__).resolve().parents[1]


def test_pairs_follow_the_gas_distributions():
    for key, dof in (("dimer", 2), ("trimer", 3)):
        inp = tc.make_pairs(tc.SHAPES[key]["shape"], 20000, seed=3)
        m = inp["body"]["mass"]
        kT = inp["kT"]
        assert inp["rot_dof"] == dof and kT == pytest.approx(2 * tc.ENERGY / (3 + dof))
        v = np.asarray(inp["vel"])
        g = v[0::2] - v[1::2]
        x = 0.5 * (m / 2) * np.sum(g ** 2, 1) / kT          # Gamma(2, 1): mean 2, variance 2
        assert abs(x.mean() - 2) < 4 * math.sqrt(2 / len(x))
        assert np.allclose(v[0::2] + v[1::2], 0)               # centre of mass at rest
        p = np.asarray(inp["pos"])
        sep = p[1::2] - p[0::2]
        assert np.all(np.linalg.norm(sep, axis=1) > 2 * inp["bounding_radius"])   # apart at the start
        assert np.all(np.einsum("ij,ij->i", sep, g) > 0)         # on collision courses
        b = np.asarray(inp["b"])
        assert abs(np.mean(b ** 2) / (2 * inp["bounding_radius"]) ** 2 - 0.5) < 0.01   # uniform over the disc
        ori = np.asarray(inp["ori"]).reshape(-1, 3, 3)
        w = np.einsum("nji,nj->ni", ori, np.asarray(inp["angvel"]))   # body frame
        pm = shp.properties(tc.SHAPES[key]["shape"], tc.MATERIAL["density"])["exact"]["principal_moments"]
        # body-frame moments: the dimer's axis is body z (I_axial, the smallest, is on z), the
        # triangle lies in the body xy plane (ascending moments on x, y, z)
        I = np.array([pm[2], pm[2], pm[0]]) if key == "dimer" else np.asarray(pm)
        erot = 0.5 * np.sum(I * w ** 2, 1)
        assert abs(erot.mean() / (dof * kT / 2) - 1) < 0.03     # equipartition
        if key == "dimer":
            assert np.max(np.abs(w[:, 2])) < 1e-12               # no spin about the axis (round-off)
        lat = np.asarray(inp["lattice"])
        d = np.linalg.norm(lat[:, None] - lat[None, :200], axis=2)
        assert np.min(d[d > 0]) >= inp["spacing"] - 1e-9


def _head_on(g=2.0):
    """One pair of paper dimers, axes along the course, centres on it: a 1-D sphere collision."""
    inp = tc.make_pairs(tc.SHAPES["dimer"]["shape"], 1, seed=1)
    r_b = inp["bounding_radius"]
    inp["pos"] = [[0.0, 0.0, -r_b - 0.01], [0.0, 0.0, r_b + 0.01]]
    inp["ori"] = [list(np.eye(3).ravel())] * 2
    inp["vel"] = [[0.0, 0.0, g / 2], [0.0, 0.0, -g / 2]]
    inp["angvel"] = [[0.0, 0.0, 0.0]] * 2
    inp["t_max"] = 1.0
    return inp


@pytest.mark.skipif(not tc.native_yade_version().startswith("2023.02a"),
                    reason="the dimer map runs on YADE 2023.02a (Debian 12); the Debian 13 root has 2025.2 only")
def test_head_on_dimers_exchange_velocities_with_second_order_energy_error(tmp_path):
    inp = _head_on()
    res = {}
    for f in (0.5, 1.0):
        out = tc.run_map(inp, f, "2023.02a", str(tmp_path), "headon")
        assert out["done"] and out["touched"] == [True] and out["yade_version"].startswith("2023")
        res[f] = tc.outcome(inp, out)
        v = np.asarray(out["vel"])
        assert np.allclose(v[:, :2], 0, atol=1e-12)              # stays on the line
        assert res[f]["q"][0] == pytest.approx(2.0, abs=2e-3)    # g' = -g
    e1, e05 = abs(res[1.0]["de_rel"][0]), abs(res[0.5]["de_rel"][0])
    assert e1 < 2e-3 and 3.5 < e1 / e05 < 6.0                   # second order: 4 (measured 4.97); first order 2


def test_free_trimer_rotation_is_second_order_on_yade_2025(tmp_path):
    """Two trimers moving apart with equipartition spin: nothing touches; |dL|, dE only from the
    integrator's free rotation (delValle2023 started half a step back)."""
    inp = tc.make_pairs(tc.SHAPES["trimer"]["shape"], 1, seed=5)
    v = np.asarray(inp["vel"])
    inp["vel"] = (-v).tolist()                                    # receding: no collision
    inp["angvel"] = (np.asarray(inp["angvel"]) * 3).tolist()      # ~ 3x thermal spin
    inp["t_max"] = 0.3
    inp["check_interval"] = 0.3
    errs = {}
    # the second factor's files live outside /tmp and the repository, which the Debian 13 root
    # does not see: run_map stages them
    outside = tempfile.mkdtemp(prefix="clumpprops-test-", dir="/var/tmp")
    try:
        outs = {f: tc.run_map(inp, f, "2025.2", work, "free") for f, work in ((0.5, str(tmp_path)), (1.0, outside))}
        assert os.path.exists(os.path.join(outside, "free-E1e+07-f1.0.out.json"))
    finally:
        shutil.rmtree(outside, ignore_errors=True)
    for f in (0.5, 1.0):
        out = outs[f]
        assert out["rot_algorithm"] == "delValle2023" and out["touched"] == [False]
        o = tc.outcome(inp, out)
        L0 = np.abs(np.asarray(inp["angvel"])).max() * 0.01
        errs[f] = float(np.max(np.linalg.norm(o["dL"][0], axis=1))) / L0
        assert abs(o["de_rel"][0]) < 1e-8                         # the integrator's invariant
    assert errs[1.0] < 1e-4 and 3.5 < errs[1.0] / errs[0.5] < 4.5   # second order: 4 (measured 4.01)


def test_decision_stops_at_the_first_unsafe_factor_and_never_extrapolates_the_gas_check():
    """The rule of docs/timestep.md: every factor up to the chosen one is safe; a factor above the
    largest gas-checked one is not declared safe however small its predicted D error."""
    rows = [{"factor": f, "D_rel_pred": -1e-4 * f * f, "D_rel_pred_se": 1e-5} for f in (0.25, 0.5, 1.0, 1.5, 2.0)]
    runs = [{"factor": f, "energy_drift": 2e-4 * f * f, "ok": True} for f in (0.5, 1.0, 1.5)]
    d = ts.decide("x", {"rows": rows}, {"runs": runs})
    assert d["largest_safe_factor"] == 1.5
    assert [p["ok"] for p in d["per_factor"]] == [True, True, True, True, False]
    runs[1] = dict(runs[1], energy_drift=2e-3)         # over the energy tolerance at 1.0
    assert ts.decide("x", {"rows": rows}, {"runs": runs})["largest_safe_factor"] == 0.5
    runs[1] = dict(runs[1], energy_drift=1e-4, ok=False)   # a run flagged by its own checks
    assert ts.decide("x", {"rows": rows}, {"runs": runs})["largest_safe_factor"] == 0.5
    rows[2] = dict(rows[2], D_rel_pred=-3e-3)           # the predicted D error too large at 1.0
    assert ts.decide("x", {"rows": rows}, None)["largest_safe_factor"] == 0.5
    assert ts.decide("x", {"rows": rows[:2]}, None)["largest_safe_factor"] == 0.5  # map only: the map decides


def test_run_map_never_reuses_another_inputs_output(tmp_path):
    """An output left next to an older input is removed before the new input is run, so a run that
    then fails (here: no such YADE) cannot leave the old result to be reused by the next call."""
    inp = _head_on()
    (tmp_path / "x-E1e+07-f0.5.in.json").write_text(json.dumps({"old": True}))
    (tmp_path / "x-E1e+07-f0.5.out.json").write_text(json.dumps({"stale": True}))
    with pytest.raises(RuntimeError, match="no YADE"):
        tc.run_map(inp, 0.5, "1999.1", str(tmp_path), "x")
    assert not (tmp_path / "x-E1e+07-f0.5.out.json").exists()


def test_run_map_reuses_a_run_whose_input_differs_only_by_round_off(tmp_path):
    """The same run's input built twice can differ in its last bits (a matrix product under one-threaded
    and multi-threaded BLAS): a relative 1e-15 is one run and is reused; 1e-9 is another run, and
    the stored output is removed before it runs (here it then fails: no such YADE)."""
    inp = _head_on()
    d = dict(inp, dt=0.5 * tc.p_wave_dt_of_body(inp))
    (tmp_path / "x-E1e+07-f0.5.in.json").write_text(json.dumps(d))
    (tmp_path / "x-E1e+07-f0.5.out.json").write_text(json.dumps({"stored": True}))
    nudged = json.loads(json.dumps(inp))
    nudged["body"]["mass"] *= 1 + 1e-15
    assert tc.run_map(nudged, 0.5, "1999.1", str(tmp_path), "x") == {"stored": True, "reused": True}
    nudged["body"]["mass"] *= 1 + 1e-9
    with pytest.raises(RuntimeError, match="no YADE"):
        tc.run_map(nudged, 0.5, "1999.1", str(tmp_path), "x")
    assert not (tmp_path / "x-E1e+07-f0.5.out.json").exists()


def test_same_input_compares_numbers_to_round_off_and_everything_else_exactly():
    a = {"m": 1.0, "v": [0.0, 2.5, 1e-300], "n": 3, "route": "aspherical"}
    assert tc.same_input(a, {"m": 1.0 + 2e-16, "v": [1e-17, 2.5 * (1 + 1e-14), 0.0], "n": 3, "route": "aspherical"})
    for other in ({"m": 1.0 + 1e-9, "v": a["v"], "n": 3, "route": "aspherical"},   # a number beyond round-off
                  dict(a, n=4), dict(a, route="isotropic"), dict(a, v=[0.0, 2.5]),  # an integer, a string, a length
                  {k: v for k, v in a.items() if k != "n"}, dict(a, n=3.0 + 1e-9), dict(a, m=True)):
        assert not tc.same_input(a, other), other


def _without(argv, *options):
    """``argv`` without the given options and their values."""
    out, skip = [], False
    for a in argv:
        if skip:
            skip = False
        elif a in options:
            skip = True
        else:
            out.append(a)
    return out


def test_make_science_reruns_the_committed_timestep_results_with_their_arguments():
    """`make science-timestep` rewrites results/timestep/timestep*.json: it must run the study with
    the arguments each file records, not with other defaults, and write it where it is.  Left out of
    the comparison: the scratch --workdir (`make` passes none) and --out, which the files record as
    the place they were first written to."""
    import shlex
    assert Path(tc.OUT).resolve() == ROOT / "results" / "timestep" / "timestep.json"   # no --out
    lines = [ln for ln in (ROOT / "Makefile").read_text().splitlines()
             if ln.startswith("\t") and "-m studies timestep" in ln]
    made = {}
    for ln in lines:
        args = shlex.split(ln.split("-m studies timestep", 1)[1])
        out = args[args.index("--out") + 1] if "--out" in args else os.path.relpath(tc.OUT, ROOT)
        made[out] = _without(args, "--out")
    for name in ("timestep.json", "timestep_tetra.json", "timestep_E1e8.json", "timestep_E1e9.json"):
        argv = json.loads((ROOT / "results" / "timestep" / name).read_text())["argv"]
        assert made.get(f"results/timestep/{name}") == _without(argv, "--workdir", "--out"), (name, argv, made)
    assert len(made) == 4


def test_a_stiffer_contact_at_the_factor_scaled_by_e_to_the_tenth_is_the_same_leapfrog_collision():
    """studies/specs/stiffness.toml raises the dt factor as (E/1e7)^(1/10): the P-wave step goes as
    E^-1/2 and a Hertz contact lasts as E^-2/5, so at the raised factor YADE's leapfrog takes the
    same steps per contact, and its error per collision (here the energy error) is that of the
    factor at 1e7 Pa: exactly for a head-on collision (the 1-D Hertz problem is self-similar), and
    to within 1 % over the gas's collisions (relative speeds at quantiles of the collision-weighted
    Maxwellian, impact parameters uniform over the disc, start phases).  A single oblique
    collision is not self-similar (the overlap's share of the contact distance,
    (mu g^2 / k_n)^(2/5) / sigma, shrinks with E), so the average is what is compared.  At an
    unraised factor the stiffer contact is resolved better, and past the scaling worse."""
    from scipy.stats import gamma
    from studies import kinetic
    rho, nu, r = 1140.0, 0.40, 0.06665                    # the dimer's spheres
    mu = 0.5 * 4.0 / 3.0 * math.pi * r ** 3 * rho
    kT = 2 * 3.75 / 5                                      # 3.75 J per dimer over 5 degrees of freedom
    x = gamma.ppf((np.arange(10) + 0.5) / 10, 2.0)         # mu g^2 / 2kT at collisions: Gamma(2)
    g = np.sqrt(2 * kT * x / mu)[:, None, None]
    b = (2 * r * np.sqrt((np.arange(6) + 0.5) / 6))[None, :, None]    # uniform over the disc
    phase = np.linspace(0.05, 0.95, 7)[None, None, :]

    def rms_energy_error(E, factor, b=b):
        kn = kinetic.hertz_kn(E, nu, r, r)
        dt = factor * r * math.sqrt(rho / E)                 # the gas's P-wave step
        _, ratio = kinetic.leapfrog_collision(b, g, 2 * r, mu, kn, dt, phase=phase)
        return float(np.sqrt(np.mean((ratio ** 2 - 1) ** 2)))

    ref, ref_head_on = rms_energy_error(1e7, 1.0), rms_energy_error(1e7, 1.0, b=0.0)
    assert 1e-5 < ref < 1e-2 and 1e-5 < ref_head_on < 1e-2   # resolved, but not exact
    for E in (1e8, 1e9):
        raised = (E / 1e7) ** 0.1
        assert rms_energy_error(E, raised, b=0.0) == pytest.approx(ref_head_on, rel=1e-9)
        assert rms_energy_error(E, raised) == pytest.approx(ref, rel=0.01)
        assert rms_energy_error(E, 1.0) < 0.7 * ref
        assert rms_energy_error(E, 1.2 * raised) > 1.3 * ref
        assert rms_energy_error(E, (E / 1e7) ** 0.125) > 1.1 * ref     # an exponent of 1/8 is not it
