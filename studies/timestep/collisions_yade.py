# -*- coding: utf-8 -*-
"""Binary collisions of clumps in YADE at one time step: the collision map of the dt study.

    python -m studies.timestep.collisions_yade IN.json OUT.json      # from the repository's root

(YADE 2023.02a: ``.venv/bin/python -m ...``; YADE 2025.2: ``scripts/debian13.sh run env
PYTHONPATH=/usr/lib/x86_64-linux-gnu/yade-double/py python3 -m ...``, as Debian's python3 does not
have YADE's Python package on its path.)  ``studies.timestep.collisions.run_map`` writes IN and
reads OUT; nothing else uses this module.

IN holds the material, the time step, the body (members, radii, mass, principal moments, builder
and route, exactly as ``studies.spec.run_input`` resolves them for the gas) and 2 n bodies: pair k
is bodies 2k and 2k+1, far from every other pair, on a collision course.  The scene is the gas's
(Hertz-Mindlin; frictionless and undamped unless the material gives ``friction``, ``restitution``,
``tangential_restitution``; no gravity) without a periodic cell.  The bodies are built
as ``yade_scripts/granular_gas.py`` builds them (same builders, mass, inertia, ``aspherical``
flag, integrator).  The run goes on until every pair is apart by more than twice the bounding
radius and separating (no contact can follow in free flight), then one more step.

Leapfrog bookkeeping (YADE's NewtonIntegrator): ``vel`` and ``angVel`` are half a step behind
the positions.  For the aspherical route on YADE >= 2025 (``rotAlgorithm='delValle2023'``) the
body-frame angular velocity R^T angVel is the one at the half step, so the initial angular
velocity (given at t = 0) is carried back half a step with Euler's equations (one RK4 step);
without that the free rotation follows a trajectory O(omega dt) away from the intended one
(measured: orientation error first order in dt; with it, second order).  OUT holds per body the
final velocity, the half-step body-frame angular velocities before and after the last step, the
orientation and the principal moments, and per pair whether a contact happened.
"""
import json
import math
import os
import sys
import time

os.environ["OMP_NUM_THREADS"] = "1"     # before YADE is imported: one thread per process

import numpy as np  # noqa: E402
import yade  # noqa: E402
import yade.config  # noqa: E402
from yade import O, utils  # noqa: E402
from yade.wrapper import (ForceResetter, InsertionSortCollider, Bo1_Sphere_Aabb, InteractionLoop,  # noqa: E402
                          Ig2_Sphere_Sphere_ScGeom, Ip2_FrictMat_FrictMat_MindlinPhys,
                          Law2_ScGeom_MindlinPhys_Mindlin, NewtonIntegrator, FrictMat, MatchMaker)
from yade.minieigenHP import Vector3  # noqa: E402


def w_dot(w, I):
    """Torque-free Euler equations in the body frame (principal moments I)."""
    return np.array([w[1] * w[2] * (I[1] - I[2]) / I[0], w[2] * w[0] * (I[2] - I[0]) / I[1],
                     w[0] * w[1] * (I[0] - I[1]) / I[2]])


def rk4(w, I, h):
    k1 = w_dot(w, I)
    k2 = w_dot(w + 0.5 * h * k1, I)
    k3 = w_dot(w + 0.5 * h * k2, I)
    k4 = w_dot(w + h * k3, I)
    return w + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


def rotation(b):
    m = b.state.ori.toRotationMatrix()
    return np.array([[float(m[i, j]) for j in range(3)] for i in range(3)])


def vec(v):
    return np.array([float(v[0]), float(v[1]), float(v[2])])


