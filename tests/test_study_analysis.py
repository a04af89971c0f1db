"""The analysis pipeline on synthetic runs with a known answer (no YADE).

Ornstein-Uhlenbeck walkers with a known D are written as the YADE script's frames, reduced by
:mod:`studies.reduce` into run records exactly as the engine does, and then read back by the
analysis (Green-Kubo D per run, Student-t over seeds), the equilibration cut, the sequential
design and effects.csv.
"""
import json
import math
import os
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from studies import analysis, design, diffusion, effects, engine, manifest, reduce as red, runner, sequential, synthetic
from studies import spec as S

TAU, SIGMA_V = 25.0, math.sqrt(0.629)         # s, m/s per component: the gas's values
D_TRUE = SIGMA_V ** 2 * TAU                    # m^2/s


def frames_of(rng, n, t_end, dt, D_scale=1.0, share=None):
    """Frames as yade_scripts/granular_gas.py writes them, from OU walkers of D = D_scale D_TRUE."""
    nf = int(round(t_end / dt)) + 1
    vel, pos = synthetic.simulate_ou(rng, n, nf, dt, TAU, SIGMA_V * math.sqrt(D_scale))
    t = np.arange(nf) * dt
    m = 2.0
    e_t = 0.5 * m * np.sum(vel ** 2, axis=(1, 2))
    s = share(t) if share is not None else np.full(nf, 0.4)
    e_r = e_t * s / (1 - s)
    return {"t": t, "disp": (pos - pos[0]).astype(np.float32), "vel": vel.astype(np.float32), "e_trans": e_t,
            "e_rot": e_r, "e_elastic": np.zeros(nf), "momentum": np.zeros((nf, 3))}, vel[0]


def write_record(rdir, run, frames, v0, cuts, max_lag, rot_dof=2, wall_s=600.0):
    rin = {"initial": {"vel": v0.tolist()}, "body": {"mass": 2.0}}
    rec = red.reduce_run(frames, rin, cuts, max_lag, energy_tol=1.0, momentum_tol=1.0)
    rec.update(key=run["key"], name=run["name"], shape=run["shape"], case=run["case"], protocol=run["protocol"],
               seed=run["seed"], params=run["params"], yade_version="synthetic", rot_algorithm="synthetic",
               host="test", wall_s=wall_s, git_commit="0" * 40, git_dirty=False, box_length=10.0, rot_dof=rot_dof,
               case_body={"mass": 2.0 if run["case"] == "exact" else 2.2}, exact_mass=2.0,
               facts={"steps_per_s": 1.0, "wall_run_s": wall_s, "builder": "synthetic", "dt": 1e-3})
    runner.write_atomic(runner.record_path(rdir, run), json.dumps(rec))
    return rec


def spec_for(tmp, groups, t_eq=0.0, cuts=(0.0,), max_lag=100.0, budget=None, start=None, schedule="in_order"):
    """A synthetic spec from dimer_paired.toml's tables with ``groups``; the study options the
    tests depend on are set here, not inherited (the committed spec's schedule may change).  Its
    ``run.legacy_dt`` (seeds below 17 at dt factor 0.5, later ones at 1.0) is kept on purpose: the
    tests of pooled time steps and of CPU-hour pricing across factors rely on it."""
    with open(os.path.join(S.SPEC_DIR, "dimer_paired.toml"), "rb") as f:
        r = tomllib.load(f)
    r["study"]["schedule"] = schedule
    if start is not None:
        r["gas"]["start"] = start
    r["study"]["results"] = str(tmp / "results")
    if budget is not None:
        r["study"]["budget_cpu_hours"] = budget
    r["analysis"].update(t_eq=t_eq, cuts=list(cuts), max_lag=max_lag, fit_lo=125.0, fit_hi=175.0)
    r["groups"] = groups
    sp = S.validate(r)
    sp["path"] = "synthetic"
    return sp


def test_analysis_recovers_a_known_D_and_a_known_difference(tmp_path):
    """12 seeds x (exact, uncorrected) of 216 walkers, 400 s: the uncorrected walkers' D is 10 %
    larger.  summary.csv and diff_D.csv must recover D and the +10 % within their intervals,
    with intervals of the width the per-run scatter implies."""
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": list(range(1, 13))}])
    rdir = engine.results_dir(sp)
    rng = np.random.default_rng(2024)
    for run in S.runs(sp):
        fr, v0 = frames_of(rng, 216, 400.0, 0.25, 1.0 if run["case"] == "exact" else 1.1)
        write_record(rdir, run, fr, v0, [0.0], 100.0)
    analysis.analyze(sp, log=lambda *a: None)
    s = pd.read_csv(tmp_path / "results" / "summary.csv").set_index("case")
    for case, truth in (("exact", D_TRUE), ("uncorrected", 1.1 * D_TRUE)):
        row = s.loc[case]
        assert row.n_seeds == 12
        assert row.ci_low <= truth <= row.ci_high, (case, row.to_dict(), truth)
        assert (row.ci_high - row.ci_low) / 2 / truth < 0.03     # 216 walkers x 400 s: ~2-3 % per run
    d = pd.read_csv(tmp_path / "results" / "diff_D.csv").set_index("case").loc["uncorrected"]
    assert d.relative_ci_low <= 0.10 <= d.relative_ci_high and d.relative_ci_low > 0.03
    runs = pd.read_csv(tmp_path / "results" / "runs.csv")
    assert (runs.t_cut == 0.0).all() and runs.diffusion_stderr_run.notna().all()
    # the per-run jackknife SE agrees with the scatter of D over seeds (within a factor 1.6)
    ex = runs[runs.case == "exact"]
    assert 1 / 1.6 < ex.diffusion_stderr_run.mean() / ex.diffusion_coefficient.std(ddof=1) < 1.6


def test_effects_rows_of_two_gases_stay_apart_and_say_which_gas_each_is(tmp_path):
    """The same shape, case and protocol in two gases (864 and 108 particles) are two rows, each
    with its own gas columns and its own interval (the +10 % and +20 % their walkers were given)."""
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": [1, 2, 3, 4]},
                             {"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": [1, 2, 3, 4],
                              "n_particles": 108}])
    rdir = engine.results_dir(sp)
    rng = np.random.default_rng(11)
    for run in S.runs(sp):
        small = run["params"]["gas"]["n_particles"] == 108
        scale = 1.0 if run["case"] == "exact" else (1.2 if small else 1.1)
        fr, v0 = frames_of(rng, 216, 400.0, 0.25, scale)
        write_record(rdir, run, fr, v0, [0.0], 100.0)
    rows = [r for r in effects.effect_rows([sp]) if r["case"] == "uncorrected"]
    assert sorted(r["n_particles"] for r in rows) == [108, 864]
    for r in rows:
        truth = 0.2 if r["n_particles"] == 108 else 0.1
        assert r["relative_ci_low"] <= truth <= r["relative_ci_high"], r
        assert set(effects.GAS_COLUMNS) <= set(r) and r["n_spheres"] == 2 and r["volume_fraction"] == 0.001


def test_a_studys_own_page_states_its_table_and_says_why_a_figure_is_missing(tmp_path):
    """The page and the figures of a study of its own (no spheres case): its name in the titles, the
    paired interval of diff_D.csv on the page, and ratio.png reported as not drawn, with the reason."""
    from studies import gas_plots, study_page
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": [1, 2, 3, 4]}],
                  t_eq="auto", start="equipartition")
    rdir = engine.results_dir(sp)
    rng = np.random.default_rng(7)
    for run in S.runs(sp):
        fr, v0 = frames_of(rng, 216, 400.0, 0.25, 1.0 if run["case"] == "exact" else 1.1)
        write_record(rdir, run, fr, v0, [0.0], 100.0)
    analysis.analyze(sp, log=lambda *a: None)
    said = []
    made = gas_plots.plot_all(rdir, log=said.append)
    assert "ratio.png" not in made and {"fig2_msd.png", "diffusion.png"} <= set(made)
    assert any("ratio.png not drawn: the paper's ratio needs the spheres case" in m for m in said)
    page = Path(study_page.write(rdir, log=lambda s: None)).read_text()
    name = sp["study"]["name"]
    assert page.startswith(f"# {name}\n")
    d = pd.read_csv(Path(rdir) / "diff_D.csv").set_index("case").loc["uncorrected"]
    row = (f"| uncorrected | paired | 4 | {100 * d.relative:+.2f} % | "
           f"[{100 * d.relative_ci_low:+.2f} %, {100 * d.relative_ci_high:+.2f} %] |")
    assert row in page
    assert "*ratio.png is not drawn: the paper's ratio needs the spheres case" in page
    # the paper's dimer summed: 2 spheres against a union of 27/16 (their lens is 5/16 of a sphere)
    assert f"its mass is off by\n{100 * (32 / 27 - 1):+.2f} %" in page
    assert "![diffusion.png](diffusion.png)" in page and "![ratio.png]" not in page
    params = json.loads((Path(rdir) / "params.json").read_text())
    assert gas_plots.msd_title(params) == f"{name}: mean-square displacement"
    assert "Fig. 2" in gas_plots.msd_title(dict(params, study={"name": "paper"}))


def test_effects_table_pairs_by_seed(tmp_path, monkeypatch):
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": list(range(1, 9))}])
    rdir = engine.results_dir(sp)
    rng = np.random.default_rng(7)
    for run in S.runs(sp):
        fr, v0 = frames_of(rng, 108, 300.0, 0.5, 1.0 if run["case"] == "exact" else 0.95)
        write_record(rdir, run, fr, v0, [0.0], 100.0)
    rows = effects.write([sp], str(tmp_path / "effects.csv"))
    t = pd.read_csv(tmp_path / "effects.csv")
    assert list(t.columns) == list(effects.COLUMNS)
    assert len(rows) == 1 and rows[0]["case"] == "mass_only" and rows[0]["n_pairs"] == 8
    assert rows[0]["relative_ci_low"] <= -0.05 <= rows[0]["relative_ci_high"]
    # mass_only runs with the exact mass and the summed inertia: k^2 = I_sum / m_exact, the summed
    # clump's k^2 (I_sum / m_sum) times m_sum / m_exact = 32/27 (the paper's dimer)
    from studies import shapes as shp
    assert rows[0]["mass_error"] == 0.0
    k2_sum = shp.k2_error(sp["shapes"]["dimer"], sp["material"]["density"])
    assert rows[0]["k2_error"] == pytest.approx((1 + k2_sum) * 32 / 27 - 1, rel=1e-12)


