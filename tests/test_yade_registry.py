"""The adapter's registry format and its two build paths (one clump at a time, vectorised batches).

* Registry format 2 (``O.tags["clumpprops.corrections"]`` = header, entries in chunk tags): survives
  ``O.save``/``O.load`` and ``saveTmp``/``loadTmp``, a build rewrites only the chunks it touched
  (the cost of recording a clump does not grow with the scene), a scene saved with format 1 (every
  entry in the one tag, sha1 fingerprints) still loads and checks, and a damaged or newer registry
  fails with a clear error.
* The plain-float path for small batches (``append_clump``) and the numpy path for large ones give
  the same corrections, orientations, fingerprints and error measures, and both are verified: a
  build whose YADE state misses the target raises on either path.
"""
import numpy as np
import pytest

from _yadehelpers import O, PAPER_RHO, assert_state_matches, fresh_scene, make_spheres, random_clump, vec

import clumpprops
from clumpprops import yade as cy


@pytest.fixture
def scene():
    fresh_scene()
    yield O
    O.reset()


@pytest.fixture
def small_chunks(monkeypatch):
    monkeypatch.setattr(cy, "_CHUNK", 4)


def _geo(seed, n_clumps, sizes=(2, 3, 5)):
    rng = np.random.default_rng(seed)
    return [random_clump(rng, sizes[k % len(sizes)], origin=(3.0 * k, 1.0, -2.0)) for k in range(n_clumps)]


def _tags():
    return {k: O.tags[k] for k in O.tags.keys() if k.startswith(cy._TAG)}


def _exact(cid):
    ids = cy.sphere_member_ids(cid)
    c = np.array([vec(O.bodies[i].state.pos) for i in ids])
    r = np.array([O.bodies[i].shape.radius for i in ids])
    return clumpprops.mass_properties(c, r, PAPER_RHO)


# ---------------------------------------------------------------- registry format 2


def test_registry_chunks_round_trip(scene, small_chunks, tmp_path):
    geo = _geo(1, 14)
    cids = [cy.append_clump(make_spheres(c, r))[0] for c, r in geo[:5]]
    cids += [cid for cid, _ in cy.append_clumps([make_spheres(c, r) for c, r in geo[5:]])]
    tags = _tags()
    assert tags[cy._TAG].startswith("#clumpprops registry v2 chunks=4 ")  # 14 entries, 4 per chunk
    lines = [ln for k in range(4) for ln in tags[f"{cy._TAG}.{k}"].splitlines()]
    assert sorted(int(ln.split()[0]) for ln in lines) == sorted(cids)
    assert all(ln.split()[2].startswith("b2:") and ln.split()[3] == "exact" for ln in lines)
    cy.erase(cids[2])  # an entry leaves its chunk
    cy.correct_clump(cids[9])  # an entry is rewritten in place
    del cids[2]
    f = str(tmp_path / "s.yade.gz")
    O.save(f)
    O.saveTmp("reg")
    for load in (lambda: O.load(f), lambda: O.loadTmp("reg")):
        O.reset()
        assert not cy.check().exact  # the empty scene's registry, not the cached one
        load()
        rep = cy.check()
        assert rep.ok and sorted(rep.exact) == sorted(cids), str(rep)
        for cid in cids:
            assert_state_matches(O.bodies[cid].state, _exact(cid))
        # the loaded registry is live: build on it and check again
        c, r = _geo(2, 1)[0]
        new, _ = cy.append_clump(make_spheres(c + 50.0, r))
        assert sorted(cy.check().exact) == sorted(cids + [new])


def test_build_rewrites_only_the_last_chunk(scene, small_chunks):
    geo = _geo(3, 13)
    cy.append_clumps([make_spheres(c, r) for c, r in geo[:12]])  # chunks 0..2 full
    before = _tags()
    c, r = geo[12]
    cid, _ = cy.append_clump(make_spheres(c, r))
    after = _tags()
    changed = {k for k in after if after[k] != before.get(k)}
    assert changed == {cy._TAG, f"{cy._TAG}.3"}
    assert after[f"{cy._TAG}.3"].startswith(f"{cid} ")
    assert cy.check().ok


def test_header_token_tracks_the_scene(scene, small_chunks):
    """O.saveTmp, more builds, O.loadTmp: the cached registry holds entries the loaded scene lacks, and
    the header (a new token per write) tells; the next build records on the loaded scene's registry."""
    geo = _geo(4, 4)
    a, _ = cy.append_clump(make_spheres(*geo[0]))
    O.saveTmp("early")
    b, _ = cy.append_clump(make_spheres(*geo[1]))
    O.loadTmp("early")
    assert set(cy._registry()) == {a}
    c, _ = cy.append_clump(make_spheres(*geo[2]))
    rep = cy.check()
    assert rep.ok and sorted(rep.exact) == sorted([a, c])


