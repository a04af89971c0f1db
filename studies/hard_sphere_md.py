"""The sphere gas as an N-body hard-sphere gas: its D against the Boltzmann equation's and Enskog's.

The study compares the YADE sphere gas (:mod:`studies.sphere_gas`) with the linear Boltzmann
equation's D for its N periodic particles (:func:`studies.kinetic.d_boltzmann`), divided by
Enskog's contact value chi (Carnahan-Starling: 1.0050 at the gas's volume fraction 0.0020).
Dividing by chi is Enskog's first density correction, and it is not exact: correlated (ring) and
three-body collisions, and in a periodic box recollisions through the images, change D at the same
order.  This module measures the N-body gas's D at the study's own state point with a second
engine, exact for hard spheres: event-driven molecular dynamics (``hsmd/hsmd.cpp``: a periodic
cube, N identical elastic spheres, exact free flights and collisions, events in time order; built
with g++ on first use and loaded with ctypes).

Per run (N spheres of 0.2 m at the study's number density, a uniform non-overlapping start,
Maxwellian velocities with zero total momentum and kinetic energy exactly 3/2 N kT, frames every
0.25 s as the YADE runs record them, the first ``--t-eq`` s dropped):

* D by the study's Green-Kubo estimator (``correlation.vacf_fft`` + ``diffusion.diffusion_green_kubo`` with
  its defaults), as the YADE runs are analysed;
* D by the exact Green-Kubo integral to ``--max-lag`` s, <v(0) . (r(T) - r(0))> / 3 from the
  unwrapped positions (exact for piecewise-constant velocities: no quadrature, no tail model);
* the collision rate per particle, whose equilibrium value is chi_true n' pi sigma^2 <g> (n' and
  <g> of the N - 1 partners, :func:`studies.kinetic._partner_law`), up to O(1/N) terms of the
  closed gas (its fixed energy raises <g> by about 1/(8M), M = (3N - 3)/2: +0.08 % at N = 108).

The reference is :func:`studies.kinetic.d_boltzmann` for hard spheres and the same N
(``--ref-chains`` chains).  Results go to ``results/hard_sphere_md.json``, one entry per N, with
every run's values; a later call continues an entry (new seeds) up to ``--runs`` runs, so a stopped
computation resumes.  Printed: D_MD / D_Boltzmann - 1 for both estimators (mean and standard
error over the runs, the independent units; the reference's own error added in quadrature) next
to Enskog's 1/chi - 1.

    .venv/bin/python -m studies.hard_sphere_md [--n 864] [--runs 200] [--ref-chains 32000]

About 3 CPU-s per 1,000 s run of 864 spheres, and 20 CPU-s per 8,000 reference chains.
"""
from __future__ import annotations

import argparse
import ctypes
import fcntl
import hashlib
import json
import math
import os
import platform
import subprocess
import time

import numpy as np

from . import correlation, diffusion, intervals
from . import kinetic
from .gas_model import random_sequential_positions
from .spec import ROOT

SOURCE = os.path.join(ROOT, "studies", "hsmd", "hsmd.cpp")
RESULTS = os.path.join(ROOT, "results", "hard_sphere_md.json")

# the study's sphere gas (results/sphere_gas.csv): 864 spheres of 0.2 m, the exact dimer's mass, in
# the paper's box; kT as the runs measure it
N = 864
BOX = 12.18284909686642          # m
SIGMA = 0.2                      # m
MASS = 2.3858201565553436        # kg
KT = 1.5                         # J
FRAME_DT = 0.25                  # s


