"""``results/predictions.csv`` (studies/prediction_table.py): merging new predictions, refreshing
the gas columns, and the committed table against the committed gas tables.  No YADE."""
import csv
import os

import pytest

from _predict_spec import read_table as _read
from studies import prediction_table as predict

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_a_new_prediction_replaces_its_own_rows_and_keeps_the_others(tmp_path):
    path = tmp_path / "p.csv"
    row = lambda shape, e, v: {"shape": shape, "youngs_modulus": "1e+07", "restitution": e, "friction": "0",  # noqa: E731
                               "case": "uncorrected/paired", "observable": "diffusion", "predicted": v,
                               "predicted_se": "0.01", "cpu_s": "1", "gas_relative": "", "gas_ci_low": "",
                               "gas_ci_high": ""}
    predict.write_table([row("grain", "1", "0.03"), row("dimer", "0.9", "0.01")], str(path))
    gas = {("grain", "", "paired", 1e7, "uncorrected"): (0.02, 0.01, 0.04)}
    out = predict.merged([row("dimer", "0.9", "0.05")], str(path), gas)
    assert [(r["shape"], r["predicted"]) for r in out] == [("grain", "0.03"), ("dimer", "0.05")]
    assert (out[0]["gas_relative"], out[0]["gas_ci_high"]) == ("0.02", "0.04")    # refreshed from the gas table
    assert predict.merged([row("x", "1", "0")], str(tmp_path / "none.csv")) == [row("x", "1", "0")]


def _row(shape, case, gas=("0.05", "0.01", "0.09")):
    return {"shape": shape, "youngs_modulus": "1e+08", "restitution": "0.9", "friction": "0.5",
            "case": f"{case}/paired", "observable": "cooling_rate", "predicted": "0.01", "predicted_se": "0.002",
            "cpu_s": "30", "gas_relative": gas[0], "gas_ci_low": gas[1], "gas_ci_high": gas[2]}


def _hcs_table(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["shape", "youngs_modulus", "restitution", "friction", "protocol", "case",
                                          "observable", "relative", "relative_ci_low", "relative_ci_high"])
        w.writeheader()
        for shape, case, rel, lo, hi in rows:
            w.writerow({"shape": shape, "youngs_modulus": 1e8, "restitution": 0.9, "friction": 0.5,
                        "protocol": "paired", "case": case, "observable": "cooling_rate", "relative": rel,
                        "relative_ci_low": lo, "relative_ci_high": hi})


def test_refreshing_the_gas_columns_follows_the_gas_tables_and_runs_nothing(tmp_path):
    path, hcs, none = tmp_path / "p.csv", tmp_path / "hcs_effects.csv", str(tmp_path / "none.csv")
    rows = [_row("tet", "mass_only"), _row("dimer", "uncorrected"), _row("grain", "uncorrected", ("", "", ""))]
    predict.write_table(rows, str(path))
    _hcs_table(hcs, [("dimer", "uncorrected", 0.02, -0.01, 0.05), ("grain", "uncorrected", -0.03, -0.05, -0.01)])
    assert predict.refresh_gas(str(path), none, str(hcs)) == 2
    _, got = _read(path)
    assert [(r["shape"], r["gas_relative"], r["gas_ci_low"], r["gas_ci_high"]) for r in got] == [
        ("tet", "0.05", "0.01", "0.09"),            # no gas row of its own: left as it was
        ("dimer", "0.02", "-0.01", "0.05"), ("grain", "-0.03", "-0.05", "-0.01")]
    assert all(r["predicted"] == "0.01" for r in got)                             # the predictions stay
    assert predict.refresh_gas(str(path), none, str(hcs)) == 0                     # up to date: untouched
    assert predict.refresh_gas(str(tmp_path / "absent.csv")) == 0


def test_a_table_of_other_columns_is_refused_and_left_as_it_is(tmp_path):
    path, hcs = tmp_path / "p.csv", tmp_path / "hcs_effects.csv"
    _hcs_table(hcs, [("dimer", "uncorrected", 0.02, -0.01, 0.05)])
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=predict.COLUMNS + ["dt_factor"])
        w.writeheader()
        w.writerow(dict(_row("dimer", "uncorrected"), dt_factor="2"))
    before = path.read_text()
    with pytest.raises(ValueError, match="its columns are not"):
        predict.refresh_gas(str(path), str(tmp_path / "none.csv"), str(hcs))
    assert path.read_text() == before


def test_the_committed_predictions_carry_the_committed_cooling_gas_intervals():
    gas = predict.hcs_intervals()
    _, rows = _read(predict.OUT)
    checked = 0
    for r in rows:
        case, _, prot = r["case"].partition("/")
        key = (r["shape"], float(r["youngs_modulus"]), float(r["restitution"]), float(r["friction"]), case,
               r["observable"])
        if key in gas:
            assert tuple(float(r[k]) for k in ("gas_relative", "gas_ci_low", "gas_ci_high")) == \
                pytest.approx(gas[key], rel=1e-5, abs=1e-9), r
            checked += 1
    assert checked >= 30


def test_the_grains_predictions_on_its_gas_step_match_those_on_a_step_four_times_shorter():
    """The committed grain predictions run at dt factor 2.0 (its gas's step); the same collision
    courses at 0.5 (results/predict_step/) give the same effects to a fraction of their standard
    error, at a fraction of the CPU."""
    _, fine = _read(os.path.join(ROOT, "results", "predict_step", "ellipsoid20_f0.5.csv"))
    _, rows = _read(predict.OUT)
    key = lambda r: (r["shape"], r["restitution"], r["friction"], r["case"], r["observable"])     # noqa: E731
    coarse = {key(r): r for r in rows}
    assert len(fine) >= 12
    for f in fine:
        c = coarse.get(key(f))
        assert c is not None, f"no committed prediction for {key(f)}"
        se = max(float(f["predicted_se"]), float(c["predicted_se"]))
        assert abs(float(c["predicted"]) - float(f["predicted"])) < 0.25 * se, (c, f)
    # the cost of one contact law with the same cases at both factors (each row holds its share)
    law = ("ellipsoid20", "0.9", "0")
    cpu = [sum(float(r["cpu_s"]) for r in table if key(r)[:3] == law) for table in (fine, rows)]
    assert {key(r)[3] for r in fine if key(r)[:3] == law} == {key(r)[3] for r in rows if key(r)[:3] == law}
    assert 0 < cpu[1] < 0.5 * cpu[0], cpu