def _write_format1(reg):
    """The registry as the adapter wrote it before format 2: every entry in the one tag, sha1 fingerprints."""
    lines = []
    for cid, (corr, _, method) in reg.items():
        spheres, _ = cy._split_members(O.bodies[cid])
        lines.append(f"{cid} {corr} {cy._fingerprint_v1(spheres)} {method}\n")
    return "".join(lines)


def test_scene_saved_with_format_1_loads(scene, tmp_path):
    cids = [cy.append_clump(make_spheres(c, r))[0] for c, r in _geo(5, 3)]
    yid, _ = O.bodies.appendClumped(make_spheres(*_geo(6, 1)[0]))  # YADE's own, uncorrected
    old = _write_format1(cy._registry())
    O.reset()
    fresh_scene()  # the same scene again, with only the format-1 tag (as an old clumpprops saved it)
    cids2 = [cy.append_clump(make_spheres(c, r))[0] for c, r in _geo(5, 3)]
    O.bodies.appendClumped(make_spheres(*_geo(6, 1)[0]))
    assert cids2 == cids
    f = str(tmp_path / "old.yade.gz")
    for k in O.tags.keys():
        if k.startswith(cy._TAG + "."):
            O.tags[k] = ""
    O.tags[cy._TAG] = old
    O.save(f)
    O.reset()
    O.load(f)
    reg = cy._registry()
    assert set(reg) == set(cids) and all(not rec[1].startswith("b2:") for rec in reg.values())
    rep = cy.check()
    assert rep.ok and sorted(rep.exact) == cids and rep.uncorrected == [yid], str(rep)
    # a format-1 fingerprint still detects a changed sphere set
    m = cy.sphere_member_ids(cids[1])
    r0 = O.bodies[m[0]].shape.radius
    O.bodies[m[0]].shape.radius = r0 * 1.01
    assert [c for c, _ in cy.check().stale] == [cids[1]]
    O.bodies[m[0]].shape.radius = r0
    # the next write converts the registry to format 2
    new, _ = cy.append_clump(make_spheres(*_geo(7, 1)[0]))
    assert O.tags[cy._TAG].startswith("#clumpprops registry v2")
    O.save(f)
    O.reset()
    O.load(f)
    rep = cy.check()
    assert rep.ok and sorted(rep.exact) == sorted(cids + [new])


def test_damaged_or_newer_registry_fails_clearly(scene, small_chunks):
    cy.append_clumps([make_spheres(c, r) for c, r in _geo(8, 6)])
    head = O.tags[cy._TAG]
    O.tags[cy._TAG] = head.replace("chunks=2", "chunks=3")  # a chunk that is not there
    with pytest.raises(cy.ClumpAdapterError, match=r"registry in O.tags is damaged: 'clumpprops.corrections.2' is missing"):
        cy.check()
    O.tags[cy._TAG] = "#clumpprops registry v9 chunks=1 token=x\n"
    with pytest.raises(cy.ClumpAdapterError, match="unknown format.*newer clumpprops"):
        cy.check()
    O.tags[cy._TAG] = head
    O.tags[cy._TAG + ".0"] = "1 2 3\n"
    O.tags[cy._TAG] = head + " "  # a new header: the cache is not used
    with pytest.raises(cy.ClumpAdapterError, match="damaged .line 1"):
        cy.check()


# ---------------------------------------------------------------- the two build paths agree


@pytest.mark.parametrize("seed", range(4))
def test_small_and_batch_paths_agree(seed):
    rng = np.random.default_rng(seed)
    geo = [random_clump(rng, n, origin=rng.normal(size=3) * 10.0) for n in (1, 2, 3, 7, 12)]
    geo.append((np.array([[0.0, 0, 0], [0.3, 0, 0]]), np.array([0.1, 0.1])))  # no overlap: zero offset
    xs, rs = [c for c, _ in geo], [r for _, r in geo]
    rhos = [[PAPER_RHO] * len(r) for r in rs]
    mass, com, inertia, scale = cy._targets(xs, rs, rhos, "exact")
    m_c, off, w, V = cy._correction_flat(np.concatenate(xs), np.concatenate(rs), np.concatenate(rhos),
                                         np.array([len(r) for r in rs]), mass, com, inertia)
    q_batch = cy._quaternions(V)
    for k, (c, r) in enumerate(geo):
        t = cy._targets([c], [r], [rhos[k]], "exact")  # lists for a small batch
        assert isinstance(t[0], list) and t[0][0] == pytest.approx(mass[k], rel=1e-15)
        assert t[3][0] == pytest.approx(scale[k], rel=1e-15)
        m1, off1, w1, V1 = cy._correction_one(c.tolist(), r.tolist(), rhos[k], float(mass[k]), com[k].tolist(),
                                              inertia[k].tolist())
        size = float(mass[k]) * float(np.max(r)) ** 2
        assert abs(m1 - m_c[k]) <= 1e-13 * mass[k]
        assert np.allclose(off1, off[k], rtol=0, atol=1e-13 * np.max(r))
        J1 = V1 @ np.diag(w1) @ V1.T
        J = V[k] @ np.diag(w[k]) @ V[k].T
        assert np.max(np.abs(J1 - J)) <= 1e-13 * size
        assert np.linalg.det(V1) > 0
        # the orientation: scalar twin, vectorised, and Eigen's Quaternion(Matrix3(V^T)) give one rotation
        Y = cy._Y.load()
        q1 = np.array(cy._quaternion_one(V[k]))
        qe = Y.Quaternion(Y.Matrix3(*V[k].T.ravel().tolist()))
        qe.normalize()
        qe = np.array([qe[3], qe[0], qe[1], qe[2]])
        for q in (q1, qe):
            assert min(np.max(np.abs(q - q_batch[k])), np.max(np.abs(q + q_batch[k]))) <= 1e-15 * 4
        assert np.allclose(cy._rotations(np.roll(q1, -1)[None])[0], V[k].T, atol=1e-15 * 4)


