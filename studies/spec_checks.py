"""Checks of a study spec's values: types and ranges of every key (:func:`check_table`), a clump
that is one rigid body (:func:`check_one_body`), a gas that random placement can reach
(:func:`check_placement`) and an analysis that fits in the run (:func:`check_analysis_window`).
Each failure is one :class:`SpecError` naming the key.  :mod:`studies.spec` runs them.
"""
from __future__ import annotations

import copy
import math

import numpy as np

from . import gas_model
from . import shapes

YADE_VERSIONS = ("2023.02a", "2025.2")
# [study] schedule: the order runs are queued in.  "in_order": group by group, seed by seed, so a
# sequential group's added seeds go before every later group's runs (the spec's groups in order of
# importance).  "round_robin": every group's k-th seed before any group's (k+1)-th, so a study
# stopped by its budget or by the machine going down holds an interval for every group (independent questions
# of similar importance).  Not part of any run key.
SCHEDULES = ("in_order", "round_robin")


class SpecError(ValueError):
    """A bad study spec; the message names the key (``table.key``) and the file."""


def _flat(typ):
    out = []
    for t in (typ if isinstance(typ, tuple) else (typ,)):
        out.extend(_flat(t) if isinstance(t, tuple) else [t])
    return tuple(out)


def check_value(where, v, typ, check):
    if (isinstance(v, bool) and bool not in _flat(typ)) or not isinstance(v, _flat(typ)):
        raise SpecError(f"{where}: expected {_tname(typ)}, got {v!r}")
    if isinstance(v, float) and not math.isfinite(v):
        raise SpecError(f"{where}: must be finite, got {v!r}")
    num = isinstance(v, (int, float)) and not isinstance(v, bool)
    if check == "pos" and num and not v > 0:
        raise SpecError(f"{where}: must be > 0, got {v!r}")
    if check == "nonneg" and num and not v >= 0:
        raise SpecError(f"{where}: must be >= 0, got {v!r}")
    if check == "frac" and not 0 < v < 1:
        raise SpecError(f"{where}: must be in (0, 1), got {v!r}")
    if check == "poisson" and not -1 < v < 0.5:
        raise SpecError(f"{where}: must be in (-1, 0.5), got {v!r}")
    if check == "yade" and v not in YADE_VERSIONS:
        raise SpecError(f"{where}: YADE version must be one of {', '.join(YADE_VERSIONS)}, got {v!r}")
    if check == "spin_pairing" and v not in gas_model.SPIN_PAIRINGS:
        raise SpecError(f"{where}: unknown spin pairing {v!r} (known: {', '.join(gas_model.SPIN_PAIRINGS)})")
    if check == "start" and v not in gas_model.STARTS:
        raise SpecError(f"{where}: must be one of {', '.join(gas_model.STARTS)}, got {v!r}")
    if check == "protocol" and v not in gas_model.PROTOCOLS:
        raise SpecError(f"{where}: must be one of {', '.join(gas_model.PROTOCOLS)}, got {v!r}")
    if check == "restitution" and num and not 0 < v <= 1:
        raise SpecError(f"{where}: a coefficient of restitution must be in (0, 1], got {v!r}")
    if check == "cooling_stop" and num and not v > 1:
        raise SpecError(f"{where}: must be > 1 (the factor T_tr falls by before the run stops), got {v!r}")
    if check == "kind" and v not in shapes.KINDS:
        raise SpecError(f"{where}: must be one of {', '.join(shapes.KINDS)}, got {v!r}")
    if check == "schedule" and v not in SCHEDULES:
        raise SpecError(f"{where}: must be one of {', '.join(SCHEDULES)}, got {v!r}")
    if check == "smass" and v not in ("exact", "density"):
        raise SpecError(f"{where}: must be 'exact' (the exact clump mass) or 'density', got {v!r}")
    if check == "diameter":
        if isinstance(v, str) and v != "equal_volume":
            raise SpecError(f"{where}: must be a diameter in m or 'equal_volume', got {v!r}")
        if num and not v > 0:
            raise SpecError(f"{where}: must be > 0, got {v!r}")
    if check == "t_eq":
        if isinstance(v, str) and v != "auto":
            raise SpecError(f"{where}: must be a time in s or 'auto', got {v!r}")
        if num and not v >= 0:
            raise SpecError(f"{where}: must be >= 0, got {v!r}")


def _tname(typ):
    names = {bool: "true or false", int: "an integer", float: "a number", str: "a string", list: "a list", dict: "a table"}
    ts = _flat(typ)
    return " or ".join(dict.fromkeys(names[t] for t in ts if not (t is int and float in ts)))


