"""Figures of the granular-gas study, drawn from the CSV tables only (no run files needed).

fig2_msd.png          log-log MSD of every case (+ relative difference panel); the paper's Fig. 2
                      for its own spec
ratio.png             (MSD_case - MSD_exact) / (MSD_spheres - MSD_exact) over lag, 95 % CI
                      (needs the spheres case)
energy_partition.png  translational / rotational share of the total energy over time
diffusion.png         D per case and protocol with 95 % CI of each alone, and D_case / D_exact - 1
                      with the 95 % t-interval of the differences paired by seed

:func:`plot_all` returns the figures drawn; :func:`not_drawn` says why each other one is not.
"""
from __future__ import annotations

import json
import os

import numpy as np

GAP_MIN = 0.05     # ratio.png hides lags where |MSD_spheres / MSD_exact - 1| < 5 %

STYLE = {
    "exact": dict(color="k", ls="-", label="exact (clumpprops)"),
    "uncorrected": dict(color="tab:red", ls="--", label="uncorrected (summed spheres)"),
    "spheres": dict(color="tab:blue", ls=":", label="spheres, m = m_exact"),
    "mass_only": dict(color="tab:green", ls="-.", label="exact mass only"),
    "inertia_only": dict(color="tab:orange", ls=(0, (5, 1, 1, 1, 1, 1)), label="exact inertia only"),
}


def _read(path):
    import pandas as pd

    return pd.read_csv(path) if os.path.exists(path) else None


def _style(case, prot="paired"):
    st = dict(STYLE.get(case, dict(color="gray", ls="-", label=case)))
    if prot != "paired":
        st["label"] += f" [{prot}]"
        st["alpha"] = 0.7
        st["lw"] = 1.0
    return st


# the specs whose study is the paper's Fig. 2 (at paper, quick and test scale)
FIG2_STUDIES = ("paper", "quick", "test")


def msd_title(params):
    """Title of fig2_msd.png from the study's params.json: its name, and "the paper's Fig. 2" only
    for the paper's own study."""
    study = params.get("study") or {}
    name = study.get("name") or f"granular gas, {params.get('scale', '?')} scale"
    fig2 = study.get("name") in FIG2_STUDIES or "scale" in params
    return f"{name}: mean-square displacement" + (" (the paper's Fig. 2)" if fig2 else "")


def not_drawn(out):
    """{figure: why it is not drawn} for the figures of :data:`__doc__` that ``out``'s tables cannot give."""
    why = {}
    for fig, table, reason in (
            ("fig2_msd.png", "msd.csv", "no mean-square displacement table (no analysed run)"),
            ("ratio.png", "ratio.csv", "the paper's ratio needs the spheres case, which this study does not run"),
            ("energy_partition.png", "energy_partition.csv", "no energy table (no analysed run)"),
            ("diffusion.png", "protocols.csv", "no diffusion table (no analysed run)")):
        t = _read(os.path.join(out, table))
        if t is None or not len(t):
            why[fig] = reason
    return why


def _subtitle(params):
    t_eq = params["t_eq"]
    return (f"{params['n_particles']} particles, box {params['box_length']:.3f} m, {params['t_end']:g} s per run, "
            + (f"t_eq = {t_eq:g} s" if isinstance(t_eq, (int, float)) else "t_eq detected per run (auto)"))


def _save(plt, fig, out, name):
    fig.tight_layout()
    fig.savefig(os.path.join(out, name), dpi=120)
    plt.close(fig)
    return name


def _plot_relative_msd(ax, rel):
    """MSD_case / MSD_exact - 1 per case, with its 95 % t band where there are 3 seeds or more."""
    if rel is not None:
        for (case, protocol), g in rel.groupby(["case", "protocol"], sort=False):
            st = _style(case, protocol)
            if g.n_seeds.min() >= 3:     # a 2-seed t-interval (t = 12.7) only hides the rest
                ax.fill_between(g.lag_s, 100 * g.ci_low, 100 * g.ci_high, color=st["color"], alpha=0.15, lw=0)
            else:
                st["label"] += f" (n={g.n_seeds.min()}, no band)"
            ax.plot(g.lag_s, 100 * g.rel_diff, **st)
    ax.legend(fontsize=6, loc="upper right")
    ax.axhline(0, color="k", lw=0.8)
    ax.set(xscale="log", xlabel="lag t (s)", ylabel="MSD / MSD$_{exact}$ - 1 (%)",
           title="MSD / MSD$_{exact}$ - 1, paired by seed (bands: 95 % t)")
    ax.set_ylim(-25, 70)
    ax.grid(True, which="both", alpha=0.3)


