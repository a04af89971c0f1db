"""The generated report (studies/report/) and the sphere-gas table (studies/sphere_gas.py) from
the committed results: every number in the answers comes from the tables, and the committed
sphere gas agrees with kinetic theory."""
import json
import math
import shutil
from pathlib import Path

import pandas as pd
import pytest

from studies import report, sphere_gas
from studies import spec as S


@pytest.fixture()
def results_copy(tmp_path, monkeypatch):
    src = S.ROOT + "/results"
    dst = tmp_path / "results"
    shutil.copytree(src, dst, ignore=shutil.ignore_patterns("runs", "*.png"))
    monkeypatch.setattr(report, "RESULTS", str(dst))
    return dst


def test_report_regenerates_the_committed_page_and_effects_table(results_copy):
    """The golden file: the page rendered from the committed results is the committed
    results/README.md byte for byte, and results/effects.csv is rewritten unchanged.  Every wording
    lives in studies/templates/report/; a change of wording is a change of this file and the page."""
    committed = (Path(S.ROOT) / "results" / "README.md").read_text()
    effects_csv = (Path(S.ROOT) / "results" / "effects.csv").read_bytes()
    text = report.build()
    assert text == committed
    assert (results_copy / "README.md").read_text() == text
    assert (results_copy / "effects.csv").read_bytes() == effects_csv


def test_report_states_the_numbers_of_its_tables(results_copy):
    """The page's numbers are those of the tables it reads (the CSV files, not the page's own code)."""
    text = report.build()
    sph = pd.read_csv(results_copy / "sphere_gas.csv")
    diff = pd.read_csv(results_copy / "granular_gas" / "diff_D.csv")
    u = diff[(diff.case == "uncorrected") & (diff.protocol == "paired")].iloc[0]
    assert f"uncorrected vs exact {100 * u.relative:+.2f} %" in text
    for r in sph.itertuples():
        assert f"measured D {100 * (r.ratio_hertz - 1):+.2f} %" in text
        ci = "n/a" if pd.isna(r.ci_low) else f"[{r.ci_low:.3f}, {r.ci_high:.3f}]"     # one run: no interval
        assert f"| {r.D:.3f} | {ci} |" in text
    eff = pd.read_csv(results_copy / "effects.csv")
    for r in eff.itertuples():
        assert (f"| {r.shape} | {'' if pd.isna(r.overlap) else r.overlap} | {r.protocol} | {r.youngs_modulus:.0e} | "
                f"{r.case} | {r.n_pairs} | {100 * r.relative:+.2f} % |") in text


def test_effects_rows_agree_with_the_run_records_by_an_independent_route():
    """The stiffness series' rows of results/effects.csv, recomputed from the run records alone: each
    seed's D_mass_only / D_exact - 1 (the records' Green-Kubo D), its mean and a Student-t 95 %
    interval written out here (not studies.estimators)."""
    from scipy import stats

    from studies import design
    sp = S.load(S.ROOT + "/studies/specs/stiffness.toml")
    by = {}
    for rec in design.load_records(sp, S.results_dir(sp)).values():
        if rec["checks"]["ok"]:
            e_mod = float(rec["params"]["material"]["youngs_modulus"])
            by.setdefault((e_mod, rec["seed"]), {})[rec["case"]] = design.run_d(rec, sp["analysis"]["t_eq"],
                                                                                stderr=False)["D"]
    eff = pd.read_csv(S.ROOT + "/results/effects.csv")
    for e_mod in (1e8, 1e9):
        x = [c["mass_only"] / c["exact"] - 1 for (e, _), c in sorted(by.items())
             if e == e_mod and {"exact", "mass_only"} <= set(c)]
        n = len(x)
        mean = sum(x) / n
        hw = stats.t.ppf(0.975, n - 1) * math.sqrt(sum((v - mean) ** 2 for v in x) / (n - 1)) / math.sqrt(n)
        (row,) = eff[(eff["shape"] == "dimer") & (eff["youngs_modulus"] == e_mod) & (eff["case"] == "mass_only")
                     & (eff["protocol"] == "paired")].itertuples()
        assert row.n_pairs == n >= 12
        assert row.relative == pytest.approx(mean, abs=1e-9)
        assert (row.relative_ci_low, row.relative_ci_high) == pytest.approx((mean - hw, mean + hw), abs=1e-9)


def test_report_without_sphere_table_says_so(results_copy):
    (results_copy / "sphere_gas.csv").unlink()
    text = report.build()
    assert "No sphere-gas runs yet." in text
    assert "Sphere gas vs kinetic theory" not in text


def test_fig2_without_its_parameters_is_refused_not_guessed(results_copy):
    (results_copy / "granular_gas" / "params.json").unlink()
    with pytest.raises(FileNotFoundError, match="no params.json beside it"):
        report.build()
    (results_copy / "granular_gas" / "diff_D.csv").unlink()          # no Fig. 2 table: no section, no error
    assert "## The paper's Fig. 2" not in report.build()


def test_first_seconds_table_states_the_shape_factors_pairs():
    base = {"shape": "dimer", "overlap": 0.5, "youngs_modulus": 1e7, "protocol": "paired", "map_relative": 0.01,
            "map_se": 0.001, "gas_relative": 0.012, "gas_ci_low": 0.0, "gas_ci_high": 0.024, "n_pairs": 3}
    rr = [dict(base, case="uncorrected", shape_relative=0.004, shape_ci_low=-0.01, shape_ci_high=0.018, shape_n_pairs=3),
          dict(base, case="mass_only", shape_relative=0.02, shape_ci_low=float("nan"), shape_ci_high=float("nan"),
               shape_n_pairs=1),
          dict(base, case="inertia_only", shape_relative=float("nan"), shape_ci_low=float("nan"),
               shape_ci_high=float("nan"), shape_n_pairs=0)]
    lines = []
    report.rate_ratio_section(lines, rr)
    rows = {ln.split(" | ")[3]: ln for ln in lines if ln.startswith("| dimer")}
    assert rows["uncorrected"].endswith("| +0.40 % [-1.00, +1.80] % |")
    assert rows["mass_only"].endswith("| +2.00 % n/a (1 of 3 pairs) |")
    assert rows["inertia_only"].endswith("| n/a |")


