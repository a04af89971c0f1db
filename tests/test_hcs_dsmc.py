"""The DSMC rough-sphere gas (studies.hcs_dsmc) against kinetic theory, and the cooling estimators
on it (studies.hcs_estimator, studies.hcs.haff_amplitude)."""
import math

import numpy as np
import pytest

from studies import hcs, hcs_dsmc as D, hcs_effects, hcs_estimator as E, hcs_theory as T


def test_elastic_collisions_conserve_energy_and_momentum_and_the_collision_frequency_is_one():
    state = D.initial_state(2000, 1)
    s = D.simulate(state, T.constant_beta_rule(1.0, 1.0), 0.4, t_end=4.0, seed=1)
    e = np.asarray(s["e_trans"]) + np.asarray(s["e_rot"])
    assert np.max(np.abs(e / e[0] - 1)) < 1e-12 and max(np.abs(s["e_dissipated"])) < 1e-9 * e[0]
    nu = 2 * s["n_collisions"] / (2000 * s["t"][-1])
    # 4 n sigma^2 sqrt(pi T / m) = 1 at the start; Poisson error of ~4000 collisions: 1.6 %
    assert nu == pytest.approx(1.0, abs=0.045)
    assert s["e_trans"][0] == pytest.approx(1.5 * 2000, rel=1e-12)           # T_tr = 1 per particle


def test_smooth_spheres_cool_at_haffs_rate_and_keep_their_spin():
    """Smooth inelastic spheres: zeta from Haff's fit against the Sonine-corrected theory (the DSMC
    solves the Boltzmann equation, whose HCS rate the second Sonine correction gives to ~0.1 %)."""
    s = D.simulate(D.initial_state(4000, 2), T.constant_beta_rule(0.9, -1.0), 0.4, t_end=1e3, cooling_stop=16,
                   seed=2)
    t_tr, t_rot = hcs.temperatures(s["e_trans"], s["e_rot"], 4000, 3)
    h = hcs.fit_haff(s["t"], t_tr)
    assert h["zeta0"] / h["t0"] ** 0.5 == pytest.approx(T.haff_cooling_rate(0.9, 1.0), rel=0.015)
    assert np.ptp(t_rot) == pytest.approx(0.0, abs=1e-12)                    # beta = -1: no torque
    # the energy the collisions took out is what the gas lost
    assert s["e_dissipated"][-1] == pytest.approx(s["e_trans"][0] - s["e_trans"][-1], rel=1e-9)


def test_rough_spheres_settle_at_the_huthmann_zippelius_ratio():
    """beta = 0, kappa = 0.4: T_rot / T_tr of the DSMC against the Maxwellian two-temperature theory,
    whose accuracy for these values is about 1 % (the DSMC's own noise here ~0.5 %)."""
    s = D.simulate(D.initial_state(4000, 4), T.constant_beta_rule(0.9, 0.0), 0.4, t_end=1e3, cooling_stop=30, seed=4)
    t_tr, t_rot = hcs.temperatures(s["e_trans"], s["e_rot"], 4000, 3)
    r = (t_rot / t_tr)[len(t_tr) // 2:]
    assert r.mean() == pytest.approx(T.hcs_temperature_ratio(0.9, 0.0, 0.4), rel=0.03)


def test_the_mean_square_displacement_gives_the_boltzmann_self_diffusion():
    """Elastic smooth spheres: D from the MSD against Chapman-Enskog's first approximation
    3 / (8 n sigma^2) sqrt(T / (pi m)), which the exact Boltzmann value exceeds by ~1.6 %, less the
    whole-step flights' -p (2/3) / 2 = -2.8 % (module docstring)."""
    s = D.simulate(D.initial_state(4000, 3), T.constant_beta_rule(1.0, -1.0), 0.4, t_end=60.0, seed=3)
    t, msd = np.asarray(s["t"]), np.asarray(s["msd"])
    sel = t > 15
    d = np.polyfit(t[sel], msd[sel], 1)[0] / 6
    p = 1 / (D.W_SIGMAS * math.sqrt(2 * math.pi))
    assert d == pytest.approx(3 / (8 * D.DENSITY) / math.sqrt(math.pi) * 1.016 * (1 - p / 3), rel=0.03)


def test_the_grid_holds_the_msd_between_grid_frames():
    """grid=True: the grid's pairs with the first frame are the MSD from the start at those frames."""
    s = D.simulate(D.initial_state(400, 4), T.walton_rule(0.9, 0.5, 0.4), 0.4, t_end=1e3, cooling_stop=4, seed=4,
                   grid=True)
    t, gt = np.asarray(s["t"]), np.asarray(s["grid_t"])
    g = len(gt)
    assert g == min(len(t), hcs.GRID_FRAMES) and len(s["grid_msd"]) == g * (g - 1) // 2
    idx = np.searchsorted(t, gt)
    assert np.asarray(s["grid_msd"])[:g - 1] == pytest.approx(np.asarray(s["msd"])[idx[1:]], rel=1e-12)
    assert "grid_msd" not in D.simulate(D.initial_state(400, 4), T.walton_rule(0.9, 0.5, 0.4), 0.4, t_end=1.0)


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="even number"):
        D.simulate(D.initial_state(3, 1), T.constant_beta_rule(0.9, 0.0), 0.4, t_end=1.0)
    with pytest.raises(ValueError, match="kappa"):
        D.simulate(D.initial_state(10, 1), T.constant_beta_rule(0.9, 0.0), 0.0, t_end=1.0)


