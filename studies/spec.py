"""Study specs: a gas study described by a TOML file (``studies/specs/*.toml``), validated and
resolved into runs.

A spec names shapes, material, gas, run length, recording, time step, analysis choices, the
YADE version it wants, and groups of (shape, cases, protocol, seeds) in priority order.  Every
table and key is checked before any run starts: an unknown key, a missing field, a negative or
non-finite number, or an aspherical shape on a YADE without a conservative aspherical integrator
stops with one :class:`SpecError` naming the key.  See ``studies/specs/paper.toml`` for a
commented example and docs/granular_gas.md for the reference.

A run is identified by its fully resolved physical parameters (shape geometry, material, gas,
run, case, protocol, seed), :data:`MODEL_VERSION`, the YADE version and the clumpprops version:
:func:`run_key`.  Never by source hashes: editing a comment changes no key.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import tomllib

import numpy as np

from . import gas_model, shapes
from .spec_checks import (SCHEDULES, YADE_VERSIONS, SpecError, check_analysis_window,  # noqa: F401
                          check_one_body, check_placement, check_table, check_value)

# Bump when the physics of a run changes (what the YADE script builds, records or integrates,
# or how initial conditions are drawn).  Part of every run key.
MODEL_VERSION = 2

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SPEC_DIR = os.path.join(ROOT, "studies", "specs")


_NUM = (int, float)
# table -> {key: (type, required, default, check)}; check: "pos" > 0, "nonneg" >= 0, "frac" in (0, 1)
SCHEMA = {
    "study": {"name": (str, True, None, None), "description": (str, False, "", None),
              "results": (str, True, None, None), "yade": (str, True, None, "yade"),
              "max_attempts": (int, False, 3, "pos"), "budget_cpu_hours": (_NUM, False, None, "pos"),
              "schedule": (str, False, "in_order", "schedule"), "in_results": (bool, False, True, None)},
    "material": {"density": (_NUM, True, None, "pos"), "youngs_modulus": (_NUM, True, None, "pos"),
                 "poisson": (_NUM, True, None, "poisson"),
                 # dissipative and frictional contacts (optional; absent keys leave a run's key as it was)
                 "restitution": (_NUM, False, None, "restitution"),
                 "tangential_restitution": (_NUM, False, None, "restitution"),
                 "friction": (_NUM, False, None, "nonneg")},
    "gas": {"n_particles": (int, True, None, "pos"), "volume_fraction": (_NUM, True, None, "frac"),
            "energy_per_particle": (_NUM, True, None, "pos"), "start": (str, False, "zero_spin", "start"),
            "spin_pairing": (str, False, "own", "spin_pairing"),
            # sphere gases: T_rot / T_tr at the start (spins matter only with friction); absent: no spin
            "spin_ratio": (_NUM, False, None, "nonneg")},
    # t_end, rec_interval, dt_factor and the analysis' times default to values from the gas itself
    # (None here; :func:`physics_defaults`)
    "run": {"t_end": (_NUM, False, None, "pos"), "rec_interval": (_NUM, False, None, "pos"),
            "dt_factor": (_NUM, False, 1.0, "pos"), "energy_tol": (_NUM, False, 1e-3, "pos"),
            "momentum_tol": (_NUM, False, 1e-9, "pos"), "progress_period": (_NUM, False, 20.0, "pos"),
            "legacy_dt": (dict, False, None, None),
            # the homogeneous cooling state: a run ends once T_tr has fallen by this factor (> 1)
            "cooling_stop": (_NUM, False, None, "cooling_stop")},
    "analysis": {"t_eq": ((_NUM, str), False, "auto", "t_eq"), "fit_lo": (_NUM, False, None, "nonneg"),
                 "fit_hi": (_NUM, False, None, "pos"), "max_lag": (_NUM, False, None, "pos"),
                 "cuts": (list, False, [], None), "sensitivity": (list, False, [], None)},
    "spheres": {"diameter": ((_NUM, str), False, "equal_volume", "diameter"),
                "mass": (str, False, "exact", "smass")},
}
# keys a spec may leave out without a default: absent, they are absent from the resolved spec too
OPTIONAL_KEYS = {"material": ("restitution", "tangential_restitution", "friction"), "run": ("cooling_stop",),
                 "gas": ("spin_ratio",)}
SHAPE_KEYS = {"kind": (str, True, None, "kind"), "sphere_diameter": (_NUM, False, None, "pos"),
              "overlap": (_NUM, False, None, "pos"), "path": (str, False, None, None),
              "scale": (_NUM, False, 1.0, "pos")}
GROUP_KEYS = {"shape": (str, True, None, None), "cases": (list, True, None, None),
              "protocol": (str, False, "paired", "protocol"), "seeds": (list, True, None, None),
              "label": (str, False, None, None),
              # per-group overrides of the study tables
              "youngs_modulus": (_NUM, False, None, "pos"), "t_end": (_NUM, False, None, "pos"),
              "dt_factor": (_NUM, False, None, "pos"), "start": (str, False, None, "start"),
              "energy_per_particle": (_NUM, False, None, "pos"), "rec_interval": (_NUM, False, None, "pos"),
              "n_particles": (int, False, None, "pos"), "spin_ratio": (_NUM, False, None, "nonneg"),
              "restitution": (_NUM, False, None, "restitution"),
              "tangential_restitution": (_NUM, False, None, "restitution"),
              "friction": (_NUM, False, None, "nonneg"), "cooling_stop": (_NUM, False, None, "cooling_stop"),
              "target": (dict, False, None, None), "max_seeds": (int, False, None, "pos")}
# what a sequential target's half-width is of: D of an elastic gas (Green-Kubo), or one of the
# cooling-gas observables of studies.hcs.effect_observables (a dissipative group's runs)
TARGET_OBSERVABLES = ("diffusion", "cooling_rate", "temperature_ratio")
# [run] legacy_dt = {below_seed, dt_factor}: seeds below ``below_seed`` keep the time step they were run
# with before ``run.dt_factor`` was raised (see :func:`resolve_run`)
LEGACY_DT_KEYS = {"below_seed": (int, True, None, "pos"), "dt_factor": (_NUM, True, None, "pos")}
OVERRIDES = {"youngs_modulus": "material", "t_end": "run", "dt_factor": "run", "rec_interval": "run",
             "start": "gas", "energy_per_particle": "gas", "n_particles": "gas", "restitution": "material",
             "tangential_restitution": "material", "friction": "material", "cooling_stop": "run",
             "spin_ratio": "gas"}


def analysis_windows(spec):
    """(cuts, max_lag): the analysis windows' start times (s) a spec's analysis reads from every run
    record (a numeric ``t_eq``, every ``cuts`` entry and every sensitivity ``t_eq``; 0 for "auto") and
    the VACF lags (s) it needs in each.  A record that lacks one cannot serve the analysis
    (:func:`studies.reduce.serves`): the driver runs it again."""
    a = spec["analysis"]
    cuts = ({float(a["t_eq"])} if a["t_eq"] != "auto" else {0.0}) | {float(c) for c in a["cuts"]} \
        | {float(s[0]) for s in a["sensitivity"]}
    return sorted(cuts), float(a["max_lag"])


def results_dir(spec):
    """Absolute path of a loaded spec's results directory (``study.results``, relative to the repository)."""
    d = spec["study"]["results"]
    return d if os.path.isabs(d) else os.path.join(ROOT, d)


