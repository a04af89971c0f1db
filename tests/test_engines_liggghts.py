"""The LIGGGHTS exports checked inside LIGGGHTS itself (Debian's liggghts 3.8.0).

Read-back: the body's mass from ``compute ke/multisphere`` with a known velocity (ke = m v^2/2)
and its inertia tensor from ``compute erotate/multisphere`` with six known angular velocities
(erotate = w.I.w/2, LIGGGHTS sums I_k (w . e_k)^2 over its principal axes), printed with
17 digits; each value comes from a fresh body (``clear`` between blocks).

* a non-overlapping clump without ``mass``/``inertia_tensor``: LIGGGHTS' Monte Carlo over
  ``ntry`` points agrees with clumpprops within its sampling error, except Iyz: LIGGGHTS
  3.8.0 stores (Iyz + Ixz)/2 there (a symmetrisation typo fixed upstream after the release);
  with the exported ``inertia_tensor`` the bug is bypassed;
* an overlapping asymmetric clump through the exported template (``use_density``): LIGGGHTS
  uses our mass and inertia tensor (1e-12 relative), and our centre of mass: the member
  velocities v = w x (x - xcm) of spinning bodies locate the point it turns about, which is
  where the sphere file's origin went;
* a free spin: the inserted body spins at the requested omega (member velocities at step 1),
  and member positions after 1 s follow the exact inertia (scipy solve_ivp) and are far from
  the summed-sphere prediction.

Debian 12's liggghts 3.8.0+repack1-9 and Debian 13's 3.8.0+repack1-13 (the Debian 13 root)
give bit-identical dumps here; numbers go into the inputs as Python floats (numpy >= 2 writes
``np.float64(2.0)`` for repr of a numpy scalar, which LIGGGHTS' atof() reads as 0).
"""
from __future__ import annotations

import re

import numpy as np
import pytest

from clumpprops import mass_properties
from clumpprops.io import Clump, export

from _engines import APART_C, APART_R, ASYM_C, ASYM_R, LIGGGHTS, LIGGGHTS_BOX, RHO, read_dump, rotation_after, run, thermo_rows

PRE = LIGGGHTS_BOX + """neighbor 0.01 bin
neigh_modify delay 0
fix m1 all property/global youngsModulus peratomtype 1.e7
fix m2 all property/global poissonsRatio peratomtype 0.4
fix m3 all property/global coefficientRestitution peratomtypepair 1 0.9
fix m4 all property/global coefficientFriction peratomtypepair 1 0.0
pair_style gran model hertz tangential history
pair_coeff * *
timestep {dt}
{template}
region bc block -0.5 0.5 -0.5 0.5 -0.5 0.5 units box
fix ins all insert/pack seed 32452843 distributiontemplate pdd1 vel constant {v} omega constant {w} orientation template insert_every once overlapcheck yes region bc particles_in_region 1 ntry_mc 10000
fix integr all multisphere
compute ke all ke/multisphere
compute er all erotate/multisphere
thermo_style custom step atoms c_ke c_er
thermo_modify format float %.17g norm no
thermo 1
"""

OMEGAS = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, 0, 1), (0, 1, 1)]


def _template_lines(tmp_path, name, ntry=None):
    lines = (tmp_path / f"{name}_liggghts.in").read_text().splitlines()
    lines = [ln for ln in lines if ln.startswith("fix ")]
    if ntry is not None:
        lines = [re.sub(r"ntry \d+", f"ntry {ntry}", ln) for ln in lines]
    return "\n".join(lines)


def read_back(tmp_path, template: str):
    """Mass and inertia tensor of the body LIGGGHTS builds from ``template`` (7 fresh bodies)."""
    blocks = [PRE.format(dt=1e-5, template=template, v="1 0 0", w="0 0 0") + "run 1\n"]
    dump = ("dump c all custom 1 {} id x y z vx vy vz\n"
            "dump_modify c format \"%d %.17g %.17g %.17g %.17g %.17g %.17g\" sort id\n")
    blocks += [PRE.format(dt=1e-5, template=template, v="0 0 0", w=" ".join(map(str, w)))
               + (dump.format(f"w{k}.dump") if k < 3 else "") + "run 1\n" for k, w in enumerate(OMEGAS)]
    (tmp_path / "in.readback").write_text("clear\n".join(blocks))
    out = run(LIGGGHTS, tmp_path / "in.readback", tmp_path)
    vals = []
    for head, rows in thermo_rows(out):
        last = rows[-1]
        assert last[1] > 0, "no body inserted"
        vals.append((last[head.index("ke")], last[head.index("er")]))
    assert len(vals) == 7
    mass = 2 * vals[0][0]
    E = [2 * er for _, er in vals[1:]]  # w.I.w
    I = np.diag(E[:3])
    I[0, 1] = I[1, 0] = (E[3] - E[0] - E[1]) / 2
    I[0, 2] = I[2, 0] = (E[4] - E[0] - E[2]) / 2
    I[1, 2] = I[2, 1] = (E[5] - E[1] - E[2]) / 2
    return mass, I, out


