"""The paper's dimer in YADE: exact clump (clumpprops.yade.append_clump) next to YADE's own.

Run (from the repository root):
    yade -n -x examples/yade_paper_dimer.py
or, with plain Python:
    .venv/bin/python examples/yade_paper_dimer.py
"""
import os
import sys

os.environ.setdefault("OMP_NUM_THREADS", "1")
try:
    import clumpprops  # noqa: F401  (installed, or run with .venv/bin/python)
except ImportError:  # `yade -x` runs Debian's python3 and does not put the script's folder on sys.path
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(sys.argv[0]))))

import numpy as np
import yade
from yade import utils
from yade.wrapper import FrictMat

import clumpprops
from clumpprops import yade as cy

O = yade.O
d = 0.1333  # m, sphere diameter
D = d / 2  # m, centre distance
rho = 1140.0  # kg/m^3
centers = [(0, 0, -D / 2), (0, 0, D / 2)]

O.reset()
O.materials.append(FrictMat(density=rho, young=1e7, poisson=0.4, label="pp"))


def dimer(shift):
    return [utils.sphere((x + shift, y, z), d / 2, material="pp") for x, y, z in centers]


exact_id, members = cy.append_clump(dimer(0.0))  # the one-call swap for O.bodies.appendClumped
sum_id, _ = O.bodies.appendClumped(dimer(1.0))  # YADE, discretization=0 (overlap counted twice)
vox_id, _ = O.bodies.appendClumped(dimer(2.0), discretization=10)  # YADE, voxelised

mp = clumpprops.mass_properties(centers, [d / 2, d / 2], density=rho)  # the library, exact

print(f"paper's dimer: d = {d} m, D = d/2, rho = {rho} kg/m^3   (YADE {yade.config.version})")
print(f"{'':>28}{'mass [kg]':>12}{'I_axial':>12}{'I_perp':>12}{'COM z [m]':>12}")


def row(label, mass, moments, z):
    print(f"{label:>28}{mass:12.6f}{moments[0]:12.4e}{moments[2]:12.4e}{z:12.2e}")


row("clumpprops (exact)", mp.mass, mp.principal_moments, mp.center_of_mass[2])
for label, cid, shift in (("YADE + append_clump", exact_id, 0.0), ("YADE appendClumped", sum_id, 1.0),
                          ("YADE discretization=10", vox_id, 2.0)):
    st = O.bodies[cid].state
    m = sorted(float(a) for a in st.inertia)
    row(label, float(st.mass), m, float(st.pos[2]))
    if cid != exact_id:
        print(f"{'':>28}{'error:':>6}{float(st.mass) / mp.mass - 1:+6.1%}{m[0] / mp.principal_moments[0] - 1:+12.1%}"
              f"{m[2] / mp.principal_moments[2] - 1:+12.1%}")
err = cy.clump_errors(exact_id)
print(f"append_clump vs library, relative: mass {err['mass']:.1e}, COM {err['center_of_mass']:.1e}, inertia {err['inertia']:.1e}")
assert max(err.values()) < 1e-12
