"""Markdown tables of the granular-gas results, from the CSV/JSON files only.

    .venv/bin/python -m studies.gas_report results/granular_gas

Rendered from ``studies/templates/gas_report.md.j2`` (Jinja2) with the values of ``params.json``,
``protocols.csv``, ``diff_D.csv``, ``ratio_D.csv``, ``protocol_effect.csv`` (where there is one)
and ``runs.csv``.
"""
from __future__ import annotations

import json
import os

import pandas as pd

TEMPLATES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "templates")


def fmt(x, nd=3):
    """A table value with ``nd`` decimals, "–" where the table has none."""
    return "–" if pd.isna(x) else f"{x:.{nd}f}"


def context(out):
    """The template's values for the study whose tables are in ``out``: each protocol row beside its
    paired difference from exact (None for exact), the paper's ratios, the protocol effect and the
    runs' drifts."""
    with open(os.path.join(out, "params.json")) as f:
        p = json.load(f)
    d = pd.read_csv(os.path.join(out, "diff_D.csv"))
    runs = pd.read_csv(os.path.join(out, "runs.csv"))
    protocols = []
    for row in pd.read_csv(os.path.join(out, "protocols.csv")).itertuples():
        dd = d[(d.case == row.case) & (d.protocol == row.protocol)]
        protocols.append((row, dd.iloc[0] if len(dd) else None))
    pe = os.path.join(out, "protocol_effect.csv")
    return {"p": p, "protocols": protocols, "ratios": list(pd.read_csv(os.path.join(out, "ratio_D.csv")).itertuples()),
            "protocol_effect": list(pd.read_csv(pe).itertuples()) if os.path.exists(pe) else None,
            "runs": {"n": len(runs), "energy_max": runs.energy_drift.max(), "energy_median": runs.energy_drift.median(),
                     "momentum_max": runs.momentum_drift.max(), "flagged": int((~runs.ok.astype(bool)).sum())}}


def report(out):
    """The Markdown summary of the results directory ``out`` (its last line without a newline)."""
    import jinja2

    env = jinja2.Environment(loader=jinja2.FileSystemLoader(TEMPLATES), keep_trailing_newline=True,
                             trim_blocks=True, lstrip_blocks=True, undefined=jinja2.StrictUndefined)
    env.filters.update(fmt=format, num=fmt)
    return env.get_template("gas_report.md.j2").render(**context(out)).removesuffix("\n")


if __name__ == "__main__":
    import argparse
    ap = argparse.ArgumentParser(prog="python -m studies.gas_report",
                                 description="Print the Markdown summary of one study's results directory.")
    ap.add_argument("results_dir", nargs="?", default="results/granular_gas")
    print(report(ap.parse_args().results_dir))
