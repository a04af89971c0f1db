"""The report's Markdown from its templates (``studies/templates/report/*.md.j2``, Jinja2).

The templates hold every word; this module gives them the number formats they share, as filters
and globals: a relative effect in per cent (:func:`pct`), a 95 % interval (:func:`interval`), its
reading (``verdict``), a value with its error (:func:`pm`, :func:`pm95`), CPU-hours in words
(``cpu_hours``), a gas's interval against a map's (``apart``) and any format specification
(:func:`fmt`).  The words among them are the macros of ``macros/common.j2``; :func:`verdict`,
:func:`cpu_hours` and :func:`apart` call them from Python.
"""
from __future__ import annotations

import functools
import os

import numpy as np
import pandas as pd

TEMPLATES = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "templates", "report")


def pct(x, nd=2):
    """``x`` in per cent with its sign, "n/a" for a missing value."""
    return "n/a" if pd.isna(x) else f"{100 * x:+.{nd}f} %"


def interval(lo, hi, nd=2):
    """The interval [lo, hi] in per cent, "n/a" if either end is missing."""
    return "n/a" if pd.isna(lo) or pd.isna(hi) else f"[{100 * lo:+.{nd}f}, {100 * hi:+.{nd}f}] %"


def pm(x, se, nd=3):
    """A relative value ± one standard error, both in per cent."""
    return f"{pct(x, nd)} ± {100 * se:.{nd}f} %"


def pm95(x, se):
    """A relative value ± 1.96 standard errors, both in per cent."""
    return f"{pct(x)} ± {100 * 1.96 * se:.2f} %"


def fmt(x, spec):
    """``format(x, spec)``: ``{{ x|fmt('.0e') }}``."""
    return format(x, spec)


def uminus(text):
    """``text`` with each hyphen-minus as the typographic minus sign (the docs' numbers: "−0.035")."""
    return str(text).replace("-", "\u2212")


def finite(x):
    """True for a number that is there (neither None nor NaN)."""
    return x is not None and not pd.isna(x)


@functools.lru_cache(maxsize=1)
def environment():
    """The Jinja2 environment of the report's templates (block tags take their line with them)."""
    import jinja2

    env = jinja2.Environment(loader=jinja2.FileSystemLoader(TEMPLATES), keep_trailing_newline=True,
                             trim_blocks=True, lstrip_blocks=True, undefined=jinja2.StrictUndefined)
    from ..sequential import MIN_PAIRS

    env.globals["min_pairs"] = MIN_PAIRS
    env.filters.update(pct=pct, pm=pm, pm95=pm95, fmt=fmt, uminus=uminus)
    env.globals.update(interval=interval, finite=finite, isfinite=isfinite, pct=pct, pm=pm, pm95=pm95)
    common = env.get_template("macros/common.j2").module
    env.globals.update(verdict=common.verdict, cpu_hours=common.cpu_hours, apart=common.apart)
    return env


def render(name, **context):
    """The Markdown of template ``name`` (``"programme.md.j2"``) with ``context``."""
    return environment().get_template(name).render(**context)


def macro(template, name):
    """Macro ``name`` of ``template``, as a function returning its text."""
    return getattr(environment().get_template(template).module, name)


def lines(text):
    """A section's text as the lines the report joins (the last newline ends the last line)."""
    return text.splitlines()


def isfinite(x):
    """True for a finite number (not NaN, not infinite)."""
    return bool(np.isfinite(x))


def verdict(lo, hi):
    """Plain words for a 95 % interval of a relative effect (the templates' ``verdict``)."""
    return macro("macros/common.j2", "verdict")(lo, hi)


def cpu_hours(h, more=False):
    """"about 3 CPU-hours", "about 1 CPU-hour", "under half a CPU-hour" (and " more" after it with
    ``more``): the templates' ``cpu_hours``."""
    return macro("macros/common.j2", "cpu_hours")(h, more)


def apart(n, lo, hi, map_value, map_se):
    """Whether a gas's 95 % interval [lo, hi] meets a map's value ± 1.96 SE: "overlap" or
    "**apart**"; "" from fewer than 2 seeds (no interval).  The templates' ``apart``."""
    return macro("macros/common.j2", "apart")(n, lo, hi, map_value, map_se)
