"""YADE's own ``O.bodies`` calls on corrected clumps: each one is exact, refused before YADE sees it,
or reported by ``cy.check()``; none aborts the process (real YADE, 2023.02a and 2025.2).

Every refusal is checked to leave the scene unchanged; where YADE itself would abort
(``Clump.cpp: Assertion 'M > 0' failed``) the call runs in a subprocess, guarded
(``cy.install_guards()``: refused, exit 0) and with YADE's own methods (the abort, the negative
control).  Importing the adapter and building clumps install nothing: that too runs in a fresh process.
"""
import numpy as np
import pytest

from _yadehelpers import (  # noqa: F401  (scene: a fixture)
    O, assert_exact, exact_of, scene, PAPER_D, PAPER_RHO, assert_state_matches, fresh_scene, is_yade_2023, make_spheres, run_yade_script,
    scene_snapshot, vec, utils,
)

import clumpprops
from clumpprops import yade as cy
from yade.wrapper import ForceResetter, FrictMat, GravityEngine, NewtonIntegrator

cy.install_guards()  # these tests check YADE's O.bodies methods as the guards route them

G = 9.81



def dimer(dx=0.0):
    d = PAPER_D
    return np.array([[dx, 0, -d / 4], [dx, 0, d / 4]]), np.array([d / 2, d / 2])




# ---------------------------------------------------------------- calls that abort YADE: subprocesses

ABORT_SCRIPT = """
corr = cy.correction_id(cid)
free = O.bodies.append(utils.sphere((1, 0, 0), 0.0125, material="m"))
plain, _ = O.bodies.appendClumped([utils.sphere((2, 0, z), 0.01, material="m") for z in (0, 0.01)])
guarded = sys.argv[1] == "guarded"
call = sys.argv[2]
if guarded:
    cy.install_guards()
def run():
    if call == "clump":                 # the issue's call: correction and a free sphere
        O.bodies.clump([corr, free], discretization=0)
    elif call == "addToClump_free_correction":   # a correction left free by YADE's own erase, added to a plain clump
        with cy.unguarded():
            O.bodies.erase(cid)
        O.bodies.addToClump([corr], plain, discretization=0)
    elif call == "appendClumped_correction_body":  # a body made like a correction, appended as a member
        from yade.wrapper import Body, Shape
        b = Body()
        b.shape, b.bounded, b.material = Shape(), False, O.materials[0]
        b.state.mass = -1.0
        O.bodies.appendClumped([utils.sphere((3, 0, 0), 0.0125, material="m"), b], discretization=0)
    elif call == "deleteClumpBody":
        O.bodies.deleteClumpBody(O.bodies[cid])
try:
    run()
except cy.ClumpAdapterError as exc:
    print("refused:", exc)
    print("check ok:", cy.check().ok if call != "addToClump_free_correction" else "n/a")
    print("bodies:", len(O.bodies))
    sys.exit(0)
print("no error")
print("orphaned:", [i for i, _ in cy.check().orphaned])
"""


def run_script(tmp_path, guarded, call):
    """The ABORT_SCRIPT call, with the guards installed (``guarded``) or YADE's own methods."""
    return run_yade_script(tmp_path, ABORT_SCRIPT, "guarded" if guarded else "unguarded", call)


ABORTING_CALLS = ["clump", "addToClump_free_correction", "appendClumped_correction_body"]


@pytest.mark.parametrize("call", ABORTING_CALLS)
def test_calls_that_abort_yade_are_refused(tmp_path, call):
    p = run_script(tmp_path, True, call)
    assert p.returncode == 0, (p.returncode, p.stdout[-500:], p.stderr[-800:])
    line = next(ln for ln in p.stdout.splitlines() if ln.startswith("refused:"))
    assert "correction" in line and len(line.splitlines()) == 1
    if call != "addToClump_free_correction":
        assert "check ok: True" in p.stdout
    assert "bodies: 9" in p.stdout  # 3 spheres, correction, clump; free sphere; plain clump of 2: nothing added


@pytest.mark.parametrize("call", ABORTING_CALLS)
def test_calls_that_abort_yade_negative_control(tmp_path, call):
    """The same calls made unguarded: YADE aborts the process (SIGABRT, ``M > 0`` assertion)."""
    p = run_script(tmp_path, False, call)
    assert p.returncode == -6 and "M > 0' failed" in p.stderr, (p.returncode, p.stdout[-500:], p.stderr[-500:])


