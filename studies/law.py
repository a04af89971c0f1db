"""The law of the overlap error: each observable's relative effect as a formula in the body's
errors, fitted to the binary-collision predictions and checked on the gas runs.

    .venv/bin/python -m studies law          # writes results/law.csv and results/law.png

The effect of a case on an observable X of the paired protocol (the same velocities in every
case) is written as

    X_case / X_exact - 1 = a k2_error + b s(E) mass_error,     s(E) = (E / 1e7 Pa)^(-2/5),

with k2_error the relative error of k^2 = I/m and mass_error that of the mass
(``studies.shapes.k2_error``, ``mass_error``).  Hard particles feel k^2 only (a mass scaled at
fixed k^2 and velocities changes no hard collision); the mass term is the Hertz contact's
softness: a mass lambda times larger at fixed velocities acts like E / lambda, and the softness'
effect scales as the contact time over the free time, ~E^(-2/5).  One pair (a, b) per
observable and contact law (restitution e, friction mu); for the elastic D the stiffness enters
through s(E), so one pair serves every E.

Fitted by weighted least squares (weights 1/se^2) to the predictions: the elastic collision maps
(``results/collision_map/*.json``, rows of uncorrected, mass_only, inertia_only and mass_scaled)
and the cooling predictions (``results/predictions.csv``, restitution < 1 or friction > 0).  The
gas runs are not used in the fit; they are its check: each paired row of ``results/effects.csv``
and ``results/hcs_effects.csv`` with an interval, against the law's value there.  ``law.csv``
holds the coefficients with their standard errors (scaled by sqrt(chi^2/dof) where that exceeds
1), the rms residual and chi^2/dof of the fit, and how many gas intervals contain the law's value.
The equal-energy protocol follows from the paired one for hard particles: D scales by
sqrt(m_exact / m_case) (docs/granular_gas.md), so it needs no law of its own.
"""
from __future__ import annotations

import argparse
import csv
import os
import sys

import numpy as np

from . import effects
from . import spec as S
from .hcs_effects import write_csv

ROOT = S.ROOT
OUT = os.path.join(ROOT, "results", "law.csv")
FIGURE = os.path.join(ROOT, "results", "law.png")
E_REF = 1.0e7
COLUMNS = ("observable", "restitution", "friction", "formula", "coef_k2", "coef_k2_se", "coef_mass", "coef_mass_se",
           "n_points", "rms_residual", "chi2_dof", "n_checks", "n_checks_inside")
FORMULA = "a k2_error + b (E / 1e7 Pa)^(-2/5) mass_error"
# the specs whose shapes the cooling predictions name (predictions.csv names a shape as its spec does)
SHAPE_SPECS = ("hcs_clumps", "grains")


def softness(youngs_modulus):
    """s(E) = (E / 1e7 Pa)^(-2/5): the Hertz contact's softness relative to the paper's E."""
    return (float(youngs_modulus) / E_REF) ** -0.4


def map_points(results):
    """The elastic collision maps' paired rows: dicts (observable "diffusion", e 1, mu 0, E,
    k2_error, mass_error, relative, se, source)."""
    from .effects_plots import read_collision_maps

    out = []
    for m in read_collision_maps(results):
        for r in m["rows"]:
            if r["protocol"] != "paired":
                continue
            out.append({"observable": "diffusion", "restitution": 1.0, "friction": 0.0,
                        "youngs_modulus": float(m["material"]["youngs_modulus"]), "k2_error": float(r["iperp_over_m_error"]),
                        "mass_error": float(r["mass_error"]), "relative": float(r["relative"]), "se": float(r["se"]),
                        "source": f"{m['file']}:{r['case']}"})
    return out


def _shapes():
    out = {}
    for name in SHAPE_SPECS:
        path = os.path.join(S.SPEC_DIR, name + ".toml")
        if os.path.exists(path):
            sp = S.load(path)
            for k, v in sp["shapes"].items():
                out.setdefault(k, (v, float(sp["material"]["density"])))
    return out


