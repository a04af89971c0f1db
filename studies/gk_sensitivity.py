"""How much D of committed runs depends on the Green-Kubo estimator's choices.

    .venv/bin/python -m studies gk-sensitivity                        # results/sphere_gas
    .venv/bin/python -m studies gk-sensitivity results/dimer_paired    # any study's records
    .venv/bin/python -m studies gk-sensitivity results/shapes --pair tet-exact-paired tet-uncorrected-equal_energy

Reads the reduced run records (no simulation) and recomputes D of each run from its stored
velocity autocorrelation with other truncations and tail-fit windows, with the plain integral to
the largest stored lag, and with the slope of the stored MSD at long lags (an estimator with no
tail model at all).  Prints, per variant, the mean over runs of D_variant / D_default - 1 with a
95 % Student-t interval over runs (the runs are the independent units).  A systematic offset
between a run set and theory that moves with these choices would point at the estimator; one
that does not, does not.

``--pair A B`` compares two run sets seed by seed (A and B are run names without their ``-s<seed>-<key>``
ending): for each variant the mean over seeds of D_B/D_A - 1 with its 95 % t-interval (the seeds are
the independent units), as the report pairs them.  Two more rows need no tail model at all: the
first seconds (D_init = C(0) tau_init / 3, ``diffusion.initial_decay_time``) and the VACF's shape
factor D/D_init, which is 1 for an exponential VACF; its paired ratio is the part of a Green-Kubo
ratio that the first seconds do not see.  Each set's mean tau_hat and shape factor are printed too.
A run set with two runs of one seed (runs of other parameters, such as another time step) is
refused: pass the results directory of one parameter set.

Windows beyond the stored lags: a variant whose truncation t_c lies beyond the last lag gives no D
for that run (n/a, left out of the count of pairs); a tail-fit window that reaches past the last
lag is clipped there (``diffusion.diffusion_green_kubo``), and the output says in how many runs
or pairs that happened.
"""
from __future__ import annotations

import argparse
import glob
import json
import os
import re
import sys

import numpy as np

from . import diffusion, intervals
from .spec import ROOT

VARIANTS = {  # name: (truncation in tau_hat, tail-fit window in tau_hat)
    "t_c = 1 tau, fit 1-3 tau": (1.0, (1.0, 3.0)),
    "t_c = 1.5 tau, fit 1.5-3.5 tau": (1.5, (1.5, 3.5)),
    "t_c = 2 tau, fit 2-4 tau": (2.0, (2.0, 4.0)),
    "t_c = 3 tau, fit 2-4 tau": (3.0, (2.0, 4.0)),
    "t_c = 1 tau, fit 1-2 tau": (1.0, (1.0, 2.0)),   # fits in 100 s of lags up to tau = 50 s
}
FIRST_SECONDS = "first seconds, D_init = C(0) tau_init / 3"
SHAPE_FACTOR = "shape factor D / D_init"


META = ("run", "tau", "tail_share", "clipped")     # run_table keys that are not D values


def _gk(lag, c, **kw):
    """Green-Kubo D, or NaN when the variant's truncation (or a 5-lag fit) does not fit in the stored lags."""
    try:
        return diffusion.diffusion_green_kubo(lag, c, **kw)
    except ValueError:
        return float("nan")


def _first_seconds(lag, c):
    """D_init = C(0) tau_init / 3, or NaN when the first seconds give no decay time."""
    try:
        return float(c[0]) * diffusion.initial_decay_time(lag, c) / 3.0
    except ValueError:
        return float("nan")


def value_names(rows):
    """The D-valued keys of ``rows`` in first-seen order (runs of other lag lengths name their
    plain integral differently)."""
    return list(dict.fromkeys(k for r in rows for k in r if k not in META))


def msd_slope(lag, msd, lo_tau, tau):
    """MSD / 6t slope by least squares on lags >= lo_tau * tau."""
    sel = lag >= lo_tau * tau
    if sel.sum() < 5:
        return float("nan")
    return float(np.polyfit(lag[sel], msd[sel], 1)[0] / 6.0)