def plot_msd(plt, out, params):
    """fig2_msd.png: the MSD of every case (log-log, with a t^2 guide) beside MSD / MSD_exact - 1."""
    msd = _read(os.path.join(out, "msd.csv"))
    if msd is None or not len(msd):
        return None
    fig, (ax_msd, ax_rel) = plt.subplots(1, 2, figsize=(12, 5))
    lag = np.geomspace(msd.lag_s.min(), msd.lag_s.max(), 20)
    for (case, protocol), g in msd.groupby(["case", "protocol"], sort=False):
        st = _style(case, protocol)
        ax_msd.plot(g.lag_s, g.msd_mean, **st)
        ax_msd.fill_between(g.lag_s, g.msd_mean - 1.96 * g.msd_stderr, g.msd_mean + 1.96 * g.msd_stderr,
                            color=st["color"], alpha=0.15, lw=0)
    ballistic = msd.msd_mean.min() / msd.lag_s.min() ** 2
    ax_msd.plot(lag, ballistic * lag ** 2, color="gray", lw=0.6, ls="-")
    ax_msd.text(lag[3], ballistic * lag[3] ** 2 * 3, "~t$^2$", color="gray", fontsize=8)
    _plot_relative_msd(ax_rel, _read(os.path.join(out, "msd_relative.csv")))
    ax_msd.set(xscale="log", yscale="log", xlabel="lag t (s)", ylabel="MSD (m$^2$)", title=msd_title(params))
    ax_msd.legend(fontsize=8)
    ax_msd.grid(True, which="both", alpha=0.3)
    fig.suptitle(_subtitle(params), fontsize=9)
    return _save(plt, fig, out, "fig2_msd.png")


def _plot_ratio_case(ax, case, g, ratio_d, index):
    """One case's curve of the paper's ratio over lag (hidden where the curves cross) and its D dot;
    returns the (first, last) lag hidden, or None."""
    st = _style(case.split("@")[0], case.split("@")[1] if "@" in case else "paired")
    # the ratio is undefined where the sphere and clump MSDs cross: hide |gap| < 5 %
    hidden = (g.gap_rel.abs() < GAP_MIN).values if "gap_rel" in g else np.zeros(len(g), bool)
    if g.n_seeds.min() >= 3:         # 2-seed t-intervals (t = 12.7) would hide everything
        ax.fill_between(g.lag_s, np.where(hidden, np.nan, g.ci_low), np.where(hidden, np.nan, g.ci_high),
                        color=st["color"], alpha=0.15, lw=0)
    else:
        st["label"] += f" (n={g.n_seeds.min()}, no band)"
    ax.plot(g.lag_s, np.where(hidden, np.nan, g.ratio.values), **st)
    if ratio_d is not None and (ratio_d.case == case).any():
        r = ratio_d[ratio_d.case == case].iloc[0]
        ax.errorbar([g.lag_s.max() * (1.2 + 0.07 * index)], [r.ratio],
                    yerr=[[r.ratio - r.ci_low], [r.ci_high - r.ratio]] if r.n_seeds >= 3 else None,
                    fmt="o", color=st["color"], capsize=3, ms=4)
    return (g.lag_s.values[hidden].min(), g.lag_s.values[hidden].max()) if hidden.any() else None


def plot_ratio(plt, out):
    """ratio.png: the paper's ratio over lag with its 95 % t band, and the same ratio for D at the right."""
    ratio = _read(os.path.join(out, "ratio.csv"))
    if ratio is None or not len(ratio):
        return None
    ratio_d = _read(os.path.join(out, "ratio_D.csv"))
    fig, ax = plt.subplots(figsize=(8, 5))
    cross = None
    cases = list(ratio.case.unique())
    for case, g in ratio.groupby("case", sort=False):
        cross = _plot_ratio_case(ax, case, g, ratio_d, cases.index(case)) or cross
    if cross:
        ax.axvspan(cross[0], cross[1], color="gray", alpha=0.2, lw=0)
        ax.text(cross[0], -0.75, " spheres and clumps\n cross: ratio undefined", fontsize=7, color="dimgray")
    ax.axhline(0.10, color="gray", lw=1, ls="--")
    ax.text(ratio.lag_s.min(), 0.105, "paper: about 0.10", color="gray", fontsize=8)
    ax.axhline(0, color="k", lw=0.8)
    ax.set(xscale="log", xlabel="lag t (s)  (dots at right: the same ratio for D; bars: 95 % t if n >= 3)",
           ylabel="(MSD$_{case}$ - MSD$_{exact}$) / (MSD$_{spheres}$ - MSD$_{exact}$)",
           title="the paper's ratio, paired by seed, 95 % t-interval")
    ax.set_ylim(-0.8, 0.8)
    ax.legend(fontsize=7, loc="upper left")
    ax.grid(True, which="both", alpha=0.3)
    return _save(plt, fig, out, "ratio.png")