def test_effects_table_one_pair_has_empty_bounds(tmp_path):
    """One seed pair has no interval: its bounds are empty cells (read back as missing), not 'nan'."""
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": [1]}])
    rdir = engine.results_dir(sp)
    rng = np.random.default_rng(8)
    for run in S.runs(sp):
        fr, v0 = frames_of(rng, 108, 300.0, 0.5, 1.0)
        write_record(rdir, run, fr, v0, [0.0], 100.0)
    effects.write([sp], str(tmp_path / "effects.csv"))
    text = (tmp_path / "effects.csv").read_text()
    assert "nan" not in text.lower()
    t = pd.read_csv(tmp_path / "effects.csv")
    assert t.n_pairs.tolist() == [1] and np.isfinite(t.relative[0])
    assert t.relative_ci_low.isna().all() and t.relative_ci_high.isna().all()


def test_auto_cut_detected_from_the_rotational_share(tmp_path):
    """The paper's zero-spin start: the rotational share relaxes as 0.4 - 0.36 exp(-t/28.4 s);
    the detected cut must lie where the share is within its fluctuation of 0.4, and the analysis
    window is the next stored one."""
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact"], "seeds": [1]}], t_eq="auto",
                  cuts=(0.0, 50.0, 125.0, 200.0), start="zero_spin")
    rng = np.random.default_rng(3)
    noise = lambda t: 0.004 * np.sin(t / 3.0) + 0.004 * rng.standard_normal(len(t))   # noqa: E731
    fr, v0 = frames_of(rng, 64, 600.0, 0.25, share=lambda t: 0.4 - 0.36 * np.exp(-t / 28.4) + noise(t))
    run = S.runs(sp)[0]
    rec = write_record(engine.results_dir(sp), run, fr, v0, [0.0, 50.0, 125.0, 200.0], 100.0)
    t_cut, t_det = design.analysis_cut(rec, "auto")
    # 0.36 exp(-t/28.4) falls below the noise (~0.004) after about 28.4 ln(90) = 128 s
    assert 60.0 <= t_det <= 200.0
    assert t_cut == min(c for c in (0.0, 50.0, 125.0, 200.0) if c >= t_det)
    # a series that never settles has no cut
    fr2, _ = frames_of(rng, 64, 600.0, 0.25, share=lambda t: 0.4 - 0.36 * np.exp(-t / 400.0))
    rec2 = red.reduce_run(fr2, {"initial": {"vel": v0.tolist()}, "body": {"mass": 2.0}}, [0.0], 100.0, 1.0, 1.0)
    rec2.update(rot_dof=2, name="never")
    with pytest.raises(ValueError, match="no equilibration cut|after every stored window"):
        design.analysis_cut(rec2, "auto")


def test_auto_cut_uses_the_whole_run_of_an_equilibrium_start(tmp_path):
    """An equipartition start has no transient: "auto" takes the first window whatever the
    detector would say.  The series below has one late excursion beyond the detector's band
    (the kind of false alarm a 5 % test gives one run in twenty): with the zero-spin start the
    detector cuts after it (or finds no stored window), with the equilibrium start it is ignored."""
    cuts = (0.0, 50.0, 125.0)
    rng = np.random.default_rng(5)

    def share(t):
        y = 0.4 + 0.004 * rng.standard_normal(len(t))
        return np.where((t > 400) & (t < 425), 0.45, y)

    fr, v0 = frames_of(rng, 64, 1000.0, 0.25, share=share)
    for start, expect in (("equipartition", (0.0, None)), ("zero_spin", None)):
        sp = spec_for(tmp_path / start, [{"shape": "dimer", "cases": ["exact"], "seeds": [1]}], t_eq="auto",
                      cuts=cuts, start=start)
        run = S.runs(sp)[0]
        rec = write_record(engine.results_dir(sp), run, fr, v0, list(cuts), 100.0)
        if expect is not None:
            assert design.analysis_cut(rec, "auto") == expect
            assert design.run_d(rec, "auto")["t_cut"] == 0.0
        else:
            with pytest.raises(ValueError, match="after every stored window"):
                design.analysis_cut(rec, "auto")


def _sequential(tmp_path, noise_sd, budget=None, max_seeds=20):
    """Paired runs whose D ratio is 1.05 (1 + noise_sd z): the uncorrected run of a seed is the
    exact run's walkers with velocities and displacements scaled (D scales with their square)."""
    g = {"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": list(range(1, 13)),
         "target": {"case": "uncorrected", "halfwidth": 0.02, "batch": 2}, "max_seeds": max_seeds}
    sp = spec_for(tmp_path, [g], budget=budget)
    rdir = engine.results_dir(sp)
    rng = np.random.default_rng(11)
    by_seed = {}
    for run in S.runs(sp):
        if run["seed"] not in by_seed:
            by_seed[run["seed"]] = frames_of(rng, 48, 250.0, 0.5)
        fr, v0 = by_seed[run["seed"]]
        if run["case"] != "exact":
            a = math.sqrt(1.05 * (1.0 + noise_sd * rng.standard_normal()))
            fr = dict(fr, disp=fr["disp"] * np.float32(a), vel=fr["vel"] * np.float32(a))
        write_record(rdir, run, fr, v0, [0.0], 100.0)
    return sp, rdir


def test_sequential_design_stops_when_the_target_is_met(tmp_path):
    sp, rdir = _sequential(tmp_path, noise_sd=0.0)        # every pair: D ratio 1.05, no scatter
    extra, status = design.plan(sp, rdir)
    st = status[0]
    assert st["n"] == 12 and st["finished"] and st["state"] == "target met" and extra[0] == []
    assert st["mean"] == pytest.approx(0.05, abs=1e-5) and st["halfwidth"] < 1e-4
    assert S.runs(sp, extra_seeds=extra) == S.runs(sp)     # nothing more to run


def test_sequential_design_adds_seeds_then_stops_at_max_seeds_or_budget(tmp_path):
    sp, rdir = _sequential(tmp_path, noise_sd=0.3)        # large scatter: 2 % is far away
    extra, status = design.plan(sp, rdir)
    assert extra[0] == [13, 14] and status[0]["state"] == "running" and status[0]["n_needed"] > 20
    # the projection in CPU-hours: 2 runs of 600 s a pair (the records' wall time, no cpu_s)
    assert status[0]["cpu_hours_per_pair"] == pytest.approx(2 * 600 / 3600)
    # seeds 13-16 at the spec's legacy factor 0.5 like the records, later seeds at 1.0: half the steps
    n_more = status[0]["n_needed"] - 12
    assert status[0]["cpu_hours_to_target"] == pytest.approx((4 + (n_more - 4) / 2) * 2 * 600 / 3600)
    assert "CPU-h more, runs already made not counted; 0.33 CPU-h a new pair" in design.describe(0, sp["groups"][0], status[0])
    # a second group comparing another case with the same exact runs: its pairs cost one run each
    # while the exact run of the seed exists (seeds 1-12), two beyond
    recs = design.load_records(sp, rdir)
    sp_b = dict(sp, groups=sp["groups"] + [dict(sp["groups"][0], cases=["exact", "mass_only"],
                                                 target=dict(sp["groups"][0]["target"], case="mass_only"))])
    run_h = 600 / 3600
    assert design.cost_of_seeds(sp_b, 1, [1, 2, 3], recs) is None       # no mass_only run to price yet
    stiff = {"E-" + k: dict(r, params=dict(r["params"], case="mass_only",
                                            material=dict(r["params"]["material"], youngs_modulus=1e9)))
             for k, r in recs.items() if r["params"]["case"] == "uncorrected"}
    assert design.cost_of_seeds(sp_b, 1, [1], dict(recs, **stiff)) is None   # another stiffness's runs do not price it
    mo = {k: dict(r, params=dict(r["params"], case="mass_only")) for k, r in recs.items()
          if r["params"]["case"] == "uncorrected"}
    priced = dict(recs, **{"mo-" + k: r for k, r in mo.items()})       # mass_only runs of known cost
    assert design.cost_of_seeds(sp_b, 1, [1, 2, 3], priced) == pytest.approx(3 * run_h)
    assert design.cost_of_seeds(sp_b, 1, [12, 13], priced) == pytest.approx(3 * run_h)
    assert design.cost_of_seeds(sp, 0, [1, 2], recs) == 0.0             # both runs of seeds 1, 2 made
    runs = S.runs(sp, extra_seeds=extra)
    assert {r["seed"] for r in runs} == set(range(1, 15))  # the driver will run seeds 13 and 14
    sp2, rdir2 = _sequential(tmp_path / "b", noise_sd=0.3, budget=1.0)   # 24 runs x 600 s = 4 CPU-h > 1
    extra2, status2 = design.plan(sp2, rdir2)
    assert extra2[0] == [] and status2[0]["state"] == "budget spent"
    line = design.describe(0, sp2["groups"][0], status2[0])
    assert "budget" in line and f"vs exact, {sp2['groups'][0]['protocol']})" in line
    # the added seeds' records count once written: the next plan extends past them, and the
    # report's and effects.csv's readers see them
    rng = np.random.default_rng(5)
    for run in S.runs(sp, extra_seeds=extra):
        if run["seed"] in (13, 14):
            fr, v0 = frames_of(rng, 48, 250.0, 0.5)
            write_record(rdir, run, fr, v0, [0.0], 100.0)
    recs = design.load_records(sp, rdir)
    assert {r["params"]["seed"] for r in recs.values()} == set(range(1, 15))
    extra_b, status_b = design.plan(sp, rdir)
    assert extra_b[0] == [13, 14, 15, 16] and status_b[0]["n"] == 14
    assert len(effects.paired_values([sp])[0][3]) == 14
    sp3, rdir3 = _sequential(tmp_path / "c", noise_sd=0.3, max_seeds=12)
    extra3, status3 = design.plan(sp3, rdir3)
    assert extra3[0] == [] and status3[0]["state"] == "max_seeds reached"


