"""The time-step study's command line, ``python -m studies timestep``: runs the collision maps and
the gases of each shape, prints their tables and the largest safe dt factor, and writes the JSON
record (default ``results/timestep/timestep.json``).  The method: ``studies.timestep`` and
docs/timestep.md."""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time

import numpy as np

from . import __doc__ as STUDY_DOC
from .analysis import analyse_map, energy_bias
from .collisions import D_TOL, E_TOL, ENERGY, MATERIAL, OUT, ROOT, SHAPES, cpu_children, make_pairs, run_map
from .gas import run_gas


def fmt_table(head, rows):
    """A Markdown table of string cells, right-aligned."""
    w = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(head)]
    out = ["| " + " | ".join(h.rjust(w[i]) for i, h in enumerate(head)) + " |",
           "|" + "|".join("-" * (x + 2) for x in w) + "|"]
    out += ["| " + " | ".join(c.rjust(w[i]) for i, c in enumerate(r)) + " |" for r in rows]
    return "\n".join(out)


def report_map(key, a):
    """Print the tables of one shape's collision map (``analysis.analyse_map``'s result ``a``)."""
    print(f"\n## Collision map: {key} ({a['n_pairs']} pairs, {a['n_touched']} touched, "
          f"{a['n_not_apart']} unfinished; ref = finest factor)")
    print(f"<1-cos chi>_ref = {a['one_minus_cos_ref']:.5f}, Omega_ref = <g^2 q>/<g^2> = {a['omega_ref']:.5f}, "
          f"mean energy error of the ref = {a['de_mean_ref']:.2e}; restoring rate "
          f"d<dK_tr>/d eps / <K_tr> = {a['relax_slope_rel']:.3f}")
    head = ["factor", "dt [s]", "|dp err| agg", "median", "p90", "order", "|dL err| agg", "order",
            "dE/E mean", "dE/E rms", "order", "|dE/E| max"]
    rows = []
    for r in a["rows"]:
        rows.append([f"{r['factor']:g}", f"{r['dt']:.3e}", f"{r['dp_err_agg']:.2e}", f"{r['dp_err_median']:.2e}",
                     f"{r['dp_err_p90']:.2e}", f"{r.get('order_dp_err_agg', float('nan')):.2f}",
                     f"{r['dL_err_agg']:.2e}", f"{r.get('order_dL_err_agg', float('nan')):.2f}",
                     f"{r['de_mean']:+.2e}", f"{r['de_rms']:.2e}", f"{r.get('order_de_rms', float('nan')):.2f}",
                     f"{r['de_absmax']:.2e}"])
    print(fmt_table(head, rows))
    print(f"collision rate {a['collision_rate_per_phi']:.1f} /s per unit volume fraction (mean free time "
          f"{a['mean_free_time_paper']:.1f} s at phi = 0.001); predicted energy drift of a gas from these "
          f"errors (random-walk sd; mean bias ± se):")
    names = list(a["rows"][0]["gas_drift_pred"])
    head = ["factor"] + names
    rows = [[f"{r['factor']:g}"] + [f"{r['gas_drift_pred'][n]['sd']:.1e}; {r['gas_drift_pred'][n]['bias']:+.1e} ± "
                                   f"{r['gas_drift_pred'][n]['bias_se']:.1e}" for n in names] for r in a["rows"]]
    print(fmt_table(head, rows))
    head = ["factor", "d<1-cos chi> rel", "d<q> rel", "d Omega rel", "dK_tr bias rel", "T_tr shift",
            "pred. dD/D", "|dD/D|+2se < 0.2%"]
    rows = []
    for r in a["rows"]:
        ok = abs(r["D_rel_pred"]) + 2 * r["D_rel_pred_se"] < D_TOL
        rows.append([f"{r['factor']:g}",
                     f"{r['one_minus_cos_rel']:+.2e} ± {r['one_minus_cos_rel_se']:.1e}",
                     f"{r['q_rel']:+.2e} ± {r['q_rel_se']:.1e}",
                     f"{r['omega_rel']:+.2e} ± {r['omega_rel_se']:.1e}",
                     f"{r['dk_tr_bias_rel']:+.2e} ± {r['dk_tr_bias_rel_se']:.1e}",
                     f"{r['t_tr_shift']:+.2e} ± {r['t_tr_shift_se']:.1e}",
                     f"{r['D_rel_pred']:+.2e} ± {r['D_rel_pred_se']:.1e}", "yes" if ok else "NO"])
    print(fmt_table(head, rows))


