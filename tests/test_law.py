"""studies.law: the fitted formula on points made from a known law, and its check on gas rows."""
import csv
import json

import numpy as np
import pytest

from studies import law


def _maps(tmp_path, a, b, rng, noise):
    d = tmp_path / "collision_map"
    d.mkdir()
    k = 0
    for E in (1e7, 1e9):
        for m_err, k2_base in ((0.185, -0.12), (0.46, -0.15), (0.5, -0.19)):
            rows = []
            for case, m, k2 in (("uncorrected", m_err, k2_base), ("mass_only", 0.0, -k2_base / 3),
                                ("inertia_only", m_err, 1.3 * k2_base), ("mass_scaled", m_err, 0.0)):
                rel = a * k2 + b * law.softness(E) * m + noise * rng.normal()
                rows.append({"case": case, "protocol": "paired", "relative": rel, "se": max(noise, 1e-4),
                             "mass_error": m, "iperp_over_m_error": k2})
            rows.append({"case": "uncorrected", "protocol": "equal_energy", "relative": -0.1, "se": 0.001,
                         "mass_error": m_err, "iperp_over_m_error": k2_base})
            (d / f"case_map_{k}.json").write_text(json.dumps({"shape": {"kind": "dimer", "overlap": 0.5},
                                                              "material": {"youngs_modulus": E}, "rows": rows}))
            k += 1


def test_a_known_law_is_recovered_and_the_gas_check_counts_intervals(tmp_path):
    rng = np.random.default_rng(3)
    a, b = -0.05, 0.035
    _maps(tmp_path, a, b, rng, 5e-4)
    with open(tmp_path / "effects.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["shape", "protocol", "youngs_modulus", "case", "n_pairs", "relative",
                                          "relative_ci_low", "relative_ci_high", "mass_error", "k2_error"])
        w.writeheader()
        truth = a * -0.12 + b * 0.185
        w.writerow({"shape": "dimer", "protocol": "paired", "youngs_modulus": 1e7, "case": "uncorrected",
                    "n_pairs": 8, "relative": truth, "relative_ci_low": truth - 0.005, "relative_ci_high": truth + 0.005,
                    "mass_error": 0.185, "k2_error": -0.12})
        w.writerow({"shape": "dimer", "protocol": "paired", "youngs_modulus": 1e7, "case": "mass_only",
                    "n_pairs": 8, "relative": 0.05, "relative_ci_low": 0.04, "relative_ci_high": 0.06,
                    "mass_error": 0.0, "k2_error": 0.04})
        w.writerow({"shape": "dimer", "protocol": "equal_energy", "youngs_modulus": 1e7, "case": "uncorrected",
                    "n_pairs": 8, "relative": -0.08, "relative_ci_low": -0.09, "relative_ci_high": -0.07,
                    "mass_error": 0.185, "k2_error": -0.12})
    rows, fits, checks = law.law_rows(str(tmp_path), str(tmp_path / "none.csv"))
    (r,) = rows
    assert (r["observable"], r["restitution"], r["friction"], r["n_points"]) == ("diffusion", 1.0, 0.0, 24)
    assert r["coef_k2"] == pytest.approx(a, abs=4 * r["coef_k2_se"]) and r["coef_k2_se"] < 0.005
    assert r["coef_mass"] == pytest.approx(b, abs=4 * r["coef_mass_se"]) and r["coef_mass_se"] < 0.003
    assert r["rms_residual"] < 1e-3 and 0.3 < r["chi2_dof"] < 2.5
    # the equal-energy row is no check of the paired law; of the two paired rows one holds the law
    assert (r["n_checks"], r["n_checks_inside"]) == (2, 1)
    law.plot(fits, checks, str(tmp_path / "law.png"))
    assert (tmp_path / "law.png").stat().st_size > 10_000


def test_the_softness_factor_follows_the_hertz_contact_time():
    assert law.softness(1e7) == 1.0 and law.softness(1e9) == pytest.approx(100 ** -0.4)