def spec_path(name):
    """The spec file a command-line argument names: ``name`` itself where it is a file, else
    ``studies/specs/NAME.toml`` (``.toml`` optional); ``name`` unchanged where neither exists, so
    :func:`load` reports the missing file.

    Parameters
    ----------
    name : str
        A path, or the name of a committed spec.

    Returns
    -------
    str
    """
    if os.path.isfile(name):
        return name
    p = os.path.join(SPEC_DIR, name if name.endswith(".toml") else name + ".toml")
    return p if os.path.isfile(p) else name


def load(path):
    """Read and validate a spec file; returns the validated spec dict (with ``path``)."""
    try:
        with open(path, "rb") as f:
            raw = tomllib.load(f)
    except FileNotFoundError:
        raise SpecError(f"{path}: no such spec file") from None
    except tomllib.TOMLDecodeError as e:
        raise SpecError(f"{path}: not valid TOML: {e}") from None
    try:
        spec = validate(raw)
    except SpecError as e:
        raise SpecError(f"{path}: {e}") from None
    rel = os.path.relpath(os.path.abspath(path), ROOT)
    spec["path"] = os.path.abspath(path) if rel.startswith("..") else rel   # a spec outside the repository: its full path
    return spec


def _validate_shapes(shapes_table):
    """The ``[shapes.NAME]`` tables, each checked for its kind's keys and for being one body."""
    if not isinstance(shapes_table, dict) or not shapes_table:
        raise SpecError("shapes: missing (one [shapes.NAME] table per shape)")
    out = {}
    for name, s in shapes_table.items():
        sd = check_table(f"shapes.{name}", s, SHAPE_KEYS)
        need = ("path",) if sd["kind"] == "file" else ("sphere_diameter", "overlap")
        for k in need:
            if sd[k] is None:
                raise SpecError(f"shapes.{name}.{k}: missing (needed by kind = {sd['kind']!r})")
        extra = [k for k in (("sphere_diameter", "overlap") if sd["kind"] == "file" else ("path", "scale"))
                 if s.get(k) is not None]
        if extra:
            raise SpecError(f"shapes.{name}.{extra[0]}: not used by kind = {sd['kind']!r}")
        sd = {k: v for k, v in sd.items() if v is not None and not (k == "scale" and sd["kind"] != "file")}
        try:
            centers, radii = shapes.raw_members(sd)
        except (ValueError, OSError) as e:
            raise SpecError(f"shapes.{name}: {e}") from None
        check_one_body(f"shapes.{name}", sd, centers, radii)
        out[name] = sd
    return out