def prediction_points(path):
    """The cooling predictions (``predictions.csv`` rows with restitution < 1 or friction > 0) as
    points of the fit, with their shape's errors (shapes named as in :data:`SHAPE_SPECS`)."""
    if not os.path.exists(path):
        return []
    shapes = _shapes()
    out = []
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            e, mu = float(r["restitution"]), float(r["friction"])
            case, _, prot = r["case"].partition("/")
            if (e == 1.0 and mu == 0.0) or prot != "paired" or r["shape"] not in shapes:
                continue
            shape, rho = shapes[r["shape"]]
            err = effects.case_errors(shape, rho, case)
            out.append({"observable": r["observable"], "restitution": e, "friction": mu,
                        "youngs_modulus": float(r["youngs_modulus"]), **err, "relative": float(r["predicted"]),
                        "se": float(r["predicted_se"]), "source": f"predictions.csv:{r['shape']}:{case}"})
    return out


def gas_points(results):
    """The gas runs' paired rows with an interval (the fit's check): effects.csv (observable
    "diffusion", elastic) and hcs_effects.csv."""
    out = []
    for name, elastic in (("effects.csv", True), ("hcs_effects.csv", False)):
        path = os.path.join(results, name)
        if not os.path.exists(path):
            continue
        with open(path, newline="") as f:
            for r in csv.DictReader(f):
                if r["protocol"] != "paired" or not r["k2_error"] or int(r["n_pairs"]) < 2:
                    continue
                out.append({"observable": "diffusion" if elastic else r["observable"],
                            "restitution": 1.0 if elastic else float(r["restitution"]),
                            "friction": 0.0 if elastic else float(r["friction"]),
                            "youngs_modulus": float(r["youngs_modulus"]), "k2_error": float(r["k2_error"]),
                            "mass_error": float(r["mass_error"]), "relative": float(r["relative"]),
                            "ci_low": float(r["relative_ci_low"]), "ci_high": float(r["relative_ci_high"]),
                            "source": f"{name}:{r['shape']}:{r['case']}"})
    return out


def design(points):
    """The fit's design matrix: columns k2_error and s(E) mass_error."""
    return np.array([[p["k2_error"], softness(p["youngs_modulus"]) * p["mass_error"]] for p in points], float)


def fit(points):
    """Weighted least squares of :data:`FORMULA` to ``points`` (each with relative and se).

    Returns
    -------
    dict
        ``coef`` (a, b), ``se`` (their standard errors, scaled by sqrt(chi^2/dof) when > 1),
        ``rms`` (rms residual), ``chi2_dof``, ``n``.
    """
    X, y = design(points), np.array([p["relative"] for p in points], float)
    w = 1.0 / np.array([max(p["se"], 1e-6) for p in points], float)
    coef, *_ = np.linalg.lstsq(X * w[:, None], y * w, rcond=None)
    resid = y - X @ coef
    dof = max(len(y) - 2, 1)
    chi2 = float(np.sum((resid * w) ** 2) / dof)
    cov = np.linalg.inv((X * w[:, None]).T @ (X * w[:, None])) * max(chi2, 1.0)
    return {"coef": coef, "se": np.sqrt(np.diag(cov)), "rms": float(np.sqrt(np.mean(resid ** 2))),
            "chi2_dof": chi2, "n": len(y)}


