"""Synthetic cooling runs with a known answer: a homogeneous gas of rough spheres by direct
simulation Monte Carlo (DSMC).

The estimators of :mod:`studies.hcs_effects` read a finite gas's cooling curve, T_rot / T_tr and
MSD, whose fluctuations (collision counting, the exchange between translation and rotation, the
relaxation from an equipartition start) set their bias and their intervals' coverage.  This module
makes runs with those fluctuations and an answer known to any accuracy wanted: Bird's
no-time-counter DSMC of the Boltzmann equation for equal rough spheres, the collisions of
:func:`studies.hcs_theory.collide` with a rule from :mod:`studies.hcs_theory` (constant tangential
restitution, or Walton's Coulomb rule).  Each particle flies freely between collisions, so its
unwrapped position gives the Boltzmann gas's MSD; positions do not decide who collides (the gas
is homogeneous by construction, and its count variance ratio is 1).  Every particle is a
candidate once per step, so free flights last whole steps: the MSD's D reads low by about
p nu_v dt / 2, 2.8 % for elastic smooth spheres at the majorant :data:`W_SIGMAS` (p = 0.084 of the
candidates collide per step).  A paired case / exact ratio cancels it to first order; the
cooling rate shows no step bias (Haff's rate within 0.3 % at 1, 2 and 4 times the majorant).  A run's output is the ``hcs`` series of a reduced YADE record
(:func:`studies.hcs.series`), so every estimator reads it unchanged.

Units: sphere diameter 1, mass 1, initial translational temperature 1 (T = m <v_x^2>), and the
number density that makes the initial collision frequency 4 n sigma^2 sqrt(pi T / m) equal to 1:
times are in mean free times of the start.
"""
from __future__ import annotations

import math

import numpy as np

from . import hcs, hcs_theory

__all__ = ["DENSITY", "initial_state", "simulate"]

# number density (diameter 1, mass 1) whose collision frequency at T = 1 is 1
DENSITY = 1.0 / (4.0 * math.sqrt(math.pi))
# NTC majorant of the approach speed u.n, in standard deviations sqrt(2 T_tr / m) of one of its
# components: a candidate above it is accepted with probability 1 (about 1e-6 of the candidates)
W_SIGMAS = 4.75


def initial_state(n_particles, seed):
    """Positions, translational velocities and unit spin draws shared by every case of a seed.

    Parameters
    ----------
    n_particles : int
        Number of spheres N.
    seed : int
        The seed: one initial state per seed (the paired protocol).

    Returns
    -------
    dict
        ``pos`` (N, 3) uniform in the box, ``vel`` (N, 3) Maxwellian at T_tr = 1 with zero total
        momentum, ``spin`` (N, 3) standard normal (the case's spins are ``spin`` sqrt(T_rot / I)),
        ``box_length``.
    """
    rng = np.random.default_rng([seed, 1])
    box = (n_particles / DENSITY) ** (1.0 / 3.0)
    vel = rng.standard_normal((n_particles, 3))
    vel -= vel.mean(axis=0)
    vel /= math.sqrt(np.mean(vel ** 2))
    return {"pos": rng.random((n_particles, 3)) * box, "vel": vel, "spin": rng.standard_normal((n_particles, 3)),
            "box_length": box}


