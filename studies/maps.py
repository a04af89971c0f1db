"""The effect of each case's mass properties on D, predicted from binary collisions.

    .venv/bin/python -m studies case-map                         # the paper's dimer, 10,000 collisions
    .venv/bin/python -m studies case-map --pairs 2000 --quick    # a look (~1 CPU-min)

An independent route to the gas study's answers, at a few CPU-minutes instead of CPU-days.  In the
first Chapman-Enskog approximation (Mason-Monchick for bodies with rotation) the self-diffusion
coefficient of a dilute gas is [D]_1 = 3 kT / (8 n m Omega11), with the collision integral

    Omega11 = sqrt(kT / 2 pi mu) int exp(-gamma^2) gamma^5 Q1(g) dgamma,   gamma^2 = mu g^2 / 2kT,

Q1 = int (1 - g'.g / g^2) dsigma the momentum-transfer cross-section averaged over orientations
and spins at equilibrium (g' != g when translation and rotation exchange energy).  Drawing the
collisions as the dt study does (``studies.timestep.collisions.make_pairs``: gamma^2 ~ Gamma(2), the
collision-flux weight; impact parameter uniform over a disc; equilibrium orientations and spins),
Omega11 ~ sqrt(kT/mu) <gamma^2 q>, q = 1 - g'.g/g^2, and for two cases of one shape

    D_case / D_exact = sqrt((kT_c/m_c) / (kT_e/m_e)) <gamma^2 q_exact> / <gamma^2 q_case>.

The same collision courses (the same gamma, impact parameters, orientations and normal draws of
the spins) are run in YADE for every case, so the ratio has a paired standard error over the
collisions.  Each case's state is the gas study's (``studies.gas_model.initial_state``,
``spin_pairing = "own"``): ``paired``, the exact case's translational velocities and the case's
spins at equipartition at its own temperature kT_c = kT_e m_c/m_e; ``equal_energy``, velocities
scaled by sqrt(m_e/m_c) and spins at kT_e.  Hard particles would give exactly 1 (paired, a case
with exact's k^2) or sqrt(m_e/m_c) (equal energy); everything else is the Hertz contact's
softness and the coupling of translation to rotation, which this measures.

What it is not: the full Boltzmann D (for the sphere gas the first approximation is 1.7 % below it,
a factor that largely cancels in a ratio of two similar cases), and not a gas measurement; the
gas study is the check.  Dimers run on YADE 2023.02a (isotropic route); the triangle trimer and
the tetrahedron on YADE 2025.2 (delValle2023, scripts/debian13.sh; their ``mass_scaled`` clump is
the exact build with mass and moments set to lambda times exact's).  A case's spins are
exact's normal draws mapped to the case's inertia tensor (``spin_map``: axis by axis where both
tensors are diagonal in the members' frame, as for these symmetric shapes).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time

import numpy as np

from . import gas_model as gm
from . import shapes as shp
from .timestep import collisions as tc

ROOT = tc.ROOT
OUT = os.path.join(ROOT, "results", "collision_map", "case_map.json")  # the report reads results/collision_map/
CASES = [("uncorrected", "paired"), ("mass_only", "paired"), ("inertia_only", "paired"),
         ("mass_scaled", "paired"), ("uncorrected", "equal_energy")]
# mass_scaled: not a gas-study case; the summed mass with the inertia scaled by the same factor
# (k^2 = I/m exact).  Hard particles cannot tell it from exact, so its effect is the contact's
# softness alone: a mass scaled by lambda at fixed velocities acts as E / lambda.


def case_input(base, shape, case, protocol):
    """The exact collision courses ``base`` (``studies.timestep.collisions.make_pairs``) with the body and the state of
    ``case`` in ``protocol`` (see the module docstring).  Returns (input, kT/m ratio to exact)."""
    props = shp.properties(shape, tc.MATERIAL["density"])
    mu = tc.MATERIAL.get("friction", 0.0)
    ex = gm.resolve_case(props, "exact", friction=mu)
    lam = 1.0
    if case == "mass_scaled":
        lam = props["sum"]["mass"] / props["exact"]["mass"]
        cr = dict(ex, mass=ex["mass"] * lam, moments=[lam * m for m in ex["moments"]])
        i_body_c = np.asarray(props["exact"]["inertia"]) * lam
    else:
        cr = gm.resolve_case(props, case, friction=mu)
        i_body_c = np.asarray(props[gm.CASE_SOURCES[case][1]]["inertia"])   # "exact" or "sum"
    i_body_e = np.asarray(props["exact"]["inertia"])
    m_e, m_c = ex["mass"], cr["mass"]
    if protocol == "paired":
        v_scale, kt_ratio = 1.0, m_c / m_e                 # kT_c / kT_e
    else:
        v_scale, kt_ratio = math.sqrt(m_e / m_c), 1.0
    # spins at equipartition at kT_c with the case's inertia, from exact's normal draws
    ori = np.asarray(base["ori"]).reshape(-1, 3, 3)
    wb = np.einsum("nji,nj->ni", ori, np.asarray(base["angvel"])) @ spin_map(i_body_e, i_body_c, kt_ratio).T
    inp = dict(base)
    inp["body"] = {"builder": cr["builder"], "route": cr["route"], "mass": m_c, "moments": cr["moments"],
                   "members": props["members"], "radii": props["radii"]}
    if lam != 1.0:   # aspherical route: the builder's (exact) moments times lam (studies/timestep/collisions_yade.py)
        inp["body"]["moment_scale"] = lam
    inp["vel"] = (np.asarray(base["vel"]) * v_scale).tolist()
    inp["angvel"] = np.einsum("nij,nj->ni", ori, wb).tolist()
    inp["kT"] = base["kT"] * kt_ratio
    return inp, kt_ratio * m_e / m_c


def _sqrtm(t, power):
    """A symmetric positive-definite matrix to the power ``power`` (eigen-decomposition)."""
    w, v = np.linalg.eigh(t)
    return (v * w ** power) @ v.T


def spin_map(i_body_e, i_body_c, kt_ratio):
    """The matrix that turns body-frame spins at equipartition with inertia tensor ``i_body_e`` into
    spins at equipartition with ``i_body_c`` at ``kt_ratio`` times the temperature, draw by draw.

    A spin drawn as w_e = sqrt(kT) I_e^(-1/2) z (z standard normal) becomes
    w_c = sqrt(kt_ratio kT) I_c^(-1/2) z = M w_e with M = sqrt(kt_ratio) I_c^(-1/2) I_e^(1/2); for
    tensors diagonal in the members' frame M scales axis by axis.

    Parameters
    ----------
    i_body_e, i_body_c : array_like, shape (3, 3)
        The exact and the case's inertia tensors in the members' frame (kg m^2).
    kt_ratio : float
        kT_case / kT_exact.

    Returns
    -------
    numpy.ndarray, shape (3, 3)
        M, applied as ``w_c = M @ w_e``.
    """
    i_e, i_c = np.asarray(i_body_e, float), np.asarray(i_body_c, float)
    if all(np.max(np.abs(t - np.diag(np.diag(t)))) <= 1e-12 * np.max(np.abs(t)) for t in (i_e, i_c)):
        return np.diag(np.sqrt(kt_ratio * np.diag(i_e) / np.diag(i_c)))
    return math.sqrt(kt_ratio) * _sqrtm(i_c, -0.5) @ _sqrtm(i_e, 0.5)


def relaxation_time_n(x, q, kT, m, area):
    """The first Chapman-Enskog velocity relaxation time of a body in a dilute gas of its kind, times
    the number density n: (tau n, its standard error), s m^-3.

    A body's velocity autocorrelation decays as exp(-t/tau) at short times, 1/tau = n A <g> <x q> / 3
    (the collision rate n A <g> over the impact-parameter disc of area A (m^2), <g> = sqrt(16 kT /
    (pi m)) the mean relative speed of two bodies of mass m (kg) at temperature kT (J), x = gamma^2
    and q = 1 - g'.g/g^2 per collision course drawn with the collision-flux weight; D = kT tau / m
    recovers [D]_1 above).  Hard spheres of diameter sigma with A = pi sigma^2 have <x q> = 2 and
    tau n = (m / kT) 3 / (8 sigma^2) sqrt(kT / (pi m)).  The gas study's records measure tau from
    the first seconds of their velocity autocorrelation (studies.diffusion.initial_decay_time)."""
    a = np.asarray(x) * np.asarray(q)
    mean = float(a.mean())
    se = float(a.std(ddof=1) / math.sqrt(len(a)))
    tn = 3.0 / (area * math.sqrt(16.0 * kT / (math.pi * m)) * mean)
    return tn, tn * se / mean


def ratio(x, q_e, q_c, kt_m_ratio, full=False):
    """D_case/D_exact - 1 = sqrt(kt_m_ratio) <x q_e>/<x q_c> - 1 and its standard error over the
    collisions (delta method; the collisions are the independent units, paired across cases).
    ``full``: also the per-collision influence values (their mean is 0), for differences of ratios."""
    a, b = x * q_e, x * q_c
    ma, mb = a.mean(), b.mean()
    r = math.sqrt(kt_m_ratio) * ma / mb
    d = r * (a / ma - b / mb)                   # influence of each collision on r
    se = float(d.std(ddof=1) / math.sqrt(len(d)))
    return (r - 1.0, se, d) if full else (r - 1.0, se)


def _parser():
    ap = argparse.ArgumentParser(prog="python -m studies case-map", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pairs", type=int, default=10000)
    ap.add_argument("--seed", type=int, default=17)
    ap.add_argument("--factor", type=float, default=0.5, help="dt factor (the studies: 0.5 or 1.0)")
    ap.add_argument("--overlap", type=float, default=0.5, help="overlap D/d_s")
    ap.add_argument("--shape", default="dimer", choices=["dimer", "trimer_triangle", "tetrahedron"],
                    help="aspherical shapes run on YADE 2025.2 (scripts/debian13.sh)")
    ap.add_argument("--youngs-modulus", type=float, default=None, help="Pa (default: the paper's 1e7)")
    ap.add_argument("--workdir", default=None, help="keep the YADE runs here (reused by a repeated call)")
    ap.add_argument("--out", default=OUT)
    ap.add_argument("--quick", action="store_true", help="do not write --out")
    return ap


def wide_pairs(shape, n_pairs, seed):
    """The collision courses of ``tc.make_pairs`` on a lattice 1.5x wider: the faster spins of some
    cases must not reach a neighbour."""
    base = tc.make_pairs(shape, n_pairs, seed)
    p = np.asarray(base["pos"])
    mid = 0.5 * (p[0::2] + p[1::2])
    p += np.repeat(0.5 * mid, 2, axis=0)
    base["pos"], base["spacing"], base["lattice"] = p.tolist(), 1.5 * base["spacing"], (1.5 * mid).tolist()
    return base


def _run_cases(runs, a, yade, work, tag):
    """Run every (case, protocol) of ``runs`` in YADE: their outcomes and the CPU seconds spent."""
    res, cpu = {}, 0.0
    for (case, prot), (inp, _) in runs.items():
        out = tc.run_map(inp, a.factor, yade, work, f"{tag}-{case}-{prot}")
        cpu += out.get("cpu_s", 0.0)
        res[(case, prot)] = tc.outcome(inp, out)
        print(f"[case_map] {case} {prot}: {int(res[(case, prot)]['touched'].sum())} of {a.pairs} collided, "
              f"cpu {out.get('cpu_s', float('nan')):.0f} s{' (reused)' if out.get('reused') else ''}", flush=True)
    return res, cpu


def _ratio_rows(runs, res, base, x, ok):
    """Per case: D_case/D_exact - 1 with its se, the hard-particle value and the body's errors (printed
    as a table); also each case's per-collision influence values."""
    ex = res[("exact", "paired")]
    print(f"{'case':>14} {'protocol':>13} | {'D_case/D_exact - 1':>18} | {'se':>7} | hard particles | "
          f"mass err. | I_perp/m err.")
    rows, infl = [], {}
    for case, prot in CASES:
        inp, ktm = runs[(case, prot)]
        rel, se, infl[(case, prot)] = ratio(x[ok], ex["q"][ok], res[(case, prot)]["q"][ok], ktm, full=True)
        hard = math.sqrt(ktm) - 1.0
        b = inp["body"]
        k2 = (max(b["moments"]) / b["mass"]) / (max(base["body"]["moments"]) / base["body"]["mass"]) - 1.0  # largest moment
        m_err = b["mass"] / base["body"]["mass"] - 1.0
        rows.append({"case": case, "protocol": prot, "relative": rel, "se": se, "hard_particles": hard,
                     "mass_error": m_err, "iperp_over_m_error": k2})
        print(f"{case:>14} {prot:>13} | {100 * rel:+17.2f} % | {100 * se:6.2f} % | {100 * hard:+13.2f} % | "
              f"{100 * m_err:+9.1f} % | {100 * k2:+8.1f} %")
    return rows, infl