def _scene(R, route):
    """Reset YADE to the gas's scene (no bodies yet): its material and the integrator's rotation
    algorithm's name."""
    O.reset()
    M = R["material"]
    e = float(M.get("restitution", 1.0))
    mat = O.materials.append(FrictMat(young=M["youngs_modulus"], poisson=M["poisson"], density=M["density"],
                                      frictionAngle=math.atan(float(M.get("friction", 0.0))), label="grain"))
    # as yade_scripts/granular_gas.py: en (and es) set a viscous damping giving that restitution
    phys = (Ip2_FrictMat_FrictMat_MindlinPhys() if e >= 1.0 else
            Ip2_FrictMat_FrictMat_MindlinPhys(en=MatchMaker(algo="val", val=e),
                                              es=MatchMaker(algo="val", val=float(M.get("tangential_restitution", e)))))
    newton = NewtonIntegrator(damping=0.0, gravity=(0, 0, 0), exactAsphericalRot=(route == "aspherical"))
    rot_algorithm = "isotropic (aspherical=False)"
    if route == "aspherical":
        if not hasattr(newton, "rotAlgorithm"):
            raise RuntimeError(f"YADE {yade.config.version} has no NewtonIntegrator.rotAlgorithm (needs >= 2025)")
        newton.rotAlgorithm = R.get("rot_algorithm", "delValle2023")
        rot_algorithm = str(newton.rotAlgorithm)
    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb()]),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [phys], [Law2_ScGeom_MindlinPhys_Mindlin()]),
        newton,
    ]
    return mat, rot_algorithm


def _clump(body, route, mat, pos, ori):
    """One clump of ``body`` at ``pos`` with orientation matrix ``ori``, as
    ``yade_scripts/granular_gas.py`` builds it."""
    members = np.array(body["members"], float)
    radii = np.array(body["radii"], float)
    moments = np.array(body["moments"], float)
    xs = pos + members @ ori.T
    spheres = [utils.sphere(tuple(float(a) for a in xs[k]), float(radii[k]), material=mat)
               for k in range(len(radii))]
    if body["builder"] == "clumpprops":
        from clumpprops.yade import append_clump
        cid, _ = append_clump(spheres, method="exact")
    else:
        cid, _ = O.bodies.appendClumped(spheres)
    b = O.bodies[int(cid)]
    b.state.mass = float(body["mass"])
    if route == "isotropic":
        b.state.inertia = Vector3(*moments)
        b.aspherical = False
    else:
        # YADE sums the members' inertia about the scene origin and diagonalises it: far from the
        # origin that costs ~eps (|x|/k)^2 relative in the summed case (measured on the triangle
        # trimer's 4000-pair lattice, |x| up to 890 m: median 2e-8, max 1.5e-7).  Check to 1e-6 (a
        # wrong shape or mass is off by percents), then give every clump the case's moments, in
        # YADE's principal frame (any frame, for a degenerate tensor).
        # mass_scaled (studies/maps.py): the exact build's moments times moment_scale
        got = np.array([float(x) for x in b.state.inertia]) * float(body.get("moment_scale", 1.0))
        order = np.argsort(got)
        if np.max(np.abs(got[order] / np.sort(moments) - 1)) > 1e-6:
            raise AssertionError(f"{body['builder']} gave principal moments {got[order]!r}; "
                                 f"expected {moments!r}")
        fixed = np.empty(3)
        fixed[order] = np.sort(moments)
        b.state.inertia = Vector3(*(float(x) for x in fixed))
        b.aspherical = True
    return b


def _set_velocities(parts, route, vel0, angvel0, R0, inertia, dt):
    """The initial velocities; the aspherical route's angular velocity carried back half a step."""
    for i, b in enumerate(parts):
        b.state.vel = Vector3(*vel0[i])
        if route == "aspherical":
            wb = R0[i].T @ angvel0[i]
            wb_half = rk4(wb, inertia[i], -0.5 * dt)         # omega at t = -dt/2 (leapfrog)
            b.state.angVel = Vector3(*(R0[i] @ wb_half))
            b.state.angMom = Vector3(*(R0[i] @ (inertia[i] * wb_half)))   # YADE 2023 integrates angMom
        else:
            b.state.angVel = Vector3(*angvel0[i])


