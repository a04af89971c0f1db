"""Fuzz target for ``method="exact"``: random clumps, near-degenerate ones included.

    .venv/bin/python tests/fuzz_exact.py [--clumps 10000] [--seed 0] [--reference 0]

(as a script: Python puts tests/ on sys.path, where the slicing reference lives; clumpprops is the
installed package, the repository's own in the editable install ``make setup`` makes.)

Every clump is built from a few random spheres and then one to three degeneracies:
external and internal tangency (exact in floating point, and off by 1e-16 .. 1e-9),
exactly coincident spheres, near-coincident spheres (offsets 10^-300 .. 10^-6 of the
radius, equal or nearly equal radii), nested spheres poking out by 10^-300 .. 10^-6 of
their radius (or not at all), concentric spheres, four or five sphere surfaces through
one point, spheres of one pencil (all through one circle, so their circles coincide on
every other sphere they meet), a sphere through the triple point of three others,
spheres with coplanar or collinear centres, a ring of spheres around a hole, a sphere
10^-6 .. 10^6 times the size of another, a coincident or near-coincident pair (down to
10^-300 of the radius) cut by a third sphere, and dense clusters of 30 .. 60 mutually
overlapping spheres; a fifth of the clumps are scaled by 10^-9 .. 10^6.

Checks, per clump:

* no exception except the documented ValueError / ClumpGeometryError (none is expected
  for this valid input, so those are counted too), no NaN or inf, volume > 0, volume
  between the largest sphere and the sum of the spheres;
* invariance within 1e-12 (relative: mass; COM / clump extent; inertia / its largest
  entry) under a translation by up to the clump's extent (plus 64 eps |t| / L: the
  translated centres are rounded), a random rotation, and a random permutation;
* with ``--reference K``: the first K clumps of at most 20 spheres against the independent slicing reference
  (tests/reference_slicing.py), reported, not asserted (it takes ~1 s per clump).

``run()`` is also called by tests/test_fuzz_exact.py with a few hundred clumps.
Exit status 1 if any check failed.
"""
from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np
from scipy.spatial.transform import Rotation

import clumpprops
from clumpprops import mass_properties
from test_exact import triple_point  # noqa: E402  (tests/ is on the path: run as a script or by pytest)

TOL = 1e-12
REFERENCE_MAX_SPHERES = 20  # the slicing reference takes minutes on the dense clusters: it sees the others
EPS = np.finfo(float).eps
DOCUMENTED = (ValueError, clumpprops.ClumpGeometryError)
KINDS = ("tangent", "internal", "duplicate", "near_duplicate", "nested", "concentric",
         "four_point", "pencil", "triple_point", "coplanar", "collinear", "ring", "radius_ratio",
         "twin_cut", "dense")


# ------------------------------------------------------------------ generators
def _unit(rng, axis_aligned=False):
    if axis_aligned:
        e = np.zeros(3)
        e[rng.integers(3)] = rng.choice([-1.0, 1.0])
        return e
    u = rng.normal(size=3)
    return u / np.linalg.norm(u)


def _dyadic(rng, lo, hi, den):
    return rng.integers(int(math.ceil(lo * den)), int(math.floor(hi * den)) + 1) / den


def _log_uniform(rng, lo, hi):
    return 10.0 ** rng.uniform(lo, hi)


def _triple_point(c, r):
    """A point where three sphere surfaces meet, or None."""
    points = triple_point(c, r)
    return None if points is None else points[0]