def test_prior_projection_of_a_question_at_another_stiffness_and_run_length(tmp_path):
    from scipy import stats

    from studies import report

    sp, rdir = _sequential(tmp_path, noise_sd=0.3)          # the reference: 12 pairs at E = 1e7 Pa, 1000 s
    _, status = design.plan(sp, rdir)
    g = {"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": list(range(1, 13)), "youngs_modulus": 1e9,
         "target": {"case": "uncorrected", "halfwidth": 0.02, "batch": 2}, "max_seeds": 40}
    sp_t = spec_for(tmp_path / "t", [g])
    sp_t["run"] = dict(sp_t["run"], t_end=400.0)
    _, status_t = design.plan(sp_t, engine.results_dir(sp_t))
    assert status_t[0]["n"] == 0
    refs = [(sp, 0, status[0], design.load_records(sp, rdir)), (sp_t, 0, status_t[0], {})]
    pr = design.prior_projection(sp_t, 0, refs)
    sd = status[0]["sd"] * math.sqrt(1000.0 / 400.0)          # t_eq = 0: the whole run is analysed
    assert pr["ref"] == sp["study"]["name"] and pr["ref_pairs"] == 12 and pr["sd"] == pytest.approx(sd, rel=1e-12)
    n = 12
    while stats.t.ppf(0.975, n - 1) * sd / math.sqrt(n) > 0.02:
        n += 1
    assert pr["n_needed"] == n and n > 40
    assert pr["halfwidth_at_max"] == pytest.approx(stats.t.ppf(0.975, 39) * sd / math.sqrt(40), rel=1e-9)
    # a reference pair: 2 runs x 600 s at dt factor 0.5, like the target's seeds; x 0.4 (length) x 10 (sqrt E)
    assert pr["cpu_hours_per_pair"] == pytest.approx(2 * 600 / 3600 * 0.4 * 10, rel=1e-12)
    # a softer target (1e5 Pa: a tenth of the steps per second) is not priced x 0.1 x 0.4: the run
    # length's ratio bounds its per-second part, the whole reference pair its fixed part (x 1)
    sp_soft = spec_for(tmp_path / "s", [dict(g, youngs_modulus=1e5)])
    sp_soft["run"] = dict(sp_soft["run"], t_end=400.0)
    pr_soft = design.prior_projection(sp_soft, 0, refs)
    assert pr_soft["cpu_hours_per_pair"] == pytest.approx(2 * 600 / 3600, rel=1e-12)
    sp_soft_long = spec_for(tmp_path / "sl", [dict(g, youngs_modulus=1e5)])
    sp_soft_long["run"] = dict(sp_soft_long["run"], t_end=2500.0)        # 2.5 x the reference's length
    pr_sl = design.prior_projection(sp_soft_long, 0, refs)
    assert pr_sl["cpu_hours_per_pair"] == pytest.approx(2 * 600 / 3600 * 2.5, rel=1e-12)
    assert pr["cpu_hours_to_target"] == pytest.approx(n * pr["cpu_hours_per_pair"], rel=1e-12)
    words = report._prior_words(pr, 0.02)
    assert f"needs about {n} pairs" in words and "max_seeds (40)" in words
    # no reference for another shape, or another case
    sp_ov = spec_for(tmp_path / "u", [g])
    sp_ov["shapes"] = {"dimer": dict(sp_ov["shapes"]["dimer"], overlap=0.25)}
    assert design.prior_projection(sp_ov, 0, refs) is None
    g_mo = dict(g, cases=["exact", "mass_only"], target=dict(g["target"], case="mass_only"))
    assert design.prior_projection(spec_for(tmp_path / "v", [g_mo]), 0, refs) is None


def test_prior_projection_prefers_a_full_pilot_then_the_nearest_stiffness_and_length(tmp_path):
    """Among references of the same question: one with a full pilot (MIN_PAIRS pairs) before one
    with fewer, then the nearest Young's modulus, then the nearest run length, then the most pairs,
    then the softer; the order the references come in never decides."""
    g = {"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": [1, 2],
         "target": {"case": "mass_only", "halfwidth": 0.01, "batch": 2}, "max_seeds": 60}

    def ref(name, e, t, n, sd):
        sp = spec_for(tmp_path / name, [dict(g, youngs_modulus=e, t_end=t)])
        sp["study"]["name"] = name
        return (sp, 0, {"case": "mass_only", "n": n, "sd": sd}, {})
    target = spec_for(tmp_path / "target", [dict(g, youngs_modulus=1e9, t_end=400.0)])
    r7 = ref("e7_1000s", 1e7, 1000.0, 20, 0.05)
    r8 = ref("e8_400s", 1e8, 400.0, 20, 0.02)
    r8_long = ref("e8_1000s", 1e8, 1000.0, 20, 0.02)
    r8_few = ref("e8_few", 1e8, 400.0, 5, 0.02)
    r8_more = ref("e8_more", 1e8, 400.0, 30, 0.02)
    r7_400 = ref("e7_400s", 1e7, 400.0, 20, 0.02)
    r8_11 = ref("e8_11", 1e8, 400.0, 11, 0.02)
    r7_12 = ref("e7_12", 1e7, 400.0, 12, 0.02)
    r10 = ref("e10_400s", 1e10, 400.0, 20, 0.02)
    for refs, want in (([r7, r8], "e8_400s"), ([r8, r7], "e8_400s"),          # nearest E, either order
                       ([r8_long, r8], "e8_400s"),                               # then nearest length
                       ([r8_long, r7_400], "e8_1000s"), ([r7_400, r8_long], "e8_1000s"),   # E before length
                       ([r7, r8_few], "e7_1000s"),                               # a full pilot first
                       ([r8_11, r7_12], "e7_12"), ([r7_12, r8_11], "e7_12"),     # 12 pairs is one, 11 not
                       ([r8, r8_more], "e8_more"), ([r8_more, r8], "e8_more"),   # then the most pairs
                       ([r10, r8], "e8_400s"), ([r8, r10], "e8_400s")):          # a tie: the softer
        pr = design.prior_projection(target, 0, refs)
        assert pr["ref"] == want, (want, pr["ref"])
    pr = design.prior_projection(target, 0, [r7, r8])
    assert pr["ref_youngs_modulus"] == 1e8 and pr["sd"] == pytest.approx(0.02, rel=1e-12)   # 400 s: unscaled


def test_report_gives_a_question_in_its_pilot_a_second_projection_from_the_prior(tmp_path):
    """A question with 2-11 pairs has its own (noisy) projection and, beside it, the prior's from the
    same question at another stiffness; at 12 pairs the prior goes."""
    from studies import report

    sp, rdir = _sequential(tmp_path / "ref", noise_sd=0.3)      # the reference: 12 pairs at 1e7 Pa
    g = {"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": list(range(1, 13)), "youngs_modulus": 1e9,
         "target": {"case": "uncorrected", "halfwidth": 0.02, "batch": 2}, "max_seeds": 40}
    sp_t = spec_for(tmp_path / "t", [g])
    sp_t["study"]["name"] = "target_study"
    rdir_t = engine.results_dir(sp_t)
    rng = np.random.default_rng(3)
    for run in S.runs(sp_t):
        if run["seed"] <= 4:                                     # 4 pairs of the 12-pair pilot
            fr, v0 = frames_of(rng, 48, 250.0, 0.5)
            write_record(rdir_t, run, fr, v0, [0.0], 100.0)
    plans = report.planned([sp, sp_t])
    st = plans[1].status[0]
    assert st["n"] == 4 and st["prior"] is not None and st["prior"]["ref_pairs"] == 12
    assert "prior" not in plans[0].status[0]                     # 12 pairs: its own spread only
    lines = []
    report.programme_section(lines, plans)
    row = next(ln for ln in lines if ln.startswith("| dimer at E = 1e+09 Pa"))
    assert row.endswith(f"| {st['n_needed']}; {st['prior']['n_needed']} (prior) | {st['cpu_hours_to_target']:.1f} |"), row
    words = report._answer(sp_t, sp_t["groups"][0], st, design.cpu_hours(plans[1].records))
    assert "second projection" in words and f"needs about {st['prior']['n_needed']} pairs" in words, words
    # the prior's CPU-hours are for the pairs not made yet, as the question's own are
    more = (st["prior"]["n_needed"] - 4) * st["prior"]["cpu_hours_per_pair"]
    assert f"at most {report._cpu_hours(more)} more (" in words, words
    # a question with fewer pairs than a full pilot is no second opinion: two questions in their
    # pilots (4 pairs at 1e9 Pa, 3 at 1e8 Pa) do not project each other
    sp_3 = spec_for(tmp_path / "three", [dict(g, youngs_modulus=1e8)])
    sp_3["study"]["name"] = "three_pairs"
    for run in S.runs(sp_3):
        if run["seed"] <= 3:
            fr, v0 = frames_of(rng, 48, 250.0, 0.5)
            write_record(engine.results_dir(sp_3), run, fr, v0, [0.0], 100.0)
    p2 = report.planned([sp_t, sp_3])
    assert [p.status[0]["n"] for p in p2] == [4, 3] and all("prior" not in p.status[0] for p in p2)
    for run in S.runs(sp_t):                                     # the pilot completes: no prior any more
        if run["seed"] > 4:
            fr, v0 = frames_of(rng, 48, 250.0, 0.5)
            write_record(rdir_t, run, fr, v0, [0.0], 100.0)
    st12 = report.planned([sp, sp_t])[1].status[0]
    assert st12["n"] == 12 and "prior" not in st12


def test_pairs_needed_is_the_smallest_sample_whose_t_interval_meets_the_target():
    from scipy import stats

    for sd, target, lo in [(0.03, 0.01, 12), (0.002, 0.01, 12), (0.05, 0.004, 2), (0.0, 0.01, 5)]:
        n = sequential.pairs_needed(sd, target, lo)
        hw = lambda k: stats.t.ppf(0.975, k - 1) * sd / math.sqrt(k)     # noqa: E731
        assert n >= max(lo, 2) and hw(n) <= target
        assert n == max(lo, 2) or hw(n - 1) > target
    with pytest.raises(ValueError, match="finite sd"):
        sequential.pairs_needed(float("nan"), 0.01)


def test_same_spin_report_divides_out_the_thermal_speed_drift(tmp_path):
    """studies.report on a spin_pairing = "same" spec: the per-seed ratio r of translational energy
    per unit mass (case over exact) and D ratio are read from the records, and the bullet divides
    sqrt(r) out.  Synthetic: the same walkers (D ratio 1) with a case mass 10 % larger, so
    r = 1/1.1 and the drift-free effect is sqrt(1.1) - 1 = +4.9 %."""
    from studies import report

    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": list(range(1, 7))}],
                  start="equipartition")
    sp["gas"]["spin_pairing"] = "same"
    rdir = engine.results_dir(sp)
    rng = np.random.default_rng(11)
    frames = {}
    for run in S.runs(sp):
        if run["seed"] not in frames:
            frames[run["seed"]] = frames_of(rng, 216, 400.0, 0.25)
        fr, v0 = frames[run["seed"]]
        write_record(rdir, run, fr, v0, [0.0], 100.0)          # case_body mass 2.2 vs exact's 2.0
    pairs = report.same_spin_pairs(sp)["uncorrected"]
    assert len(pairs) == 6
    for _, d_ratio, r in pairs:
        assert d_ratio == pytest.approx(1.0, rel=1e-12) and r == pytest.approx(2.0 / 2.2, rel=1e-12)
    (line,) = report._same_spin_answers([sp])
    assert "+0.00 % [+0.00, +0.00] %" in line and "-4.65 %" in line and "+4.88 %" in line
    sp["gas"]["spin_pairing"] = "own"
    assert report._same_spin_answers([sp]) == []


