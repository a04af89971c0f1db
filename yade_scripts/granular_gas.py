# -*- coding: utf-8 -*-
"""The paper's periodic granular gas (Parteli, DISCUSSION / Fig. 2) in YADE, one case per run.

Run headless, one thread:
    OMP_NUM_THREADS=1 yade -n -x yade_scripts/granular_gas.py
Parameters come from ``yade.utils.readParamsFromTable`` (defaults below), so a
``yade-batch`` table, or ``YADE_BATCH=table:line`` as the driver
``python -m studies.granular_gas`` sets, drives sweeps.  Columns:

  case        exact | uncorrected | mass_only | inertia_only | spheres
  protocol    paired (velocities scaled to the energy with the exact mass, identical in
              every case) | equal_energy (scaled with the case's own mass)
  seed        initial positions, orientations, velocities (shared by all cases)
  n_particles 864 in the paper;  volume_fraction 0.001;  energy_per_particle 3.75 J
  t_end       simulated seconds;  rec_interval  seconds between recorded frames
  dt_factor   dt = dt_factor x P-wave step of a member sphere (0.5)
  record      1: record + check (the study);  0: bare run for the benchmark
  out         output path prefix: writes <out>.npz (trajectory) then <out>.json (last)
  energy_tol  relative total-energy tolerance (1e-3);  momentum_tol (1e-9, relative)

Dimer clumps carry their case's mass and an isotropic inertia I_perp with
``aspherical=False``.  For frictionless two-sphere clumps every contact force passes
through a member centre on the symmetry axis, so torques are perpendicular to the axis;
with zero initial spin the exact (I_axial != I_perp) motion keeps the axial spin at zero,
and for such motion L = I_perp * omega, which is exactly the isotropic body's motion.
YADE 2023.02a's aspherical integrator (Fincham 1992) is unstable here (see
docs/granular_gas.md); ``tests/test_granular_gas_rigid.py`` checks the equivalence
against full rigid-body dynamics.
"""
import json
import os
import subprocess
import sys
import time



def _script_path():
    # `yade -x` exec()s the script with yade's own globals: __file__ is /usr/bin/yade
    cands = [globals().get("__file__", "")] + list(sys.argv)
    for c in cands:
        if c and os.path.basename(c) == "granular_gas.py" and os.path.exists(c):
            return os.path.abspath(c)
    raise RuntimeError("cannot locate granular_gas.py; set CLUMPPROPS_ROOT to the repository root")


ROOT = os.environ.get("CLUMPPROPS_ROOT") or os.path.dirname(os.path.dirname(_script_path()))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

import numpy as np
import yade
import yade.config
from yade import O, utils
from yade.wrapper import (ForceResetter, InsertionSortCollider, Bo1_Sphere_Aabb, InteractionLoop,
                          Ig2_Sphere_Sphere_ScGeom, Ip2_FrictMat_FrictMat_MindlinPhys,
                          Law2_ScGeom_MindlinPhys_Mindlin, NewtonIntegrator, PyRunner, FrictMat)
from yade.minieigenHP import Vector3

from studies import gas_model as gm

utils.readParamsFromTable(
    case="exact", protocol="paired", seed=1, n_particles=864, volume_fraction=gm.VOLUME_FRACTION,
    energy_per_particle=gm.ENERGY_PER_PARTICLE, t_end=10.0, rec_interval=0.25, dt_factor=0.5,
    record=1, out="granular_gas_run", energy_tol=1e-3, momentum_tol=1e-9, progress_period=20.0,
    builder="auto",
)
from yade.params import table as P  # noqa: E402

WALL0 = time.time()
props = gm.case_properties(P.case)
protocol = gm.effective_protocol(P.case, P.protocol)
N = int(P.n_particles)
L = gm.box_length(N, P.volume_fraction)
pos0, axes0, vel0 = gm.initial_conditions(int(P.seed), N, L, P.case, protocol, P.energy_per_particle)

# ---- scene -----------------------------------------------------------------------------
O.reset()
O.periodic = True
O.cell.setBox(L, L, L)
mat = O.materials.append(FrictMat(young=gm.YOUNG, poisson=gm.POISSON, density=gm.DENSITY,
                                  frictionAngle=0.0, label="grain"))
law = Law2_ScGeom_MindlinPhys_Mindlin()
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_MindlinPhys()],   # betan = betas = 0: no damping
                    [law]),                                 # frictionAngle 0: no tangential force
    NewtonIntegrator(damping=0.0, gravity=(0, 0, 0), exactAsphericalRot=False),
]