def _degenerate(rng, c, r, kind):
    """Append spheres to (c, r) realising one degeneracy with a random existing sphere."""
    i = rng.integers(len(r))
    ci, ri = c[i], r[i]
    new_c, new_r = [], []
    if kind == "tangent":  # exactly tangent along an axis (dyadic numbers), or slightly off
        r2 = _dyadic(rng, 0.2, 0.6, 64)
        e = _unit(rng, axis_aligned=rng.random() < 0.7)
        new_c.append(ci + (ri + r2) * e)
        new_r.append(r2 * (1 + rng.choice([0.0, 0.0, 1e-16, -1e-16, 1e-15, -1e-15, 1e-12, -1e-12, 1e-9, -1e-9])))
    elif kind == "internal":
        r2 = ri * _dyadic(rng, 0.125, 0.875, 8)
        e = _unit(rng, axis_aligned=rng.random() < 0.7)
        new_c.append(ci + (ri - r2) * e)
        new_r.append(r2 * (1 + rng.choice([0.0, 0.0, 1e-16, -1e-16, 1e-15, -1e-15, 1e-12, -1e-12, 1e-9, -1e-9])))
    elif kind == "duplicate":
        new_c.append(ci.copy())
        new_r.append(ri)
    elif kind == "near_duplicate":
        new_c.append(ci + _log_uniform(rng, -300, -6) * ri * _unit(rng))
        s = rng.choice([0.0, 0.0, 1.0, -1.0])
        new_r.append(ri * (1 + s * _log_uniform(rng, -16, -6)))
    elif kind == "nested":
        r2 = ri * rng.uniform(0.1, 0.95)
        if rng.random() < 0.8:  # poking out (or not) by a tiny fraction of its radius
            p = rng.choice([1.0, -1.0]) * _log_uniform(rng, -300, -6) * r2
        else:
            p = -rng.uniform(0, 1) * (ri - r2)
        new_c.append(ci + ((ri - r2) + p) * _unit(rng))
        new_r.append(r2)
    elif kind == "concentric":
        new_c.append(ci.copy())
        new_r.append(ri * (1 + rng.choice([1.0, -1.0]) * _log_uniform(rng, -16, -1)))
    elif kind == "four_point":  # 4 or 5 sphere surfaces through one point
        P = ci + rng.uniform(-0.3, 0.3, 3)
        k = rng.integers(4, 6)
        for _ in range(k):
            cc = P + rng.uniform(0.2, 0.6) * _unit(rng)
            new_c.append(cc)
            new_r.append(float(np.linalg.norm(cc - P)))
    elif kind == "pencil":  # spheres through one common circle
        j_c = ci + rng.uniform(0.3, 1.2) * ri * _unit(rng)
        j_r = ri * rng.uniform(0.5, 1.2)
        D = float(np.linalg.norm(j_c - ci))
        if D >= ri + j_r or D <= abs(ri - j_r):
            j_r = D * 0.8 + abs(ri - 0.2 * D)  # make them cross
        e = (j_c - ci) / D
        x = (D * D + ri * ri - j_r * j_r) / (2 * D)
        rho2 = ri * ri - x * x
        if rho2 <= 0:
            return c, r
        m = ci + x * e
        new_c.append(j_c)
        new_r.append(j_r)
        for _ in range(rng.integers(1, 3)):
            t = rng.uniform(-0.8, 0.8) * ri
            new_c.append(m + t * e)
            new_r.append(math.sqrt(rho2 + t * t))
    elif kind == "triple_point":
        q = ci + np.array([[0.0, 0, 0], [0.7, 0, 0], [0.3, 0.6, 0.05]]) * rng.uniform(0.6, 1.2)
        rq = np.array([0.55, 0.5, 0.6]) * rng.uniform(0.9, 1.1)
        tp = _triple_point(q, rq)
        if tp is None:
            return c, r
        c4 = tp + rng.uniform(-0.5, 0.5, 3)
        new_c += list(q) + [c4]
        new_r += list(rq) + [max(float(np.linalg.norm(c4 - tp)), 1e-3)]
    elif kind == "coplanar":  # 3..6 centres in one plane through c_i (axis-aligned or not)
        e1 = _unit(rng, axis_aligned=rng.random() < 0.5)
        e2 = np.cross(e1, _unit(rng))
        e2 /= np.linalg.norm(e2)
        for _ in range(rng.integers(3, 7)):
            new_c.append(ci + ri * (rng.uniform(-1, 1) * e1 + rng.uniform(-1, 1) * e2))
            new_r.append(ri * rng.uniform(0.3, 1.0))
    elif kind == "collinear":  # 3..6 centres on one line through c_i
        e = _unit(rng, axis_aligned=rng.random() < 0.5)
        for _ in range(rng.integers(3, 7)):
            new_c.append(ci + ri * rng.uniform(-1.5, 1.5) * e)
            new_r.append(ri * rng.uniform(0.3, 1.0))
    elif kind == "ring":  # 5..12 equal spheres on a circle, each meeting its neighbours, a hole inside
        k = int(rng.integers(5, 13))
        e = _unit(rng)
        u = np.cross(e, _unit(rng))
        u /= np.linalg.norm(u)
        v = np.cross(e, u)
        R = ri * rng.uniform(1.5, 3.0)
        rr = R * math.sin(math.pi / k) * rng.uniform(1.02, 1.3)  # overlaps neighbours, not the centre
        for t in np.arange(k) * 2 * math.pi / k:
            new_c.append(ci + R * (math.cos(t) * u + math.sin(t) * v))
            new_r.append(min(rr, 0.95 * R))
    elif kind == "radius_ratio":  # a sphere 1e-6 .. 1e6 times r_i, overlapping sphere i
        q = _log_uniform(rng, -6, 6)
        r2 = ri * q
        new_c.append(ci + (ri + r2) * rng.uniform(0.5, 0.999) * _unit(rng))
        new_r.append(r2)
    elif kind == "twin_cut":  # a coincident or near-coincident pair cut by a third sphere
        gap = rng.choice([0.0, _log_uniform(rng, -300, -6)]) * ri
        c2 = ci + ri * rng.uniform(0.3, 1.5) * _unit(rng)
        new_c += [c2, c2 + gap * _unit(rng)]
        new_r += [ri, ri]
    elif kind == "dense":  # 30..60 spheres, every one overlapping every other
        k = int(rng.integers(30, 61))
        for _ in range(k):
            new_c.append(ci + ri * 0.5 * rng.uniform(-1, 1, 3))
            new_r.append(ri * rng.uniform(0.6, 1.0))
    else:
        raise ValueError(kind)
    return np.vstack([c, np.array(new_c)]), np.append(r, new_r)