def _minus_mass_scaled(rows, infl):
    """Each paired case's effect beyond the softness of its mass: the difference from ``mass_scaled``
    of equal mass, with its paired se over the same collisions (added to the rows)."""
    sc = next((r for r in rows if r["case"] == "mass_scaled"), None)
    for r in rows if sc else []:
        if r["protocol"] == "paired" and r["case"] != "mass_scaled" and r["mass_error"] == sc["mass_error"]:
            dd = infl[(r["case"], "paired")] - infl[("mass_scaled", "paired")]
            r["minus_mass_scaled"] = r["relative"] - sc["relative"]
            r["minus_mass_scaled_se"] = float(dd.std(ddof=1) / math.sqrt(len(dd)))
            print(f"{r['case']:>14} minus mass_scaled (the k² part): {100 * r['minus_mass_scaled']:+.2f} % "
                  f"± {100 * r['minus_mass_scaled_se']:.2f} % (se)")


def main(argv=None):
    """``python -m studies case-map [options]``: one shape's collision map for every case; writes
    ``--out`` (unless ``--quick``), recording ``argv`` (default ``sys.argv[1:]``)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    a = _parser().parse_args(argv)
    if a.youngs_modulus:
        tc.MATERIAL["youngs_modulus"] = a.youngs_modulus
    shape = {"kind": a.shape, "sphere_diameter": 0.1333, "overlap": a.overlap}
    linear = shp.properties(shape, tc.MATERIAL["density"])["linear"]
    yade = "2023.02a" if linear else "2025.2"
    work = a.workdir or tempfile.mkdtemp(prefix="case_map-")
    os.makedirs(work, exist_ok=True)
    t0 = time.time()
    base = wide_pairs(shape, a.pairs, a.seed)
    tag = f"{a.shape}-d{a.overlap}-E{tc.MATERIAL['youngs_modulus']:g}-n{a.pairs}-s{a.seed}"
    runs = {("exact", "paired"): (base, 1.0)}
    for case, prot in CASES:
        runs[(case, prot)] = case_input(base, shape, case, prot)
    res, cpu = _run_cases(runs, a, yade, work, tag)
    ok = np.ones(a.pairs, bool)
    for r in res.values():
        ok &= r["apart"]
    x = np.asarray(base["g"]) ** 2 * (base["body"]["mass"] / 2) / (2 * base["kT"])   # gamma^2 = mu g^2 / 2kT
    print(f"\n{a.shape}, D/d_s = {a.overlap}, YADE {yade}, E = {tc.MATERIAL['youngs_modulus']:g} Pa, "
          f"{int(ok.sum())} collision courses, dt factor {a.factor}; first Chapman-Enskog (Mason-Monchick):")
    rows, infl = _ratio_rows(runs, res, base, x, ok)
    _minus_mass_scaled(rows, infl)
    area = math.pi * (2.0 * base["bounding_radius"]) ** 2       # make_pairs' impact-parameter disc
    relax = {f"{case}/{prot}": relaxation_time_n(x[ok], res[(case, prot)]["q"][ok], inp["kT"], inp["body"]["mass"], area)
             for (case, prot), (inp, _) in runs.items()}
    print("first Chapman-Enskog velocity relaxation time x number density (s m^-3): "
          + ", ".join(f"{k} {v[0]:.2f} ± {v[1]:.2f}" for k, v in relax.items()))
    print(f"\n[total] CPU of the YADE runs {cpu / 60:.1f} min, wall {(time.time() - t0) / 60:.1f} min")
    if not a.quick:
        res_json = {"argv": argv, "shape": shape, "material": tc.MATERIAL, "pairs": a.pairs,
                    "pairs_used": int(ok.sum()), "seed": a.seed, "dt_factor": a.factor, "spin_pairing": "own",
                    "energy_per_particle": tc.ENERGY, "rows": rows,
                    "relaxation_time_n": {k: {"value": v[0], "se": v[1]} for k, v in relax.items()},
                    "cpu_s": cpu, "date": time.strftime("%Y-%m-%d")}
        os.makedirs(os.path.dirname(a.out), exist_ok=True)
        with open(a.out, "w") as f:
            json.dump(res_json, f, indent=1)
        print(f"wrote {os.path.relpath(a.out, ROOT)}")
    return 0