def test_committed_sphere_gas_agrees_with_kinetic_theory():
    """The first version's sphere gas (E = 1e7 Pa, 8 seeds) against the Hertz-sphere Boltzmann D,
    recomputed here from the committed tables with a smaller Monte Carlo (SE ~0.3 %)."""
    g = sphere_gas.gas_from_first_version()
    assert g is not None and g["n_runs"] >= 8
    assert g["kT"] == pytest.approx(2.5, rel=1e-3)          # 3.24 kJ / 864 spheres, all translational
    row = sphere_gas.rows([], n_chains=400, n_steps=800, log=lambda s: None)[0]
    assert row["ci_low"] / row["d_hertz_boltzmann"] < 1.0 < row["ci_high"] / row["d_hertz_boltzmann"]
    # and it is not the hard-sphere gas: softness is resolved at this stiffness
    assert row["ci_low"] > row["d_hard_boltzmann"]
    assert row["dlnD_dlnE"] < -0.01
    # the ratio's interval carries the theory's Monte Carlo error too: wider than the runs' alone
    ref = row["d_hertz_boltzmann"]
    assert row["ratio_hertz_ci_low"] < row["ci_low"] / ref and row["ratio_hertz_ci_high"] > row["ci_high"] / ref
    # the first version ran at dt factor 0.5: the step moves D by -6e-5 (kinetic.timestep_shift)
    assert row["dt"] == pytest.approx(3.558e-4, rel=1e-3)
    assert -1e-4 < row["dt_effect"] < -3e-5
    # ... and it is the leapfrog collision map's shift for this row's own gas and step (wiring pinned)
    from studies import kinetic as K
    kn = K.hertz_kn(row["youngs_modulus"], row["poisson"], row["diameter"] / 2, row["diameter"] / 2)
    assert row["dt_effect"] == pytest.approx(K.timestep_shift(row["kT"], row["mass"] / 2, row["diameter"], kn, row["dt"]),
                                             rel=1e-9)
    committed = sphere_gas.read()
    assert committed and math.isclose(committed[0]["d_hertz_boltzmann"], row["d_hertz_boltzmann"], rel_tol=0.015)


def test_effect_figures_from_tables_only(tmp_path):
    """Every figure is drawn from the CSV tables alone, and only when they hold rows for it."""
    from studies import effects_plots
    cols = "shape,overlap,protocol,youngs_modulus,case,n_pairs,relative,relative_ci_low,relative_ci_high,mass_error,k2_error,yade_version,rot_algorithm\n"
    rows = ["dimer,0.5,paired,1e7,uncorrected,4,-0.01,-0.03,0.01,0.185,-0.105,2023.02a,isotropic",
            "dimer,0.5,paired,1e7,mass_only,4,0.004,-0.01,0.02,0.185,-0.105,2023.02a,isotropic",
            "dimer,0.5,paired,1e8,mass_only,1,0.002,,,0.185,-0.105,2023.02a,isotropic",
            "dimer,0.5,equal_energy,1e7,uncorrected,4,-0.08,-0.1,-0.06,0.185,-0.105,2023.02a,isotropic",
            "tetrahedron,,equal_energy,1e7,uncorrected,2,-0.05,-0.09,-0.01,0.3,-0.2,2025.2,delValle2023"]
    (tmp_path / "effects.csv").write_text(cols + "\n".join(rows) + "\n")
    made = effects_plots.plot_all(str(tmp_path), log=lambda s: None)
    assert made == ["effects.png", "decomposition.png", "protocol.png"]
    for m in made:
        assert (tmp_path / m).stat().st_size > 10_000
    (tmp_path / "effects.csv").write_text(cols)
    for m in made:
        (tmp_path / m).unlink()
    assert effects_plots.plot_all(str(tmp_path), log=lambda s: None) == []
    # the dimer's uncorrected row alone decomposes nothing; a collision map of the dimer does
    (tmp_path / "effects.csv").write_text(cols + rows[0] + "\n")
    assert effects_plots.plot_all(str(tmp_path), log=lambda s: None) == ["effects.png"]
    (tmp_path / "collision_map").mkdir()
    cmap = {"shape": {"kind": "dimer", "overlap": 0.5}, "material": {"youngs_modulus": 1e7},
            "rows": [{"case": c, "protocol": "paired", "relative": r, "se": 0.001, "mass_error": 0.0}
                     for c, r in (("uncorrected", 0.013), ("mass_only", -0.002), ("mass_scaled", 0.006))]}
    (tmp_path / "collision_map" / "case_map.json").write_text(json.dumps(cmap))
    assert effects_plots.plot_all(str(tmp_path), log=lambda s: None) == ["effects.png", "decomposition.png"]


def test_equal_energy_answer_states_the_mass_scaling_prediction():
    """The paper's dimer (overlap D = d_s/2) sums to 32/27 of its union's mass, so hard particles at
    equal energy predict D_unc/D_exact = sqrt(27/32) (closed form, not the library); the sentence
    says whether the interval holds it, and other protocols and cases get none."""
    sp = S.load(S.ROOT + "/studies/specs/dimer_equal_energy.toml")
    g = sp["groups"][0]
    pred = math.sqrt(27.0 / 32.0) - 1.0
    inside = report._mass_scaling(sp, g, {"case": "uncorrected", "n": 5, "mean": -0.07, "halfwidth": 0.02})
    outside = report._mass_scaling(sp, g, {"case": "uncorrected", "n": 5, "mean": -0.02, "halfwidth": 0.02})
    assert f"{100 * pred:+.2f} %" in inside and inside.endswith("inside the interval.")
    assert outside.endswith("**outside** the interval.")
    assert report._mass_scaling(sp, g, {"case": "mass_only", "n": 5, "mean": 0.0, "halfwidth": 0.01}) == ""
    assert report._mass_scaling(sp, dict(g, protocol="paired"), {"case": "uncorrected", "n": 5, "mean": 0.0,
                                                                  "halfwidth": 0.01}) == ""


