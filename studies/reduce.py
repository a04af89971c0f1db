"""One run's recorded frames -> a small reduced record (committed under ``results/``).

The reduced record holds what every analysis needs, so the raw trajectory (tens of MB) can be
deleted: the run's checks (energy and momentum drift, finiteness), the energy partition every
second, and for each analysis window [t_cut, t_end] the particle-averaged MSD on a log-spaced lag
grid and the velocity autocorrelation (VACF, :func:`studies.correlation.vacf_fft`) on the frame
grid up to ``max_lag``, overall and for 8 disjoint particle groups (contiguous index blocks,
:func:`studies.correlation.group_labels`; for per-run jackknife standard errors).  Pure numpy; no YADE, no driver.
"""
from __future__ import annotations

import json
import os

import numpy as np

from .correlation import msd_fft, vacf_fft

REDUCTION_VERSION = 1
N_GROUPS = 8
ENERGY_STRIDE_S = 1.0


def _r(a):
    """A list of floats rounded to 7 significant digits (float32 precision; small JSON)."""
    return [float(f"{x:.7g}") for x in np.asarray(a, float).ravel()]


def _even_frames(t):
    """Frames on the even grid: frame 0 is t = 0, frames k >= 1 are at (k n_rec + 1) dt."""
    keep = np.ones(len(t), bool)
    if len(t) > 2 and abs((t[1] - t[0]) - (t[2] - t[1])) > 1e-9:
        keep[0] = False
    return keep


def checks(frames, n_particles, mass, energy_tol, momentum_tol, speed0_sum=None):
    """Energy drift max|E - E0|/E0, momentum drift (relative to m sum|v0|), and pass/fail reasons.
    A dissipative run's frames hold ``e_dissipated``: E then counts it, so the check is the balance."""
    e = frames["e_trans"] + frames["e_rot"] + frames["e_elastic"] + frames.get("e_dissipated", 0.0)
    e_drift = float(np.max(np.abs(e - e[0])) / e[0])
    if speed0_sum is None:
        speed0_sum = float(np.sum(np.linalg.norm(frames["vel"][0].astype(float), axis=1)))
    p_scale = mass * speed0_sum
    p = frames["momentum"]
    p_drift = float(np.max(np.linalg.norm(p - p[0], axis=1)) / p_scale)
    reasons = []
    finite = all(np.all(np.isfinite(frames[k])) for k in ("disp", "vel", "e_trans", "e_rot", "e_elastic"))
    if not finite or not np.isfinite(e_drift):
        reasons.append("non-finite state")
    if not e_drift <= energy_tol:
        reasons.append(f"energy drift {e_drift:.3g} > {energy_tol:g}")
    if not p_drift <= momentum_tol:
        reasons.append(f"momentum drift {p_drift:.3g} > {momentum_tol:g}")
    return {"energy_drift": e_drift, "momentum_drift": p_drift, "ok": not reasons, "fail_reasons": reasons,
            "e_total_initial": float(e[0])}


def window(frames, t_cut, max_lag_s, n_groups=N_GROUPS, n_msd=160):
    """MSD and VACF of the frames with t >= t_cut (evenly spaced frames only)."""
    t = frames["t"]
    keep = _even_frames(t) & (t >= t_cut - 1e-9)
    tt = t[keep]
    if len(tt) < 4:
        raise ValueError(f"analysis window from t_cut = {t_cut} s has {len(tt)} frames")
    dt_f = float(np.median(np.diff(tt)))
    msd = msd_fft(frames["disp"][keep])
    lag = tt - tt[0]
    n_half = len(lag) // 2 + 1                # lags up to half the window are well averaged
    idx = np.unique(np.concatenate([[0], np.round(np.geomspace(1, n_half - 1, n_msd)).astype(int)]))
    n_lag = min(int(round(max_lag_s / dt_f)), len(tt) - 2)
    vacf, vg = vacf_fft(frames["vel"][keep], n_lag, groups=n_groups)
    return {"t_cut": float(t_cut), "t_start": float(tt[0]), "t_end": float(tt[-1]), "n_frames": int(len(tt)),
            "frame_interval": dt_f,
            "msd_lag_s": _r(lag[idx]), "msd": _r(msd[idx]),
            "vacf_lag_s": (np.arange(n_lag + 1) * dt_f).tolist(),
            "vacf": _r(vacf),
            "vacf_groups": [_r(g) for g in vg]}


def energy_series(frames, stride_s=ENERGY_STRIDE_S):
    """The energy partition (t, translational, rotational, elastic) about every ``stride_s`` seconds."""
    t = frames["t"]
    dt_f = t[2] - t[1] if len(t) > 2 else 1.0
    stride = max(1, int(round(stride_s / dt_f)))
    sl = slice(0, None, stride)
    return {k: [float(f"{x:.10g}") for x in frames[k][sl]] for k in ("t", "e_trans", "e_rot", "e_elastic")}