NO_PATCH_SCRIPT = """
import types
from clumpprops.yade.guards import _GUARDED
BC = type(O.bodies)
def patched():
    return [n for n in _GUARDED if isinstance(getattr(BC, n), types.FunctionType)]
cy.correct_clump(cid)
O.bodies.erase(cy.append_clump([utils.sphere((5, 0, 0), 0.05, material="m")])[0])
ok = cy.check().ok
print("before:", patched(), cy.guards_installed(), ok)
print("install:", cy.install_guards(), cy.install_guards())
print("after:", len(patched()) == len(_GUARDED), cy.guards_installed())
"""


def test_importing_and_building_patch_nothing(tmp_path):
    """Importing clumpprops.yade, loading YADE through it, building and correcting clumps leave YADE's
    O.bodies methods as they are (YADE's erase of a corrected clump then leaves its correction free:
    check() is not ok); install_guards() patches them, once."""
    p = run_yade_script(tmp_path, NO_PATCH_SCRIPT)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "before: [] False False" in p.stdout, p.stdout
    assert "install: True False" in p.stdout and "after: True True" in p.stdout, p.stdout


# ---------------------------------------------------------------- O.bodies.clump / appendClumped


def corrected_and_free():
    cid, mids = cy.append_clump(make_spheres(*dimer()))
    free = O.bodies.append(utils.sphere((1.0, 0, 0), PAPER_D / 2, material="mat"))
    return cid, mids, cy.correction_id(cid), free


@pytest.mark.parametrize("which", ["correction", "correction alone", "sphere", "clump"])
def test_clump_touching_a_corrected_clump_is_refused(scene, which):
    cid, mids, corr, free = corrected_and_free()
    ids = {"correction": [corr, free], "correction alone": [corr], "sphere": [mids[0], free], "clump": [cid, free]}[which]
    before = scene_snapshot()
    with pytest.raises(cy.ClumpAdapterError, match=rf"O.bodies.clump: body #{ids[0]} is a") as exc:
        O.bodies.clump(ids, discretization=0)
    assert "\n" not in str(exc.value)
    assert scene_snapshot() == before
    assert_exact(cid)
    O.bodies.clump([free, O.bodies.append(utils.sphere((1.0, 0, 0.05), PAPER_D / 2, material="mat"))])  # plain spheres: YADE's
    rep = cy.check()
    assert rep.ok and len(rep.uncorrected) == 1, str(rep)


def test_clump_negative_control_check_reports_every_state(scene):
    """Unguarded, YADE's clump leaves states that only check() can see: the old clump without its
    correction (or a sphere short), a clump of the correction alone (negative mass), a clump of the
    correction with a foreign body."""
    cid, mids, corr, free = corrected_and_free()
    with cy.unguarded():
        new = O.bodies.clump([corr])
    assert O.bodies[new].state.mass < 0  # YADE accepts a clump of negative mass here
    rep = cy.check()
    assert sorted(c for c, _ in rep.stale) == [cid, new], str(rep)
    assert "no sphere members" in dict(rep.stale)[new]
    assert new in [i for i, _ in rep.invalid]
    assert not rep.ok and f"invalid body #{new}" in str(rep)
    # a correction clumped with a foreign (non-sphere) body
    fresh_scene()
    cid, mids, corr, free = corrected_and_free()
    box = O.bodies.append(utils.box((3, 0, 0), (0.1, 0.1, 0.1), material="mat"))
    with cy.unguarded():
        new = O.bodies.clump([corr, box])
    rep = cy.check()
    assert sorted(c for c, _ in rep.stale) == [cid, new], str(rep)
    assert "not a sphere (Box)" in dict(rep.stale)[new]


def test_append_clumped_of_spheres_is_yades_own(scene):
    cy.append_clump(make_spheres(*dimer(1.0)))  # the guards are installed
    cid, mids = O.bodies.appendClumped(make_spheres(*dimer()), discretization=0)
    assert O.bodies[cid].state.mass == pytest.approx(2 * PAPER_RHO * 4 / 3 * np.pi * (PAPER_D / 2) ** 3, rel=1e-14)
    assert cid in cy.check().uncorrected


# ---------------------------------------------------------------- deleteClumpMember, deleteClumpBody, clear, replace


def trimer(dx=0.0, s=0.03):
    return np.array([[dx, 0, -s], [dx, 0, s], [dx, s, 0]]), np.array([PAPER_D / 2] * 3)


