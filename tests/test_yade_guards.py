"""YADE's own ``O.bodies`` calls on corrected clumps: each one is exact, refused before YADE sees it,
or reported by ``cy.check()``; none aborts the process (real YADE, 2023.02a and 2025.2).

Every refusal is checked to leave the scene unchanged; where YADE itself would abort
(``Clump.cpp: Assertion 'M > 0' failed``) the call runs in a subprocess, guarded (refused, exit 0)
and unguarded (``cy.unguarded()``: the abort, the negative control).
"""
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from _yadehelpers import O, PAPER_D, PAPER_RHO, assert_state_matches, fresh_scene, make_spheres, scene_snapshot, vec, utils

import clumpprops
from clumpprops import yade as cy
from yade.wrapper import Body, ForceResetter, FrictMat, GravityEngine, NewtonIntegrator, Shape

ROOT = Path(__file__).resolve().parents[1]
G = 9.81


@pytest.fixture
def scene():
    fresh_scene()
    yield O
    O.reset()


def dimer(dx=0.0):
    d = PAPER_D
    return np.array([[dx, 0, -d / 4], [dx, 0, d / 4]]), np.array([d / 2, d / 2])


def exact_of(cid):
    ids = cy.sphere_member_ids(cid)
    c = np.array([vec(O.bodies[i].state.pos) for i in ids])
    r = np.array([O.bodies[i].shape.radius for i in ids])
    return clumpprops.mass_properties(c, r, PAPER_RHO)


def assert_exact(cid):
    assert_state_matches(O.bodies[cid].state, exact_of(cid))
    rep = cy.check()
    assert rep.ok, str(rep)
    assert cid in rep.exact


# ---------------------------------------------------------------- calls that abort YADE: subprocesses

ABORT_SCRIPT = textwrap.dedent(
    """
    import os, sys
    os.environ["OMP_NUM_THREADS"] = "1"
    sys.path.insert(0, {root!r})
    import yade
    from yade import utils
    from yade.wrapper import FrictMat
    from clumpprops import yade as cy
    O = yade.O
    O.materials.append(FrictMat(density=1140.0, label="m"))
    d = 0.1333
    # two small spheres inside a big one: the correction's mass is minus the small spheres' mass
    spheres = [utils.sphere((0, 0, 0), d / 2, material="m")] + [utils.sphere((0, 0, z), 0.0125, material="m") for z in (-0.01, 0.01)]
    cid, mids = cy.append_clump(spheres)
    corr = cy.correction_id(cid)
    free = O.bodies.append(utils.sphere((1, 0, 0), 0.0125, material="m"))
    plain, _ = O.bodies.appendClumped([utils.sphere((2, 0, z), 0.01, material="m") for z in (0, 0.01)])
    guarded = sys.argv[1] == "guarded"
    call = sys.argv[2]
    def run():
        if call == "clump":                 # the issue's call: correction and a free sphere
            O.bodies.clump([corr, free], discretization=0)
        elif call == "addToClump_free_correction":   # a correction left free by YADE's own erase, added to a plain clump
            with cy.unguarded():
                O.bodies.erase(cid)
            O.bodies.addToClump([corr], plain, discretization=0)
    try:
        if guarded:
            run()
        else:
            with cy.unguarded():
                run()
    except cy.ClumpAdapterError as exc:
        print("refused:", exc)
        print("check ok:", cy.check().ok if call != "addToClump_free_correction" else "n/a")
        sys.exit(0)
    print("no error")
    """
)


def run_script(tmp_path, guarded, call):
    script = tmp_path / "abort.py"
    script.write_text(ABORT_SCRIPT.format(root=str(ROOT)))
    return subprocess.run([sys.executable, str(script), "guarded" if guarded else "unguarded", call],
                          capture_output=True, text=True, timeout=120, env=dict(os.environ, OMP_NUM_THREADS="1"))


@pytest.mark.parametrize("call", ["clump", "addToClump_free_correction"])
def test_calls_that_abort_yade_are_refused(tmp_path, call):
    p = run_script(tmp_path, True, call)
    assert p.returncode == 0, (p.returncode, p.stdout[-500:], p.stderr[-800:])
    line = next(ln for ln in p.stdout.splitlines() if ln.startswith("refused:"))
    assert "correction" in line and len(line.splitlines()) == 1
    if call != "addToClump_free_correction":
        assert "check ok: True" in p.stdout


@pytest.mark.parametrize("call", ["clump", "addToClump_free_correction"])
def test_calls_that_abort_yade_negative_control(tmp_path, call):
    """The same calls made unguarded: YADE aborts the process (SIGABRT, ``M > 0`` assertion)."""
    p = run_script(tmp_path, False, call)
    assert p.returncode == -6 and "M > 0' failed" in p.stderr, (p.returncode, p.stdout[-500:], p.stderr[-500:])


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


def test_append_clumped_refuses_correction_bodies(scene):
    b = Body()
    b.shape = Shape()
    b.bounded = False
    b.state.mass = -1.0
    n = len(O.bodies)
    with pytest.raises(cy.ClumpAdapterError, match=r"O.bodies.appendClumped: item 1 is a clumpprops correction body"):
        O.bodies.appendClumped([utils.sphere((0, 0, 0), 0.1, material="mat"), b], discretization=0)
    assert len(O.bodies) == n
    cid, mids = O.bodies.appendClumped(make_spheres(*dimer()), discretization=0)  # spheres: YADE's own, unchanged
    assert O.bodies[cid].state.mass == pytest.approx(2 * PAPER_RHO * 4 / 3 * np.pi * (PAPER_D / 2) ** 3, rel=1e-14)