def law_rows(results, predictions):
    """``law.csv``'s rows: one fit per (observable, restitution, friction) with at least 3 points."""
    pts = map_points(results) + prediction_points(predictions)
    checks = gas_points(results)
    groups = {}
    for p in pts:
        groups.setdefault((p["observable"], p["restitution"], p["friction"]), []).append(p)
    rows, fits = [], {}
    for key in sorted(groups):
        g = groups[key]
        if len(g) < 3:
            continue
        f = fit(g)
        fits[key] = (f, g)
        mine = [c for c in checks if (c["observable"], c["restitution"], c["friction"]) == key]
        law = design(mine) @ f["coef"] if mine else np.array([])
        inside = sum(c["ci_low"] <= v <= c["ci_high"] for c, v in zip(mine, law))
        rows.append({"observable": key[0], "restitution": key[1], "friction": key[2], "formula": FORMULA,
                     "coef_k2": f["coef"][0], "coef_k2_se": f["se"][0], "coef_mass": f["coef"][1],
                     "coef_mass_se": f["se"][1], "n_points": f["n"], "rms_residual": f["rms"],
                     "chi2_dof": f["chi2_dof"], "n_checks": len(mine), "n_checks_inside": int(inside)})
    return rows, fits, checks


def plot(fits, checks, path):
    """One panel per fit: each point's effect less the law's mass term against k2_error, the law's
    line a k2_error, and the gas rows with their intervals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(fits)
    ncols = min(n, 4)
    nrows = -(-n // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols, 3.6 * nrows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    for ax, (key, (f, g)) in zip(axes.flat, fits.items()):
        a, b = f["coef"]
        x = np.array([p["k2_error"] for p in g])
        y = np.array([p["relative"] - b * softness(p["youngs_modulus"]) * p["mass_error"] for p in g])
        ax.errorbar(100 * x, 100 * y, yerr=[100 * p["se"] for p in g], fmt="o", ms=3, color="C0",
                    label="binary collisions")
        mine = [c for c in checks if (c["observable"], c["restitution"], c["friction"]) == key]
        if mine:
            xc = np.array([c["k2_error"] for c in mine])
            shift = np.array([b * softness(c["youngs_modulus"]) * c["mass_error"] for c in mine])
            yc = np.array([c["relative"] for c in mine]) - shift
            err = np.array([[c["relative"] - c["ci_low"], c["ci_high"] - c["relative"]] for c in mine]).T
            ax.errorbar(100 * xc, 100 * yc, yerr=100 * err, fmt="s", ms=4, color="C3", label="gas (95 % CI)")
        xs = np.linspace(min(x.min(), 0) * 1.1, max(x.max(), 0) * 1.1 + 1e-9, 10)
        ax.plot(100 * xs, 100 * a * xs, "k-", lw=1, label=f"law: a = {a:.3f}")
        ax.axhline(0, color="gray", lw=0.5)
        ax.set_xlabel("k² error (%)")
        ax.set_ylabel("effect − mass term (%)")
        ax.set_title(f"{key[0]}, e = {key[1]:g}, μ = {key[2]:g}", fontsize=9)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write(rows, path):
    """Write ``law_rows``' rows as CSV with the columns :data:`COLUMNS`."""
    write_csv(path, COLUMNS, rows, ".6g")


def main(argv=None):
    """``python -m studies law``: results/law.csv and results/law.png; 0, or 1 with nothing to fit."""
    ap = argparse.ArgumentParser(prog="python -m studies law", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--results", default=os.path.join(ROOT, "results"))
    ap.add_argument("--out", default=OUT)
    ap.add_argument("--figure", default=FIGURE)
    a = ap.parse_args(argv)
    rows, fits, checks = law_rows(a.results, os.path.join(a.results, "predictions.csv"))
    if not rows:
        print("[law] nothing to fit: no collision maps or cooling predictions", file=sys.stderr)
        return 1
    write(rows, a.out)
    plot(fits, checks, a.figure)
    for r in rows:
        print(f"[law] {r['observable']} e={r['restitution']:g} mu={r['friction']:g}: a = {r['coef_k2']:.4f} ± "
              f"{r['coef_k2_se']:.4f}, b = {r['coef_mass']:.4f} ± {r['coef_mass_se']:.4f} ({r['n_points']} points, rms "
              f"{100 * r['rms_residual']:.2f} %, chi2/dof {r['chi2_dof']:.2f}); gas check {r['n_checks_inside']} of "
              f"{r['n_checks']} intervals contain the law")
    print(f"[law] wrote {a.out} and {a.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
