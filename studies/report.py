"""``results/README.md``: the study's answers, generated from the results tables (no typed numbers).

    .venv/bin/python -m studies.report          # writes results/effects.csv and results/README.md

Reads ``results/granular_gas/*.csv`` (the paper's Fig. 2, paired and equal-energy protocols),
the committed run records of every spec under ``studies/specs/`` (through
:mod:`studies.effects` and :mod:`studies.design`), and states, for each question of the paper,
the answer its interval supports, or the half-width reached, the CPU-hours spent and the
projected number of seed pairs where the target is not met yet.
"""
from __future__ import annotations

import json
import os
import sys

import pandas as pd

from . import design, effects, engine
from . import spec as S

RESULTS = os.path.join(S.ROOT, "results")


def pct(x, nd=2):
    return "n/a" if pd.isna(x) else f"{100 * x:+.{nd}f} %"


def interval(lo, hi, nd=2):
    return "n/a" if pd.isna(lo) or pd.isna(hi) else f"[{100 * lo:+.{nd}f}, {100 * hi:+.{nd}f}] %"


def verdict(lo, hi, scale=None):
    """Plain words for a 95 % interval of a relative effect."""
    if pd.isna(lo) or pd.isna(hi):
        return "not resolved (fewer than 2 pairs)"
    if lo > 0:
        return "larger than exact, resolved"
    if hi < 0:
        return "smaller than exact, resolved"
    w = max(abs(lo), abs(hi))
    return f"no effect resolved: |effect| < {100 * w:.2f} % at 95 %"


def fig2_section(lines):
    d = os.path.join(RESULTS, "granular_gas")
    if not os.path.exists(os.path.join(d, "diff_D.csv")):
        return
    p = json.load(open(os.path.join(d, "params.json")))
    diff = pd.read_csv(os.path.join(d, "diff_D.csv"))
    summ = pd.read_csv(os.path.join(d, "summary.csv"))
    lines += ["## The paper's Fig. 2 (`results/granular_gas/`)", "",
              f"{p.get('n_particles')} particles, {p.get('t_end'):g} s per run, D from the MSD on lags "
              f"{p['fit_window_s'][0]:g}-{p['fit_window_s'][1]:g} s (the first version's estimator), "
              f"{p.get('n_runs_ok', '?')} runs.  ![Fig. 2](granular_gas/fig2_msd.png)", "",
              "| case | seeds | D (m²/s) | 95 % CI |", "|---|---|---|---|"]
    for r in summ.itertuples():
        lines.append(f"| {r.case} | {r.n_seeds} | {r.diffusion_coefficient:.3f} | [{r.ci_low:.3f}, {r.ci_high:.3f}] |")
    lines += ["", "| vs exact, paired by seed | protocol | seeds | D_case/D_exact − 1 | 95 % CI | reading |",
              "|---|---|---|---|---|---|"]
    for r in diff.itertuples():
        lines.append(f"| {r.case} | {r.protocol} | {r.n_seeds} | {pct(r.relative)} | "
                     f"{interval(r.relative_ci_low, r.relative_ci_high)} | "
                     f"{verdict(r.relative_ci_low, r.relative_ci_high)} |")
    rd = os.path.join(d, "ratio_D.csv")
    if os.path.exists(rd):
        q = pd.read_csv(rd)
        u = q[q.case == "uncorrected"]
        if len(u):
            u = u.iloc[0]
            within = u.ci_low <= 0.10 <= u.ci_high
            lines += ["", f"The paper's \"about 10 %\" (the uncorrected clumps' share of the sphere-clump gap in D): "
                      f"{u.ratio:+.3f} [{u.ci_low:+.3f}, {u.ci_high:+.3f}] over {u.n_seeds} seeds, which "
                      + ("contains 0.10." if within else "excludes 0.10.")]
    lines.append("")


def programme_section(lines, specs):
    lines += ["## Questions and how far the runs have answered them", ""]
    any_group = False
    for sp in specs:
        rdir = engine.results_dir(sp)
        if not os.path.isdir(rdir) or not any(g.get("target") for g in sp["groups"]):
            continue
        recs = design.load_records(sp, rdir)
        _, status = design.plan(sp, rdir, recs)
        lines.append(f"### `{sp['study']['name']}`: {sp['study']['description']}")
        lines.append("")
        lines.append(f"Spec `{sp['path']}`; {len(recs)} finished runs, {design.cpu_hours(recs):.1f} CPU-hours.")
        lines.append("")
        lines.append("| question | pairs | D_case/D_exact − 1 | 95 % half-width | target | state | projected pairs |")
        lines.append("|---|---|---|---|---|---|---|")
        for gi, st in status.items():
            any_group = True
            g = sp["groups"][gi]
            mean = st["mean"]
            hw = st["halfwidth"]
            lines.append(f"| {g['shape']}, {st['case']} vs exact, {g['protocol']} | {st['n']} | {pct(mean)} | "
                         f"{'n/a' if hw != hw else f'{100 * hw:.2f} %'} | {100 * st['target']:.2f} % | {st['state']} | "
                         f"{st['n_needed'] if st['n_needed'] is not None else 'n/a'} |")
        lines.append("")
    if not any_group:
        lines += ["No sequential study has finished pairs yet.", ""]


def effects_section(lines, rows):
    lines += ["## Effect on D for every shape, protocol and stiffness (`effects.csv`)", ""]
    if not rows:
        lines += ["No paired runs finished yet.", ""]
        return
    lines += ["| shape | D/d_s | protocol | E (Pa) | case | pairs | D_case/D_exact − 1 | 95 % CI | mass error | k² error | YADE | rotation |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['shape']} | {r['overlap']} | {r['protocol']} | {r['youngs_modulus']:.0e} | {r['case']} | "
                     f"{r['n_pairs']} | {pct(r['relative'])} | {interval(r['relative_ci_low'], r['relative_ci_high'])} | "
                     f"{pct(r['mass_error'], 1)} | {pct(r['k2_error'], 1)} | {r['yade_version']} | {r['rot_algorithm']} |")
    lines.append("")


def build():
    specs = effects.committed_specs()
    rows = effects.write(specs, os.path.join(RESULTS, "effects.csv"))
    lines = ["# Results", "",
             "Generated by `.venv/bin/python -m studies.report` from the tables and run records under "
             "`results/`; every interval is a 95 % Student-t interval over seeds (the independent units), "
             "paired by seed where it compares two cases.  D of a run: Green-Kubo on its velocity "
             "autocorrelation (docs/estimator.md) unless a table says otherwise.", ""]
    fig2_section(lines)
    programme_section(lines, specs)
    effects_section(lines, rows)
    text = "\n".join(lines) + "\n"
    path = os.path.join(RESULTS, "README.md")
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)
    return text


if __name__ == "__main__":
    sys.stdout.write(build())