def build_dimer(c, u):
    """Append one two-sphere clump at centre c with axis u; return the clump body."""
    mc, mr = gm.dimer_members(u)
    spheres = [utils.sphere(tuple(c + mc[i]), float(mr[i]), material=mat) for i in range(2)]
    used = "appendClumped"
    if P.case == "exact" and P.builder in ("auto", "clumpprops"):
        try:
            from clumpprops.yade import append_clump
            cid, _ = append_clump(spheres, method="exact")
            used = "clumpprops.yade.append_clump"
        except ImportError:
            if P.builder == "clumpprops":
                raise
            cid, _ = O.bodies.appendClumped(spheres)
    else:
        cid, _ = O.bodies.appendClumped(spheres)
    b = O.bodies[int(cid)]
    if used.startswith("clumpprops"):   # cross-check the adapter against the study's numbers
        ip = max(b.state.inertia)
        if abs(b.state.mass / props["mass"] - 1) > 1e-9 or abs(ip / props["inertia"] - 1) > 1e-9:
            raise AssertionError(f"append_clump gave m={b.state.mass}, I_perp={ip}; expected "
                                 f"{props['mass']}, {props['inertia']}")
    # dimer COM is the same for summed and exact properties (symmetric); set the case's
    # mass and the isotropic I_perp route (see module docstring)
    b.state.mass = props["mass"]
    b.state.inertia = Vector3(props["inertia"], props["inertia"], props["inertia"])
    b.aspherical = False
    return b, used


parts = []
builder_used = None
for i in range(N):
    if props["shape"] == "dimer":
        b, builder_used = build_dimer(pos0[i], axes0[i])
    else:
        bid = O.bodies.append(utils.sphere(tuple(pos0[i]), props["radius"], material=mat))
        b = O.bodies[int(bid)]
        b.state.mass = props["mass"]
        b.state.inertia = Vector3(*(3 * [props["inertia"]]))
        builder_used = "sphere"
    b.state.vel = Vector3(*vel0[i])
    b.state.angVel = Vector3(0, 0, 0)
    parts.append(b)
if np.max(np.abs(np.array([tuple(b.state.pos) for b in parts]) - pos0)) > 1e-12:
    raise AssertionError("particle centres differ from the initial conditions")

# common time step for every case: dt_factor x P-wave step of a member sphere
DT = P.dt_factor * gm.R_SPHERE * np.sqrt(gm.DENSITY / gm.YOUNG)
if props["shape"] == "dimer":
    assert abs(utils.PWaveTimeStep() * P.dt_factor / DT - 1) < 1e-9
O.dt = DT
N_STEPS = int(round(P.t_end / DT))
N_REC = max(1, int(round(P.rec_interval / DT)))
N_FRAMES = N_STEPS // N_REC + 1
mass = props["mass"]
inertia = props["inertia"]

# ---- recording -------------------------------------------------------------------------
rec = {k: np.zeros(N_FRAMES) for k in ("t", "e_trans", "e_rot", "e_elastic")}
rec["momentum"] = np.zeros((N_FRAMES, 3))
traj = np.zeros((N_FRAMES, N, 3))
frame = [0]


INDEX = {b.id: k for k, b in enumerate(parts)}


def contact_forces(p):
    """Force and torque (about the particle centre) of every contact on every particle.

    Cheap: only the few real interactions of the dilute gas are visited.  The law adds
    -f to id1 and +f to id2 (see CONTACT_SIGN).
    """
    F = np.zeros((N, 3))
    T = np.zeros((N, 3))
    for I in O.interactions:
        if not I.isReal:
            continue
        f = np.array(tuple(I.phys.normalForce)) + np.array(tuple(I.phys.shearForce))
        for bid, sgn in ((I.id1, -CONTACT_SIGN), (I.id2, CONTACT_SIGN)):
            b = O.bodies[bid]
            k = INDEX[b.clumpId if b.isClumpMember else bid]
            F[k] += sgn * f
            T[k] += sgn * np.cross(np.array(tuple(b.state.pos)) - p[k], f)
    return F, T


# Law2_ScGeom_MindlinPhys_Mindlin adds -f to id1, +f to id2.  Checked on a 27-particle gas
# at volume fraction 0.02 over 20 s: energy error 4e-4 with this sign, 1.8e-2 with the
# opposite one and 8.6e-3 without the half-step synchronisation.
CONTACT_SIGN = 1.0


def snapshot(t):
    k = frame[0]
    if k >= N_FRAMES:
        return
    p = np.array([tuple(b.state.pos) for b in parts])       # unwrapped (YADE periodic cell)
    v = np.array([tuple(b.state.vel) for b in parts])
    w = np.array([tuple(b.state.angVel) for b in parts])
    if O.iter > 0:
        # leapfrog: vel/angVel are at the half step after the forces of this step, the
        # elastic energy belongs to the contact state of this step; bring the velocities
        # back half a step so that kinetic and elastic energy refer to the same time
        F, T = contact_forces(p)
        v = v - 0.5 * DT * F / mass
        w = w - 0.5 * DT * T / inertia
    e_t, e_r = gm.energies(mass, inertia, v, w)
    traj[k] = p
    rec["t"][k] = t
    rec["e_trans"][k] = e_t
    rec["e_rot"][k] = e_r
    # the law's scene pointer is null before the first step (calling it segfaults); the
    # initial state has no contacts (placement gap), so its elastic energy is zero
    rec["e_elastic"][k] = law.normElastEnergy() if O.iter > 0 else 0.0
    rec["momentum"][k] = mass * v.sum(axis=0)
    frame[0] = k + 1