def test_collision_map_predictions_come_from_their_files(results_copy):
    """A collision-map file under results/collision_map/ gives a table row per case and, for the
    paper's dimer, the split of the paired effect into softness (mass_scaled) and the k² rest."""
    import json

    d = results_copy / "collision_map"
    shutil.rmtree(d, ignore_errors=True)
    d.mkdir()
    rows = [{"case": "uncorrected", "protocol": "paired", "relative": 0.0123, "se": 0.001, "hard_particles": 0.0,
             "mass_error": 0.185, "iperp_over_m_error": -0.119, "minus_mass_scaled": 0.0045,
             "minus_mass_scaled_se": 0.0008},
            {"case": "mass_scaled", "protocol": "paired", "relative": 0.0078, "se": 0.0005, "hard_particles": 0.0,
             "mass_error": 0.185, "iperp_over_m_error": 0.0},
            {"case": "uncorrected", "protocol": "equal_energy", "relative": -0.0801, "se": 0.002,
             "hard_particles": -0.0814, "mass_error": 0.185, "iperp_over_m_error": -0.119}]
    for e_mod, scale in ((1e7, 1.0), (1e9, 0.1)):
        rr = [dict(r, relative=r["relative"] * scale) if r["case"] == "mass_scaled" else r for r in rows]
        (d / f"m{e_mod:g}.json").write_text(json.dumps({
            "shape": {"kind": "dimer", "sphere_diameter": 0.1333, "overlap": 0.5}, "pairs_used": 1234,
            "material": {"density": 1140.0, "youngs_modulus": e_mod, "poisson": 0.4}, "rows": rr}))
    text = report.build()
    assert "uncorrected vs exact, paired, +1.23 % ± 0.20 %" in text
    assert "+0.78 % ± 0.10 %, and the wrong k² the rest, +0.45 % ± 0.16 %" in text
    assert "+0.78 % ± 0.10 % at E = 1e+07 Pa, +0.08 % ± 0.10 % at E = 1e+09 Pa" in text
    # equal energy: softness drops out at one kT, so hard particles x (1 + k² part): 0.9186 x 1.0045 - 1
    assert ("At equal energy -8.01 % ± 0.39 %: the hard-particle mass scaling -8.14 % times one plus the k² part, "
            "-7.73 %") in text
    # ... and the plain words give the largest gap over the maps: |-8.01 - (-7.73)| = 0.28 % of D
    assert ("in each of the 2 collision maps with an equal-energy row the equal-energy ratio is the hard-particle "
            "scaling times one plus the paired k² part to 0.28 % of D") in text
    assert "| dimer | 0.5 | 1e+07 | uncorrected | equal_energy | +18.5 % | -11.9 % | -8.01 % ± 0.39 % | -8.14 % |" in text
    # another shape: its own bullet (paired and equal energy), never labelled as the paper's dimer
    tet = [dict(r, relative=r["relative"] * 2, mass_error=0.5) for r in rows if r["case"] != "mass_scaled"]
    (d / "tet.json").write_text(json.dumps({
        "shape": {"kind": "tetrahedron", "sphere_diameter": 0.1333, "overlap": 0.5}, "pairs_used": 99,
        "material": {"density": 1140.0, "youngs_modulus": 1e7, "poisson": 0.4}, "rows": tet}))
    text = report.build()
    assert ("**Collision-map prediction, tetrahedron (D/d_s = 0.5), E = 1e+07 Pa** (99 collisions per case; "
            "`tet.json`; summed mass +50.0 %, largest moment over mass -11.9 %): uncorrected vs exact, paired, "
            "+2.46 % ± 0.20 %; equal energy -16.02 % ± 0.39 % (hard particles -8.14 %; times one plus the paired "
            "k² part: -7.73 %).") in text
    assert text.count("Collision-map prediction, the paper's dimer") == 2


def test_plain_words_for_other_shapes_from_effects_rows():
    """The shapes' bullet: every shape but the paper's dimer, paired and equal energy, with the largest
    95 % bound and the hard-particle scaling inside or outside each interval; nothing without rows."""
    def row(shape, overlap, protocol, rel, lo, hi, mass, n=9, case="uncorrected", e=1e7):
        return {"shape": shape, "overlap": overlap, "protocol": protocol, "case": case, "youngs_modulus": e,
                "n_pairs": n, "relative": rel, "relative_ci_low": lo, "relative_ci_high": hi, "mass_error": mass,
                "k2_error": -0.15}
    eff = [row("dimer", 0.5, "paired", 0.0135, 0.0085, 0.0185, 0.185, n=64),            # the paper's: not here
           row("tetrahedron", 0.5, "paired", 0.0172, 0.0017, 0.0328, 0.501),
           row("dimer", 0.25, "paired", 0.0295, 0.0183, 0.0406, 0.463, n=7),
           row("tetrahedron", 0.5, "equal_energy", -0.1643, -0.1740, -0.1545, 0.501),   # hard -18.36 %: outside
           row("trimer_triangle", 0.5, "equal_energy", -0.1338, -0.1475, -0.1201, 0.35),  # hard -13.93 %: inside
           row("tetrahedron", 0.5, "paired", 0.5, 0.4, 0.6, 0.501, e=1e9),               # another E: not here
           row("tetrahedron", 0.5, "paired", 0.5, 0.4, 0.6, 0.501, case="mass_only")]     # another case: not here
    (text,) = report._other_shapes_words(eff)
    assert ("+2.95 % [+1.83, +4.06] % (dimer D/d_s = 0.25, mass +46.3 %, k² -15.0 %), +1.72 % [+0.17, +3.28] % "
            "(tetrahedron, mass +50.1 %, k² -15.0 %) (7-9 seed pairs): for every shape at most 4.1 % of D") in text
    assert "(tetrahedron; hard particles -18.38 %, outside)" in text                # 1.501^-1/2 - 1
    assert "(trimer_triangle; hard particles -13.93 %, inside)" in text
    assert "(9 seed pairs each): the hard-particle mass scaling sqrt(m_exact/m_summed) is inside 1 of 2" in text
    assert "the measured effects are 96 %, 89 % of it (point estimates" in text       # trimer, tetrahedron
    assert "+50.0" not in text and "dimer D/d_s = 0.5" not in text
    assert report._other_shapes_words(eff[:1]) == [] and report._other_shapes_words([]) == []


