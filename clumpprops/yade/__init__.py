"""YADE adapter: clumps that carry the exact mass properties from the moment they are built.

YADE (2023.02a, 2025.2) builds a clump's mass, centre of mass and inertia by summing its
member spheres (``discretization=0``: overlaps counted twice) or by voxelising
them (``discretization>0``: approximate and slow).  This package swaps one call
for the YADE one and the clump in the simulation has the properties
:func:`clumpprops.mass_properties` gives for the union of its spheres.

How (the *correction member*)
-----------------------------
``Clump::updateProperties`` sums each NON-spherical member with its own
``state.mass``, ``state.pos``, ``state.inertia`` and ``state.ori``.  Every
corrected clump gets one extra member, the correction: a body with the bare base
class ``Shape`` (no ``Bo1`` functor exists for it) and ``bounded=False``, so it
never has a bound, never enters collision detection and never makes a contact.
Its state holds exactly the difference "exact minus summed spheres":

* mass ``m_c = m_exact - sum(m_i)`` (negative where spheres overlap),
* position ``p_c`` such that the first moments add up to the exact centre of mass,
* principal moments and orientation such that the summed inertia tensor about the
  exact centre of mass equals the exact tensor (eigenvalues may be negative).

Its state is ``material.newAssocState()`` of the spheres' material (CpmState for CpmMat, ...)
and its ``mask`` the union of its spheres' mask bits.

YADE then computes mass, centre of mass, principal moments and axes itself, so the
correction is part of the scene: it is saved by ``O.save``/``O.saveTmp``, and a
later ``O.bodies.updateClumpProperties(discretization=0)`` reproduces the exact
values.  Member spheres are not touched: they keep their material (true density),
radius and world position.  Forces applied per member through the body's mass
(``GravityEngine``) act on the correction member too, so the clump receives the
exact weight ``m_exact g`` through the exact centre of mass.

The clump's life (docs/yade_adapter.md has the table): YADE's own release, add, erase and
update recompute a clump with whatever members it then has, so the correction would go stale
(or the summed mass reach zero and YADE abort).  :func:`release`, :func:`add_to_clump`,
:func:`erase` and :func:`update_clump_properties` neutralise the correction, let YADE do the
operation and correct the clump again.

Guards (an explicit call): :func:`install_guards` routes the same ``O.bodies`` methods through
them for corrected clumps, ``deleteClumpMember``/``deleteClumpBody`` through :func:`erase`, makes
``clump``/``appendClumped``/``addToClump`` refuse corrections and corrected clumps they cannot keep
exact (YADE would abort on ``M > 0`` or leave them stale), and ``clear``/``replace`` empty the
registry.  It patches YADE's ``BodyContainer`` for the whole process, so nothing here calls it:
importing this package, loading YADE and building clumps leave YADE's methods as they are.  Call
it once in a script that also uses YADE's own clump methods (idempotent; :func:`unguarded` gives
YADE's methods back inside a block).  Every correction is recorded in
``O.tags["clumpprops.corrections*"]`` (a header and chunks of entries) with a fingerprint of its
spheres, and :func:`check` verifies the whole scene.

Nothing here is imported by ``import clumpprops``; YADE itself is imported inside
the functions, so this package works both in scripts run by the ``yade`` executable and after a
plain ``import yade``.

Modules (each one job): :mod:`~clumpprops.yade.correction` (targets and the correction member,
through the compiled core), :mod:`~clumpprops.yade.registry` (the record in ``O.tags`` and the
fingerprints), :mod:`~clumpprops.yade.scene` (reading bodies and states), :mod:`~clumpprops.yade.build`
(new and existing clumps made exact), :mod:`~clumpprops.yade.lifecycle` (release, add, erase,
update), :mod:`~clumpprops.yade.guards` (:func:`install_guards`), :mod:`~clumpprops.yade.check`
(the scene check), :mod:`~clumpprops.yade.textclumps` (textClumps files) and ``_loader`` (YADE
imported on first use).

Argument names are snake_case, except in the drop-ins that mirror a YADE function and keep its
keywords so that a call written for YADE works unchanged: :func:`text_clumps` (``fileName``),
:func:`erase` (``eraseClumpMembers``) and :func:`update_clump_properties` (``excludeList``).
"""
from __future__ import annotations

from ._loader import ClumpAdapterError
from .build import append_clump, append_clumps, correct_all_clumps, correct_clump, correct_clumps, replace_by_clumps
from .check import CheckReport, check
from .correction import correction_terms
from .guards import guards_installed, install_guards, unguarded
from .lifecycle import add_to_clump, erase, release, update_clump_properties
from .scene import (clump_errors, correction_id, exact_properties, is_correction, set_clump_velocity,
                    sphere_member_ids)
from .textclumps import export_text_clumps, text_clumps

__all__ = [
    "append_clump",
    "append_clumps",
    "correct_clump",
    "correct_clumps",
    "correct_all_clumps",
    "replace_by_clumps",
    "text_clumps",
    "export_text_clumps",
    "correction_id",
    "sphere_member_ids",
    "is_correction",
    "exact_properties",
    "clump_errors",
    "set_clump_velocity",
    "release",
    "add_to_clump",
    "erase",
    "update_clump_properties",
    "check",
    "CheckReport",
    "install_guards",
    "guards_installed",
    "unguarded",
    "ClumpAdapterError",
]