def record():
    # PyRunner after the integrator: positions are those of time (iter + 1) * dt
    snapshot((O.iter + 1) * DT)


PROG = {"wall": time.time(), "iter": 0}


def progress():
    now = time.time()
    sps = (O.iter - PROG["iter"]) / max(now - PROG["wall"], 1e-9)
    PROG.update(wall=now, iter=O.iter)
    eta = (N_STEPS - O.iter) / max(sps, 1e-9)
    print(f"PROGRESS t={O.iter * DT:.1f} t_end={N_STEPS * DT:.1f} steps_per_s={sps:.0f} eta_s={eta:.0f}",
          flush=True)


if P.record:
    snapshot(0.0)
    O.engines = O.engines + [PyRunner(iterPeriod=N_REC, command="record()")]
O.engines = O.engines + [PyRunner(realPeriod=P.progress_period, command="progress()")]

# ---- run -------------------------------------------------------------------------------
setup_s = time.time() - WALL0
t0 = time.time()
O.run(N_STEPS, True)
run_s = time.time() - t0


def git_commit():
    try:
        c = subprocess.run(["git", "-C", ROOT, "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
        d = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--", "yade_scripts", "studies"],
                           capture_output=True, text=True).stdout.strip()
        return c + ("-dirty" if d else "")
    except OSError:
        return "unknown"


result = {
    "params": {k: getattr(P, k) for k in ("case", "protocol", "seed", "n_particles", "volume_fraction",
                                           "energy_per_particle", "t_end", "rec_interval", "dt_factor",
                                           "record", "energy_tol", "momentum_tol", "builder")},
    "effective_protocol": protocol,
    "properties": props,
    "builder": builder_used,
    "n_particles": N,
    "box_length": L,
    "dt": DT,
    "n_steps": N_STEPS,
    "rec_steps": N_REC,
    "yade_version": yade.config.version,
    "git_commit": git_commit(),
    "code_version": gm.code_version(),
    "wall_setup_s": setup_s,
    "wall_run_s": run_s,
    "steps_per_s": N_STEPS / max(run_s, 1e-9),
}

def axial_spin():
    """max |omega . u| and rms |omega| over the dimers (u: unit axis from the member spheres)."""
    if props["shape"] != "dimer":
        return 0.0, 0.0
    ax_max, w2 = 0.0, 0.0
    for b in parts:
        ms = [O.bodies[int(i)] for i in b.shape.members.keys()]
        ms = [m for m in ms if type(m.shape).__name__ == "Sphere"]
        u = np.array(tuple(ms[1].state.pos)) - np.array(tuple(ms[0].state.pos))
        u /= np.linalg.norm(u)
        w = np.array(tuple(b.state.angVel))
        ax_max = max(ax_max, abs(float(w @ u)))
        w2 += float(w @ w)
    return ax_max, float(np.sqrt(w2 / len(parts)))


result["axial_spin_max"], result["angvel_rms"] = axial_spin()

if P.record:
    n = frame[0]
    if n != N_FRAMES:
        raise RuntimeError(f"recorded {n} frames, expected {N_FRAMES}")
    e_tot = rec["e_trans"] + rec["e_rot"] + rec["e_elastic"]
    e_drift = float(np.max(np.abs(e_tot - e_tot[0])) / e_tot[0])
    p_scale = mass * np.sum(np.linalg.norm(vel0, axis=1))
    p_drift = float(np.max(np.linalg.norm(rec["momentum"] - rec["momentum"][0], axis=1)) / p_scale)
    reasons = []
    if not np.all(np.isfinite(traj)) or not np.isfinite(e_drift):
        reasons.append("non-finite state")
    if not e_drift <= P.energy_tol:
        reasons.append(f"energy drift {e_drift:.3g} > {P.energy_tol:g}")
    if not p_drift <= P.momentum_tol:
        reasons.append(f"momentum drift {p_drift:.3g} > {P.momentum_tol:g}")
    result.update(energy_drift=e_drift, momentum_drift=p_drift, ok=not reasons, fail_reasons=reasons,
                  e_total_initial=float(e_tot[0]))
    disp = (traj - traj[0]).astype(np.float32)   # displacement from t=0, small numbers
    tmp = P.out + ".tmp.npz"
    np.savez(tmp, t=rec["t"], pos0=traj[0], disp=disp, vel0=vel0, axes0=axes0,
             e_trans=rec["e_trans"], e_rot=rec["e_rot"], e_elastic=rec["e_elastic"],
             momentum=rec["momentum"])
    os.replace(tmp, P.out + ".npz")
    print(f"RESULT ok={result['ok']} energy_drift={e_drift:.3g} momentum_drift={p_drift:.3g} "
          f"steps_per_s={result['steps_per_s']:.0f}", flush=True)
else:
    print(f"RESULT bare steps_per_s={result['steps_per_s']:.0f}", flush=True)

tmp = P.out + ".tmp.json"
with open(tmp, "w") as f:
    json.dump(result, f, indent=1, default=float)
os.replace(tmp, P.out + ".json")
