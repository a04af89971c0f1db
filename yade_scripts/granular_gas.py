# -*- coding: utf-8 -*-
"""A periodic granular gas of sphere clumps (Parteli, DISCUSSION / Fig. 2) in YADE: one run.

Run headless, one thread:
    OMP_NUM_THREADS=1 yade -n -x yade_scripts/granular_gas.py            (parameters below)
    YADE_BATCH=table:2 yade -n -x yade_scripts/granular_gas.py            (one line of a table)
    yade-batch table yade_scripts/granular_gas.py                         (many runs)
Parameters come from ``yade.utils.readParamsFromTable``:

  run    path of the run file (JSON) that ``python -m studies prepare SPEC`` writes: material,
         box, time step, the clump's member spheres, its mass and inertia, the initial state of
         every particle, and what to record.  Everything the run does comes from this file.
  out    output prefix: writes <out>.npz (the recorded frames) then <out>.json (run facts, last)

The script imports only YADE, numpy and clumpprops.  It builds the bodies the run file asks for:

* ``builder = "clumpprops"``: ``clumpprops.yade.append_clump`` (exact mass, centre of mass and
  inertia of the union of the spheres); ``"appendClumped"``: YADE's own summed clump;
  ``"sphere"``: one sphere.  Then the body gets the run file's mass, and for the
  ``route = "isotropic"`` the isotropic inertia I_perp with ``aspherical = False`` (exact for
  frictionless linear clumps without axial spin: every contact force passes through the axis);
  ``route = "aspherical"`` keeps the clump's principal moments and integrates full rigid-body
  rotation, which needs ``NewtonIntegrator.rotAlgorithm`` (YADE >= 2025, 'delValle2023').
* Contacts: Hertz-Mindlin, frictionless, undamped.  Recording: every ``rec_steps`` steps the
  unwrapped centres of mass, velocities, and the translational, rotational and elastic energies
  and momentum of the gas, with the velocities brought back half a step so that kinetic and
  elastic energy refer to the same instant.  Progress lines ``PROGRESS t= t_end= steps_per_s=
  eta_s=`` every ``progress_period`` wall seconds.
"""
import json
import os
import sys
import time


def _script_path():
    # `yade -x` exec()s the script with yade's own globals: __file__ is /usr/bin/yade
    for c in [globals().get("__file__", "")] + list(sys.argv):
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
                          Law2_ScGeom_MindlinPhys_Mindlin, NewtonIntegrator, PyRunner, FrictMat, MatchMaker)
from yade.minieigenHP import Vector3, Quaternion, Matrix3

import clumpprops

utils.readParamsFromTable(run="run.json", out="granular_gas_run", noTableOk=True)
from yade.params import table as P  # noqa: E402

WALL0 = time.time()
with open(P.run) as f:
    R = json.load(f)
body = R["body"]
N = len(R["initial"]["pos"])
L = float(R["box_length"])
DT = float(R["dt"])
N_STEPS = int(R["n_steps"])
N_REC = int(R["rec_steps"])
ROUTE = body["route"]
pos0 = np.array(R["initial"]["pos"], float)
ori0 = np.array(R["initial"]["ori"], float).reshape(N, 3, 3)
vel0 = np.array(R["initial"]["vel"], float)
angvel0 = np.array(R["initial"]["angvel"], float)
YADE_VERSION = yade.config.version

# ---- scene -----------------------------------------------------------------------------
O.reset()
O.periodic = True
O.cell.setBox(L, L, L)
MATERIAL = R["material"]
RESTITUTION = float(MATERIAL.get("restitution", 1.0))
FRICTION = float(MATERIAL.get("friction", 0.0))
DISSIPATIVE = RESTITUTION < 1.0 or FRICTION > 0.0
mat = O.materials.append(FrictMat(young=MATERIAL["youngs_modulus"], poisson=MATERIAL["poisson"],
                                  density=MATERIAL["density"], frictionAngle=float(np.arctan(FRICTION)),
                                  label="grain"))
law = Law2_ScGeom_MindlinPhys_Mindlin(calcEnergy=DISSIPATIVE)


