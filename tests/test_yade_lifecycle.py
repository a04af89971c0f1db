"""A corrected clump through its whole life in real YADE (2023.02a and 2025.2).

For every operation the clump either stays exact (YADE's state checked against the library, and
``cy.check()`` clean) or the adapter raises ``ClumpAdapterError`` naming the clump before
anything changes.  Where YADE's own call does something wrong with a corrected clump, the same
call made unguarded (``cy.unguarded()``: YADE as if the adapter were not loaded) is the
negative control, so each test can fail.
"""
import signal
import subprocess
import sys
import textwrap
import warnings

import numpy as np
import pytest

from _yadehelpers import (  # noqa: F401  (scene: a fixture)
    O, assert_exact, exact_of, scene, PAPER_D, PAPER_RHO, assert_state_matches, fresh_scene, is_yade_2023, make_spheres, random_clump,
    run_yade_script, scene_snapshot, vec, yade, utils,
)

import clumpprops
from clumpprops import yade as cy
from clumpprops.yade import build
from yade.wrapper import (
    Body, CpmMat, CpmStateUpdater, ForceResetter, FrictMat, GravityEngine, InsertionSortCollider, JCFpmMat,
    NewtonIntegrator, Shape, VTKRecorder, Bo1_Sphere_Aabb,
)

cy.install_guards()  # these tests check YADE's O.bodies methods as the guards route them

G = 9.81



def dimer(dx=0.0, D=PAPER_D / 2):
    d = PAPER_D
    return np.array([[dx, 0, -D / 2], [dx, 0, D / 2]]), np.array([d / 2, d / 2])


def trimer(dx=0.0, s=0.03):
    """Three spheres sharing a region (triple overlap): heavy overlap, large negative correction."""
    d = PAPER_D
    return np.array([[dx, 0, -s], [dx, 0, s], [dx, s, 0]]), np.array([d / 2, d / 2, d / 2])




def free_bodies():
    return [b for b in O.bodies if b is not None and not b.isClump and not b.isClumpMember]


# ---------------------------------------------------------------- releaseFromClump


def test_release_keeps_clump_and_released_sphere_exact(scene):
    c, r = trimer()
    cid, mids = cy.append_clump(make_spheres(c, r))
    cy.set_clump_velocity(cid, (0.5, 0, 0), (0, 0, 2.0))
    st = O.bodies[cid].state
    c0, v0, w0 = vec(st.pos), vec(st.vel), vec(st.angVel)
    cy.release(mids[2], cid)
    assert sorted(cy.sphere_member_ids(cid)) == mids[:2]
    assert_exact(cid)
    b = O.bodies[mids[2]]
    assert not b.isClumpMember and b.state.mass == pytest.approx(PAPER_RHO * 4 / 3 * np.pi * r[2] ** 3, rel=1e-14)
    # it leaves with the clump's rigid-body velocity at its position
    assert np.allclose(vec(b.state.vel), v0 + np.cross(w0, c[2] - c0), rtol=1e-12, atol=1e-15)
    assert np.allclose(vec(O.bodies[cid].state.angVel), w0, rtol=1e-14)
    # the raw YADE call is routed through the adapter as well
    O.bodies.addToClump([mids[2]], cid)
    O.bodies.releaseFromClump(mids[2], cid)
    assert_exact(cid)


def test_release_negative_control_yade_keeps_stale_correction(scene):
    """The issue's numbers: YADE's own release from the corrected paper dimer leaves 0.972 kg, not 1.414 kg."""
    c, r = dimer()
    cid, mids = cy.append_clump(make_spheres(c, r))
    before = scene_snapshot()
    with pytest.raises(cy.ClumpAdapterError, match=rf"clump #{cid}: releasing body #{mids[0]} would leave 1 sphere"):
        cy.release(mids[0], cid)  # YADE refuses this for an uncorrected dimer too
    with pytest.raises(cy.ClumpAdapterError, match=rf"clump #{cid}"):
        O.bodies.releaseFromClump(mids[0], cid)  # guarded
    assert scene_snapshot() == before
    with cy.unguarded():
        O.bodies.releaseFromClump(mids[0], cid)
    m_sphere = PAPER_RHO * 4 / 3 * np.pi * r[0] ** 3
    assert m_sphere == pytest.approx(1.414, abs=1e-3)
    assert O.bodies[cid].state.mass == pytest.approx(0.972, abs=1e-3)  # sphere + stale correction
    rep = cy.check()
    assert [c for c, _ in rep.stale] == [cid] and "fingerprint" in rep.stale[0][1]


