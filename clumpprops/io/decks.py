"""Runnable input decks: the exported clumps in an empty box, no gravity, a free run of N steps.

``clumpprops export FILE --to liggghts|lammps|yade --deck`` writes, beside the clump files,
one deck that inserts every clump at rest or with ``--velocity VX VY VZ`` (m/s) and
``--spin WX WY WZ`` (rad/s, space frame) and runs ``--steps N`` steps of ``--dt`` s:

========  ==========================  =====================================================
engine    deck (run it in --out)      what it reports
========  ==========================  =====================================================
liggghts  ``STEM_deck_liggghts.in``   thermo ``c_ke c_er`` (ke/multisphere, erotate/multisphere,
          ``liggghts -in FILE``       17 digits); member ``id x y z vx vy vz`` in
                                      ``STEM_liggghts_start.dump`` (the step the bodies are
                                      inserted) and ``STEM_liggghts_end.dump`` (step N)
lammps    ``STEM_deck_lammps.in``     thermo ``c_ke c_er`` (ke/rigid, erotate/rigid); member
          ``lmp -in FILE``            ``id mol x y z vx vy vz`` at steps 0 and N in
                                      ``STEM_lammps.dump``
yade      ``STEM_deck_yade.py``       prints each clump's mass, inertia tensor (space frame),
          ``yade -x FILE``            angular momentum and kinetic energy at step 0 and N
========  ==========================  =====================================================

Each deck names its files relative to its own folder: run it there.  LIGGGHTS inserts the
clumps in random places of a region in the middle of the box, in the orientation of the
sphere files (the source file's axes); LAMMPS and YADE keep them where the source file puts
them.  The LAMMPS deck gives the bodies their initial state through the ``fix rigid``
infile (``vxcm``, and ``lx ly lz`` = I w with the exact tensor I), and has no pair
interactions (``pair_style zero``): add a granular pair style for contacts.  The timestep is
a fifth of the Rayleigh time of the smallest sphere for the deck's contact material
(LIGGGHTS: Hertz, E = 1e7 Pa, nu = 0.4), and at most 0.01/|w|.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import List, Optional, Sequence

import numpy as np

from ._common import Clump, Props, fnum, header_lines

#: The engines :func:`write` makes a deck for.
DECK_ENGINES = ("liggghts", "lammps", "yade")

YOUNG, POISSON = 1.0e7, 0.4  # the LIGGGHTS deck's contact material


def default_dt(clumps: Sequence[Clump], density: float, spin=(0.0, 0.0, 0.0)) -> float:
    """A fifth of the Rayleigh time of the smallest sphere, and at most 0.01 rad per step.

    Parameters
    ----------
    clumps : sequence of Clump
        The clumps of the deck.
    density : float
        Their density, kg/m^3.
    spin : sequence of 3 float, optional
        The initial angular velocity, rad/s.

    Returns
    -------
    float
        The timestep in s.
    """
    rmin = min(float(np.min(c.radii)) for c in clumps)
    shear = YOUNG / (2.0 * (1.0 + POISSON))
    rayleigh = math.pi * rmin * math.sqrt(density / shear) / (0.1631 * POISSON + 0.8766)
    w = float(np.linalg.norm(spin))
    return min(0.2 * rayleigh, 0.01 / w) if w > 0 else 0.2 * rayleigh


def _reach(clumps, com) -> float:
    """The largest distance of a sphere's surface from its clump's centre of mass, m."""
    return max(float(np.max(np.linalg.norm(c.centers - com[k], axis=1) + c.radii)) for k, c in enumerate(clumps))


def _dump_format(ncols: int) -> str:
    return '"%d' + " %.17g" * ncols + '"'


def _thermo(steps: int) -> List[str]:
    """The thermo lines both LIGGGHTS and LAMMPS decks print: step, atoms, ke, erotate (17 digits)."""
    return ["thermo_style custom step atoms c_ke c_er", "thermo_modify format float %.17g norm no",
            f"thermo {max(1, steps // 10)}"]


def _liggghts(clumps, mp, stem: str, velocity, spin, steps: int, dt: float, header) -> str:
    """The LIGGGHTS deck: ``include STEM_liggghts.in``, insert, ``fix multisphere``, run (see :func:`write`)."""
    P = Props(mp)
    b = _reach(clumps, P.com)
    n = len(clumps)
    half_ins = 2.0 * b * max(1, math.ceil(n ** (1.0 / 3.0)))
    half = half_ins + b + float(np.linalg.norm(velocity)) * steps * dt + b
    rmin = min(float(np.min(c.radii)) for c in clumps)
    single = any(c.n_spheres == 1 for c in clumps)
    v, w = " ".join(fnum(x) for x in velocity), " ".join(fnum(x) for x in spin)
    box = f"{fnum(-half)} {fnum(half)} " * 3
    ins = f"{fnum(-half_ins)} {fnum(half_ins)} " * 3
    cols = "id x y z vx vy vz"
    lines = [f"# {h}" for h in header] + [
        f"# run in this folder: liggghts -in {stem}_deck_liggghts.in (or -screen FILE: under -screen none",
        "# LIGGGHTS 3.8.0's fix insert/pack crashes, its Region::reset_random prints to the missing screen)",
        "atom_style sphere",
        "atom_modify map array sort 0 0", "boundary f f f", "newton off", "communicate single vel yes",
        "processors 1 1 1", "units si", f"region box block {box}units box", "create_box 1 box",
        f"neighbor {fnum(0.2 * rmin)} bin", "neigh_modify delay 0",
        f"fix m1 all property/global youngsModulus peratomtype {fnum(YOUNG)}",
        f"fix m2 all property/global poissonsRatio peratomtype {fnum(POISSON)}",
        "fix m3 all property/global coefficientRestitution peratomtypepair 1 0.9",
        "fix m4 all property/global coefficientFriction peratomtypepair 1 0.0",
        "pair_style gran model hertz tangential history", "pair_coeff * *", f"timestep {fnum(dt)}",
        f"include {stem}_liggghts.in", f"region ins block {ins}units box",
        f"fix ins all insert/pack seed 32452843 distributiontemplate pdd1 vel constant {v} omega constant {w} "
        f"orientation template insert_every once overlapcheck yes region ins particles_in_region {n} ntry_mc 10000",
        "fix integr all multisphere"]
    if single:
        lines.append("fix single all nve/sphere  # the one-sphere clumps (plain spheres)")
    lines += ["compute ke all ke/multisphere", "compute er all erotate/multisphere"] + _thermo(steps) + ["run 1",
              f"dump start all custom 1 {stem}_liggghts_start.dump {cols}",
              f"dump_modify start format {_dump_format(6)} sort id", "run 0", "undump start",
              f"dump end all custom {steps} {stem}_liggghts_end.dump {cols}",
              f"dump_modify end format {_dump_format(6)} sort id", f"run {steps - 1}"]
    return "\n".join(lines) + "\n"


def _lammps(clumps, mp, stem: str, velocity, spin, steps: int, dt: float, header) -> str:
    """The LAMMPS deck: ``read_data STEM.data``, ``fix rigid/nve ... infile STEM.rigid`` (which holds
    the initial state), run."""
    P = Props(mp)
    b = _reach(clumps, P.com)
    travel = float(np.linalg.norm(velocity)) * steps * dt
    lo = P.com.min(axis=0) - 2.0 * b - travel
    hi = P.com.max(axis=0) + 2.0 * b + travel
    rmin = min(float(np.min(c.radii)) for c in clumps)
    box = " ".join(f"{a} final {fnum(lo[i])} {fnum(hi[i])}" for i, a in enumerate("xyz"))
    cols = "id mol x y z vx vy vz"
    lines = [f"# {h}" for h in header] + [
        f"# run in this folder: lmp -in {stem}_deck_lammps.in", "units si", "atom_style hybrid sphere molecular",
        "boundary f f f", f"read_data {stem}.data", f"change_box all {box} units box",
        f"pair_style zero {fnum(2.0 * b)}", "pair_coeff * *", f"neighbor {fnum(0.2 * rmin)} bin",
        "neigh_modify exclude molecule/intra all", f"timestep {fnum(dt)}",
        f"fix rb all rigid/nve molecule infile {stem}.rigid",
        "compute ke all ke/rigid rb", "compute er all erotate/rigid rb", *_thermo(steps),
        f"dump d all custom {steps} {stem}_lammps.dump {cols}",
        "dump_modify d format float %.17g sort id", f"run {steps}"]
    return "\n".join(lines) + "\n"


def _yade(clumps, mp, stem: str, velocity, spin, steps: int, dt: float, header, density: float) -> str:
    """The YADE deck (Python for ``yade -x``): ``clumpprops.yade.text_clumps(STEM_textclumps.txt)``,
    the initial state, run."""
    lines = [f"# {h}" for h in header] + [
        f"# run in this folder: yade -x {stem}_deck_yade.py  (clumpprops must be importable by YADE's Python)",
        "import numpy as np",
        "from yade import O", "from yade.minieigenHP import Vector3",
        "from yade.wrapper import (FrictMat, ForceResetter, InsertionSortCollider, Bo1_Sphere_Aabb, InteractionLoop,",
        "                          Ig2_Sphere_Sphere_ScGeom, Ip2_FrictMat_FrictMat_FrictPhys, Law2_ScGeom_FrictPhys_CundallStrack,",
        "                          NewtonIntegrator)",
        "from clumpprops import yade as cy", "",
        f"VELOCITY, SPIN, STEPS, DT = {list(map(float, velocity))!r}, {list(map(float, spin))!r}, {int(steps)}, {float(dt)!r}",
        f"O.materials.append(FrictMat(density={float(density)!r}, young=1e7, poisson=0.4, frictionAngle=0.0, label='mat'))",
        f"clumps = cy.text_clumps('{stem}_textclumps.txt', material='mat')  # relative to the folder yade runs in",
        "O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb()]),",
        "             InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],",
        "                             [Law2_ScGeom_FrictPhys_CundallStrack()]),",
        "             NewtonIntegrator(gravity=(0, 0, 0), damping=0.0, exactAsphericalRot=True)]",
        "O.dt = DT", "",
        "def report(tag):",
        "    for cid, _ in clumps:",
        "        s = O.bodies[int(cid)].state",
        "        R = np.array(s.ori.toRotationMatrix())",
        "        I = R @ np.diag(np.array(s.inertia)) @ R.T",
        "        L = np.array(s.angMom)",
        "        w = np.linalg.solve(I, L)",
        "        ke = 0.5 * s.mass * np.dot(np.array(s.vel), np.array(s.vel)) + 0.5 * np.dot(w, L)",
        "        print(tag, int(cid), 'mass', repr(float(s.mass)), 'inertia', ' '.join(repr(float(x)) for x in I.ravel()),",
        "              'angmom', ' '.join(repr(float(x)) for x in L), 'ke', repr(float(ke)), flush=True)", "",
        "for cid, _ in clumps:  # the initial state: angMom = R diag(I) R^T w (YADE integrates angMom)",
        "    s = O.bodies[int(cid)].state",
        "    R = np.array(s.ori.toRotationMatrix())",
        "    s.vel = Vector3(*VELOCITY)",
        "    s.angVel = Vector3(*SPIN)",
        "    s.angMom = Vector3(*(R @ np.diag(np.array(s.inertia)) @ R.T @ np.array(SPIN)))",
        "report('step 0')", "O.run(STEPS, True)", "report(f'step {O.iter}')"]
    return "\n".join(lines) + "\n"


_DECKS = {"liggghts": (_liggghts, "{}_deck_liggghts.in"), "lammps": (_lammps, "{}_deck_lammps.in"),
          "yade": (_yade, "{}_deck_yade.py")}


def write(to: str, clumps: Sequence[Clump], mp, out_dir, stem: str, density: float, method: str,
          velocity=(0.0, 0.0, 0.0), spin=(0.0, 0.0, 0.0), steps: int = 1000, dt: Optional[float] = None,
          source: str = "", scale: float = 1.0) -> List[Path]:
    """Write the deck of engine `to` into `out_dir`, beside the clump files it reads.

    Parameters
    ----------
    to : str
        One of :data:`DECK_ENGINES`.
    clumps : sequence of Clump
        The clumps.
    mp : clumpprops.MassProperties
        Their mass properties (a batch).
    out_dir : str or os.PathLike
        The folder of the clump files.
    stem : str
        The stem of the exported files the deck reads.
    density : float
        Density, kg/m^3.
    method : str
        The method the values come from (named in the header).
    velocity, spin : sequence of 3 float, optional
        Initial velocity (m/s) and angular velocity (rad/s, space frame) of every clump.
    steps : int, optional
        Number of steps to run; at least 2.
    dt : float or None, optional
        Timestep, s; None for :func:`default_dt`.
    source : str, optional
        The input file (named in the header).
    scale : float, optional
        The factor applied to the input's lengths (named in the header).

    Returns
    -------
    list of pathlib.Path
        The deck written.

    Raises
    ------
    ValueError
        If `to` has no deck, `steps` < 2 or `dt` is not positive.
    """
    if to not in _DECKS:
        raise ValueError(f"--deck applies to {', '.join(DECK_ENGINES)}; {to} has documented snippets in docs/engines.md")
    if int(steps) < 2:
        raise ValueError(f"steps must be at least 2, got {steps}")
    dt = default_dt(clumps, density, spin) if dt is None else float(dt)
    if not dt > 0:
        raise ValueError(f"dt must be > 0, got {dt}")
    make, name = _DECKS[to]
    header = header_lines(f"a {to} deck", density, method, source, scale, extra=[
        f"initial velocity {' '.join(fnum(x) for x in velocity)} m/s, angular velocity "
        f"{' '.join(fnum(x) for x in spin)} rad/s, {int(steps)} steps of {fnum(dt)} s, no gravity"])
    path = Path(out_dir) / name.format(stem)
    args = (clumps, mp, stem, tuple(map(float, velocity)), tuple(map(float, spin)), int(steps), dt, header)
    path.write_text(make(*args, density) if to == "yade" else make(*args))
    return [path]