def test_paper_share_from_independent_runs_covers_the_known_ratio(tmp_path):
    """Uncorrected walkers 4 % faster than exact (seeds 1-10) and sphere walkers 40 % slower (seeds
    11-18, their own exact runs): the report's share (D_unc - D_ex)/(D_sph - D_ex) is about -0.10,
    with a Fieller interval that holds it and excludes 0."""
    from studies import report
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": list(range(1, 11))},
                             {"shape": "dimer", "cases": ["exact", "spheres"], "seeds": list(range(11, 19))}])
    rdir = engine.results_dir(sp)
    rng = np.random.default_rng(21)
    scale = {"exact": 1.0, "uncorrected": 1.04, "spheres": 0.6}
    for run in S.runs(sp):
        fr, v0 = frames_of(rng, 216, 400.0, 0.5, scale[run["case"]])
        write_record(rdir, run, fr, v0, [0.0], 100.0)
    (line,) = report.paper_share_answers([sp])
    assert "10 seed pairs for the numerator, 8 for the sphere-clump gap" in line
    th, lo, hi = (float(x) for x in
                  line.split("Fieller 95 % interval): ")[1].split(", which")[0].replace("[", "").replace("]", "")
                  .replace(",", "").split())
    assert lo <= -0.04 / 0.4 <= hi and hi < 0 and lo < th < hi
    assert "excludes 0.10 and excludes 0" in line
    for run in S.runs(sp):           # without the sphere runs there is no gap and no statement
        if run["case"] == "spheres":
            os.remove(runner.record_path(rdir, run))
    assert report.paper_share_answers([sp]) == []
    # numerator and gap from the same exact runs (one pair key) are not independent: no statement
    sp2 = spec_for(tmp_path / "one", [{"shape": "dimer", "cases": ["exact", "uncorrected", "spheres"],
                                       "seeds": [1, 2, 3, 4]}])
    for run in S.runs(sp2):
        fr, v0 = frames_of(rng, 48, 200.0, 0.5, scale[run["case"]])
        write_record(engine.results_dir(sp2), run, fr, v0, [0.0], 100.0)
    assert len(effects.paired_values([sp2])) == 2 and report.paper_share([sp2]) is None
    # a gap measured from the same starts at another run length (other run keys, the same initial
    # states of seeds 5-10) is correlated with the numerator: those seeds leave the larger sample
    # (before: both samples used in full, as if independent)
    sp3 = spec_for(tmp_path / "gap", [{"shape": "dimer", "cases": ["exact", "spheres"], "seeds": list(range(5, 13))}])
    sp3["run"]["t_end"] = 500.0
    for run in S.runs(sp3):
        fr, v0 = frames_of(rng, 216, 400.0, 0.5, scale[run["case"]])
        write_record(engine.results_dir(sp3), run, fr, v0, [0.0], 100.0)
    r = report.paper_share([sp, sp3])
    assert (r["n_num"], r["n_gap"], r["n_dropped"]) == (4, 8, 6)
    assert r["low"] <= -0.04 / 0.4 <= r["high"]
    (line,) = report.paper_share_answers([sp, sp3])
    assert "4 seed pairs for the numerator, 8 for the sphere-clump gap" in line and "6 seeds whose exact start" in line


def _scaled_record(rdir, run, base, a):
    """The record of ``run``: the walkers ``base`` with velocities and displacements scaled by
    sqrt(a), so its D is exactly a times base's."""
    fr, v0 = base
    s = np.float32(math.sqrt(a))
    return write_record(rdir, run, dict(fr, disp=fr["disp"] * s, vel=fr["vel"] * s), v0, [0.0], 100.0)


def test_effects_pool_pairs_across_a_raised_time_step_one_pair_per_seed(tmp_path):
    """A study that raised run.dt_factor and kept its earlier seeds (run.legacy_dt): seeds 1-3 at
    0.5, 4-6 at 1.0.  Every pair is made at one dt, and effects.csv pools them into one row.
    Traps: exact runs of seeds 1-3 at dt 1.0 (another spec, other walkers, D 1.3x) must not be
    paired with the dt-0.5 mass_only runs, and a second mass_only pair of seed 2 at dt 1.0 (ratio
    0.90) must not be counted beside its dt-0.5 pair (one pair per seed, the smaller factor)."""
    sp = spec_for(tmp_path / "a", [{"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": list(range(1, 7))}])
    sp["run"]["legacy_dt"] = {"below_seed": 4, "dt_factor": 0.5}
    sp["run"]["dt_factor"] = 1.0
    runs = S.runs(sp)
    assert {r["seed"]: r["params"]["run"]["dt_factor"] for r in runs} == {1: 0.5, 2: 0.5, 3: 0.5, 4: 1.0, 5: 1.0, 6: 1.0}
    rng = np.random.default_rng(21)
    base = {s: frames_of(rng, 48, 250.0, 0.5) for s in range(1, 7)}
    for run in runs:
        _scaled_record(engine.results_dir(sp), run, base[run["seed"]], 1.0 if run["case"] == "exact" else 0.95)
    other = spec_for(tmp_path / "b", [{"shape": "dimer", "cases": ["exact"], "seeds": [1, 2, 3], "dt_factor": 1.0},
                                      {"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": [2], "dt_factor": 1.0}])
    b2 = frames_of(rng, 48, 250.0, 0.5)
    for run in S.runs(other):
        _scaled_record(engine.results_dir(other), run, base[run["seed"]] if run["seed"] != 2 else b2,
                       (1.3 if run["seed"] != 2 else 1.0) if run["case"] == "exact" else 0.90)
    (pv,) = effects.paired_values([sp, other])
    assert pv.case == "mass_only" and pv.seeds == [1, 2, 3, 4, 5, 6]
    assert pv.values == pytest.approx([-0.05] * 6, abs=1e-6)
    assert len(set(pv.exact_states)) == 6 and pv.facts["run"]["dt_factor"] == 0.5
    (row,) = effects.effect_rows([sp, other])
    assert row["n_pairs"] == 6 and row["relative"] == pytest.approx(-0.05, abs=1e-6)
    # without the legacy seeds the dt-1.0 pair of seed 2 is a pair like any other
    (pv2,) = effects.paired_values([other])
    assert pv2.seeds == [2] and pv2.values == pytest.approx([-0.10], abs=1e-6)


def test_effects_keep_a_groups_own_time_step_apart_and_refuse_rows_effects_csv_cannot_tell_apart(tmp_path, monkeypatch, capsys):
    """A group with its own dt_factor (a convergence check) is no legacy seed: its pairs are not
    pooled into the study's row (before: they silently replaced the main pairs of the same seeds,
    the smaller factor first).  And two studies of one shape, overlap, protocol, E and case that
    differ in another run parameter (run length here, the quick scale beside the real study) would
    give two rows that effects.csv cannot tell apart: an error naming the parameter, not two rows
    (before: both were written, and the report's look-ups took the first)."""
    sp = spec_for(tmp_path / "a", [{"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": [20, 21]},
                                   {"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": [20, 21],
                                    "dt_factor": 0.25}])
    assert sorted({r["params"]["run"]["dt_factor"] for r in S.runs(sp)}) == [0.25, 1.0]
    rng = np.random.default_rng(5)
    base = {s: frames_of(rng, 48, 250.0, 0.5) for s in (20, 21)}
    for run in S.runs(sp):
        _scaled_record(engine.results_dir(sp), run, base[run["seed"]], 1.0 if run["case"] == "exact" else 0.95)
    with pytest.raises(ValueError, match=r"run\.dt_factor \(0\.25 / 1\.0\)"):
        effects.paired_values([sp])
    main = spec_for(tmp_path / "a", [{"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": [20, 21]}])
    (pv,) = effects.paired_values([main])           # the study alone: its own pairs at dt 1.0
    assert pv.seeds == [20, 21] and pv.facts["run"]["dt_factor"] == 1.0
    short = spec_for(tmp_path / "c", [{"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": [20, 21]}])
    short["run"]["t_end"] = 200.0
    for run in S.runs(short):
        _scaled_record(engine.results_dir(short), run, base[run["seed"]], 1.0 if run["case"] == "exact" else 0.9)
    short["study"]["name"] = "short"
    # another run length is another gas: its own row, with its own t_end (effects.GAS_COLUMNS)
    rows = [r for r in effects.effect_rows([main, short]) if r["case"] == "mass_only"]
    assert sorted(r["t_end"] for r in rows) == [200.0, main["run"]["t_end"]]
    # two studies whose rows differ only in what effects.csv does not show (the recording interval
    # here) still stop the headline, in one line, writing neither effects.csv nor README.md
    fine = spec_for(tmp_path / "d", [{"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": [20, 21]}])
    fine["run"]["rec_interval"] = 0.125
    for run in S.runs(fine):
        _scaled_record(engine.results_dir(fine), run, base[run["seed"]], 1.0 if run["case"] == "exact" else 0.9)
    fine["study"]["name"] = "fine"
    with pytest.raises(ValueError, match=r"apart, from dimer_paired and from fine, differing in run\.rec_interval"):
        effects.effect_rows([main, fine])
    from studies import report
    monkeypatch.setattr(report, "readable_specs", lambda: ([main, fine], []))
    monkeypatch.setattr(report, "RESULTS", str(tmp_path / "results_out"))
    assert report.main() == 1
    err = capsys.readouterr().err
    assert err.startswith("[report] error: effects: two rows of mass_only vs exact") and "Traceback" not in err
    assert not (tmp_path / "results_out").exists()
    # the legacy factor counts as the study's own only below below_seed: a convergence group at the
    # legacy factor 0.5 on seeds 20-21 (ratio 0.80) must not replace the main pairs (ratio 0.95)
    leg = spec_for(tmp_path / "d", [{"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": [20, 21]},
                                    {"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": [20, 21],
                                     "dt_factor": 0.5}])
    assert leg["run"]["legacy_dt"] == {"below_seed": 17, "dt_factor": 0.5}
    for run in S.runs(leg):
        _scaled_record(engine.results_dir(leg), run, base[run["seed"]], 1.0 if run["case"] == "exact" else
                       (0.95 if run["params"]["run"]["dt_factor"] == 1.0 else 0.80))
    with pytest.raises(ValueError, match=r"apart, both from dimer_paired, differing in run\.dt_factor \(0\.5 / 1\.0\)"):
        effects.paired_values([leg])


