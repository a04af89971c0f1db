"""The event-driven hard-sphere engine (studies/hsmd/hsmd.cpp, studies/hard_sphere_md.py).

Independent routes: a brute-force event loop written here (every pair, every periodic image, the
globally earliest collision each step, no cells, no queue); the conservation laws; no overlap at
any frame; and the equilibrium collision rate of hard spheres, exactly Enskog's chi n pi sigma^2
<g> with chi the contact value of the pair correlation (Carnahan-Starling, accurate to a few 0.1 %
at the densities used here).
"""
import math
import shutil
import numpy as np
import pytest

pytestmark = pytest.mark.skipif(shutil.which("g++") is None, reason="needs g++ to build the engine")

from studies import hard_sphere_md as H  # noqa: E402
from studies import kinetic as K  # noqa: E402


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    return H.library(build_dir=str(tmp_path_factory.mktemp("hsmd")))


def brute_force(pos, vel, box, sigma, frames, frame_dt):
    """Reference: at each step the earliest collision over all pairs and the images -2..2 of
    each; returns unwrapped positions and velocities at the frames."""
    x, v = pos.copy(), vel.copy()
    n = len(x)
    shifts = np.array([(a, b, c) for a in range(-2, 3) for b in range(-2, 3) for c in range(-2, 3)], float) * box
    t, out_x, out_v = 0.0, [], []
    for f in range(frames):
        t_frame = f * frame_dt
        while True:
            best, pair = math.inf, None
            for i in range(n):
                for j in range(i + 1, n):
                    d = x[i] - x[j]
                    dr = (d - box * np.round(d / box))[None, :] + shifts
                    dv = v[i] - v[j]
                    b = dr @ dv
                    c = np.einsum("ki,ki->k", dr, dr) - sigma ** 2
                    a = dv @ dv
                    disc = b * b - a * c
                    ok = (b < 0) & (disc > 0)
                    if ok.any():
                        tc = ((-b[ok] - np.sqrt(disc[ok])) / a).min()
                        if tc < best:
                            best, pair = tc, (i, j, shifts[ok][np.argmin((-b[ok] - np.sqrt(disc[ok])) / a)])
            if t + best > t_frame:
                break
            x += v * best
            t += best
            i, j, s = pair
            d = x[i] - x[j]
            dr = d - box * np.round(d / box) + s
            dvn = (v[i] - v[j]) @ dr / (dr @ dr)
            v[i] -= dvn * dr
            v[j] += dvn * dr
        x += v * (t_frame - t)
        t = t_frame
        out_x.append(x.copy())
        out_v.append(v.copy())
    return np.array(out_x), np.array(out_v)


def test_the_engine_follows_the_brute_force_event_loop(lib):
    rng = np.random.default_rng(3)
    n, box, sigma = 10, 3.0, 0.45
    pos, vel = H.initial_state(rng, n, box, sigma, kT=1.0, m=1.0)
    # the gas is chaotic: round-off differences grow ~10x per collision here, so the comparison
    # stops after 4 s (~15 collisions, differences still ~1e-11; 2e-4 after 10 s)
    ref_x, ref_v = brute_force(pos, vel, box, sigma, frames=17, frame_dt=0.25)
    for n_cells in (4, 6):                                     # the fewest cells allowed, and more
        out = H.simulate(pos, vel, box, sigma, 17, frame_dt=0.25, n_cells=n_cells, lib=lib)
        assert out["n_coll"] >= 12                             # the comparison covers many collisions
        assert np.max(np.abs(out["vel"] - ref_v)) < 1e-9
        assert np.max(np.abs(out["pos"] - (ref_x - ref_x[0] + out["pos"][0]))) < 1e-9


def test_many_cells_follow_the_brute_force_event_loop(lib):
    """30 spheres in a box of 12 sigma on 12 cells per side: collisions across cell faces, edges
    and corners, and through the periodic boundary."""
    rng = np.random.default_rng(8)
    n, sigma, box = 30, 1.0, 12.0
    pos, vel = H.initial_state(rng, n, box, sigma, kT=1.0, m=1.0)
    ref_x, ref_v = brute_force(pos, vel, box, sigma, frames=13, frame_dt=0.5)
    out = H.simulate(pos, vel, box, sigma, 13, frame_dt=0.5, n_cells=12, lib=lib)
    assert out["n_coll"] >= 5
    assert np.max(np.abs(out["vel"] - ref_v)) < 1e-9
    assert np.max(np.abs(out["pos"] - (ref_x - ref_x[0] + out["pos"][0]))) < 1e-9


