"""clumpprops' voxel baseline against YADE's own ``appendClumped(..., discretization=d)``, run in YADE."""
import os

import numpy as np
import pytest

import clumpprops as cp
from test_baselines import RHO, valid_pairwise_clump   # the same random clumps


def _yade():
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    import yade  # installed by scripts/setup.sh: a missing YADE is a failure

    return yade


@pytest.mark.parametrize("discretization", [10, 20])
def test_voxel_reproduces_yade_appendClumped_discretization(discretization):
    """clumpprops' voxel baseline is YADE 2023.02a's grid scheme: same mass, COM and moments."""
    _yade()
    from yade import O, utils
    from yade.wrapper import FrictMat

    rng = np.random.default_rng(discretization)
    c, r = valid_pairwise_clump(rng, n=3)
    c = c * 0.05
    r = r * 0.05
    O.reset()
    mat = O.materials.append(FrictMat(density=RHO, young=1e7, poisson=0.4))
    cid, _ = O.bodies.appendClumped([utils.sphere(tuple(map(float, x)), float(rr), material=mat) for x, rr in zip(c, r)],
                                    discretization=discretization)
    st = O.bodies[cid].state
    vx = cp.mass_properties(c, r, RHO, method="voxel", discretization=discretization)
    assert st.mass == pytest.approx(vx.mass, rel=1e-12)
    assert np.allclose(np.array(st.pos), vx.center_of_mass, rtol=0, atol=1e-12 * r.max())
    # YADE adds each cell's own inertia without the density factor (dv dx^2/6); that term is
    # far below the grid error, so the moments agree to its size only
    assert np.allclose(np.sort(np.array(st.inertia)), vx.principal_moments, rtol=1e-3)
    O.reset()
