"""The report's sentences, one function each, rendered from the macros of its templates
(``answers.md.j2``, ``plain_words.md.j2``) with the facts of :mod:`studies.report.answers`: for a
caller that wants one sentence rather than the page (the page renders the same macros)."""
from __future__ import annotations

from . import answers, tables
from .render import cpu_hours, macro


def _answers_macro(name):
    return macro("macros/answers.j2", name)


def answer(sp, g, st, cpu):
    """The bullet of one sequential question, from its status (no typed numbers)."""
    return _answers_macro("answer")(answers.question(sp, g, st, cpu))


def prior_words(prior, target, n_done=0):
    """The sentence of a question's prior projection (``design.prior_projection``): what its target
    would take, projected from the same question at another stiffness, run length or time step; ""
    without one.  ``n_done``: the pairs the question already has, which cost nothing more."""
    return _answers_macro("prior_words")(prior, target, n_done)


def mass_scaling(sp, g, st):
    """The hard-particle mass scaling's sentence for uncorrected vs exact at equal energy; "" otherwise."""
    return _answers_macro("mass_scaling")(answers.mass_scaling(sp, g, st))


def map_check(sp, g, st, maps):
    """The sentence of a group's gas against its collision map; "" without a map."""
    return _answers_macro("map_check")(answers.map_check(sp, g, st, maps))


def same_spin_answers(specs, records=None):
    """The bullets of the superseded same-spin runs (:func:`tables.same_spin_rows`)."""
    return [_answers_macro("same_spin")(r) for r in tables.same_spin_rows(specs, records)]


def paper_share_answers(specs, shape="dimer", overlap=0.5, youngs_modulus=1e7, share=False):
    """The bullet of :func:`tables.paper_share` (empty without both samples); ``share``: its result, if known."""
    r = tables.paper_share(specs, shape, overlap, youngs_modulus) if share is False else share
    return [] if r is None else [_answers_macro("paper_share")(r)]


def other_shapes_words(effect_rows, youngs_modulus=1e7):
    """The bullet of the shapes other than the paper's dimer (empty without their rows)."""
    f = answers._other_shapes(effect_rows, youngs_modulus)
    return [] if f is None else [macro("macros/plain_words.j2", "other_shapes_bullet")(f)]


def stiffness_words(effect_rows, maps):
    """The bullet of the hard-particle limit in the gas (empty without mass_only rows at other E)."""
    f = answers._stiffness(effect_rows, maps)
    return [] if f is None else [macro("macros/plain_words.j2", "stiffness_bullet")(f)]


def cpu_hours_more(h):
    """"about 3 CPU-hours more", "about 1 CPU-hour more", "under half a CPU-hour more"."""
    return cpu_hours(h, more=True)