def test_touching_and_approaching_spheres_collide_at_once(lib):
    """Round-off can leave a pair exactly in contact and approaching: it collides now (and only
    once), it never passes through; a touching pair moving apart does not collide."""
    pos = np.array([[2.0, 2.0, 2.0], [3.0, 2.0, 2.0]])           # |r| = sigma exactly
    vel = np.array([[0.5, 0.1, 0.0], [-0.5, 0.0, 0.0]])
    out = H.simulate(pos, vel, 10.0, 1.0, 2, frame_dt=0.5, check_gaps=True, lib=lib)
    assert out["n_coll"] == 1 and out["min_gap"] >= -1e-12
    assert np.allclose(out["vel"][-1], [[-0.5, 0.1, 0.0], [0.5, 0.0, 0.0]], rtol=0, atol=1e-15)
    out = H.simulate(pos, -vel, 10.0, 1.0, 2, frame_dt=0.5, lib=lib)
    assert out["n_coll"] == 0


def test_conservation_and_no_overlap_in_a_dense_gas(lib):
    rng = np.random.default_rng(5)
    n, sigma, phi = 256, 1.0, 0.25
    box = (n * math.pi / 6.0 / phi) ** (1.0 / 3.0)
    pos, vel = H.initial_state(rng, n, box, sigma, kT=1.0, m=1.0)
    out = H.simulate(pos, vel, box, sigma, 41, frame_dt=0.25, check_gaps=True, lib=lib)
    assert out["n_coll"] > 10 * n
    e = np.einsum("tni,tni->t", out["vel"], out["vel"])
    p = out["vel"].sum(axis=1)
    assert np.max(np.abs(e / e[0] - 1.0)) < 1e-12
    assert np.max(np.abs(p)) < 1e-11 * math.sqrt(e[0])
    assert -1e-9 < out["min_gap"] < 0.05                        # touching, never overlapping


def test_collision_rate_is_enskogs(lib):
    """At phi = 0.1 the rate is chi = 1.303 times Boltzmann's; measured over ~90k collisions (the
    1 % tolerance is ~3 standard errors)."""
    rng = np.random.default_rng(11)
    n, sigma, phi, kT, m = 500, 1.0, 0.1, 1.0, 1.0
    box = (n * math.pi / 6.0 / phi) ** (1.0 / 3.0)
    pos, vel = H.initial_state(rng, n, box, sigma, kT, m)
    warm = H.simulate(pos, vel, box, sigma, 2, frame_dt=20.0, lib=lib)           # to equilibrium
    out = H.simulate(warm["pos"][-1], warm["vel"][-1], box, sigma, 2, frame_dt=200.0, lib=lib)
    rate = 2.0 * out["n_coll"] / (n * 200.0)
    nd = n / box ** 3
    _, _, n_partners, g_mean = K._partner_law(nd, kT, m, n)
    enskog = K.enskog_chi(phi) * n_partners * math.pi * sigma ** 2 * g_mean
    boltzmann = enskog / K.enskog_chi(phi)
    assert abs(rate / enskog - 1.0) < 0.01                     # the Boltzmann rate is 30 % lower
    assert rate / boltzmann - 1.0 > 0.25


def test_exact_integral_of_free_flight():
    """Without collisions v(t) = v(0): the integral to T is <|v|^2> T / 3."""
    rng = np.random.default_rng(2)
    vel = np.repeat(rng.normal(size=(1, 7, 3)), 41, axis=0)
    t = np.arange(41) * 0.25
    pos = vel[0][None] * t[:, None, None]
    got = H.exact_integral(pos, vel, 0.25, 2.5)
    assert got == pytest.approx(np.mean(np.sum(vel[0] ** 2, axis=1)) * 2.5 / 3.0, rel=1e-12)
    with pytest.raises(ValueError, match="outside the run"):
        H.exact_integral(pos, vel, 0.25, 20.0)


def test_exact_integral_pairs_each_velocity_with_the_displacement_after_it():
    """Piecewise-constant random velocities: the integral to k frames is dt/3 times the sum over
    lags m < k of the discrete velocity autocorrelation (a shifted pairing fails this)."""
    rng = np.random.default_rng(4)
    dt, T, n, k = 0.25, 60, 5, 7
    vel = rng.normal(size=(T, n, 3))
    pos = np.concatenate([np.zeros((1, n, 3)), np.cumsum(vel[:-1] * dt, axis=0)])
    origins = T - k
    want = sum(np.einsum("tni,tni->", vel[:origins], vel[m:m + origins]) for m in range(k)) * dt / (3 * origins * n)
    assert H.exact_integral(pos, vel, dt, k * dt) == pytest.approx(want, rel=1e-12)