def _group_list(raw):
    groups = raw.get("groups")
    if not isinstance(groups, list) or not groups:
        raise SpecError("groups: missing (one [[groups]] table per group of runs)")
    return groups


def _validate_group(where, g, spec):
    """One ``[[groups]]`` table (``where``: its name in messages), checked against the spec's shapes and YADE."""
    gd = check_table(where, g, GROUP_KEYS)
    if gd["shape"] not in spec["shapes"]:
        raise SpecError(f"{where}.shape: unknown shape {gd['shape']!r} (defined: {', '.join(spec['shapes'])})")
    if not gd["cases"]:
        raise SpecError(f"{where}.cases: empty")
    for j, c in enumerate(gd["cases"]):
        if c not in gas_model.CASES:
            raise SpecError(f"{where}.cases[{j}]: unknown case {c!r} (known: {', '.join(gas_model.CASES)})")
    if not gd["seeds"]:
        raise SpecError(f"{where}.seeds: empty")
    for j, s in enumerate(gd["seeds"]):
        if isinstance(s, bool) or not isinstance(s, int) or s < 0:
            raise SpecError(f"{where}.seeds[{j}]: expected a non-negative integer, got {s!r}")
    if gd["target"] is not None:
        t = check_table(f"{where}.target", gd["target"],
                        {"case": (str, True, None, None), "halfwidth": (_NUM, True, None, "pos"),
                         "batch": (int, False, 2, "pos"), "observable": (str, False, "diffusion", None)})
        if t["case"] not in gd["cases"] or "exact" not in gd["cases"]:
            raise SpecError(f"{where}.target.case: {t['case']!r} and 'exact' must both be in {where}.cases")
        if t["observable"] not in TARGET_OBSERVABLES:
            raise SpecError(f"{where}.target.observable: {t['observable']!r} is not one of "
                            f"{', '.join(TARGET_OBSERVABLES)}")
        gd["target"] = t
        if gd["max_seeds"] is None:
            raise SpecError(f"{where}.max_seeds: missing (needed by {where}.target)")
    props = shapes.properties(spec["shapes"][gd["shape"]], spec["material"]["density"])
    sph = dict(spec["spheres"], density=spec["material"]["density"])
    mat = dict(spec["material"], **{k: gd[k] for k in OPTIONAL_KEYS["material"] if gd[k] is not None})
    routes = {c: gas_model.resolve_case(props, c, sph, mat.get("friction") or 0.0)["route"] for c in gd["cases"]}
    dissipative = (mat.get("restitution") is not None and mat["restitution"] < 1) or (mat.get("friction") or 0.0) > 0
    if gd["target"] is not None and (gd["target"]["observable"] != "diffusion") and not dissipative:
        raise SpecError(f"{where}.target.observable: {gd['target']['observable']!r} needs a cooling gas "
                        f"(restitution < 1 or friction > 0); an elastic group's target is of D ('diffusion')")
    if spec["study"]["yade"] == "2023.02a" and "aspherical" in routes.values():
        why = ("is not a linear clump" if not props["linear"] else
               f"has friction (material.friction = {mat['friction']:g}: a tangential force turns a linear clump about its axis)")
        raise SpecError(f"{where}.shape: {gd['shape']!r} {why} and needs full rigid-body "
                        f"rotation, but study.yade = '2023.02a' has only Fincham 1992's aspherical "
                        f"integrator, which gains energy; set study.yade = '2025.2'")
    return gd