def test_release_refusals_raise_and_change_nothing(scene):
    c, r = trimer()
    cid, mids = cy.append_clump(make_spheres(c, r))
    other = O.bodies.append(utils.sphere((3, 0, 0), 0.05, material="mat"))
    corr = cy.correction_id(cid)
    before = scene_snapshot()
    for bid, pattern in [(other, "is not a member"), (corr, "correction member"), (999, "does not exist")]:
        with pytest.raises(cy.ClumpAdapterError, match=pattern):
            cy.release(bid, cid)
        assert scene_snapshot() == before
    # an uncorrected clump: YADE's refusal (a warning it carries on after) becomes an error
    yid, ymids = O.bodies.appendClumped(make_spheres(*dimer(2.0)))
    with pytest.raises(cy.ClumpAdapterError, match=rf"clump #{yid}"):
        cy.release(ymids[0], yid)


RELEASE_ABORT = """
O.bodies.releaseFromClump(mids[0], cid)  # YADE's own: no guards installed in this process
print("survived", O.bodies[cid].state.mass, flush=True)
"""


def nested_trimer():
    """Two small spheres inside a big one: the union is the big sphere; releasing the big sphere from
    YADE's clump sums the small ones with the stale correction, M = -5.6e-17."""
    return np.array([[0, 0, 0], [0, 0, -0.01], [0, 0, 0.01]]), np.array([PAPER_D / 2, 0.0125, 0.0125])


def test_release_heavy_overlap_never_aborts(scene):
    cid, mids = cy.append_clump(make_spheres(*nested_trimer()))
    O.bodies.releaseFromClump(mids[0], cid)  # guarded
    assert_exact(cid)
    assert 0 < O.bodies[cid].state.mass < 2 * PAPER_RHO * 4 / 3 * np.pi * 0.0125**3  # the two small spheres overlap


def test_release_heavy_overlap_negative_control_yade_aborts(tmp_path):
    """YADE's own release aborts the process (``Clump.cpp:241: Assertion 'M > 0' failed``, 2023.02a and
    2025.2): run in a subprocess."""
    p = run_yade_script(tmp_path, RELEASE_ABORT)
    assert p.returncode == -6 and "M > 0' failed" in p.stderr, (p.returncode, p.stdout[-500:], p.stderr[-500:])


# ---------------------------------------------------------------- addToClump


def test_add_to_clump_spheres_and_corrected_clumps(scene):
    c, r = trimer()
    cid, mids = cy.append_clump(make_spheres(c, r))
    s = O.bodies.append(utils.sphere((0.06, 0.06, 0), 0.05, material="mat"))
    cy.set_clump_velocity(cid, (0, 0.2, 0), (1.0, 0, 0))
    w0 = vec(O.bodies[cid].state.angVel)
    cy.add_to_clump([s], cid)
    assert sorted(cy.sphere_member_ids(cid)) == sorted(mids + [s])
    assert_exact(cid)
    assert np.allclose(vec(O.bodies[cid].state.angVel), w0, rtol=1e-14)
    # a corrected clump merged in: one correction remains, the other clump body is gone
    c2, r2 = dimer(0.1)
    cid2, mids2 = cy.append_clump(make_spheres(c2, r2))
    corr2 = cy.correction_id(cid2)
    O.bodies.addToClump([cid2], cid)  # guarded
    assert O.bodies[cid2] is None and O.bodies[corr2] is None
    assert sorted(cy.sphere_member_ids(cid)) == sorted(mids + [s] + mids2)
    assert_exact(cid)
    assert all(not cy.is_correction(b) for b in free_bodies())


def test_add_to_clump_negative_control_and_refusals(scene):
    c, r = trimer()
    cid, mids = cy.append_clump(make_spheres(c, r))
    heavy = FrictMat(density=2 * PAPER_RHO, label="heavy")
    O.materials.append(heavy)
    s_heavy = O.bodies.append(utils.sphere((0.05, 0, 0), 0.05, material="heavy"))
    box = O.bodies.append(utils.box((0.05, 0, 0), (0.02, 0.02, 0.02), material="mat"))
    before = scene_snapshot()
    for bid, pattern in [(s_heavy, "different densities"), (box, r"not a sphere or a clump of spheres \(Box\)"),
                         (mids[0], "already part of it")]:
        with pytest.raises(cy.ClumpAdapterError, match=rf"clump #{cid}.*{pattern}"):
            cy.add_to_clump([bid], cid)
        assert scene_snapshot() == before
    s = O.bodies.append(utils.sphere((0.06, 0.06, 0), 0.05, material="mat"))
    with cy.unguarded():
        O.bodies.addToClump([s], cid)
    # YADE summed the new sphere with the old correction: the mass is off
    assert abs(O.bodies[cid].state.mass / exact_of(cid).mass - 1) > 1e-3
    assert not cy.check().ok


# ---------------------------------------------------------------- erase


