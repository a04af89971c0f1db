"""The LAMMPS exports checked inside LAMMPS itself (Debian 12's lmp, 29 Sep 2021 update 2).

* a non-overlapping clump without an infile: LAMMPS' own summed mass, centre of mass and
  inertia (read back with ``compute rigid/local``) equal clumpprops' exact values;
* an overlapping asymmetric clump through the exported infile (``fix rigid/small``) and
  through the exported molecule file (``fix rigid/small mol`` + ``fix deposit``): LAMMPS
  uses our mass, centre of mass and inertia (to 1e-12 relative; it prints 17 digits);
* a free spin with ``fix rigid/nve`` and the infile's angular momentum: the member
  positions after 1 s follow the exact inertia (scipy solve_ivp of the rigid-body
  equations) and are far from the summed-sphere prediction.
"""
from __future__ import annotations

import numpy as np
import pytest

from clumpprops import mass_properties
from clumpprops.io import Clump, export, lammps as lio

from _engines import APART_C, APART_R, ASYM_C, ASYM_R, LAMMPS, RHO, quat_to_matrix, read_dump, rotation_after, run

PRE = """units si
atom_style hybrid sphere molecular
boundary f f f
{setup}
pair_style zero 0.5
pair_coeff * *
neighbor 0.01 bin
neigh_modify exclude molecule/intra all
thermo_style custom step
"""
RL = """compute rl all rigid/local r mass x y z inertiax inertiay inertiaz quatw quati quatj quatk
dump d all local 1 rl.dump c_rl[*]
dump_modify d format float %.17g
"""


def _export(tmp_path, centers, radii, name):
    c = Clump(np.asarray(centers, float), np.asarray(radii, float), name=name)
    export([c], "lammps", tmp_path, density=RHO)
    return c, mass_properties(c.centers, c.radii, density=RHO)


def _rigid_local(tmp_path, step):
    cols, a = read_dump(tmp_path / "rl.dump")[step]
    a = a[0]
    mass, com, moments, q = a[0], a[1:4], a[4:7], a[7:11]
    Q = quat_to_matrix(q)
    return mass, com, moments, Q @ np.diag(moments) @ Q.T


def _rel(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b)))


def test_lammps_own_sum_equals_exact_for_a_nonoverlapping_clump(tmp_path):
    c, mp = _export(tmp_path, APART_C, APART_R, "apart")
    assert np.isclose(mp.mass, mass_properties(c.centers, c.radii, density=RHO, method="sum").mass, rtol=1e-14)
    (tmp_path / "in.own").write_text(PRE.format(setup="read_data apart.data") + "fix r all rigid/small molecule\n" + RL + "run 0\n")
    run(LAMMPS, tmp_path / "in.own", tmp_path)
    mass, com, moments, I = _rigid_local(tmp_path, 0)
    print(f"LAMMPS own sum, no overlap: mass {_rel(mass, mp.mass):.1e}, COM {_rel(com, mp.center_of_mass):.1e}, "
          f"tensor {_rel(I, mp.inertia):.1e}")
    assert _rel(mass, mp.mass) < 1e-13
    assert _rel(com, mp.center_of_mass) < 1e-13
    assert _rel(np.sort(moments), mp.principal_moments) < 1e-12
    assert _rel(I, mp.inertia) < 1e-12