def run_table(paths):
    rows = []
    for p in paths:
        with open(p) as f:
            rec = json.load(f)
        if not rec["checks"]["ok"]:
            continue
        w = rec["windows"][0]  # the whole run: the window studies.design uses for equilibrated starts
        c = np.asarray(w["vacf"])
        lag = np.arange(len(c)) * w["frame_interval"]  # as studies.design.run_d (stored lags are rounded)
        base = diffusion.diffusion_green_kubo(lag, c, full_output=True)
        r = {"run": rec["name"], "D": base["D"], "tau": base["tau_hat"], "tail_share": base["tail"] / base["D"],
             "clipped": {name for name, (_, fw) in VARIANTS.items() if fw[1] * base["tau_hat"] > lag[-1] + 1e-9}}
        if 3.0 * base["tau_hat"] > lag[-1] + 1e-9:
            r["clipped"] |= {"D", SHAPE_FACTOR}        # the estimator of record fits on 1-3 tau_hat
        for name, (ct, fw) in VARIANTS.items():
            r[name] = _gk(lag, c, c_trunc=ct, fit_window=fw)
        r[f"plain integral to {lag[-1]:.0f} s"] = diffusion.vacf_integral(lag, c)
        r["MSD slope, lags >= 4 tau"] = msd_slope(np.asarray(w["msd_lag_s"]), np.asarray(w["msd"]), 4.0,
                                                  base["tau_hat"])
        r[FIRST_SECONDS] = _first_seconds(lag, c)
        r[SHAPE_FACTOR] = base["D"] / r[FIRST_SECONDS]
        rows.append(r)
    return rows


RUN_NAME = re.compile(r"^(?P<label>.+)-s(?P<seed>\d+)-[0-9a-f]{8}$")


def label_seed(name):
    """(label, seed) of a run name ``<shape>-<case>-<protocol>-s<seed>-<key[:8]>``."""
    m = RUN_NAME.match(name)
    if m is None:
        raise ValueError(f"run name {name!r} is not <label>-s<seed>-<key>")
    return m["label"], int(m["seed"])


def paired(rows, a, b):
    """Per D value, D_B/D_A - 1 over the seeds both run sets have: {name: (mean, lo, hi, n, clipped)}
    with ``clipped`` the number of those pairs in which either run's fit window was clipped at its
    last lag.  Also ``{label: (mean tau_hat, mean shape factor, runs)}`` of the two sets.

    ``rows`` from :func:`run_table`; ``a``, ``b`` run labels.  The 'D' row is the estimator of record.
    Refuses a set with two runs of one seed (other parameters: the pairs would be ambiguous).
    """
    by, skipped = {}, []
    for r in rows:
        try:
            lab, seed = label_seed(r["run"])
        except ValueError:
            skipped.append(r["run"])
            continue
        if lab in (a, b) and seed in by.get(lab, {}):
            raise SystemExit(f"two runs of {lab} seed {seed} ({by[lab][seed]['run']}, {r['run']}): runs of other "
                             f"parameters share this directory; pass the results directory of one parameter set")
        by.setdefault(lab, {})[seed] = r
    if skipped:
        print(f"[gk_sensitivity] left out {len(skipped)} run(s) whose names are not <label>-s<seed>-<key>: "
              f"{', '.join(skipped[:3])}", file=sys.stderr)
    for lab in (a, b):
        if lab not in by:
            raise SystemExit(f"no finished run labelled {lab!r}; labels here: {', '.join(sorted(by))}")
    seeds = sorted(set(by[a]) & set(by[b]))
    if len(seeds) < 2:
        raise SystemExit(f"{a} and {b} share {len(seeds)} seed(s); need at least 2 pairs")
    out = {}
    for name in value_names(rows):
        ok = [s for s in seeds if np.isfinite(by[b][s].get(name, np.nan) / by[a][s].get(name, np.nan))]
        rel = np.array([by[b][s][name] / by[a][s][name] - 1.0 for s in ok])
        clipped = sum(1 for s in ok if name in by[a][s]["clipped"] or name in by[b][s]["clipped"])
        stats = intervals.t_interval(rel)[:3] if len(rel) >= 2 else (np.nan, np.nan, np.nan)
        out[name] = stats + (len(rel), clipped)
    sets = {lab: (float(np.mean([by[lab][s]["tau"] for s in seeds])),
                  float(np.nanmean([by[lab][s][SHAPE_FACTOR] for s in seeds])), len(seeds)) for lab in (a, b)}
    return out, sets


