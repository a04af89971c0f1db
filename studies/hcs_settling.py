"""How a cooling clump gas's paired effects evolve as it cools: rows of ``results/hcs_settling.csv``.

The effect rows of :mod:`studies.hcs_effects` average each run over one window; an effect that is
still moving there depends on where the window starts (``results/hcs_window.csv``).  This table
follows each case's effect through the run instead, in bins of the scaled time
s = ln(1 + t / tau0), the HCS's clock (a bin of s holds the same number of collisions per particle
at any temperature).  Per seed, both runs of a pair are cut at the same times: the bins of the exact
run's s, its tau0 from Haff's fit to its total kinetic energy past the transient
(:func:`studies.hcs.fit_haff`).  In each bin, per run:

* ``temperature_ratio``: the mean of T_rot / T_tr over the bin's frames;
* ``cooling_rate``: the bin's local cooling rate -d ln(E_kin) / dt (the least-squares slope of
  ln E_kin over the bin's frames) over the mean of sqrt(T_tr / T_tr(0)): the rate at the start
  temperature, since in the HCS it scales as sqrt(T_tr) (the Haff rate of
  :func:`studies.hcs.effect_observables`, bin by bin).

For Haff's law the bin rate reads (2 / tau0)(1 - w^2 / 30) for a bin w wide in s wherever it lies
(the slope weights the rate parabolically over the bin, the denominator uniformly); the factor
cancels in a pair's ratio.  The per-seed relative effect ``X_case / X_exact - 1`` of each bin that
both runs cover within their homogeneous windows (:func:`studies.hcs.window_end`) goes into a
Student-t interval over the seeds (:func:`studies.intervals.t_interval`), as in
``hcs_effects.csv``.  In the HCS every bin's effect is the same.  Whether it still moves is asked
seed by seed: each later bin's effect minus that of the reference bin, the first bin that starts
past the effect rows' transient in every seed (``t_low``, the bin's earliest start over the seeds),
Student-t over the seeds in both (``change`` columns).

    .venv/bin/python -m studies hcs-settling                     # hcs_settling and hcs_clumps
    .venv/bin/python -m studies hcs-settling hcs_settling --width 0.25
"""
from __future__ import annotations

import math
import os
import sys

import numpy as np

from . import hcs
from .effects import _pair_key
from .hcs_effects import T_TRANSIENT, _group_fields, load_records, write_csv
from .intervals import t_interval

COLUMNS = ("study", "shape", "n_spheres", "restitution", "friction", "cooling_stop", "case", "observable",
           "s_low", "s_high", "t_low", "n_pairs", "relative", "relative_ci_low", "relative_ci_high", "reference_s",
           "change", "change_ci_low", "change_ci_high", "change_pairs")
OBSERVABLES = ("cooling_rate", "temperature_ratio")
WIDTH = 0.2          # a bin's width in scaled time s
MIN_FRAMES = 5       # frames a bin needs in a run for a slope


def scaled_time(series, t_transient=T_TRANSIENT):
    """A run's scaled time s = ln(1 + t / tau0) at its frames, tau0 from Haff's fit to the total
    kinetic energy between the transient and the end of the homogeneous window.

    Parameters
    ----------
    series : mapping
        The run's HCS series (a record's ``hcs`` part).
    t_transient : float, optional
        Frames before it (s) are left out of the fit.

    Returns
    -------
    numpy.ndarray
        s at every frame.
    """
    return hcs.scaled_time(np.asarray(series["t"], float), hcs.energy_tau0(series, t_transient))


