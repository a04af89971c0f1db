"""Each case's effect on a clump gas in the homogeneous cooling state: rows of ``results/hcs_effects.csv``.

Reads the HCS series kept in the reduced records of cooling-clump studies (``hcs_clumps.toml``),
analyses every run with :func:`studies.hcs.analyse_series` and pairs each case with the exact case
of the same seed and parameters (the paired protocol: one initial state per seed).  Per seed, the
relative effect ``X_case / X_exact - 1`` of three observables:

* ``cooling_rate``: zeta = 2 / tau0 past the transient, at the start temperature (zeta scales as
  sqrt(T_tr): zeta0 sqrt(T_start / T0)), with tau0 from Haff's fit to the total kinetic energy
  and T0 the T_tr amplitude at that tau0 (:func:`studies.hcs.haff_amplitude`);
* ``temperature_ratio``: T_rot / T_tr averaged over the window after the transient;
* ``diffusion``: D0 from the MSD from the first frame against the scaled time ln(1 + t / tau0)
  (:func:`studies.hcs.fit_scaled_msd`), at the start temperature as zeta.  Not from the
  multi-origin MSD grid (:func:`studies.hcs.fit_scaled_msd_grid`): in the frictional clump gases
  a particle's velocity remembers itself (the first-frame fit's intercept over its slope) about as
  long as the grid's shortest lag, so the grid's D0 grows with that lag and its bias differs
  between cases (``docs/hcs.md``).

The interval is Student-t over the seeds' relative effects (:func:`studies.intervals.t_interval`).
The bias and coverage of these estimators on synthetic cooling gases with a known answer:
``python -m studies hcs-estimator`` (:mod:`studies.hcs_estimator`, ``results/estimator/hcs_cooling.csv``).
"""
from __future__ import annotations

import csv
import glob
import json
import math
import os
import sys

import numpy as np

from . import hcs
from .effects import _pair_key, case_errors, shape_name
from .intervals import t_interval

COLUMNS = ("shape", "n_spheres", "youngs_modulus", "restitution", "friction", "protocol", "case", "observable",
           "n_pairs", "relative", "relative_ci_low", "relative_ci_high", "mass_error", "k2_error", "yade_version",
           "rot_algorithm")
OBSERVABLES = ("cooling_rate", "temperature_ratio", "diffusion")
T_TRANSIENT = hcs.CLUMP_TRANSIENT


def load_records(results_dir):
    """The reduced records of a study's cooling runs (those with an ``hcs`` part), in name order.

    Parameters
    ----------
    results_dir : str
        A study's results folder (its ``runs/*.json``).

    Returns
    -------
    list of dict
        The records.
    """
    out = []
    for path in sorted(glob.glob(os.path.join(results_dir, "runs", "*.json"))):
        with open(path) as f:
            rec = json.load(f)
        if "hcs" in rec:
            out.append(rec)
    return out


# the HCS observables of one run, past the transient (one definition, shared with studies.design)
observables = hcs.effect_observables


def paired(records, t_transient=T_TRANSIENT, left_out=None):
    """Per-seed relative effects of every case against exact.

    Parameters
    ----------
    records : list of dict
        Reduced run records (:func:`load_records`).
    t_transient : float or callable, optional
        As :func:`observables`; a callable gives each run's own from its record.
    left_out : list, optional
        Gets ``(run name, reason)`` for each run whose window cannot be analysed (it ends, where the
        gas clusters, before the transient does): that run's pair is left out of every row.

    Returns
    -------
    dict
        ``{(pair key, case): {"params": ..., "seeds": [...], "relative": {observable: [...]},
        "yade_version": set, "rot_algorithm": set}}``, the observables those of :func:`observables`.
    """
    groups = {}
    for rec in records:
        p = rec["params"]
        key = _pair_key(p)
        groups.setdefault((key, rec["seed"]), {})[rec["case"]] = rec
    out = {}
    for (key, seed), cases in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][1])):
        ex = cases.get("exact")
        if ex is None:
            continue
        x_ex = _observables_or_none(ex, t_transient, left_out)
        for case, rec in sorted(cases.items()):
            if case == "exact":
                continue
            x = _observables_or_none(rec, t_transient, left_out)
            if x is None or x_ex is None:
                continue
            slot = out.setdefault((key, case), {"params": rec["params"], "seeds": [], "yade_version": set(),
                                                "rot_algorithm": set(),
                                                "relative": {o: [] for o in x}})
            slot["seeds"].append(seed)
            for o in x:
                slot["relative"][o].append(x[o] / x_ex[o] - 1.0)
            for r in (ex, rec):
                slot["yade_version"].add(r["yade_version"])
                slot["rot_algorithm"].add(r["rot_algorithm"])
    return out