def validate(raw):
    """Validate a parsed spec (dict); returns it completed with defaults.  Raises SpecError."""
    known = set(SCHEMA) | {"shapes", "groups"}
    for k in raw:
        if k not in known:
            raise SpecError(f"{k}: unknown table (known: {', '.join(sorted(known))})")
    spec = {}
    for t, keys in SCHEMA.items():
        if t not in raw and t not in ("spheres", "run", "analysis"):
            raise SpecError(f"{t}: missing table")
        spec[t] = check_table(t, raw.get(t, {}), keys)
    for t, keys in OPTIONAL_KEYS.items():          # absent optional keys stay absent (run keys unchanged)
        for k in keys:
            if spec[t][k] is None:
                del spec[t][k]
    if spec["run"]["legacy_dt"] is not None:
        spec["run"]["legacy_dt"] = check_table("run.legacy_dt", spec["run"]["legacy_dt"], LEGACY_DT_KEYS)
    a = spec["analysis"]
    for i, c in enumerate(a["cuts"]):
        check_value(f"analysis.cuts[{i}]", c, _NUM, "nonneg")
    for i, s in enumerate(a["sensitivity"]):
        if not (isinstance(s, list) and len(s) == 3):
            raise SpecError(f"analysis.sensitivity[{i}]: expected [t_eq, fit_lo, fit_hi], got {s!r}")
        for j, v in enumerate(s):
            check_value(f"analysis.sensitivity[{i}][{j}]", v, _NUM, "nonneg")
    spec["shapes"] = _validate_shapes(raw.get("shapes"))
    spec["groups"] = [_validate_group(f"groups[{i}]", g, spec) for i, g in enumerate(_group_list(raw))]
    physics_defaults(spec)
    a = spec["analysis"]
    if a["fit_hi"] <= a["fit_lo"]:
        raise SpecError(f"analysis.fit_hi: must be > analysis.fit_lo ({a['fit_lo']}), got {a['fit_hi']}")
    for i, gd in enumerate(spec["groups"]):
        check_placement(f"groups[{i}]", spec, gd, group_tables(spec, gd))
        check_analysis_window(f"groups[{i}]", spec, gd, group_tables(spec, gd))
    return spec


def velocity_correlation_time(spec, g):
    """tau_v = m D / kT [s]: how long a particle of group ``g``'s gas keeps its velocity, from the first
    Chapman-Enskog D of hard spheres (:func:`studies.kinetic.d_hard_spheres_first`) of the clump's
    mass and volume-equivalent diameter, at the gas's number density and equipartition temperature
    (kT = 2 e / (3 + rotational degrees of freedom)).  For the paper's dimer gas it gives 22 s
    (measured: about 25 s), for its sphere gas 11 s (measured: about 11.5 s; docs/granular_gas.md)."""
    from .kinetic import d_hard_spheres_first

    mat, gas, _ = group_tables(spec, g)
    props = shapes.properties(spec["shapes"][g["shape"]], mat["density"])
    m, vol = props["exact"]["mass"], props["exact"]["volume"]
    sigma = (6.0 * vol / math.pi) ** (1.0 / 3.0)
    n = float(gas["volume_fraction"]) / vol                  # particles per m^3 (box^3 = N vol / phi)
    kT = 2.0 * float(gas["energy_per_particle"]) / (3.0 + (2.0 if props["linear"] else 3.0))
    return m * d_hard_spheres_first(n, kT, m, sigma) / kT


def _nice(x, up=False):
    """x rounded to 1, 2, 2.5 or 5 times a power of ten (down, or up with ``up``)."""
    e = 10.0 ** math.floor(math.log10(x))
    steps = [s * e for s in (1.0, 2.0, 2.5, 5.0, 10.0)]
    return min(s for s in steps if s >= x * (1 - 1e-12)) if up else max(s for s in steps if s <= x * (1 + 1e-12))