def test_erase_clump_leaves_no_correction_behind(scene):
    c, r = dimer()
    cid, mids = cy.append_clump(make_spheres(c, r))
    corr = cy.correction_id(cid)
    O.bodies.erase(cid)  # guarded
    assert O.bodies[cid] is None and O.bodies[corr] is None
    assert sorted(b.id for b in free_bodies()) == mids
    assert all(b.state.mass > 0 for b in O.bodies if b is not None)
    rep = cy.check()
    assert rep.ok and not rep.exact
    # erasing with its members
    cid, mids = cy.append_clump(make_spheres(*dimer(1.0)))
    corr = cy.correction_id(cid)
    cy.erase(cid, True)
    assert all(O.bodies[i] is None for i in [cid, corr] + mids)
    assert cy.check().ok


def test_erase_clump_negative_control_negative_mass_body(scene):
    """YADE's own erase turns the correction into a free dynamic body of -0.44 kg that the energy sums see."""
    c, r = dimer()
    cid, mids = cy.append_clump(make_spheres(c, r))
    corr = cy.correction_id(cid)
    for i in mids:
        O.bodies[i].state.vel = (1.0, 0, 0)
    O.bodies[corr].state.vel = (1.0, 0, 0)
    with cy.unguarded():
        O.bodies.erase(cid)
    b = O.bodies[corr]
    assert b is not None and b.dynamic and not b.isClumpMember
    assert b.state.mass == pytest.approx(-0.4418, abs=1e-4)
    m_s = 2 * O.bodies[mids[0]].state.mass
    assert utils.kineticEnergy() == pytest.approx(0.5 * (m_s + b.state.mass), rel=1e-12)  # counted, negative
    rep = cy.check()
    assert [i for i, _ in rep.orphaned] == [corr] or sorted(i for i, _ in rep.orphaned) == sorted([corr, cid])


def test_erase_member_keeps_clump_exact(scene):
    c, r = trimer()
    cid, mids = cy.append_clump(make_spheres(c, r))
    corr = cy.correction_id(cid)
    O.bodies.erase(mids[0])  # guarded
    assert O.bodies[mids[0]] is None and sorted(cy.sphere_member_ids(cid)) == mids[1:]
    assert_exact(cid)
    cy.erase(mids[1])  # down to one sphere: YADE keeps a one-member clump; so does the adapter
    assert cy.sphere_member_ids(cid) == [mids[2]]
    assert_exact(cid)
    cy.erase(mids[2])  # the last sphere: the clump and its correction go
    assert O.bodies[cid] is None and O.bodies[corr] is None
    assert cy.check().ok
    with pytest.raises(cy.ClumpAdapterError, match="correction"):
        c2, m2 = cy.append_clump(make_spheres(*trimer(2.0)))
        cy.erase(cy.correction_id(c2))


def test_erase_member_negative_control(scene):
    c, r = trimer()
    cid, mids = cy.append_clump(make_spheres(c, r))
    with cy.unguarded():
        O.bodies.erase(mids[0])
    assert abs(O.bodies[cid].state.mass / exact_of(cid).mass - 1) > 0.05
    rep = cy.check()
    assert [c for c, _ in rep.stale] == [cid]


# ---------------------------------------------------------------- replaceByClumps


def test_replace_by_clumps_leaves_existing_corrected_clumps_alone(scene):
    cid, _ = cy.append_clump(make_spheres(*trimer(-2.0)))
    O.bodies.append([utils.sphere((k * 0.5, 0, 0), 0.1, material="mat") for k in range(4)])
    tpl = [utils.clumpTemplate(relRadii=[1, 0.8, 0.6], relPositions=[[0, 0, 0], [0.9, 0, 0], [0.4, 0.7, 0.2]])]
    ret = cy.replace_by_clumps(tpl, [1.0])
    assert len(ret) == 4 and cid not in [c for c, _ in ret]
    for c, _ in ret + [(cid, None)]:
        assert_exact(c)
    # YADE's own replaceByClumps leaves existing clumps alone too (only standalone spheres are replaced)
    O.bodies.append([utils.sphere((k * 0.5, 3, 0), 0.1, material="mat") for k in range(2)])
    O.bodies.replaceByClumps(tpl, [1.0], discretization=0)
    rep = cy.check()
    assert rep.ok and len(rep.exact) == 5 and len(rep.uncorrected) == 2


# ---------------------------------------------------------------- updateClumpProperties and gravity


def _fall(gravity_engine, steps=100, dt=1e-4):
    O.engines = [ForceResetter()] + (
        [GravityEngine(gravity=(0, 0, -G)), NewtonIntegrator(damping=0)] if gravity_engine
        else [NewtonIntegrator(damping=0, gravity=(0, 0, -G))]
    )
    O.dt = dt
    O.run(steps, True)
    return steps * dt