def test_plain_words_for_the_hard_particle_limit_from_mass_only_rows_at_other_stiffnesses():
    """The stiffness bullet: the paper's dimer's mass_only rows at E other than 1e7 Pa with two or
    more pairs, in order of E, each with its verdict and its own map's mass_only prediction; the
    maps' mass_scaled (softness) parts after; nothing for 1e7, one pair, another shape or case."""
    def row(e, rel, lo, hi, n=12, case="mass_only", shape="dimer", overlap=0.5):
        return {"shape": shape, "overlap": overlap, "protocol": "paired", "case": case, "youngs_modulus": e,
                "n_pairs": n, "relative": rel, "relative_ci_low": lo, "relative_ci_high": hi}

    def cmap(e, mass_only, soft):
        return {"shape": {"kind": "dimer", "sphere_diameter": 0.1333, "overlap": 0.5}, "material": {"youngs_modulus": e},
                "rows": [{"case": "mass_only", "protocol": "paired", "relative": mass_only, "se": 0.0005},
                         {"case": "mass_scaled", "protocol": "paired", "relative": soft, "se": 0.0001}]}
    eff = [row(1e9, -0.004, -0.0135, 0.0055, n=14), row(1e8, 0.012, 0.002, 0.022),
           row(1e7, 0.0009, -0.0091, 0.0108),                  # the 1e7 answer has its own bullet
           row(3e8, 0.1, 0.0, 0.2, n=1),                       # one pair: no interval
           row(1e8, 0.5, 0.4, 0.6, case="uncorrected"), row(1e8, 0.5, 0.4, 0.6, overlap=0.25)]
    maps = [cmap(1e8, -0.0030, 0.0028), cmap(1e9, -0.0031, 0.0012), cmap(1e7, -0.0022, 0.0065)]
    (text,) = report._stiffness_words(eff, maps)
    assert text.startswith("* **The hard-particle limit (gas, the paper's dimer, mass corrected alone, same velocities):** "
                           "+1.20 % [+0.20, +2.20] % at E = 1e+08 Pa (12 seed pairs; larger than exact, resolved; "
                           "collision map -0.30 % ± 0.10 %), -0.40 % [-1.35, +0.55] % at E = 1e+09 Pa (14 seed pairs; "
                           "no effect resolved: |effect| < 1.35 % at 95 %; collision map -0.31 % ± 0.10 %).")
    assert "is +0.65 % at E = 1e+07 Pa, +0.28 % at E = 1e+08 Pa, +0.12 % at E = 1e+09 Pa in the collision maps" in text
    assert "3e+08" not in text and "+50" not in text
    assert report._stiffness_words(eff[2:], maps) == [] and report._stiffness_words([], maps) == []
    (bare,) = report._stiffness_words(eff[:1], [])                   # no maps: no map clauses
    assert "collision map" not in bare and "mass_scaled" not in bare
    assert bare in "\n".join(report.plain_words(eff[:1], [], None))