def library(build_dir=os.path.join(ROOT, "build", "hsmd")):
    """The compiled engine (ctypes), built with g++ on first use under ``build_dir``, keyed by the
    source's hash and the C library's version (an edited source is rebuilt, and a build from the
    Debian 13 root, which bind-mounts this tree, is never loaded on the Debian 12 host)."""
    with open(SOURCE, "rb") as fh:
        key = hashlib.sha256(fh.read() + repr(platform.libc_ver()).encode()).hexdigest()[:16]
    so = os.path.join(build_dir, f"libhsmd-{key}.so")
    if not os.path.exists(so):
        os.makedirs(build_dir, exist_ok=True)
        tmp = f"{so}.{os.getpid()}.tmp"
        cmd = ["g++", "-O2", "-std=c++17", "-shared", "-fPIC", "-o", tmp, SOURCE]
        res = subprocess.run(cmd, capture_output=True, text=True)
        if res.returncode != 0:
            raise RuntimeError(f"compiling {SOURCE} failed:\n{res.stderr}")
        os.replace(tmp, so)
    lib = ctypes.CDLL(so)
    dp = ctypes.POINTER(ctypes.c_double)
    lib.hsmd_run.argtypes = [ctypes.c_int, ctypes.c_double, ctypes.c_double, ctypes.c_int, dp, dp,
                             ctypes.c_int, ctypes.c_double, dp, dp, ctypes.c_int, dp,
                             ctypes.POINTER(ctypes.c_longlong)]
    lib.hsmd_run.restype = ctypes.c_int
    return lib


def _ptr(a):
    return a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


def default_cells(n, box, sigma):
    """Cells per side: about one particle per two cells, never smaller than sigma, at least 4
    (hsmd.cpp: the minimum image is then the neighbouring cells' one)."""
    most = int(box / sigma)
    if most < 4:
        raise ValueError(f"box {box} m is smaller than 4 sphere diameters ({sigma} m): too small for the cell grid")
    return min(most, max(4, int(box / (2.0 * box ** 3 / n) ** (1.0 / 3.0))))


def simulate(pos0, vel0, box, sigma, n_frames, frame_dt=FRAME_DT, n_cells=None, check_gaps=False, lib=None):
    """Run the hard-sphere gas from ``pos0``, ``vel0`` (N, 3) [m, m/s] in a periodic cube of side
    ``box`` [m]; returns dict(pos (n_frames, N, 3) unwrapped [m], vel (n_frames, N, 3) [m/s],
    n_coll, min_gap (smallest |r_ij|/sigma - 1 over the frames, if ``check_gaps``))."""
    pos0 = np.ascontiguousarray(pos0, dtype=np.float64)
    vel0 = np.ascontiguousarray(vel0, dtype=np.float64)
    n = pos0.shape[0]
    if pos0.shape != (n, 3) or vel0.shape != (n, 3):
        raise ValueError(f"pos0 and vel0 must both be (N, 3), got {pos0.shape} and {vel0.shape}")
    if not (np.all(np.isfinite(pos0)) and np.all(np.isfinite(vel0))):
        raise ValueError("pos0 and vel0 must be finite")
    if n_cells is None:
        n_cells = default_cells(n, box, sigma)
    lib = lib or library()
    pos = np.empty((n_frames, n, 3))
    vel = np.empty((n_frames, n, 3))
    gap = ctypes.c_double(math.nan)
    ncoll = ctypes.c_longlong(0)
    rc = lib.hsmd_run(n, float(box), float(sigma), int(n_cells), _ptr(pos0), _ptr(vel0), int(n_frames),
                      float(frame_dt), _ptr(pos), _ptr(vel), int(bool(check_gaps)), ctypes.byref(gap),
                      ctypes.byref(ncoll))
    if rc == -1:
        raise ValueError(f"bad arguments: N={n}, box={box}, sigma={sigma}, n_cells={n_cells} "
                         "(need N >= 2, n_cells >= 4, box / n_cells >= sigma, n_frames >= 1, frame_dt > 0)")
    if rc == -2:
        raise ValueError("the start has overlapping spheres")
    return dict(pos=pos, vel=vel, n_coll=int(ncoll.value), min_gap=gap.value if check_gaps else None)


def initial_state(rng, n, box, sigma, kT, m):
    """Uniform non-overlapping positions (random sequential addition) and Maxwellian velocities with
    zero total momentum, scaled to the kinetic energy 3/2 N kT exactly (kT as the runs measure it)."""
    pos = random_sequential_positions(rng, n, box, sigma)
    vel = rng.normal(0.0, math.sqrt(kT / m), (n, 3))
    vel -= vel.mean(axis=0)
    vel *= math.sqrt(1.5 * n * kT / (0.5 * m * np.sum(vel ** 2)))
    return pos, vel