def test_lammps_infile_carries_the_exact_values_of_an_overlapping_clump(tmp_path):
    c, mp = _export(tmp_path, ASYM_C, ASYM_R, "asym")
    summed = mass_properties(c.centers, c.radii, density=RHO, method="sum")
    (tmp_path / "in.infile").write_text(
        PRE.format(setup="read_data asym.data") + "fix r all rigid/small molecule infile asym.rigid\n" + RL + "run 0\n")
    run(LAMMPS, tmp_path / "in.infile", tmp_path)
    mass, com, moments, I = _rigid_local(tmp_path, 0)
    print(f"LAMMPS infile read-back: mass {_rel(mass, mp.mass):.1e}, COM {_rel(com, mp.center_of_mass):.1e}, "
          f"moments {_rel(np.sort(moments), mp.principal_moments):.1e}, tensor {_rel(I, mp.inertia):.1e}")
    assert _rel(mass, mp.mass) < 1e-14
    assert _rel(com, mp.center_of_mass) < 1e-14
    assert _rel(np.sort(moments), mp.principal_moments) < 1e-12
    assert _rel(I, mp.inertia) < 1e-12  # full tensor: component order and off-diagonal sign
    assert _rel(mass, summed.mass) > 1e-2  # the summed value would have been visibly different
    # and without the infile LAMMPS sums the spheres (overlaps twice)
    (tmp_path / "in.sum").write_text(PRE.format(setup="read_data asym.data") + "fix r all rigid/small molecule\n" + RL + "run 0\n")
    run(LAMMPS, tmp_path / "in.sum", tmp_path)
    mass_s, _, _, I_s = _rigid_local(tmp_path, 0)
    assert _rel(mass_s, summed.mass) < 1e-13 and _rel(I_s, summed.inertia) < 1e-12


def test_lammps_molecule_file_carries_the_exact_values(tmp_path):
    c, mp = _export(tmp_path, ASYM_C, ASYM_R, "asym")
    setup = "region box block -1 1 -1 1 -1 1\ncreate_box 1 box\nmolecule m asym.mol"
    (tmp_path / "in.mol").write_text(
        PRE.format(setup=setup) + "timestep 1e-6\nfix r all rigid/small molecule mol m\n"
        "region ins block -0.1 0.1 -0.1 0.1 -0.1 0.1\n"
        "fix dep all deposit 1 0 1 12345 region ins mol m rigid r near 0.01 vx 0 0 vy 0 0 vz 0 0 id next\n"
        + RL + "run 1\n")
    run(LAMMPS, tmp_path / "in.mol", tmp_path)
    mass, com, moments, I = _rigid_local(tmp_path, 1)
    print(f"LAMMPS molecule file read-back: mass {_rel(mass, mp.mass):.1e}, "
          f"moments {_rel(np.sort(moments), mp.principal_moments):.1e}")
    assert _rel(mass, mp.mass) < 1e-14
    # principal moments: sensitive to the order of the six header values (see lammps.molecule_inertia_words)
    assert _rel(np.sort(moments), mp.principal_moments) < 1e-12


def test_lammps_free_spin_follows_the_exact_inertia(tmp_path):
    c, mp = _export(tmp_path, ASYM_C, ASYM_R, "asym")
    summed = mass_properties(c.centers, c.radii, density=RHO, method="sum")
    w0 = np.array([2.0, -1.0, 3.0])  # rad/s
    L = mp.inertia @ w0
    hdr = lio.header_lines("LAMMPS test", RHO, "exact")
    (tmp_path / "spin.rigid").write_text(lio.infile_text([c], mp, hdr, angmom=[L]))
    dt, nsteps = 1e-4, 10000
    (tmp_path / "in.spin").write_text(
        PRE.format(setup="read_data asym.data") + f"timestep {dt}\nfix r all rigid/nve molecule infile spin.rigid\n"
        f"dump a all custom {nsteps} atoms.dump id x y z\ndump_modify a format float %.17g sort id\nrun {nsteps}\n")
    run(LAMMPS, tmp_path / "in.spin", tmp_path)
    frames = read_dump(tmp_path / "atoms.dump")
    x0 = frames[0][1][:, 1:4]
    assert np.allclose(x0, c.centers, rtol=0, atol=1e-15)
    x1 = frames[nsteps][1][:, 1:4]
    t = dt * nsteps
    R = rotation_after(mp.inertia, L, t)
    pred = mp.center_of_mass + (c.centers - mp.center_of_mass) @ R.T
    Rs = rotation_after(summed.inertia, L, t)
    pred_sum = summed.center_of_mass + (c.centers - summed.center_of_mass) @ Rs.T
    size = 0.1
    err = np.max(np.abs(x1 - pred)) / size
    err_sum = np.max(np.abs(x1 - pred_sum)) / size
    print(f"LAMMPS spin: position error vs exact prediction {err:.2e}, vs summed-sphere prediction {err_sum:.2e} (of 0.1 m)")
    assert err < 1e-5
    assert err_sum > 1e3 * err

