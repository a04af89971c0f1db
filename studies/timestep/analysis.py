"""The tables of one shape's collision map (errors against the finest factor, the D prediction, the
energy drift a gas would show) and the phase-stratified energy bias per collision."""
from __future__ import annotations

import math

import numpy as np

from .. import shapes as shp
from .collisions import ENERGY, MATERIAL, SHAPES, make_pairs, outcome, p_wave_dt_of_body, paired_rel, run_map

# the gases whose energy drift the map predicts: name: (particles, volume fraction, run length s)
GASES = {"test gas (125, phi 0.01, 40 s)": (125, 0.01, 40.0),
         "paper (864, phi 0.001, 400 s)": (864, 0.001, 400.0),
         "dimer_paired (864, phi 0.001, 1000 s)": (864, 0.001, 1000.0)}


def analyse_map(inp, runs, factors, kT, rot_dof, shape):
    """Tables of one shape: per factor, errors against the finest factor and the D prediction.

    Parameters
    ----------
    inp : dict
        The collision courses (``collisions.make_pairs``).
    runs : dict
        factor -> the output of ``collisions.run_map`` at that factor.
    factors : list of float
        The dt factors run; the finest is the reference.
    kT : float
        Temperature of the drawn gas, J.
    rot_dof : int
        Rotational degrees of freedom of the body.
    shape : dict
        The shape definition (``studies.shapes``).

    Returns
    -------
    dict
        ``rows`` (one per factor, ascending) and the map's reference values.
    """
    res = {f: outcome(inp, runs[f]) for f in factors}
    ref = res[min(factors)]
    ok = np.ones(len(ref["q"]), bool)
    for f in factors:
        ok &= res[f]["apart"]
    touched = ref["touched"] | np.zeros_like(ref["touched"])
    for f in factors:
        touched |= res[f]["touched"]
    g2 = ref["g2"]
    slope, slope_se = _restoring_slope(inp, ref, ok, kT, rot_dof)
    rows = [_factor_row(f, runs[f], res[f], ref, ok, touched, g2, slope) for f in sorted(factors)]
    # collision rate per particle at volume fraction phi: n <g sigma(g)> = n pi (2 r_b)^2 <g> x the
    # (flux-weighted) fraction of the sampled courses that touch
    m = inp["body"]["mass"]
    props = shp.properties(shape, MATERIAL["density"])
    mean_g = math.sqrt(8 * kT / (math.pi * m / 2))
    f_touch = float(touched[ok].mean())
    rate_per_phi = (1.0 / props["exact"]["volume"]) * math.pi * (2 * inp["bounding_radius"]) ** 2 * mean_g * f_touch
    for r in rows:
        r["gas_drift_pred"] = _gas_drift_predictions(res[r["factor"]], ok, rate_per_phi)
    _observed_orders(rows)
    return {"rows": rows, "relax_slope": slope, "collision_rate_per_phi": rate_per_phi,
            "mean_free_time_paper": 1.0 / (rate_per_phi * 0.001), "touched_fraction": f_touch, "relax_slope_se": slope_se,
            "relax_slope_rel": slope / float(np.mean(ref["etr0"][ok])),
            "n_pairs": len(ref["q"]), "n_touched": int(touched.sum()), "n_not_apart": int((~ok).sum()),
            "one_minus_cos_ref": float(np.mean(ref["one_minus_cos"][ok])),
            "omega_ref": float(np.mean(g2[ok] * ref["q"][ok]) / np.mean(g2[ok])),
            "de_mean_ref": float(ref["de_rel"][touched & ok].mean())}


def _restoring_slope(inp, ref, ok, kT, rot_dof):
    """Restoring rate of the translational/rotational energy split, by reweighting the collisions:
    d<dK_tr>/d eps at fixed total energy, eps = relative excess of the translational temperature
    (its value and standard error, J)."""
    gamma2 = 0.5 * (inp["body"]["mass"] / 2) * ref["g2"] / kT                  # mu g^2 / 2kT
    score = (gamma2 - 2.0) - (3.0 / rot_dof) * (ref["erot0"] / kT - rot_dof)
    dk_ref = ref["dk_tr"][ok]
    slope = float(np.mean(dk_ref * score[ok]))
    slope_se = float(np.std(dk_ref * score[ok], ddof=1) / math.sqrt(ok.sum()))
    return slope, slope_se


