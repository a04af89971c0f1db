"""``results/README.md``: the study's answers, generated from the results tables (no typed numbers).

    .venv/bin/python -m studies.report          # writes results/effects.csv and results/README.md

It also brings the gas columns of ``results/predictions.csv`` up to date with the gas tables
(:func:`studies.prediction_table.refresh_gas`; the predictions themselves stay as they are).

Tables first, words after: :mod:`studies.report.tables` reads ``results/granular_gas/*.csv`` (the
paper's Fig. 2, paired and equal-energy protocols), ``results/sphere_gas.csv`` (the sphere gas
against kinetic theory, :mod:`studies.sphere_gas`), the run records of every spec under
``studies/specs/`` but those with ``study.in_results = false`` (:func:`studies.effects.results_specs`;
through :mod:`studies.effects` and :mod:`studies.design`) and writes ``results/effects.csv``;
:mod:`studies.report.answers` states what each answer rests on; the templates under
``studies/templates/report/`` (Jinja2, :mod:`studies.report.render`) hold every word.  For each
question of the paper the report states the answer its interval supports, or the half-width
reached, the CPU-hours spent and the projected number of seed pairs where the target is not met yet.
"""
from __future__ import annotations

import os
import sys

from .. import effects, effects_plots, prediction_table, rates, sphere_gas
from .. import spec as S
from . import answers, findings, tables
from .render import apart as _apart
from .render import interval, pct, render, verdict
from .render import lines as _lines
from .sections import (LATE_VARIANT, RECORD_VARIANT, collision_map_section, cooling_section, effects_section, law_section,
                       hard_sphere_md_section, programme_section, rate_ratio_section, rates_section,
                       sphere_gas_section)
from .sections import fig2_section as _fig2_section
from .tables import Planned, paper_share, planned, readable_specs, same_spin_pairs
from .words import paper_share_answers

# one sentence at a time, under the names the report's tests call them by
from .render import cpu_hours as _cpu_hours  # noqa: E402,F401
from .tables import status_rows as _status_rows  # noqa: E402,F401
from .words import answer as _answer  # noqa: E402,F401
from .words import cpu_hours_more as _cpu_hours_more  # noqa: E402,F401
from .words import map_check as _map_check  # noqa: E402,F401
from .words import mass_scaling as _mass_scaling  # noqa: E402,F401
from .words import other_shapes_words as _other_shapes_words  # noqa: E402,F401
from .words import prior_words as _prior_words  # noqa: E402,F401
from .words import same_spin_answers as _same_spin_answers  # noqa: E402,F401
from .words import stiffness_words as _stiffness_words  # noqa: E402,F401

__all__ = ["RESULTS", "FINDINGS", "build", "main", "Planned", "planned", "readable_specs", "paper_share", "paper_share_answers",
           "same_spin_pairs", "pct", "interval", "verdict", "RECORD_VARIANT", "LATE_VARIANT", "fig2_section",
           "failures_section", "plain_words", "answers_section", "programme_section", "effects_section",
           "collision_map_section", "rates_section", "rate_ratio_section", "sphere_gas_section",
           "hard_sphere_md_section", "cooling_section", "law_section"]

RESULTS = os.path.join(S.ROOT, "results")
FINDINGS = findings.FINDINGS            # docs/findings.md, the study's findings page


def _gas_against_map(n, value, lo, hi, map_value, map_se, num, ival):
    """Table cells "gas value [CI]" and whether its 95 % interval meets the map's (value ± 1.96 SE)
    (:func:`studies.report.render.apart`); with fewer than 2 seeds the value alone and no verdict.
    ``num`` and ``ival`` format a value and an interval."""
    cell = num(value) if n < 2 else f"{num(value)} {ival(lo, hi)}"
    return cell, _apart(n, lo, hi, map_value, map_se)


def fig2_section(lines):
    """The paper's Fig. 2 (``RESULTS/granular_gas/``)."""
    _fig2_section(lines, RESULTS)


def failures_section(lines, failures):
    """The studies the report could not read, each with its error (nothing when there is none)."""
    lines += _lines(render("failures.md.j2", failures=failures))


def plain_words(effect_rows, maps, share, cooling=None):
    """The lines of the answers the issues ask for, in words, from effects.csv's rows, the
    collision maps, the paper's share and the cooling gases' answer (``tables.cooling_answer``;
    each clause only where its numbers exist)."""
    return _lines(render("plain_words.md.j2", **answers.plain_words_facts(effect_rows, maps, share, cooling)))