def test_delete_clump_member_keeps_clump_exact(scene):
    cid, mids = cy.append_clump(make_spheres(*trimer()))
    corr = cy.correction_id(cid)
    O.bodies.deleteClumpMember(O.bodies[cid], O.bodies[mids[0]])
    assert O.bodies[mids[0]] is None and cy.sphere_member_ids(cid) == mids[1:]
    assert_exact(cid)
    with pytest.raises(cy.ClumpAdapterError, match=rf"body #{corr} is a clumpprops correction of clump #{cid}"):
        O.bodies.deleteClumpMember(O.bodies[cid], O.bodies[corr])
    O.bodies.deleteClumpMember(O.bodies[cid], O.bodies[mids[1]])
    assert_exact(cid)
    O.bodies.deleteClumpMember(O.bodies[cid], O.bodies[mids[2]])  # the last sphere takes clump and correction along
    assert all(O.bodies[i] is None for i in [cid, corr] + mids)
    assert cy.check().ok and not cy.check().exact


def test_delete_clump_member_negative_control(scene):
    cid, mids = cy.append_clump(make_spheres(*trimer()))
    with cy.unguarded():
        O.bodies.deleteClumpMember(O.bodies[cid], O.bodies[mids[0]])
    assert abs(O.bodies[cid].state.mass / exact_of(cid).mass - 1) > 0.1
    rep = cy.check()
    assert [c for c, _ in rep.stale] == [cid] and "fingerprint differs" in rep.stale[0][1]


def test_delete_clump_body_leaves_nothing(scene):
    cid, mids = cy.append_clump(make_spheres(*trimer()))
    keep, _ = cy.append_clump(make_spheres(*trimer(1.0)))
    corr = cy.correction_id(cid)
    O.bodies.deleteClumpBody(O.bodies[cid])
    assert all(O.bodies[i] is None for i in [cid, corr] + mids)
    rep = cy.check()
    assert rep.ok and rep.exact == [keep], str(rep)


def test_delete_clump_body_negative_control(tmp_path):
    """YADE's own deleteClumpBody on a corrected clump: on 2023.02a the bodies go and the registry
    entry stays (reported as orphaned); on 2025.2 the process aborts."""
    p = run_script(tmp_path, False, "deleteClumpBody")
    if is_yade_2023():
        assert p.returncode == 0 and "orphaned: [4]" in p.stdout, (p.returncode, p.stdout[-500:], p.stderr[-500:])
    else:
        assert p.returncode == -6, (p.returncode, p.stdout[-500:], p.stderr[-500:])
    p = run_script(tmp_path, True, "deleteClumpBody")
    assert p.returncode == 0 and "orphaned: []" in p.stdout, (p.returncode, p.stdout[-500:], p.stderr[-500:])


@pytest.mark.parametrize("call", ["clear", "replace"])
def test_clear_and_replace_forget_the_registry(scene, call):
    cid, _ = cy.append_clump(make_spheres(*trimer()))
    if call == "clear":
        O.bodies.clear()
    else:
        O.bodies.replace(make_spheres(*trimer(1.0)))
    rep = cy.check()
    assert rep.ok and not rep.orphaned and not rep.exact, str(rep)
    cid, _ = cy.append_clump(make_spheres(*trimer(2.0)))
    assert cy.check().exact == [cid]
    with cy.unguarded():  # negative control: the registry entry outlives its clump
        getattr(O.bodies, call)(*([] if call == "clear" else [[]]))
    assert [c for c, _ in cy.check().orphaned] == [cid]


def test_guarded_calls_with_keywords_stay_exact(scene):
    """Each guarded method with YADE's keywords on a corrected clump."""
    cid, mids = cy.append_clump(make_spheres(*trimer()))
    O.bodies.releaseFromClump(mids[2], cid, discretization=0)
    assert_exact(cid)
    O.bodies.addToClump([mids[2]], cid, discretization=10)
    assert_exact(cid)
    O.bodies.updateClumpProperties(excludeList=[], discretization=5)
    assert_exact(cid)
    other, omids = cy.append_clump(make_spheres(*trimer(1.0)))
    O.bodies.erase(other, eraseClumpMembers=True)
    assert all(O.bodies[i] is None for i in [other] + omids)
    assert_exact(cid)


# ---------------------------------------------------------------- masks


def masked_dimer(masks, dx=0.0):
    c, r = dimer(dx)
    return [utils.sphere(tuple(x), float(rr), material="mat", mask=m) for x, rr, m in zip(c, r, masks)]


def fall(engines, steps=100, dt=1e-4):
    O.engines = [ForceResetter()] + engines
    O.dt = dt
    O.run(steps, True)
    return steps * dt