@pytest.mark.parametrize("discretization", [0, 5, 10])
@pytest.mark.parametrize("gravity_engine", [True, False])
def test_update_clump_properties_any_discretization_keeps_exact_fall(scene, discretization, gravity_engine):
    c, r = trimer()
    cid, _ = cy.append_clump(make_spheres(c, r))
    yid, _ = O.bodies.appendClumped(make_spheres(*trimer(1.0)))  # an uncorrected clump gets YADE's update
    O.bodies.updateClumpProperties(discretization=discretization)  # guarded
    assert_exact(cid)
    t = _fall(gravity_engine)
    assert vec(O.bodies[cid].state.vel)[2] == pytest.approx(-G * t, rel=1e-12)
    assert np.max(np.abs(vec(O.bodies[cid].state.angVel))) < 1e-12
    assert_exact(cid)
    if discretization:  # YADE's voxelised values for the uncorrected clump, as without the adapter
        assert abs(O.bodies[yid].state.mass / exact_of(yid).mass - 1) > 1e-3


def test_update_clump_properties_negative_control_falls_slow(scene):
    """The issue's numbers: YADE's default update (discretization=5) drops the correction from the mass,
    GravityEngine still applies m_c g: the clump falls at ~0.86 g."""
    c, r = dimer()
    cid, _ = cy.append_clump(make_spheres(c, r))
    with cy.unguarded():
        O.bodies.updateClumpProperties()
    t = _fall(True)
    a = -vec(O.bodies[cid].state.vel)[2] / t
    assert a / G == pytest.approx(0.86, abs=0.01)
    assert not cy.check().ok


def test_update_with_exclude_list(scene):
    cid, _ = cy.append_clump(make_spheres(*trimer()))
    yid, _ = O.bodies.appendClumped(make_spheres(*trimer(1.0)))
    m_y = O.bodies[yid].state.mass
    cy.update_clump_properties(excludeList=[yid], discretization=10)
    assert O.bodies[yid].state.mass == m_y  # excluded: untouched
    assert_exact(cid)


# ---------------------------------------------------------------- save / load, energy


def test_save_load_keeps_registry_and_exactness(scene, tmp_path):
    cids = [cy.append_clump(make_spheres(*random_clump(np.random.default_rng(k), 5, origin=(k, 0, 0))))[0] for k in range(3)]
    O.bodies.appendClumped(make_spheres(*dimer(5.0)))
    f = str(tmp_path / "s.yade.gz")
    O.save(f)
    O.saveTmp("t")
    for load in (lambda: O.load(f), lambda: O.loadTmp("t")):
        O.reset()
        assert cy.check().ok and not cy.check().exact
        load()
        rep = cy.check()
        assert rep.ok and sorted(rep.exact) == sorted(cids) and len(rep.uncorrected) == 1
        for cid in cids:
            assert_exact(cid)
        c = cids[0]
        m = cy.sphere_member_ids(c)
        O.bodies.erase(m[0])  # the loaded scene is guarded like the original
        assert_exact(c)


def test_kinetic_energy_and_energy_tracker(scene):
    c, r = random_clump(np.random.default_rng(2), 5)
    cid, _ = cy.append_clump(make_spheres(c, r))
    cy.set_clump_velocity(cid, (0.3, -0.2, 0.1), (1.0, 2.0, -0.5))
    mp = exact_of(cid)
    st = O.bodies[cid].state
    v, w = vec(st.vel), vec(st.angVel)
    E = 0.5 * mp.mass * v @ v + 0.5 * w @ mp.inertia @ w
    assert utils.kineticEnergy() == pytest.approx(E, rel=1e-12)
    O.engines = [ForceResetter(), NewtonIntegrator(damping=0)]
    O.trackEnergy = True
    O.dt = 1e-7
    O.run(1, True)
    st = O.bodies[cid].state
    v, w = vec(st.vel), vec(st.angVel)
    E1 = 0.5 * mp.mass * v @ v + 0.5 * w @ exact_of(cid).inertia @ w
    if is_yade_2023():  # O.energy['kinRot'] uses R^T I R for clumps in 2023.02a (yade-facts.md), corrected or not
        R = np.array([[st.ori.toRotationMatrix()[i, j] for j in range(3)] for i in range(3)])
        E1 = 0.5 * mp.mass * v @ v + 0.5 * w @ (R.T @ np.diag(vec(st.inertia)) @ R) @ w
    assert O.energy["kinetic"] == pytest.approx(E1, rel=1e-6)
    # erasing the clump leaves the spheres only: no negative-mass body in the sums
    cy.erase(cid)
    assert all(b.state.mass > 0 for b in O.bodies if b is not None)


# ---------------------------------------------------------------- materials, masks, VTK


def test_correction_state_class_follows_material(scene):
    O.materials.append(CpmMat(density=2000.0, label="cpm"))
    O.materials.append(JCFpmMat(density=2000.0, young=1e7, label="jc"))
    ids = []
    for k, mat in enumerate(["cpm", "jc", "mat"]):
        ids.append(cy.append_clump([utils.sphere((k, 0, 0), 0.1, material=mat), utils.sphere((k, 0, 0.1), 0.1, material=mat)])[0])
    kinds = [type(O.bodies[cy.correction_id(c)].state).__name__ for c in ids]
    assert kinds == ["CpmState", "JCFpmState", "State"]
    O.engines = [ForceResetter(), NewtonIntegrator(damping=0), CpmStateUpdater(realPeriod=0, iterPeriod=1)]
    O.dt = 1e-5
    O.run(3, True)  # YADE checks material/state pairs of every body
    assert cy.check().ok


