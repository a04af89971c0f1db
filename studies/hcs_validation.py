"""The sphere validations of the homogeneous cooling state: rows of ``results/hcs_theory.csv``.

Reads the HCS series of every run (:func:`studies.hcs.series`): from the reduced run records a
sweep writes (:func:`load_records`, their ``hcs`` part), or from raw frames
(``python -m studies run SPEC --keep-raw``, :func:`load_raw`); analyses each with
:func:`studies.hcs.analyse_series`, and compares the seeds' mean with kinetic theory:

* ``cooling_rate``: zeta0 = 2 / tau0 of Haff's fit against :func:`studies.hcs.haff_theory`
  (Enskog frequency, Carnahan-Starling contact value, Sonine factor) for smooth spheres;
* ``diffusion``: D0 from the scaled-time MSD against Brilliantov and Poeschel's
  T0 / (m (nu_D - zeta0 / 2)) (:func:`studies.hcs_theory.hcs_diffusion`) for smooth spheres;
* ``temperature_ratio``: T_rot / T_tr against a given theory value for rough spheres (the
  two-temperature balance of the measured collision rule, docs/hcs.md).  The ratio relaxes to its
  HCS value about as slowly as the gas cools, so a run ends before it has settled.  When a seed was
  run twice, started at zero spin (below the HCS value) and spinning (above it), the two runs
  bracket it, and :func:`bracketed_ratio` extrapolates the pair to the settled value.

Intervals are Student-t over seeds (:func:`studies.intervals.t_interval`).
"""
from __future__ import annotations

import glob
import json
import os
import re
import sys

import numpy as np

from . import hcs, hcs_theory
from .hcs_effects import write_csv
from .intervals import t_interval

COLUMNS = ("observable", "restitution", "friction", "measured", "ci_low", "ci_high", "theory", "theory_name",
           "theory_accuracy")
# kappa = 4 I / (m sigma^2) of a solid sphere
KAPPA_SPHERE = 0.4
# the theories' own accuracy as their sources state it (relative): the Sonine correction to zeta is
# below 0.3 % at e = 0.9, and the Maxwellian HCS ratio is within a few per cent of the Sonine one
# for e >= 0.8 (studies/hcs_theory.py); the diffusion's is not stated there (NaN)
ACCURACY = {"cooling_rate": 0.003, "temperature_ratio": 0.05, "diffusion": float("nan")}


def load_raw(raw_dir):
    """The HCS series of the runs of a raw folder, in name order.

    Parameters
    ----------
    raw_dir : str
        Folder with ``<run>.npz`` and ``<run>.run.json``.

    Returns
    -------
    list of dict
        :func:`studies.hcs.series` of each run (with ``seed`` where the file name has ``-sN``).
    """
    out = []
    for path in sorted(glob.glob(os.path.join(raw_dir, "*.npz"))):
        with open(path[:-4] + ".run.json") as f:
            rin = json.load(f)
        with np.load(path) as z:
            s = hcs.series({k: z[k] for k in z.files}, rin)
        m = re.search(r"-s(\d+)(-|$)", os.path.basename(path)[:-4])
        out.append(dict(s, seed=int(m.group(1))) if m else s)
    return out


def load_records(results_dir):
    """The HCS series kept in the reduced run records of a results folder, in name order.

    Parameters
    ----------
    results_dir : str
        A study's results folder (its ``runs/*.json``).

    Returns
    -------
    list of dict
        The ``hcs`` part of every record that has one (dissipative runs), with the run's ``seed``.
    """
    out = []
    for path in sorted(glob.glob(os.path.join(results_dir, "runs", "*.json"))):
        with open(path) as f:
            rec = json.load(f)
        if "hcs" in rec:
            out.append(dict(rec["hcs"], seed=rec.get("seed")))
    return out


def smooth_theory(s):
    """Enskog-Sonine zeta0 and Brilliantov-Poeschel D0 of a smooth-sphere run at its T0.

    Parameters
    ----------
    s : mapping
        The run's :func:`studies.hcs.series` (a sphere gas).

    Returns
    -------
    dict
        ``zeta0`` (1/s) and ``d0`` (m^2/s).
    """
    n, e = int(s["n_particles"]), float(s["restitution"])
    t0 = 2.0 * float(s["e_trans"][0]) / (3.0 * n)
    th = hcs.haff_theory(n, float(s["box_length"]), float(s["diameter"]), float(s["mass"]), t0, e)
    nu_d = hcs_theory.velocity_relaxation_rate(e, -1.0, KAPPA_SPHERE, th["omega0"])
    return {"zeta0": th["zeta0"], "d0": hcs_theory.hcs_diffusion(t0, float(s["mass"]), nu_d, th["zeta0"])}