@pytest.mark.parametrize("route", ["GravityEngine(mask=0b101)", "GravityEngine(mask=0)", "NewtonIntegrator.gravity"])
def test_masked_gravity_weighs_the_exact_clump(scene, route):
    """Spheres with masks 0b110 and 0b011 share no bit: GravityEngine(mask=0b101) selects each of them,
    so it must select the correction too (union of the bits, 0b111) for the clump to fall at g."""
    cid, _ = cy.append_clump(masked_dimer([0b110, 0b011]))
    other, _ = cy.append_clump(masked_dimer([0b010, 0b010], dx=1.0))  # selected by no bit of 0b101
    assert O.bodies[cy.correction_id(cid)].mask == 0b111
    engines = {"GravityEngine(mask=0b101)": [GravityEngine(gravity=(0, 0, -G), mask=0b101), NewtonIntegrator(damping=0)],
               "GravityEngine(mask=0)": [GravityEngine(gravity=(0, 0, -G), mask=0), NewtonIntegrator(damping=0)],
               "NewtonIntegrator.gravity": [NewtonIntegrator(damping=0, gravity=(0, 0, -G))]}[route]
    t = fall(engines)
    assert vec(O.bodies[cid].state.vel)[2] == pytest.approx(-G * t, rel=1e-12)
    assert np.max(np.abs(vec(O.bodies[cid].state.angVel))) < 1e-12
    v_other = vec(O.bodies[other].state.vel)[2]
    if route == "GravityEngine(mask=0b101)":
        assert v_other == 0
    else:
        assert v_other == pytest.approx(-G * t, rel=1e-12)


def test_masked_gravity_negative_control_common_bits(scene):
    """With the bits common to both spheres (0) on the correction, GravityEngine(mask=0b101) weighs the
    spheres only: the dimer falls faster than g by m_spheres / m_exact (the correction's mass is negative)."""
    cid, mids = cy.append_clump(masked_dimer([0b110, 0b011]))
    O.bodies[cy.correction_id(cid)].mask = 0b110 & 0b011
    t = fall([GravityEngine(gravity=(0, 0, -G), mask=0b101), NewtonIntegrator(damping=0)])
    m_s = sum(O.bodies[i].state.mass for i in mids)
    assert vec(O.bodies[cid].state.vel)[2] == pytest.approx(-G * t * m_s / O.bodies[cid].state.mass, rel=1e-10)
    assert m_s / O.bodies[cid].state.mass == pytest.approx(1.1852, abs=1e-4)  # the paper dimer: YADE's sum is +18.5 %


def test_mask_changed_after_build_is_reported_and_repaired(scene):
    cid, mids = cy.append_clump(masked_dimer([0b001, 0b001]))
    corr = cy.correction_id(cid)
    assert cy.check().ok
    O.bodies[mids[1]].mask = 0b100  # behind the adapter's back
    rep = cy.check()
    assert not rep.ok and [c for c, _ in rep.masks] == [cid] and f"cy.correct_clump({cid})" in rep.masks[0][1]
    assert rep.exact == [cid]  # mass properties are still right
    with pytest.raises(cy.ClumpAdapterError, match=rf"mask of clump #{cid}"):
        cy.check(raise_on_error=True)
    cy.correct_clump(cid)
    assert O.bodies[corr].mask == 0b101 and cy.check().ok


# ---------------------------------------------------------------- negative or zero dynamic mass


def test_check_reports_nonpositive_dynamic_mass(scene):
    cid, mids = cy.append_clump(make_spheres(*dimer()))
    corr = cy.correction_id(cid)
    O.materials.append(FrictMat(density=0.0, label="massless"))
    s0 = O.bodies.append(utils.sphere((2, 0, 0), 0.1, material="massless"))  # dynamic, mass 0
    wall = O.bodies.append(utils.wall(-1, axis=2))  # not dynamic: mass 0 is fine
    rep = cy.check()
    assert [i for i, _ in rep.invalid] == [s0] and "mass 0 kg" in rep.invalid[0][1], str(rep)
    O.bodies[s0].dynamic = False
    assert cy.check().ok
    with cy.unguarded():
        O.bodies.erase(cid)  # the correction becomes a free dynamic body of negative mass
    rep = cy.check()
    assert [i for i, _ in rep.invalid] == [corr] and [i for i, _ in rep.orphaned] == [corr, cid], str(rep)
    assert wall not in [i for i, _ in rep.invalid]
