"""Study specs: validation messages, shape generators, run identity, initial conditions.

No YADE here: the specs, shapes and initial states are pure numpy + clumpprops.
"""
import copy
import json
import math
import re
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import clumpprops
from _spec_toml import _toml
from studies import gas_model as gm
from studies import shapes as shp
from studies import spec as S

SPECS = Path(S.SPEC_DIR)


def raw(name="paper"):
    with open(SPECS / f"{name}.toml", "rb") as f:
        return tomllib.load(f)


def test_committed_specs_validate():
    paths = sorted(SPECS.glob("*.toml"))
    assert len(paths) >= 9, paths                  # the study's specs are all found
    for p in paths:
        sp = S.load(str(p))
        assert S.runs(sp), p


def _bad(mutate):
    r = raw()
    mutate(r)
    with pytest.raises(S.SpecError) as e:
        S.validate(r)
    return str(e.value)


@pytest.mark.parametrize("mutate, message", [
    (lambda r: r["gas"].update(n_particle=3), "gas.n_particle: unknown key"),
    (lambda r: r.update(extra={}), "extra: unknown table"),
    (lambda r: r["gas"].pop("n_particles"), "gas.n_particles: missing"),
    (lambda r: r.pop("material"), "material: missing table"),
    (lambda r: r["material"].update(density=-1.0), "material.density: must be > 0"),
    (lambda r: r["material"].update(youngs_modulus=float("inf")), "material.youngs_modulus: must be finite"),
    (lambda r: r["material"].update(youngs_modulus=float("nan")), "material.youngs_modulus: must be finite"),
    (lambda r: r["run"].update(t_end="400"), "run.t_end: expected a number"),
    (lambda r: r["run"].update(dt_factor=0), "run.dt_factor: must be > 0"),
    (lambda r: r["gas"].update(volume_fraction=1.5), "gas.volume_fraction: must be in (0, 1)"),
    (lambda r: r["gas"].update(n_particles=True), "gas.n_particles: expected an integer"),
    (lambda r: r["gas"].update(start="hot"), "gas.start: must be one of"),
    (lambda r: r["material"].update(poisson=0.7), "material.poisson: must be in"),
    (lambda r: r["study"].update(yade="2024.1"), "study.yade: YADE version must be one of"),
    (lambda r: r["analysis"].update(fit_hi=10.0), "analysis.fit_hi: must be > analysis.fit_lo"),
    (lambda r: r["analysis"].update(t_eq="soon"), "analysis.t_eq: must be a time in s or 'auto'"),
    (lambda r: r["shapes"]["dimer"].update(overlap=-0.5), "shapes.dimer.overlap: must be > 0"),
    (lambda r: r["shapes"]["dimer"].pop("overlap"), "shapes.dimer.overlap: missing (needed by kind = 'dimer')"),
    (lambda r: r["shapes"]["dimer"].update(kind="cube"), "shapes.dimer.kind: must be one of"),
    (lambda r: r["shapes"]["dimer"].update(path="x.txt"), "shapes.dimer.path: not used by kind = 'dimer'"),
    (lambda r: r.pop("shapes"), "shapes: missing"),
    (lambda r: r["groups"][1].update(shape="trimer"), "groups[1].shape: unknown shape 'trimer'"),
    (lambda r: r["groups"][0].update(cases=["exact", "exakt"]), "groups[0].cases[1]: unknown case 'exakt'"),
    (lambda r: r["groups"][0].update(protocol="both"), "groups[0].protocol: must be one of"),
    (lambda r: r["groups"][0].update(seeds=[1, -2]), "groups[0].seeds[1]: expected a non-negative integer"),
    (lambda r: r["groups"][2].update(seeds=[]), "groups[2].seeds: empty"),
    (lambda r: r["groups"][0].update(colour="red"), "groups[0].colour: unknown key"),
    (lambda r: r["groups"][0].update(youngs_modulus=-1e8), "groups[0].youngs_modulus: must be > 0"),
    (lambda r: r["groups"][0].update(n_particles=0), "groups[0].n_particles: must be > 0"),
    (lambda r: r["groups"][0].update(n_particles=100.0), "groups[0].n_particles: expected"),
    (lambda r: r["run"].update(legacy_dt=0.5), "run.legacy_dt: expected a table"),
    (lambda r: r["run"].update(legacy_dt={"below_seed": 4}), "run.legacy_dt.dt_factor: missing"),
    (lambda r: r["run"].update(legacy_dt={"below_seed": 0, "dt_factor": 0.5}), "run.legacy_dt.below_seed: must be > 0"),
    (lambda r: r["run"].update(legacy_dt={"below": 4, "dt_factor": 0.5}), "run.legacy_dt.below: unknown key"),
    (lambda r: r["study"].update(schedule="breadth_first"), "study.schedule: must be one of in_order, round_robin"),
    (lambda r: r["study"].update(in_results="no"), "study.in_results: expected true or false"),
    (lambda r: r["study"].update(in_results=0), "study.in_results: expected true or false"),
])
def test_bad_spec_names_the_key(mutate, message):
    assert message in _bad(mutate)


def test_asymmetric_shape_refused_on_yade_2023():
    def m(r):
        r["shapes"]["tet"] = {"kind": "tetrahedron", "sphere_diameter": 0.1, "overlap": 0.7}
        r["groups"].append({"shape": "tet", "cases": ["exact", "uncorrected"], "seeds": [1]})
    msg = _bad(m)
    assert "groups[4].shape: 'tet' is not a linear clump" in msg and "study.yade = '2025.2'" in msg

    def ok(r):
        m(r)
        r["study"]["yade"] = "2025.2"
    r = raw()
    ok(r)
    sp = S.validate(r)
    assert any(x["shape"] == "tet" for x in S.runs(sp))