def random_clump(rng):
    """(centres, radii, kinds): 1..6 random spheres (dyadic) and 1..3 degeneracies."""
    n = rng.integers(1, 7)
    c = np.array([[_dyadic(rng, -0.6, 0.6, 1024) for _ in range(3)] for _ in range(n)])
    r = np.array([_dyadic(rng, 0.3, 0.7, 1024) for _ in range(n)])
    kinds = list(rng.choice(KINDS, size=rng.integers(1, 4)))
    for kind in kinds:
        c, r = _degenerate(rng, c, r, kind)
    if rng.random() < 0.2:  # any length scale
        s = _log_uniform(rng, -9, 6)
        c, r = c * s, r * s
    return c, r, kinds


# ------------------------------------------------------------------ checks
def _errors(a, b, L):
    """Relative differences (mass, COM / L, inertia / max |I|) between two MassProperties batches."""
    em = np.abs(b.mass / a.mass - 1)
    ec = np.max(np.abs(b.center_of_mass - a.center_of_mass), axis=1) / L
    ei = np.max(np.abs(b.inertia - a.inertia), axis=(1, 2)) / np.max(np.abs(a.inertia), axis=(1, 2))
    return np.maximum(em, np.maximum(ec, ei))


def _evaluate(cs, rs):
    """Batch evaluation; falls back to one call per clump to name the clumps that raise."""
    try:
        return mass_properties(cs, rs, 1.0, method="exact"), {}
    except Exception:  # noqa: BLE001 - every exception is classified below
        pass
    bad, good = {}, []
    for k, (c, r) in enumerate(zip(cs, rs)):
        try:
            mass_properties(c, r, 1.0, method="exact")
            good.append(k)
        except Exception as exc:  # noqa: BLE001
            bad[k] = exc
    return None, bad