def test_plain_words_from_the_tables_maps_and_share():
    """The three plain answers carry the table's, the maps' and the share's numbers; the k² verdict
    follows the largest mapped k² part; nothing to say without data."""
    eff = [{"shape": "dimer", "overlap": 0.5, "protocol": "paired", "case": "uncorrected", "youngs_modulus": 1e7,
            "n_pairs": 9, "relative": 0.0107, "relative_ci_low": -0.0001, "relative_ci_high": 0.0215},
           {"shape": "dimer", "overlap": 0.5, "protocol": "equal_energy", "case": "uncorrected", "youngs_modulus": 1e7,
            "n_pairs": 6, "relative": -0.0709, "relative_ci_low": -0.0937, "relative_ci_high": -0.0482}]

    def cmap(e, soft, k2, kind="dimer"):
        return {"shape": {"kind": kind, "overlap": 0.5}, "material": {"youngs_modulus": e}, "rows": [
            {"case": "uncorrected", "protocol": "paired", "relative": soft + k2, "se": 0.001,
             "iperp_over_m_error": -0.119, "minus_mass_scaled": k2, "minus_mass_scaled_se": 0.0007},
            {"case": "mass_scaled", "protocol": "paired", "relative": soft, "se": 0.0002},
            {"case": "uncorrected", "protocol": "equal_energy", "relative": -0.075, "se": 0.001,
             "hard_particles": -0.0814}]}

    maps = [cmap(1e7, 0.0065, 0.0067), cmap(1e9, 0.0012, 0.0083)]
    share = {"share": -0.028, "low": -0.056, "high": 0.0001, "n_num": 9, "n_gap": 6, "gap": -0.384}
    text = "\n".join(report.plain_words(eff, maps, share))
    assert "+1.07 % [-0.01, +2.15] % (9 seed pairs)" in text and "predicts +1.32 % ± 0.20 %: at most 2.1 % of D" in text
    assert "-7.09 % [-9.37, -4.82] % (6 seed pairs), resolved; predicted -7.50 % ± 0.20 %, hard particles -8.14 %, nearly all" in text
    assert "+0.65 % ± 0.04 % is the contact's softness" in text
    assert "(+0.12 % at E = 1e+09 Pa: it falls as the contact stiffens" in text
    assert "the largest k² part is +0.83 % ± 0.14 % (dimer, D/d_s = 0.5, E = 1e+09 Pa)" in text
    assert "in every map its size is below 0.97 % of D at 95 %: no shape shows an inertia effect as large" in text
    assert "-0.028 [-0.056, +0.000] of a gap of -38.40 %" in text and "0.10 is outside the interval" in text
    maps.append(cmap(1e7, 0.01, 0.015, kind="tetrahedron"))
    text = "\n".join(report.plain_words(eff, maps, dict(share, high=0.12)))
    assert "is +1.50 % ± 0.14 % (tetrahedron, D/d_s = 0.5, E = 1e+07 Pa)" in text
    assert "in every map its size is below 1.64 % of D at 95 %." in text
    assert "0.10 is inside the interval" in text
    # a large negative k² part is the largest; a softer map (1e6) is listed, not dropped; no fall, no claim
    maps.append(cmap(1e7, 0.01, -0.03, kind="trimer_triangle"))
    maps.append(cmap(1e6, 0.0001, 0.0067))
    text = "\n".join(report.plain_words(eff, maps, share))
    assert "is -3.00 % ± 0.14 % (trimer_triangle" in text and "below 3.14 % of D" in text
    assert "+0.01 % at E = 1e+06 Pa, +0.12 % at E = 1e+09 Pa)" in text and "falls as the contact" not in text
    # an equal-energy map row without gas rows: no empty clause
    text = "\n".join(report.plain_words([], [cmap(1e7, 0.0065, 0.0067)], None))
    assert "With the same kinetic energy for every case: predicted -7.50 %" in text and ": ;" not in text
    assert report.plain_words([], [], None) == []
    # the gas's mass/inertia decomposition joins the "which part" answer, with or without maps
    dec = [dict(eff[0], case="mass_only", n_pairs=12, relative=0.0025, relative_ci_low=-0.0113, relative_ci_high=0.0164),
           dict(eff[0], case="inertia_only", n_pairs=7, relative=0.0168, relative_ci_low=0.0073, relative_ci_high=0.0262),
           dict(eff[0], case="inertia_only", n_pairs=1, youngs_modulus=1e9)]           # one pair: no interval, left out
    text = "\n".join(report.plain_words(eff + dec, maps, share))
    which = next(ln for ln in text.splitlines() if ln.startswith("* **Through which part?**"))
    assert "the contact's softness" in which and which.endswith(
        "with the mass corrected alone (mass_only: exact m, summed I): +0.25 % [-1.13, +1.64] % (12 seed pairs), no effect "
        "resolved: |effect| < 1.64 % at 95 %; with the inertia corrected alone (inertia_only: summed m, exact I): "
        "+1.68 % [+0.73, +2.62] % (7 seed pairs), larger than exact, resolved.")
    alone = report.plain_words(dec[1:], [], None)
    assert alone[2].startswith("* **Through which part?** In the gas") and "mass_only" not in alone[2]


def test_effect_figure_tells_dimer_overlaps_apart(tmp_path, monkeypatch):
    """Dimers at two overlaps are two legend entries with two markers, not one merged series."""
    from studies import effects_plots
    cols = "shape,overlap,protocol,youngs_modulus,case,n_pairs,relative,relative_ci_low,relative_ci_high,mass_error,k2_error,yade_version,rot_algorithm\n"
    rows = ["dimer,0.25,equal_energy,1e7,uncorrected,3,-0.17,-0.24,-0.10,0.463,-0.127,2025.2,isotropic",
            "dimer,0.5,equal_energy,1e7,uncorrected,6,-0.07,-0.09,-0.05,0.185,-0.105,2023.02a,isotropic"]
    (tmp_path / "effects.csv").write_text(cols + "\n".join(rows) + "\n")
    saved = {}
    real_save = effects_plots._save

    def spy(fig, results, name):
        ax = fig.axes[0]
        leg = ax.get_legend() or fig.legends[0]          # effects.png: one legend below both panels
        saved[name] = ([t.get_text() for t in leg.get_texts()],
                       [c.lines[0].get_marker() for c in ax.containers])
        return real_save(fig, results, name)

    monkeypatch.setattr(effects_plots, "_save", spy)
    assert effects_plots.plot_all(str(tmp_path), log=lambda s: None)[0] == "effects.png"
    labels, markers = saved["effects.png"]
    assert "dimer D/d_s = 0.25, uncorrected, equal_energy" in labels
    assert "dimer D/d_s = 0.5, uncorrected, equal_energy" in labels
    assert len(set(markers)) == 2


def test_a_study_not_started_is_stated_with_its_budget(tmp_path):
    """A sequential spec without a results directory (the stiffness series before its first run) is
    a question of the report too: each group says it has no pairs and that nothing is spent, with
    the budget, and groups that differ only in Young's modulus are told apart (before: the spec was
    left out of both sections)."""
    sp = S.load(S.ROOT + "/studies/specs/stiffness.toml")
    sp["study"]["results"] = str(tmp_path / "nowhere")
    rows = report._status_rows(report.planned([sp]))
    assert len(rows) == 2 and all(st["n"] == 0 and cpu == 0 and st["state"] == "not started" for _, _, st, cpu in rows)
    from studies import design
    assert design.describe(1, rows[1][1], rows[1][2]).startswith(
        "group 1 (dimer at E = 1e+09 Pa: mass_only vs exact, paired): not started; 0 pairs")
    a = [report._answer(*r) for r in rows]
    assert a[0].startswith("* **dimer at E = 1e+08 Pa, mass_only vs exact (paired protocol, `stiffness`):** 0 seed pair(s)")
    assert a[1].startswith("* **dimer at E = 1e+09 Pa, mass_only vs exact")
    assert all(f"not started ({sp['study']['budget_cpu_hours']:g} CPU-hours budgeted)." in x for x in a)
    lines = []
    report.programme_section(lines, report.planned([sp]))
    text = "\n".join(lines)
    assert "### `stiffness`" in text and f"not started; budget {sp['study']['budget_cpu_hours']:g} CPU-hours." in text
    assert "| dimer at E = 1e+08 Pa, mass_only vs exact, paired | 0 | n/a | n/a | 1.00 % | not started |" in text
    assert not (tmp_path / "nowhere").exists()          # the report reads; it creates nothing


