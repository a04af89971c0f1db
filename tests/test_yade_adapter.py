"""clumpprops.yade with real YADE (plain ``import yade``): state, persistence, contacts, bad input."""
import numpy as np
import pytest

from _yadehelpers import (
    O, PAPER_D, PAPER_RHO, assert_state_matches, fresh_scene, make_spheres, random_clump,
    scene_snapshot, vec, yade, utils,
)

import clumpprops
from clumpprops import yade as cy
from yade.wrapper import (
    Box, Bo1_Box_Aabb, Bo1_Facet_Aabb, Bo1_Sphere_Aabb, Bo1_Wall_Aabb, ForceResetter, FrictMat,
    GravityEngine, Ig2_Box_Sphere_ScGeom, Ig2_Facet_Sphere_ScGeom, Ig2_Sphere_Sphere_ScGeom, Ig2_Wall_Sphere_ScGeom,
    InsertionSortCollider, InteractionLoop, Ip2_FrictMat_FrictMat_MindlinPhys, Law2_ScGeom_MindlinPhys_Mindlin,
    NewtonIntegrator,
)

cy.install_guards()  # these tests check YADE's O.bodies methods as the guards route them


@pytest.fixture
def scene():
    fresh_scene()
    yield O
    O.reset()


def paper_dimer():
    d = PAPER_D
    return np.array([[0, 0, -d / 4], [0, 0, d / 4]]), np.array([d / 2, d / 2])


# ---------------------------------------------------------------- the paper's dimer (pairwise: no triples)


def test_paper_dimer_equals_library_and_differs_from_yade(scene):
    c, r = paper_dimer()
    mp = clumpprops.mass_properties(c, r, PAPER_RHO, method="pairwise")
    cid, mids = cy.append_clump(make_spheres(c, r), method="pairwise")
    st = O.bodies[cid].state
    assert_state_matches(st, mp)
    assert mids == [0, 1] and O.bodies[cid].isClump
    for i, m in enumerate(mids):  # members exactly where they were, true density kept
        assert np.array_equal(vec(O.bodies[m].state.pos), c[i])
        assert O.bodies[m].material.density == PAPER_RHO
    # YADE's own clump of the same spheres counts the lens twice (facts: mass +18.5 %)
    yid, _ = O.bodies.appendClumped(make_spheres(c + 1.0, r))
    assert O.bodies[yid].state.mass / mp.mass - 1 == pytest.approx(0.185, abs=0.001)


def test_exact_and_pairwise_agree_on_dimer(scene):
    c, r = paper_dimer()
    cid, _ = cy.append_clump(make_spheres(c, r))  # default: exact
    assert_state_matches(O.bodies[cid].state, clumpprops.mass_properties(c, r, PAPER_RHO, method="pairwise"), rtol=1e-11)


# ---------------------------------------------------------------- random asymmetric clumps with triple overlaps


def _triple_overlap(c, r):
    n = len(r)
    d = np.linalg.norm(c[:, None] - c[None], axis=-1)
    ov = d < r[:, None] + r[None]
    return any(ov[i, j] and ov[j, k] and ov[i, k] for i in range(n) for j in range(i + 1, n) for k in range(j + 1, n))


SEEDS = list(range(8))


@pytest.mark.parametrize("seed", SEEDS)
def test_random_clumps_exact_state_positions_persistence(scene, tmp_path, seed):
    rng = np.random.default_rng(seed)
    n = [2, 3, 4, 6, 9, 13, 17, 20][seed]
    c, r = random_clump(rng, n, origin=rng.uniform(-0.5, 0.5, 3))
    if n >= 3:
        assert _triple_overlap(c, r)
    mp = clumpprops.mass_properties(c, r, PAPER_RHO)
    assert mp.mass < clumpprops.mass_properties(c, r, PAPER_RHO, method="sum").mass * (1 - 1e-3)
    cid, mids = cy.append_clump(make_spheres(c, r))
    corr = cy.correction_id(cid)
    assert len(mids) == n and corr not in mids

    def check(label):
        b = O.bodies[cid]
        assert b.isClump, label
        assert_state_matches(b.state, mp)
        for i, m in enumerate(mids):
            assert np.allclose(vec(O.bodies[m].state.pos), c[i], rtol=0, atol=1e-15), label
            assert O.bodies[m].material.density == PAPER_RHO
        assert cy.correction_id(cid) == corr and O.bodies[corr].bound is None

    check("built")
    for i, m in enumerate(mids):  # bit-identical right after the build
        assert np.array_equal(vec(O.bodies[m].state.pos), c[i])
    O.bodies.updateClumpProperties(discretization=0)
    check("updateClumpProperties(0)")
    f = str(tmp_path / "scene.yade.gz")
    O.save(f)
    O.reset()
    assert len(O.bodies) == 0
    O.load(f)
    check("O.save/O.load")
    O.bodies.updateClumpProperties(discretization=0)
    check("load + updateClumpProperties(0)")
    O.saveTmp("t")
    with cy.unguarded():  # YADE's own voxel update ignores the correction
        O.bodies.updateClumpProperties(discretization=10)
    assert abs(O.bodies[cid].state.mass - mp.mass) > 1e-4 * mp.mass
    assert not cy.check().ok
    O.loadTmp("t")
    check("saveTmp/loadTmp")
    O.bodies.updateClumpProperties(discretization=10)  # routed through the adapter: stays exact
    check("updateClumpProperties(10), guarded")
    with cy.unguarded():
        O.bodies.updateClumpProperties(discretization=10)
    cy.correct_all_clumps()  # restores after YADE's own voxel update too
    check("voxel update + correct_all_clumps")
    assert cy.check().ok
    assert cy.correction_id(cid) == corr


