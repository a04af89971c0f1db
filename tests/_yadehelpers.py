"""Shared helpers for the YADE adapter tests (real YADE, plain ``import yade``)."""
import os
import subprocess
import sys
import textwrap
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")  # before YADE is imported anywhere in this process

import numpy as np
import pytest

import yade  # installed by scripts/setup.sh; a missing YADE is a failure, not a skip
import yade.config  # noqa: E402
from yade import utils  # noqa: E402
from yade.wrapper import FrictMat  # noqa: E402

O = yade.O

YADE_VERSION = str(yade.config.version)  # "2023.02a" (Debian 12) or "2025.2.0" (Debian 13)


def default_rot_algorithm():
    """NewtonIntegrator's scheme for aspherical rotation: YADE 2023.02a has only Fincham 1992;
    2025.2 adds ``rotAlgorithm`` with default delValle2023 (yade-facts.md)."""
    from yade.wrapper import NewtonIntegrator

    n = NewtonIntegrator()
    name = str(n.rotAlgorithm).rsplit(".", 1)[-1] if hasattr(n, "rotAlgorithm") else "Fincham1992"
    expected = {"2023": "Fincham1992", "2025": "delValle2023"}.get(YADE_VERSION[:4])
    assert expected is None or name == expected, (YADE_VERSION, name)
    return name


def is_yade_2023():
    return YADE_VERSION.startswith("2023")


PAPER_D = 0.1333  # m, sphere diameter of the paper's dimer
PAPER_RHO = 1140.0  # kg/m^3


def fresh_scene(density=PAPER_RHO, young=1e7, poisson=0.4, friction_deg=0.0):
    O.reset()
    O.materials.append(FrictMat(density=density, young=young, poisson=poisson, frictionAngle=np.radians(friction_deg), label="mat"))
    return O



@pytest.fixture
def scene():
    """A fresh scene of the paper's material for one test, reset afterwards (import it into a test module)."""
    fresh_scene()
    yield O
    O.reset()


def vec(v):
    return np.array([float(v[0]), float(v[1]), float(v[2])])


def rotation(q):
    m = q.toRotationMatrix()
    return np.array([[float(m[i, j]) for j in range(3)] for i in range(3)])


def random_clump(rng, n, origin=(0.0, 0.0, 0.0), scale=0.1):
    """n overlapping spheres grown from a seed, dense enough that triples share volume."""
    c = [np.zeros(3)]
    r = [scale * rng.uniform(0.6, 1.0)]
    while len(c) < n:
        k = rng.integers(len(c))
        rn = scale * rng.uniform(0.4, 1.0)
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        c.append(c[k] + u * (r[k] + rn) * rng.uniform(0.3, 0.8))
        r.append(rn)
    return np.array(c) + np.asarray(origin, float), np.array(r)


def make_spheres(centers, radii, material="mat"):
    return [utils.sphere(tuple(float(a) for a in x), float(rr), material=material) for x, rr in zip(centers, radii)]


def yade_inertia(state):
    R = rotation(state.ori)
    return R @ np.diag(vec(state.inertia)) @ R.T


def assert_state_matches(state, mp, rtol=1e-12):
    """state.mass, state.pos, R diag(inertia) R^T and the principal moments equal the library's."""
    assert abs(float(state.mass) - mp.mass) <= rtol * mp.mass, (float(state.mass), mp.mass)
    size = np.sqrt(np.trace(mp.inertia) / (2 * mp.mass))  # radius of gyration
    dc = np.linalg.norm(vec(state.pos) - mp.center_of_mass)
    assert dc <= rtol * size, (dc, size)
    Imax = float(np.max(mp.principal_moments))
    dI = np.max(np.abs(yade_inertia(state) - mp.inertia))
    assert dI <= rtol * Imax, (dI, Imax)
    dw = np.max(np.abs(np.sort(vec(state.inertia)) - mp.principal_moments))
    assert dw <= rtol * Imax, (dw, Imax)



def exact_of(cid):
    """The library's properties of the clump's sphere members where they are now (independent of YADE's state)."""
    from clumpprops import mass_properties, yade as cy

    ids = cy.sphere_member_ids(cid)
    c = np.array([vec(O.bodies[i].state.pos) for i in ids])
    r = np.array([O.bodies[i].shape.radius for i in ids])
    return mass_properties(c, r, PAPER_RHO)


def assert_exact(cid):
    """The clump's YADE state equals the library's properties of its members, and the scene check agrees."""
    from clumpprops import yade as cy

    assert_state_matches(O.bodies[cid].state, exact_of(cid))
    rep = cy.check()
    assert rep.ok, str(rep)
    assert cid in rep.exact

def scene_snapshot():
    """Everything bad input must not change: bodies, shapes, states, clump membership."""
    snap = [len(O.bodies)]
    for b in O.bodies:
        if b is None:
            snap.append(None)
            continue
        st = b.state
        snap.append(
            (
                b.id,
                type(b.shape).__name__,
                b.clumpId,
                b.bounded,
                tuple(vec(st.pos)),
                float(st.mass),
                tuple(vec(st.inertia)),
                tuple(float(a) for a in (st.ori.toAxisAngle()[0] * st.ori.toAxisAngle()[1])),
                tuple(vec(st.vel)),
                tuple(sorted(b.shape.members.keys())) if b.isClump else None,
            )
        )
    return snap


ROOT = Path(__file__).resolve().parents[1]

# The start of every YADE script the tests run in a fresh process (calls that abort YADE, a first
# import): YADE, the adapter of this source tree, and one corrected clump whose correction is
# heavily negative (two small spheres inside a big one: the union is the big sphere, the correction's
# mass minus the small spheres').  The guards on O.bodies are not installed.
YADE_PRELUDE = textwrap.dedent(
    """
    import os, sys
    os.environ["OMP_NUM_THREADS"] = "1"
    import yade
    from yade import utils
    from yade.wrapper import FrictMat
    from clumpprops import yade as cy
    O = yade.O
    O.materials.append(FrictMat(density=1140.0, label="m"))
    d = 0.1333
    spheres = [utils.sphere((0, 0, 0), d / 2, material="m")] + [utils.sphere((0, 0, z), 0.0125, material="m") for z in (-0.01, 0.01)]
    cid, mids = cy.append_clump(spheres)
    """
)


def run_yade_script(tmp_path, body, *args, timeout=120):
    """Run :data:`YADE_PRELUDE` followed by ``body`` (dedented) in a fresh Python with this source
    tree's ``clumpprops`` first on its path; returns the ``subprocess.CompletedProcess``."""
    script = tmp_path / "yade_script.py"
    script.write_text(YADE_PRELUDE + textwrap.dedent(body))
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=path)
    return subprocess.run([sys.executable, str(script), *args], capture_output=True, text=True, timeout=timeout,
                          env=env, cwd=tmp_path)