STATE_CLASS = textwrap.dedent(
    """
    import os
    os.environ["OMP_NUM_THREADS"] = "1"
    import yade
    from yade import utils
    from yade.wrapper import Body, CpmMat, CpmStateUpdater, ForceResetter, NewtonIntegrator, Shape
    O = yade.O
    O.materials.append(CpmMat(density=2000.0, label="cpm"))
    corr = Body()
    corr.shape, corr.material, corr.bounded = Shape(), O.materials[0], False
    corr.state.mass = -0.1
    O.bodies.appendClumped([utils.sphere((0, 0, z), 0.1, material="cpm") for z in (0, 0.1)] + [corr])
    O.engines = [ForceResetter(), NewtonIntegrator(damping=0), CpmStateUpdater(realPeriod=0, iterPeriod=1)]
    O.dt = 1e-5
    try:
        O.run(3, True)
    except RuntimeError:
        pass    # YADE rethrows the runner thread's error in wait(), unless the thread stopped first
    print("iterations", O.iter)
    """
)


def test_correction_state_class_negative_control(tmp_path):
    """A correction with a plain State (the adapter before this fix) stops YADE with a CpmMat clump
    (a fresh process: YADE checks material/state pairs once per scene)."""
    script = tmp_path / "state.py"
    script.write_text(STATE_CLASS)
    p = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert "doesn't correspond to Body::state type State" in p.stdout + p.stderr, p.stderr[-1000:]
    # the scene stopped at the check, before its 3 steps (whether wait() rethrew the runner thread's
    # error is a race in YADE: a CI run under load printed after O.run once)
    its = [int(ln.split()[1]) for ln in p.stdout.splitlines() if ln.startswith("iterations ")]
    assert its and its[0] < 3, p.stdout[-1000:]


def test_mask_selected_engines(scene):
    """The correction carries the union of the mask bits of its spheres: a GravityEngine selecting
    the spheres by mask weighs the correction too (exact weight, no torque); one selecting other
    bodies sees neither."""
    c, r = trimer()
    a_id, _ = cy.append_clump([utils.sphere(tuple(x), rr, material="mat", mask=0b011) for x, rr in zip(c, r)])
    b_id, _ = cy.append_clump([utils.sphere(tuple(x), rr, material="mat", mask=0b100) for x, rr in zip(c + [2, 0, 0], r)])
    assert O.bodies[cy.correction_id(a_id)].mask == 0b011 and O.bodies[cy.correction_id(b_id)].mask == 0b100
    O.engines = [ForceResetter(), GravityEngine(gravity=(0, 0, -G), mask=0b010), NewtonIntegrator(damping=0)]
    O.dt = 1e-4
    O.run(100, True)
    assert vec(O.bodies[a_id].state.vel)[2] == pytest.approx(-G * 0.01, rel=1e-12)
    assert np.max(np.abs(vec(O.bodies[a_id].state.angVel))) < 1e-12
    assert np.all(vec(O.bodies[b_id].state.vel) == 0)
    # mixed masks: the union of the bits
    c2, m2 = cy.append_clump([utils.sphere((4, 0, 0), 0.1, material="mat", mask=0b110),
                              utils.sphere((4, 0, 0.1), 0.1, material="mat", mask=0b011)])
    assert O.bodies[cy.correction_id(c2)].mask == 0b111


# VTKRecorder's recorders that write interactions (r-intrs.*.vtp): "intr" and the ones that turn it on.
VTK_INTR_RECORDERS = ["all", "intr", "cpm", "jcfpm", "wpm", "liquidcontrol"]
# Every other recorder of YADE 2023.02a and 2025.2.
VTK_OTHER_RECORDERS = ["spheres", "velocity", "facets", "boxes", "colors", "mass", "ids", "mask", "clumpId", "materialId",
                       "stress", "force", "coordNumber", "bstresses", "cracks", "moments", "lsBodies"]


def touching_trimers(append):
    """Three trimers 0.12 m apart: spheres of neighbouring clumps overlap, so there are contacts."""
    return [append(make_spheres(*trimer(0.12 * k))) for k in range(3)]


def contact_engines(*extra):
    from yade.wrapper import (Ig2_Sphere_Sphere_ScGeom, InteractionLoop, Ip2_FrictMat_FrictMat_FrictPhys,
                              Law2_ScGeom_FrictPhys_CundallStrack)

    return [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb()]),
            InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()], [Law2_ScGeom_FrictPhys_CundallStrack()]),
            NewtonIntegrator(damping=0), *extra]