def _factor_row(f, run, r, ref, ok, touched, g2, slope):
    """One factor's row: its errors against the reference ``ref`` (the finest factor's outcome) over
    the collisions that finished at every factor (``ok``) and touched, and the predicted D error."""
    t = ok & touched
    dp_err = np.linalg.norm(r["dp"] - ref["dp"], axis=1)[t]
    dp_ref = np.linalg.norm(ref["dp"], axis=1)[t]
    dl_err = np.linalg.norm(r["dL"] - ref["dL"], axis=2).sum(1)[t]
    dl_ref = np.linalg.norm(ref["dL"], axis=2).sum(1)[t]
    rel = dp_err / np.maximum(dp_ref, 1e-300)
    om, om_se = paired_rel(r["q"][ok], ref["q"][ok], g2[ok])
    cm, cm_se = paired_rel(r["one_minus_cos"][ok], ref["one_minus_cos"][ok])
    qm, qm_se = paired_rel(r["q"][ok], ref["q"][ok])
    # translational energy bias per collision relative to the finest factor, and the shift of the
    # translational temperature it causes in the gas: delta <dK_tr> + slope * eps = 0
    ddk = (r["dk_tr"] - ref["dk_tr"])[ok]
    bias = float(ddk.mean())
    bias_se = float(ddk.std(ddof=1) / math.sqrt(ok.sum()))
    eps = -bias / slope if slope < 0 else float("nan")
    eps_se = abs(bias_se / slope) if slope < 0 else float("nan")
    d_rel = -om + 0.5 * eps
    d_se = math.sqrt(om_se ** 2 + (0.5 * eps_se) ** 2)
    return {
        "factor": f, "dt": run["dt"], "steps": run["n_steps"], "cpu_s": run["cpu_s"],
        "wall_s": run["wall_s"], "yade_version": run["yade_version"],
        "rot_algorithm": run["rot_algorithm"],
        "n_collisions": int(t.sum()), "n_pairs_used": int(ok.sum()),
        "dp_err_agg": float(dp_err.sum() / dp_ref.sum()),
        "dp_err_median": float(np.median(rel)), "dp_err_p90": float(np.percentile(rel, 90)),
        "dp_err_rms": float(np.sqrt(np.mean(rel ** 2))),
        "dL_err_agg": float(dl_err.sum() / dl_ref.sum()) if dl_ref.sum() > 0 else 0.0,
        "de_mean": float(r["de_rel"][t].mean()), "de_rms": float(np.sqrt(np.mean(r["de_rel"][t] ** 2))),
        "de_absmax": float(np.max(np.abs(r["de_rel"][t]))),
        "de_mean_se": float(r["de_rel"][t].std(ddof=1) / math.sqrt(t.sum())),
        "ang_total_rel_max": float(np.max(r["ang_total_drift"][t])),
        "omega_rel": om, "omega_rel_se": om_se,
        "one_minus_cos_rel": cm, "one_minus_cos_rel_se": cm_se,
        "q_rel": qm, "q_rel_se": qm_se,
        "omega": float(np.mean(g2[ok] * r["q"][ok]) / np.mean(g2[ok])),
        "one_minus_cos": float(np.mean(r["one_minus_cos"][ok])),
        "dk_tr_bias_rel": bias / float(np.mean(ref["etr0"][ok])), "dk_tr_bias_rel_se": bias_se / float(np.mean(ref["etr0"][ok])),
        "t_tr_shift": eps, "t_tr_shift_se": eps_se,
        "D_rel_pred": d_rel, "D_rel_pred_se": d_se,
    }


def _gas_drift_predictions(r, ok, rate_per_phi):
    """Energy drift of each of :data:`GASES` predicted from one factor's per-collision energy errors: a
    random walk of N nu t / 2 collisions (sd) plus their mean (bias), relative to the gas's energy N e."""
    dE = (r["de_rel"] * r["e_pair"])[ok]
    out = {}
    for name, (N, phi, t) in GASES.items():
        ev = N * rate_per_phi * phi * t / 2
        etot = N * ENERGY
        out[name] = {
            "collisions_per_particle": 2 * ev / N,
            "sd": math.sqrt(ev * np.mean(dE ** 2)) / etot,
            "bias": ev * float(np.mean(dE)) / etot,
            "bias_se": ev * float(np.std(dE, ddof=1) / math.sqrt(len(dE))) / etot}
    return out