def contact_physics():
    """Hertz-Mindlin; with ``restitution`` < 1 YADE's ``en`` (and ``es``, the run file's
    ``tangential_restitution``, else ``restitution``) set a viscous damping that gives that
    restitution in a head-on collision (docs/hcs.md); without it, no damping."""
    if RESTITUTION >= 1.0:
        return Ip2_FrictMat_FrictMat_MindlinPhys()          # betan = betas = 0: no damping
    es = float(MATERIAL.get("tangential_restitution", RESTITUTION))
    return Ip2_FrictMat_FrictMat_MindlinPhys(en=MatchMaker(algo="val", val=RESTITUTION),
                                             es=MatchMaker(algo="val", val=es))



newton = NewtonIntegrator(damping=0.0, gravity=(0, 0, 0), exactAsphericalRot=(ROUTE == "aspherical"))
ROT_ALGORITHM = "isotropic (aspherical=False)"
if ROUTE == "aspherical":
    if not hasattr(newton, "rotAlgorithm"):
        raise RuntimeError(f"YADE {YADE_VERSION} has no conservative aspherical integrator "
                           "(NewtonIntegrator.rotAlgorithm, YADE >= 2025): its Fincham 1992 scheme "
                           "gains energy; run this shape on YADE >= 2025")
    newton.rotAlgorithm = R.get("rot_algorithm", "delValle2023")
    ROT_ALGORITHM = str(newton.rotAlgorithm)
COLLIDER = InsertionSortCollider([Bo1_Sphere_Aabb()])
O.engines = [
    ForceResetter(),
    COLLIDER,
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom()],
                    [contact_physics()],
                    [law]),                                 # frictionAngle 0: no tangential force
    newton,
]

MEMBERS = np.array(body.get("members", []), float)
RADII = np.array(body.get("radii", []), float)
MASS = float(body["mass"])
MOMENTS = np.array(body["moments"], float)     # principal moments the body integrates with

# The collider re-sorts the bodies' bounds whenever one has moved its Verlet distance.  YADE's
# default (half the smallest radius) re-sorts every few steps in this dilute, fast gas; three
# bounding radii does the same work with 10-19 % less CPU (benchmarks/bench_gas.py).  Contacts are
# still found from the exact geometry every step, so the trajectory is the same to the last bit
# (tests/test_study_engine.py).  A padded sphere bound must stay well under half the periodic
# cell: at 45 % of it YADE's periodic collider handled a contact differently (measured in a
# 1.4 m box), so the padding is capped at a quarter of the cell per bound.  Every pair of
# overlapping padded bounds is a potential contact whose geometry is computed every step, so the
# padding is also capped at a quarter of the mean spacing of the member spheres: 1000 grains of
# 20 spheres at volume fraction 0.02 ran 3 steps/s padded by three bounding radii (0.3 m, about
# 180 overlapping bounds per member) and 126 steps/s padded by 0.02-0.05 m.  The run file's
# ``verlet_dist`` (m; -0.5: YADE's default) overrides.
R_BOUND = (float(body["radius"]) if body["builder"] == "sphere"
           else float(np.max(np.linalg.norm(MEMBERS, axis=1) + RADII)))
R_MEMBER = float(body["radius"]) if body["builder"] == "sphere" else float(np.max(RADII))
MEMBER_SPACING = L / (N * max(len(RADII), 1)) ** (1.0 / 3.0)
VERLET_PAD = min(3.0 * R_BOUND, 0.125 * L - R_MEMBER, 0.25 * MEMBER_SPACING)
VERLET_DIST = float(R.get("verlet_dist", VERLET_PAD if VERLET_PAD > 0 else -0.5))   # too small a box: the default
COLLIDER.verletDist = VERLET_DIST


def quat(Rm):
    return Quaternion(Matrix3(*[float(x) for x in Rm.flatten()]))   # minieigen Matrix3 takes rows


def build(i):
    """Append particle i; return its body."""
    if body["builder"] == "sphere":
        b = O.bodies[int(O.bodies.append(utils.sphere(tuple(pos0[i]), float(body["radius"]), material=mat)))]
        b.state.mass = MASS
        b.state.inertia = Vector3(*MOMENTS)
        return b
    xs = pos0[i] + MEMBERS @ ori0[i].T
    spheres = [utils.sphere(tuple(xs[k]), float(RADII[k]), material=mat) for k in range(len(RADII))]
    if body["builder"] == "clumpprops":
        from clumpprops.yade import append_clump
        cid, _ = append_clump(spheres, method="exact")
    else:
        cid, _ = O.bodies.appendClumped(spheres)
    b = O.bodies[int(cid)]
    b.state.mass = MASS
    if ROUTE == "isotropic":
        b.state.inertia = Vector3(*MOMENTS)
        b.aspherical = False
    else:
        got = np.sort([float(x) for x in b.state.inertia])
        if np.max(np.abs(got / MOMENTS - 1)) > 1e-9:
            raise AssertionError(f"{body['builder']} gave principal moments {got}; expected {MOMENTS}")
        b.aspherical = True
    return b