def physics_defaults(spec):
    """Fill the times a spec leaves out from its gas's velocity correlation time tau_v (the longest of
    its groups', :func:`velocity_correlation_time`), as the committed studies chose them by hand for
    the paper's gas (tau_v about 25 s): ``analysis.max_lag`` = 4 tau_v (the VACF has decayed to
    e^-4), the OLS window ``fit_lo``..``fit_hi`` = 5..7 tau_v (the MSD is linear), ``run.t_end`` =
    40 tau_v (D to a few per cent a run), ``run.rec_interval`` = tau_v / 100; each rounded to 1, 2,
    2.5 or 5 times a power of ten.  ``analysis.t_eq`` defaults to "auto" and ``run.dt_factor`` to
    1.0 (docs/timestep.md).  Records which keys were derived in ``spec["derived"]``."""
    tau = max(velocity_correlation_time(spec, g) for g in spec["groups"])
    a, run = spec["analysis"], spec["run"]
    rules = ((a, "max_lag", _nice(4 * tau, up=True)), (a, "fit_lo", _nice(5 * tau)), (a, "fit_hi", _nice(7 * tau, up=True)),
             (run, "t_end", _nice(40 * tau, up=True)), (run, "rec_interval", _nice(tau / 100)))
    derived = {}
    for table, key, value in rules:
        if table[key] is None:
            table[key] = derived[key] = value
    spec["derived"] = dict(derived, tau_v=tau)


def group_tables(spec, g):
    """(material, gas, run) tables of group ``g``: the spec's, with the group's overrides
    (:data:`OVERRIDES`) applied; copies, the spec is not changed."""
    mat, gas, run = dict(spec["material"]), dict(spec["gas"]), dict(spec["run"])
    for k, t in OVERRIDES.items():
        if g.get(k) is not None:
            {"material": mat, "gas": gas, "run": run}[t][k] = g[k]
    return mat, gas, run


def resolve_run(spec, g, case, seed):
    """The fully resolved parameters of one run (a JSON-able dict); its key is :func:`run_key`."""
    import clumpprops

    mat, gas, run = group_tables(spec, g)
    legacy = spec["run"].get("legacy_dt")
    if legacy and g.get("dt_factor") is None and seed < legacy["below_seed"]:
        # Seeds run before the study's dt_factor was raised keep their factor, so their runs (and
        # keys) stay valid; both cases of a seed always share one time step, so every pair is made
        # at one dt.  studies.effects pools such pairs into one row (docs/timestep.md: the dimer's
        # D moves by 3e-4 between factors 0.5 and 1.0, so a paired ratio by at most 6e-4).
        run["dt_factor"] = legacy["dt_factor"]
    shape = spec["shapes"][g["shape"]]
    props = shapes.properties(shape, mat["density"])
    spheres = dict(spec["spheres"], density=mat["density"])
    cres = gas_model.resolve_case(props, case, spheres, mat.get("friction") or 0.0)
    protocol = gas_model.effective_protocol(cres, props["exact"]["mass"], g["protocol"])
    spin_pairing = gas.pop("spin_pairing", "same")
    p = {
        "model_version": MODEL_VERSION,
        "yade": spec["study"]["yade"],
        "clumpprops_version": clumpprops.__version__,
        "shape": {"members": np.round(props["members"], 15).tolist(), "radii": props["radii"],
                  "definition": shape},
        "material": {k: float(v) for k, v in mat.items() if v is not None},
        "gas": {k: (float(v) if k not in ("n_particles", "start") else v) for k, v in gas.items()},
        "run": {k: float(run[k]) for k in ("t_end", "rec_interval", "dt_factor")},
        "case": case, "protocol": protocol, "seed": int(seed),
    }
    if run.get("cooling_stop") is not None:
        p["run"]["cooling_stop"] = float(run["cooling_stop"])
    if case == "spheres":
        p["spheres"] = {"diameter": spec["spheres"]["diameter"], "mass": spec["spheres"]["mass"]}
    if spin_pairing == "own" and spin_pairing_matters(p, cres, cres["route"] == "isotropic"):
        p["gas"]["spin_pairing"] = "own"
    return p


def spin_pairing_matters(params, case_res, linear):
    """True when ``gas.spin_pairing`` changes a run's initial state (see
    :func:`studies.gas_model.initial_state`): an equipartition start of a clump case other than
    exact, in the paired protocol, or in equal energy for an aspherical clump.  Only then is
    ``"own"`` part of the run's parameters (and key); elsewhere both pairings give the same state,
    so runs made before the option existed keep their keys."""
    return (params["gas"].get("start") == "equipartition" and case_res["body"] == "clump"
            and params["case"] != "exact" and (params["protocol"] == "paired" or not linear))


def spin_pairing_of(params):
    """The spin pairing a run record was made with: "own", "same", or None where it does not matter
    (records made before the option existed carry none and were made with "same")."""
    g = params["gas"]
    if g.get("spin_pairing"):
        return g["spin_pairing"]
    if g.get("start") != "equipartition" or params["case"] in ("exact", "spheres"):
        return None
    if params["protocol"] == "paired":
        return "same"
    linear = shapes.properties(params["shape"]["definition"], params["material"]["density"])["linear"]
    return None if linear else "same"