@pytest.mark.parametrize("origin", [(5.0, -3.0, 2.0), (100.0, -50.0, 30.0)])
def test_far_from_origin(scene, origin):
    """YADE sums inertia about the world origin (cancellation ~ eps (|x| / size)^2); the adapter
    builds around the exact COM and moves the clump back, so it stays exact far away too."""
    rng = np.random.default_rng(42)
    c, r = random_clump(rng, 8, origin=origin)
    mp = clumpprops.mass_properties(c, r, PAPER_RHO)
    cid, mids = cy.append_clump(make_spheres(c, r))
    assert_state_matches(O.bodies[cid].state, mp, rtol=1e-12)
    for i, m in enumerate(mids):
        assert np.array_equal(vec(O.bodies[m].state.pos), c[i])
    c2, r2 = random_clump(rng, 6, origin=np.add(origin, 1.0))
    yid, ymids = O.bodies.appendClumped(make_spheres(c2, r2))
    cy.correct_clump(yid)
    assert_state_matches(O.bodies[yid].state, clumpprops.mass_properties(c2, r2, PAPER_RHO), rtol=1e-12)
    for i, m in enumerate(ymids):
        assert np.array_equal(vec(O.bodies[m].state.pos), c2[i])
    # YADE's own update keeps the correction but uses its world-origin sums: eps (|c|/size)^2
    with cy.unguarded():
        O.bodies.updateClumpProperties(discretization=0)
    assert_state_matches(O.bodies[cid].state, mp, rtol=max(1e-12, 1e-14 * (np.linalg.norm(origin) / 0.1) ** 2))
    cy.correct_all_clumps()  # back to round-off
    assert_state_matches(O.bodies[cid].state, mp, rtol=1e-12)


# ---------------------------------------------------------------- other ways to build clumps


def test_correct_clumps_built_by_yade(scene):
    rng = np.random.default_rng(7)
    geo = [random_clump(rng, n, origin=(k * 0.8, 0, 0)) for k, n in enumerate([2, 5, 11])]
    c0, r0 = geo[0]
    ids = O.bodies.append(make_spheres(c0, r0))
    cid_a = O.bodies.clump(ids)  # O.bodies.clump
    cid_b, _ = O.bodies.appendClumped(make_spheres(*geo[1]))  # appendClumped
    cid_c, _ = O.bodies.appendClumped(make_spheres(*geo[2]), discretization=10)  # voxelised
    lone = O.bodies.append(utils.sphere((5, 5, 5), 0.1))  # a standalone sphere is left alone
    pos_before = {b.id: vec(b.state.pos) for b in O.bodies}
    cids = cy.correct_all_clumps()
    assert sorted(cids) == sorted([cid_a, cid_b, cid_c])
    for cid, (c, r) in zip([cid_a, cid_b, cid_c], geo):
        assert_state_matches(O.bodies[cid].state, clumpprops.mass_properties(c, r, PAPER_RHO))
    for bid, p in pos_before.items():
        if not O.bodies[bid].isClump:
            assert np.array_equal(vec(O.bodies[bid].state.pos), p)
    assert not O.bodies[lone].isClumpMember
    # idempotent: the same correction body is reused
    corr = [cy.correction_id(c) for c in cids]
    n_bodies = len(O.bodies)
    cy.correct_clumps(cids)
    assert [cy.correction_id(c) for c in cids] == corr and len(O.bodies) == n_bodies


