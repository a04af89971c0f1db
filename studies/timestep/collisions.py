"""The collision map of the time-step study: collision courses drawn from the equilibrium gas, run in
YADE at one time step (``collisions_yade``), and the outcome of each collision.

The study and its method: the package docstring (``studies.timestep``) and docs/timestep.md.
"""
from __future__ import annotations

import json
import math
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

from .. import gas_model as gm
from .. import shapes as shp

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
YADE_SCRIPT = "studies.timestep.collisions_yade"     # run with python -m from ROOT (/repo in Debian 13)
YADE_PY = "/usr/lib/x86_64-linux-gnu/yade-double/py"  # YADE's Python package: not on Debian 13's python3 path
DEBIAN13 = os.path.join(ROOT, "scripts", "debian13.sh")
OUT = os.path.join(ROOT, "results", "timestep", "timestep.json")
MATERIAL = {"density": 1140.0, "youngs_modulus": 1.0e7, "poisson": 0.40}
ENERGY = 3.75            # J per particle (the paper's 3.24 kJ / 864)
D_TOL = 2e-3             # the tolerance on D
E_TOL = 1e-3             # the study's energy tolerance
SHAPES = {
    "dimer": {"shape": {"kind": "dimer", "sphere_diameter": 0.1333, "overlap": 0.5}, "yade": "2023.02a"},
    "trimer": {"shape": {"kind": "trimer_triangle", "sphere_diameter": 0.1333, "overlap": 0.5}, "yade": "2025.2"},
    "tetra": {"shape": {"kind": "tetrahedron", "sphere_diameter": 0.1333, "overlap": 0.5}, "yade": "2025.2"},
}


def cpu_children():
    """CPU seconds (user + system) of this process's finished children."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def random_rotations(rng, n):
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    w, x, y, z = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], 1)


def unit(rng, n):
    u = rng.normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1)[:, None]


def make_pairs(shape, n_pairs, seed, energy=ENERGY, gap=1e-3):
    """n_pairs binary collisions drawn from the equilibrium gas (pair k: bodies 2k, 2k+1).

    Relative velocity g = v_A - v_B: direction uniform, |g| from the collision-rate-weighted
    Maxwellian (density ~ g^3 exp(-mu g^2 / 2kT), mu = m/2); centre-of-mass velocity 0.  Impact
    parameter uniform over the disc of radius 2 r_b (r_b: bounding radius), so every collision
    of the gas is represented with its rate.  Orientations uniform; body-frame angular
    velocities Gaussian with variance kT/I_k (frictionless linear clumps: none about the axis).  kT =
    2 energy / (3 + rotational dof)."""
    rng = np.random.default_rng(seed)
    rho = MATERIAL["density"]
    props = shp.properties(shape, rho)
    cres = gm.resolve_case(props, "exact", friction=MATERIAL.get("friction", 0.0))
    m = cres["mass"]
    rot_dof = cres["rot_dof"]
    kT = 2.0 * energy / (3 + rot_dof)
    mu = m / 2
    r_b = shp.bounding_radius(shape, rho)
    n = n_pairs
    x = rng.gamma(2.0, 1.0, n)                      # mu g^2 / 2kT
    g = np.sqrt(2 * kT / mu * x)
    gh = unit(rng, n)
    bdir = unit(rng, n)
    bdir -= np.einsum("ij,ij->i", bdir, gh)[:, None] * gh
    bdir /= np.linalg.norm(bdir, axis=1)[:, None]
    b = 2 * r_b * np.sqrt(rng.uniform(size=n))
    s0 = np.sqrt((2 * r_b + gap) ** 2 - b ** 2)      # bounding spheres gap apart along the course
    sep = s0[:, None] * gh + b[:, None] * bdir       # p_B - p_A
    ori = random_rotations(rng, 2 * n)
    pm = np.asarray(props["exact"]["principal_moments"])
    z = rng.normal(size=(2 * n, 3))
    if cres["route"] == "isotropic" and props["linear"]:     # body z is the axis
        wb = z * np.sqrt(kT / pm[2])
        wb[:, 2] = 0.0
    else:
        wb = z * np.sqrt(kT / pm)
    angvel = np.einsum("nij,nj->ni", ori, wb)
    vel = np.empty((2 * n, 3))
    vel[0::2] = 0.5 * g[:, None] * gh
    vel[1::2] = -0.5 * g[:, None] * gh
    # lattice far enough apart that no body can reach a neighbouring pair before t_max
    e_pair = 0.5 * m * np.sum(vel.reshape(n, 2, 3) ** 2, axis=(1, 2)) + \
        0.5 * np.sum(pm * wb.reshape(n, 2, 3) ** 2, axis=(1, 2))
    v_bound = float(np.sqrt(2 * e_pair.max() / m))
    t_max = float(min(3.0, 0.2 + 8 * r_b / g.min()))
    spacing = 2 * (v_bound * t_max + 2 * r_b) + 1.0
    k = int(math.ceil(n ** (1 / 3)))
    ijk = np.stack(np.unravel_index(np.arange(n), (k, k, k)), 1).astype(float) * spacing
    pos = np.empty((2 * n, 3))
    pos[0::2] = ijk - 0.5 * sep
    pos[1::2] = ijk + 0.5 * sep
    body = {"builder": cres["builder"], "route": cres["route"], "mass": cres["mass"], "moments": cres["moments"],
            "members": props["members"], "radii": props["radii"]}
    return {"material": dict(MATERIAL), "body": body, "bounding_radius": r_b, "kT": kT, "rot_dof": rot_dof,
            "pos": pos.tolist(), "ori": ori.reshape(-1, 9).tolist(), "vel": vel.tolist(),
            "angvel": angvel.tolist(), "t_max": t_max, "spacing": spacing, "lattice": ijk.tolist(),
            "g": g.tolist(), "b": b.tolist(), "seed": seed, "rot_algorithm": "delValle2023"}


def native_yade_version():
    """Version of the YADE this Python imports (2023.02a on Debian 12, 2025.2 on Debian 13)."""
    out = subprocess.run([sys.executable, "-c", "import yade.config; print(yade.config.version)"],
                         capture_output=True, text=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
    return (out.stdout.strip().splitlines() or [""])[-1]


# how far two run inputs' numbers may differ and still be one run: a matrix product's round-off (the
# spins turned into the lab frame) differs between one-threaded and multi-threaded BLAS by ~1e-16
SAME_RTOL = 1e-12


def same_input(a, b, rtol=SAME_RTOL):
    """Whether two run inputs (parsed JSON) are one run: the same keys, lists, strings and integers,
    floats equal to ``rtol`` (relative, or absolute ``rtol`` near 0)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same_input(a[k], b[k], rtol) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same_input(x, y, rtol) for x, y in zip(a, b))
    if isinstance(a, float) or isinstance(b, float):
        if isinstance(a, bool) or isinstance(b, bool) or not isinstance(a, (int, float)) or not isinstance(b, (int, float)):
            return False
        return abs(a - b) <= rtol * max(abs(a), abs(b), 1.0)
    return type(a) is type(b) and a == b