def main(argv=None):
    """``python -m studies gk-sensitivity [RESULTS] [--case C] [--pair A B]``: prints the tables."""
    ap = argparse.ArgumentParser(prog="python -m studies gk-sensitivity", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("results", nargs="?", default=os.path.join(ROOT, "results", "sphere_gas"))
    ap.add_argument("--case", default=None, help="only runs of this case (e.g. exact)")
    ap.add_argument("--pair", nargs=2, metavar=("A", "B"), default=None,
                    help="compare run sets A and B seed by seed (run names without -s<seed>-<key>), "
                         "e.g. tet-exact-paired tet-uncorrected-equal_energy")
    a = ap.parse_args(argv)
    paths = sorted(glob.glob(os.path.join(a.results, "runs", "*.json")))
    if a.case:
        paths = [p for p in paths if f"-{a.case}-" in os.path.basename(p)]
    rows = run_table(paths)
    if a.pair:
        res, sets = paired(rows, *a.pair)
        print(f"{a.pair[1]} against {a.pair[0]} ({os.path.relpath(a.results, ROOT)}), paired by seed: "
              f"D_B/D_A - 1, mean and 95 % t-interval over pairs")
        for lab, (tau, f, n) in sets.items():
            print(f"  {lab}: tau_hat {tau:.2f} s, shape factor D/D_init {f:.4f} (mean over the {n} paired seeds)")
        for name, (m, lo, hi, n, clipped) in res.items():
            label = "estimator of record (t_c = 2 tau, fit 1-3 tau)" if name == "D" else name
            note = f"; fit window clipped at the last lag in {clipped}" if clipped else ""
            if n < 2:
                print(f"{label:>48} | n/a: {n} pair(s) with a value (t_c beyond the stored lags?)")
            else:
                print(f"{label:>48} | {100 * m:+8.2f} % | [{100 * lo:+.2f}, {100 * hi:+.2f}] % | {n} pairs{note}")
        return
    if len(rows) < 2:
        raise SystemExit(f"need at least 2 finished runs with passed checks under {a.results}/runs, found {len(rows)}")
    print(f"{len(rows)} runs from {os.path.relpath(a.results, ROOT)}: D (default Green-Kubo) mean "
          f"{np.mean([r['D'] for r in rows]):.5g} m^2/s, tau_hat mean {np.mean([r['tau'] for r in rows]):.3g} s, "
          f"tail share of D {100 * np.mean([r['tail_share'] for r in rows]):.1f} %")
    print(f"{'variant':>42} | {'mean D_variant/D_default - 1':>28} | 95 % CI over runs")
    for name in [k for k in value_names(rows) if k not in ("D", SHAPE_FACTOR)]:
        rel = np.array([r.get(name, np.nan) / r["D"] - 1.0 for r in rows])
        rel = rel[np.isfinite(rel)]
        clipped = sum(1 for r in rows if name in r["clipped"])
        note = f" (fit window clipped at the last lag in {clipped} runs)" if clipped else ""
        if len(rel) < 2:
            print(f"{name:>42} | n/a: a value in {len(rel)} of {len(rows)} runs (t_c beyond the stored lags?)")
            continue
        m, lo, hi, _, _ = intervals.t_interval(rel)
        print(f"{name:>42} | {100 * m:+27.3f} % | [{100 * lo:+.3f}, {100 * hi:+.3f}] %{note}")


if __name__ == "__main__":
    main()