def test_vtk_export_sees_spheres_only(scene, tmp_path, monkeypatch):
    """VTKRecorder with every recorder that does not write interactions (those can crash in YADE
    itself: test_vtk_recorder_interactions_*), and export.VTKExporter for spheres and contacts:
    only the 9 spheres are exported, with their own mass; the correction never appears."""
    from yade import export

    monkeypatch.chdir(tmp_path)  # "cracks" looks for its input in the working directory
    cids = touching_trimers(lambda s: cy.append_clump(s)[0])
    O.engines = contact_engines(VTKRecorder(fileName=str(tmp_path / "r-"), recorders=VTK_OTHER_RECORDERS, iterPeriod=1))
    O.dt = 1e-5
    O.run(2, True)
    vtu = sorted(tmp_path.glob("r-spheres*.vtu"))
    assert len(vtu) == 2 and not list(tmp_path.glob("r-intrs*"))
    head = vtu[-1].read_text(errors="replace")
    assert 'NumberOfPoints="9"' in head and 'Name="mass"' in head and 'Name="clumpId"' in head
    ex = export.VTKExporter(str(tmp_path / "e"))
    ex.exportSpheres(what=dict(mass="b.state.mass", clump="b.clumpId"))
    text = next(tmp_path.glob("e-spheres*.vtk")).read_text()
    assert "POINTS 9 " in text
    masses = [float(x) for x in text.split("SCALARS mass double 1\nLOOKUP_TABLE default\n")[1].split()[:9]]
    assert masses == pytest.approx([O.bodies[i].state.mass for i in cy.sphere_member_ids(cids[0])] * 3, rel=1e-6)
    n_contacts = len([i for i in O.interactions if i.isReal])
    assert n_contacts >= 2  # spheres of neighbouring clumps
    ex.exportInteractions(what=dict(fn="i.phys.normalForce.norm()"))
    assert f"LINES {n_contacts} " in next(tmp_path.glob("e-intrs*.vtk")).read_text()
    assert cy.check().ok


# YADE's VTKRecorder (Debian's builds of 2023.02a and 2025.2 have YADE_MPI) has two int members,
# rank and commSize, that its constructor never initialises (they are set only when
# parallelMode=True). Its interaction writer then tests `if (rank == 0)` without checking
# parallelMode and writes a parallel .pvtp summary with commSize (garbage) pieces:
# vtkXMLWriter::WriteCellDataAppendedData segfaults. Whether it happens depends on what the
# heap held at the recorder's address (import order, earlier allocations): random. A script
# makes it deterministic: it frees a chunk of sizeof(VTKRecorder) = 0x128 bytes filled with
# chosen bytes just before the recorder is built, and glibc's allocator (LIFO per-thread cache)
# hands that chunk to `new VTKRecorder`. 0xFF bytes: rank = -1, the writer behaves; zero bytes: rank = 0.
VTK_RECORDER = textwrap.dedent(
    """
    import ctypes, os, sys
    os.environ["OMP_NUM_THREADS"] = "1"
    fill, corrected, out, recorders = sys.argv[1], sys.argv[2] == "1", sys.argv[3], sys.argv[4].split(",")
    import yade
    from yade import utils
    from yade.wrapper import (Bo1_Sphere_Aabb, ForceResetter, FrictMat, Ig2_Sphere_Sphere_ScGeom, InsertionSortCollider,
                              InteractionLoop, Ip2_FrictMat_FrictMat_FrictPhys, Law2_ScGeom_FrictPhys_CundallStrack,
                              NewtonIntegrator, VTKRecorder)
    O = yade.O
    O.materials.append(FrictMat(density=1140.0, young=1e7, poisson=0.4, label="mat"))
    r = 0.1333 / 2
    for k in range(3):
        x = 0.12 * k
        spheres = [utils.sphere(c, r, material="mat") for c in ((x, 0, -0.03), (x, 0, 0.03), (x, 0.03, 0))]
        if corrected:
            from clumpprops import yade as cy
            cy.append_clump(spheres)
        else:  # plain YADE: clumpprops is not even imported
            O.bodies.appendClumped(spheres)
    libc = ctypes.CDLL(None)
    libc.malloc.restype = ctypes.c_void_p
    libc.free.argtypes = [ctypes.c_void_p]
    chunk = libc.malloc(0x128)
    ctypes.memset(chunk, 0xFF if fill == "ff" else 0, 0x128)
    libc.free(chunk)
    recorder = VTKRecorder(fileName=os.path.join(out, "r-"), recorders=recorders, iterPeriod=1)
    O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb()]),
                 InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                                 [Law2_ScGeom_FrictPhys_CundallStrack()]),
                 NewtonIntegrator(damping=0), recorder]
    O.dt = 1e-5
    O.run(2, True)
    assert not corrected or cy.check().ok
    print("contacts", len([i for i in O.interactions if i.isReal]))
    print("ran")
    """
)