def start_ratio(s):
    """T_rot / T_tr of a run's first frame (0 for a gas started without spin).

    Parameters
    ----------
    s : mapping
        The run's :func:`studies.hcs.series`.

    Returns
    -------
    float
    """
    t_tr, t_rot = hcs.temperatures(np.asarray(s["e_trans"][:1], float), np.asarray(s["e_rot"][:1], float),
                                   int(s["n_particles"]), int(s["rot_dof"]))
    return float(t_rot[0] / t_tr[0])


def bracketed_ratio(below, above, t_lo):
    """The settled HCS ratio r from two runs of one seed that approach it from both sides.

    If T_rot / T_tr relaxes linearly in the number of collisions, r(c) - r = (r(0) - r) E(c) with one
    decay E(c) for both runs, then at every collision count c the value is
    r = (r_a r0_b - r_b r0_a) / (r_a - r_b + r0_b - r0_a) (subscripts: the run from below and from
    above, 0 their starts).  The runs are compared at equal c = int sqrt(T_tr / T_tr(0)) dt, not at
    equal times: the spinning run carries more energy, keeps a higher T_tr and collides faster.  The
    estimate is the mean over the frames of the run from below from ``t_lo`` on, while both runs are
    homogeneous.  That it does not drift
    with ``t_lo`` is the check of the linear relaxation (docs/hcs.md).

    Parameters
    ----------
    below, above : mapping
        :func:`studies.hcs.series` of the two runs (same seed, starts r0_b < r0_a).
    t_lo : float
        Start of the window (s).

    Returns
    -------
    float
    """
    clocks, rs, r0 = [], [], []
    for s in (below, above):
        t = np.asarray(s["t"], float)
        t_tr, t_rot = hcs.temperatures(np.asarray(s["e_trans"], float), np.asarray(s["e_rot"], float),
                                       int(s["n_particles"]), int(s["rot_dof"]))
        end = min(t[-1], hcs.window_end(s))
        keep = t <= end + 1e-12
        # the collision clock: collisions per particle go as sqrt(T_tr), so c = int sqrt(T_tr / T_tr(0)) dt
        g = np.sqrt(t_tr[keep] / t_tr[0])
        c = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(t[keep]))])
        clocks.append((t[keep], c))
        rs.append((t_rot / t_tr)[keep])
        r0.append(float(t_rot[0] / t_tr[0]))
    (tb, cb), (_, ca) = clocks
    rb, ra = rs
    sel = (tb >= t_lo - 1e-12) & (cb <= ca[-1])
    rb_w, ra_w = rb[sel], np.interp(cb[sel], ca, ra)
    den = ra_w - rb_w + r0[0] - r0[1]
    ok = np.abs(den) > 1e-3 * abs(r0[1] - r0[0])
    if ok.sum() < 4:
        raise ValueError(f"the window from {t_lo:g} s holds {int(ok.sum())} usable frames; need >= 4")
    return float(np.mean((ra_w[ok] * r0[0] - rb_w[ok] * r0[1]) / den[ok]))


def _row(observable, e, mu, values, theory, name):
    m, lo, hi, _, _ = t_interval(values)
    return {"observable": observable, "restitution": e, "friction": mu, "measured": m, "ci_low": lo, "ci_high": hi,
            "theory": float(theory), "theory_name": name, "theory_accuracy": ACCURACY[observable]}