def bin_values(series, mask):
    """The observables of one run over the frames ``mask`` selects (one bin).

    Parameters
    ----------
    series : mapping
        The run's HCS series.
    mask : numpy.ndarray of bool
        The bin's frames; at least :data:`MIN_FRAMES`.

    Returns
    -------
    dict
        ``temperature_ratio`` (NaN without rotation) and ``cooling_rate`` (1/s, at the start temperature).
    """
    if int(np.count_nonzero(mask)) < MIN_FRAMES:
        raise ValueError(f"a bin needs at least {MIN_FRAMES} frames, got {int(np.count_nonzero(mask))}")
    t = np.asarray(series["t"], float)
    e_tr, e_rot = np.asarray(series["e_trans"], float), np.asarray(series["e_rot"], float)
    t_tr, t_rot = hcs.temperatures(e_tr, e_rot, int(series["n_particles"]), int(series["rot_dof"]))
    slope = np.polyfit(t[mask], np.log(e_tr[mask] + e_rot[mask]), 1)[0]
    ratio = float(np.mean(t_rot[mask] / t_tr[mask])) if int(series["rot_dof"]) > 0 else float("nan")
    return {"cooling_rate": float(-slope / np.mean(np.sqrt(t_tr[mask] / t_tr[0]))), "temperature_ratio": ratio}


def rows(records, study="", width=WIDTH, t_transient=T_TRANSIENT, left_out=None):
    """Rows of ``results/hcs_settling.csv`` (columns :data:`COLUMNS`) from one study's records.

    Parameters
    ----------
    records : list of dict
        Reduced records of cooling clump runs (:func:`studies.hcs_effects.load_records`).
    study : str, optional
        The study's name (the ``study`` column).
    width : float, optional
        The bins' width in scaled time; the bins start at s = 0.
    t_transient : float, optional
        As :func:`scaled_time`; also where the reference bin starts (:func:`_changes`).
    left_out : list, optional
        Gets ``(run name, reason)`` for each exact run whose tau0 cannot be fitted (its seed gives no
        bin) and each bin a run holds too few frames for (that bin of that pair is left out).

    Returns
    -------
    list of dict
        One row per (shape, material, case, observable, bin) with at least two paired seeds.
    """
    if not width > 0:
        raise ValueError(f"width: expected a positive bin width in scaled time, got {width!r}")
    note = (lambda name, why: left_out.append((name, why))) if left_out is not None else (lambda name, why: None)
    seeds = {}
    for rec in records:
        seeds.setdefault((_pair_key(rec["params"]), rec["seed"]), {})[rec["case"]] = rec
    per = {}          # (pair key, case, observable) -> {bin: {seed: relative effect}}
    starts = {}       # (pair key, case) -> {bin: [the bin's first frame time in each seed]}
    params = {}
    for (key, seed), cases in sorted(seeds.items(), key=lambda kv: (kv[0][0], kv[0][1])):
        ex = cases.get("exact")
        if ex is None or len(cases) < 2:
            continue
        t = np.asarray(ex["hcs"]["t"], float)
        try:
            s = scaled_time(ex["hcs"], t_transient)
        except ValueError as e:
            note(ex.get("name", "?"), f"no Haff fit for its scaled time: {e}")
            continue
        if not np.all(np.isfinite(s)):
            note(ex.get("name", "?"), "its Haff fit gives no finite scaled time")
            continue
        for case, rec in cases.items():
            if case == "exact":
                continue
            params[(key, case)] = rec["params"]
            t_case = np.asarray(rec["hcs"]["t"], float)
            # both runs homogeneous to the bin's end: each run's own window, on the exact run's clock
            t_end = min(hcs.window_end(ex["hcs"]), hcs.window_end(rec["hcs"]), t[-1], t_case[-1])
            s_end = float(np.interp(t_end, t, s))
            if s_end < width:
                note(rec.get("name", "?"), f"its pair's window reaches s = {s_end:.3g}, short of a whole bin")
            for b in range(int(math.floor(s_end / width + 1e-9))):
                m_ex = (s >= b * width) & (s < (b + 1) * width)
                if int(np.count_nonzero(m_ex)) < MIN_FRAMES:
                    note(ex.get("name", "?"), f"s {b * width:g}-{(b + 1) * width:g} holds fewer than {MIN_FRAMES} frames")
                    continue
                t_lo, t_hi = t[m_ex][0], t[m_ex][-1]
                m_case = (t_case >= t_lo - 1e-9) & (t_case <= t_hi + 1e-9)
                if int(np.count_nonzero(m_case)) < MIN_FRAMES:
                    note(rec.get("name", "?"), f"s {b * width:g}-{(b + 1) * width:g} holds fewer than {MIN_FRAMES} frames")
                    continue
                v_ex, v_case = bin_values(ex["hcs"], m_ex), bin_values(rec["hcs"], m_case)
                starts.setdefault((key, case), {}).setdefault(b, []).append(float(t_lo))
                for o in OBSERVABLES:
                    if math.isfinite(v_ex[o]) and math.isfinite(v_case[o]):
                        per.setdefault((key, case, o), {}).setdefault(b, {})[seed] = v_case[o] / v_ex[o] - 1.0
    out = []
    for (key, case, o), bins in per.items():
        p = params[(key, case)]
        t_low = {b: min(ts) for b, ts in starts[(key, case)].items()}
        ref, changes = _changes(bins, t_low, t_transient)
        for b, by_seed in sorted(bins.items()):
            if len(by_seed) < 2:
                continue
            m, lo, hi, _, n = t_interval(list(by_seed.values()))
            out.append({"study": study, **_group_fields(p), "cooling_stop": float(p["run"]["cooling_stop"]),
                        "case": case, "observable": o, "s_low": b * width, "s_high": (b + 1) * width,
                        "t_low": t_low[b], "n_pairs": n, "relative": m, "relative_ci_low": lo, "relative_ci_high": hi,
                        "reference_s": None if ref is None else ref * width,
                        **changes.get(b, {"change": None, "change_ci_low": None, "change_ci_high": None,
                                          "change_pairs": None})})
    out.sort(key=lambda r: (r["study"], r["shape"], r["friction"], r["case"], OBSERVABLES.index(r["observable"]),
                            r["s_low"]))
    return out