parts = [build(i) for i in range(N)]


def rotation(b):
    m = b.state.ori.toRotationMatrix()
    return np.array([[float(m[i, j]) for j in range(3)] for i in range(3)])


def inertia_world(b):
    Rb = rotation(b)
    return Rb @ np.diag([float(x) for x in b.state.inertia]) @ Rb.T


for i, b in enumerate(parts):
    b.state.vel = Vector3(*vel0[i])
    b.state.angVel = Vector3(*angvel0[i])
    if ROUTE == "aspherical":
        b.state.angMom = Vector3(*(inertia_world(b) @ angvel0[i]))   # YADE 2023 integrates angMom
# appendClumped puts a clump at its summed COM, clumpprops at the exact one (the same point for
# symmetric clumps); recorded for the run's facts
COM_OFFSET = np.array([tuple(b.state.pos) for b in parts]) - pos0

O.dt = DT
N_FRAMES = N_STEPS // N_REC + 1
rec = {k: np.zeros(N_FRAMES) for k in ("t", "e_trans", "e_rot", "e_elastic", "e_dissipated")}
rec["momentum"] = np.zeros((N_FRAMES, 3))
disp = np.zeros((N_FRAMES, N, 3), np.float32)
velrec = np.zeros((N_FRAMES, N, 3), np.float32)
P0 = np.array([tuple(b.state.pos) for b in parts])
INDEX = {b.id: k for k, b in enumerate(parts)}
frame = [0]
# Law2_ScGeom_MindlinPhys_Mindlin adds -f to id1, +f to id2 (checked: energy error 4e-4 with this
# sign on a 27-particle gas, 1.8e-2 with the opposite one)
CONTACT_SIGN = 1.0


def contact_forces(p):
    """Force and torque (about the body's centre of mass) of every contact on every particle."""
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


def snapshot(t):
    k = frame[0]
    if k >= N_FRAMES:
        return
    p = np.array([tuple(b.state.pos) for b in parts])       # unwrapped (YADE periodic cell)
    v = np.array([tuple(b.state.vel) for b in parts])
    w = np.array([tuple(b.state.angVel) for b in parts])
    if ROUTE == "aspherical":
        Iw = np.array([inertia_world(b) for b in parts])
    if O.iter > 0:
        # leapfrog: vel/angVel are half a step after the forces of this step; bring them back
        # half a step so that kinetic and elastic energy refer to the same instant
        F, T = contact_forces(p)
        v = v - 0.5 * DT * F / MASS
        if ROUTE == "aspherical":
            w = w - 0.5 * DT * np.linalg.solve(Iw, T[..., None])[..., 0]
        else:
            w = w - 0.5 * DT * T / MOMENTS[0]
    rec["t"][k] = t
    rec["e_trans"][k] = 0.5 * MASS * np.sum(v ** 2)
    if ROUTE == "aspherical":
        rec["e_rot"][k] = 0.5 * np.einsum("ni,nij,nj->", w, Iw, w)
    else:
        rec["e_rot"][k] = 0.5 * MOMENTS[0] * np.sum(w ** 2)
    # the law's scene pointer is null before the first step; the initial state has no contact
    rec["e_elastic"][k] = law.normElastEnergy() if O.iter > 0 else 0.0
    if DISSIPATIVE and O.iter > 0:
        # the law's energy terms (calcEnergy): tangential elastic energy, and the energy that
        # sliding and the normal and tangential dampers have taken out of the gas since t = 0
        rec["e_elastic"][k] += float(law.shearEnergy)
        rec["e_dissipated"][k] = float(law.frictionDissipation + law.normDampDissip + law.shearDampDissip)
    rec["momentum"][k] = MASS * v.sum(axis=0)
    disp[k] = p - P0
    velrec[k] = v
    frame[0] = k + 1


# the homogeneous cooling state: stop once T_tr (so E_trans) has fallen by this factor
COOLING_STOP = float(R.get("cooling_stop", 0.0))