def check_table(where, d, keys):
    if not isinstance(d, dict):
        raise SpecError(f"{where}: expected a table, got {d!r}")
    for k in d:
        if k not in keys:
            raise SpecError(f"{where}.{k}: unknown key (known: {', '.join(keys)})")
    out = {}
    for k, (typ, req, default, check) in keys.items():
        if k not in d:
            if req:
                raise SpecError(f"{where}.{k}: missing")
            out[k] = copy.deepcopy(default)
            continue
        check_value(f"{where}.{k}", d[k], typ, check)
        out[k] = d[k]
    return out


def check_one_body(where, shape, centers, radii):
    """A clump must be one rigid body: every sphere overlaps the others in one connected set, and
    none is coincident with or inside another (it would add nothing to the union and its mass
    twice to the sum)."""
    d = np.linalg.norm(centers[:, None] - centers[None], axis=2)
    scale = float(np.max(radii))
    inside = d + radii[:, None] <= radii[None] + 1e-12 * scale
    np.fill_diagonal(inside, False)
    if inside.any():
        i, j = np.argwhere(inside)[0]
        raise SpecError(f"{where}: sphere {i} is coincident with or inside sphere {j}; remove it")
    touching = d <= (radii[:, None] + radii[None]) * (1 + 1e-12)        # overlapping or touching
    reached, todo = {0}, [0]
    while todo:
        for j in np.flatnonzero(touching[todo.pop()]):
            if int(j) not in reached:
                reached.add(int(j))
                todo.append(int(j))
    if len(reached) < len(radii):
        hint = (" (overlap = D/d_s must be < 1 for the spheres to overlap)" if shape["kind"] != "file" else
                f" (is the file in metres? scale = {shape.get('scale', 1.0)})")
        raise SpecError(f"{where}: the spheres do not form one body: sphere {min(set(range(len(radii))) - reached)} "
                        f"overlaps none of the spheres connected to sphere 0{hint}")


# random sequential addition (studies.gas_model.random_sequential_positions) of the bounding spheres
# reaches this share of the box within its 1000 n tries (its jamming limit is 0.38)
PLACEMENT_LIMIT = 0.25


def check_placement(where, spec, g, tables):
    """The gas of group ``g`` (whose (material, gas, run) ``tables`` are given) can be placed: its particles' bounding spheres (plus the start's gap)
    fill at most :data:`PLACEMENT_LIMIT` of the box."""
    mat, gas, _ = tables
    props = shapes.properties(spec["shapes"][g["shape"]], mat["density"])
    spheres = dict(spec["spheres"], density=mat["density"])
    rb = max([shapes.bounding_radius(spec["shapes"][g["shape"]], mat["density"])] +
             [gas_model.resolve_case(props, c, spheres).get("radius", 0.0) for c in g["cases"]])
    n, phi = int(gas["n_particles"]), float(gas["volume_fraction"])
    box = gas_model.box_length(n, props["exact"]["volume"], phi)
    filled = n * math.pi / 6 * (2 * rb + gas_model.PLACEMENT_GAP) ** 3 / box ** 3
    if filled > PLACEMENT_LIMIT:
        raise SpecError(f"{where}: gas.volume_fraction = {phi:g} cannot be placed: the particles' bounding spheres "
                        f"would fill {filled:.2f} of the box and random placement reaches {PLACEMENT_LIMIT}; "
                        f"use volume_fraction <= {phi * PLACEMENT_LIMIT / filled:.3g}")


def check_analysis_window(where, spec, g, tables):
    """The analysis fits the run: t_eq, the cuts, the MSD fit window and the VACF lags inside the
    run length of group ``g`` (``tables``: its (material, gas, run))."""
    _, _, run = tables
    a, t_end = spec["analysis"], float(run["t_end"])
    t_eq = a["t_eq"] if not isinstance(a["t_eq"], str) else 0.0
    start = max([t_eq] + list(a["cuts"]) + [float(s[0]) for s in a["sensitivity"]])
    if start > t_end - 3 * float(run["rec_interval"]):          # a window of fewer than 4 frames is never stored
        key = ("analysis.t_eq" if t_eq >= start else "analysis.cuts" if start in a["cuts"]
               else "analysis.sensitivity")
        raise SpecError(f"{where}: {key} = {start:g} s is too close to the end of the run (t_end = {t_end:g} s; "
                        f"a window needs 4 recorded frames)")
    window = t_end - start
    for key in ("max_lag", "fit_hi"):
        if a[key] >= window:
            raise SpecError(f"{where}: analysis.{key} = {a[key]:g} s does not fit the analysed window of "
                            f"{window:g} s (t_end {t_end:g} s from t = {start:g} s): lengthen the run or shorten the lags")