def _changes(bins, t_low, t_transient):
    """The reference bin, the first that starts past ``t_transient`` in every seed (``t_low``: a bin's
    earliest start over the seeds), and each later bin's change from it: per seed present in both,
    the bin's effect minus the reference's, Student-t over those seeds (two or more).

    Returns
    -------
    tuple
        (reference bin index or None, {bin: {change, change_ci_low, change_ci_high, change_pairs}}).
    """
    after = [b for b in sorted(bins) if t_low[b] >= t_transient - 1e-9 and len(bins[b]) >= 2]
    if not after:
        return None, {}
    ref = after[0]
    out = {}
    for b in after[1:]:
        both = [bins[b][sd] - bins[ref][sd] for sd in bins[b] if sd in bins[ref]]
        if len(both) >= 2:
            m, lo, hi, _, n = t_interval(both)
            out[b] = {"change": m, "change_ci_low": lo, "change_ci_high": hi, "change_pairs": n}
    return ref, out


def _predictions(path):
    """{(shape, restitution, friction, case, observable): predicted} of the cooling rows of
    ``predictions.csv`` (the predictor's stationary HCS balance), or {} without the file."""
    import csv

    if not os.path.exists(path):
        return {}
    with open(path, newline="") as f:
        return {(r["shape"], float(r["restitution"]), float(r["friction"]), r["case"].partition("/")[0], r["observable"]):
                float(r["predicted"]) for r in csv.DictReader(f) if float(r["restitution"]) < 1 or float(r["friction"]) > 0}