def test_bad_file_message_names_the_file(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text("[study]\nname = 1\n")
    with pytest.raises(S.SpecError, match=r"s.toml: study.name: expected a string"):
        S.load(str(p))
    p.write_text("[study\n")
    with pytest.raises(S.SpecError, match="not valid TOML"):
        S.load(str(p))


def test_cli_reports_a_bad_spec_in_one_line(tmp_path):
    import subprocess
    r = raw()
    r["gas"]["n_particles"] = 0
    p = tmp_path / "bad.toml"
    p.write_text(_toml(r))
    out = subprocess.run([sys.executable, "-m", "studies", "sweep", str(p)], cwd=S.ROOT, capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 2
    assert out.stderr.strip().count("\n") == 0 and "gas.n_particles: must be > 0" in out.stderr


def test_toml_writer_round_trips():
    r = raw()
    assert tomllib.loads(_toml(r)) == r


# ---- run identity -----------------------------------------------------------------------------

def test_run_key_depends_on_physics_not_on_labels_or_order():
    sp = S.validate(raw())
    keys = {r["name"]: r["key"] for r in S.runs(sp)}
    r2 = raw()
    r2["groups"] = list(reversed(r2["groups"]))
    r2["study"]["description"] = "another text"
    r2["analysis"]["fit_lo"] = 100.0
    r2["study"]["schedule"] = "round_robin"           # the queue order is not physics
    assert {r["name"]: r["key"] for r in S.runs(S.validate(r2))} == keys
    r3 = raw()
    r3["material"]["youngs_modulus"] = 2e7
    assert not set(keys.values()) & {r["key"] for r in S.runs(S.validate(r3))}
    r4 = raw()
    r4["groups"][0]["youngs_modulus"] = 1e7          # an override equal to the default: same runs
    assert {r["key"] for r in S.runs(S.validate(r4))} == set(keys.values())
    r5 = raw()
    r5["groups"][0]["n_particles"] = r5["gas"]["n_particles"] + 1     # another gas: other runs
    assert r5["study"]["in_results"] is False
    g0 = [r for r in S.runs(S.validate(r5)) if r["group"] == 0]
    assert g0 and not set(keys.values()) & {r["key"] for r in g0}
    assert all(r["params"]["gas"]["n_particles"] == r5["gas"]["n_particles"] + 1 for r in g0)


def test_n_particles_override_keeps_the_density_and_is_a_gas_of_its_own_in_the_effects_table():
    """A group's n_particles grows the box at the spec's volume fraction (L ~ N^(1/3)); in a spec
    whose runs feed results/effects.csv its rows carry their own n_particles (studies.effects.GAS_COLUMNS)."""
    r = raw("sphere_gas_size")
    sp = S.validate(r)
    by_n = {}
    for run in S.runs(sp):
        if run["seed"] == 1:
            by_n[run["params"]["gas"]["n_particles"]] = S.run_input(run["params"], record=False)["box_length"]
    assert set(by_n) == {108, 288}
    assert by_n[288] / by_n[108] == pytest.approx((288 / 108) ** (1 / 3), rel=1e-12)
    other = raw("dimer_paired")                        # its runs feed results/effects.csv
    other["groups"][0]["n_particles"] = 108
    sp = S.validate(other)
    from studies import effects
    assert {effects.gas_of(r["params"])["n_particles"] for r in S.runs(sp) if r["group"] == 0} == {108}


def test_legacy_dt_keeps_the_earlier_seeds_runs_and_raises_the_rest():
    """run.legacy_dt: seeds below ``below_seed`` resolve exactly as the spec did at the old factor
    (same keys: their finished runs stay valid), later seeds at the new one; both cases of a seed
    share one time step; a group's own dt_factor wins."""
    old = raw()
    old["run"]["dt_factor"] = 0.5
    old_keys = {(r["name"].rsplit("-", 1)[0]): r["key"] for r in S.runs(S.validate(old))}
    new = raw()
    new["run"].update(dt_factor=1.0, legacy_dt={"below_seed": 4, "dt_factor": 0.5})
    sp = S.validate(new)
    plain = raw()
    plain["run"]["dt_factor"] = 1.0
    plain_keys = {(r["name"].rsplit("-", 1)[0]): r["key"] for r in S.runs(S.validate(plain))}
    runs = S.runs(sp)
    assert {r["seed"] for r in runs} >= {1, 4}
    for r in runs:
        name = r["name"].rsplit("-", 1)[0]
        if r["seed"] < 4:
            assert r["params"]["run"]["dt_factor"] == 0.5 and r["key"] == old_keys[name]
        else:
            assert r["params"]["run"]["dt_factor"] == 1.0 and r["key"] == plain_keys[name]
    g = dict(sp["groups"][0], dt_factor=2.0)
    assert S.resolve_run(sp, g, "exact", 1)["run"]["dt_factor"] == 2.0


def _steps_per_contact(params):
    """t_c / dt of a run: a head-on Hertz contact of two of its shape's smallest member spheres
    (YADE's k_n, reduced mass half the exact clump's) at the thermal speed sqrt(2 e / m), over the
    run's own time step (``spec.time_step``).  t_c = 3.218 (mu / k_n)^(2/5) g^(-1/5)."""
    from studies import kinetic
    mat, e = params["material"], params["gas"]["energy_per_particle"]
    props = shp.properties(params["shape"]["definition"], mat["density"])
    r, m = min(props["radii"]), props["exact"]["mass"]
    kn = kinetic.hertz_kn(mat["youngs_modulus"], mat["poisson"], r, r)
    t_c = 3.218 * (0.5 * m / kn) ** 0.4 * math.sqrt(2 * e / m) ** -0.2
    return t_c / S.time_step(params)


def _measured_safe(params):
    """The same run in the configuration docs/timestep.md measured safe: E = 1e7 Pa, 1140 kg/m^3,
    3.75 J a particle, dt factor 1.0."""
    q = copy.deepcopy(params)
    q["material"].update(youngs_modulus=1e7, density=1140.0)
    q["gas"]["energy_per_particle"] = 3.75
    q["run"]["dt_factor"] = 1.0
    return q


# the shapes whose largest safe factor docs/timestep.md measured (1.0 at 1e7 Pa)
MEASURED_KINDS = ("dimer", "trimer_triangle", "tetrahedron")


def _most_steps_measured_safe(params):
    """The most steps per contact among the measured shapes (the paper's overlap 0.5, d_s = 0.1333 m)
    in their measured-safe configuration: what a shape the time-step study never ran must reach."""
    steps = []
    for kind in MEASURED_KINDS:
        q = copy.deepcopy(params)
        q["shape"]["definition"] = {"kind": kind, "sphere_diameter": 0.1333, "overlap": 0.5}
        steps.append(_steps_per_contact(_measured_safe(q)))
    return max(steps)


def _coarser_than_measured_safe(spec):
    """Runs of a spec that resolve a contact with fewer steps than the measured-safe configuration:
    their own shape at factor 1.0 where the time-step study measured that kind, else the most
    demanding measured shape."""
    def reference(params):
        if params["shape"]["definition"]["kind"] in MEASURED_KINDS:
            return _steps_per_contact(_measured_safe(params))
        return _most_steps_measured_safe(params)
    return [r["name"] for r in S.runs(spec)
            if _steps_per_contact(r["params"]) < (1 - 1e-9) * reference(r["params"])]


def test_a_shape_the_time_step_study_never_ran_is_held_to_the_measured_shapes_steps_per_contact():
    sp = S.load(str(SPECS / "grains.toml"))
    assert _coarser_than_measured_safe(sp) == []
    params = S.runs(sp)[0]["params"]
    need = _most_steps_measured_safe(params)
    assert _steps_per_contact(params) >= need
    with open(SPECS / "grains.toml", "rb") as f:
        coarse = tomllib.load(f)
    coarse["run"]["dt_factor"] *= 1.01 * _steps_per_contact(params) / need    # just too coarse
    coarse = S.validate(coarse)
    assert len(_coarser_than_measured_safe(coarse)) == len(S.runs(coarse)) > 0


def test_committed_specs_resolve_every_contact_as_finely_as_the_measured_safe_step():
    """The dt factor measured safe at 1e7 Pa (1.0; docs/timestep.md) holds at another stiffness,
    density or temperature only at as many steps per Hertz contact (t_c/dt ~ (E/rho)^(1/10) g^(-1/5),
    tests/test_timestep.py checks the leapfrog's side of it); where the time-step study was run at
    a spec's stiffness (results/timestep/timestep*.json), the spec is also within its measured
    largest safe factor."""
    for p in sorted(SPECS.glob("*.toml")):
        assert _coarser_than_measured_safe(S.load(str(p))) == [], p
    measured = {}
    for f in sorted((SPECS.parents[1] / "results" / "timestep").glob("timestep*.json")):
        res = json.loads(f.read_text())
        if "dimer" in res.get("decision", {}):
            measured[res["material"]["youngs_modulus"]] = res["decision"]["dimer"]["largest_safe_factor"]
    assert measured == {1e7: 1.0, 1e8: 1.25, 1e9: 1.58}
    sp = S.load(str(SPECS / "stiffness.toml"))
    for g in sp["groups"]:
        prm = S.resolve_run(sp, g, "exact", 1)
        assert prm["run"]["dt_factor"] <= measured[g["youngs_modulus"]]
        assert _steps_per_contact(prm) == pytest.approx(_steps_per_contact(_measured_safe(prm)), rel=0.01)
    bad = raw("stiffness")
    bad["groups"][1]["dt_factor"] = 2.0                        # fails the energy check at 1e9 (timestep_E1e9.json)
    assert len(_coarser_than_measured_safe(S.validate(bad))) == 2 * len(bad["groups"][1]["seeds"])
    hot = raw("dimer_equal_energy")
    hot["gas"]["energy_per_particle"] = 4 * 3.75               # contacts 4^(1/5) = 1.3x shorter at 1.0
    assert _coarser_than_measured_safe(S.validate(hot))


def test_run_key_includes_model_yade_and_clumpprops_versions(monkeypatch):
    sp = S.validate(raw())
    r = S.runs(sp)[0]
    for field, other in (("model_version", S.MODEL_VERSION + 1), ("yade", "2025.2"), ("clumpprops_version", "9.9")):
        p = copy.deepcopy(r["params"])
        p[field] = other
        assert S.run_key(p) != r["key"]
    assert r["params"]["clumpprops_version"] == clumpprops.__version__


def test_equal_energy_of_an_exact_mass_case_is_the_paired_run():
    r = raw()
    r["groups"].append({"shape": "dimer", "cases": ["exact", "mass_only"], "protocol": "equal_energy", "seeds": [1]})
    names = [x["name"] for x in S.runs(S.validate(r))]
    assert len(names) == len(set(names))
    assert not any("exact-equal_energy" in n or "mass_only-equal_energy" in n for n in names)


# ---- shapes against independent routes --------------------------------------------------------

def _lens(r, D):
    """Closed-form volume of the lens of two equal spheres of radius r, centres D apart."""
    return math.pi * (2 * r - D) ** 2 * (D ** 2 + 4 * D * r) / (12 * D)


@pytest.mark.parametrize("overlap", [0.25, 0.5, 0.75, 0.99])
def test_dimer_against_closed_form(overlap):
    d = 0.1333
    s = {"kind": "dimer", "sphere_diameter": d, "overlap": overlap}
    p = shp.properties(s, 1140.0)
    c = np.asarray(p["members"])
    assert np.linalg.norm(c[1] - c[0]) == pytest.approx(overlap * d, rel=1e-14)
    r = d / 2
    v = 2 * 4 / 3 * math.pi * r ** 3 - _lens(r, overlap * d)
    assert p["exact"]["volume"] == pytest.approx(v, rel=1e-12)
    assert p["sum"]["mass"] == pytest.approx(1140.0 * 2 * 4 / 3 * math.pi * r ** 3, rel=1e-14)
    assert p["linear"]
    assert np.allclose(c[:, :2], 0) and np.allclose(c.sum(0), 0, atol=1e-16)


def test_trimer_linear_and_triangle_without_triple_overlap_against_lenses():
    d, ov = 0.1, 0.9            # triangle circumradius 0.9 d / sqrt(3) = 0.52 d > r: no triple region
    r = d / 2
    ball = 4 / 3 * math.pi * r ** 3
    lin = shp.properties({"kind": "trimer_linear", "sphere_diameter": d, "overlap": ov}, 1000.0)
    assert lin["exact"]["volume"] == pytest.approx(3 * ball - 2 * _lens(r, ov * d), rel=1e-12)
    assert lin["linear"]
    tri = shp.properties({"kind": "trimer_triangle", "sphere_diameter": d, "overlap": ov}, 1000.0)
    c = np.asarray(tri["members"])
    dist = np.linalg.norm(c[:, None] - c[None], axis=-1)[np.triu_indices(3, 1)]
    assert np.allclose(dist, ov * d, rtol=1e-14)
    assert tri["exact"]["volume"] == pytest.approx(3 * ball - 3 * _lens(r, ov * d), rel=1e-12)
    assert not tri["linear"]
    pm = tri["exact"]["principal_moments"]
    assert pm[0] == pytest.approx(pm[1], rel=1e-12)           # in-plane moments equal (3-fold axis)
    assert pm[2] > pm[1]                                        # the plate normal has the largest moment
    I = np.asarray(tri["exact"]["inertia"])
    assert abs(I[2, 2] - pm[2]) < 1e-12 * pm[2]                 # ... and it is the body z axis
    mc = clumpprops.mass_properties(c, tri["radii"], density=1000.0, method="montecarlo", n_samples=400_000, seed=1)
    se = np.asarray(mc.standard_error.inertia)
    assert np.all(np.abs(np.asarray(mc.inertia) - I) <= 4 * se + 1e-12 * pm[2])


def _axisymmetric_k2(z_centres, r, density):
    """Exact mass and transverse moment about the COM of a union of equal balls centred on the z
    axis, from the slice-by-slice reference (``_clump_reference``: no clumpprops code), by
    inclusion-exclusion over neighbours (no three of these balls share a point)."""
    import _clump_reference as ref

    c = [np.array([0.0, 0.0, z]) for z in z_centres]
    bodies = [ref.sphere_body(x, r) for x in c] + [ref.pair_body(a, r, b, r, "intersection")
                                                   for a, b in zip(c, c[1:])]
    v, _, qc = ref.combine(bodies, [1.0] * len(c) + [-1.0] * (len(c) - 1))
    return density * v, ref.inertia(qc, density)[0, 0]


@pytest.mark.parametrize("kind,overlap", [("dimer", 0.25), ("dimer", 0.5), ("dimer", 0.75),
                                          ("trimer_linear", 0.6)])
def test_k2_error_of_a_linear_clump_is_its_transverse_moment_against_quadrature(kind, overlap):
    # the axial moment of a linear clump never enters a frictionless gas's motion; its k^2 error
    # is the transverse one (tr(I)/2m would mix in the axial moment: -10.5 % for the paper's
    # dimer, against -11.9 % here)
    d, rho = 0.1333, 1140.0
    s = {"kind": kind, "sphere_diameter": d, "overlap": overlap}
    zc = np.asarray(shp.properties(s, rho)["members"])[:, 2]
    r = d / 2
    m_e, i_e = _axisymmetric_k2(zc, r, rho)
    m1 = rho * 4 / 3 * math.pi * r ** 3
    m_s = len(zc) * m1
    i_s = sum(m1 * (0.4 * r * r + z * z) for z in zc - zc.mean())
    want = (i_s / m_s) / (i_e / m_e) - 1.0
    assert shp.k2_error(s, rho) == pytest.approx(want, rel=1e-9)
    if kind == "dimer" and overlap == 0.5:
        assert shp.k2_error(s, rho) == pytest.approx(-0.119, abs=5e-4)


def test_k2_error_of_a_planar_trimer_is_its_mean_moment_against_monte_carlo():
    s = {"kind": "trimer_triangle", "sphere_diameter": 0.1333, "overlap": 0.5}
    rho = 1140.0
    p = shp.properties(s, rho)
    c, r = np.asarray(p["members"]), np.asarray(p["radii"])
    mc = clumpprops.mass_properties(c, r, density=rho, method="montecarlo", n_samples=400_000, seed=5)
    k2_mc = np.trace(np.asarray(mc.inertia)) / mc.mass
    se = np.asarray(mc.standard_error.inertia)
    rel_se = np.sum(np.diag(se)) / np.trace(np.asarray(mc.inertia)) + mc.standard_error.mass / mc.mass
    sm = clumpprops.mass_properties(c, r, density=rho, method="sum")
    k2_sum = np.trace(np.asarray(sm.inertia)) / sm.mass
    want = k2_sum / k2_mc - 1.0
    got = shp.k2_error(s, rho)
    assert abs(got - want) <= 4 * rel_se * (1 + want)
    # ... and not the largest moment's error (the collision maps' "largest moment over mass")
    pm_s, pm_e = np.asarray(p["sum"]["principal_moments"]), np.asarray(p["exact"]["principal_moments"])
    largest = (pm_s[2] / p["sum"]["mass"]) / (pm_e[2] / p["exact"]["mass"]) - 1.0
    assert abs(got - want) < abs(largest - want) and abs(got - largest) > 0.01     # -15.8 % vs -17.3 %


@pytest.mark.parametrize("shape", [{"kind": "dimer", "sphere_diameter": 0.1333, "overlap": 0.5},
                                   {"kind": "tetrahedron", "sphere_diameter": 0.1333, "overlap": 0.5}])
def test_effects_errors_are_those_of_the_body_each_case_runs_with(shape):
    # effects.csv's x values against the masses and moments the YADE script is handed
    # (gas_model.resolve_case: principal moments, not the body-frame tensor k2_error reads)
    from studies import effects, gas_model

    rho = 1140.0
    props = shp.properties(shape, rho)
    ex = gas_model.resolve_case(props, "exact")
    seen = set()
    for case in ("uncorrected", "mass_only", "inertia_only"):
        b = gas_model.resolve_case(props, case)
        got = effects.case_errors(shape, rho, case)
        assert got["mass_error"] == pytest.approx(b["mass"] / ex["mass"] - 1, abs=1e-14)
        k2 = (np.mean(b["moments"]) / b["mass"]) / (np.mean(ex["moments"]) / ex["mass"]) - 1
        assert got["k2_error"] == pytest.approx(k2, abs=1e-13)
        seen.add(round(got["k2_error"], 6))
    assert len(seen) == 3
    if shape["kind"] == "dimer":      # the paper's dimer: docs/collision_map.md's +4.5 % and -15.6 %
        assert effects.case_errors(shape, rho, "mass_only")["k2_error"] == pytest.approx(0.045, abs=5e-4)
        assert effects.case_errors(shape, rho, "inertia_only")["k2_error"] == pytest.approx(-0.156, abs=5e-4)
    assert effects.case_errors(shape, rho, "spheres") == {"mass_error": None, "k2_error": None}
    with pytest.raises(ValueError, match="source"):
        shp.k2_error(shape, rho, mass="union")


def test_tetrahedron_with_triple_overlaps_against_monte_carlo():
    s = {"kind": "tetrahedron", "sphere_diameter": 0.1, "overlap": 0.6}
    p = shp.properties(s, 1000.0)
    c = np.asarray(p["members"])
    dist = np.linalg.norm(c[:, None] - c[None], axis=-1)[np.triu_indices(4, 1)]
    assert np.allclose(dist, 0.06, rtol=1e-14)
    pm = np.asarray(p["exact"]["principal_moments"])
    assert np.ptp(pm) < 1e-12 * pm.max()                     # a regular tetrahedron: isotropic
    mc = clumpprops.mass_properties(c, p["radii"], density=1000.0, method="montecarlo", n_samples=400_000, seed=3)
    assert abs(p["exact"]["mass"] - mc.mass) < 4 * mc.standard_error.mass
    with pytest.raises(clumpprops.ClumpGeometryError):     # the pairwise formula cannot do it
        clumpprops.mass_properties(c, p["radii"], density=1000.0, method="pairwise")


def test_template_file_is_rotated_into_its_body_frame(tmp_path):
    rng = np.random.default_rng(5)
    c = rng.normal(scale=0.05, size=(5, 3)) + [1.0, 2.0, 3.0]
    rr = rng.uniform(0.03, 0.05, 5)
    f = tmp_path / "t.txt"
    f.write_text("".join(f"{x} {y} {z} {r} 0\n" for (x, y, z), r in zip(c, rr)))
    p = shp.properties({"kind": "file", "path": str(f), "scale": 1.0}, 1000.0)
    ref = clumpprops.mass_properties(c, rr, density=1000.0)
    assert p["exact"]["mass"] == pytest.approx(ref.mass, rel=1e-13)
    np.testing.assert_allclose(p["exact"]["principal_moments"], ref.principal_moments, rtol=1e-12)
    I = np.asarray(p["exact"]["inertia"])
    assert np.abs(I - np.diag(np.diag(I))).max() < 1e-12 * I.max()     # principal frame
    np.testing.assert_allclose(np.diag(I), ref.principal_moments, rtol=1e-12)
    np.testing.assert_allclose(p["exact"]["com"], 0, atol=1e-15)


# ---- initial conditions -----------------------------------------------------------------------

def _initial_conditions_v1(seed, n_particles, box, m_case, m_exact, protocol="paired",
                           energy_per_particle=3.75, gap=0.02, bounding_radius=0.1):
    """The study's initial conditions as model version 1 draws them (its studies/gas_model.py code,
    copied verbatim apart from the masses passed in): the reference."""
    rng = np.random.default_rng(seed)
    dmin = 2 * bounding_radius + gap
    pos = np.empty((n_particles, 3))
    k = 0
    while k < n_particles:
        p = rng.uniform(0.0, box, 3)
        d = pos[:k] - p
        d -= box * np.round(d / box)
        if k == 0 or np.min(np.einsum("ij,ij->i", d, d)) > dmin ** 2:
            pos[k] = p
            k += 1
    axes = rng.normal(size=(n_particles, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    vel = rng.normal(size=(n_particles, 3))
    vel -= vel.mean(axis=0)
    m_scale = m_exact if protocol == "paired" else m_case
    vel *= np.sqrt(n_particles * energy_per_particle / (0.5 * m_scale * np.sum(vel ** 2)))
    return pos, axes, vel


@pytest.mark.parametrize("case, protocol", [("exact", "paired"), ("uncorrected", "paired"), ("spheres", "paired"),
                                            ("uncorrected", "equal_energy")])
def test_paper_spec_gives_the_first_versions_initial_conditions(case, protocol):
    sp = S.load(str(SPECS / "paper.toml"))
    run = next(r for r in S.runs(sp) if r["case"] == case and r["protocol"] == protocol and r["seed"] == 2)
    rin = S.run_input(run["params"])
    assert rin["box_length"] == pytest.approx(12.18284909686642, rel=1e-14)      # the first version's box
    assert rin["dt"] == pytest.approx(0.0003558136327489435, rel=1e-14)
    r = 0.1333 / 2
    m_sum = 1140.0 * 2 * 4 / 3 * math.pi * r ** 3                       # closed forms, not the library
    m_ex = m_sum - 1140.0 * _lens(r, 2 * r / 2)
    m = {"exact": m_ex, "uncorrected": m_sum, "spheres": m_ex}
    pos, axes, vel = _initial_conditions_v1(2, 864, rin["box_length"], m[case], m["exact"], protocol)
    np.testing.assert_array_equal(np.asarray(rin["initial"]["pos"]), pos)
    np.testing.assert_allclose(np.asarray(rin["initial"]["vel"]), vel, rtol=1e-12)
    ori = np.asarray(rin["initial"]["ori"]).reshape(-1, 3, 3)
    np.testing.assert_allclose(ori[:, :, 2], axes, atol=1e-15)           # body z axis = the old axis
    np.testing.assert_allclose(np.asarray(rin["initial"]["angvel"]), 0.0)
    if case != "spheres":
        c = np.asarray(rin["body"]["members"])
        assert np.linalg.norm(c[1] - c[0]) == pytest.approx(0.1333 / 2, rel=1e-14)


def test_equipartition_start_shares_the_energy_and_is_paired():
    """spin_pairing = "same" (the first equilibrated runs): every paired case gets exact's spins."""
    r = raw()
    r["gas"]["start"] = "equipartition"
    r["gas"]["spin_pairing"] = "same"
    r["gas"]["n_particles"] = 200
    r["groups"].append({"shape": "dimer", "cases": ["uncorrected"], "protocol": "equal_energy", "seeds": [2]})
    sp = S.validate(r)
    by = {(x["case"], x["protocol"]): x for x in S.runs(sp) if x["seed"] == 2}
    ex = S.run_input(by[("exact", "paired")]["params"])
    un = S.run_input(by[("uncorrected", "paired")]["params"])
    ee = S.run_input(by[("uncorrected", "equal_energy")]["params"])
    v, w = np.asarray(ex["initial"]["vel"]), np.asarray(ex["initial"]["angvel"])
    m, I = ex["body"]["mass"], ex["body"]["moments"][0]
    e_t, e_r = 0.5 * m * np.sum(v ** 2), 0.5 * I * np.sum(w ** 2)
    assert e_t + e_r == pytest.approx(200 * 3.75, rel=1e-12)
    assert e_r / (e_t + e_r) == pytest.approx(0.4, rel=1e-12)             # 2 of 5 degrees of freedom
    axes = np.asarray(ex["initial"]["ori"]).reshape(-1, 3, 3)[:, :, 2]
    assert np.abs(np.einsum("ni,ni->n", w, axes)).max() < 1e-12 * np.abs(w).max()   # no axial spin
    np.testing.assert_array_equal(np.asarray(un["initial"]["vel"]), v)             # paired
    np.testing.assert_array_equal(np.asarray(un["initial"]["angvel"]), w)
    vu, wu = np.asarray(ee["initial"]["vel"]), np.asarray(ee["initial"]["angvel"])
    mu, Iu = ee["body"]["mass"], ee["body"]["moments"][0]
    assert 0.5 * mu * np.sum(vu ** 2) == pytest.approx(e_t, rel=1e-12)             # equal energy
    assert 0.5 * Iu * np.sum(wu ** 2) == pytest.approx(e_r, rel=1e-12)
    # each body-frame component has variance kT / I (Gaussian), checked on the 400 components
    kT = 2 * 3.75 / 5
    assert np.mean(np.sum(w ** 2, axis=1)) * I / 2 == pytest.approx(kT, rel=0.15)


def test_equipartition_for_an_aspherical_shape_uses_its_principal_moments():
    r = raw()
    r["study"]["yade"] = "2025.2"
    r["gas"].update(start="equipartition", n_particles=3000)
    r["shapes"]["tri"] = {"kind": "trimer_triangle", "sphere_diameter": 0.1333, "overlap": 0.5}
    r["groups"] = [{"shape": "tri", "cases": ["exact"], "seeds": [4]}]
    sp = S.validate(r)
    rin = S.run_input(S.runs(sp)[0]["params"])
    p = shp.properties(sp["shapes"]["tri"], 1140.0)
    I = np.asarray(p["exact"]["inertia"])
    ori = np.asarray(rin["initial"]["ori"]).reshape(-1, 3, 3)
    wb = np.einsum("nji,nj->ni", ori, np.asarray(rin["initial"]["angvel"]))   # body frame
    e_axis = 0.5 * np.diag(I) * np.mean(wb ** 2, axis=0)                         # kT/2 per axis
    np.testing.assert_allclose(e_axis, 3.75 / 6, rtol=0.08)
    e_r = 0.5 * np.einsum("ni,ij,nj->", wb, I, wb)
    assert e_r == pytest.approx(3000 * 3.75 / 2, rel=1e-12)
    assert rin["body"]["route"] == "aspherical" and rin["rot_dof"] == 3
    np.testing.assert_allclose(np.einsum("nij,nkj->nik", ori, ori), np.broadcast_to(np.eye(3), ori.shape), atol=1e-14)


def _own_vs_same(shape, n=4000, seed=3):
    """Run inputs of every (case, protocol) for both spin pairings, an equipartition start."""
    out = {}
    for pairing in ("own", "same"):
        r = raw()
        r["study"]["yade"] = "2025.2"
        r["gas"].update(start="equipartition", n_particles=n, spin_pairing=pairing)
        r["shapes"]["s"] = shape
        r["groups"] = [{"shape": "s", "cases": ["exact", "uncorrected", "mass_only", "inertia_only"], "seeds": [seed]},
                       {"shape": "s", "cases": ["uncorrected"], "protocol": "equal_energy", "seeds": [seed]}]
        sp = S.validate(r)
        out[pairing] = {(x["case"], x["protocol"]): x for x in S.runs(sp)}
    return out


def _sqrtm(a):
    w, V = np.linalg.eigh(a)
    return V @ np.diag(np.sqrt(w)) @ V.T


def _state(run):
    rin = S.run_input(run["params"])
    ori = np.asarray(rin["initial"]["ori"]).reshape(-1, 3, 3)
    v, w = np.asarray(rin["initial"]["vel"]), np.asarray(rin["initial"]["angvel"])
    return rin, v, np.einsum("nji,nj->ni", ori, w)           # body-frame angular velocities


@pytest.mark.parametrize("shape", [{"kind": "dimer", "sphere_diameter": 0.1333, "overlap": 0.5},
                                   {"kind": "trimer_triangle", "sphere_diameter": 0.1333, "overlap": 0.5},
                                   {"kind": "tetrahedron", "sphere_diameter": 0.1333, "overlap": 0.5}],
                         ids=["dimer", "trimer_triangle", "tetrahedron"])
def test_own_spin_pairing_starts_every_case_in_its_own_equipartition(shape):
    """spin_pairing = "own": paired velocities, and each case's spins at equipartition at the
    temperature of its own translational motion (what the paper's zero-spin start relaxes to):
    rotational energy per rotational degree of freedom = translational energy per translational
    one, and kT/2 about each of the case's principal axes; so every paired case has exact's
    thermal speed.  Exact's state, and a linear clump's equal-energy state, do not change."""
    runs = _own_vs_same(shape)
    props = shp.properties(shape, 1140.0)
    rot_dof = 2 if props["linear"] else 3
    rin_e, v_e, wb_e = _state(runs["own"][("exact", "paired")])
    I_e = np.asarray(props["exact"]["inertia"])
    _, v_es, wb_es = _state(runs["same"][("exact", "paired")])
    np.testing.assert_array_equal(v_e, v_es)
    np.testing.assert_array_equal(wb_e, wb_es)
    assert runs["own"][("exact", "paired")]["key"] == runs["same"][("exact", "paired")]["key"]
    n = len(v_e)
    for case, prot in (("uncorrected", "paired"), ("mass_only", "paired"), ("inertia_only", "paired"),
                       ("uncorrected", "equal_energy")):
        own, same = runs["own"][(case, prot)], runs["same"][(case, prot)]
        rin, v, wb = _state(own)
        m = rin["body"]["mass"]
        src = gm.CASE_SOURCES[case][1]
        I = np.asarray(props["exact" if src == "exact" else "sum"]["inertia"])
        e_t = 0.5 * m * np.sum(v ** 2)
        e_r = 0.5 * np.einsum("ni,ij,nj->", wb, I, wb)
        assert e_r / rot_dof == pytest.approx(e_t / 3, rel=1e-12), case       # equipartition in total
        kT = 2 * e_t / (3 * n)
        w_ax, V = np.linalg.eigh(I)
        wp = wb @ V                                                          # principal frame
        e_axis = 0.5 * w_ax * np.mean(wp ** 2, axis=0)
        live = e_axis > 1e-6 * kT                                            # a dimer: none about its axis
        assert live.sum() == rot_dof
        np.testing.assert_allclose(e_axis[live], kT / 2, rtol=0.08)          # kT/2 per axis (4000 draws)
        # covariance exactly kT I^-1 from exact's normal draws z: I^(1/2) w = s R z with R orthogonal,
        # so |I^(1/2) w| / |I_exact^(1/2) w_exact| is one constant over the particles
        ratio = np.linalg.norm(wb @ _sqrtm(I), axis=1) / np.linalg.norm(wb_e @ _sqrtm(I_e), axis=1)
        assert np.ptp(ratio) < 1e-9 * ratio.mean(), (case, prot, np.ptp(ratio) / ratio.mean())
        if prot == "paired":
            np.testing.assert_array_equal(v, v_e)                            # paired velocities
            kT_e = 2 * 0.5 * rin_e["body"]["mass"] * np.sum(v_e ** 2) / (3 * n)
            assert kT / m == pytest.approx(kT_e / rin_e["body"]["mass"], rel=1e-12)   # exact's thermal speed
            assert own["key"] != same["key"] and own["params"]["gas"]["spin_pairing"] == "own"
            assert S.spin_pairing_of(own["params"]) == "own" and S.spin_pairing_of(same["params"]) == "same"
        elif props["linear"]:   # equal energy, linear clump: the two pairings give one state and one key
            _, v_s, wb_s = _state(same)
            np.testing.assert_array_equal(v, v_s)
            np.testing.assert_allclose(wb, wb_s, rtol=1e-13, atol=1e-13 * np.abs(wb).max())
            assert own["key"] == same["key"] and S.spin_pairing_of(own["params"]) is None
        else:                   # equal energy, aspherical: the case's own covariance, a new key
            assert own["key"] != same["key"] and S.spin_pairing_of(same["params"]) == "same"
    # the "same" pairing really is out of equipartition for a paired case whose k^2 differs
    rin, v, wb = _state(runs["same"][("uncorrected", "paired")])
    I = np.asarray(props["sum"]["inertia"])
    ratio = (0.5 * np.einsum("ni,ij,nj->", wb, I, wb) / rot_dof) / (0.5 * rin["body"]["mass"] * np.sum(v ** 2) / 3)
    assert abs(ratio - 1) > 0.05


def test_spin_pairing_is_validated():
    r = raw()
    r["gas"]["spin_pairing"] = "paired"
    with pytest.raises(S.SpecError, match="gas.spin_pairing"):
        S.validate(r)


def _file_shape_spec(tmp_path, lines, **shape):
    f = tmp_path / "clump.txt"
    f.write_text("".join(f"{x} {y} {z} {r} 0\n" for x, y, z, r in lines))
    r = raw()
    r["shapes"] = {"mine": dict(kind="file", path=str(f), **shape)}
    for g in r["groups"]:
        g["shape"] = "mine"
    return r


@pytest.mark.parametrize("lines, message", [
    ([(0, 0, 0, 0.05), (1.0, 0, 0, 0.05)], "the spheres do not form one body: sphere 1"),
    ([(0, 0, 0, 0.05), (0.05, 0, 0, 0.05), (0.05, 0, 0, 0.05)], "sphere 1 is coincident with or inside sphere 2"),
    ([(0, 0, 0, 0.05), (0.01, 0, 0, 0.02)], "sphere 1 is coincident with or inside sphere 0"),
])
def test_a_file_clump_that_is_not_one_body_is_refused_by_name(tmp_path, lines, message):
    with pytest.raises(S.SpecError, match="shapes.mine: " + message):
        S.validate(_file_shape_spec(tmp_path, lines))


@pytest.mark.parametrize("mutate, message", [
    (lambda r: r["shapes"]["dimer"].update(overlap=1.5), r"shapes.dimer: the spheres do not form one body.*overlap = D/d_s must be < 1"),
    (lambda r: r["shapes"]["dimer"].update(scale=2.0), "shapes.dimer.scale: not used by kind = 'dimer'"),
    (lambda r: r["gas"].update(volume_fraction=0.7), r"gas.volume_fraction = 0.7 cannot be placed.*use volume_fraction <= 0\.0"),
    (lambda r: r["analysis"].update(t_eq=500.0), r"analysis.t_eq = 500 s is too close to the end of the run \(t_end = 400 s"),
    (lambda r: r["analysis"].update(cuts=[0.0, 450.0]), r"analysis.cuts = 450 s is too close to the end"),
    (lambda r: r["analysis"].update(max_lag=360.0), r"analysis.max_lag = 360 s does not fit the analysed window of 300 s"),
    (lambda r: r["groups"][0].update(t_end=200.0), r"groups\[0\]: analysis.max_lag = 150 s does not fit the analysed window of 100 s"),
])
def test_a_spec_that_cannot_run_or_be_analysed_is_refused_before_any_run(mutate, message):
    assert re.search(message, _bad(mutate)), _bad(mutate)


def test_the_largest_volume_fraction_the_refusal_names_can_be_placed():
    from studies import gas_model as gm
    msg = _bad(lambda r: r["gas"].update(volume_fraction=0.7))
    phi = float(re.search(r"use volume_fraction <= ([0-9.e-]+)", msg).group(1))
    r = raw()
    r["gas"]["volume_fraction"] = phi * 0.999
    sp = S.validate(r)
    run = S.runs(sp)[0]
    state = S.run_input(run["params"])       # places the particles
    pos = np.asarray(state["initial"]["pos"])
    assert len(pos) == r["gas"]["n_particles"]
    r["gas"]["volume_fraction"] = phi * 1.01
    with pytest.raises(S.SpecError, match="cannot be placed"):
        S.validate(r)


def test_a_bad_spec_stops_the_command_line_with_one_line_and_status_2(tmp_path):
    import subprocess
    r = raw()
    r["shapes"]["dimer"]["overlap"] = 1.5
    f = tmp_path / "bad.toml"
    f.write_text(_toml(r))
    p = subprocess.run([sys.executable, "-m", "studies", "status", str(f)], capture_output=True, text=True,
                       cwd=S.ROOT)
    assert p.returncode == 2
    assert p.stdout == "" and len(p.stderr.strip().splitlines()) == 1
    assert "shapes.dimer: the spheres do not form one body" in p.stderr


def _measured_vacf_time(study, shape, n=8):
    """The velocity correlation time (s) measured in committed exact runs: the integral of the
    normalised VACF to the stored lags, averaged over n seeds."""
    out = []
    for f in sorted((SPECS.parents[1] / "results" / study / "runs").glob(f"{shape}-exact-*.json"))[:n]:
        w = json.loads(f.read_text())["windows"][0]
        v = np.asarray(w["vacf"])
        out.append(np.trapz(v / v[0], dx=w["frame_interval"]))
    assert len(out) == n
    return float(np.mean(out))


@pytest.mark.parametrize("study, group", [("dimer_paired", 0), ("shapes", 0), ("shapes", 1), ("shapes", 2), ("shapes", 3)])
def test_the_velocity_correlation_time_behind_the_defaults_matches_the_gas_runs(study, group):
    """Kinetic theory's tau_v = m D / kT (hard spheres of the clump's volume) against the VACF of the
    committed runs of five shapes: within 15 % (it is 0.90-1.01 of the measured)."""
    sp = S.load(str(SPECS / f"{study}.toml"))
    g = sp["groups"][group]
    ratio = S.velocity_correlation_time(sp, g) / _measured_vacf_time(study, g["shape"])
    assert 0.85 < ratio < 1.1, ratio


def test_a_spec_of_shape_material_gas_and_cases_only_gets_its_times_from_the_gas(tmp_path):
    """No [run] or [analysis] table: t_end, the recording, the lags and the fit window follow from
    tau_v, the spec validates, and its runs can be placed and analysed."""
    r = {"study": {"name": "mine", "results": str(tmp_path / "r"), "yade": "2023.02a"},
         "material": {"density": 1140.0, "youngs_modulus": 1e7, "poisson": 0.4},
         "gas": {"n_particles": 864, "volume_fraction": 0.001, "energy_per_particle": 3.75, "start": "equipartition"},
         "shapes": {"d": {"kind": "dimer", "sphere_diameter": 0.1333, "overlap": 0.5}},
         "groups": [{"shape": "d", "cases": ["exact", "uncorrected"], "seeds": [1, 2]}]}
    sp = S.validate(r)
    tau = sp["derived"]["tau_v"]
    a, run = sp["analysis"], sp["run"]
    assert a["t_eq"] == "auto" and run["dt_factor"] == 1.0
    # each rounded to 1, 2, 2.5 or 5 x 10^k (at most a factor 2), up for lags and lengths, down for the rest
    assert 4 * tau <= a["max_lag"] <= 8 * tau and 2.5 * tau <= a["fit_lo"] <= 5 * tau and 7 * tau <= a["fit_hi"] <= 14 * tau
    assert 40 * tau <= run["t_end"] <= 80 * tau and 0.005 * tau <= run["rec_interval"] <= 0.01 * tau
    assert S.runs(sp) and S.analysis_windows(sp) == ([0.0], a["max_lag"])
    r["run"] = {"t_end": 150.0}                    # too short for the derived lags: said, not guessed
    with pytest.raises(S.SpecError, match="analysis.fit_hi = 200 s does not fit the analysed window of 150 s"):
        S.validate(r)


def test_touching_spheres_are_one_body_and_a_sensitivity_window_must_fit_the_run():
    r = raw()
    r["shapes"]["dimer"]["overlap"] = 1.0                  # tangent spheres: one body, as YADE clumps them
    assert S.validate(r)["shapes"]["dimer"]["overlap"] == 1.0
    msg = _bad(lambda r: r["analysis"].update(sensitivity=[[399.9, 5.0, 9.0]]))
    assert "analysis.sensitivity = 399.9 s is too close to the end of the run" in msg, msg


def test_a_spec_argument_is_a_file_where_one_exists_else_a_committed_spec_name(tmp_path, monkeypatch):
    own = tmp_path / "paper.toml"
    own.write_text("")
    assert S.spec_path(str(own)) == str(own)                      # a file beats the committed spec
    for arg in ("paper", "paper.toml"):
        assert S.spec_path(arg) == str(SPECS / "paper.toml")
    monkeypatch.chdir(tmp_path)
    assert S.spec_path("paper.toml") == "paper.toml"              # ./paper.toml exists here
    (tmp_path / "grains").mkdir()                                 # a folder is not a spec file
    assert S.spec_path("grains") == str(SPECS / "grains.toml")
    assert S.spec_path("no_such_spec") == "no_such_spec"          # load() then names the missing file
    with pytest.raises(S.SpecError, match="no_such_spec"):
        S.load(S.spec_path("no_such_spec"))
