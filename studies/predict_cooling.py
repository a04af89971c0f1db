"""Each case's effect on a clump gas's homogeneous cooling state, from YADE binary collisions.

The clumps' route of ``python -m studies predict`` for inelastic or frictional contacts.  The
collision courses are the elastic predictor's (``studies.maps.wide_pairs``: relative speed with the
collision-flux weight at T_tr, impact parameter uniform over the bounding disc, random
orientations), run in YADE with the spec's contact law; only the spins change: they are drawn at
T_rot = r T_tr (the same normal draws at every r and in every case, mapped to the case's inertia as
``studies.maps.case_input`` maps them, so every comparison is paired collision by collision).

Per collision the pair's translational and rotational energy change, in units of the case's
temperature T_tr, and x q (x = mu g^2 / 2 T_tr, q = 1 - g'.g / g^2, the momentum transfer).  For
contact laws that are linear in the velocities the means are linear in r,

    <dE_tr> / T_tr = a1 + a2 r,      <dE_rot> / T_tr = b1 + b2 r,

only nearly: the spins change which courses touch, and Coulomb friction and the Hertz contact are
not linear.  The means are therefore measured at three ratios ``RATIOS`` and interpolated by the
parabola through them; the two-temperature balance of ``studies.predict_hcs``

    F(r) = <dE_rot> / (f_rot r) - <dE_tr> / 3 = 0       (d ln T_rot / dt = d ln T_tr / dt)

gives the HCS ratio r*.  A fourth run at r* checks the interpolation: ``root_check`` is the shift
of the root it implies, -F(r*) / (r* F'(r*)), relative to r*.  With nu = n A <g> the collision
frequency (A the bounding disc's area, the same for every case; <g> the same in the paired protocol,
where T_tr / m is the same in every case):

* cooling rate zeta / nu = -<dE_tr + dE_rot>(r*) / (3 + f_rot r*) (the total energy's loss: at the
  root it equals the translational and the rotational rate, and it is the least noisy of the three);
* velocity relaxation nu_v / nu = <x q>(r*) / 3;
* HCS self-diffusion D0 = (T_tr / m) / (nu_v - zeta / 2) (Brilliantov and Poeschel 2000).

Each case's relative effect against exact follows, with a standard error from a bootstrap over the
collisions (resampled together in every case and at every r).  Units SI; temperatures in joules.
"""
from __future__ import annotations

import math

import numpy as np

from . import maps
from .timestep import collisions as tc

__all__ = ["NoBalance", "RATIOS", "spun", "balance_root", "at", "collision_means", "cooling_predictions"]

class NoBalance(ValueError):
    """The two-temperature balance has no root in the ratios the route covers."""


#: T_rot / T_tr of the three runs that give the parabolas; the HCS ratio must lie in [0.5 RATIOS[0], 1.5 RATIOS[-1]]
RATIOS = (0.4, 0.8, 1.2)
OBSERVABLES = ("cooling_rate", "temperature_ratio", "diffusion")


def spun(base, r):
    """The collision courses ``base`` with every spin scaled to T_rot = ``r`` T_tr.

    Parameters
    ----------
    base : dict
        Collision courses at equipartition (``studies.maps.wide_pairs``).
    r : float
        T_rot / T_tr (> 0).

    Returns
    -------
    dict
        A copy with the angular velocities times sqrt(r).
    """
    out = dict(base)
    out["angvel"] = (np.asarray(base["angvel"]) * math.sqrt(r)).tolist()
    return out


def _parabola(r, v):
    """Coefficients (c0, c1, c2) of the parabola through (r[k], v[k]), k = 0..2; ``v`` (3, ...)."""
    r0, r1, r2 = r
    v0, v1, v2 = v
    d01, d12 = (v1 - v0) / (r1 - r0), (v2 - v1) / (r2 - r1)
    c2 = (d12 - d01) / (r2 - r0)
    c1 = d01 - c2 * (r0 + r1)
    return v0 - c1 * r0 - c2 * r0 * r0, c1, c2