def reduce_run(frames, run_input, cuts, max_lag_s, energy_tol, momentum_tol):
    """The reduced record of one run: ``frames`` is the YADE script's npz (dict-like),
    ``run_input`` the run file, ``cuts`` the analysis windows' start times (s)."""
    fr = {k: np.asarray(frames[k]) for k in ("t", "disp", "vel", "e_trans", "e_rot", "e_elastic", "momentum")
          + (("e_dissipated",) if "e_dissipated" in frames else ())}
    v0 = np.asarray(run_input["initial"]["vel"], float)
    out = {"reduction_version": REDUCTION_VERSION,
           "checks": checks(fr, len(v0), run_input["body"]["mass"], energy_tol, momentum_tol,
                            float(np.sum(np.linalg.norm(v0, axis=1)))),
           "energy": energy_series(fr), "windows": []}
    if "e_dissipated" in fr:       # a cooling run: the HCS series its analysis needs (studies.hcs)
        out["hcs"] = hcs_part(frames, run_input)
    t = fr["t"]
    for c in sorted(set(float(x) for x in cuts)):
        if np.sum(_even_frames(t) & (t >= c - 1e-9)) >= 4:        # shorter windows are not stored
            out["windows"].append(window(fr, c, max_lag_s))
    return out


def hcs_part(frames, run_input):
    """The ``hcs`` part of a cooling run's record: :func:`studies.hcs.series`, arrays as lists of
    10-digit floats."""
    from .hcs import series
    hcs = series(frames, run_input)
    return {k: ([float(f"{x:.10g}") for x in v] if isinstance(v, np.ndarray) else v) for k, v in hcs.items()}


def refresh_hcs(rec, frames, run_input):
    """A copy of a cooling run's record whose ``hcs`` part is the current reduction's, from the run's
    kept raw frames (``--keep-raw``): a later series (the multi-origin MSD grid) for runs reduced
    before it existed.  Everything else is kept as it was.

    Parameters
    ----------
    rec : dict
        The run's reduced record (with an ``hcs`` part).
    frames : mapping
        The run's raw frames (its npz).
    run_input : dict
        The run file.

    Returns
    -------
    dict
    """
    if "hcs" not in rec:
        raise ValueError(f"{rec.get('name', 'the record')} is not a cooling run (no hcs part)")
    t_rec, t_raw = np.asarray(rec["hcs"]["t"], float), np.asarray(frames["t"], float)
    if t_rec.shape != t_raw.shape or not np.allclose(t_rec, t_raw, rtol=1e-9, atol=0.0):
        raise ValueError(f"{rec.get('name', 'the record')}: the raw frames' times are not the record's")
    return {**rec, "hcs": hcs_part(frames, run_input)}


def _read(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def is_complete(path, key, needs=None):
    """True if ``path`` is a finished reduced record of run ``key`` (and, with ``needs`` = (cuts,
    max_lag), one that :func:`serves` that analysis)."""
    rec = _read(path)
    ok = isinstance(rec, dict) and rec.get("key") == key and rec.get("reduction_version") == REDUCTION_VERSION
    return ok and (needs is None or serves(rec, *needs))


def _missing_windows(rec, cuts, max_lag):
    """The cuts (s) of ``cuts`` whose window the record lacks or holds with VACF lags short of
    ``max_lag`` (as far as the window reaches)."""
    have = {round(w["t_cut"], 9): w for w in rec.get("windows", [])}
    out = []
    for c in cuts:
        w = have.get(round(float(c), 9))
        if w is None:
            out.append(float(c))
            continue
        reach = min(max_lag, (w["n_frames"] - 2) * w["frame_interval"])
        if w["vacf_lag_s"][-1] < reach - 0.5 * w["frame_interval"]:
            out.append(float(c))
    return out


def serves(rec, cuts, max_lag):
    """True if the record stores a window from every cut (s) of ``cuts``, each with VACF lags up to
    ``max_lag`` (s) or as far as the window reaches: what an analysis with those settings reads."""
    return not _missing_windows(rec, cuts, max_lag)


def why_not_served(path, needs):
    """One line: which windows the record at ``path`` lacks for ``needs`` = (cuts, max_lag)."""
    rec = _read(path) or {}
    stored = [w["t_cut"] for w in rec.get("windows", [])]
    return (f"the analysis reads windows from t = {_missing_windows(rec, *needs)} s with lags to {needs[1]:g} s; "
            f"the record stores windows from {stored} s")


def stored_windows(path):
    """(cuts, max_lag) a finished record at ``path`` stores, or ([], 0.0)."""
    rec = _read(path) or {}
    ws = rec.get("windows", [])
    return [w["t_cut"] for w in ws], max([w["vacf_lag_s"][-1] for w in ws] or [0.0])


def record_path(results_dir, run):
    """Where run ``run``'s reduced record lives under a study's results directory."""
    return os.path.join(results_dir, "runs", run["name"] + ".json")
