"""The many-sphere grain templates (studies/grains): what they are, checked by independent routes."""
import json
import os

import numpy as np
import pytest

from clumpprops.textclumps import read_text_clumps

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GRAINS = os.path.join(ROOT, "studies", "grains")


def _load(name):
    with open(os.path.join(GRAINS, name + ".json")) as f:
        return json.load(f)


def test_ellipsoid20_is_one_body_of_twenty_unequal_spheres_whose_sum_overstates_the_mass_by_half():
    c = read_text_clumps(os.path.join(GRAINS, "ellipsoid20.txt"))
    assert len(c) == 1
    x, r = np.asarray(c[0].centers), np.asarray(c[0].radii)
    assert len(r) >= 15 and len(np.unique(np.round(r, 12))) > len(r) // 2
    # connected: the overlap graph (centre distance < r_i + r_j) reaches every sphere
    d = np.linalg.norm(x[:, None] - x[None], axis=2)
    adj = d < r[:, None] + r[None]
    seen, todo = {0}, [0]
    while todo:
        i = todo.pop()
        for j in np.flatnonzero(adj[i]):
            if j not in seen:
                seen.add(j)
                todo.append(j)
    assert len(seen) == len(r)
    # no sphere inside another (each adds volume of its own)
    inside = d + r[:, None] <= r[None] + 1e-12
    np.fill_diagonal(inside, False)
    assert not inside.any()
    rec = _load("ellipsoid20")
    assert rec["mass_error"] >= 0.5


def test_ellipsoid20_summed_mass_is_the_closed_form_sum_of_sphere_masses():
    rec = _load("ellipsoid20")
    r = np.asarray(rec["radii"])
    assert rec["sum"]["mass"] == pytest.approx(rec["density"] * 4 / 3 * np.pi * np.sum(r ** 3), rel=1e-14)


def test_ellipsoid20_exact_properties_agree_with_monte_carlo_over_the_union_within_its_standard_error():
    """Independent route: uniform points in the bounding box, kept where inside any sphere."""
    rec = _load("ellipsoid20")
    x, r, rho = np.asarray(rec["members"]), np.asarray(rec["radii"]), rec["density"]
    lo, hi = (x - r[:, None]).min(0), (x + r[:, None]).max(0)
    box = np.prod(hi - lo)
    rng = np.random.default_rng(20)
    n = 400_000
    p = lo + (hi - lo) * rng.random((n, 3))
    inside = np.zeros(n, bool)
    for xi, ri in zip(x, r):
        inside |= np.einsum("ij,ij->i", p - xi, p - xi) <= ri * ri
    # per-point contributions: volume, first moments, second moments (about the exact COM, the origin)
    q = p * inside[:, None]
    f = {"volume": inside.astype(float), "mx": q[:, 0], "my": q[:, 1], "mz": q[:, 2]}
    for k, (a, b) in {"Ixx": (1, 2), "Iyy": (0, 2), "Izz": (0, 1)}.items():
        f[k] = rho * (q[:, a] ** 2 + q[:, b] ** 2)
    est = {k: (box * v.mean(), box * v.std(ddof=1) / np.sqrt(n)) for k, v in f.items()}
    ex = rec["exact"]
    I = np.asarray(ex["inertia"])
    want = {"volume": ex["volume"], "mx": 0.0, "my": 0.0, "mz": 0.0, "Ixx": I[0, 0], "Iyy": I[1, 1], "Izz": I[2, 2]}
    z = {k: (est[k][0] - want[k]) / est[k][1] for k in want}
    assert max(abs(v) for v in z.values()) < 4.5, z
    # body frame: the exact tensor is diagonal, principal moments on the diagonal
    assert np.allclose(I, np.diag(np.diag(I)), atol=1e-12 * np.abs(I).max())
    assert np.allclose(np.sort(np.diag(I)), ex["principal_moments"], rtol=1e-12)


def test_grain_records_match_their_templates():
    from studies import grains

    for name in grains.templates():
        rec, now = _load(name), grains.describe(name)
        assert rec["n_spheres"] == now["n_spheres"]
        assert np.allclose(rec["exact"]["principal_moments"], now["exact"]["principal_moments"], rtol=1e-13)
        assert rec["mass_error"] == pytest.approx(now["mass_error"], rel=1e-13)
