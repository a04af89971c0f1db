"""The report's cooling section (studies.report.tables.cooling_tables, cooling.md.j2) on small tables."""
import csv

import pytest

from studies import report
from studies.report import sections, tables
from studies.report.render import render


def _write(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def _effect(case, obs, rel, lo, hi, n=4):
    return {"shape": "dimer", "n_spheres": 2, "youngs_modulus": 1e8, "restitution": 0.9, "friction": 0.5,
            "protocol": "paired", "case": case, "observable": obs, "n_pairs": n, "relative": rel,
            "relative_ci_low": lo, "relative_ci_high": hi, "mass_error": 0.185, "k2_error": -0.1,
            "yade_version": "2025.2", "rot_algorithm": "delValle2023"}


def _pred(shape, case, obs, p, se, e=0.9, mu=0.5, cpu_s=10):
    return {"shape": shape, "youngs_modulus": "1e+08", "restitution": e, "friction": mu, "case": f"{case}/paired",
            "observable": obs, "predicted": p, "predicted_se": se, "cpu_s": cpu_s, "gas_relative": "", "gas_ci_low": "",
            "gas_ci_high": ""}


def test_the_predictor_record_counts_gas_intervals_that_meet_their_prediction(tmp_path):
    _write(tmp_path / "hcs_effects.csv", [_effect("uncorrected", "cooling_rate", -0.04, -0.045, -0.035),
                                          _effect("uncorrected", "diffusion", 0.03, 0.025, 0.035),
                                          _effect("mass_only", "cooling_rate", 0.0, -0.2, 0.2, n=1)])
    _write(tmp_path / "predictions.csv", [_pred("dimer", "uncorrected", "cooling_rate", -0.041, 0.002),
                                          _pred("dimer", "uncorrected", "diffusion", 0.0, 0.001),
                                          _pred("tet", "uncorrected", "diffusion", 0.01, 0.001),
                                          _pred("grain", "uncorrected", "diffusion", 0.01, 0.001, e=1, mu=0)])
    _write(tmp_path / "hcs_theory.csv", [{"observable": "cooling_rate", "restitution": 0.9, "friction": 0,
                                          "measured": 0.15, "ci_low": 0.149, "ci_high": 0.151, "theory": 0.1505,
                                          "theory_name": "Haff", "theory_accuracy": 0.003}])
    theory, clumps, record, predicted = tables.cooling_tables(str(tmp_path))
    assert theory[0]["theory_inside"] and abs(theory[0]["halfwidth"] - 0.001 / 0.15) < 1e-12
    assert (record["n"], record["overlap"], record["apart"]) == (2, 1, 1)       # one seed: no interval, not counted
    assert record["apart_rows"][0]["observable"] == "diffusion"
    assert record["targets_met"] == 2                                            # 0.5 % half-widths
    assert [p["shape"] for p in predicted] == ["tet"]                            # the elastic grain is not a cooling row
    text = render("cooling.md.j2", theory=theory, clumps=clumps, record=record, predicted=predicted)
    assert "of 2 gas intervals with a prediction, 1 overlap the prediction's 95 % band" in text
    assert '"inside": 1 of them hold the predicted value itself) and 1 do not (dimer mu = 0.5 uncorrected diffusion)' in text
    assert "-4.10 % ± 0.20 %" in text


def test_the_predictor_cost_of_a_shape_and_contact_law_is_the_sum_of_its_rows_shares(tmp_path, monkeypatch):
    _write(tmp_path / "hcs_effects.csv", [_effect("uncorrected", "cooling_rate", -0.04, -0.045, -0.035)])
    obs = ("cooling_rate", "temperature_ratio", "diffusion")
    # each row holds a third of its case's runs and of its share of exact's (predict_cooling)
    rows = [_pred("dimer", c, o, 0.01, 0.001, cpu_s=20) for c in ("uncorrected", "mass_only") for o in obs]
    rows += [_pred("grain", c, o, 0.01, 0.001, mu=mu, cpu_s=cpu) for mu, cpu in ((0.5, 70), (0, 30))
             for c in ("uncorrected", "mass_only", "inertia_only") for o in obs]
    rows.append(_pred("grain", "uncorrected", "diffusion", 0.01, 0.001, e=1, mu=0, cpu_s=9999))   # elastic: no cooling law
    _write(tmp_path / "predictions.csv", rows)
    monkeypatch.setattr(tables, "PREDICTOR_TARGET_CPU_MIN", 10.0)
    _, clumps, record, predicted = tables.cooling_tables(str(tmp_path))
    costs = [(c["shape"], c["friction"], c["n_cases"], round(c["cpu_min"], 6), c["within"]) for c in record["costs"]]
    assert costs == [("grain", 0.5, 3, 10.5, False), ("grain", 0.0, 3, 4.5, True), ("dimer", 0.5, 2, 2.0, True)]
    text = render("cooling.md.j2", theory=[], clumps=clumps, record=record, predicted=predicted)
    assert "every case together, is 2.0 to 10.5 CPU-min against a target of 10; above it: grain mu = 0.5 " \
           "(10.5 CPU-min, 3 cases)." in text


def test_the_cooling_checks_name_groups_still_relaxing_and_estimators_that_miss(tmp_path):
    relax = [{"shape": "dimer", "n_spheres": 2, "restitution": 0.9, "friction": f, "case": "exact", "n_runs": 4,
              "drift": d, "drift_ci_low": d - 0.02, "drift_ci_high": d + 0.02, "window_start": 5, "window_end": 30}
             for f, d in ((0.0, 0.01), (0.5, -0.08))]
    _write(tmp_path / "hcs_relaxation.csv", relax)
    (tmp_path / "estimator").mkdir()
    est = [{"setting": s, "observable": "temperature_ratio", "estimator": "mean", "n_seeds": 4, "n_studies": 100,
            "truth": -0.1, "truth_se": 0.001, "mean": -0.1 + b, "bias": b, "bias_se": 0.002, "sd_per_seed": 0.03,
            "mean_halfwidth": 0.04, "coverage": c, "coverage_low": c - 0.05, "coverage_high": min(c + 0.05, 1.0)}
           for s, b, c in (("rough", 0.001, 0.95), ("weakly_rough", 0.17, 0.0))]
    _write(tmp_path / "estimator" / "hcs_cooling.csv", est)
    e, moving, n = tables.cooling_checks(str(tmp_path))
    assert n == 2 and [r["friction"] for r in moving] == [0.5]
    assert [r["covers"] for r in e] == [True, False] and [r["unbiased"] for r in e] == [True, False]
    _write(tmp_path / "hcs_effects.csv", [_effect("uncorrected", "cooling_rate", -0.04, -0.045, -0.035)])
    _, clumps, _, _ = tables.cooling_tables(str(tmp_path))
    text = render("cooling.md.j2", theory=[], clumps=clumps, record=None, predicted=[], estimator=e, moving=moving,
                  n_relax=n)
    assert "In 1 of 2 groups the ratio still moves (dimer mu = 0.5 exact: -8.00 % [-10.0, -6.0] %)" in text
    assert "| weakly_rough | temperature_ratio | mean | -10.00 ± 0.10 % | +17.00 ± 0.20 % |" in text and "(not 95 %)" in text


def test_the_flow_check_names_groups_whose_velocity_field_grows_and_skips_runs_without_it(tmp_path):
    base = {"shape": "dimer", "n_spheres": 2, "restitution": 0.9, "case": "exact", "n_runs": 4, "drift": 0.0,
            "drift_ci_low": -0.02, "drift_ci_high": 0.02, "window_start": 5, "window_end": 30}
    relax = [dict(base, friction=f, flow_runs=k, flow_ratio=fr, flow_growth=g, flow_growth_ci_low=g - 0.03,
                  flow_growth_ci_high=g + 0.03)
             for f, k, fr, g in ((0.0, 4, 1.02, 0.0), (0.5, 4, 1.9, 0.4), (0.25, 0, float("nan"), float("nan")))]
    _write(tmp_path / "hcs_relaxation.csv", relax)
    checked, growing = tables.cooling_flow(str(tmp_path))
    assert [r["friction"] for r in checked] == [0.0, 0.5] and [r["friction"] for r in growing] == [0.5]
    e, moving, n = tables.cooling_checks(str(tmp_path))
    _write(tmp_path / "hcs_effects.csv", [_effect("uncorrected", "cooling_rate", -0.04, -0.045, -0.035)])
    _, clumps, _, _ = tables.cooling_tables(str(tmp_path))
    text = render("cooling.md.j2", theory=[], clumps=clumps, record=None, predicted=[], estimator=e, moving=moving,
                  n_relax=n, flow=(checked, growing))
    assert "over the 8 runs whose raw frames gave it" in text and "between 1.02 and 1.90 in the 2 groups" in text
    assert "It grows in 1 of them (dimer mu = 0.5 exact: +40.00 % [+37.0, +43.0] %)" in text
    calm = render("cooling.md.j2", theory=[], clumps=clumps, record=None, predicted=[], estimator=e, moving=moving,
                  n_relax=n, flow=(checked[:1], []))
    assert "no growth of the flow field is detected within the analysed windows" in calm and "(up to +3 %)" in calm


def test_the_window_check_names_effects_that_move_with_the_window_start(tmp_path):
    rows = [{"shape": "tetrahedron", "n_spheres": 4, "restitution": 0.9, "friction": 0.5, "case": "uncorrected",
             "observable": o, "n_pairs": 8, "shift": sh, "shift_ci_low": sh - 0.01, "shift_ci_high": sh + 0.01,
             "window_start": 5, "later_start": ls, "drop": 0.25} for o, sh, ls in (("cooling_rate", -0.02, 13.0),
                                                                     ("diffusion", 0.005, 12.0))]
    _write(tmp_path / "hcs_window.csv", rows)
    every, moving = tables.cooling_window(str(tmp_path))
    assert len(every) == 2 and [r["observable"] for r in moving] == ["cooling_rate"]
    _write(tmp_path / "hcs_effects.csv", [_effect("uncorrected", "cooling_rate", -0.04, -0.045, -0.035)])
    _, clumps, _, _ = tables.cooling_tables(str(tmp_path))
    text = render("cooling.md.j2", theory=[], clumps=clumps, record=None, predicted=[], window=(every, moving))
    assert "leaves out the first 25 % of every seed's window" in text and "on average, 12.0-13.0 s" in text
    assert "In 1 of 2 rows the shift's interval excludes 0 (tetrahedron mu = 0.5 uncorrected cooling_rate: " \
           "-2.00 pp [-3.00, -1.00])" in text
    calm = render("cooling.md.j2", theory=[], clumps=clumps, record=None, predicted=[], window=(every, []))
    assert "In none of its 2 rows does the shift's interval exclude 0." in calm


def test_the_maxwellian_check_marks_differences_beyond_twice_their_error(tmp_path):
    (tmp_path / "estimator").mkdir()
    rows = [{"setting": "rough", "observable": o, "truth": t, "truth_se": 0.001, "maxwellian": m, "maxwellian_se": 0.0002,
             "difference": m - t, "difference_se": 0.00102}
            for o, t, m in (("cooling_rate", -0.0174, -0.0180), ("temperature_ratio", -0.1053, -0.1017))]
    _write(tmp_path / "estimator" / "hcs_maxwellian.csv", rows)
    mx = tables.cooling_maxwellian(str(tmp_path))
    assert [r["agrees"] for r in mx] == [True, False]
    text = render("cooling.md.j2", theory=[], clumps=[], record=None, predicted=[], maxwellian=mx)
    assert "| rough | temperature_ratio | -10.53 ± 0.10 % | -10.17 ± 0.02 % | +0.36 ± 0.10 % (more than twice its error) |" in text
    assert "| rough | cooling_rate | -1.74 ± 0.10 % | -1.80 ± 0.02 % | -0.06 ± 0.10 % |" in text
    assert "no relative effect by more than 0.36 percentage points" in text
    assert tables.cooling_maxwellian(str(tmp_path / "none")) == []


def test_the_settling_paragraph_names_effects_that_still_move_after_the_transient(tmp_path):
    def row(study, case, s_low, rel, change=None, obs="temperature_ratio", mu=0.5, ref=0.4):
        return {"study": study, "shape": "tetrahedron", "n_spheres": 4, "restitution": 0.9, "friction": mu,
                "cooling_stop": 16, "case": case, "observable": obs, "s_low": s_low, "s_high": s_low + 0.2,
                "t_low": 12 * s_low, "n_pairs": 6, "relative": rel, "relative_ci_low": rel - 0.01,
                "relative_ci_high": rel + 0.01, "reference_s": ref,
                "change": change, "change_ci_low": None if change is None else change - 0.015,
                "change_ci_high": None if change is None else change + 0.015, "change_pairs": None if change is None else 5}
    rows = ([row("hcs_clumps", "uncorrected", s, r, c) for s, r, c in ((0.0, -0.01, None), (0.2, -0.03, None),
                                                                        (0.4, -0.04, None), (0.6, -0.05, -0.01),
                                                                        (0.8, -0.07, -0.03))]
            + [row("hcs_clumps", "mass_only", s, 0.05, c) for s, c in ((0.2, None), (0.4, None), (0.6, 0.002))]
            + [row("hcs_clumps", "uncorrected", s, 0.5, c, obs="cooling_rate") for s, c in ((0.4, None), (0.6, 0.1))]
            + [row("hcs_clumps", "uncorrected", s, 0.5, c, mu=0.0) for s, c in ((0.4, None), (0.6, 0.1))]
            + [row("hcs_settling", "uncorrected", s, -0.05, None, ref=None) for s in (0.2, 0.4)])
    _write(tmp_path / "hcs_settling.csv", rows)
    _write(tmp_path / "predictions.csv", [_pred("tetrahedron", "uncorrected", "temperature_ratio", -0.054, 0.009)])
    got = tables.cooling_settling(str(tmp_path))
    # the smooth gas, the cooling rate and a study with no change past its reference are left out
    assert [(r["study"], r["case"], r["moved"]) for r in got] == [("hcs_clumps", "mass_only", False),
                                                                   ("hcs_clumps", "uncorrected", True)]
    unc = got[1]
    assert (unc["early"]["s_low"], unc["late"]["s_low"], unc["predicted"]) == (0.4, 0.8, -0.054)
    assert got[0]["predicted"] is None and abs(got[0]["bound"] - 0.017) < 1e-12
    _write(tmp_path / "hcs_effects.csv", [_effect("uncorrected", "cooling_rate", -0.04, -0.045, -0.035)])
    _, clumps, _, _ = tables.cooling_tables(str(tmp_path))
    text = render("cooling.md.j2", theory=[], clumps=clumps, record=None, predicted=[], settling=got)
    assert ("hcs_clumps tetrahedron uncorrected from -4.0 % (s 0.4-0.6) to -7.0 % (s 0.8-1.0), a change of "
            "-3.0 pp [-4.5, -1.5] over 5 seeds (predicted -5.4 %)") in text
    assert "In 1 of 2 the change's interval excludes 0 (hcs_clumps tetrahedron uncorrected)" in text
    assert "over the runs of `hcs_clumps`." in text and "hcs_settling.png" in text
    calm = render("cooling.md.j2", theory=[], clumps=clumps, record=None, predicted=[], settling=got[:1])
    assert "In none of them does the change's interval exclude 0; changes up to about ±2 pp are not excluded." in calm


def test_the_cooling_answer_resolves_an_effect_only_where_its_interval_excludes_zero(tmp_path):
    _write(tmp_path / "hcs_effects.csv", [_effect("uncorrected", "cooling_rate", -0.04, -0.045, -0.035),
                                          _effect("uncorrected", "temperature_ratio", 0.01, -0.01, 0.03),
                                          _effect("uncorrected", "diffusion", 0.08, 0.02, 0.14, n=3),
                                          _effect("mass_only", "cooling_rate", -0.2, -0.3, -0.1),
                                          dict(_effect("uncorrected", "cooling_rate", 0.02, -0.2, 0.2, n=1),
                                               shape="grain"),
                                          # another protocol is another question: not in the paired answer
                                          dict(_effect("uncorrected", "cooling_rate", 0.5, 0.4, 0.6),
                                               protocol="equal_energy")])
    _write(tmp_path / "predictions.csv", [_pred("dimer", "uncorrected", "cooling_rate", -0.041, 0.002)])
    _, clumps, record, predicted = tables.cooling_tables(str(tmp_path))
    answer = tables.cooling_answer(clumps)
    dimer, grain = answer["rows"]
    assert (dimer["shape"], dimer["n_pairs"], grain["n_pairs"]) == ("dimer", 3, 1)
    assert [dimer["effects"][o]["resolved"] for o in ("cooling_rate", "temperature_ratio", "diffusion")] == \
        [True, False, True]
    assert grain["effects"]["cooling_rate"]["resolved"] is None                  # one pair: no interval
    # mass_only's -20 % is not the uncorrected case's: the largest resolved effect is the dimer's D0
    assert (answer["n"], answer["resolved"], answer["top"]["observable"]) == (3, 2, "diffusion")
    assert (answer["smallest"], answer["largest"]) == (0.04, 0.08)
    text = render("cooling.md.j2", theory=[], clumps=clumps, record=record, predicted=predicted, answer=answer)
    assert "| dimer | 0.9 | 0.5 | 3 | **-4.0 %** [-4.5, -3.5] | not resolved (\\|effect\\| < 3.0 %) | **+8.0 %** [+2.0, +14.0] |" \
        in text
    assert "| grain | 0.9 | 0.5 | 1 | n/a | n/a | n/a |" in text
    assert "2 of these 3 effects are resolved, from 4.0 % to 8.0 % in size." in text
    assert "| -4.10 % ± 0.20 % | inside |" in text                               # the gas interval holds it
    words = "\n".join(report.plain_words([], [], None, answer))
    assert "2 of the 3 effects of summing the member spheres" in words
    assert "the largest is the rough dimer's self-diffusion, +8.0 % [+2.0, +14.0] %." in words
    assert report.plain_words([], [], None, tables.cooling_answer([])) == []      # nothing to say


def test_the_campaign_table_states_each_sequential_groups_target_and_projection():
    campaign = tables.cooling_campaign()                       # the committed hcs_clumps records
    assert campaign["path"] == "studies/specs/hcs_clumps.toml" and campaign["budget"] == 32
    assert 0 < campaign["cpu_hours"] <= campaign["budget"]
    targets = {(g["label"], g["shape"]): (g["case"], g["observable"]) for g in campaign["groups"]}
    assert targets[("rough", "dimer")] == ("uncorrected", "temperature_ratio")
    assert targets[("grain_rough", "ellipsoid20")] == ("uncorrected", "diffusion")
    g = dict(campaign["groups"][0], label="smooth", shape="dimer", case="uncorrected", observable="cooling_rate",
             n=12, mean=-0.0515, halfwidth=0.0089, target=0.01, state="target met", n_needed=12,
             cpu_hours_to_target=None)
    row = dict(_effect("uncorrected", "cooling_rate", -0.04, -0.045, -0.035), halfwidth=0.005, target=0.01,
               predicted=None, predicted_se=None)
    text = render("cooling.md.j2", theory=[], clumps=[row], record=None, predicted=[],
                  campaign=dict(campaign, groups=[g], cpu_hours=11.04))
    assert "The campaign (`studies/specs/hcs_clumps.toml`): 11.0 CPU-hours of a budget of 32." in text
    assert "| smooth | dimer | uncorrected, cooling_rate | 12 | -5.15 % | 0.89 % | 1.00 % | target met | 12 | n/a |" in text
    assert tables.cooling_campaign("no_such_spec") is None


def test_the_laws_words_quote_the_mass_term_at_a_stiffness_its_points_ran_at():
    def row(e):
        return dict(observable="cooling_rate", restitution=e, friction=0.0, coef_k2=-0.2, coef_k2_se=0.01,
                    coef_mass=-0.8, coef_mass_se=0.05, n_points=9, rms_residual=0.01, chi2_dof=1.0, n_checks=2,
                    n_checks_inside=2)
    fits = {("cooling_rate", 0.9, 0.0): (None, [{"youngs_modulus": 1e8}, {"youngs_modulus": 1e8}]),
            ("cooling_rate", 1.0, 0.0): (None, [{"youngs_modulus": E} for E in (1e9, 1e7, 1e8)])}
    # softness (E / 1e7 Pa)^(-2/5): 10^(-0.4) = 0.3981 at 1e8 Pa, so -0.8 x 10 % x 0.3981 = -3.18 %
    words = sections.law_words([row(0.9), row(1.0)], fits)
    assert (words[0]["mass_at"], words[0]["stiffnesses"], words[1]["mass_at"]) == (1e8, [1e8], 1e7)
    assert words[0]["mass_10pct"] == pytest.approx(-8.0 * 10 ** -0.4) and words[1]["mass_10pct"] == -8.0
    cooling = render("law.md.j2", rows=words[:1], formula="f")
    assert "a mass 10 % too large (at the same k² and E = 1e+08 Pa, the one stiffness its points ran at) by -3.18 %" in cooling
    assert "YADE sets its viscous damping from the colliding member spheres' reduced mass" in cooling
    assert "Each dissipative fit's points ran at one stiffness" in cooling and "apart.\n\n![The law]" in cooling
    elastic = render("law.md.j2", rows=words[1:], formula="f")
    assert "a mass 10 % too large (at the same k² and E = 1e+07 Pa) by -8.00 %" in elastic
    assert "damping" not in elastic