def plot(rows_, path, predictions=None):
    """One column per (study, shape, contact law), a row per observable: each case's effect bin by
    bin (95 % intervals) against the scaled time, and the predictor's stationary value (dashed).

    Parameters
    ----------
    rows_ : list of dict
        :func:`rows`.
    path : str
        The PNG file.
    predictions : dict, optional
        :func:`_predictions`.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = sorted({(r["study"], r["shape"], r["restitution"], r["friction"]) for r in rows_})
    fig, axes = plt.subplots(len(OBSERVABLES), len(panels), figsize=(3.6 * len(panels), 3.0 * len(OBSERVABLES)),
                             squeeze=False, sharex="col")
    for j, key in enumerate(panels):
        for i, o in enumerate(OBSERVABLES):
            ax = axes[i, j]
            mine = [r for r in rows_ if (r["study"], r["shape"], r["restitution"], r["friction"]) == key
                    and r["observable"] == o]
            for k, case in enumerate(sorted({r["case"] for r in mine})):
                c = sorted((r for r in mine if r["case"] == case), key=lambda r: r["s_low"])
                x = np.array([(r["s_low"] + r["s_high"]) / 2 for r in c]) + 0.015 * (k - 1)
                y = np.array([r["relative"] for r in c])
                err = np.array([[r["relative"] - r["relative_ci_low"], r["relative_ci_high"] - r["relative"]] for r in c]).T
                ax.errorbar(x, 100 * y, yerr=100 * err, fmt="o-", ms=3, lw=0.8, capsize=2, color=f"C{k}", label=case)
                pred = (predictions or {}).get((key[1], key[2], key[3], case, o))
                if pred is not None:
                    ax.axhline(100 * pred, color=f"C{k}", ls="--", lw=0.8)
            ax.axhline(0, color="gray", lw=0.5)
            ax.set_ylabel(f"{o.replace('_', ' ')}: case / exact − 1 (%)", fontsize=8)
            if i == len(OBSERVABLES) - 1:
                ax.set_xlabel("scaled time s = ln(1 + t / τ0)")
            if i == 0:
                ax.set_title(f"{key[0]}: {key[1]}, e = {key[2]:g}, μ = {key[3]:g}", fontsize=8)
            ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    """``python -m studies hcs-settling [SPEC ...]``: ``results/hcs_settling.csv`` from cooling clump studies.

    Parameters
    ----------
    argv : sequence of str, optional
        The command line's arguments.

    Returns
    -------
    int
        0, or 1 when no study has two paired seeds yet.
    """
    import argparse

    from . import spec as S

    ap = argparse.ArgumentParser(prog="python -m studies hcs-settling",
                                 description="Each case's paired effect on the cooling rate and on T_rot / T_tr of "
                                             "clump gases, bin by bin of the scaled time ln(1 + t / tau0).",
                                 epilog="Writes results/hcs_settling.csv (or --out) and, beside it, hcs_settling.png "
                                        "(the frictional gases, with the predictor's values from predictions.csv "
                                        "there). Intervals: Student-t over seeds.")
    ap.add_argument("specs", nargs="*", default=["hcs_settling", "hcs_clumps"],
                    help="cooling clump studies (default: hcs_settling hcs_clumps)")
    ap.add_argument("--width", type=float, default=WIDTH, help=f"bin width in scaled time (default {WIDTH:g})")
    ap.add_argument("--t-transient", type=float, default=T_TRANSIENT, metavar="S",
                    help=f"frames before it are left out of the Haff fit that sets s (default: {T_TRANSIENT:g} s)")
    ap.add_argument("--out", default=os.path.join(S.ROOT, "results", "hcs_settling.csv"))
    a = ap.parse_args(argv)
    if not a.width > 0:
        ap.error(f"--width {a.width:g}: expected a positive bin width")
    out, left_out = [], []
    for name in a.specs:
        spec = S.load(S.spec_path(name))
        out += rows(load_records(S.results_dir(spec)), spec["study"]["name"], a.width, a.t_transient, left_out)
    for name, why in left_out:
        print(f"[hcs-settling] left out of its bins: {name}: {why}", file=sys.stderr)
    if not out:
        print(f"[hcs-settling] no bin with two paired seeds in {', '.join(a.specs)}", file=sys.stderr)
        return 1
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    write_csv(a.out, COLUMNS, out)
    png = os.path.splitext(a.out)[0] + ".png"
    plot([r for r in out if r["friction"] > 0], png,
         _predictions(os.path.join(os.path.dirname(os.path.abspath(a.out)), "predictions.csv")))
    for r in out:
        print(f"[hcs-settling] {r['study']} {r['shape']} mu={r['friction']:g} {r['case']:>12} {r['observable']:>17} "
              f"s {r['s_low']:.2f}-{r['s_high']:.2f}: {100 * r['relative']:+.2f} % "
              f"[{100 * r['relative_ci_low']:+.2f}, {100 * r['relative_ci_high']:+.2f}] ({r['n_pairs']} pairs)")
    print(f"[hcs-settling] wrote {a.out} and {png} (the frictional gases)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