def test_correct_keeps_rigid_velocity_field(scene):
    rng = np.random.default_rng(3)
    c, r = random_clump(rng, 5)
    cid, mids = O.bodies.appendClumped(make_spheres(c, r))
    cy.set_clump_velocity(cid, (0.3, -0.1, 0.2), (1.0, 2.0, -0.5))
    st = O.bodies[cid].state
    v0, w0, c0 = vec(st.vel), vec(st.angVel), vec(st.pos)
    cy.correct_clump(cid)
    st = O.bodies[cid].state
    c1 = vec(st.pos)
    assert np.linalg.norm(c1 - c0) > 1e-4  # the centre of mass did move
    assert np.allclose(vec(st.angVel), w0, rtol=1e-14)
    assert np.allclose(vec(st.vel), v0 + np.cross(w0, c1 - c0), rtol=1e-14, atol=1e-15)
    # angMom is consistent with the exact tensor (YADE 2023 integrates angMom)
    mp = clumpprops.mass_properties(c, r, PAPER_RHO)
    assert np.allclose(vec(st.angMom), mp.inertia @ w0, rtol=1e-12, atol=0)


def test_replace_by_clumps(scene):
    O.bodies.append([utils.sphere((k * 0.5, 0, 0), 0.1) for k in range(6)])
    tpl = [utils.clumpTemplate(relRadii=[1, 0.8, 0.6], relPositions=[[0, 0, 0], [0.9, 0, 0], [0.4, 0.7, 0.2]])]
    ret = cy.replace_by_clumps(tpl, [1.0])
    assert len(ret) == 6
    for cid, mids in ret:
        assert len(mids) == 3 and sorted(mids) == cy.sphere_member_ids(cid)
        c = np.array([vec(O.bodies[m].state.pos) for m in mids])
        r = np.array([O.bodies[m].shape.radius for m in mids])
        assert_state_matches(O.bodies[cid].state, clumpprops.mass_properties(c, r, PAPER_RHO))


def test_text_clumps(scene, tmp_path):
    f = tmp_path / "clumps.txt"
    f.write_text("#format x_y_z_r_clumpId\n0 0 0 .1 0\n.12 0 0 .08 0\n.05 .09 0 .07 0\n1 0 0 .1 1\n1.1 0 0 .1 1\n")
    ret = cy.text_clumps(str(f), shift=(0, 0, 1), scale=2.0, material="mat")
    assert [len(m) for _, m in ret] == [3, 2]
    c = 2.0 * np.array([[0, 0, 0], [0.12, 0, 0], [0.05, 0.09, 0]]) + [0, 0, 1]
    r = 2.0 * np.array([0.1, 0.08, 0.07])
    assert_state_matches(O.bodies[ret[0][0]].state, clumpprops.mass_properties(c, r, PAPER_RHO))
    for (cid, mids), nn in zip(ret, [3, 2]):
        assert O.bodies[cid].mask == O.bodies[mids[0]].mask


def test_append_clumps_batch_equals_single(scene):
    rng = np.random.default_rng(11)
    geo = [random_clump(rng, n, origin=(k, 0, 0)) for k, n in enumerate([2, 3, 7])]
    ret = cy.append_clumps([make_spheres(c, r) for c, r in geo])
    assert len(ret) == len(geo)
    for (cid, _), (c, r) in zip(ret, geo):
        assert_state_matches(O.bodies[cid].state, clumpprops.mass_properties(c, r, PAPER_RHO))


# ---------------------------------------------------------------- never a contact


def _pairs(sphere_of_clump):
    """Interacting pairs as (clump index, member index) labels, so two scenes can be compared."""
    out = set()
    for i in O.interactions:
        if not i.isReal:
            continue
        a, b = sphere_of_clump.get(i.id1, ("x", i.id1)), sphere_of_clump.get(i.id2, ("x", i.id2))
        out.add(tuple(sorted([a, b], key=str)))
    return out