def exact_integral(pos, vel, frame_dt, max_lag):
    """(1/3) int_0^T <v(0).v(t)> dt = (1/3) <v(t0) . (r(t0 + T) - r(t0))> over particles and frame
    origins t0 [m^2/s]: exact for piecewise-constant velocities (T = ``max_lag`` s, a whole number
    of frames)."""
    k = int(round(max_lag / frame_dt))
    if k < 1 or k >= pos.shape[0]:
        raise ValueError(f"max_lag {max_lag} s outside the run ({pos.shape[0]} frames of {frame_dt} s)")
    disp = pos[k:] - pos[:-k]
    return float(np.einsum("tni,tni->", vel[:-k], disp) / (3.0 * disp.shape[0] * disp.shape[1]))


def equilibrated_run(seed, n=N, box=BOX, sigma=SIGMA, kT=KT, m=MASS, t_end=1000.0, t_eq=50.0, lib=None):
    """One run from :func:`initial_state` drawn with ``seed``: the first ``t_eq`` s run and dropped,
    then recorded to ``t_end`` s.  Returns (:func:`simulate`'s dict for t_eq..t_end, the collisions
    during the dropped start)."""
    rng = np.random.default_rng(seed)
    pos0, vel0 = initial_state(rng, n, box, sigma, kT, m)
    n_frames = int(round(t_end / FRAME_DT)) + 1
    k_eq = int(round(t_eq / FRAME_DT))
    r0 = simulate(pos0, vel0, box, sigma, k_eq + 1, lib=lib)
    return simulate(r0["pos"][-1], r0["vel"][-1], box, sigma, n_frames - k_eq, lib=lib), r0["n_coll"]


def one_run(seed, n=N, box=BOX, sigma=SIGMA, kT=KT, m=MASS, t_end=1000.0, t_eq=50.0, max_lag=150.0, lib=None):
    """D of one run by the study's Green-Kubo estimator and by the exact integral to ``max_lag``,
    and the collision rate per particle [1/s]."""
    out, coll_eq = equilibrated_run(seed, n, box, sigma, kT, m, t_end, t_eq, lib)
    pos, vel = out["pos"], out["vel"]
    c = correlation.vacf_fft(vel, int(round(max_lag / FRAME_DT)))
    lag = np.arange(c.size) * FRAME_DT
    return dict(seed=int(seed), d_gk=diffusion.diffusion_green_kubo(lag, c), d_exact=exact_integral(pos, vel, FRAME_DT, max_lag),
                rate=2.0 * out["n_coll"] / (n * (t_end - t_eq)), coll_eq=coll_eq,
                kT=float(0.5 * m * np.sum(vel[0] ** 2) / (1.5 * n)))


def _engine_hash():
    with open(SOURCE, "rb") as fh:
        return hashlib.sha256(fh.read()).hexdigest()[:16]


def _versions():
    cc = subprocess.run(["g++", "--version"], capture_output=True, text=True).stdout.splitlines()
    try:
        commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--", "studies"], capture_output=True,
                               text=True).stdout.strip() != ""
    except OSError:                    # no git: the engine's hash still identifies the code that ran
        commit, dirty = "", None
    return dict(python=platform.python_version(), numpy=np.__version__, compiler=cc[0] if cc else "", commit=commit,
                studies_dirty=dirty, engine_sha256=_engine_hash())


