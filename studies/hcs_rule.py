"""The collision rule of YADE's Hertz-Mindlin contact with restitution and Coulomb friction,
measured from binary sphere collisions, for the rough-sphere HCS theory (:mod:`studies.hcs_theory`).

YADE's ``es`` is not Walton's constant tangential restitution beta0 (docs/hcs.md): the tangential
restitution beta of a sticking impact depends on the impact's angle.  :func:`measured_rule` runs
one collision of two equal spheres per ratio g_t / g_n of a table, at a fixed normal speed, and
returns the rule ``rule(g_n, g_t, kappa) -> (e, beta)`` that :func:`studies.hcs_theory.hcs_ratio_for_rule`
takes: beta interpolated in the table, and Walton's sliding limit beyond its last ratio.

Runs in the interpreter that imports YADE (the project's .venv with YADE 2023.02a).
"""
from __future__ import annotations

import math

import numpy as np

#: Ratios g_t / g_n of the measured table: 48 log-spaced from 0.02 to 5.  The HCS ratio of the
#: rough-sphere validation (mu = 0.5, e = 0.9) moves by -3 % from 48 to 6 ratios, by -0.25 % to 24.
RATIOS = np.round(np.geomspace(0.02, 5.0, 48), 4)


def binary(e, mu, v_n, v_t, young=1.0e9, density=1140.0, poisson=0.4, radius=0.1):
    """One collision of two equal spheres in YADE: (normal restitution, tangential restitution beta).

    Parameters
    ----------
    e : float
        YADE's ``en`` and ``es``.
    mu : float
        Coulomb friction coefficient (``frictionAngle = atan(mu)``).
    v_n, v_t : float
        Normal and tangential relative speed at impact (m/s), no spin.
    young, density, poisson, radius : float, optional
        The spheres' material (Pa, kg/m^3, -) and radius (m).

    Returns
    -------
    (float, float)
        The normal restitution -g_n'/g_n and beta = -g_t'/g_t of the contact point (NaN when v_t = 0).
    """
    from yade import O, utils
    from yade.minieigenHP import Vector3
    from yade.wrapper import (Bo1_Sphere_Aabb, ForceResetter, FrictMat, Ig2_Sphere_Sphere_ScGeom, InsertionSortCollider,
                              InteractionLoop, Ip2_FrictMat_FrictMat_MindlinPhys, Law2_ScGeom_MindlinPhys_Mindlin,
                              MatchMaker, NewtonIntegrator)
    O.reset()
    mat = O.materials.append(FrictMat(young=young, poisson=poisson, density=density, frictionAngle=math.atan(mu)))
    a = O.bodies.append(utils.sphere((0, 0, 0), radius, material=mat))
    b = O.bodies.append(utils.sphere((2 * radius * 1.0005, 0, 0), radius, material=mat))
    O.bodies[a].state.vel = Vector3(v_n / 2, v_t / 2, 0)
    O.bodies[b].state.vel = Vector3(-v_n / 2, -v_t / 2, 0)
    ip = Ip2_FrictMat_FrictMat_MindlinPhys(en=MatchMaker(algo="val", val=e), es=MatchMaker(algo="val", val=e))
    O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb()]),
                 InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [ip], [Law2_ScGeom_MindlinPhys_Mindlin()]),
                 NewtonIntegrator(damping=0)]
    O.dt = 0.5 * radius * math.sqrt(density / young)
    while True:
        O.run(200, True)
        if len([i for i in O.interactions if i.isReal]) == 0 and O.iter > 400:
            break
    sa, sb = O.bodies[a].state, O.bodies[b].state
    g_n = -(sa.vel[0] - sb.vel[0])
    g_t = (sa.vel[1] - sb.vel[1]) + radius * (sa.angVel[2] + sb.angVel[2])
    return g_n / v_n, (-g_t / v_t if v_t else float("nan"))


def measured_rule(e, mu, v_n=0.5, **material):
    """The collision rule of YADE's contact, measured at normal speed ``v_n``.

    Parameters
    ----------
    e, mu : float
        Restitution (``en`` = ``es``) and Coulomb friction.
    v_n : float, optional
        Normal impact speed of the table (m/s).
    **material
        Passed to :func:`binary` (``young``, ``density``, ``poisson``, ``radius``).

    Returns
    -------
    rule : callable
        ``rule(g_n, g_t, kappa) -> (e, beta)`` arrays, for :func:`studies.hcs_theory.hcs_ratio_for_rule`.
    betas : numpy.ndarray
        The measured beta at :data:`RATIOS`.
    """
    betas = np.array([binary(e, mu, v_n, v_n * q, **material)[1] for q in RATIOS])

    def rule(g_n, g_t, kappa):
        with np.errstate(divide="ignore", invalid="ignore"):
            q = g_t / g_n
            sliding = -1.0 + mu * (1.0 + e) * (1.0 + 1.0 / kappa) / q
        beta = np.where(q <= RATIOS[-1], np.interp(q, RATIOS, betas), np.minimum(betas[-1], sliding))
        return np.full_like(g_n, e), beta
    return rule, betas