def balance_root(tr, rot, f_rot, ratios=RATIOS):
    """The HCS ratio r* where F(r) = <dE_rot>(r) / (f_rot r) - <dE_tr>(r) / 3 = 0, the means
    interpolated by the parabolas through their values at ``ratios``.

    Parameters
    ----------
    tr, rot : array_like, shape (3, ...)
        <dE_tr> / T_tr and <dE_rot> / T_tr at each ratio (trailing axes: one root each, e.g.
        bootstrap replicates).
    f_rot : int
        Rotational degrees of freedom.
    ratios : sequence of 3 float
        The ratios of the rows.

    Returns
    -------
    float or numpy.ndarray
        r* (the first sign change of F on a fine grid over [ratios[0] / 2, 1.5 ratios[-1]], refined
        linearly); NaN where F does not change sign there.
    """
    ct, cr = _parabola(ratios, np.asarray(tr, float)), _parabola(ratios, np.asarray(rot, float))
    gv = np.linspace(0.5 * ratios[0], 1.5 * ratios[-1], 801)
    grid = gv.reshape((-1,) + (1,) * np.ndim(ct[0]))
    F = (cr[0] + cr[1] * grid + cr[2] * grid ** 2) / (f_rot * grid) - (ct[0] + ct[1] * grid + ct[2] * grid ** 2) / 3.0
    sign = np.signbit(F)
    change = sign[1:] != sign[:-1]
    k = np.argmax(change, axis=0)
    found = np.any(change, axis=0)
    f0, f1 = np.take_along_axis(F, k[None], 0)[0], np.take_along_axis(F, k[None] + 1, 0)[0]
    g0, g1 = gv[k], gv[k + 1]
    root = np.where(found, g0 - f0 * (g1 - g0) / np.where(f1 != f0, f1 - f0, 1.0), np.nan)
    return float(root) if np.ndim(root) == 0 else root


def at(values, r, ratios=RATIOS):
    """The parabola through ``values`` (3, ...) at ``ratios``, evaluated at ``r``."""
    c0, c1, c2 = _parabola(ratios, np.asarray(values, float))
    return c0 + c1 * r + c2 * r * r


def collision_means(inp, out, x):
    """Per-collision values of one YADE run: dE_tr / T_tr, dE_rot / T_tr and x q.

    Parameters
    ----------
    inp : dict
        The run's input (its ``kT`` is the case's T_tr).
    out : dict
        ``studies.timestep.collisions.run_map``'s output.
    x : numpy.ndarray
        gamma^2 = mu g^2 / 2 T_tr of each course.

    Returns
    -------
    dict
        ``tr``, ``rot``, ``xq`` (arrays over the courses) and ``apart`` (bool array).
    """
    o = tc.outcome(inp, out)
    d_total = o["de_rel"] * o["e_pair"]
    kT = float(inp["kT"])
    return {"tr": o["dk_tr"] / kT, "rot": (d_total - o["dk_tr"]) / kT, "xq": x * o["q"], "apart": o["apart"]}


def _estimates(c, idx, f_rot):
    """r*, zeta / nu and (nu_v - zeta / 2) / nu of one case from its runs at RATIOS, on collisions ``idx``
    (arrays of indices: one row per bootstrap replicate)."""
    m = {k: np.array([c[r][k][idx].mean(axis=-1) for r in RATIOS]) for k in ("tr", "rot", "xq")}
    rs = balance_root(m["tr"], m["rot"], f_rot)
    zeta = -(at(m["tr"], rs) + at(m["rot"], rs)) / (3.0 + f_rot * rs)
    return rs, zeta, at(m["xq"], rs) / 3.0 - zeta / 2.0