def test_small_and_batch_error_measures_agree():
    rng = np.random.default_rng(5)
    geo = [random_clump(rng, n) for n in (2, 3, 4, 5, 6)]
    mass, com, inertia, scale = cy._targets([c for c, _ in geo], [r for _, r in geo],
                                            [[PAPER_RHO] * len(r) for _, r in geo], "exact")
    rows = []
    for k in range(len(geo)):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        rows.append((mass[k] * (1 + 1e-9 * rng.normal()), *(com[k] + 1e-6 * rng.normal(size=3)),
                     *np.abs(rng.normal(size=3)) * scale[k], *q))
    e_np = cy._state_errors(None, list(range(5)), mass, com, inertia, scale, rows)
    e_py = np.array(cy._errors_small(rows, mass, com, inertia, scale)).T
    assert np.allclose(e_np, e_py, rtol=1e-12, atol=0)


def test_fingerprints_scalar_and_vectorised():
    ids = [[5, 6], [9, 7, 8], [11]]  # the second set not sorted by id
    radii = [[0.1, 0.2], [0.3, 0.1, 0.2], [0.5]]
    rhos = [[1000.0] * 2, [1000.0] * 3, [2500.0]]
    one = [cy._fp(i, r, d) for i, r, d in zip(ids, radii, rhos)]
    many = cy._fps(sum(ids, []), sum(radii, []), sum(rhos, []), [2, 3, 1])
    assert one == many and len(set(one)) == 3 and all(f.startswith("b2:") and len(f) == 19 for f in one)
    assert cy._fp([7, 8, 9], [0.1, 0.2, 0.3], rhos[1]) == one[1]  # sorted by id: order of input is irrelevant
    assert cy._fp([7, 8, 9], [0.1, 0.2, 0.30000000000000004], rhos[1]) != one[1]


@pytest.mark.parametrize("n_clumps", [1, 2, 5])
def test_append_paths_are_verified(scene, monkeypatch, n_clumps):
    """A build whose YADE state misses its target raises naming the clump, on the plain-float path
    (1-2 clumps) and on the numpy path (more)."""
    real_one, real_flat = cy._correction_one, cy._correction_flat

    def one(*a, **k):
        m, off, w, V = real_one(*a, **k)
        return m + 1e-3, off, w, V

    def flat(*a, **k):
        m, off, w, V = real_flat(*a, **k)
        return m + 1e-3, off, w, V

    monkeypatch.setattr(cy, "_correction_one", one)
    monkeypatch.setattr(cy, "_correction_flat", flat)
    geo = _geo(9, n_clumps)
    first = len(O.bodies) + len(geo[0][1]) + 1  # the members (spheres and correction) come first
    with pytest.raises(cy.ClumpAdapterError, match=rf"clump #{first}: YADE's state after the build differs"):
        cy.append_clumps([make_spheres(c, r) for c, r in geo])


@pytest.mark.parametrize("n_clumps", [1, 2, 5])
def test_append_paths_exact(scene, n_clumps):
    geo = _geo(10, n_clumps)
    ret = cy.append_clumps([make_spheres(c, r) for c, r in geo])
    for (cid, mids), (c, r) in zip(ret, geo):
        assert_state_matches(O.bodies[cid].state, clumpprops.mass_properties(c, r, PAPER_RHO))
        assert np.array_equal(np.array([vec(O.bodies[i].state.pos) for i in mids]), c)  # bit for bit
        corr = O.bodies[cy.correction_id(cid)]
        assert cy.is_correction(corr) and type(corr.shape) is cy._Y.Shape
    assert cy.check().ok