def report_gas(key, g):
    """Print the energy drift of one shape's gases (``gas.run_gas``'s result ``g``)."""
    print(f"\n## Gas energy drift: {key} ({g['n_particles']} particles, phi = {g['volume_fraction']}, "
          f"{g['t_end']} s, seeds {g['seeds']}; study tolerance {E_TOL:g})")
    by = {}
    for r in g["runs"]:
        by.setdefault(r["factor"], []).append(r)
    head = ["factor", "dt [s]", "runs", "max energy drift", "final drift", "steps/s", "ok"]
    rows = []
    for f in sorted(by):
        rs = by[f]
        fd = [r["final_drift"] for r in rs if r["final_drift"] is not None]
        rows.append([f"{f:g}", f"{rs[0]['dt']:.3e}", str(len(rs)), f"{max(r['energy_drift'] for r in rs):.2e}",
                     ", ".join(f"{x:+.1e}" for x in fd) or "-", f"{np.mean([r['steps_per_s'] for r in rs]):.0f}",
                     "yes" if all(r["ok"] for r in rs) else "NO"])
    print(fmt_table(head, rows))


def decide(key, a, g):
    """Largest factor below which every factor is safe: the predicted D error |est| + 2 se of the
    collision map, plus half the largest gas energy drift at that factor (a drift delta of the
    energy moves D ~ sqrt(T) by at most delta/2), is under D_TOL, and every gas run at that
    factor stayed within the study's energy tolerance.  When gas runs were made, a factor above the
    largest one they checked is not declared safe (the drift grows with dt; below the smallest
    checked factor it only shrinks)."""
    per = []
    gas_max = max((x["factor"] for x in g["runs"]), default=None) if g is not None else None
    for r in a["rows"]:
        d_map = abs(r["D_rel_pred"]) + 2 * r["D_rel_pred_se"]
        gas_ok, d_total = None, None
        if g is not None:
            rs = [x for x in g["runs"] if abs(x["factor"] - r["factor"]) < 1e-12]
            if rs:
                drift = max(x["energy_drift"] for x in rs)
                gas_ok = drift < E_TOL and all(x["ok"] for x in rs)
                d_total = d_map + 0.5 * drift
        ok = (d_total if d_total is not None else d_map) < D_TOL and gas_ok is not False
        if gas_max is not None and r["factor"] > gas_max + 1e-12:
            ok = False  # extrapolated: no gas run checked the energy drift this far
        per.append({"factor": r["factor"], "d_map": d_map, "d_total": d_total, "gas_ok": gas_ok, "ok": ok})
    best = None
    for d in sorted(per, key=lambda d: d["factor"]):
        if not d["ok"]:
            break
        best = d["factor"]
    return {"shape": key, "largest_safe_factor": best, "per_factor": per}