def test_a_new_spec_in_the_spec_folder_does_not_enter_the_headline(tmp_path):
    """A user's own study (or one of the project's not yet listed) is not read by the headline: the
    headline's specs are listed by name, whatever else lies beside them."""
    import shutil
    for f in os.listdir(S.SPEC_DIR):
        shutil.copy(os.path.join(S.SPEC_DIR, f), tmp_path / f)
    before = [sp["study"]["name"] for sp in effects.results_specs(str(tmp_path))]
    extra = tmp_path / "my_chain.toml"
    extra.write_text((tmp_path / "test.toml").read_text().replace("in_results = false", "in_results = true")
                     .replace('name = "test"', 'name = "my_chain"'))
    assert S.load(str(extra))["study"]["in_results"]
    assert [sp["study"]["name"] for sp in effects.results_specs(str(tmp_path))] == before
    assert "my_chain" not in before


def test_results_specs_are_the_programme():
    """The report reads every committed spec but the scratch and first-version scales, whose runs
    (make run's quick scale among them) would otherwise enter effects.csv beside the real study."""
    names = {sp["study"]["name"] for sp in effects.results_specs()}
    assert {"dimer_paired", "dimer_equal_energy", "grains", "shapes", "sphere_gas", "stiffness"} <= names
    assert not names & {"quick", "test", "paper"}


def _fake_execute_logging_to(log_path):
    def fake_execute(run, settings):
        import time
        time.sleep(0.3)                      # a run lasts longer than submitting the batch
        rng = np.random.default_rng(run["seed"] * 10 + len(run["case"]))
        a = 1.0 if run["case"] == "exact" else 1.05 * (1.0 + 0.3 * rng.standard_normal()) ** 2
        rec = _scaled_record(settings["results_dir"], run, frames_of(rng, 24, 120.0, 0.5), a)
        with open(log_path, "a") as f:
            f.write(f"{run['seed']} {run['case']}\n")
        return {"ok": True, "fail_reasons": [], "energy_drift": rec["checks"]["energy_drift"], "steps_per_s": 1.0,
                "wall_s": 600.0, "yade_version": "synthetic", "rot_algorithm": "synthetic"}
    return fake_execute


def test_driver_queues_a_sequential_groups_new_seeds_before_later_groups(tmp_path, monkeypatch):
    """The driver plans again whenever a run finishes: the seeds a sequential group adds run next,
    not after every later group's run submitted earlier (so a stopped study holds the first
    group's answer).  Fake runs (synthetic records) on a 1-worker LocalCluster."""
    g0 = {"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": [1, 2],
          "target": {"case": "uncorrected", "halfwidth": 0.001, "batch": 2}, "max_seeds": 4}
    g1 = {"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": list(range(11, 17))}
    sp = spec_for(tmp_path, [g0, g1])
    log_path = tmp_path / "order.txt"        # Dask ships a copy of the function: log to a file
    monkeypatch.setattr(runner, "execute", _fake_execute_logging_to(log_path))
    lines = []
    rows = engine.sweep(sp, workers=1, allow_dirty=True, log=lines.append, progress_every=1.0)
    order = [int(ln.split()[0]) for ln in log_path.read_text().splitlines()]
    assert len(order) == 4 * 2 + 6 * 2 and len(rows) == 20 and all(r["status"] == "done" for r in rows.values())
    assert sorted(s for s in order if s < 10) == [1, 1, 2, 2, 3, 3, 4, 4]
    g0_at = [i for i, s in enumerate(order) if s < 10]
    # the extension (seeds 3, 4) ran before the later group's runs, but for the one or two
    # already on the worker when seed 2 finished; before this fix it ran after all twelve
    assert max(g0_at) <= 7 + 2, order
    assert any("max_seeds reached" in ln for ln in lines)
    # `python -m studies status` counts the added seeds' runs too (before: the 16 of the listed seeds)
    st = engine.status(sp, log=lines.append)
    assert len(st) == 20 and all(r["status"] == "done" for r in st.values())


def test_killed_starts_count_as_attempts_but_never_leave_a_run_undone(tmp_path, monkeypatch):
    """attempts counts every start; the cap (max_attempts) applies to failures only: a run whose
    record is gone after three starts that were killed runs again, and one start is one attempt."""
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact"], "seeds": [1]}])
    sp["study"]["max_attempts"] = 3
    monkeypatch.setattr(runner, "execute", _fake_execute_logging_to(tmp_path / "order.txt"))
    rows = engine.sweep(sp, workers=1, allow_dirty=True, log=lambda s: None)
    (key,) = rows
    rdir = engine.results_dir(sp)
    os.remove(runner.record_path(rdir, S.runs(sp)[0]))          # the record is lost ...
    m = Path(rdir) / "manifest.csv"
    m.write_text(m.read_text().replace(",done,1,", ",done,3,"))     # ... after three (killed) starts
    rows = engine.sweep(sp, workers=1, allow_dirty=True, log=lambda s: None)
    assert rows[key]["status"] == "done" and int(rows[key]["attempts"]) == 4
    # a start the driver has not counted yet, of a run whose record is there: one attempt, not two
    m.write_text(m.read_text().replace(",done,4,", ",done,0,"))
    runner._count_start(rdir, key)
    rows = engine.sweep(sp, workers=1, allow_dirty=True, log=lambda s: None)
    assert int(rows[key]["attempts"]) == 1


def test_driver_keeps_runs_in_flight_when_the_budget_runs_out_mid_batch(tmp_path, monkeypatch):
    """A re-plan after the budget is spent drops a sequential group's added seeds; those already
    submitted must still be collected and recorded (before: KeyError in the driver, which closed
    the cluster and killed every run in flight).  Found by review; 600 s a fake run, budget 0.8 h."""
    g0 = {"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": [1, 2],
          "target": {"case": "uncorrected", "halfwidth": 0.001, "batch": 2}, "max_seeds": 6}
    g1 = {"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": list(range(11, 17))}
    sp = spec_for(tmp_path, [g0, g1], budget=0.8)
    log_path = tmp_path / "order.txt"
    monkeypatch.setattr(runner, "execute", _fake_execute_logging_to(log_path))
    lines = []
    rows = engine.sweep(sp, workers=1, allow_dirty=True, log=lines.append, progress_every=1.0)
    ran = [tuple(ln.split()) for ln in log_path.read_text().splitlines()]
    assert all(r["status"] == "done" for r in rows.values())
    assert {("3", "exact"), ("3", "uncorrected")} <= set(ran)         # the dropped batch's runs finished
    assert any("budget spent" in ln for ln in lines)
    rdir = engine.results_dir(sp)                                    # and their records are complete on disk
    dropped = [r for r in S.runs(sp, extra_seeds={0: [3, 4]}) if r["seed"] == 3]
    assert dropped and all(runner.is_complete(runner.record_path(rdir, r), r["key"]) for r in dropped)
    # and the manifest lists them as done, after the sweep and in a status read (before: left out)
    man = manifest.read_manifest(rdir)
    assert all(man[r["key"]]["status"] == "done" for r in dropped)
    st = engine.status(sp, log=lambda s: None)
    assert all(st[r["key"]]["status"] == "done" for r in dropped)
    assert engine.sweep(sp, workers=1, allow_dirty=True, log=lambda s: None) and \
        all(manifest.read_manifest(rdir)[r["key"]]["status"] == "done" for r in dropped)


def test_driver_drains_finishing_runs_in_flight_and_resumes_after(tmp_path, monkeypatch):
    """A drain file (scripts/sweep.sh drain) asked while a run is in flight: that run finishes and is
    recorded, the queued runs are cancelled and stay to do, the driver ends; the next driver removes
    the stale file and runs the rest.  The fake run marks itself started as runner.execute does (a
    progress file) and asks for the drain from inside the first run."""
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": [1, 2, 3]}])
    rdir = engine.results_dir(sp)
    log_path = tmp_path / "ran.txt"
    inner = _fake_execute_logging_to(log_path)

    def fake_execute(run, settings):
        prog = runner.progress_path(settings["results_dir"], run["key"])
        runner.write_atomic(prog, json.dumps({"t": 0.0, "t_end": 1.0, "steps_per_s": 0.0, "eta_s": None}))
        try:
            if not log_path.exists():                      # the first run: the user asks for a drain now
                open(os.path.join(settings["results_dir"], engine.DRAIN), "w").close()
                import time
                time.sleep(6.0)                            # the driver sees it while this run is in flight
            return inner(run, settings)
        finally:
            os.remove(prog)

    monkeypatch.setattr(runner, "execute", fake_execute)
    lines = []
    rows = engine.sweep(sp, workers=1, allow_dirty=True, log=lines.append, progress_every=1.0)
    ran = log_path.read_text().splitlines()
    assert len(ran) == 1, ran                                          # the run in flight, nothing after it
    assert sorted(r["status"] for r in rows.values()) == ["done"] + ["todo"] * 5
    assert any("draining" in ln and "1 run(s) in flight finish, 5 queued run(s) cancelled" in ln for ln in lines), lines
    assert any(ln.startswith("[study] finished 1 runs") and "5 cancelled by the drain" in ln for ln in lines), lines
    man = manifest.read_manifest(rdir)
    assert sorted(r["status"] for r in man.values()) == ["done"] + ["todo"] * 5
    assert all(r["attempts"] in ("", "0", 0) for r in man.values() if r["status"] == "todo")   # not counted as tries
    assert os.path.exists(os.path.join(rdir, engine.DRAIN))            # left for a look; the next driver clears it
    lines2 = []
    rows2 = engine.sweep(sp, workers=1, allow_dirty=True, log=lines2.append, progress_every=1.0)
    assert all(r["status"] == "done" for r in rows2.values()) and len(log_path.read_text().splitlines()) == 6
    assert not os.path.exists(os.path.join(rdir, engine.DRAIN)) and not any("draining" in ln for ln in lines2)


