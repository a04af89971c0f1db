"""The fuzz target tests/fuzz_exact.py at CI size (a few hundred clumps; ``make fuzz`` runs 10^4)."""
import fuzz_exact


def test_fuzz_exact_small():
    out = fuzz_exact.run(n_clumps=300, seed=20261123, block=300)
    assert out["clumps"] == 300
    assert all(n > 0 for n in out["kinds"].values()), out["kinds"]  # every degeneracy was drawn
    assert out["ok"], out["failures"][:5]
    for key in ("documented_exceptions", "other_exceptions", "nonfinite", "bounds_violations",
                "translation_fail", "rotation_fail", "permutation_fail"):
        assert out[key] == 0, (key, out[key])
    assert max(out["max_translation"], out["max_rotation"], out["max_permutation"]) <= 1e-12