def test_answers_are_checked_against_the_collision_map_of_their_gas():
    """An answer is compared with the collision map of the same shape, density, stiffness and energy
    (and only that one): inside its interval, outside with overlapping intervals, or outside."""
    sp = S.load(S.ROOT + "/studies/specs/dimer_equal_energy.toml")
    g = sp["groups"][0]
    m = {"file": "m.json", "shape": dict(sp["shapes"][g["shape"]]), "material": dict(sp["material"]),
         "energy_per_particle": sp["gas"]["energy_per_particle"],
         "rows": [{"case": "uncorrected", "protocol": "equal_energy", "relative": -0.075, "se": 0.001}]}
    st = {"case": "uncorrected", "n": 6}
    assert report._map_check(sp, g, dict(st, mean=-0.07, halfwidth=0.02), [m]).endswith(
        "predicts -7.50 % ± 0.20 %: inside the interval.")
    assert report._map_check(sp, g, dict(st, mean=-0.05, halfwidth=0.024), [m]).endswith(
        "outside the interval, but the two intervals overlap.")
    assert report._map_check(sp, g, dict(st, mean=-0.02, halfwidth=0.02), [m]).endswith(
        "**outside** the interval, and the two intervals do not overlap.")
    assert report._map_check(sp, g, dict(st, n=1, mean=-0.02, halfwidth=float("nan")), [m]).endswith("± 0.20 %.")
    stiffer = dict(m, material=dict(m["material"], youngs_modulus=1e9))
    other = dict(m, shape=dict(m["shape"], overlap=0.25))
    for wrong in (stiffer, other):
        assert report._map_check(sp, g, dict(st, mean=-0.07, halfwidth=0.02), [wrong]) == ""
    assert report._map_check(sp, dict(g, protocol="paired"), dict(st, mean=-0.07, halfwidth=0.02), [m]) == ""


def test_answer_says_whether_the_target_is_met_reached_or_not_yet():
    """Met (the group finished), reached while the group's listed seeds still run, or not yet with
    the projection."""
    sp = S.load(S.ROOT + "/studies/specs/dimer_paired.toml")
    g = sp["groups"][2]
    st = {"case": "inertia_only", "n": 12, "mean": 0.0169, "halfwidth": 0.0073, "target": 0.01, "met": True,
          "state": "running", "n_needed": 12}
    assert "Target ±1.00 % reached (half-width 0.73 % after 18.2 CPU-hours for the whole spec); the seeds the group " \
           "lists are still running (state: running)." in report._answer(sp, g, st, 18.2)
    assert "Target half-width ±1.00 % met." in report._answer(sp, g, dict(st, state="target met"), 18.2)
    no = report._answer(sp, g, dict(st, met=False, halfwidth=0.0138, n_needed=21, cpu_hours_to_target=2.0), 18.2)
    assert "Target ±1.00 % not met yet: half-width 1.38 %" in no and "projects 21 pairs, about 2 CPU-hours more" in no
    # within the target before the design's minimum sample (sequential_status's min_n): says so, not "not met"
    few = report._answer(sp, g, dict(st, n=5, met=False, halfwidth=0.0095, n_needed=12, min_n=12), 18.2)
    assert "Half-width 0.95 % already within the target ±1.00 %, but the design stops no earlier than 12 pairs" in few
    assert "7 more (state: running)" in few and "not met yet" not in few
    from studies import design
    line = design.describe(2, g, dict(st, n=5, met=False, halfwidth=0.0095, n_needed=12, min_n=12, cpu_hours=18.2,
                                      budget_cpu_hours=30.0))
    assert "within the target but short of the design's minimum of 12 pairs" in line and "projected" not in line


def test_gas_against_map_says_apart_only_when_the_intervals_do_not_meet():
    """The rate tables' verdict: the gas's 95 % interval against the map's value ± 1.96 SE (map 10 ± 0.98
    here), decided at the interval ends, and no verdict from one seed."""
    num, ival = (lambda x: f"{x:.2f}"), (lambda lo, hi: f"[{lo:.2f}, {hi:.2f}]")
    assert report._gas_against_map(5, 11.5, 11.0, 12.0, 10.0, 0.5, num, ival) == ("11.50 [11.00, 12.00]", "**apart**")
    assert report._gas_against_map(5, 11.5, 10.97, 12.0, 10.0, 0.5, num, ival)[1] == "overlap"
    assert report._gas_against_map(5, 8.5, 8.0, 9.03, 10.0, 0.5, num, ival)[1] == "overlap"
    assert report._gas_against_map(5, 8.5, 8.0, 9.01, 10.0, 0.5, num, ival)[1] == "**apart**"
    assert report._gas_against_map(1, 8.5, float("nan"), float("nan"), 10.0, 0.5, num, ival) == ("8.50", "")


def test_cpu_hours_more_reads_as_english():
    assert report._cpu_hours_more(11.4) == "about 11 CPU-hours more"
    assert report._cpu_hours_more(1.2) == "about 1 CPU-hour more"
    assert report._cpu_hours_more(0.2) == "under half a CPU-hour more"
    assert report._cpu_hours_more(0.5) == "about 1 CPU-hour more" and report._cpu_hours_more(2.5) == "about 3 CPU-hours more"