def run_vtk_recorder(tmp_path, fill, corrected, recorders):
    script = tmp_path / "vtk.py"
    script.write_text(VTK_RECORDER)
    out = tmp_path / "out"
    out.mkdir()
    p = subprocess.run([sys.executable, str(script), fill, "1" if corrected else "0", str(out), ",".join(recorders)],
                       capture_output=True, text=True, timeout=180, cwd=tmp_path)
    return p, out


@pytest.mark.parametrize("recorders", [["all"], VTK_INTR_RECORDERS[1:]], ids=["all", "intr-cpm-jcfpm-wpm-liquidcontrol"])
def test_vtk_recorder_interactions_with_corrected_clumps(tmp_path, recorders):
    """With YADE's uninitialised rank made nonzero, VTKRecorder(recorders=['all']) and every
    recorder that writes interactions run on corrected clumps in contact: 9 spheres (no
    correction) with their mass and clump ids, the contacts as lines, the clumps exact after."""
    p, out = run_vtk_recorder(tmp_path, "ff", True, recorders)
    assert p.returncode == 0 and "ran" in p.stdout, p.stderr[-2000:]
    n_contacts = int(p.stdout.split("contacts")[1].split()[0])
    assert n_contacts >= 2
    intrs = sorted(out.glob("r-intrs.*.vtp"))
    assert len(intrs) == 2 and not list(out.glob("*.pvtp"))
    assert f'NumberOfLines="{n_contacts}"' in intrs[-1].read_text(errors="replace")
    if recorders == ["all"]:
        head = sorted(out.glob("r-spheres.*.vtu"))[-1].read_text(errors="replace")
        assert 'NumberOfPoints="9"' in head and 'Name="mass"' in head and 'Name="clumpId"' in head


@pytest.mark.parametrize("recorders, crashes", [(["intr"], True), (["all"], True), (VTK_OTHER_RECORDERS, False)],
                         ids=["intr", "all", "others"])
def test_vtk_recorder_interactions_crash_in_yade_itself(tmp_path, recorders, crashes):
    """Negative control, the limit of the adapter: plain YADE (clumpprops not imported, no
    correction) segfaults in VTKRecorder's interaction writer when the recorder's uninitialised
    rank happens to be 0; the other recorders never read it. This fails (and docs/yade_adapter.md
    must be updated) once a YADE initialises rank or checks parallelMode there."""
    p, out = run_vtk_recorder(tmp_path, "zero", False, recorders)
    if crashes:
        assert p.returncode == -signal.SIGSEGV and "ran" not in p.stdout, (p.returncode, p.stderr[-2000:])
        assert list(out.glob("r-intrs_0_0.vtp"))  # the piece of the parallel file it should never have written
    else:
        assert p.returncode == 0 and "ran" in p.stdout, p.stderr[-2000:]


# ---------------------------------------------------------------- text_clumps: a drop-in for ymport.textClumps


def test_text_clumps_matches_ymport_arguments(scene, tmp_path):
    from yade import ymport
    from yade.minieigenHP import Quaternion, Vector3

    f = tmp_path / "c.txt"
    f.write_text("#format x_y_z_r_clumpId\n0 0 0 .1 0\n.12 0 0 .08 0\n.05 .09 0 .07 0\n1 0 0 .1 1\n1.1 0 0 .1 1\n")
    q = Quaternion(Vector3(1, 2, 3).normalized(), 0.7)
    args = (str(f), Vector3(0.5, -1, 2), 0, q, 1.5)
    ret_y = ymport.textClumps(*args, material="mat", mask=0b101)
    pos_y = [[vec(O.bodies[m].state.pos) for m in mids] for _, mids in ret_y]
    O.bodies.clear()
    ret = cy.text_clumps(*args, material="mat", mask=0b101)
    assert [len(m) for _, m in ret] == [len(m) for _, m in ret_y] == [3, 2]
    for (cid, mids), py in zip(ret, pos_y):
        assert np.allclose([vec(O.bodies[m].state.pos) for m in mids], py, rtol=0, atol=1e-15)
        assert O.bodies[cid].mask == 0b101 and O.bodies[mids[0]].mask == 0b101
        assert_exact(cid)
    assert cy.text_clumps(str(f), discretization=7, scale=2.0)  # keyword form too


def test_text_clumps_malformed_file_adds_nothing(scene, tmp_path):
    from clumpprops.io import ClumpFileError

    f = tmp_path / "bad.txt"
    f.write_text("0 0 0 .1 0\n1 0 0 .1 1\n1 0 x .1 1\n")
    n = len(O.bodies)
    with pytest.raises(ClumpFileError, match=r"bad.txt:3: z is not a number"):
        cy.text_clumps(str(f))
    assert len(O.bodies) == n


# ---------------------------------------------------------------- internals: no silent clamp, no warning, verified builds