def run_map(inp, factor, yade, tmp, name):
    dt = factor * p_wave_dt_of_body(inp)
    d = dict(inp, dt=dt)
    tag = f"{name}-E{inp['material']['youngs_modulus']:g}-f{factor}"    # runs at other E never collide
    fin = os.path.join(tmp, f"{tag}.in.json")
    fout = os.path.join(tmp, f"{tag}.out.json")
    text = json.dumps(d)
    if os.path.exists(fout) and os.path.exists(fin):       # the same run done before: reuse it
        with open(fin) as f:
            old = json.load(f)
        old.pop("shape", None)
        if same_input(old, json.loads(text)):
            with open(fout) as f:
                out = json.load(f)
            out["reused"] = True
            return out
    if os.path.exists(fout):       # another input's output: never reusable once fin is rewritten
        os.remove(fout)
    with open(fin, "w") as f:
        f.write(text)
    env = dict(os.environ, OMP_NUM_THREADS="1")
    stage = None
    if native_yade_version().startswith(yade):        # Debian 12 for 2023.02a, Debian 13 for 2025.2
        cmd = ["nice", "-n", "5", sys.executable, "-m", YADE_SCRIPT, fin, fout]
    elif yade.startswith("2025") and not os.environ.get("CLUMPPROPS_IN_DEBIAN13"):
        # the Debian 13 root sees only the repository (as /repo) and /tmp: stage the files in /tmp
        stage = tempfile.mkdtemp(prefix="cmap-", dir="/tmp")
        shutil.copy(fin, os.path.join(stage, "in.json"))
        cmd = ["nice", "-n", "5", DEBIAN13, "run", "env", f"PYTHONPATH={YADE_PY}", "python3", "-m", YADE_SCRIPT,
               os.path.join(stage, "in.json"), os.path.join(stage, "out.json")]
    else:
        raise RuntimeError(f"no YADE {yade} here (the native one is {native_yade_version()})")
    t0 = time.time()
    c0 = cpu_children()
    try:
        p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        if stage is not None and os.path.exists(os.path.join(stage, "out.json")):
            shutil.move(os.path.join(stage, "out.json"), fout)
    finally:
        if stage is not None:
            shutil.rmtree(stage, ignore_errors=True)
    if p.returncode != 0 or not os.path.exists(fout):
        raise RuntimeError(f"collision map {name} f={factor} failed ({p.returncode}):\n{p.stdout[-2000:]}\n"
                           f"{p.stderr[-2000:]}")
    with open(fout) as f:
        out = json.load(f)
    out["wall_driver_s"] = time.time() - t0
    out["cpu_s"] = cpu_children() - c0
    if not out["yade_version"].startswith(yade):
        raise RuntimeError(f"collision map {name}: ran YADE {out['yade_version']}, wanted {yade}")
    with open(fout, "w") as f:                              # keep the CPU time with the result
        json.dump(out, f)
    out["reused"] = False
    return out