def _drain_fake(log_path, asks_drain, hold=6.0, pause=0.0):
    """A fake runner.execute that keeps runner.execute's drain protocol (progress file first, then
    the drain check, returning the drained sentinel) and asks for a drain from inside the runs for
    which ``asks_drain(run)`` is true, holding them ``hold`` s so the driver sees it in flight."""
    inner = _fake_execute_logging_to(log_path)

    def fake_execute(run, settings):
        import time
        prog = runner.progress_path(settings["results_dir"], run["key"])
        runner.write_atomic(prog, json.dumps({"t": 0.0, "t_end": 1.0, "steps_per_s": 0.0, "eta_s": None}))
        try:
            if not asks_drain(run):
                time.sleep(pause)            # Dask has begun this run; the drain comes meanwhile
            if os.path.exists(os.path.join(settings["results_dir"], runner.DRAIN)):
                return {"drained": True}
            if asks_drain(run):
                open(os.path.join(settings["results_dir"], runner.DRAIN), "w").close()
                time.sleep(hold)
            return inner(run, settings)
        finally:
            os.remove(prog)
    return fake_execute


def test_a_run_that_began_after_the_drain_returns_untried_and_a_sequential_group_adds_no_seeds(tmp_path, monkeypatch):
    """Two paths of a drain: (1) a run Dask began before the driver saw the drain file finds the
    file itself and returns the drained sentinel, which the driver counts as cancelled, not as an
    attempt; (2) a sequential group whose last run finishes during the drain is not planned again
    (its new seeds would start: the driver cancels queued runs once, when it first sees the file)."""
    from studies import engine as eng
    g = {"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": [1],
         "target": {"case": "uncorrected", "halfwidth": 0.001, "batch": 2}, "max_seeds": 5}
    sp = spec_for(tmp_path, [g])
    log_path = tmp_path / "ran.txt"
    # (2): the second run of seed 1 asks for the drain; without the guard seeds 2 and 3 would run
    monkeypatch.setattr(runner, "execute", _drain_fake(log_path, lambda r: r["case"] == "uncorrected"))
    lines = []
    rows = engine.sweep(sp, workers=1, allow_dirty=True, log=lines.append, progress_every=1.0)
    assert len(log_path.read_text().splitlines()) == 2 and len(rows) == 2, lines
    assert any(ln.startswith("[study] drained") for ln in lines)
    # (1): a drain file already there when a run begins (here: asked by the planner's first call,
    # after the driver cleared stale files and before it submitted): nothing is submitted at all
    sp2 = spec_for(tmp_path / "b", [{"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": [1, 2]}])
    rdir2 = engine.results_dir(sp2)
    plan = eng._plan

    def plan_then_drain(spec, rdir, log):
        open(os.path.join(rdir, runner.DRAIN), "w").close()
        return plan(spec, rdir, log)
    monkeypatch.setattr(eng, "_plan", plan_then_drain)
    log2 = tmp_path / "ran2.txt"
    monkeypatch.setattr(runner, "execute", _drain_fake(log2, lambda r: False))
    lines = []
    rows = engine.sweep(sp2, workers=1, allow_dirty=True, log=lines.append, progress_every=1.0)
    assert not log2.exists() and all(r["status"] == "todo" for r in rows.values()), lines
    assert any("4 run(s) to do not submitted" in ln for ln in lines), lines
    monkeypatch.setattr(eng, "_plan", plan)
    # the sentinel through the driver: two workers begin seed 1's two runs together; the exact one
    # asks for the drain at once, the other finds the file 0.5 s later and returns untried
    os.remove(os.path.join(rdir2, runner.DRAIN))
    log3 = tmp_path / "ran3.txt"
    monkeypatch.setattr(runner, "execute", _drain_fake(log3, lambda r: r["case"] == "exact" and r["seed"] == 1,
                                                       hold=2.0, pause=0.5))
    lines = []
    rows = engine.sweep(sp2, workers=2, allow_dirty=True, log=lines.append, progress_every=1.0)
    assert log3.read_text().split() == ["1", "exact"], lines
    assert sorted(r["status"] for r in rows.values()) == ["done", "todo", "todo", "todo"]
    man = manifest.read_manifest(rdir2)
    assert all(r["attempts"] in ("", "0", 0) for r in man.values() if r["status"] == "todo"), man
    assert any(ln.startswith("[study] finished 1 runs") and "3 cancelled by the drain" in ln for ln in lines), lines


def test_may_start_reads_the_drain_file_as_now_or_a_deadline(tmp_path):
    rdir = str(tmp_path)
    run = {"expected_wall_s": 600.0}
    assert runner.drain_deadline(rdir) is None and runner.may_start(run, rdir)      # no drain
    path = tmp_path / runner.DRAIN
    path.write_text("")
    assert runner.drain_deadline(rdir) == 0.0 and not runner.may_start(run, rdir)     # drain now
    path.write_text("garbage")
    assert runner.drain_deadline(rdir) == 0.0 and not runner.may_start(run, rdir)     # unreadable: now
    now = 1.0e9
    path.write_text(f"{now + 1000}\n")
    assert runner.drain_deadline(rdir) == now + 1000
    assert runner.may_start(run, rdir, now=now)                               # 1.15 x 600 = 690 s fits
    assert not runner.may_start({"expected_wall_s": 900.0}, rdir, now=now)   # 1,035 s does not
    assert not runner.may_start({"expected_wall_s": None}, rdir, now=now)    # unknown length never fits
    assert not runner.may_start({}, rdir, now=now)
    assert not runner.may_start(run, rdir, now=now + 1001)                    # past the deadline


def test_a_new_driver_removes_an_old_drain_file_and_keeps_one_asked_after_its_lock(tmp_path, monkeypatch):
    import time as _time
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": [1]}])
    rdir = engine.results_dir(sp)
    os.makedirs(rdir, exist_ok=True)
    log_path = tmp_path / "ran.txt"
    monkeypatch.setattr(runner, "execute", _drain_fake(log_path, lambda r: False))
    drain = Path(rdir) / runner.DRAIN
    drain.write_text("")
    os.utime(drain, (_time.time() + 30, _time.time() + 30))       # stamped after the driver's lock
    lines = []
    rows = engine.sweep(sp, workers=1, allow_dirty=True, log=lines.append, progress_every=1.0)
    assert not log_path.exists() and all(r["status"] == "todo" for r in rows.values())
    assert any("2 run(s) to do not submitted" in ln for ln in lines), lines
    os.utime(drain, (_time.time() - 60, _time.time() - 60))       # a drain asked of an earlier driver
    rows = engine.sweep(sp, workers=1, allow_dirty=True, log=lambda s: None, progress_every=1.0)
    assert all(r["status"] == "done" for r in rows.values()) and not drain.exists()


def test_studies_run_skips_the_analysis_only_when_a_drain_left_runs_to_do(tmp_path, monkeypatch):
    from studies import __main__ as cli
    from studies import analysis
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact"], "seeds": [1]}])
    rdir = engine.results_dir(sp)
    os.makedirs(rdir, exist_ok=True)
    analysed = []
    monkeypatch.setattr(S, "load", lambda path: sp)
    monkeypatch.setattr(analysis, "single_gas_problem", lambda spec: None)
    monkeypatch.setattr(analysis, "analyze", lambda spec: analysed.append(1))
    from studies import gas_plots
    monkeypatch.setattr(gas_plots, "plot_all", lambda rdir_: None)
    from studies import study_page
    monkeypatch.setattr(study_page, "write", lambda rdir_: None)
    (Path(rdir) / runner.DRAIN).write_text("")
    for status, code, n in (("todo", 1, 0), ("done", 0, 1)):
        monkeypatch.setattr(engine, "sweep", lambda spec, **kw: {"k": {"status": status}})
        assert cli.main(["run", "synthetic"]) == code and len(analysed) == n


def test_may_start_estimates_a_run_from_the_records_finished_by_then(tmp_path):
    """Without a given estimate, a run's expected wall time is the median of the records on disk of
    runs like it when it is about to start (not when it was queued); another case's do not count."""
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": [1, 2, 3]}])
    rdir = engine.results_dir(sp)
    runs = S.runs(sp)
    later = [r for r in runs if r["seed"] == 3]
    rng = np.random.default_rng(2)
    os.makedirs(os.path.join(rdir, "runs"), exist_ok=True)
    (Path(rdir) / runner.DRAIN).write_text(f"{1.0e9 + 1000}")
    assert not any(runner.may_start(r, rdir, now=1.0e9) for r in later)        # nothing finished yet
    for r, wall in zip([r for r in runs if r["seed"] < 3], (500.0, 900.0, 500.0, 900.0)):
        fr, v0 = frames_of(rng, 12, 60.0, 0.5)
        write_record(rdir, r, fr, v0, [0.0], 20.0, wall_s=wall)
    by_case = {r["case"]: r for r in later}
    # seeds 1, 2: exact 500 and 500 s, uncorrected 900 and 900 s (zip order: exact, uncorrected per seed)
    walls = {c: design.expected_wall_s_in(rdir, by_case[c]["params"]) for c in by_case}
    assert walls == {"exact": 500.0, "uncorrected": 900.0}, walls
    assert runner.may_start(by_case["exact"], rdir, now=1.0e9)                  # 575 s fits in 1,000
    assert not runner.may_start(by_case["uncorrected"], rdir, now=1.0e9)        # 1,035 s does not