def test_correction_terms_raises_instead_of_clamping():
    c, r = dimer()
    mp = clumpprops.mass_properties(c, r, PAPER_RHO)
    rho = [np.full(2, PAPER_RHO)]
    # a target centre of mass 1 m off: the correction would sit far outside the clump
    with pytest.raises(cy.ClumpAdapterError, match="clump 0 of the batch: the correction's centroid"):
        cy.correction_terms([c], [r], rho, [mp.mass], [mp.center_of_mass + [1.0, 0, 0]], [mp.inertia])
    with pytest.raises(cy.ClumpAdapterError, match="exceeds the summed spheres"):
        cy.correction_terms([c], [r], rho, [mp.mass * 2], [mp.center_of_mass], [mp.inertia])
    # not strict (sampled methods): no such check
    cy.correction_terms([c], [r], rho, [mp.mass * 2], [mp.center_of_mass], [mp.inertia], strict=False)


@pytest.mark.parametrize(
    "centers, radii",
    [
        ([[0.1, 0.2, 0.3]], [0.05]),
        ([[0, 0, 0], [0.1, 0, 0]], [0.05, 0.05]),
        ([[0, 0, 0], [0.3, 0.1, 0], [0, 0.2, 0.2]], [0.05, 0.07, 0.03]),
        ([[0, 0, 0], [0.0, 0, 0.02]], [0.05, 0.01]),
        ([[0, 0, -0.033325], [0, 0, 0.033325]], [0.06665, 0.06665]),
    ],
)
def test_correction_terms_no_runtime_warning(centers, radii):
    c, r = np.array(centers, float), np.array(radii, float)
    mp = clumpprops.mass_properties(c, r, PAPER_RHO)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m_c, off, w, V = cy.correction_terms([c], [r], [np.full(len(r), PAPER_RHO)], [mp.mass], [mp.center_of_mass], [mp.inertia])
    assert np.all(np.isfinite(off)) and np.all(np.isfinite(w))


def test_refusal_free_recorrection_of_one_sphere_clump(scene):
    """Re-correcting a one-sphere clump used to release and re-add the correction, which YADE refused
    (a warning it carried on after); now every YADE warning inside the adapter is an error, and none occurs."""
    cid, _ = cy.append_clump(make_spheres([[0.1, 0.2, 0.3]], [0.05]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cy.correct_clump(cid)
        cy.correct_clump(cid)
    assert_exact(cid)


def test_build_is_verified_against_the_target(scene, monkeypatch):
    """A build whose YADE state does not match the target raises naming the clump."""
    real = build._set_correction_state

    def off_by_a_gram(Y, st, m, p, w, q):
        real(Y, st, m + 1e-3, p, w, q)

    monkeypatch.setattr(build, "_set_correction_state", off_by_a_gram)
    yid, _ = O.bodies.appendClumped(make_spheres(*trimer()))
    with pytest.raises(cy.ClumpAdapterError, match=rf"clump #{yid}: YADE's state after the build differs"):
        cy.correct_clump(yid)


def test_check_reports_orphans_and_stale(scene):
    cid, mids = cy.append_clump(make_spheres(*trimer()))
    yid, _ = O.bodies.appendClumped(make_spheres(*dimer(2.0)))
    rep = cy.check()
    assert rep.ok and rep.exact == [cid] and rep.uncorrected == [yid]
    O.bodies[mids[0]].shape.radius *= 1.01  # a sphere changed behind the adapter's back
    rep = cy.check()
    assert [c for c, _ in rep.stale] == [cid]
    with pytest.raises(cy.ClumpAdapterError, match=rf"stale clump #{cid}"):
        cy.check(raise_on_error=True)
    cy.correct_clump(cid)
    assert cy.check().ok


def test_export_text_clumps_round_trip(scene, tmp_path):
    """YADE's export.textClumps writes %g (6 digits; ids >= 10**6 in exponent form, which the reader
    refuses); cy.export_text_clumps writes integers and every bit, so the clumps come back exact."""
    from yade import export

    rng = np.random.default_rng(8)
    geo = [random_clump(rng, n, origin=(k * 1.234567891, 0.1, 0)) for k, n in enumerate([2, 5])]
    ids = [cy.append_clump(make_spheres(c, r))[0] for c, r in geo]
    f = tmp_path / "exact.txt"
    assert cy.export_text_clumps(str(f)) == (2, 7)
    export.textClumps(str(tmp_path / "yade.txt"))
    O.bodies.clear()
    ret = cy.text_clumps(str(f), material="mat")
    for (cid, mids), (c, r) in zip(ret, geo):
        assert np.array_equal(np.array([vec(O.bodies[m].state.pos) for m in mids]), c)
        assert_exact(cid)
    # YADE's own file has 6 digits only
    yade_c = np.loadtxt(tmp_path / "yade.txt")[:, :3]
    assert np.max(np.abs(yade_c - np.concatenate([c for c, _ in geo]))) > 1e-9