def _observables_or_none(rec, t_transient, left_out):
    """:func:`observables` of a record, or None (its name and the reason put in ``left_out``) when
    its window holds too few frames."""
    try:
        return observables(rec["hcs"], t_transient(rec) if callable(t_transient) else t_transient)
    except ValueError as e:
        if left_out is not None and all(name != rec.get("name") for name, _ in left_out):
            left_out.append((rec.get("name", "?"), str(e)))
        return None


def _group_fields(params):
    """The columns that name a run's shape and contact law: shape, n_spheres, restitution, friction."""
    mat = params["material"]
    return {"shape": shape_name(params["shape"]["definition"]), "n_spheres": len(params["shape"]["radii"]),
            "restitution": float(mat.get("restitution", 1.0)), "friction": float(mat.get("friction", 0.0))}


def rows(records, t_transient=T_TRANSIENT, left_out=None):
    """Rows of ``results/hcs_effects.csv`` (columns :data:`COLUMNS`).

    Parameters
    ----------
    records : list of dict
        Reduced records of cooling clump runs (:func:`load_records`).
    t_transient : float, optional
        As :func:`observables`.
    left_out : list, optional
        As :func:`paired`.

    Returns
    -------
    list of dict
        One row per (shape, material, protocol, case, observable) with at least one paired seed.
    """
    out = []
    for (_, case), slot in paired(records, t_transient, left_out).items():
        p = slot["params"]
        shape, mat = p["shape"]["definition"], p["material"]
        for o in OBSERVABLES:
            vals = [v for v in slot["relative"][o] if math.isfinite(v)]
            if not vals:
                continue
            m, lo, hi, _, n = t_interval(vals)
            out.append({**_group_fields(p), "youngs_modulus": float(mat["youngs_modulus"]),
                        "protocol": p["protocol"], "case": case,
                        "observable": o, "n_pairs": n, "relative": m, "relative_ci_low": lo, "relative_ci_high": hi,
                        **case_errors(shape, float(mat["density"]), case),
                        "yade_version": ";".join(sorted(slot["yade_version"])),
                        "rot_algorithm": ";".join(sorted(slot["rot_algorithm"]))})
    out.sort(key=lambda r: (r["shape"], r["friction"], r["restitution"], r["case"], OBSERVABLES.index(r["observable"])))
    return out


RELAXATION_COLUMNS = ("shape", "n_spheres", "restitution", "friction", "case", "n_runs", "drift", "drift_ci_low",
                      "drift_ci_high", "window_start", "window_end", "flow_runs", "flow_ratio", "flow_growth",
                      "flow_growth_ci_low", "flow_growth_ci_high")


