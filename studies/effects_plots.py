"""The programme's figures, drawn from ``results/effects.csv`` and ``results/sphere_gas.csv`` only.

effects.png        D_case/D_exact - 1 (paired by seed, 95 % bars) against the summed clump's mass error
                   and against its k^2 = I/m error: one point per shape x overlap x protocol x case;
                   with equal-energy rows, the hard-particle mass scaling (1 + mass error)^(-1/2) - 1;
                   the collision-map predictions of results/collision_map/ as crosses (left panel)
decomposition.png  the paper's dimer, paired protocol, against Young's modulus: uncorrected, mass_only,
                   inertia_only and mass_scaled (summed mass, exact k^2: softness only), the
                   collision-map predictions (results/collision_map/) and the gas runs' 95 % intervals
protocol.png       uncorrected vs exact per shape: paired against equal-energy protocol, with the
                   hard-particle mass-scaling prediction sqrt(m_exact/m_summed) - 1 for equal energy
sphere_gas.png     the sphere gas's D over the Hertz-sphere and hard-sphere Boltzmann D against E

Each figure is written only when its table has rows for it; ``plot_all`` returns the files made.
``studies.report`` calls it and links what exists.
"""
from __future__ import annotations

import os

import numpy as np

CASE_COLORS = {"uncorrected": "tab:red", "mass_only": "tab:green", "inertia_only": "tab:orange"}
SHAPE_MARKERS = {"dimer": "o", "trimer_linear": "s", "trimer_triangle": "^", "tetrahedron": "D"}
DIMER_MARKERS = {"0.25": "v", "0.5": "o", "0.75": "P"}     # the paper's dimer (D/d_s = 0.5) keeps "o"


def _overlap_str(x):
    """An overlap ratio D/d_s as the short string the tables use ('0.5'); '' when absent."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        return ""
    return "" if v != v else f"{v:g}"


def _marker(shape, ov):
    return DIMER_MARKERS.get(ov, "o") if shape == "dimer" else SHAPE_MARKERS.get(shape, "o")


def _shape_label(shape, ov):
    return f"{shape} D/d_s = {ov}" if shape == "dimer" and ov else shape


def _read(path):
    import pandas as pd

    return pd.read_csv(path) if os.path.exists(path) else None


def read_collision_maps(results):
    """The collision-map predictions under ``results``/collision_map/ (studies/maps.py): a list
    of dicts (shape, material, pairs_used, rows: case, protocol, relative, se, hard_particles, ...),
    each with its file name under ``file``, by overlap and Young's modulus."""
    import json

    d = os.path.join(results, "collision_map")
    out = []
    if os.path.isdir(d):
        for f in sorted(os.listdir(d)):
            if f.endswith(".json"):
                with open(os.path.join(d, f)) as fh:
                    m = json.load(fh)
                m["file"] = f
                out.append(m)
    out.sort(key=lambda m: (m["shape"].get("overlap", 0), m["material"]["youngs_modulus"]))
    return out


def is_paper_dimer(m):
    """Whether a collision map is of the paper's dimer (overlap D/d_s = 0.5)."""
    sh = m.get("shape", {})
    return sh.get("kind") == "dimer" and abs(float(sh.get("overlap", 0)) - 0.5) <= 1e-12


def _bars(ax, x, r, **kw):
    y = 100 * r["relative"].to_numpy()
    lo = 100 * r["relative_ci_low"].to_numpy()
    hi = 100 * r["relative_ci_high"].to_numpy()
    ok = np.isfinite(lo) & np.isfinite(hi)
    yerr = np.vstack([np.where(ok, y - lo, 0), np.where(ok, hi - y, 0)])
    ax.errorbar(x, y, yerr=yerr, fmt=kw.pop("fmt", "o"), capsize=3, **kw)


