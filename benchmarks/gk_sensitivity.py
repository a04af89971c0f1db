"""How much D of committed runs depends on the Green-Kubo estimator's choices (issue 12).

    .venv/bin/python benchmarks/gk_sensitivity.py                        # results/sphere_gas
    .venv/bin/python benchmarks/gk_sensitivity.py results/dimer_paired    # any study's records

Reads the reduced run records (no simulation) and recomputes D of each run from its stored
velocity autocorrelation with other truncations and tail-fit windows, with the plain integral to
the largest stored lag, and with the slope of the stored MSD at long lags (an estimator with no
tail model at all).  Prints, per variant, the mean over runs of D_variant / D_default - 1 with a
95 % Student-t interval over runs (the runs are the independent units).  A systematic offset
between a run set and theory that moves with these choices would point at the estimator; one
that does not, does not.
"""
import argparse
import glob
import json
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from studies import estimators as est  # noqa: E402

VARIANTS = {  # name: (truncation in tau_hat, tail-fit window in tau_hat)
    "t_c = 1 tau, fit 1-3 tau": (1.0, (1.0, 3.0)),
    "t_c = 1.5 tau, fit 1.5-3.5 tau": (1.5, (1.5, 3.5)),
    "t_c = 2 tau, fit 2-4 tau": (2.0, (2.0, 4.0)),
    "t_c = 3 tau, fit 2-4 tau": (3.0, (2.0, 4.0)),
}


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
        base = est.diffusion_green_kubo(lag, c, full_output=True)
        r = {"run": rec["name"], "D": base["D"], "tau": base["tau_hat"], "tail_share": base["tail"] / base["D"]}
        for name, (ct, fw) in VARIANTS.items():
            r[name] = est.diffusion_green_kubo(lag, c, c_trunc=ct, fit_window=fw)
        r[f"plain integral to {lag[-1]:.0f} s"] = est.vacf_integral(lag, c)
        r["MSD slope, lags >= 4 tau"] = msd_slope(np.asarray(w["msd_lag_s"]), np.asarray(w["msd"]), 4.0,
                                                  base["tau_hat"])
        rows.append(r)
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("results", nargs="?", default=os.path.join(ROOT, "results", "sphere_gas"))
    ap.add_argument("--case", default=None, help="only runs of this case (e.g. exact)")
    a = ap.parse_args()
    paths = sorted(glob.glob(os.path.join(a.results, "runs", "*.json")))
    if a.case:
        paths = [p for p in paths if f"-{a.case}-" in os.path.basename(p)]
    rows = run_table(paths)
    if len(rows) < 2:
        raise SystemExit(f"need at least 2 finished runs with passed checks under {a.results}/runs, found {len(rows)}")
    print(f"{len(rows)} runs from {os.path.relpath(a.results, ROOT)}: D (default Green-Kubo) mean "
          f"{np.mean([r['D'] for r in rows]):.5g} m^2/s, tau_hat mean {np.mean([r['tau'] for r in rows]):.3g} s, "
          f"tail share of D {100 * np.mean([r['tail_share'] for r in rows]):.1f} %")
    print(f"{'variant':>34} | {'mean D_variant/D_default - 1':>28} | 95 % CI over runs")
    for name in [k for k in rows[0] if k not in ("run", "D", "tau", "tail_share")]:
        rel = np.array([r[name] / r["D"] - 1.0 for r in rows])
        rel = rel[np.isfinite(rel)]
        m, lo, hi, _, _ = est.t_interval(rel)
        print(f"{name:>34} | {100 * m:+27.3f} % | [{100 * lo:+.3f}, {100 * hi:+.3f}] %")


if __name__ == "__main__":
    main()