def test_expected_wall_time_of_a_new_stiffness_is_an_upper_bound_from_the_runs_at_another(tmp_path):
    """The first run at a new Young's modulus has no like run to time: its expected wall time is the
    runs' at another modulus or length, scaled by the run length and by the steps per simulated
    second when there are more of them (an upper bound), so a deadline drain can start it."""
    g = {"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": [1]}
    sp = spec_for(tmp_path, [dict(g, youngs_modulus=1e8, t_end=400.0, dt_factor=1.25)])
    ref = {c: S.resolve_run(sp, sp["groups"][0], c, 1) for c in g["cases"]}
    recs = {"a": {"params": ref["exact"], "wall_s": 600.0}, "b": {"params": ref["exact"], "wall_s": 800.0},
            "c": {"params": ref["mass_only"], "wall_s": 5000.0}}          # another case: never used
    sp9 = spec_for(tmp_path / "9", [dict(g, youngs_modulus=1e9, t_end=400.0, dt_factor=1.58)])
    p9 = S.resolve_run(sp9, sp9["groups"][0], "exact", 1)
    assert design._median_like(p9, recs, lambda r: r["wall_s"]) is None        # no run like it
    assert design.expected_wall_s(p9, recs) == pytest.approx(700.0 * math.sqrt(10.0) * 1.25 / 1.58, rel=1e-12)
    sp7 = spec_for(tmp_path / "7", [dict(g, youngs_modulus=1e7, t_end=1000.0, dt_factor=1.0)])
    p7 = S.resolve_run(sp7, sp7["groups"][0], "exact", 1)
    # fewer steps per second (r = 0.395): the run length's ratio alone, not the smaller r x 2.5
    assert design.expected_wall_s(p7, recs) == pytest.approx(700.0 * 2.5, rel=1e-12)
    # a shorter run at the same step density: never below the reference's whole wall time (its
    # fixed part, start-up and analysis, does not shrink with the run), not 0.5 x 700 s
    sp2 = spec_for(tmp_path / "2", [dict(g, youngs_modulus=1e8, t_end=200.0, dt_factor=1.25)])
    assert design.expected_wall_s(S.resolve_run(sp2, sp2["groups"][0], "exact", 1), recs) == pytest.approx(700.0)
    # another model version: not a bound (a newer model may be slower)
    p_new = dict(p9, model_version=(p9.get("model_version") or 0) + 1)
    assert design.expected_wall_s(p_new, recs) is None
    sp_ov = spec_for(tmp_path / "o", [dict(g, youngs_modulus=1e9, t_end=400.0, dt_factor=1.58)])
    sp_ov["shapes"] = {"dimer": dict(sp_ov["shapes"]["dimer"], overlap=0.25)}
    assert design.expected_wall_s(S.resolve_run(sp_ov, sp_ov["groups"][0], "exact", 1), recs) is None
    # the same through a deadline drain: 1.15 x 1,751 s = 2,014 s fits in 2,100 s, not in 1,900 s
    rdir = engine.results_dir(sp9)
    os.makedirs(rdir, exist_ok=True)
    run9 = {"params": p9}
    (Path(rdir) / runner.DRAIN).write_text(f"{1.0e9 + 2100}")
    assert not runner.may_start(run9, rdir, now=1.0e9)                      # no records in rdir yet
    os.makedirs(os.path.join(rdir, "runs"), exist_ok=True)
    for k, rec in recs.items():
        Path(rdir, "runs", k + ".json").write_text(json.dumps(rec))
    assert runner.may_start(run9, rdir, now=1.0e9)
    (Path(rdir) / runner.DRAIN).write_text(f"{1.0e9 + 1900}")
    assert not runner.may_start(run9, rdir, now=1.0e9)


def test_driver_under_a_deadline_starts_only_runs_that_fit(tmp_path, monkeypatch):
    """A deadline drain (BY=HH:MM scripts/sweep.sh drain) asked once the driver runs: runs whose
    expected wall time (the median of the finished runs like them: 600 s for the synthetic records)
    fits start and finish; runs of a case never run before (unknown length) stay to do, untried;
    the driver ends and says it drained."""
    import time as _time
    from studies import engine as eng
    g = {"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": [1]}
    sp = spec_for(tmp_path, [g])
    rdir = engine.results_dir(sp)
    log_path = tmp_path / "ran.txt"
    monkeypatch.setattr(runner, "execute", _drain_fake(log_path, lambda r: False))
    engine.sweep(sp, workers=1, allow_dirty=True, log=lambda s: None, progress_every=1.0)   # seed 1: known lengths
    sp2 = spec_for(tmp_path, [dict(g, cases=["exact", "uncorrected", "mass_only"], seeds=[1, 2, 3])])
    plan = eng._plan

    def plan_then_deadline(spec, rdir_, log):
        (Path(rdir_) / runner.DRAIN).write_text(f"{_time.time() + 750.0}")   # 690 s fits, once
        return plan(spec, rdir_, log)

    def fits_then_not(run, settings):      # the fake keeps runner.execute's protocol, with may_start
        prog = runner.progress_path(settings["results_dir"], run["key"])
        runner.write_atomic(prog, json.dumps({"t": 0.0, "t_end": 1.0, "steps_per_s": 0.0, "eta_s": None}))
        try:
            if not runner.may_start(run, settings["results_dir"]):
                return {"drained": True}
            return _fake_execute_logging_to(log_path)(run, settings)
        finally:
            os.remove(prog)
    monkeypatch.setattr(eng, "_plan", plan_then_deadline)
    monkeypatch.setattr(runner, "execute", fits_then_not)
    lines = []
    rows = engine.sweep(sp2, workers=1, allow_dirty=True, log=lines.append, progress_every=1.0)
    ran = [tuple(ln.split()) for ln in log_path.read_text().splitlines()]
    assert sorted(ran[2:]) == [("2", "exact"), ("2", "uncorrected"), ("3", "exact"), ("3", "uncorrected")], ran
    todo = sorted(r["name"].split("-")[1] for r in rows.values() if r["status"] == "todo")
    assert todo == ["mass_only"] * 3, rows
    man = manifest.read_manifest(rdir)
    assert all(r["attempts"] in ("", "0", 0) for r in man.values() if r["status"] == "todo")
    assert any(ln.startswith("[study] drain by") for ln in lines), lines
    assert any(ln.startswith("[study] drained") for ln in lines), lines
    assert any("3 cancelled by the drain" in ln for ln in lines), lines


def test_execute_marks_the_run_started_first_and_never_starts_yade_during_a_drain(tmp_path, monkeypatch):
    """runner.execute writes its progress file before anything else (a draining driver reads it as
    "in flight"), removes it if it fails before the work begins, and with a drain file present
    returns the drained sentinel without looking for YADE."""
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact"], "seeds": [1]}])
    (run,) = S.runs(sp)
    rdir = engine.results_dir(sp)
    settings = engine.settings_of(sp, rdir)
    prog = Path(runner.progress_path(rdir, run["key"]))
    seen = []

    def no_yade(*a, **k):
        seen.append(prog.exists())
        raise runner.RunError("no YADE here")
    monkeypatch.setattr(runner, "yade_command", no_yade)
    with pytest.raises(runner.RunError, match="no YADE here"):
        runner.execute(run, settings)
    assert seen == [True] and not prog.exists()
    (Path(rdir) / runner.DRAIN).write_text("")
    seen.clear()
    assert runner.execute(run, settings) == {"drained": True}
    assert seen == [] and not prog.exists()


def test_round_robin_schedule_gives_every_group_its_seeds_before_extending_one(tmp_path, monkeypatch):
    """``schedule = "round_robin"``: a sequential group that keeps adding seeds (target out of reach)
    does not starve a later group; the later group's four seeds all run before the first group's
    fifth and sixth (rank 4, 5), but for a run already on the worker.  Under ``in_order`` the later
    group ran last (the test above)."""
    g0 = {"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": [1, 2],
          "target": {"case": "uncorrected", "halfwidth": 0.001, "batch": 2}, "max_seeds": 6}
    g1 = {"shape": "dimer", "cases": ["exact", "mass_only"], "seeds": list(range(11, 15))}
    sp = spec_for(tmp_path, [g0, g1], schedule="round_robin")
    assert sp["study"]["schedule"] == "round_robin"
    log_path = tmp_path / "order.txt"
    monkeypatch.setattr(runner, "execute", _fake_execute_logging_to(log_path))
    rows = engine.sweep(sp, workers=1, allow_dirty=True, log=lambda s: None, progress_every=1.0)
    order = [int(ln.split()[0]) for ln in log_path.read_text().splitlines()]
    assert len(order) == 6 * 2 + 4 * 2 and all(r["status"] == "done" for r in rows.values())
    last_g1 = max(i for i, s in enumerate(order) if s >= 10)
    first_late_g0 = min(i for i, s in enumerate(order) if s in (5, 6))
    assert last_g1 < first_late_g0 + 2, order
    # and the first round: seed 1 and seed 11 before anything of rank 2 or later
    assert max(order.index(1), order.index(11)) < min(order.index(s) for s in (3, 13)), order


def test_rates_recover_known_relaxation_times_and_their_d_ratio(tmp_path):
    """studies.rates on OU walkers with known tau (exact 25 s, uncorrected 27.5 s with 10 % smaller
    <v^2>): the gas tau of each case within its interval of the truth, gas / map - 1 ~ 0 against a
    map that predicts the truth, and the D ratio from the first seconds (0.9 x 1.1 - 1 = -1 %) within
    its paired interval.  Runs from the paper's zero-spin start are left out."""
    from studies import rates

    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": list(range(1, 7))}],
                  start="equipartition", max_lag=60.0)     # the lags the records below store
    rng = np.random.default_rng(41)
    truth = {"exact": (25.0, 1.0), "uncorrected": (27.5, 0.9)}          # tau, <v^2> scale
    for run in S.runs(sp):
        tau, v2 = truth[run["case"]]
        vel, pos = synthetic.simulate_ou(rng, 216, 1201, 0.25, tau, SIGMA_V * math.sqrt(v2))
        t = np.arange(1201) * 0.25
        e_t = np.sum(vel ** 2, axis=(1, 2))
        fr = {"t": t, "disp": pos.astype(np.float32), "vel": vel.astype(np.float32), "e_trans": e_t,
              "e_rot": e_t * 2 / 3, "e_elastic": np.zeros(1201), "momentum": np.zeros((1201, 3))}
        write_record(engine.results_dir(sp), run, fr, vel[0], [0.0], 60.0)
    n = sp["gas"]["n_particles"] / 10.0 ** 3                               # write_record's box: 10 m
    m = {"file": "map.json", "shape": dict(sp["shapes"]["dimer"]), "material": dict(sp["material"]),
         "energy_per_particle": sp["gas"]["energy_per_particle"],
         "relaxation_time_n": {"exact/paired": {"value": 25.0 * n, "se": 0.1 * n},
                               "uncorrected/paired": {"value": 27.5 * n, "se": 0.1 * n}},
         "rows": [{"case": "uncorrected", "protocol": "paired", "relative": 0.9 * 1.1 - 1.0, "se": 0.001}]}
    collected = effects.collect([sp])
    rows = {r["case"]: r for r in rates.rows(collected, [m])}
    for case, (tau, _) in truth.items():
        r = rows[case]
        assert r["n_seeds"] == 6 and r["gas_ci_low"] <= tau <= r["gas_ci_high"], r
        assert r["map_tau"] == pytest.approx(tau) and abs(r["relative"]) < 0.02
    (rr,) = rates.ratio_rows(collected, [m])
    assert rr["case"] == "uncorrected" and rr["n_pairs"] == 6
    assert rr["gas_ci_low"] <= 0.9 * 1.1 - 1.0 <= rr["gas_ci_high"], rr
    assert rr["map_relative"] == pytest.approx(-0.01)
    assert rr["shape_n_pairs"] == 6                     # its values: test_rates_shape_factor_ratio_*
    rec0 = json.loads(next((Path(engine.results_dir(sp)) / "runs").glob("*.json")).read_text())
    assert math.isfinite(rates.run_shape_factor(rec0))
    rec0["windows"][0]["vacf"] = rec0["windows"][0]["vacf"][:20]   # 5 s of lags: no Green-Kubo D, a NaN
    assert math.isnan(rates.run_shape_factor(rec0))
    # runs of the same seeds with other parameters (another run length) are no pairs of these:
    # their uncorrected walkers (tau 50 s) must not be paired with the exact runs above (before the
    # fix they replaced this study's uncorrected runs seed by seed, and the ratio moved to ~+0.8)
    sp2 = spec_for(tmp_path / "other", [{"shape": "dimer", "cases": ["exact", "uncorrected"], "seeds": list(range(1, 7))}],
                   start="equipartition")
    sp2["run"]["t_end"] = 500.0
    for run in S.runs(sp2):
        assert run["params"]["run"]["t_end"] == 500.0
        if run["case"] != "uncorrected":
            continue
        vel, pos = synthetic.simulate_ou(rng, 216, 1201, 0.25, 50.0, SIGMA_V * math.sqrt(0.9))
        e_t = np.sum(vel ** 2, axis=(1, 2))
        fr = {"t": np.arange(1201) * 0.25, "disp": pos.astype(np.float32), "vel": vel.astype(np.float32),
              "e_trans": e_t, "e_rot": e_t * 2 / 3, "e_elastic": np.zeros(1201), "momentum": np.zeros((1201, 3))}
        write_record(engine.results_dir(sp2), run, fr, vel[0], [0.0], 120.0)
    assert rates.ratio_rows(effects.collect([sp, sp2]), [m]) == [rr]
    assert rates.ratio_rows(effects.collect([sp2, sp]), [m]) == [rr]
    both = {r["case"]: r for r in rates.rows(effects.collect([sp, sp2]), [m])}
    only2 = {r["case"]: r for r in rates.rows(effects.collect([sp2]), [m])}
    # records read once beforehand (the report's planned pass) give the same rows as collect reading
    # them itself, matched to their spec by position (both specs here have the path "synthetic")
    pre = [design.load_records(s, engine.results_dir(s)) for s in (sp, sp2)]
    assert rates.ratio_rows(effects.collect([sp, sp2], pre), [m]) == [rr]
    assert {r["case"]: r for r in rates.rows(effects.collect([sp, sp2], pre), [m])} == both
    assert rates.ratio_rows(effects.collect([sp2, sp], pre[::-1]), [m]) == [rr]
    with pytest.raises(ValueError, match="1 record sets for 2 specs"):
        effects.collect([sp, sp2], pre[:1])
    assert both["exact"] == rows["exact"] and both["uncorrected"]["n_seeds"] == 6   # one run per seed,
    assert both["uncorrected"]["gas_tau"] in (rows["uncorrected"]["gas_tau"], only2["uncorrected"]["gas_tau"])  # one key
    sp0 = spec_for(tmp_path / "z", [{"shape": "dimer", "cases": ["exact"], "seeds": [1]}], start="zero_spin")
    for run in S.runs(sp0):
        fr, v0 = frames_of(rng, 24, 250.0, 0.5)
        write_record(engine.results_dir(sp0), run, fr, v0, [0.0], 100.0)
    assert rates.rows(effects.collect([sp0]), [m]) == []