def run(n_clumps=10_000, seed=0, reference=0, block=2000, verbose=False):
    """Fuzz n_clumps clumps; returns a dict of counts and maximal errors (see module doc)."""
    rng = np.random.default_rng(seed)
    out = dict(clumps=0, spheres=0, kinds={k: 0 for k in KINDS}, documented_exceptions=0, other_exceptions=0,
               nonfinite=0, bounds_violations=0, translation_fail=0, rotation_fail=0, permutation_fail=0,
               max_translation=0.0, max_rotation=0.0, max_permutation=0.0, failures=[])
    ref_err = []
    t0 = time.perf_counter()
    done = 0
    while done < n_clumps:
        m = min(block, n_clumps - done)
        clumps = [random_clump(rng) for _ in range(m)]
        cs = [c for c, _, _ in clumps]
        rs = [r for _, r, _ in clumps]
        for _, _, kinds in clumps:
            for k in kinds:
                out["kinds"][k] += 1
        L = np.array([np.ptp(c, axis=0).max() + 2 * r.max() for c, r in zip(cs, rs)])
        # transformed copies
        t_dir = rng.normal(size=(m, 3))
        t = t_dir / np.linalg.norm(t_dir, axis=1)[:, None] * (rng.uniform(0, 1, m) * L)[:, None]
        rot = Rotation.random(m, random_state=rng.integers(2**31)).as_matrix()
        perms = [rng.permutation(len(r)) for r in rs]
        variants = {
            "orig": (cs, rs),
            "translation": ([c + t[k] for k, c in enumerate(cs)], rs),
            "rotation": ([c @ rot[k].T for k, c in enumerate(cs)], rs),
            "permutation": ([c[p] for c, p in zip(cs, perms)], [r[p] for r, p in zip(rs, perms)]),
        }
        res = {}
        broken = set()
        for name, (vc, vr) in variants.items():
            mp, bad = _evaluate(vc, vr)
            for k, exc in bad.items():
                kind = "documented_exceptions" if isinstance(exc, DOCUMENTED) else "other_exceptions"
                out[kind] += 1
                broken.add(k)
                out["failures"].append((name, repr(exc)[:200], cs[k].tolist(), rs[k].tolist()))
            if mp is None:  # recompute the others one by one
                res[name] = None
                continue
            finite = (np.isfinite(mp.mass) & np.all(np.isfinite(mp.center_of_mass), axis=1)
                      & np.all(np.isfinite(mp.inertia), axis=(1, 2)) & (mp.volume > 0))
            for k in np.flatnonzero(~finite):
                out["nonfinite"] += 1
                broken.add(int(k))
                out["failures"].append((name, "non-finite or non-positive", cs[k].tolist(), rs[k].tolist()))
            res[name] = mp
        if any(v is None for v in res.values()):
            # rare: evaluate per clump, skipping the broken ones
            keep = [k for k in range(m) if k not in broken]
            for name, (vc, vr) in variants.items():
                res[name] = mass_properties([vc[k] for k in keep], [vr[k] for k in keep], 1.0, method="exact")
            sel = np.array(keep)
        else:
            sel = np.array([k for k in range(m) if k not in broken])
            if len(sel) < m:
                res = {name: mp[sel] for name, mp in res.items()}
        a = res["orig"]
        Ls = L[sel]
        vmax = np.array([4.0 / 3.0 * math.pi * rs[k].max() ** 3 for k in sel])
        vsum = np.array([4.0 / 3.0 * math.pi * np.sum(rs[k] ** 3) for k in sel])
        viol = (a.volume < vmax * (1 - 1e-14)) | (a.volume > vsum * (1 + 1e-14))
        out["bounds_violations"] += int(viol.sum())
        for k in np.flatnonzero(viol):
            kk = int(sel[k])
            out["failures"].append(("bounds", f"V={a.volume[k]!r} max={vmax[k]!r} sum={vsum[k]!r}", cs[kk].tolist(), rs[kk].tolist()))
        for name in ("translation", "rotation", "permutation"):
            b = res[name]
            if name == "rotation":
                # compare in the rotated frame
                R = rot[sel]
                com = np.einsum("mij,mj->mi", R, a.center_of_mass)
                I = np.einsum("mij,mjk,mlk->mil", R, a.inertia, R)
                err = np.maximum.reduce([np.abs(b.mass / a.mass - 1),
                                         np.max(np.abs(b.center_of_mass - com), axis=1) / Ls,
                                         np.max(np.abs(b.inertia - I), axis=(1, 2)) / np.max(np.abs(I), axis=(1, 2))])
                tol = TOL
            elif name == "translation":
                ta = t[sel]

                class _Shifted:  # a's COM moved by t
                    mass, inertia = a.mass, a.inertia
                    center_of_mass = a.center_of_mass + ta

                err = _errors(_Shifted, b, Ls)
                tol = TOL + 64 * EPS * np.max(np.abs(ta), axis=1) / Ls
            else:
                err = _errors(a, b, Ls)
                tol = TOL
            fail = err > tol
            out[f"{name}_fail"] += int(fail.sum())
            out[f"max_{name}"] = max(out[f"max_{name}"], float(err.max()) if len(err) else 0.0)
            for k in np.flatnonzero(fail):
                kk = int(sel[k])
                out["failures"].append((name, f"err={err[k]:.3e}", cs[kk].tolist(), rs[kk].tolist()))
        out["clumps"] += m
        out["spheres"] += int(sum(len(r) for r in rs))
        if reference and len(ref_err) < reference:
            import reference_slicing as rsl

            small = [int(k) for k in sel if len(rs[int(k)]) <= REFERENCE_MAX_SPHERES]
            for k in small[: reference - len(ref_err)]:
                mref = rsl.union_mass_properties(cs[k], rs[k], 1.0)
                one = a[int(np.flatnonzero(sel == k)[0])]
                ref_err.append(max(abs(one.volume / mref["volume"] - 1),
                                   np.max(np.abs(one.center_of_mass - mref["com"])) / L[k],
                                   np.max(np.abs(one.inertia - mref["inertia"])) / np.max(np.abs(mref["inertia"]))))
        done += m
        if verbose:
            print(f"  {done} clumps, {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    out["seconds"] = time.perf_counter() - t0
    if reference:
        out["reference_clumps"] = len(ref_err)
        out["reference_max_error"] = float(max(ref_err)) if ref_err else 0.0
        out["reference_over_1e-12"] = int(np.sum(np.array(ref_err) > 1e-12))
    out["ok"] = not out["failures"]
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clumps", type=int, default=10_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--reference", type=int, default=0, help="compare the first K clumps with the slicing reference")
    args = ap.parse_args(argv)
    out = run(args.clumps, args.seed, args.reference, verbose=True)
    fails = out.pop("failures")
    for key, val in out.items():
        print(f"{key}: {val}")
    for f in fails[:20]:
        print("FAIL", f)
    if len(fails) > 20:
        print(f"... {len(fails) - 20} more failures")
    return 0 if out["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