def rows(runs, ratio_theory=None, t_transient=0.0):
    """Rows of ``results/hcs_theory.csv`` from analysed sphere runs.

    Parameters
    ----------
    runs : list of dict
        The HCS series of each run (:func:`load_records`, :func:`load_raw`); sphere gases only.
    ratio_theory : callable, optional
        ``ratio_theory(restitution, friction) -> T_rot / T_tr`` of the rough-sphere theory; NaN without it.
    t_transient : float, optional
        Frames before it are left out of the T_rot / T_tr average (s).

    Returns
    -------
    list of dict
        One row per (observable, restitution, friction), columns :data:`COLUMNS`.

    Raises
    ------
    ValueError
        If a run is not a sphere gas.
    """
    groups = {}
    for s in runs:
        if s["builder"] != "sphere":
            raise ValueError("the HCS validation takes sphere gases only")
        key = (float(s["restitution"]), float(s["friction"]))
        groups.setdefault(key, []).append((s, hcs.analyse_series(s, t_transient=t_transient)))
    out = []
    for (e, mu), items in sorted(groups.items()):
        if mu == 0.0:
            th = [smooth_theory(s) for s, _ in items]
            out.append(_row("cooling_rate", e, mu, [a["haff"]["zeta0"] for _, a in items],
                            np.mean([t["zeta0"] for t in th]), "Haff, Enskog-Sonine (van Noije and Ernst 1998)"))
            out.append(_row("diffusion", e, mu, [a["msd"]["d0"] for _, a in items],
                            np.mean([t["d0"] for t in th]), "HCS self-diffusion (Brilliantov and Poeschel 2000)"))
        else:
            by_seed = {}
            for s, _ in items:
                if s.get("seed") is not None:
                    by_seed.setdefault(s["seed"], []).append(s)
            sides = {k: sorted(v, key=start_ratio) for k, v in by_seed.items()}
            both = sorted(k for k, v in sides.items() if start_ratio(v[-1]) - start_ratio(v[0]) > 0.1)
            if both:            # seeds run from both sides: the bracketed estimate
                ratios = [bracketed_ratio(sides[k][0], sides[k][-1], t_transient) for k in both]
            else:
                ratios = [a["ratio"]["ratio"] for _, a in items if a["ratio"] is not None]
            theory = ratio_theory(e, mu) if ratio_theory is not None else float("nan")
            out.append(_row("temperature_ratio", e, mu, ratios, theory,
                            "two-temperature balance of the measured collision rule (Huthmann and Zippelius 1997)"))
    return out


def write(path, rows_):
    """Write ``rows_`` (:func:`rows`) as CSV with the columns :data:`COLUMNS` (``results/hcs_theory.csv``)."""
    write_csv(path, COLUMNS, rows_)


def main(argv=None):
    """``python -m studies hcs-validation [SPEC]``: results/hcs_theory.csv from a sphere study's records.

    Parameters
    ----------
    argv : sequence of str, optional
        The command line's arguments.

    Returns
    -------
    int
        0, or 1 when the study has no cooling-run records yet.
    """
    import argparse

    from . import spec as S
    from .hcs_rule import measured_rule

    ap = argparse.ArgumentParser(prog="python -m studies hcs-validation",
                                 description="The sphere validations of the homogeneous cooling state against kinetic "
                                             "theory, from the committed run records of a sphere study.",
                                 epilog="Writes results/hcs_theory.csv (or --out). The rough spheres' theory is the "
                                        "two-temperature balance of YADE's collision rule, measured from binary "
                                        "collisions of the study's material (studies.hcs_rule).")
    ap.add_argument("spec", nargs="?", default="hcs_spheres", help="the sphere study (default: hcs_spheres)")
    ap.add_argument("--t-transient", type=float, default=10.0, metavar="S",
                    help="frames before it are left out of the T_rot / T_tr average (default: 10 s)")
    ap.add_argument("--out", default=os.path.join(S.ROOT, "results", "hcs_theory.csv"))
    a = ap.parse_args(argv)
    spec = S.load(S.spec_path(a.spec))
    runs = load_records(os.path.join(S.ROOT, spec["study"]["results"]))
    if not runs:
        print(f"[hcs-validation] no cooling-run records in {spec['study']['results']}/runs", file=sys.stderr)
        return 1
    mat = spec["material"]

    def ratio_theory(e, mu):
        radius = 0.5 * next(float(s["diameter"]) for s in runs if float(s["friction"]) == mu)
        rule, _ = measured_rule(e, mu, young=float(mat["youngs_modulus"]), density=float(mat["density"]),
                                poisson=float(mat["poisson"]), radius=radius)
        return hcs_theory.hcs_ratio_for_rule(rule, KAPPA_SPHERE, size=200_000, seed=1)[0]

    out = rows(runs, ratio_theory=ratio_theory, t_transient=a.t_transient)
    write(a.out, out)
    for r in out:
        print(f"[hcs-validation] {r['observable']} e={r['restitution']} mu={r['friction']}: measured "
              f"{r['measured']:.5g} [{r['ci_low']:.5g}, {r['ci_high']:.5g}], theory {r['theory']:.5g} "
              f"({100 * (r['measured'] / r['theory'] - 1):+.2f} %; {r['theory_name']})")
    print(f"[hcs-validation] wrote {a.out}")
    return 0
