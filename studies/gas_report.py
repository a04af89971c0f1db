"""Markdown tables of the granular-gas results, from the CSV/JSON files only.

    .venv/bin/python -m studies.gas_report results/granular_gas
"""
from __future__ import annotations

import json
import os

import pandas as pd


def fmt(x, nd=3):
    return "–" if pd.isna(x) else f"{x:.{nd}f}"


def report(out):
    lines = []
    with open(os.path.join(out, "params.json")) as f:
        p = json.load(f)
    s = pd.read_csv(os.path.join(out, "protocols.csv"))
    d = pd.read_csv(os.path.join(out, "diff_D.csv"))
    r = pd.read_csv(os.path.join(out, "ratio_D.csv"))
    runs = pd.read_csv(os.path.join(out, "runs.csv"))
    lines.append(f"{p['n_particles']} particles, box {p['box_length']:.4f} m, {p['t_end']:g} s per run, "
                 f"dt {p['dt']:.4g} s, equilibration cut {p['t_eq']:g} s, D fitted on lags "
                 f"{p['fit_window_s'][0]:g}-{p['fit_window_s'][1]:g} s; {p['n_runs_ok']} runs used, "
                 f"{p['n_runs_excluded']} excluded, {p['n_runs_missing']} missing.\n")
    lines.append("| case | protocol | seeds | D (m²/s) | 95 % CI | D − D_exact (paired) | 95 % CI | relative | max energy drift |")
    lines.append("|---|---|---|---|---|---|---|---|---|")
    for row in s.itertuples():
        dd = d[(d.case == row.case) & (d.protocol == row.protocol)]
        if len(dd):
            q = dd.iloc[0]
            diff = (f"{q.d_minus_d_exact:+.3f}", f"[{q.ci_low:+.3f}, {q.ci_high:+.3f}]",
                    f"{100 * q.relative:+.2f} % [{100 * q.relative_ci_low:+.2f}, {100 * q.relative_ci_high:+.2f}]")
        else:
            diff = ("–", "–", "–")
        lines.append(f"| {row.case} | {row.protocol} | {row.n_seeds} | {fmt(row.diffusion_coefficient)} | "
                     f"[{fmt(row.ci_low)}, {fmt(row.ci_high)}] | {diff[0]} | {diff[1]} | {diff[2]} | "
                     f"{row.max_energy_drift:.1e} |")
    lines.append("")
    lines.append("| paper's ratio for D: (D_case − D_exact)/(D_spheres − D_exact) | seeds | ratio | 95 % CI |")
    lines.append("|---|---|---|---|")
    for row in r.itertuples():
        lines.append(f"| {row.case} | {row.n_seeds} | {row.ratio:+.3f} | [{row.ci_low:+.3f}, {row.ci_high:+.3f}] |")
    pe = os.path.join(out, "protocol_effect.csv")
    if os.path.exists(pe):
        lines.append("")
        lines.append("| protocol effect: D_equal_energy / D_paired (same case, paired by seed) | seeds | ratio | 95 % CI | hard-particle scaling sqrt(m_exact/m) |")
        lines.append("|---|---|---|---|---|")
        for row in pd.read_csv(pe).itertuples():
            lines.append(f"| {row.case} | {row.n_seeds} | {row.d_equal_energy_over_d_paired:.4f} | "
                         f"[{row.ci_low:.4f}, {row.ci_high:.4f}] | {row.hard_particle_prediction:.4f} |")
    lines.append("")
    lines.append(f"Energy drift over all {len(runs)} runs: max {runs.energy_drift.max():.1e}, median "
                 f"{runs.energy_drift.median():.1e}; momentum drift max {runs.momentum_drift.max():.1e}; "
                 f"{int((~runs.ok.astype(bool)).sum())} runs flagged.")
    if p.get("wall_sweep_s"):
        lines.append(f"Wall time of the last `run` invocation: {p['wall_sweep_s'] / 60:.0f} min; sum of the wall "
                     f"times of all {p['n_runs']} runs: {p['wall_run_s_total'] / 60:.0f} min (2 processes side by side).")
    return "\n".join(lines)


if __name__ == "__main__":
    import argparse
    ap = argparse.ArgumentParser(prog="python -m studies.gas_report",
                                 description="Print the Markdown summary of one study's results directory.")
    ap.add_argument("results_dir", nargs="?", default="results/granular_gas")
    print(report(ap.parse_args().results_dir))