def test_a_sphere_gas_of_one_run_gets_no_verdict():
    """One run (the first of a new stiffness) has no interval: the report says so, never "not
    consistent" from a NaN interval (before: it said **not consistent** with "n/a" bounds), and the
    table shows n/a, not "[nan, nan]"."""
    rows = sphere_gas.read(S.ROOT + "/results/sphere_gas.csv")
    one = dict(rows[-1], n_runs=1.0, ci_low=float("nan"), ci_high=float("nan"),
               **{f"ratio_{k}_ci_{e}": float("nan") for k in ("hertz", "hard") for e in ("low", "high")})
    lines = []
    report.answers_section(lines, [], [one])
    text = "\n".join(lines)
    assert "(one run so far: no interval, no verdict)" in text and "not consistent" not in text
    lines = []
    report.sphere_gas_section(lines, [one])
    table = "\n".join(lines)
    assert "| 1 | " in table and "nan" not in table.lower().replace("n/a", "")


def test_sphere_gas_cli_for_a_diagnostic_spec_refuses_without_runs(tmp_path, capsys):
    """`python -m studies.sphere_gas --spec SPEC`: a missing spec exits 2, a spec without finished
    sphere runs exits 1 and writes nothing."""
    with pytest.raises(SystemExit) as e:
        sphere_gas.main(["--spec", str(tmp_path / "nope.toml")])
    assert e.value.code == 2 and "no such spec file" in capsys.readouterr().err
    spec = (S.ROOT + "/studies/specs/sphere_gas_size.toml")
    text = open(spec).read().replace('results = "results/sphere_gas_size"', f'results = "{tmp_path}/empty"')
    (tmp_path / "s.toml").write_text(text)
    out = tmp_path / "table.csv"
    with pytest.raises(SystemExit) as e:
        sphere_gas.main(["--spec", str(tmp_path / "s.toml"), "--out", str(out)])
    assert e.value.code == 1 and "nothing written" in capsys.readouterr().err
    assert not out.exists()


def _md_entry(n, rel_enskog, se, runs=100, gk_bias=-0.002, gk_se=0.0007):
    chi = 1.005
    rel_b = (1 + rel_enskog) / chi - 1
    gk = (1 + rel_enskog) * (1 + gk_bias) - 1
    return dict(n=n, rho_sigma3=0.00382, number_density=0.4778, n_runs=runs, enskog_rel=1 / chi - 1,
                d_exact_rel_boltzmann=rel_b, d_exact_rel_boltzmann_se=se, d_exact_rel_enskog=rel_enskog,
                d_exact_rel_enskog_se=se, d_gk_rel_boltzmann=(1 + gk) / chi - 1, d_gk_rel_boltzmann_se=se / 2,
                d_gk_rel_enskog=gk, d_gk_rel_enskog_se=se / 2, gk_minus_exact=gk_bias, gk_minus_exact_se=gk_se,
                rate_rel_enskog=1e-4, rate_rel_enskog_se=4e-4)


def test_hard_sphere_md_section_reads_its_file_and_judges_by_the_standard_error():
    sphere = dict(n_particles=864.0, number_density=0.4778, n_runs=15.0, ratio_hertz=0.9957, youngs_modulus=1e7,
                  source="sphere_gas (Green-Kubo)", ratio_hertz_ci_low=0.9917, ratio_hertz_ci_high=0.9997,
                  estimator="green_kubo")
    other = dict(sphere, n_particles=108.0)           # another N: against the MD entry of its own N
    ols = dict(sphere, estimator="ols_msd_125_175")   # another estimator: not "analysed the same way"
    lines = []
    report.hard_sphere_md_section(lines, [_md_entry(108, -0.004, 0.001), _md_entry(864, 0.0006, 0.0009),
                                          _md_entry(288, 0.1, 0.1, runs=1)], [sphere, other, ols])
    text = "\n".join(lines)
    assert "| 864 | 0.00382 | 100 | " in text and "| 108 |" in text and "| 288 |" not in text   # one run: left out
    assert "+0.060 % ± 0.090 % from Enskog's D_Boltzmann / chi (+0.7 standard errors" in text
    assert "not resolved at this density" in text
    assert "reads -0.200 % ± 0.070 % from the exact integral" in text and "(-2.9 standard errors; the likely cause, not proven" in text
    # the YADE gas against the hard-sphere gas analysed the same way: -0.43 % - (-0.14 %)
    gk = (1.0006 * 0.998 - 1)
    assert f"sits {100 * gk:+.2f} % from its own" in text and text.count("* The YADE sphere gas") == 2
    assert "the N-body gas of 864 leads" in text and "the N-body gas of 108 leads" in text
    se_r = 0.008 / (2 * 2.1447866879169273)
    assert f"{100 * (-0.0043 - gk):+.3f} % ± {100 * math.hypot(se_r, 0.00045):.3f} %" in text
    lines = []
    report.hard_sphere_md_section(lines, [_md_entry(864, -0.004, 0.001, gk_bias=-0.001, gk_se=0.001)])
    text = "\n".join(lines)
    assert "leave them out" in text and ": not resolved)." in text
    lines = []
    report.hard_sphere_md_section(lines, [])
    assert lines == []


def _vacf_shape(rise, rise_se, shift=0.0010, shift_se=0.0003, n=864, rel_record=True):
    rec = dict(rel_exact=-0.0019, rel_exact_se=0.0006, rel_record=0.0, rel_record_se=0.0, sd_per_run=0.0097)
    late = dict(rel_exact=0.0001, rel_exact_se=0.0006, rel_record=shift, rel_record_se=shift_se, sd_per_run=0.0110)
    if not rel_record:
        for d in (rec, late):
            del d["rel_record"], d["rel_record_se"]
    return dict(runs=200, n=n, local_decay_time=[13.98, 14.1, 14.39, 14.5], local_decay_time_se=[0.01, 0.02, 0.05, 0.1],
                rise_2_3_over_0_05=rise, rise_se=rise_se,
                variants={report.RECORD_VARIANT: rec, report.LATE_VARIANT: late})


