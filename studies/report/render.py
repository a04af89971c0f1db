"""The report's Markdown from its templates (``studies/templates/report/*.md.j2``, Jinja2).

The templates hold every word; this module gives them the number formats they share, as filters
and globals: a relative effect in per cent (:func:`pct`), a 95 % interval (:func:`interval`), its
reading (:func:`verdict`), a value with its error (:func:`pm`, :func:`pm95`), CPU-hours in words
(:func:`cpu_hours`) and any format specification (:func:`fmt`).
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


def verdict(lo, hi):
    """Plain words for a 95 % interval of a relative effect."""
    if pd.isna(lo) or pd.isna(hi):
        return "not resolved (fewer than 2 pairs)"
    if lo > 0:
        return "larger than exact, resolved"
    if hi < 0:
        return "smaller than exact, resolved"
    w = max(abs(lo), abs(hi))
    return f"no effect resolved: |effect| < {100 * w:.2f} % at 95 %"


def pm(x, se, nd=3):
    """A relative value ± one standard error, both in per cent."""
    return f"{pct(x, nd)} ± {100 * se:.{nd}f} %"


def pm95(x, se):
    """A relative value ± 1.96 standard errors, both in per cent."""
    return f"{pct(x)} ± {100 * 1.96 * se:.2f} %"


def cpu_hours(h):
    """"about 3 CPU-hours", "about 1 CPU-hour", "under half a CPU-hour"."""
    if h < 0.5:
        return "under half a CPU-hour"
    n = max(1, int(h + 0.5))
    return f"about {n} CPU-hour{'' if n == 1 else 's'}"


def fmt(x, spec):
    """``format(x, spec)``: ``{{ x|fmt('.0e') }}``."""
    return format(x, spec)


def finite(x):
    """True for a number that is there (neither None nor NaN)."""
    return x is not None and not pd.isna(x)


@functools.lru_cache(maxsize=1)
def environment():
    """The Jinja2 environment of the report's templates (block tags take their line with them)."""
    import jinja2

    env = jinja2.Environment(loader=jinja2.FileSystemLoader(TEMPLATES), keep_trailing_newline=True,
                             trim_blocks=True, lstrip_blocks=True, undefined=jinja2.StrictUndefined)
    from ..estimators import MIN_PAIRS

    env.globals["min_pairs"] = MIN_PAIRS
    env.filters.update(pct=pct, pm=pm, pm95=pm95, cpu_hours=cpu_hours, fmt=fmt)
    env.globals.update(interval=interval, verdict=verdict, finite=finite, isfinite=isfinite, pct=pct, pm=pm, pm95=pm95, apart=apart)
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


def apart(n, lo, hi, map_value, map_se):
    """Whether a gas's 95 % interval [lo, hi] meets a map's value ± 1.96 SE: "overlap" or
    "**apart**"; "" from fewer than 2 seeds (no interval)."""
    if n < 2:
        return ""
    lo_m, hi_m = map_value - 1.96 * map_se, map_value + 1.96 * map_se
    return "overlap" if lo <= hi_m and lo_m <= hi else "**apart**"


def isfinite(x):
    """True for a finite number (not NaN, not infinite)."""
    return bool(np.isfinite(x))