def test_summary_uses_the_ratio_of_means_and_both_errors():
    runs = [dict(d_gk=g, d_exact=x, rate=0.1 + 0.001 * i) for i, (g, x) in
            enumerate([(9.0, 9.5), (9.2, 8.9), (8.8, 9.1), (9.1, 9.3)])]
    e = H.summarise(dict(per_run=runs, d_boltzmann=9.0, d_boltzmann_se=0.01, enskog_chi=1.005, rate_enskog=0.1))
    g, x = np.array([9.0, 9.2, 8.8, 9.1]), np.array([9.5, 8.9, 9.1, 9.3])
    r = g.mean() / x.mean()
    assert e["gk_minus_exact"] == pytest.approx(r - 1, rel=1e-12)          # not the mean of the ratios
    assert e["gk_minus_exact_se"] == pytest.approx(np.std(g - r * x, ddof=1) / 2 / x.mean(), rel=1e-12)
    se_run = np.std(g, ddof=1) / 2
    assert e["d_gk_rel_boltzmann"] == pytest.approx(g.mean() / 9.0 - 1, rel=1e-12)
    assert e["d_gk_rel_boltzmann_se"] == pytest.approx(math.hypot(se_run / 9.0, g.mean() * 0.01 / 81.0), rel=1e-12)
    assert e["d_gk_rel_enskog_se"] == pytest.approx(1.005 * e["d_gk_rel_boltzmann_se"], rel=1e-12)
    assert e["n_runs"] == 4 and e["rate_rel_enskog"] == pytest.approx(0.1015 / 0.1 - 1, rel=1e-12)


def test_bad_input_is_refused(lib):
    pos = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]])
    vel = np.zeros((2, 3))
    with pytest.raises(ValueError, match="overlapping"):
        H.simulate(pos, vel, 10.0, 1.0, 2, lib=lib)
    with pytest.raises(ValueError, match="n_cells"):
        H.simulate(pos * 4, vel, 10.0, 1.0, 2, n_cells=20, lib=lib)     # cells smaller than sigma
    with pytest.raises(ValueError, match="n_cells"):
        H.simulate(pos * 4, vel, 10.0, 1.0, 2, n_cells=3, lib=lib)      # the minimum image may not be the neighbour's
    with pytest.raises(ValueError, match="finite"):
        H.simulate(pos * 4, vel * np.nan, 10.0, 1.0, 2, lib=lib)


def test_the_command_writes_and_resumes_an_entry(tmp_path, capsys, monkeypatch, lib):
    monkeypatch.setattr(H, "library", lambda: lib)            # no build in the repository's build/
    out = tmp_path / "md.json"
    args = ["--n", "27", "--t-end", "200", "--t-eq", "5", "--max-lag", "40", "--ref-chains", "40", "--out", str(out)]
    H.main(args + ["--runs", "3"])
    first = H.read(str(out))
    assert len(first) == 1 and first[0]["n_runs"] == 3
    H.main(args + ["--runs", "5"])                 # continued with new seeds, the reference kept
    (e,) = H.read(str(out))
    seeds = [r["seed"] for r in e["per_run"]]
    assert e["n_runs"] == 5 and len(set(seeds)) == 5 and seeds[:3] == [r["seed"] for r in first[0]["per_run"]]
    assert e["d_boltzmann"] == first[0]["d_boltzmann"]
    assert [b["runs"] for b in e["batches"]] == [3, 5] and e["versions"]["engine_sha256"]
    for key in ("d_gk_rel_boltzmann", "d_exact_rel_enskog", "rate_rel_enskog", "d_gk_rel_boltzmann_se"):
        assert math.isfinite(e[key])
    assert e["d_gk_rel_enskog"] == pytest.approx((1 + e["d_gk_rel_boltzmann"]) * e["enskog_chi"] - 1, rel=1e-12)
    assert "Enskog" in capsys.readouterr().out
    H.main(["--n", "32"] + args[2:] + ["--runs", "2"])    # another N: its own entry, the first kept
    assert [(g["n"], g["n_runs"]) for g in H.read(str(out))] == [(27, 5), (32, 2)]
