"""Large batches are computed in blocks of clumps: the blocks must not change any value."""
import numpy as np
import pytest

import clumpprops as cp
from clumpprops import api

FIELDS = ("mass", "volume", "center_of_mass", "inertia", "principal_moments", "principal_axes")


def _clumps(M, N, seed):
    rng = np.random.default_rng(seed)
    c = rng.normal(scale=0.5, size=(M, N, 3)) + rng.normal(scale=100.0, size=(M, 1, 3))
    r = rng.uniform(0.3, 0.6, size=(M, N))
    return c, r


@pytest.mark.parametrize("method,N", [("exact", 4), ("pairwise", 2), ("sum", 3)])
def test_blocks_equal_one_block(monkeypatch, method, N):
    c, r = _clumps(23, N, 1)
    whole = cp.mass_properties(c, r, 1140.0, method=method)
    monkeypatch.setattr(api, "_BATCH_CHUNK", 5)  # 5 blocks, the last one partial
    blocks = cp.mass_properties(c, r, 1140.0, method=method)
    assert blocks.batched and len(blocks) == 23 and blocks.method == method
    for f in FIELDS:
        assert np.array_equal(getattr(blocks, f), getattr(whole, f)), f
    with pytest.raises(ValueError):
        blocks.inertia[0, 0, 0] = 1.0  # still immutable


def test_blocks_of_a_ragged_batch(monkeypatch):
    rng = np.random.default_rng(2)
    cs = [rng.normal(scale=0.4, size=(n, 3)) for n in (1, 3, 2, 5, 4, 2, 3)]
    rs = [rng.uniform(0.3, 0.6, size=len(c)) for c in cs]
    whole = cp.mass_properties(cs, rs)
    monkeypatch.setattr(api, "_BATCH_CHUNK", 3)
    blocks = cp.mass_properties(cs, rs)
    for f in FIELDS:
        assert np.array_equal(getattr(blocks, f), getattr(whole, f)), f


def test_triple_overlap_error_names_the_clump_of_the_whole_batch(monkeypatch):
    c, r = _clumps(12, 3, 3)
    c[:, :, :] = [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [6.0, 0.0, 0.0]]  # chains without overlap
    r[:] = 1.0
    c[9] = [[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.25, 0.4, 0.0]]  # a true triple overlap in clump 9
    monkeypatch.setattr(api, "_BATCH_CHUNK", 4)
    with pytest.raises(cp.ClumpGeometryError, match=r"of clump 9\b"):
        cp.mass_properties(c, r, method="pairwise")