def p_wave_dt_of_body(inp):
    return min(inp["body"]["radii"]) * math.sqrt(MATERIAL["density"] / MATERIAL["youngs_modulus"])


def outcome(inp, out):
    """Per-collision quantities of one run: dict of arrays (pairs first)."""
    n = len(inp["vel"]) // 2
    m = np.asarray(out["mass"])
    I = np.asarray(out["inertia"])                       # principal moments per body
    R0 = np.asarray(out["ori_start"]).reshape(-1, 3, 3)
    R1 = np.asarray(out["ori_end"]).reshape(-1, 3, 3)
    v0 = np.asarray(inp["vel"])
    w0 = np.asarray(inp["angvel"])
    v1 = np.asarray(out["vel"])
    wa = np.asarray(out["w_body_after"])                  # half-step, body frame
    wm = 0.5 * (np.asarray(out["w_body_before"]) + wa)    # full step (second order)
    wb0 = np.einsum("nji,nj->ni", R0, w0)
    L0 = np.einsum("nij,nj->ni", R0, I * wb0)
    L1 = np.einsum("nij,nj->ni", R1, I * wm)
    erot0 = 0.5 * np.sum(I * wb0 ** 2, axis=1)
    erot1 = 0.5 * np.sum(I * wa ** 2, axis=1)            # the integrator's free-flight invariant
    etr0 = 0.5 * m * np.sum(v0 ** 2, axis=1)
    etr1 = 0.5 * m * np.sum(v1 ** 2, axis=1)
    pair = lambda a: a.reshape(n, 2, *a.shape[1:])        # noqa: E731
    g0 = v0[0::2] - v0[1::2]
    g1 = v1[0::2] - v1[1::2]
    gg = np.einsum("ij,ij->i", g0, g0)
    q = np.einsum("ij,ij->i", g0, g0 - g1) / gg           # 1 - g'.g/g^2
    cos_chi = np.einsum("ij,ij->i", g0, g1) / np.sqrt(gg * np.einsum("ij,ij->i", g1, g1))
    e0 = pair(etr0 + erot0).sum(1)
    e1 = pair(etr1 + erot1).sum(1)
    p0 = np.asarray(inp["pos"])
    return {
        "dp": (m[:, None] * (v1 - v0))[0::2],            # momentum transfer to body A (B gets -dp)
        "dL": pair(L1 - L0),                              # spin angular momentum transfer, both bodies
        "g2": gg, "q": q, "one_minus_cos": 1.0 - np.clip(cos_chi, -1, 1),
        "de_rel": (e1 - e0) / e0, "e_pair": e0,
        "dk_tr": pair(etr1 - etr0).sum(1),                 # translational energy gained by the pair
        "erot0": pair(erot0).sum(1), "etr0": pair(etr0).sum(1),
        "touched": np.asarray(out["touched"], bool), "apart": np.asarray(out["apart"], bool),
        "ang_total_drift": _ang_total(p0, v0, L0, np.asarray(out["pos"]), v1, L1, m, n),
    }


def _ang_total(p0, v0, L0, p1, v1, L1, m, n):
    """Relative change of each pair's total angular momentum about its centre of mass."""
    c0 = 0.5 * (p0[0::2] + p0[1::2])
    c1 = 0.5 * (p1[0::2] + p1[1::2])
    J0 = np.cross(p0[0::2] - c0, m[0::2, None] * v0[0::2]) + np.cross(p0[1::2] - c0, m[1::2, None] * v0[1::2]) \
        + L0[0::2] + L0[1::2]
    J1 = np.cross(p1[0::2] - c1, m[0::2, None] * v1[0::2]) + np.cross(p1[1::2] - c1, m[1::2, None] * v1[1::2]) \
        + L1[0::2] + L1[1::2]
    return np.linalg.norm(J1 - J0, axis=1) / np.maximum(np.linalg.norm(J0, axis=1), 1e-300)


def paired_rel(x_h, x_ref, w=None):
    """Relative difference of the means <w x_h>/<w x_ref> - 1 and its standard error (paired)."""
    w = np.ones_like(x_ref) if w is None else w
    a, r = w * x_h, w * x_ref
    mr = r.mean()
    d = (a - r) / mr
    return float(d.mean()), float(d.std(ddof=1) / math.sqrt(len(d)))