def com_from_velocities(tmp_path):
    """The body's centre of mass as LIGGGHTS moves it: member velocities v = w x (x - xcm) at
    w = e_x, e_y, e_z (v_cm = 0) give xcm; also the member positions of the e_z body."""
    xc = []
    for k in range(3):
        cols, a = read_dump(tmp_path / f"w{k}.dump")[1]
        x, v = a[:, 1:4], a[:, 4:7]
        w = np.eye(3)[k]
        # v = w x (x - c)  =>  w x v = w (w.(x - c)) - (x - c): the components of c across w
        c = x + np.cross(w, v) - np.outer((x @ w), w)
        c[:, k] = np.nan
        xc.append(c)
    return np.nanmean(np.concatenate(xc), axis=0), read_dump(tmp_path / "w2.dump")[1][1][:, 1:4]


def _rel(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b)))


def _export(tmp_path, centers, radii, name):
    c = Clump(np.asarray(centers, float), np.asarray(radii, float), name=name)
    export([c], "liggghts", tmp_path, density=RHO)
    return c, mass_properties(c.centers, c.radii, density=RHO)


def test_liggghts_uses_the_exported_mass_and_inertia_tensor(tmp_path):
    c, mp = _export(tmp_path, ASYM_C, ASYM_R, "asym")
    summed = mass_properties(c.centers, c.radii, density=RHO, method="sum")
    mass, I, _ = read_back(tmp_path, _template_lines(tmp_path, "asym", ntry=10000))
    print(f"LIGGGHTS read-back: mass rel. error {abs(mass / mp.mass - 1):.1e}, tensor {_rel(I, mp.inertia):.1e}")
    assert abs(mass / mp.mass - 1) < 1e-14
    assert _rel(I, mp.inertia) < 1e-12  # component order Ixx Ixy Ixz Iyy Iyz Izz and the off-diagonal sign
    assert abs(mass / summed.mass - 1) > 1e-2 and _rel(I, summed.inertia) > 1e-3
    # centre of mass: the point the body turns about is where the sphere file's origin (our COM) went
    xcm, x = com_from_velocities(tmp_path)
    f = c.centers - mp.center_of_mass
    U, _, Vt = np.linalg.svd((f - f.mean(0)).T @ (x - x.mean(0)))
    R0 = (U @ Vt).T
    origin = x.mean(0) - R0 @ f.mean(0)
    err = np.max(np.abs(xcm - origin)) / 0.1
    # the summed clump's centre of mass sits elsewhere in the file's frame
    off = np.max(np.abs(summed.center_of_mass - mp.center_of_mass)) / 0.1
    print(f"LIGGGHTS centre of mass (from member velocities) vs exported: {err:.1e} of 0.1 m (summed COM: {off:.1e})")
    assert err < 1e-12 and off > 1e-3


def test_liggghts_monte_carlo_agrees_with_exact_for_a_nonoverlapping_clump(tmp_path):
    c, mp = _export(tmp_path, APART_C, APART_R, "apart")
    ntry = 2000000
    tmpl = _template_lines(tmp_path, "apart", ntry=ntry)
    tmpl = re.sub(r" mass \S+ inertia_tensor( \S+){6} use_density", "", tmpl)  # LIGGGHTS' own Monte Carlo
    blocks = PRE.format(dt=1e-5, template=tmpl, v="1 0 0", w="1 0 0") + "run 1\n"
    (tmp_path / "in.mc").write_text(blocks)
    out = run(LIGGGHTS, tmp_path / "in.mc", tmp_path)
    head, rows = thermo_rows(out)[-1]
    mass = 2 * rows[-1][head.index("ke")]
    # binomial standard error of the hit fraction p in the bounding box
    lo = (c.centers - c.radii[:, None]).min(0)
    hi = (c.centers + c.radii[:, None]).max(0)
    p = mp.volume / np.prod(hi - lo)
    se = np.sqrt((1 - p) / (p * ntry))
    print(f"LIGGGHTS Monte Carlo (ntry {ntry}): mass rel. error {mass / mp.mass - 1:+.1e}, 1 sigma {se:.1e}")
    assert abs(mass / mp.mass - 1) < 5 * se
    # the log prints LIGGGHTS' inertia tensor with 7 digits
    log = (tmp_path / "log.out").read_text()
    rows = [list(map(float, m.group(1).split(","))) for m in re.finditer(r"Inertia tensor: (.*)", log)]
    I = np.array(rows[-3:])
    tol = 10 * se * np.max(mp.principal_moments)
    off = np.ones((3, 3), bool)
    off[1, 2] = off[2, 1] = False
    print(f"LIGGGHTS Monte Carlo inertia: max deviation {np.max(np.abs(I - mp.inertia)[off]):.1e} kg m^2 "
          f"(tolerance {tol:.1e}) except Iyz: {I[1, 2]:.6e} vs exact {mp.inertia[1, 2]:.6e}")
    assert np.max(np.abs(I - mp.inertia)[off]) < tol
    # LIGGGHTS 3.8.0 (Debian) symmetrises Iyz as (moi[2][1] + moi[2][0]) / 2, i.e. (Iyz + Ixz) / 2
    # (fixed upstream after the release, commit 62685fa9 "Inertial tensor fix", May 2021)
    buggy = (mp.inertia[1, 2] + mp.inertia[0, 2]) / 2
    assert abs(I[1, 2] - buggy) < tol
    assert abs(I[1, 2] - mp.inertia[1, 2]) > 3 * tol