def _run_until_apart(R, parts, vel0, dt, r_b):
    """Run until every pair is apart and separating (or t_max): (touched, apart, done) per pair."""
    check_steps = max(1, int(round(float(R.get("check_interval", 2e-3)) / dt)))
    t_max = float(R["t_max"])
    pairs = np.arange(len(parts)).reshape(-1, 2)
    touched = np.zeros(len(pairs), bool)
    v_in = vel0.copy()
    done = False
    while O.iter * dt < t_max:
        O.run(check_steps, True)
        p = np.array([vec(b.state.pos) for b in parts])
        v = np.array([vec(b.state.vel) for b in parts])
        touched |= np.any(np.abs(v - v_in) > 0, axis=1).reshape(-1, 2).any(axis=1)
        r = p[pairs[:, 1]] - p[pairs[:, 0]]
        g = v[pairs[:, 1]] - v[pairs[:, 0]]
        apart = (np.einsum("ij,ij->i", r, r) > (2 * r_b * (1 + 1e-9)) ** 2) & (np.einsum("ij,ij->i", r, g) > 0)
        if apart.all() and not any(I.isReal for I in O.interactions):
            done = True
            break
    return touched, apart, done


def main(inp, outp):
    """Run the collisions of IN (``inp``, JSON) and write OUT (``outp``, JSON)."""
    wall0 = time.time()
    with open(inp) as f:
        R = json.load(f)
    body = R["body"]
    route = body["route"]
    dt = float(R["dt"])
    pos0 = np.array(R["pos"], float)
    ori0 = np.array(R["ori"], float).reshape(-1, 3, 3)
    vel0 = np.array(R["vel"], float)
    angvel0 = np.array(R["angvel"], float)
    n = len(pos0)
    mat, rot_algorithm = _scene(R, route)
    parts = [_clump(body, route, mat, pos0[i], ori0[i]) for i in range(n)]
    com0 = np.array([vec(b.state.pos) for b in parts])
    com_shift = float(np.max(np.abs(com0 - pos0)))
    inertia = np.array([vec(b.state.inertia) for b in parts])
    R0 = np.array([rotation(b) for b in parts])
    _set_velocities(parts, route, vel0, angvel0, R0, inertia, dt)
    O.dt = dt
    touched, apart, done = _run_until_apart(R, parts, vel0, dt, float(R["bounding_radius"]))
    n_steps = O.iter
    # the last step: half-step angular velocities on both sides of the full-step orientation
    w_before = np.array([rotation(b).T @ vec(b.state.angVel) for b in parts])
    R_end = np.array([rotation(b) for b in parts])
    O.run(1, True)
    w_after = np.array([rotation(b).T @ vec(b.state.angVel) for b in parts])
    out = {
        "yade_version": yade.config.version, "rot_algorithm": rot_algorithm, "dt": dt, "n_steps": n_steps,
        "t_end": n_steps * dt, "done": done, "wall_s": time.time() - wall0, "com_shift_max": com_shift,
        "n_bodies": len(O.bodies), "touched": touched.tolist(), "apart": apart.tolist(),
        "pos": [vec(b.state.pos).tolist() for b in parts],
        "vel": [vec(b.state.vel).tolist() for b in parts],
        "w_body_before": w_before.tolist(), "w_body_after": w_after.tolist(),
        "ori_end": R_end.reshape(n, 9).tolist(), "ori_start": R0.reshape(n, 9).tolist(),
        "inertia": inertia.tolist(), "mass": [float(b.state.mass) for b in parts],
    }
    tmp = outp + ".tmp"
    with open(tmp, "w") as f:
        json.dump(out, f)
    os.replace(tmp, outp)
    print(f"RESULT steps={n_steps} t_end={n_steps * dt:.4f} done={done} wall={out['wall_s']:.1f}s "
          f"yade={yade.config.version} rot={rot_algorithm}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