def ratio_drift(series, t_transient=T_TRANSIENT):
    """How far T_rot / T_tr still moves in a run's analysed window: the mean of its second half over
    the mean of its first half, minus one (0 in the HCS, where the ratio is constant).

    Parameters
    ----------
    series : mapping
        The run's HCS series.
    t_transient : float, optional
        The window starts here (s) and ends where the gas stops being homogeneous.

    Returns
    -------
    (float, float, float)
        The drift, and the window's start and end (s); NaN drift without rotation or frames.
    """
    t, e_tr, e_rot = (np.asarray(series[k], float) for k in ("t", "e_trans", "e_rot"))
    t_tr, t_rot = hcs.temperatures(e_tr, e_rot, int(series["n_particles"]), int(series["rot_dof"]))
    t_hom = hcs.window_end(series)
    if np.max(e_rot) <= 1e-9 * e_tr[0]:
        return float("nan"), t_transient, t_hom
    return _half_drift(t, t_rot / t_tr, t_transient, t_hom)[0], t_transient, t_hom


def _half_drift(t, x, t_lo, t_hi):
    """The mean of ``x`` over the second half of the frames of [t_lo, t_hi] (its finite values) over
    that of the first half, minus one, and the second half's mean; NaN for fewer than 4 frames."""
    x = np.asarray(x, float)
    if x.shape != np.shape(t):
        raise ValueError(f"{x.shape[0] if x.ndim else 0} values for {len(t)} frames")
    sel = (t >= t_lo) & (t <= t_hi) & np.isfinite(x)
    if sel.sum() < 4:
        return float("nan"), float("nan")
    v = x[sel]
    half = len(v) // 2
    return float(v[half:].mean() / v[:half].mean() - 1.0), float(v[half:].mean())


def flow_growth(series, t_transient=T_TRANSIENT):
    """Whether the velocity field's vortices grow in a run's analysed window: the mean
    :func:`studies.hcs.flow_energy_ratio` of the window's second half over that of its first half,
    minus one (0 while the gas stays homogeneous in velocity), and the second half's mean.

    Parameters
    ----------
    series : mapping
        The run's HCS series.
    t_transient : float, optional
        The window starts here (s) and ends where the gas stops being homogeneous in density.

    Returns
    -------
    (float, float)
        The growth and the late mean; NaN for a series without ``flow_ratio`` (frames without
        velocities) or with fewer than 4 finite values in the window.
    """
    if "flow_ratio" not in series:
        return float("nan"), float("nan")
    return _half_drift(np.asarray(series["t"], float), series["flow_ratio"], t_transient, hcs.window_end(series))


def relaxation_rows(records, t_transient=T_TRANSIENT):
    """Rows of ``results/hcs_relaxation.csv``: per shape, contact law and case (exact included),
    the mean :func:`ratio_drift` of its runs with a Student-t interval over them.  An interval that
    excludes 0 says the window still holds part of the relaxation from the equipartition start, so
    that group's T_rot / T_tr (and, less, its cooling rate) is not yet the HCS value
    (``results/estimator/hcs_cooling.csv`` measures that bias on synthetic gases).  The ``flow_``
    columns do the same for the velocity field (:func:`flow_growth`, over the runs whose series has
    it): ``flow_ratio`` is the late window's :func:`studies.hcs.flow_energy_ratio`, and a growth
    interval above 0 says vortices are forming.

    Parameters
    ----------
    records : list of dict
        Reduced records of cooling clump runs (:func:`load_records`).
    t_transient : float, optional
        As :func:`observables`.

    Returns
    -------
    list of dict
    """
    groups = {}
    for rec in records:
        p = rec["params"]
        key = (_pair_key(p), rec["case"])
        g = groups.setdefault(key, {"params": p, "case": rec["case"], "vals": [], "flow": []})
        g["vals"].append(ratio_drift(rec["hcs"], t_transient))
        g["flow"].append(flow_growth(rec["hcs"], t_transient))
    out = []
    for g in groups.values():
        vals = [v for v in g["vals"] if math.isfinite(v[0])]
        if len(vals) < 2:
            continue
        m, lo, hi, _, n = t_interval([v[0] for v in vals])
        flow = [f for f in g["flow"] if math.isfinite(f[0])]
        fm, flo, fhi = t_interval([f[0] for f in flow])[:3] if len(flow) >= 2 else (float("nan"),) * 3
        out.append({**_group_fields(g["params"]), "case": g["case"], "n_runs": n, "drift": m, "drift_ci_low": lo, "drift_ci_high": hi,
                    "window_start": float(np.mean([v[1] for v in vals])),
                    "window_end": float(np.mean([v[2] for v in vals])),
                    "flow_runs": len(flow),
                    "flow_ratio": float(np.mean([f[1] for f in flow])) if flow else float("nan"),
                    "flow_growth": fm, "flow_growth_ci_low": flo, "flow_growth_ci_high": fhi})
    out.sort(key=lambda r: (r["shape"], r["friction"], r["restitution"], r["case"]))
    return out