def _parser():
    ap = argparse.ArgumentParser(prog="python -m studies timestep", description=STUDY_DOC,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pairs", type=int, default=2000, help="collisions per shape (default 2000)")
    ap.add_argument("--factors", default="0.0625,0.125,0.25,0.5,1.0,1.5,2.0", help="dt factors of the collision map")
    ap.add_argument("--factors-of", action="append", default=[], metavar="SHAPE=F1,F2,...",
                    help="dt factors of one shape's collision map (overrides --factors for it)")
    ap.add_argument("--shapes", default="dimer,trimer", help=f"of {','.join(SHAPES)}")
    ap.add_argument("--seed", type=int, default=8)
    ap.add_argument("--no-gas", action="store_true", help="skip the gas energy-drift runs")
    ap.add_argument("--no-map", action="store_true", help="skip the collision maps (gas runs only)")
    ap.add_argument("--bias", default="", help="phase-stratified energy bias: GEOMETRIES,PHASES (dimer only)")
    ap.add_argument("--bias-factors", default="1.0")
    ap.add_argument("--gas-factors", default="0.25,0.5,1.0,1.5")
    ap.add_argument("--gas-n", type=int, default=125)
    ap.add_argument("--gas-phi", type=float, default=0.01)
    ap.add_argument("--gas-t-end", type=float, default=40.0)
    ap.add_argument("--gas-seeds", default="1,2")
    ap.add_argument("--workdir", default=None, help="scratch directory (default: a temporary one)")
    ap.add_argument("--youngs-modulus", type=float, default=None,
                    help="Pa (default: the paper's 1e7); the contacts' steps per collision go as E^(1/10) at one factor")
    ap.add_argument("--out", default=OUT)
    return ap


def _map_of_shape(key, cfg, factors, a, workdir):
    """Run one shape's collision map at every factor and analyse it (with its CPU time)."""
    inp = make_pairs(cfg["shape"], a.pairs, a.seed)
    runs = {}
    for f in factors:
        runs[f] = run_map(inp, f, cfg["yade"], workdir, key)
        o = runs[f]
        print(f"[map] {key} f={f:g} dt={o['dt']:.3e} steps={o['n_steps']} t={o['t_end']:.3f} s "
              f"done={o['done']} cpu={o['cpu_s']:.1f} s{' (reused)' if o['reused'] else ''} "
              f"({o['yade_version']}, {o['rot_algorithm']})", flush=True)
    an = analyse_map(inp, runs, factors, inp["kT"], inp["rot_dof"], cfg["shape"])
    an.update(shape=cfg["shape"], yade=cfg["yade"], kT=inp["kT"], bounding_radius=inp["bounding_radius"],
              t_max=inp["t_max"], spacing=inp["spacing"], seed=a.seed,
              map_cpu_s=sum(r["cpu_s"] for r in runs.values()),
              com_shift_max=max(r["com_shift_max"] for r in runs.values()))
    return an


def _print_decision(key, decision):
    print(f"\n[decision] {key}: largest safe dt factor = {decision['largest_safe_factor']}", flush=True)
    print(fmt_table(["factor", "pred. |dD/D| + 2 se", "+ half max gas drift", "gas drift ok", "safe"],
                    [[f"{d['factor']:g}", f"{d['d_map']:.2e}", f"{d['d_total']:.2e}" if d["d_total"] is not None
                      else "-", {True: "yes", False: "NO", None: "-"}[d["gas_ok"]], "yes" if d["ok"] else "NO"]
                     for d in decision["per_factor"]]))


def _study(a, argv, workdir):
    """Every shape's map and gases, and the dimer's energy bias: the JSON record (without timings)."""
    gas_factors = [float(x) for x in a.gas_factors.split(",")]
    seeds = [int(x) for x in a.gas_seeds.split(",")]
    own = dict(x.split("=", 1) for x in a.factors_of)
    result = {"argv": argv, "pairs": a.pairs, "material": dict(MATERIAL),
              "energy_per_particle": ENERGY, "d_tol": D_TOL, "energy_tol": E_TOL, "shapes": {}, "decision": {}}
    cpu_study = 0.0
    for key in a.shapes.split(","):
        cfg = SHAPES[key]
        factors = [float(x) for x in (own[key] if key in own else a.factors).split(",")]
        an = gas = None
        if not a.no_map:
            an = _map_of_shape(key, cfg, factors, a, workdir)
            cpu_study += an["map_cpu_s"]
            report_map(key, an)
        if not a.no_gas:
            gas = run_gas(key, cfg, gas_factors, a.gas_n, a.gas_phi, a.gas_t_end, seeds, workdir)
            cpu_study += gas["cpu_s"]
            report_gas(key, gas)
        result["shapes"][key] = {"map": an, "gas": gas}
        if an is not None:
            result["decision"][key] = decide(key, an, gas)
            _print_decision(key, result["decision"][key])
    if a.bias:
        ng, K = (int(x) for x in a.bias.split(","))
        b = energy_bias("dimer", ng, K, [float(x) for x in a.bias_factors.split(",")], a.seed, workdir)
        result["energy_bias_dimer"] = {str(k): v for k, v in b.items()}
        cpu_study += sum(v["cpu_s"] for v in b.values())
    result["cpu_s_study"] = cpu_study
    return result


def main(argv=None):
    """``python -m studies timestep [options]``: the study; writes ``--out``.  ``argv`` (default
    ``sys.argv[1:]``) is recorded in the output's ``argv``."""
    argv = list(sys.argv[1:] if argv is None else argv)
    ap = _parser()
    a = ap.parse_args(argv)
    if a.youngs_modulus is not None:
        if not a.youngs_modulus > 0:
            ap.error(f"--youngs-modulus must be positive, got {a.youngs_modulus}")
        MATERIAL["youngs_modulus"] = a.youngs_modulus
    tmp_obj = None
    if a.workdir:
        workdir = a.workdir
        os.makedirs(workdir, exist_ok=True)
    else:
        tmp_obj = tempfile.TemporaryDirectory(prefix="clumpprops-dt-")
        workdir = tmp_obj.name
    t_start, c_start = time.time(), cpu_children()
    result = _study(a, argv, workdir)
    cpu_study = result["cpu_s_study"]
    result["cpu_s_this_invocation"] = cpu_children() - c_start
    result["wall_s_this_invocation"] = time.time() - t_start
    result["date"] = time.strftime("%Y-%m-%d %H:%M:%S %Z")
    print(f"\n[total] CPU of the study's YADE runs {cpu_study / 60:.1f} min (this invocation "
          f"{result['cpu_s_this_invocation'] / 60:.1f} min, wall {result['wall_s_this_invocation'] / 60:.1f} min)")
    os.makedirs(os.path.dirname(a.out), exist_ok=True)
    with open(a.out, "w") as f:
        json.dump(result, f, indent=1)
    print(f"wrote {os.path.relpath(a.out, ROOT)}")
    if tmp_obj:
        tmp_obj.cleanup()
    return 0