def answers_section(lines, plans, sph, effect_rows=(), maps=(), share=False):
    """The answers, one bullet each; ``plans``: :func:`planned` of the specs; ``share``: the
    paper's share (:func:`paper_share`), if known."""
    specs = [p.spec for p in plans]
    questions = [dict(question=answers.question(sp, g, st, cpu), mass_scaling=answers.mass_scaling(sp, g, st),
                      map_check=answers.map_check(sp, g, st, maps)) for sp, g, st, cpu in tables.status_rows(plans)]
    lines += _lines(render(
        "answers.md.j2", questions=questions, same_spin_rows=tables.same_spin_rows(specs, [p.records for p in plans]),
        maps=answers.collision_map_facts(maps), first_version=tables.first_version_row(RESULTS),
        share_first=tables.uncorrected_share(RESULTS), share=paper_share(specs) if share is False else share,
        sphere=answers.sphere_gas_facts(sph, effect_rows)))


def _write(path, text):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def build():
    """Write ``RESULTS/effects.csv``, ``RESULTS/law.csv``, the report's figures, ``RESULTS/README.md`` and ``docs/findings.md``
    (:mod:`studies.report.findings`), and bring the gas columns of ``RESULTS/predictions.csv`` up to
    date (:func:`studies.prediction_table.refresh_gas`); returns the report's text."""
    specs, failures = readable_specs()
    plans = planned(specs)                    # every record read, and every design planned, once
    collected = effects.collect(specs, [p.records for p in plans])
    values = effects.paired_values(specs, collected)
    rows = effects.write(specs, os.path.join(RESULTS, "effects.csv"), values=values)
    n = prediction_table.refresh_gas(os.path.join(RESULTS, "predictions.csv"), os.path.join(RESULTS, "effects.csv"),
                                     os.path.join(RESULTS, "hcs_effects.csv"))
    if n:
        print(f"[report] predictions.csv: the gas columns of {n} row(s) brought up to date", file=sys.stderr)
    sph = sphere_gas.read(os.path.join(RESULTS, "sphere_gas.csv"))
    figs = effects_plots.plot_all(RESULTS, log=lambda s: None)
    maps = effects_plots.read_collision_maps(RESULTS)
    share = paper_share(specs, values=values)
    lines = _lines(render("header.md.j2"))
    failures_section(lines, failures)
    lines += plain_words(rows, maps, share, tables.cooling_answer(tables.cooling_tables(RESULTS)[1]))
    answers_section(lines, plans, sph, rows, maps, share)
    fig2_section(lines)
    programme_section(lines, plans)
    effects_section(lines, rows)
    collision_map_section(lines, maps, rows)
    rrows, ratio_rows = rates.rows(collected, maps), rates.ratio_rows(collected, maps)
    rates_section(lines, rrows)
    rate_ratio_section(lines, ratio_rows)
    sphere_gas_section(lines, sph)
    vacf_shape = tables.read_json(os.path.join(S.ROOT, "results", "estimator", "vacf_shape_md.json"))
    hsmd = tables.read_json(os.path.join(RESULTS, "hard_sphere_md.json"))        # written by studies.hard_sphere_md
    hard_sphere_md_section(lines, hsmd["gases"] if hsmd else [], sph, vacf_shape)
    cooling_section(lines, RESULTS)
    law_section(lines, RESULTS)
    lines += _lines(render("figures.md.j2", figures=figs))
    text = "\n".join(lines) + "\n"
    _write(os.path.join(RESULTS, "README.md"), text)
    findings.write(FINDINGS, plans=plans, effect_rows=rows, maps=maps, share=share, sph=sph, rrows=rrows,
                   ratio_rows=ratio_rows, hsmd=hsmd, vacf=vacf_shape, results=RESULTS)
    return text


def main(argv=()):
    """``python -m studies.report``: 0 on success; 1 with the reason on stderr, no traceback, when
    the results cannot be reported as they are (two effects rows a reader could not tell apart, a
    record without a Green-Kubo D, a bad spec).  A headline study that cannot be read alone is left
    out of the report, which says so in its own section; the status is then 1 too.  ``argv``: the
    command line's arguments (none are taken; ``--help`` prints what the command writes and writes
    nothing)."""
    import argparse
    argparse.ArgumentParser(prog="python -m studies.report", description="Write results/README.md, the study's answers, generated "
                            "from the results tables (no typed numbers).",
                            epilog="Writes results/effects.csv, results/README.md and the report's plots "
                                   "in results/ from the committed run records.").parse_args(list(argv))
    try:
        text = build()
    except ValueError as e:         # SpecError is one
        print(f"[report] error: {e}", file=sys.stderr)
        return 1
    sys.stdout.write(text)
    if "\n## Studies not reported\n" in text:
        print("[report] error: some studies of the programme could not be read: see 'Studies not reported' in "
              "results/README.md", file=sys.stderr)
        return 1
    return 0