def test_rates_shape_factor_ratio_is_zero_for_exponential_vacfs_and_sees_a_mixture(tmp_path, monkeypatch):
    """The shape factors' ratio of :func:`studies.rates.ratio_rows` on OU walkers: mass_only (one
    exponential, tau 27.5 s) against exact (one exponential, 25 s) has ratio 1 (D = C(0) tau / 3 for
    both); uncorrected, half its walkers at tau 15 s and half at 35 s, has C(t) = C(0) (e^-t/15 +
    e^-t/35) / 2, so D = C(0) 25 s / 3 while its first seconds decay at the mean rate, tau_init = 21 s:
    shape factor 25/21, +19.0 % against exact (less what the estimator's exponential tail misses of
    the mixture's slower part, computed here on the noise-free curve)."""
    from studies import rates

    seeds = list(range(1, 7))
    sp = spec_for(tmp_path, [{"shape": "dimer", "cases": ["exact", "mass_only", "uncorrected"], "seeds": seeds}],
                  start="equipartition")
    rng = np.random.default_rng(5)
    nw, nf, dt = 432, 2401, 0.25                                         # 600 s runs
    for run in S.runs(sp):
        if run["case"] == "uncorrected":
            parts = [synthetic.simulate_ou(rng, nw // 2, nf, dt, tau, SIGMA_V) for tau in (15.0, 35.0)]
            vel, pos = (np.concatenate([a[i] for a in parts], axis=1) for i in (0, 1))
        else:
            tau, v2 = (25.0, 1.0) if run["case"] == "exact" else (27.5, 0.9)
            vel, pos = synthetic.simulate_ou(rng, nw, nf, dt, tau, SIGMA_V * math.sqrt(v2))
        e_t = np.sum(vel ** 2, axis=(1, 2))
        fr = {"t": np.arange(nf) * dt, "disp": pos.astype(np.float32), "vel": vel.astype(np.float32), "e_trans": e_t,
              "e_rot": e_t * 2 / 3, "e_elastic": np.zeros(nf), "momentum": np.zeros((nf, 3))}
        write_record(engine.results_dir(sp), run, fr, vel[0], [0.0], 100.0)
    n = sp["gas"]["n_particles"] / 10.0 ** 3
    m = {"file": "map.json", "shape": dict(sp["shapes"]["dimer"]), "material": dict(sp["material"]),
         "energy_per_particle": sp["gas"]["energy_per_particle"],
         "relaxation_time_n": {f"{c}/paired": {"value": 25.0 * n, "se": 0.1 * n} for c in ("exact", "mass_only", "uncorrected")},
         "rows": [{"case": c, "protocol": "paired", "relative": 0.0, "se": 0.001} for c in ("mass_only", "uncorrected")]}
    rr = {r["case"]: r for r in rates.ratio_rows(effects.collect([sp]), [m])}
    one = rr["mass_only"]
    assert one["shape_n_pairs"] == 6 and one["shape_ci_low"] < 0.0 < one["shape_ci_high"], one
    assert one["shape_ci_high"] - one["shape_ci_low"] < 0.10, one                # about 3.5 % sd a pair
    # the mixture, noise-free, through the estimator: its tail model misses a little of the 35 s part
    lag = np.arange(401) * dt
    c_mix = 3 * SIGMA_V ** 2 * (np.exp(-lag / 15.0) + np.exp(-lag / 35.0)) / 2
    c_one = 3 * SIGMA_V ** 2 * np.exp(-lag / 25.0)
    f_mix = diffusion.diffusion_green_kubo(lag, c_mix) / (c_mix[0] * diffusion.initial_decay_time(lag, c_mix) / 3)
    f_one = diffusion.diffusion_green_kubo(lag, c_one) / (c_one[0] * diffusion.initial_decay_time(lag, c_one) / 3)
    expect = f_mix / f_one - 1.0
    assert 0.14 < expect <= 25.0 / 21.0 - 1.0 + 0.005, expect      # the closed form, less the missed tail
    mix = rr["uncorrected"]
    assert mix["shape_n_pairs"] == 6 and mix["shape_ci_low"] <= expect <= mix["shape_ci_high"], (mix, expect)
    assert mix["shape_ci_low"] > 0.1, mix                            # resolved, far from zero
    # a run whose shape factor is NaN (no Green-Kubo D) leaves its pair out of the shape ratio only
    orig = rates.run_shape_factor
    monkeypatch.setattr(rates, "run_shape_factor", lambda rec, **kw: math.nan if rec["seed"] == 2 else orig(rec, **kw))
    rr2 = {r["case"]: r for r in rates.ratio_rows(effects.collect([sp]), [m])}
    assert rr2["uncorrected"]["shape_n_pairs"] == 5 and rr2["uncorrected"]["n_pairs"] == 6
    assert rr2["uncorrected"]["gas_relative"] == mix["gas_relative"]


def test_state_key_is_the_initial_state():
    """Exact runs that start from the same state (studies.spec.run_input's initial arrays) share a
    state key whatever their YADE version, time step, length, stiffness or protocol; another gas
    or shape gives another key and another state."""
    sp = spec_for(Path("/nonexistent"), [{"shape": "dimer", "cases": ["exact"], "seeds": [3]}])
    g = sp["groups"][0]
    base = S.resolve_run(sp, g, "exact", 3)
    init = S.run_input(base)["initial"]
    same = [dict(base, yade="2025.2", clumpprops_version="9.9"),
            dict(base, run=dict(base["run"], dt_factor=0.25, t_end=50.0)),
            dict(base, material=dict(base["material"], youngs_modulus=1e9)),
            dict(base, gas=dict(base["gas"], spin_pairing="same"))]
    for p in same:
        assert effects.state_key(p) == effects.state_key(base)
        assert S.run_input(p)["initial"] == init
    other = [dict(base, gas=dict(base["gas"], energy_per_particle=2.0)),
             dict(base, material=dict(base["material"], density=2000.0))]
    for p in other:
        assert effects.state_key(p) != effects.state_key(base)
        assert S.run_input(p)["initial"]["vel"] != init["vel"]


def test_fig2_tables_refuse_a_spec_of_several_gases(capsys):
    """The Fig. 2 tables are keyed by case, protocol and seed: a spec whose groups run different gases
    (shapes, stiffnesses, sizes, a group's own time step) would mix them.  `analyze` refuses it, and
    `python -m studies analyze` says where its answers are and exits 1 before reading any record;
    the study's own time step and its legacy step pool (one gas)."""
    from studies.__main__ import main
    for name in ("paper", "dimer_paired", "dimer_equal_energy", "test"):
        assert analysis.single_gas_problem(S.load(f"{S.SPEC_DIR}/{name}.toml")) is None
    shapes = S.load(f"{S.SPEC_DIR}/shapes.toml")
    msg = analysis.single_gas_problem(shapes)
    assert msg and "4 different gases" in msg and "results/effects.csv" in msg
    with pytest.raises(ValueError, match="4 different gases"):
        analysis.analyze(shapes)
    with open(f"{S.SPEC_DIR}/paper.toml", "rb") as f:
        raw = tomllib.load(f)
    raw["groups"][1]["dt_factor"] = 0.25                 # a convergence check inside the spec
    assert "2 different gases" in analysis.single_gas_problem(S.validate(raw))
    assert main(["analyze", f"{S.SPEC_DIR}/sphere_gas_size.toml"]) == 1
    err = capsys.readouterr().err
    assert "N = 108; dimer at E = 1e+07 Pa, N = 288" in err and "studies.sphere_gas --spec" in err