def summarise(entry):
    """Add the summary statistics of ``entry``'s runs (in place) and return it: for "d_gk",
    "d_exact" and "rate" the mean, its standard error and the sd per run; the D's relative to the
    Boltzmann reference ("_rel_boltzmann", with "_se" carrying both errors) and to Enskog's
    D_Boltzmann / chi ("_rel_enskog"); the rate relative to Enskog's; "gk_minus_exact",
    mean(D_GK) / mean(D_exact) - 1 with its delta-method error from the paired runs (the
    estimator's bias on this gas)."""
    runs = entry["per_run"]
    d_ref, se_ref, chi = entry["d_boltzmann"], entry["d_boltzmann_se"], entry["enskog_chi"]
    for key in ("d_gk", "d_exact", "rate"):
        entry[key], _, _, entry[key + "_se"], n_ = intervals.t_interval([x[key] for x in runs])
        entry[key + "_sd_per_run"] = entry[key + "_se"] * math.sqrt(n_)
    for key in ("d_gk", "d_exact"):
        se = math.hypot(entry[key + "_se"] / d_ref, entry[key] * se_ref / d_ref ** 2)
        entry[key + "_rel_boltzmann"] = entry[key] / d_ref - 1.0
        entry[key + "_rel_enskog"] = entry[key] * chi / d_ref - 1.0
        entry[key + "_rel_boltzmann_se"] = se
        entry[key + "_rel_enskog_se"] = chi * se
    # the study's estimator against the exact integral on the same runs: the ratio of the means (a
    # mean of per-run ratios would carry the noisy denominator's bias, Var/mu^2 ~ 3e-4 per run at
    # N = 864), with the delta-method error of the paired differences
    entry["gk_minus_exact"], entry["gk_minus_exact_se"] = intervals.ratio_of_means([x["d_gk"] for x in runs],
                                                                           [x["d_exact"] for x in runs])
    entry["enskog_rel"] = 1.0 / chi - 1.0
    entry["rate_rel_enskog"] = entry["rate"] / entry["rate_enskog"] - 1.0
    entry["rate_rel_enskog_se"] = entry["rate_se"] / entry["rate_enskog"]
    entry["n_runs"] = len(runs)
    return entry


def read(path=RESULTS):
    """The entries of results/hard_sphere_md.json (a list, one per N; [] if there is none)."""
    if not os.path.exists(path):
        return []
    with open(path) as fh:
        return json.load(fh)["gases"]