def cooling_predictions(shape, cases, pairs, seed, factor, workdir, tag, yade, n_boot=400):
    """Each case's relative effect on zeta, T_rot / T_tr and D0 of the HCS (see the module docstring).

    Parameters
    ----------
    shape : dict
        A shape of a spec.
    cases : list of str
        Cases to predict against exact (paired protocol).
    pairs : int
        Collision courses drawn.
    seed : int
        Seed of the draws.
    factor : float
        Time-step factor on the smallest member's P-wave step.
    workdir : str
        Folder of the YADE runs' files (a repeated call reuses identical runs).
    tag : str
        Prefix of the run files.
    yade : str
        The YADE the runs need ("2023.02a" or "2025.2").
    n_boot : int, optional
        Bootstrap replicates of the standard errors.

    Returns
    -------
    list of dict
        Per case and observable: case, protocol ("paired"), observable, predicted, predicted_se,
        cpu_s (the case's runs plus an equal share of exact's, split over the observables),
        pairs_used; and ``ratio_exact`` / ``ratio_case`` (r*), ``ratio_exact_se`` and ``root_check`` (the larger of the
        two cases' relative root shifts at r*).
    """
    base = maps.wide_pairs(shape, pairs, seed)
    f_rot = int(base["rot_dof"])
    x = np.asarray(base["g"]) ** 2 * (base["body"]["mass"] / 2) / (2 * base["kT"])
    vals, cpu, inputs = {}, {}, {}
    every = ["exact"] + list(cases)

    def run(case, r, label):
        inp, _ = maps.case_input(spun(base, r), shape, case, "paired") if case != "exact" else (spun(base, r), 1.0)
        out = tc.run_map(inp, factor, yade, workdir, f"{tag}-{case}-{label}")
        cpu[case] = cpu.get(case, 0.0) + float(out.get("cpu_s", 0.0))
        print(f"[predict] {tag} {case} T_rot/T_tr = {r:.4g}: {int(np.sum(out['touched']))} of {pairs} collided, "
              f"cpu {float(out.get('cpu_s', 0.0)):.0f} s{' (reused)' if out.get('reused') else ''}", flush=True)
        return collision_means(inp, out, x)

    for case in every:
        vals[case] = {r: run(case, r, f"r{r:g}") for r in RATIOS}
    ok = np.logical_and.reduce([v["apart"] for c in every for v in vals[c].values()])
    idx_all = np.flatnonzero(ok)
    est = {c: _estimates(vals[c], idx_all, f_rot) for c in every}
    # the check: each case run at its own r*; the root shift its balance residual implies
    lin = {}
    for c in every:
        rs = est[c][0]
        if not math.isfinite(rs):
            raise NoBalance(f"{tag}: case {c}: the balance has no root for T_rot/T_tr in "
                               f"[{0.5 * RATIOS[0]:g}, {1.5 * RATIOS[-1]:g}] (more --pairs, or a contact law far from these gases')")
        chk = run(c, rs, f"rstar{rs:.6f}")
        ok_c = idx_all[chk["apart"][idx_all]]
        m = {k: np.array([vals[c][r][k][idx_all].mean() for r in RATIOS]) for k in ("tr", "rot")}
        h = 1e-4 * rs
        F = lambda r: at(m["rot"], r) / (f_rot * r) - at(m["tr"], r) / 3.0          # noqa: E731
        slope = (F(rs + h) - F(rs - h)) / (2 * h)
        resid = chk["rot"][ok_c].mean() / (f_rot * rs) - chk["tr"][ok_c].mean() / 3.0
        lin[c] = float(-resid / (rs * slope))
    rng = np.random.default_rng(seed)
    boot = idx_all[rng.integers(0, len(idx_all), (n_boot, len(idx_all)))]
    bt = {c: _estimates(vals[c], boot, f_rot) for c in every}

    def rel(c, k):
        if k == "diffusion":            # D0 is proportional to 1 / ((nu_v - zeta / 2) / nu)
            return est["exact"][2] / est[c][2] - 1.0, bt["exact"][2] / bt[c][2] - 1.0
        j = {"temperature_ratio": 0, "cooling_rate": 1}[k]
        return est[c][j] / est["exact"][j] - 1.0, bt[c][j] / bt["exact"][j] - 1.0

    rows = []
    for c in cases:
        for k in OBSERVABLES:
            p, b = rel(c, k)
            rows.append({"case": c, "protocol": "paired", "observable": k, "predicted": float(p),
                         "predicted_se": float(np.nanstd(b, ddof=1)),
                         "cpu_s": (cpu[c] + cpu["exact"] / len(cases)) / len(OBSERVABLES),
                         "pairs_used": int(ok.sum()), "ratio_exact": est["exact"][0], "ratio_case": est[c][0],
                         "ratio_exact_se": float(np.nanstd(bt["exact"][0], ddof=1)),
                         "root_check": max(abs(lin[c]), abs(lin["exact"]))})
    return rows