def simulate(state, rule, kappa, t_end, rec_interval=0.25, spin_ratio=1.0, cooling_stop=None, seed=0,
             restitution=float("nan"), friction=float("nan"), grid=False):
    """Run the DSMC gas from ``state`` and return its HCS series.

    Parameters
    ----------
    state : dict
        :func:`initial_state`.
    rule : callable
        ``rule(g_n, |g_t|, kappa) -> (e, beta)`` (:func:`studies.hcs_theory.constant_beta_rule`,
        :func:`studies.hcs_theory.walton_rule`).
    kappa : float
        Reduced moment of inertia 4 I / (m sigma^2).
    t_end : float
        Time to stop (mean free times of the start).
    rec_interval : float, optional
        A frame is recorded at the first step ending after each multiple of it.
    spin_ratio : float, optional
        T_rot / T_tr at the start.
    cooling_stop : float, optional
        Stop once T_tr has fallen by this factor.
    seed : int, optional
        The collisions' random stream (the run's own; the initial state is ``state``'s).
    restitution, friction : float, optional
        Stored in the series as the contact's parameters.
    grid : bool, optional
        Also keep every frame's positions and return the multi-origin MSD grid
        (:func:`studies.hcs.msd_grid`: ``grid_t``, ``grid_msd``), as a reduced YADE record has it.

    Returns
    -------
    dict
        The series of :func:`studies.hcs.series` (``t``, ``e_trans``, ``e_rot``, ``msd``,
        ``count_ratio``, ...), with ``builder = "dsmc"``, ``n_collisions`` and ``e_dissipated`` (the
        energy the collisions have taken out by each frame).
    """
    if not kappa > 0 or not t_end > 0 or not rec_interval > 0 or not spin_ratio >= 0:
        raise ValueError(f"need kappa, t_end, rec_interval > 0 and spin_ratio >= 0, got {kappa}, {t_end}, "
                         f"{rec_interval}, {spin_ratio}")
    rng = np.random.default_rng([seed, 2])
    vel = np.array(state["vel"], float)
    n = len(vel)
    if n < 4 or n % 2:
        raise ValueError(f"need an even number of particles >= 4, got {n}")
    inertia = kappa / 4.0                                   # m = 1, sigma = 1
    w = np.array(state["spin"], float) * math.sqrt(spin_ratio / inertia)
    pos0 = np.array(state["pos"], float)
    pos = pos0.copy()
    box = float(state["box_length"])
    volume = box ** 3
    frames = {"t": [], "e_trans": [], "e_rot": [], "msd": [], "e_lost": [], "pos": []}
    lost = [0.0]

    def record(t):
        frames["t"].append(t)
        frames["e_trans"].append(0.5 * float(np.sum(vel ** 2)))
        frames["e_rot"].append(0.5 * inertia * float(np.sum(w ** 2)))
        frames["msd"].append(float(np.mean(np.sum((pos - pos0) ** 2, axis=1))))
        frames["e_lost"].append(lost[0])
        if grid:
            frames["pos"].append(pos.copy())

    t, next_frame, n_coll = 0.0, rec_interval, 0
    record(0.0)
    e0 = frames["e_trans"][0]
    half = n // 2
    while t < t_end:
        t_tr = float(np.sum(vel ** 2)) / (3.0 * n)
        w_max = W_SIGMAS * math.sqrt(2.0 * t_tr)
        dt = volume / (4.0 * math.pi * w_max * (n - 1))     # each pair is a candidate with probability 1/(N-1)
        pos += vel * dt
        t += dt
        perm = rng.permutation(n)
        i, j = perm[:half], perm[half:]
        nv = rng.standard_normal((half, 3))
        nv /= np.linalg.norm(nv, axis=1)[:, None]
        u_n = np.einsum("ij,ij->i", vel[i] - vel[j], nv)
        acc = rng.random(half) * w_max < u_n
        if acc.any():
            a, b, nn = i[acc], j[acc], nv[acc]
            e_before = 0.5 * float(np.sum(vel[a] ** 2 + vel[b] ** 2) + inertia * np.sum(w[a] ** 2 + w[b] ** 2))
            vel[a], vel[b], w[a], w[b], _ = hcs_theory.collide(vel[a], vel[b], w[a], w[b], nn, rule, kappa)
            lost[0] += e_before - 0.5 * float(np.sum(vel[a] ** 2 + vel[b] ** 2) + inertia * np.sum(w[a] ** 2 + w[b] ** 2))
            n_coll += int(acc.sum())
        if t >= next_frame:
            record(t)
            next_frame = rec_interval * (math.floor(t / rec_interval) + 1)
            if cooling_stop and frames["e_trans"][-1] * cooling_stop <= e0:
                break
    # the gas is homogeneous by construction (positions do not decide who collides): its count
    # variance ratio is 1, so no window ends at a fluctuation of the counts
    cells = 4
    out = {"t": frames["t"], "e_trans": frames["e_trans"], "e_rot": frames["e_rot"], "msd": frames["msd"],
           "count_ratio": [1.0] * len(frames["t"]),
           "cells_per_side": cells, "n_particles": n, "rot_dof": 3, "box_length": box, "builder": "dsmc",
           "mass": 1.0, "diameter": 1.0, "restitution": restitution, "friction": friction,
           "n_collisions": n_coll, "e_dissipated": frames["e_lost"]}
    if grid:
        out.update(hcs.msd_grid(frames["t"], np.asarray(frames["pos"]) - pos0))
    return out