def plot_energy_partition(plt, out):
    """energy_partition.png: the translational and rotational shares of the energy over time."""
    part = _read(os.path.join(out, "energy_partition.csv"))
    if part is None or not len(part):
        return None
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for (case, protocol), g in part.groupby(["case", "protocol"], sort=False):
        st = _style(case, protocol)
        ax.plot(g.t, g.trans_fraction, **st)
        if case != "spheres":
            ax.plot(g.t, g.rot_fraction, **dict(st, label=None, lw=0.8))
    ax.axhline(0.6, color="gray", lw=0.8, ls="--")
    ax.axhline(0.4, color="gray", lw=0.8, ls="--")
    ax.text(0.1, 0.62, "equipartition (3 + 2 dof): translational 3/5", fontsize=8, color="gray")
    ax.text(0.1, 0.36, "rotational 2/5", fontsize=8, color="gray")
    ax.set_xscale("symlog", linthresh=1.0)
    ax.set_xlim(0, part.t.max())
    ax.set(xlabel="t (s)  (linear below 1 s)", ylabel="share of total energy (seed mean)",
           title="energy partition (upper: translational, lower: rotational)")
    ax.set_ylim(-0.02, 1.02)
    ax.legend(fontsize=6, loc="center", bbox_to_anchor=(0.62, 0.5), ncol=2, framealpha=0.9)
    ax.grid(True, alpha=0.3)
    return _save(plt, fig, out, "energy_partition.png")


def _plot_unpaired(ax, protocols):
    """D of each (case, protocol) alone with its 95 % CI over seeds, and the hard-particle prediction."""
    for i, r in enumerate(protocols.itertuples()):
        st = _style(r.case, r.protocol)
        lo = r.diffusion_coefficient - r.ci_low if r.ci_low == r.ci_low else 0
        hi = r.ci_high - r.diffusion_coefficient if r.ci_high == r.ci_high else 0
        ax.errorbar([r.diffusion_coefficient], [i], xerr=[[lo], [hi]], fmt="o", color=st["color"], capsize=4)
        if r.protocol != "paired" and r.hard_particle_prediction_from_paired == r.hard_particle_prediction_from_paired:
            ax.plot([r.hard_particle_prediction_from_paired], [i], "x", color="k", ms=8,
                    label="hard-particle scaling of paired D" if "x" not in [h.get_marker() for h in ax.lines[:-1]] else None)
    ax.set_yticks(range(len(protocols)))
    ax.set_yticklabels([f"{r.case} [{r.protocol}] n={r.n_seeds}" for r in protocols.itertuples()], fontsize=8)
    ax.set(xlabel="self-diffusion coefficient D (m$^2$/s), 95 % CI over seeds",
           title="D of each case alone (unpaired intervals)")
    ax.grid(True, axis="x", alpha=0.3)
    handles, _ = ax.get_legend_handles_labels()
    if handles:
        ax.legend(fontsize=7)


def plot_diffusion(plt, out):
    """diffusion.png: D of each case alone, and beside it each case against exact paired by seed."""
    protocols = _read(os.path.join(out, "protocols.csv"))
    if protocols is None or not len(protocols):
        return None
    paired = _read(os.path.join(out, "diff_D.csv"))
    paired = paired if paired is not None and len(paired) else None
    fig, axes = plt.subplots(1, 2 if paired is not None else 1, figsize=(13 if paired is not None else 7, 4),
                             squeeze=False)
    _plot_unpaired(axes[0, 0], protocols)
    if paired is not None:
        _plot_paired(axes[0, 1], paired)
    return _save(plt, fig, out, "diffusion.png")


def plot_all(out, log=print):
    """Draw every figure of :data:`__doc__` that ``out``'s tables give; return their file names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with open(os.path.join(out, "params.json")) as f:
        params = json.load(f)
    drawn = [plot_msd(plt, out, params), plot_ratio(plt, out), plot_energy_partition(plt, out),
             plot_diffusion(plt, out)]
    made = [name for name in drawn if name]
    log(f"[plot] wrote {', '.join(made)} in {out}")
    for fig_name, why in not_drawn(out).items():
        log(f"[plot] {fig_name} not drawn: {why}")
    return made


def _plot_paired(ax, paired):
    """D_case / D_exact - 1 per case, with the 95 % t-interval of the differences paired by seed."""
    for i, r in enumerate(paired.itertuples()):
        st = _style(r.case, r.protocol)
        ok = r.relative_ci_low == r.relative_ci_low
        ax.errorbar([100 * r.relative], [i], fmt="o", color=st["color"], capsize=4,
                    xerr=[[100 * (r.relative - r.relative_ci_low)], [100 * (r.relative_ci_high - r.relative)]] if ok else None)
    ax.axvline(0, color="k", lw=0.8)
    ax.set_yticks(range(len(paired)))
    ax.set_yticklabels([f"{r.case} [{r.protocol}] n={r.n_seeds}" for r in paired.itertuples()], fontsize=8)
    ax.set(xlabel="D$_{case}$ / D$_{exact}$ - 1 (%), 95 % t-interval over seed pairs",
           title="each case against exact, paired by seed")
    ax.grid(True, axis="x", alpha=0.3)