def _write(entry, path):
    """Put ``entry`` into the file at ``path`` in place of the entry of the same N, keeping the
    others as they are in the file now (another N may be running beside this one)."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(f"{path}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        entries = [e for e in read(path) if e.get("n") != entry["n"]] + [entry]
        entries.sort(key=lambda e: e["n"])
        tmp = f"{path}.tmp{os.getpid()}"
        with open(tmp, "w") as fh:
            json.dump({"about": "studies/hard_sphere_md.py: event-driven hard-sphere MD of the study's sphere gas "
                                "against the Boltzmann equation (one entry per N)", "gases": entries}, fh, indent=1)
        os.replace(tmp, path)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=200, help="runs wanted for this N (an entry is continued up to it)")
    ap.add_argument("--n", type=int, default=N, help="particles (the box keeps the study's number density)")
    ap.add_argument("--t-end", type=float, default=1000.0)
    ap.add_argument("--t-eq", type=float, default=50.0)
    ap.add_argument("--max-lag", type=float, default=150.0)
    ap.add_argument("--ref-chains", type=int, default=32000)
    ap.add_argument("--out", default=RESULTS)
    a = ap.parse_args(argv)
    if a.runs < 2 or a.n < 3 or not (a.t_end > a.t_eq + 3 * a.max_lag) or a.ref_chains < 2:
        ap.exit(2, "hard_sphere_md: need --runs >= 2, --n >= 3, --t-end > --t-eq + 3 --max-lag, --ref-chains >= 2\n")
    box = BOX * (a.n / N) ** (1.0 / 3.0)
    n_dens = a.n / box ** 3
    phi = n_dens * math.pi * SIGMA ** 3 / 6.0
    params = dict(n=a.n, box=box, sigma=SIGMA, mass=MASS, kT=KT, frame_dt=FRAME_DT, t_end=a.t_end, t_eq=a.t_eq,
                  max_lag=a.max_lag)
    entry = next((e for e in read(a.out) if all(e.get(k) == v for k, v in params.items())), None)
    if entry is None:                  # a new entry (it replaces one of the same N and other parameters)
        entry = dict(params, number_density=n_dens, volume_fraction=phi, rho_sigma3=n_dens * SIGMA ** 3,
                     enskog_chi=kinetic.enskog_chi(phi), per_run=[], md_cpu_s=0.0)
    if entry.get("ref_chains") != a.ref_chains:
        t1 = time.process_time()
        d_ref, se_ref = kinetic.d_boltzmann(n_dens, KT, MASS, SIGMA, None, n_chains=a.ref_chains, n_steps=3000, seed=a.n,
                                      n_particles=a.n)
        _, _, n_partners, g_mean = kinetic._partner_law(n_dens, KT, MASS, a.n)     # N - 1 partners, zero momentum
        entry.update(d_boltzmann=d_ref, d_boltzmann_se=se_ref, ref_chains=a.ref_chains,
                     ref_cpu_s=time.process_time() - t1,
                     rate_enskog=entry["enskog_chi"] * n_partners * math.pi * SIGMA ** 2 * g_mean)
        print(f"[hsmd] N = {a.n}: Boltzmann D {d_ref:.5f} +- {se_ref:.5f} m^2/s ({a.ref_chains} chains, "
              f"{entry['ref_cpu_s']:.0f} CPU-s)", flush=True)
    lib = library()
    done = {x["seed"] for x in entry["per_run"]}
    todo = [s_ for s_ in range(1, 10 * a.runs + 1) if s_ not in done][:max(0, a.runs - len(done))]
    t0 = time.process_time()
    for k, seed in enumerate(todo):
        entry["per_run"].append(one_run(seed, n=a.n, box=box, t_end=a.t_end, t_eq=a.t_eq, max_lag=a.max_lag, lib=lib))
        if (k + 1) % 20 == 0 or k + 1 == len(todo):
            entry["md_cpu_s"] += time.process_time() - t0
            t0 = time.process_time()
            v = _versions()
            entry.update(versions=v)                       # the latest batch's
            entry.setdefault("batches", []).append(dict(v, runs=len(entry["per_run"])))
            if len(entry["per_run"]) >= 2:
                summarise(entry)
            _write(entry, a.out)
            print(f"[hsmd] N = {a.n}: {len(entry['per_run'])}/{a.runs} runs, {entry['md_cpu_s']:.0f} CPU-s; "
                  f"D (GK) {entry.get('d_gk', math.nan):.5f} +- {entry.get('d_gk_se', math.nan):.5f} m^2/s", flush=True)
    if len(entry["per_run"]) < 2:
        ap.exit(1, "hard_sphere_md: fewer than 2 runs, no summary\n")
    if not todo:                       # nothing run: the stored runs summarised again (the loop wrote the rest)
        summarise(entry)
        _write(entry, a.out)
    e = entry
    print(f"[hsmd] N = {a.n}, rho sigma^3 = {e['rho_sigma3']:.5f} (phi = {phi:.5f}), {e['n_runs']} runs of "
          f"{a.t_end:g} s ({e['md_cpu_s']:.0f} CPU-s); Boltzmann D {e['d_boltzmann']:.5f} +- {e['d_boltzmann_se']:.5f} m^2/s")
    for key, label in (("d_gk", "study's Green-Kubo"), ("d_exact", f"exact integral to {a.max_lag:g} s")):
        print(f"  D_MD / D_Boltzmann - 1 ({label}): {100 * e[key + '_rel_boltzmann']:+.3f} % "
              f"+- {100 * e[key + '_rel_boltzmann_se']:.3f} % (sd per run {100 * e[key + '_sd_per_run'] / e[key]:.2f} %); "
              f"against Enskog's D_Boltzmann / chi: {100 * e[key + '_rel_enskog']:+.3f} %")
    print(f"  Enskog, 1/chi - 1: {100 * e['enskog_rel']:+.3f} %")
    print(f"  the study's Green-Kubo / exact integral - 1 (paired by run): {100 * e['gk_minus_exact']:+.3f} % "
          f"+- {100 * e['gk_minus_exact_se']:.3f} %")
    print(f"  collision rate / Enskog's - 1: {100 * e['rate_rel_enskog']:+.3f} % +- {100 * e['rate_rel_enskog_se']:.3f} %")
    print(f"  written {os.path.relpath(a.out, ROOT)}")
    return e


if __name__ == "__main__":
    main()