def test_haff_amplitude_is_t0_of_an_exact_haff_curve():
    t = np.linspace(0, 30, 121)
    temp = 2.5 / (1 + t / 7.0) ** 2
    assert hcs.haff_amplitude(t, temp, 7.0, 5.0) == pytest.approx(2.5, rel=1e-12)
    with pytest.raises(ValueError):
        hcs.haff_amplitude(t, -temp, 7.0)


def test_the_energy_estimator_recovers_an_inertia_effect_on_dsmc_runs():
    """A small paired study (8 seeds of 1000 rough spheres, kappa -15.6 %): the mean effect on zeta
    from hcs_effects' estimator lies within 4 standard errors of the truth of long 16000-sphere runs."""
    truth = E.truth("rough", n_particles=16000, seeds=(91, 92))
    vals = E.study("rough", 8, 1)[("cooling_rate", "energy")]
    se = math.hypot(np.std(vals, ddof=1) / math.sqrt(len(vals)), truth["cooling_rate_se"])
    assert abs(np.mean(vals) - truth["cooling_rate"]) < 4 * se
    assert se < 0.015


def test_observables_read_dsmc_series():
    s = D.simulate(D.initial_state(1000, 5), T.walton_rule(0.9, 0.5, 0.4), 0.4, t_end=1e3, cooling_stop=16, seed=5,
                   grid=True)
    x = hcs_effects.observables(s)
    assert set(x) == {"cooling_rate", "temperature_ratio", "diffusion", "diffusion_grid"}
    assert all(math.isfinite(v) and v > 0 for v in x.values())
    # the two MSD routes read one D0 (1000 spheres: each scatters a few per cent)
    assert x["diffusion_grid"] == pytest.approx(x["diffusion"], rel=0.1)
    s.pop("grid_msd")
    assert math.isnan(hcs_effects.observables(s)["diffusion_grid"])


def test_the_drift_diagnostic_sees_a_ratio_still_relaxing_and_not_a_settled_one():
    """Weak coupling (beta = -0.6): from equipartition T_rot / T_tr is still falling in the window
    of a sixteenfold cooling, started at its two-temperature balance it is not."""
    rule = T.constant_beta_rule(0.9, -0.6)
    r_hcs = T.hcs_ratio_for_rule(rule, 0.4, size=100_000)[0]
    drift = {}
    for tag, start in (("equipartition", 1.0), ("balance", r_hcs)):
        drift[tag] = [hcs_effects.ratio_drift(D.simulate(D.initial_state(1000, s), rule, 0.4, t_end=1e3,
                                                         spin_ratio=start, cooling_stop=16, seed=s))[0]
                      for s in (1, 2, 3, 4)]
    _, lo_eq, hi_eq, _, _ = E.t_interval(drift["equipartition"])
    assert hi_eq < 0                                       # still falling: the interval excludes 0
    _, lo, hi, _, _ = E.t_interval(drift["balance"])
    assert lo <= 0.0 <= hi and hi - lo < 0.1              # settled: 0 inside a narrow interval
    assert hi_eq < lo                                      # and the two states apart


def test_the_maxwellian_effects_of_a_constant_beta_rule_are_the_closed_forms():
    """The Monte Carlo Maxwellian approximation of hcs_estimator.maxwellian against Huthmann and
    Zippelius' closed forms for constant tangential restitution (hcs_theory)."""
    e, beta = 0.9, -0.6
    assert E.SETTINGS["weakly_rough"]["rule"](np.array([1.0]), np.array([1.0]), 0.4)[1] == pytest.approx(beta)
    m = E.maxwellian("weakly_rough", size=200_000, seeds=(1, 2))

    def closed(kappa):
        zeta = T.hcs_cooling_rate(e, beta, kappa, 1.0)
        return {"temperature_ratio": T.hcs_temperature_ratio(e, beta, kappa), "cooling_rate": zeta,
                "diffusion": 1.0 / (T.velocity_relaxation_rate(e, beta, kappa, 1.0) - zeta / 2)}

    a, b = closed(E.KAPPA), closed(E.KAPPA_CASE)
    for k in a:
        assert m[k] == pytest.approx(b[k] / a[k] - 1, abs=5 * m[k + "_se"] + 2e-4), k
    rows = E.maxwellian_rows("weakly_rough", {k: 0.0 for k in m}, m)
    assert [r["observable"] for r in rows] == ["cooling_rate", "temperature_ratio", "diffusion"]
    assert all(r["difference"] == m[r["observable"]] for r in rows)