def _contact_scene(correct):
    fresh_scene()
    rng = np.random.default_rng(5)
    label = {}
    O.bodies.append(utils.wall(0.0, axis=2, material="mat"))
    O.bodies.append(utils.box((0.4, 0.4, 0.05), (0.2, 0.2, 0.05), material="mat"))
    O.bodies.append(utils.facet([(-1, -1, 0.02), (2, -1, 0.02), (-1, 2, 0.02)], material="mat"))
    for k in range(12):  # a tight pile: many sphere-sphere, sphere-wall, sphere-box, sphere-facet contacts
        c, r = random_clump(rng, 4, origin=(0.2 * (k % 4), 0.2 * (k // 4), 0.08))
        spheres = make_spheres(c, r)
        cid, mids = (cy.append_clump if correct else O.bodies.appendClumped)(spheres)
        label.update({m: (k, j) for j, m in enumerate(mids)})
    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb(), Bo1_Facet_Aabb(), Bo1_Wall_Aabb()]),
        InteractionLoop(
            [Ig2_Sphere_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
            [Ip2_FrictMat_FrictMat_MindlinPhys()],
            [Law2_ScGeom_MindlinPhys_Mindlin()],
        ),
        NewtonIntegrator(gravity=(0, 0, -9.81), exactAsphericalRot=True),
    ]
    O.dt = 1e-5
    O.run(20, True)
    return label


def test_correction_never_collides_and_network_unchanged(scene):
    label = _contact_scene(correct=True)
    corr = {cy.correction_id(b.id) for b in O.bodies if b.isClump}
    assert len(corr) == 12
    for i in O.interactions.all():
        assert i.id1 not in corr and i.id2 not in corr
    for k in corr:
        assert O.bodies[k].bound is None and not O.bodies[k].bounded
    for b in O.bodies:  # after 20 steps with contacts the clumps are still exact for where their spheres are
        if b.isClump:
            assert max(cy.clump_errors(b.id).values()) < 1e-12
    with_corr = _pairs(label)
    label0 = _contact_scene(correct=False)
    without = _pairs(label0)
    assert len(with_corr) > 20  # the scene does have contacts
    assert with_corr == without


def test_gravity_engine_acts_on_exact_mass_through_exact_com(scene):
    rng = np.random.default_rng(9)
    c, r = random_clump(rng, 6)
    cid, _ = cy.append_clump(make_spheres(c, r))
    O.engines = [ForceResetter(), GravityEngine(gravity=(0, 0, -9.81)), NewtonIntegrator(damping=0, exactAsphericalRot=True)]
    O.dt = 1e-4
    O.run(100, True)
    st = O.bodies[cid].state
    assert np.allclose(vec(st.vel), [0, 0, -9.81 * 100 * 1e-4], rtol=1e-12, atol=1e-15)
    # member weights m_i g plus the correction's m_c g: no torque about the exact centre of mass
    assert np.max(np.abs(vec(st.angVel))) < 1e-12


# ---------------------------------------------------------------- bad input: clear error, scene unchanged


def _bad_scene():
    fresh_scene()
    O.materials.append(FrictMat(density=2 * PAPER_RHO, label="heavy"))
    cid, mids = O.bodies.appendClumped(make_spheres(*paper_dimer()))
    lone = O.bodies.append(utils.sphere((1, 0, 0), 0.1))
    box_clump, _ = O.bodies.appendClumped([utils.sphere((2, 0, 0), 0.1), utils.box((2.1, 0, 0), (0.05, 0.05, 0.05))])
    mixed, _ = O.bodies.appendClumped([utils.sphere((3, 0, 0), 0.1, material="mat"), utils.sphere((3.1, 0, 0), 0.1, material="heavy")])
    good, _ = cy.append_clump(make_spheres(*paper_dimer()))
    return dict(cid=cid, member=mids[0], lone=lone, box_clump=box_clump, mixed=mixed, good=good)


@pytest.mark.parametrize(
    "what, pattern",
    [
        ("lone", r"body #{lone} is not a clump"),
        ("member", r"body #{member} is not a clump"),
        ("missing", r"body #999 does not exist"),
        ("negative", r"body #-1 does not exist"),
        ("box_clump", r"clump #{box_clump}: member #\d+ is not a sphere \(Box\)"),
        ("mixed", r"clump #{mixed}: member spheres have different densities"),
    ],
)
def test_bad_clump_ids(scene, what, pattern):
    ids = _bad_scene()
    ids.update(missing=999, negative=-1)
    before = scene_snapshot()
    # a valid clump first in the list: it must not be corrected either (all-or-nothing)
    with pytest.raises(cy.ClumpAdapterError, match=pattern.format(**ids)):
        cy.correct_clumps([ids["cid"], ids[what]])
    assert scene_snapshot() == before
    with pytest.raises(cy.ClumpAdapterError, match=pattern.format(**ids)):
        cy.correct_clump(ids[what])
    assert scene_snapshot() == before
    if what in ("box_clump", "mixed"):
        with pytest.raises(cy.ClumpAdapterError):
            cy.correct_all_clumps()
        assert scene_snapshot() == before


def test_bad_append_input(scene):
    _bad_scene()
    before = scene_snapshot()
    good = make_spheres(*paper_dimer())
    cases = [
        ([good[0], utils.box((0, 0, 0), (1, 1, 1))], r"item 1: not a sphere \(Box\)"),
        ([good[0], O.bodies[0]], r"item 1: body #0 is already in a scene"),
        ([good[0], good[0]], r"same Body object"),
        ([good[0], utils.sphere((0, 0, 0.05), 0.05, material="heavy")], r"different densities"),
        ([], r"is empty"),
    ]
    for spheres, pattern in cases:
        with pytest.raises(cy.ClumpAdapterError, match=pattern):
            cy.append_clump(spheres)
        assert scene_snapshot() == before
    # a batch whose second clump is bad appends nothing
    with pytest.raises(cy.ClumpAdapterError, match=r"clump 1 of the input"):
        cy.append_clumps([make_spheres(*paper_dimer()), [utils.box((0, 0, 0), (1, 1, 1))]])
    assert scene_snapshot() == before
    # a method that cannot do the geometry (pairwise with a triple overlap) fails before any change
    c, r = random_clump(np.random.default_rng(1), 6)
    with pytest.raises(cy.ClumpAdapterError, match="could not be computed"):
        cy.append_clump(make_spheres(c, r), method="pairwise")
    assert scene_snapshot() == before


def test_inspection_helpers(scene):
    cid, mids = cy.append_clump(make_spheres(*paper_dimer()))
    corr = cy.correction_id(cid)
    assert cy.is_correction(O.bodies[corr]) and not cy.is_correction(O.bodies[mids[0]])
    assert cy.sphere_member_ids(cid) == mids
    err = cy.clump_errors(cid)
    assert max(err.values()) < 1e-13
    yid, _ = O.bodies.appendClumped(make_spheres(*paper_dimer()))
    assert cy.correction_id(yid) is None
    assert cy.clump_errors(yid)["mass"] == pytest.approx(0.185, abs=1e-3)


@pytest.mark.parametrize(
    "centers, radii",
    [
        ([[0.1, 0.2, 0.3]], [0.05]),  # one sphere
        ([[0, 0, 0], [0.1, 0, 0]], [0.05, 0.05]),  # touching: no overlap, correction is round-off only
        ([[0, 0, 0], [0.3, 0.1, 0], [0, 0.2, 0.2]], [0.05, 0.07, 0.03]),  # apart
        ([[0, 0, 0], [1e-9, 0, 0]], [0.05, 0.05]),  # nearly coincident
        ([[0, 0, 0], [0.0, 0, 0.02]], [0.05, 0.01]),  # one sphere inside the other
    ],
)
def test_degenerate_clumps(scene, centers, radii):
    c, r = np.array(centers, float), np.array(radii, float)
    mp = clumpprops.mass_properties(c, r, PAPER_RHO)
    cid, mids = cy.append_clump(make_spheres(c, r))
    assert_state_matches(O.bodies[cid].state, mp)
    O.bodies.updateClumpProperties(discretization=0)
    assert_state_matches(O.bodies[cid].state, mp)
    corr = O.bodies[cy.correction_id(cid)]
    # the correction stays inside the clump (it is the excess of the summed over the union)
    reach = np.max(np.linalg.norm(c - mp.center_of_mass, axis=1) + r)
    assert np.linalg.norm(vec(corr.state.pos) - mp.center_of_mass) <= reach * (1 + 1e-12)


def test_public_names_and_their_argument_names():
    """Every name of ``__all__`` and every ``cy.<name>`` of docs/yade_adapter.md exists; public
    functions take snake_case arguments, except the drop-ins that mirror a YADE function, which keep
    its camelCase keywords and say so."""
    import inspect
    import re
    from pathlib import Path

    mirrors = {"text_clumps": {"fileName"}, "erase": {"eraseClumpMembers"}, "update_clump_properties": {"excludeList"}}
    for name in cy.__all__:
        obj = getattr(cy, name)
        if inspect.isfunction(obj):
            camel = {p for p in inspect.signature(obj).parameters if p != p.lower()}
            assert camel == mirrors.get(name, set()), name
            assert name not in mirrors or "camelCase" in obj.__doc__, name
    doc = (Path(__file__).resolve().parents[1] / "docs" / "yade_adapter.md").read_text()
    used = set(re.findall(r"\bcy\.([a-zA-Z]\w*)", doc))
    assert {"append_clump", "install_guards", "check", "unguarded"} <= used
    assert not [n for n in used if not hasattr(cy, n)]
