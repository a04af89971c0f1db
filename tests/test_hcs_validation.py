"""studies.hcs_validation on synthetic runs whose answer is known (no YADE)."""
import json
import math

import numpy as np
import pytest

from studies import hcs, hcs_validation as V

N, BOX, SIGMA, MASS = 200, 8.0, 0.2, 5.0


def _run_file(e, mu):
    return {"initial": {"pos": [[0.0, 0.0, 0.0]] * N}, "box_length": BOX,
            "body": {"builder": "sphere", "route": "isotropic", "radius": SIGMA / 2, "mass": MASS},
            "material": {"restitution": e, **({"friction": mu} if mu else {})}}


def _frames(rng, t0, tau0, d0, ratio=0.0):
    t = np.linspace(0.0, 3 * tau0, 301)
    temp = t0 / (1 + t / tau0) ** 2
    msd = 6 * d0 * tau0 * np.log1p(t / tau0)
    u = rng.normal(size=(N, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    return {"t": t, "e_trans": 1.5 * N * temp, "e_rot": 1.5 * N * ratio * temp,
            "pos0": rng.uniform(0, BOX, (N, 3)), "disp": np.sqrt(msd)[:, None, None] * u[None]}


def test_smooth_runs_that_follow_theory_agree_with_it(tmp_path):
    rng = np.random.default_rng(4)
    rin = _run_file(0.9, 0.0)
    t0 = 2.0
    th = V.smooth_theory(hcs.series({**_frames(rng, t0, 1.0, 0.0), "e_trans": [1.5 * N * t0]}, rin))
    for seed in range(3):
        frames = _frames(rng, t0, 2 / th["zeta0"] * (1 + 0.01 * (seed - 1)), th["d0"])
        np.savez(tmp_path / f"s{seed}.npz", **frames)
        (tmp_path / f"s{seed}.run.json").write_text(json.dumps(rin))
    rows = V.rows(V.load_raw(str(tmp_path)))
    by = {r["observable"]: r for r in rows}
    assert set(by) == {"cooling_rate", "diffusion"}
    assert by["cooling_rate"]["ci_low"] <= th["zeta0"] <= by["cooling_rate"]["ci_high"]
    assert by["cooling_rate"]["measured"] == pytest.approx(by["cooling_rate"]["theory"], rel=2e-3)
    assert by["diffusion"]["measured"] == pytest.approx(th["d0"], rel=0.02)
    assert set(rows[0]) == set(V.COLUMNS)


def test_rough_runs_give_the_ratio_row():
    rng = np.random.default_rng(5)
    runs = [hcs.series(_frames(rng, 2.0, 5.0, 0.1, ratio=0.45), _run_file(0.9, 0.5)) for _ in range(2)]
    rows = V.rows(runs, ratio_theory=lambda e, mu: 0.5)
    assert len(rows) == 1 and rows[0]["observable"] == "temperature_ratio"
    assert rows[0]["measured"] == pytest.approx(0.45) and rows[0]["theory"] == 0.5
    assert math.isnan(V.rows(runs)[0]["theory"])


def test_clumps_are_refused():
    rin = _run_file(0.9, 0.0)
    rin["body"]["builder"] = "clumpprops"
    with pytest.raises(ValueError, match="sphere"):
        V.rows([hcs.series(_frames(np.random.default_rng(1), 1.0, 5.0, 0.1), rin)])


def test_records_keep_what_the_validation_needs(tmp_path):
    """A dissipative run's reduced record holds its HCS series, and the rows from the records
    equal the rows from the raw frames."""
    from studies import reduce as red
    rng = np.random.default_rng(6)
    rin = _run_file(0.9, 0.0)
    rin["initial"]["vel"] = rng.normal(size=(N, 3)).tolist()
    raw = []
    (tmp_path / "runs").mkdir()
    for seed in range(3):
        fr = _frames(rng, 2.0, 6.0 + seed, 0.05)
        n_f = len(fr["t"])
        fr.update(vel=np.zeros((n_f, N, 3)), e_elastic=np.zeros(n_f), momentum=np.zeros((n_f, 3)),
                  e_dissipated=fr["e_trans"][0] - fr["e_trans"])
        rin["body"]["mass"] = MASS
        rec = red.reduce_run(fr, rin, [0.0], 1.0, 0.2, 1e-9)
        assert set(rec["hcs"]) >= {"t", "e_trans", "e_rot", "msd", "count_ratio", "builder", "restitution"}
        (tmp_path / "runs" / f"s{seed}.json").write_text(json.dumps(rec))
        raw.append(hcs.series(fr, rin))
    from_records, from_raw = V.rows(V.load_records(str(tmp_path))), V.rows(raw)
    assert [r["observable"] for r in from_records] == ["cooling_rate", "diffusion"]
    for a, b in zip(from_records, from_raw):
        assert a["measured"] == pytest.approx(b["measured"], rel=1e-8)
        assert a["theory"] == pytest.approx(b["theory"], rel=1e-8)


def test_the_command_writes_the_table_from_the_records(tmp_path, capsys):
    """`python -m studies hcs-validation SPEC` reads the study's records and writes the CSV with
    the issue's columns (smooth spheres here: their theory needs no YADE)."""
    import csv
    import os
    from studies import reduce as red
    from studies import spec as S
    text = open(os.path.join(S.SPEC_DIR, "hcs_test.toml")).read()
    text = text.replace('results = "results/hcs_test"', f'results = "{tmp_path / "res"}"')
    text = text[:text.rindex("[[groups]]")]                      # the smooth group only
    spec = tmp_path / "smooth.toml"
    spec.write_text(text)
    rng = np.random.default_rng(8)
    rin = _run_file(0.9, 0.0)
    rin["initial"]["vel"] = rng.normal(size=(N, 3)).tolist()
    (tmp_path / "res" / "runs").mkdir(parents=True)
    zeta = V.smooth_theory(hcs.series({**_frames(rng, 2.0, 1.0, 0.0), "e_trans": [1.5 * N * 2.0]}, rin))["zeta0"]
    for seed in range(3):
        fr = _frames(rng, 2.0, 2.0 / zeta * (1 + 0.01 * (seed - 1)), 0.05)
        n_f = len(fr["t"])
        fr.update(vel=np.zeros((n_f, N, 3)), e_elastic=np.zeros(n_f), momentum=np.zeros((n_f, 3)),
                  e_dissipated=fr["e_trans"][0] - fr["e_trans"])
        rec = red.reduce_run(fr, rin, [0.0], 1.0, 0.2, 1e-9)
        (tmp_path / "res" / "runs" / f"s{seed}.json").write_text(json.dumps(rec))
    out = tmp_path / "hcs_theory.csv"
    assert V.main([str(spec), "--out", str(out)]) == 0
    with open(out) as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == V.COLUMNS and [r["observable"] for r in rows] == ["cooling_rate", "diffusion"]
    assert float(rows[0]["ci_low"]) <= zeta <= float(rows[0]["ci_high"])
    assert "hcs_theory.csv" in capsys.readouterr().out
    empty = tmp_path / "empty.toml"
    empty.write_text(text.replace(str(tmp_path / "res"), str(tmp_path / "none")))
    assert V.main([str(empty), "--out", str(tmp_path / "x.csv")]) == 1


def _relaxing(rng, r_hcs, r0, lam, seed):
    """A rough run whose T_rot / T_tr relaxes from r0 to r_hcs as exp(-lam t), with frame noise."""
    t = np.linspace(0.0, 20.0, 401)
    temp = 2.0 / (1 + t / 6.0) ** 2
    r = r_hcs + (r0 - r_hcs) * np.exp(-lam * t) + 0.002 * rng.normal(size=t.size)
    rin = _run_file(0.9, 0.5)
    fr = {"t": t, "e_trans": 1.5 * N * temp, "e_rot": 1.5 * N * r * temp, "pos0": rng.uniform(0, BOX, (N, 3)),
          "disp": np.zeros((t.size, N, 3))}
    return dict(hcs.series(fr, rin), seed=seed)


def test_runs_from_both_sides_bracket_the_settled_ratio():
    """Runs stopped long before T_rot / T_tr settles (exp(-0.1 t) is 0.14 at 20 s): each side's
    window mean is far off, the bracketed estimate is not, at any window start."""
    rng = np.random.default_rng(8)
    below = [_relaxing(rng, 0.66, 0.0, 0.1, k) for k in range(4)]
    above = [_relaxing(rng, 0.66, 1.0, 0.1, k) for k in range(4)]
    for t_lo in (5.0, 10.0, 15.0):
        got = [V.bracketed_ratio(b, a, t_lo) for b, a in zip(below, above)]
        assert np.mean(got) == pytest.approx(0.66, abs=3e-3)
    assert V.start_ratio(below[0]) == pytest.approx(0.0, abs=0.01) and V.start_ratio(above[0]) > 0.9
    rows = V.rows(below + above, ratio_theory=lambda e, mu: 0.66, t_transient=10.0)
    assert rows[0]["ci_low"] <= 0.66 <= rows[0]["ci_high"] and rows[0]["ci_high"] - rows[0]["ci_low"] < 0.02
    one_side = V.rows(below, t_transient=10.0)[0]["measured"]
    assert one_side < 0.62                      # without the bracket: biased low by the transient


def _direct(t, r, seed):
    temp = 2.0 / (1 + t / 6.0) ** 2
    return {"t": t, "e_trans": 1.5 * N * temp, "e_rot": 1.5 * N * r * temp, "count_ratio": np.ones_like(t),
            "cells_per_side": 4, "n_particles": N, "rot_dof": 3, "seed": seed}


def test_the_bracketed_interval_covers_the_settled_ratio_at_its_nominal_rate():
    """200 synthetic studies of 8 seed pairs: each seed's gas settles to its own ratio (spread 0.02
    about 0.66, as seeds differ) with frame noise; the 95 % Student-t interval over the seeds'
    bracketed estimates holds 0.66 in 95 % of them, within binomial limits."""
    rng = np.random.default_rng(9)
    t = np.linspace(0.0, 20.0, 201)
    hits = 0
    for _ in range(200):
        vals = []
        for k in range(8):
            r_k, lam = 0.66 + 0.02 * rng.normal(), 0.1 * (1 + 0.2 * rng.normal())
            b = r_k * (1 - np.exp(-lam * t)) + 0.005 * rng.normal(size=t.size)
            a = r_k + (1 - r_k) * np.exp(-lam * t) + 0.005 * rng.normal(size=t.size)
            b[0], a[0] = 0.0, 1.0
            vals.append(V.bracketed_ratio(_direct(t, b, k), _direct(t, a, k), 10.0))
        _, lo, hi, _, _ = V.t_interval(vals)
        hits += lo <= 0.66 <= hi
    assert 0.95 * 200 - 3 * math.sqrt(200 * 0.95 * 0.05) <= hits <= 200


def test_the_committed_rough_runs_give_one_settled_ratio_from_any_window_start():
    """The linear-relaxation check on the committed hcs_spheres records (docs/hcs.md): the
    bracketed estimate from window starts 5 s to 19 s falls inside every other start's interval."""
    import os
    from studies import spec as S
    runs = [s for s in V.load_records(os.path.join(S.ROOT, "results", "hcs_spheres")) if s["friction"] > 0]
    if len({s["seed"] for s in runs}) * 2 > len(runs):
        pytest.skip("no seed of the committed rough runs was run from both sides")
    got = [V.rows(runs, t_transient=t)[0] for t in (5.0, 10.0, 15.0, 19.0)]
    for a in got:
        for b in got:
            assert b["ci_low"] <= a["measured"] <= b["ci_high"]


def test_the_bracket_compares_the_runs_at_equal_collision_counts():
    """The spinning run cools from a higher T_tr and relaxes faster in time; in collision counts both
    relax alike.  Compared at equal times the estimate would be biased; at equal counts it is not."""
    t = np.linspace(0.0, 20.0, 801)

    def run(r0, t_tr, seed):
        g = np.sqrt(t_tr / t_tr[0])
        c = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(t))])
        r = 0.66 + (r0 - 0.66) * np.exp(-0.3 * c)
        return {"t": t, "e_trans": 1.5 * N * t_tr, "e_rot": 1.5 * N * r * t_tr, "count_ratio": np.ones_like(t),
                "cells_per_side": 4, "n_particles": N, "rot_dof": 3, "seed": seed}

    below = run(0.0, 2.0 / (1 + t / 6.0) ** 2, 1)
    above = run(1.0, 2.0 / (1 + t / 4.0) ** 2, 1)
    for t_lo in (2.0, 5.0, 10.0):
        assert V.bracketed_ratio(below, above, t_lo) == pytest.approx(0.66, abs=1e-3)
    assert not math.isnan(V.bracketed_ratio(below, above, 0.0))       # the start's 0/0 is left out