def test_liggghts_free_spin_follows_the_exact_inertia(tmp_path):
    c, mp = _export(tmp_path, ASYM_C, ASYM_R, "asym")
    summed = mass_properties(c.centers, c.radii, density=RHO, method="sum")
    w0 = np.array([2.0, -1.0, 3.0])
    dt, nsteps = 1e-5, 100000
    # Python floats: under numpy >= 2 repr(np.float64(2.0)) is "np.float64(2.0)", which LIGGGHTS'
    # fix insert reads with atof() as 0 without a word (a body inserted at rest)
    omega = " ".join(map(repr, w0.tolist()))
    text = PRE.format(dt=dt, template=_template_lines(tmp_path, "asym", ntry=10000), v="0 0 0", w=omega)
    text += ("thermo 10000\nrun 1\n"  # inserted at step 1
             "dump a all custom 1 atoms0.dump id x y z vx vy vz\n"
             "dump_modify a format \"%d %.17g %.17g %.17g %.17g %.17g %.17g\" sort id\n"
             "run 0\nundump a\n"
             f"dump b all custom {nsteps} atoms1.dump id x y z\ndump_modify b format \"%d %.17g %.17g %.17g\" sort id\n"
             f"run {nsteps - 1}\n")
    (tmp_path / "in.spin").write_text(text)
    run(LIGGGHTS, tmp_path / "in.spin", tmp_path, timeout=300)
    f0, f1 = read_dump(tmp_path / "atoms0.dump"), read_dump(tmp_path / "atoms1.dump")
    steps = [min(f0), max(f1)]
    assert steps == [1, nsteps]
    x0, v0 = f0[1][1][:, 1:4], f0[1][1][:, 4:7]
    x1 = f1[nsteps][1][:, 1:4]
    rel0 = c.centers - mp.center_of_mass  # the exported sphere file
    # the body's orientation at step 1 from the inserted positions (Kabsch): LIGGGHTS inserts in
    # the sphere file's orientation (orientation template), rigidly
    a0, f0 = x0 - x0.mean(0), rel0 - rel0.mean(0)
    U, _, Vt = np.linalg.svd(f0.T @ a0)
    R0 = (U @ Vt).T
    assert np.linalg.det(R0) > 0 and np.max(np.abs(a0 - f0 @ R0.T)) < 1e-12, "rigid placement of the template"
    assert np.max(np.abs(R0 - np.eye(3))) < 1e-6, "template orientation"
    com = x0.mean(0) - R0 @ rel0.mean(0)  # where the file's origin (our centre of mass) went
    I0 = R0 @ mp.inertia @ R0.T
    w_ins = w0  # LIGGGHTS sets omega in the space frame
    # the body spins as asked: member velocities at step 1 are w0 x (x - xcm), v_cm = 0
    v_exp = np.cross(w_ins, x0 - com)
    assert np.max(np.abs(v0 - v_exp)) < 1e-12 * np.max(np.abs(v_exp)), \
        f"inserted spin: member velocities {v0.tolist()} are not w0 x (x - xcm) (omega words: {omega!r})"
    L = I0 @ w_ins
    t = dt * (steps[-1] - steps[0])
    R = rotation_after(I0, L, t)
    pred = com + (x0 - com) @ R.T
    Is = R0 @ summed.inertia @ R0.T
    com_s = com + R0 @ (summed.center_of_mass - mp.center_of_mass)
    Rs = rotation_after(Is, Is @ w_ins, t)
    pred_sum = com_s + (x0 - com_s) @ Rs.T
    err = np.max(np.abs(x1 - pred)) / 0.1
    err_sum = np.max(np.abs(x1 - pred_sum)) / 0.1
    print(f"LIGGGHTS spin: position error vs exact prediction {err:.2e}, vs summed-sphere prediction {err_sum:.2e} (of 0.1 m)")
    assert err < 1e-4
    assert err_sum > 100 * err