def record():
    snapshot((O.iter + 1) * DT)       # PyRunner after the integrator: state of time (iter + 1) dt
    k = frame[0] - 1
    if COOLING_STOP and rec["e_trans"][k] * COOLING_STOP <= rec["e_trans"][0]:
        O.pause()


PROG = {"wall": time.time(), "iter": 0}


def progress():
    now = time.time()
    sps = (O.iter - PROG["iter"]) / max(now - PROG["wall"], 1e-9)
    PROG.update(wall=now, iter=O.iter)
    eta = (N_STEPS - O.iter) / max(sps, 1e-9)
    print(f"PROGRESS t={O.iter * DT:.2f} t_end={N_STEPS * DT:.2f} steps_per_s={sps:.0f} eta_s={eta:.0f}",
          flush=True)


RECORD = bool(R.get("record", True))
if RECORD:
    snapshot(0.0)
    O.engines = O.engines + [PyRunner(iterPeriod=N_REC, command="record()")]
O.engines = O.engines + [PyRunner(realPeriod=float(R.get("progress_period", 20.0)), command="progress()")]

setup_s = time.time() - WALL0
t0 = time.time()
O.run(N_STEPS, True)
run_s = time.time() - t0
progress()

facts = {
    "yade_version": YADE_VERSION,
    "rot_algorithm": ROT_ALGORITHM,
    "clumpprops_version": clumpprops.__version__,
    "python": sys.version.split()[0],
    "numpy": np.__version__,
    "n_particles": N, "dt": DT, "n_steps": N_STEPS, "rec_steps": N_REC,
    "wall_setup_s": setup_s, "wall_run_s": run_s, "steps_per_s": O.iter / max(run_s, 1e-9),
    "builder": body["builder"], "route": ROUTE,
    "body_mass": float(parts[0].state.mass), "body_inertia": [float(x) for x in parts[0].state.inertia],
    "com_offset_max": float(np.max(np.abs(COM_OFFSET))),
    "n_bodies": len(O.bodies),
    "verlet_dist": VERLET_DIST,
}
if DISSIPATIVE:
    # energy is not conserved: the checks test the balance E_trans + E_rot + E_elastic + E_dissipated
    facts.update(restitution=RESTITUTION, friction=FRICTION, energy_check="balance",
                 e_dissipated=float(rec["e_dissipated"][frame[0] - 1]) if RECORD else None)
if RECORD:
    facts["cooling_stopped"] = bool(COOLING_STOP and frame[0] < N_FRAMES)
    facts["steps_done"] = int(O.iter)
    if frame[0] != N_FRAMES and not facts["cooling_stopped"]:
        raise RuntimeError(f"recorded {frame[0]} frames, expected {N_FRAMES}")
    for key in rec:
        rec[key] = rec[key][:frame[0]]
    disp, velrec = disp[:frame[0]], velrec[:frame[0]]
    w = np.array([tuple(b.state.angVel) for b in parts])
    if ROUTE == "isotropic" and len(RADII) >= 2:
        # axial spin of linear clumps must stay at round-off (the isotropic route's premise)
        ax = []
        for b in parts:
            ms = [O.bodies[int(i)] for i in b.shape.members.keys()]
            ms = [m for m in ms if type(m.shape).__name__ == "Sphere"]
            u = np.array(tuple(ms[-1].state.pos)) - np.array(tuple(ms[0].state.pos))
            ax.append(abs(float(w[len(ax)] @ (u / np.linalg.norm(u)))))
        facts["axial_spin_max"] = float(max(ax))
    facts["angvel_rms"] = float(np.sqrt(np.mean(np.sum(w ** 2, axis=1))))
    tmp = P.out + ".tmp.npz"
    np.savez(tmp, t=rec["t"], pos0=P0, disp=disp, vel=velrec, e_trans=rec["e_trans"], e_rot=rec["e_rot"],
             e_elastic=rec["e_elastic"], momentum=rec["momentum"],
             **({"e_dissipated": rec["e_dissipated"]} if DISSIPATIVE else {}))
    os.replace(tmp, P.out + ".npz")
tmp = P.out + ".tmp.json"
with open(tmp, "w") as f:
    json.dump(facts, f, indent=1)
os.replace(tmp, P.out + ".json")
print(f"RESULT steps_per_s={facts['steps_per_s']:.0f} yade={YADE_VERSION} rot={ROT_ALGORITHM}", flush=True)