def _md_text(vacf_shape):
    lines = []
    report.hard_sphere_md_section(lines, [_md_entry(864, 0.0006, 0.0009)], vacf_shape=vacf_shape)
    return "\n".join(lines)                           # the entry's estimator bias: -0.200 % +- 0.070 %


def test_hard_sphere_md_section_states_the_measured_cause_only_when_resolved():
    text = _md_text(_vacf_shape(0.029, 0.003, shift=0.0020, shift_se=0.0003))     # the shift matches the bias
    assert "the cause, measured (`benchmarks/vacf_shape_md.py`, 200 runs of 864)" in text
    assert "13.98 ± 0.01 s on 0-0.5 tau to 14.39 ± 0.05 s on 2-3 tau (+2.90 % ± 0.30 %)" in text
    assert "the estimator reads -0.190 % ± 0.060 % from the exact integral" in text
    assert "(2-4 tau) reads +0.200 % ± 0.030 % above the estimator (paired), at a per-run sd of 1.10 % instead of 0.97 %" in text
    assert "not proven" not in text and "short of" not in text
    # a resolved shift of a fifth of the bias (+0.04 % +- 0.01 % against -0.20 % +- 0.07 %): a contributor
    text = _md_text(_vacf_shape(0.029, 0.003, shift=0.0004, shift_se=0.0001))
    assert "a contributor, measured (`benchmarks" in text and "short of the whole bias" in text
    assert "the cause, measured" not in text
    # an older file without the paired shift: the rise and the estimator's reading only, a contributor
    text = _md_text(_vacf_shape(0.029, 0.003, rel_record=False))
    assert "a contributor, measured" in text and "from the exact integral" in text and "2-4 tau) reads" not in text
    # not resolved (2.9 standard errors, a falling time, no error, NaN), another N, or no file: still a guess
    for weak in (_vacf_shape(0.0087, 0.003), _vacf_shape(-0.029, 0.003), _vacf_shape(0.029, 0.0),
                 _vacf_shape(0.029, float("nan")), _vacf_shape(float("nan"), 0.003), _vacf_shape(0.029, 0.003, n=108),
                 None):
        text = _md_text(weak)
        assert "the likely cause, not proven" in text and "measured (`benchmarks" not in text


def test_committed_hard_sphere_md_collides_at_enskogs_rate():
    """The committed event-driven runs of the study's gas (N = 864): the collision rate of hard
    spheres is Enskog's exactly (chi the true contact value; Carnahan-Starling's is exact to
    O(phi^2) here).  Smaller N carry O(1/N) corrections to the contact value of a closed gas, so
    only the study's own N is held to it."""
    from studies import hard_sphere_md
    (e,) = [g for g in hard_sphere_md.read() if g["n"] == 864]
    assert e["n_runs"] >= 100
    assert abs(e["rate_rel_enskog"]) < 3 * e["rate_rel_enskog_se"]


def test_report_help_prints_usage_and_writes_nothing(monkeypatch, capsys):
    """`python -m studies.report --help` says what the command writes and exits 0 without building
    the report (it used to ignore its arguments and rewrite results/); an unknown option exits 2."""
    monkeypatch.setattr(report, "build", lambda: pytest.fail("--help built the report"))
    with pytest.raises(SystemExit) as e:
        report.main(["--help"])
    assert e.value.code == 0 and "results/README.md" in capsys.readouterr().out
    with pytest.raises(SystemExit) as e:
        report.main(["--bogus"])
    assert e.value.code == 2


def test_a_broken_study_is_reported_in_its_own_section_and_the_others_still_are(results_copy, monkeypatch):
    """A headline study whose spec no longer loads (here: a bad spec file) does not stop the report:
    its error has its own section, and the other studies' answers are still there."""
    import shutil as sh
    from studies import effects
    specs = results_copy.parent / "specs"
    sh.copytree(S.SPEC_DIR, specs)
    bad = specs / "shapes.toml"
    bad.write_text(bad.read_text().replace("volume_fraction = 0.001", "volume_fraction = 0.7"))
    monkeypatch.setattr(S, "SPEC_DIR", str(specs))
    assert report.main() == 1                      # reported, and said on the status
    text = (results_copy / "README.md").read_text()
    assert "## Studies not reported" in text
    assert "* `shapes`: SpecError:" in text and "cannot be placed" in text
    assert "## The answers so far" in text
    assert "uncorrected vs exact (paired protocol, `dimer_paired`)" in text
    shapes = set(pd.read_csv(results_copy / "effects.csv")["shape"])
    assert "tetrahedron" not in shapes and "dimer" in shapes          # only the broken study's rows are gone
    assert "shapes" in effects.HEADLINE


def test_gas_report_states_the_values_of_its_tables():
    """`python -m studies.gas_report`: every paired difference and every ratio of the study's CSV
    tables, in its row, and a protocol without a difference (exact) shows dashes."""
    from studies import gas_report
    out = S.ROOT + "/results/granular_gas"
    text = gas_report.report(out)
    rows = {ln.split(" | ")[0][2:] + "/" + ln.split(" | ")[1]: ln for ln in text.splitlines() if ln.count(" | ") == 8}
    for r in pd.read_csv(out + "/diff_D.csv").itertuples():
        assert (f"| {r.d_minus_d_exact:+.3f} | [{r.ci_low:+.3f}, {r.ci_high:+.3f}] | {100 * r.relative:+.2f} % "
                f"[{100 * r.relative_ci_low:+.2f}, {100 * r.relative_ci_high:+.2f}] |") in rows[f"{r.case}/{r.protocol}"]
    assert "| – | – | – |" in rows["exact/paired"]
    for r in pd.read_csv(out + "/ratio_D.csv").itertuples():
        assert f"| {r.case} | {r.n_seeds} | {r.ratio:+.3f} | [{r.ci_low:+.3f}, {r.ci_high:+.3f}] |" in text
    assert not text.endswith("\n")