WINDOW_COLUMNS = ("shape", "n_spheres", "restitution", "friction", "case", "observable", "n_pairs", "shift",
                  "shift_ci_low", "shift_ci_high", "window_start", "later_start", "drop")
# the fraction of each seed's analysed window that the window check drops from its start
WINDOW_DROP = 0.25


def later_start(t_transient, t_end, drop=WINDOW_DROP):
    """The start (s) of a window [t_transient, t_end] with its first ``drop`` fraction left out."""
    return t_transient + drop * max(t_end - t_transient, 0.0)


def window_rows(records, t_transient=T_TRANSIENT, drop=WINDOW_DROP, left_out=None):
    """Rows of ``results/hcs_window.csv``: how far each effect of :func:`rows` moves when the window
    starts later.  Every run of a seed (exact and each case) starts its later window at one time,
    :func:`later_start` of the seed's shortest window, so a pair's two runs stay matched.  In the
    HCS the observables do not depend on the window, so a shift whose interval excludes 0 says the
    window still holds something else (the relaxation from the equipartition start, or a slow
    drift) at that effect's precision.  Per seed the shift is the later window's relative effect
    minus the whole window's; the interval is Student-t over the seeds.

    Parameters
    ----------
    records : list of dict
        Reduced records of cooling clump runs (:func:`load_records`).
    t_transient : float, optional
        As :func:`observables`.
    drop : float, optional
        The fraction of each seed's window left out at its start.
    left_out : list, optional
        As :func:`paired`, for the later windows: a seed whose later window is too short for a fit
        is left out of the shift (so a row's ``n_pairs`` can be below ``hcs_effects.csv``'s).

    Returns
    -------
    list of dict
    """
    if not 0.0 < drop < 1.0:
        raise ValueError(f"drop must lie in (0, 1), got {drop}")

    def seed_key(rec):
        return _pair_key(rec["params"]), rec["seed"]

    ends = {}
    for rec in records:
        k = seed_key(rec)
        ends[k] = min(ends.get(k, math.inf), hcs.window_end(rec["hcs"]))
    whole = paired(records, t_transient)
    cut = paired(records, lambda rec: later_start(t_transient, ends[seed_key(rec)], drop), left_out)
    out = []
    for key, slot in whole.items():
        other = cut.get(key)
        if other is None:
            continue
        for o in OBSERVABLES:
            by_seed = dict(zip(other["seeds"], other["relative"][o]))
            used = [(sd, by_seed[sd] - v) for sd, v in zip(slot["seeds"], slot["relative"][o])
                    if sd in by_seed and math.isfinite(v) and math.isfinite(by_seed[sd])]
            if len(used) < 2:
                continue
            m, lo, hi, _, n = t_interval([d for _, d in used])
            out.append({**_group_fields(slot["params"]), "case": key[1], "observable": o, "n_pairs": n, "shift": m,
                        "shift_ci_low": lo, "shift_ci_high": hi, "window_start": float(t_transient),
                        "later_start": float(np.mean([later_start(t_transient, ends[(key[0], sd)], drop)
                                                      for sd, _ in used])),
                        "drop": float(drop)})
    out.sort(key=lambda r: (r["shape"], r["friction"], r["restitution"], r["case"], OBSERVABLES.index(r["observable"])))
    return out


