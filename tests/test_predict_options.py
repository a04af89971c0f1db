"""``python -m studies predict``'s options and input errors, without YADE (the collision runs are
replaced where a test reaches them)."""
import pytest

from _predict_spec import dimer025_spec as _dimer025_spec
from studies import predict


def test_a_step_factor_applies_to_every_shape_unless_one_is_named():
    shapes = ["dimer", "ellipsoid20"]
    assert predict.step_factors(None, shapes) == {"dimer": 0.5, "ellipsoid20": 0.5}
    assert predict.step_factors(["1.0"], shapes) == {"dimer": 1.0, "ellipsoid20": 1.0}
    assert predict.step_factors(["ellipsoid20=2", "0.25"], shapes) == {"dimer": 0.25, "ellipsoid20": 2.0}
    assert predict.step_factors(["ellipsoid20=2", "ellipsoid20=1.5"], shapes)["ellipsoid20"] == 1.5
    for bad in ("0", "-1", "nan", "inf", "fast", "ellipsoid20=", "ellipsoid20=0"):
        with pytest.raises(ValueError, match="positive number"):
            predict.step_factors([bad], shapes)
    with pytest.raises(ValueError, match="no shape 'grain'"):
        predict.step_factors(["grain=2"], shapes)


def test_each_shape_runs_its_collisions_on_its_own_step_factor(tmp_path, monkeypatch):
    spec = _dimer025_spec(tmp_path)
    with open(spec, "a") as f:           # a second shape: the dimer at D/d_s = 0.5
        f.write('\n[shapes.dimer050]\nkind = "dimer"\nsphere_diameter = 0.1333\noverlap = 0.5\n'
                '\n[[groups]]\nshape = "dimer050"\ncases = ["exact", "uncorrected"]\nseeds = [1]\n')
    seen = []

    def fake(shape, cases, pairs, seed, factor, workdir, tag):
        seen.append((tag.split("-")[0], factor))
        return [{"case": c, "protocol": p, "predicted": 0.01, "predicted_se": 0.001, "cpu_s": 1.0, "pairs_used": pairs}
                for c, p in cases]

    monkeypatch.setattr(predict, "elastic_predictions", fake)
    out = str(tmp_path / "p.csv")
    assert predict.main([spec, "--pairs", "20", "--out", out, "--factor", "dimer025=0.25"]) == 0
    assert seen == [("dimer025", 0.25), ("dimer050", 0.5)]
    seen.clear()
    assert predict.main([spec, "--pairs", "20", "--out", out, "--factor", "1", "--factor", "dimer050=2"]) == 0
    assert seen == [("dimer025", 1.0), ("dimer050", 2.0)]


def test_a_bad_step_factor_stops_with_a_one_line_error(tmp_path, capsys):
    assert predict.main([_dimer025_spec(tmp_path), "--factor", "sphere=1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: --factor sphere=1: the spec has no shape") and "\n" not in err


def test_a_missing_spec_stops_with_a_one_line_error(tmp_path, capsys):
    assert predict.main([str(tmp_path / "none.toml")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err