def run_key(params):
    """16 hex digits of the SHA-256 of the canonical JSON of a run's resolved parameters."""
    return hashlib.sha256(json.dumps(params, sort_keys=True, separators=(",", ":")).encode()).hexdigest()[:16]


def runs(spec, extra_seeds=None):
    """Every run of a spec in priority order (group by group, seed by seed), without duplicates.

    Returns dicts ``{key, name, group, rank, shape, case, protocol, seed, params}``; ``rank`` is the
    seed's place in its group's list (0 for the first seed), which the driver's ``round_robin``
    schedule queues by.  ``extra_seeds`` maps a group index to seeds added by sequential design.
    """
    out, seen = [], set()
    for gi, g in enumerate(spec["groups"]):
        seeds = list(g["seeds"]) + list((extra_seeds or {}).get(gi, []))
        for rank, seed in enumerate(seeds):
            for case in g["cases"]:
                params = resolve_run(spec, g, case, seed)
                key = run_key(params)
                if key in seen:
                    continue
                seen.add(key)
                label = g.get("label") or g["shape"]
                out.append({"key": key, "name": f"{label}-{case}-{params['protocol']}-s{seed}-{key[:8]}",
                            "group": gi, "rank": rank, "shape": g["shape"], "case": case, "protocol": params["protocol"],
                            "seed": int(seed), "params": params})
    return out


def time_step(params, props=None):
    """The run's time step dt [s]: ``run.dt_factor`` x r_min sqrt(rho/E), the P-wave step of the
    shape's smallest member sphere (every case of a shape, the reference spheres too, runs at it).
    ``props``: :func:`studies.shapes.properties` of the shape, if already computed."""
    mat = params["material"]
    if props is None:
        props = shapes.properties(params["shape"]["definition"], mat["density"])
    return params["run"]["dt_factor"] * min(props["radii"]) * math.sqrt(mat["density"] / mat["youngs_modulus"])


def run_input(spec_or_params, params=None, record=True, progress_period=20.0):
    """The run file of one run (what ``yade_scripts/granular_gas.py`` reads): a JSON-able dict with
    material, box, time step, the body and the initial state of every particle."""
    p = params if params is not None else spec_or_params
    mat, gas, run = p["material"], p["gas"], p["run"]
    shape = p["shape"]["definition"]
    props = shapes.properties(shape, mat["density"])
    spheres = dict(p.get("spheres", {}), density=mat["density"])
    cres = gas_model.resolve_case(props, p["case"], spheres, mat.get("friction", 0.0))
    ex = props["exact"]
    n = int(gas["n_particles"])
    box = gas_model.box_length(n, ex["volume"], gas["volume_fraction"])
    rb = max(shapes.bounding_radius(shape, mat["density"]), cres.get("radius", 0.0))
    case_tensor = np.asarray(props[cres["inertia_source"] or "exact"]["inertia"])
    pos, ori, vel, angvel = gas_model.initial_state(
        p["seed"], n, box, rb, cres, ex["mass"], np.asarray(ex["inertia"]), case_tensor, p["protocol"],
        gas["energy_per_particle"], gas["start"], props["linear"] and cres["route"] == "isotropic", spin_pairing=gas.get("spin_pairing", "same"),
        spin_ratio=float(gas.get("spin_ratio", 0.0)))
    dt = time_step(p, props)
    n_steps = int(round(run["t_end"] / dt))
    rec_steps = max(1, int(round(run["rec_interval"] / dt)))
    body = {"builder": cres["builder"], "route": cres["route"], "mass": cres["mass"], "moments": cres["moments"]}
    if cres["body"] == "sphere":
        body["radius"] = cres["radius"]
    else:
        body.update(members=props["members"], radii=props["radii"])
    rin = {"material": mat, "box_length": box, "dt": dt, "n_steps": n_steps, "rec_steps": rec_steps,
           "rot_algorithm": "delValle2023", "body": body, "record": bool(record),
           "progress_period": float(progress_period),
           "initial": {"pos": pos.tolist(), "ori": ori.reshape(n, 9).tolist(), "vel": vel.tolist(),
                       "angvel": angvel.tolist()},
           "case": cres, "rot_dof": cres["rot_dof"], "exact_mass": ex["mass"]}
    if "cooling_stop" in run:
        rin["cooling_stop"] = float(run["cooling_stop"])
    return rin