def write_csv(path, columns, rows_, fmt=".10g"):
    """Write ``rows_`` (dicts) as CSV with the header ``columns``: floats as ``fmt``, None as an
    empty cell (the tables of the cooling gases: ``hcs_theory.csv``, ``hcs_effects.csv``, ``law.csv``).

    Parameters
    ----------
    path : str
        The CSV file.
    columns : sequence of str
        The header, in order.
    rows_ : list of dict
        The rows.
    fmt : str, optional
        Format of a float.
    """
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns)
        w.writeheader()
        for r in rows_:
            w.writerow({k: (format(v, fmt) if isinstance(v, float) else ("" if v is None else v)) for k, v in r.items()})


def write(path, rows_):
    """Write ``rows_`` (:func:`rows`) as CSV with the columns :data:`COLUMNS` (``results/hcs_effects.csv``)."""
    write_csv(path, COLUMNS, rows_)


def main(argv=None):
    """``python -m studies hcs-effects [SPEC ...]``: results/hcs_effects.csv from cooling clump studies' records.

    Parameters
    ----------
    argv : sequence of str, optional
        The command line's arguments.

    Returns
    -------
    int
        0, or 1 when no study has a paired cooling-run record yet.
    """
    import argparse

    from . import spec as S

    ap = argparse.ArgumentParser(prog="python -m studies hcs-effects",
                                 description="Each case's relative effect on the cooling rate, T_rot / T_tr and the "
                                             "HCS self-diffusion of clump gases, from the committed run records.",
                                 epilog="Writes results/hcs_effects.csv (or --out), and hcs_relaxation.csv and "
                                        "hcs_window.csv beside it. "
                                        "Intervals: Student-t over seeds.")
    ap.add_argument("specs", nargs="*", default=["hcs_clumps"], help="cooling clump studies (default: hcs_clumps)")
    ap.add_argument("--t-transient", type=float, default=T_TRANSIENT, metavar="S",
                    help=f"frames before it are left out of every fit (default: {T_TRANSIENT:g} s)")
    ap.add_argument("--out", default=os.path.join(S.ROOT, "results", "hcs_effects.csv"))
    a = ap.parse_args(argv)
    records = []
    for name in a.specs:
        spec = S.load(S.spec_path(name))
        records += load_records(os.path.join(S.ROOT, spec["study"]["results"]))
    left_out = []
    out = rows(records, a.t_transient, left_out)
    for name, why in left_out:
        print(f"[hcs-effects] left out {name} and its pair: {why}", file=sys.stderr)
    if not out:
        print(f"[hcs-effects] no paired cooling-run records in {', '.join(a.specs)}", file=sys.stderr)
        return 1
    write(a.out, out)
    relax = os.path.join(os.path.dirname(os.path.abspath(a.out)), "hcs_relaxation.csv")
    write_csv(relax, RELAXATION_COLUMNS, relaxation_rows(records, a.t_transient))
    window = os.path.join(os.path.dirname(os.path.abspath(a.out)), "hcs_window.csv")
    short = []
    write_csv(window, WINDOW_COLUMNS, window_rows(records, a.t_transient, left_out=short))
    for name, why in short:
        print(f"[hcs-effects] the window check leaves out {name}'s seed (its later window): {why}", file=sys.stderr)
    for r in out:
        print(f"[hcs-effects] {r['shape']} e={r['restitution']:g} mu={r['friction']:g} {r['case']:>12} "
              f"{r['observable']:>17}: {100 * r['relative']:+.2f} % [{100 * r['relative_ci_low']:+.2f}, "
              f"{100 * r['relative_ci_high']:+.2f}] ({r['n_pairs']} pairs)")
    print(f"[hcs-effects] wrote {a.out}, {relax} and {window}")
    return 0