def _observed_orders(rows):
    """Observed orders of convergence between successive factors, added to the rows (errors against
    the finest, so the last pair is biased)."""
    for i in range(1, len(rows) - 1):
        a, b = rows[i], rows[i + 1]
        for k in ("dp_err_agg", "dL_err_agg", "de_rms"):
            if a[k] > 0 and b[k] > 0:
                b[f"order_{k}"] = math.log(b[k] / a[k]) / math.log(b["factor"] / a["factor"])


def _rodrigues(w, t):
    """Rotation matrices (n, 3, 3) of angle |w| t about w (n, 3)."""
    th = np.linalg.norm(w, axis=1) * t
    k = w / np.maximum(np.linalg.norm(w, axis=1), 1e-300)[:, None]
    K = np.zeros((len(w), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    K -= K.transpose(0, 2, 1)
    return np.eye(3) + np.sin(th)[:, None, None] * K + (1 - np.cos(th))[:, None, None] * (K @ K)


def energy_bias(key, n_geom, phases, factors, seed, workdir):
    """Mean energy error per collision with the contact phase stratified: each of ``n_geom``
    collision geometries is run ``phases`` times, started k/phases of a time step earlier
    (k = 0..phases-1; free flight back in time is exact for the isotropic route), so the mean over
    a geometry's copies is its average over the phase of the step at contact, which removes the
    phase noise that dominates the spread of single collisions.  Isotropic route only."""
    cfg = SHAPES[key]
    inp = make_pairs(cfg["shape"], n_geom, seed + 1000)
    if inp["body"]["route"] != "isotropic":
        raise ValueError("phase-stratified energy bias: isotropic route only")
    out = {}
    for f in factors:
        dt = f * p_wave_dt_of_body(inp)
        pos = np.asarray(inp["pos"])
        vel = np.asarray(inp["vel"])
        ori = np.asarray(inp["ori"]).reshape(-1, 3, 3)
        w = np.asarray(inp["angvel"])
        n2 = len(pos)
        lat = np.asarray(inp["lattice"])
        k3 = int(math.ceil((n_geom * phases) ** (1 / 3)))
        grid = np.stack(np.unravel_index(np.arange(n_geom * phases), (k3, k3, k3)), 1) * inp["spacing"]
        P, V, Rm, W = [], [], [], []
        for k in range(phases):
            tau = k / phases * dt
            P.append(pos - vel * tau - np.repeat(lat, 2, axis=0))
            V.append(vel)
            Rm.append(_rodrigues(w, -tau) @ ori)
            W.append(w)
        idx = np.arange(n2)
        big = {"pos": [], "vel": [], "ori": [], "angvel": []}
        for j in range(n_geom * phases):
            k, g = divmod(j, n_geom)
            sl = idx[2 * g:2 * g + 2]
            big["pos"].append(P[k][sl] + grid[j])
            big["vel"].append(V[k][sl])
            big["ori"].append(Rm[k][sl].reshape(2, 9))
            big["angvel"].append(W[k][sl])
        d = dict(inp, **{k: np.concatenate(v).tolist() for k, v in big.items()})
        d["lattice"] = grid.tolist()
        r = run_map(d, f, cfg["yade"], workdir, f"{key}-bias{phases}")
        o = outcome(d, r)
        dE = (o["de_rel"] * o["e_pair"]).reshape(phases, n_geom)     # J, [phase, geometry]
        per_geom = dE.mean(0)
        e_mean = float(o["e_pair"].mean())
        out[f] = {"factor": f, "n_geometries": n_geom, "phases": phases, "cpu_s": r["cpu_s"],
                  "touched": int(o["touched"].sum()), "all_apart": bool(o["apart"].all()),
                  "mean_rel": float(dE.mean() / e_mean),
                  "mean_rel_se_stratified": float(per_geom.std(ddof=1) / math.sqrt(n_geom) / e_mean),
                  "single_rms_rel": float(np.sqrt(np.mean(dE ** 2)) / e_mean),
                  "phase_averaged_rms_rel": float(np.sqrt(np.mean(per_geom ** 2)) / e_mean)}
        print(f"[bias] {key} f={f:g}: mean energy error per collision {out[f]['mean_rel']:+.2e} ± "
              f"{out[f]['mean_rel_se_stratified']:.1e} of the mean pair energy ({n_geom} geometries x {phases} "
              f"phases; rms single {out[f]['single_rms_rel']:.1e}, phase-averaged {out[f]['phase_averaged_rms_rel']:.1e}; "
              f"cpu {r['cpu_s']:.0f} s)", flush=True)
    return out