def plot_all(results, log=print):
    """Draw every figure whose table has rows for it under ``results``; returns the files made."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    made = []
    eff = _read(os.path.join(results, "effects.csv"))
    if eff is not None:   # the sphere gas is not a clump's mass-property error (its -40 % would hide the rest)
        eff = eff[(eff["case"] != "spheres") & (eff["n_pairs"] >= 2)]   # one pair: no interval, no point
    if eff is not None and len(eff):
        maps = read_collision_maps(results)
        made.append(_effects_figure(plt, eff, maps, results))
        dim = eff[(eff["shape"] == "dimer") & (eff["protocol"] == "paired") & (eff["overlap"].astype(str) == "0.5")
                  & eff["case"].isin(DECOMP_CASES)]
        pred = _dimer_map_series(maps)
        if pred or (len(dim) and dim["case"].nunique() > 1):
            made.append(_decomposition(plt, dim, pred, results))
        unc = eff[eff["case"] == "uncorrected"]
        if len(unc) and unc["protocol"].nunique() > 1:
            made.append(_protocol_figure(plt, unc, results))
    sph = _read(os.path.join(results, "sphere_gas.csv"))
    if sph is not None and len(sph):
        made.append(_sphere_gas_figure(plt, sph, results))
    for m in made:
        log(f"[plot] {m}")
    return made


def _effects_figure(plt, eff, maps, results):
    """effects.png: every effects row against its mass error (left) and k^2 error (right), with the
    hard-particle mass scaling where there are equal-energy rows and the collision maps' predictions."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 6.8), sharey=True)
    ov_key = eff["overlap"].map(_overlap_str)
    for (shape, ov, prot, case), g in eff.groupby([eff["shape"], ov_key, eff["protocol"], eff["case"]]):
        kw = dict(color=CASE_COLORS.get(case, "gray"), fmt=_marker(shape, ov),
                  mfc="none" if prot != "paired" else None, label=f"{_shape_label(shape, ov)}, {case}, {prot}")
        _bars(axes[0], 100 * g["mass_error"].to_numpy(), g, **kw)
        _bars(axes[1], 100 * g["k2_error"].to_numpy(), g, **dict(kw, label=None))
    if (eff["protocol"] == "equal_energy").any():  # hard particles, equal energy: D ~ m^-1/2
        xm = np.concatenate([100 * eff["mass_error"].to_numpy(dtype=float),
                             [100 * r["mass_error"] for m in maps for r in m["rows"]]])
        x = np.linspace(max(min(0.0, xm.min()) - 2, -50), xm.max() + 2, 200)
        axes[0].plot(x, 100 * ((1 + x / 100) ** -0.5 - 1), "k--", lw=1,
                     label="equal energy, hard particles: (1 + mass error)^(-1/2) − 1")
    if maps:   # kinetic-theory predictions (studies/maps.py), the left panel only
        xs = [100 * r["mass_error"] for m in maps for r in m["rows"] if r["case"] != "mass_scaled"]
        ys = [100 * r["relative"] for m in maps for r in m["rows"] if r["case"] != "mass_scaled"]
        axes[0].plot(xs, ys, "kx", ms=6, label="collision-map prediction (each case, shape, E)")
    for ax, what in zip(axes, ("mass error of the case's body, m_case/m_exact − 1 (%)\n(uncorrected: the summed clump; mass_only: 0)",
                               "k² = I/m error of the case's body against exact (%)\n(I: I_⊥ of a linear clump, tr(I)/3 otherwise)")):
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xlabel(what)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("D_case / D_exact − 1 (%), 95 % CI over seed pairs")
    handles, labels = axes[0].get_legend_handles_labels()     # below both panels: it hid the shapes' points
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=7)
    fig.suptitle("Effect of the clump's mass properties on D, one point per shape × overlap × protocol × case")
    fig.tight_layout(rect=(0, 0.04 + 0.022 * ((len(labels) + 2) // 3), 1, 1))
    return _save(fig, results, "effects.png")


def _protocol_figure(plt, unc, results):
    """protocol.png: uncorrected vs exact per shape, paired against equal energy, with the
    hard-particle mass scaling sqrt(m_exact/m_summed) - 1."""
    fig, ax = plt.subplots(figsize=(8, 4.5))
    labels = sorted({(r.shape, str(r.overlap)) for r in unc.itertuples()})
    for j, prot in enumerate(("paired", "equal_energy")):
        g = unc[unc["protocol"] == prot]
        xs = [labels.index((r.shape, str(r.overlap))) + (j - 0.5) * 0.25 for r in g.itertuples()]
        if len(g):
            _bars(ax, xs, g, color="tab:red" if prot == "paired" else "tab:purple", label=prot)
    pred = [np.sqrt(1.0 / (1.0 + unc[(unc["shape"] == s) & (unc["overlap"].astype(str) == o)]["mass_error"].iloc[0])) - 1
            for s, o in labels]
    ax.plot(np.arange(len(labels)) + 0.125, 100 * np.array(pred), "k_", ms=18, mew=2,
            label="equal energy, hard particles: sqrt(m_exact/m_sum) − 1")
    ax.set_xticks(np.arange(len(labels)))
    ax.set_xlim(-0.6, len(labels) - 0.4)
    ax.set_xticklabels([f"{s}\nD/d_s = {o}" if o not in ("", "nan") else s for s, o in labels], fontsize=8)
    return _finish(fig, ax, 0, "D_uncorrected / D_exact − 1 (%), 95 % CI",
                   "The protocol effect: same velocities vs same energy", results, "protocol.png")


def _sphere_gas_figure(plt, sph, results):
    """sphere_gas.png: the sphere gas's D over the Hertz-sphere and hard-sphere Boltzmann D against E."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    sources = list(dict.fromkeys(sph["source"]))
    # one marker per source (the first version's OLS runs open, the Green-Kubo runs filled), each
    # source a little apart on the E axis so that two at one stiffness do not hide each other
    for i, src in enumerate(sources):
        q = sph[sph["source"] == src]
        e = q["youngs_modulus"].to_numpy() * 10 ** (0.025 * (i - (len(sources) - 1) / 2))
        gk = (q["estimator"] == "green_kubo").all()
        mk = "o" if gk else "s"
        for name, col, lab in (("hertz", "tab:blue", "measured / Hertz-sphere Boltzmann D"),
                               ("hard", "tab:gray", "measured / hard-sphere Boltzmann D")):
            y = q[f"ratio_{name}"].to_numpy()
            yerr = np.vstack([y - q[f"ratio_{name}_ci_low"].to_numpy(), q[f"ratio_{name}_ci_high"].to_numpy() - y])
            ax.errorbar(e, y, yerr=yerr, fmt=mk, capsize=3, color=col, mfc=col if gk else "white",
                        label=lab if i == 0 else None)
        ax.plot(e, q["d_hertz_boltzmann"] / q["d_hard_boltzmann"], "kx",
                label="theory: Hertz / hard spheres" if i == 0 else None)
        ax.plot([], [], mk, color="k", mfc="k" if gk else "white", label=src)
    ax.set_xscale("log")
    ax.set_xlabel("Young's modulus E (Pa)")
    return _finish(fig, ax, 1, "D ratio, 95 % CI (runs and theory)", "Sphere gas against kinetic theory",
                   results, "sphere_gas.png")


DECOMP_CASES = ["uncorrected", "mass_only", "inertia_only", "mass_scaled"]


def _dimer_map_series(maps):
    """{case: [(E, relative, se), ...]} of the paper's dimer (D/d_s = 0.5), paired, from the collision maps."""
    out = {}
    for m in filter(is_paper_dimer, maps):
        E = float(m["material"]["youngs_modulus"])
        for r in m["rows"]:
            if r["protocol"] == "paired" and r["case"] in DECOMP_CASES:
                out.setdefault(r["case"], []).append((E, r["relative"], r["se"]))
    return {c: sorted(v) for c, v in out.items()}


def _decomposition(plt, dim, pred, results):
    """decomposition.png: per case, D_case/D_exact - 1 against E: collision-map predictions (crosses and
    lines, ±1.96 se) and the gas runs' 95 % intervals (filled markers)."""
    fig, ax = plt.subplots(figsize=(10.5, 4.8))
    colors = dict(CASE_COLORS, mass_scaled="tab:blue")
    for j, case in enumerate(DECOMP_CASES):
        col = colors.get(case, "gray")
        if case in pred:
            E, y, se = (np.array(v, dtype=float) for v in zip(*pred[case]))
            ax.errorbar(E, 100 * y, yerr=196 * se, fmt="x-", color=col, capsize=2, lw=1,
                        label=f"{case}: collision-map prediction")
        g = dim[dim["case"] == case]
        if len(g):
            _bars(ax, g["youngs_modulus"].to_numpy(dtype=float) * (1.08 + 0.04 * j), g, color=col,
                  label=f"{case}: gas runs, 95 % CI")
    ax.set_xscale("log")
    ax.set_xlabel("Young's modulus E (Pa)\n"
                  "mass_only: exact m, summed I  ·  inertia_only: summed m, exact I  ·  "
                  "mass_scaled: summed m, exact k²", fontsize=8)
    return _finish(fig, ax, 0, "D_case / D_exact − 1 (%)",
                   "Paper's dimer, paired protocol: mass vs inertia vs contact stiffness", results,
                   "decomposition.png", legend=dict(loc="center left", bbox_to_anchor=(1.01, 0.5)))  # beside the axes


def _finish(fig, ax, ref, ylabel, title, results, name, legend=None):
    """The single-panel figures' common dressing (reference line at ``ref``, labels, legend, grid), saved."""
    ax.axhline(ref, color="k", lw=0.8)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8, **(legend or {}))
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return _save(fig, results, name)


def _save(fig, results, name):
    import matplotlib.pyplot as plt

    path = os.path.join(results, name)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return name
