"""A study's own report page, ``<results>/README.md``: what it ran and what it found, from its tables.

Rendered from ``studies/templates/study.md.j2`` (Jinja2) with the values of ``params.json``,
``diff_D.csv`` and the figures :mod:`studies.gas_plots` drew or could not draw (and why).  The
project's headline (``results/README.md``) is another page, :mod:`studies.report`.
"""
from __future__ import annotations

import json
import os

from . import gas_plots

TEMPLATES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "templates")


def _num(x, fmt="g"):
    """A number for the page, or "?" where the table does not hold it."""
    return "?" if x is None or x != x else format(x, fmt)


def _pct(x):
    return f"{100 * x:+.2f} %"


def _paired_rows(out):
    t = gas_plots._read(os.path.join(out, "diff_D.csv"))
    rows = []
    for r in ([] if t is None else t.itertuples()):
        has_ci = r.relative_ci_low == r.relative_ci_low
        rows.append({"case": r.case, "protocol": r.protocol, "n_seeds": r.n_seeds, "relative": _pct(r.relative),
                     "interval": f"[{_pct(r.relative_ci_low)}, {_pct(r.relative_ci_high)}]" if has_ci else "one pair: none"})
    return rows


def _grains(p):
    """Each shape's sphere count and its summed mass and k^2 errors against the exact union."""
    from . import shapes as shp

    rho = p.get("material", {}).get("density")
    out = []
    for name, shape in (p.get("shapes") or {}).items():
        if rho is None:
            continue
        k2 = shp.k2_error(shape, rho)
        out.append({"name": name, "n_spheres": len(shp.properties(shape, rho)["radii"]),
                    "mass_error": _pct(shp.mass_error(shape, rho)),
                    "k2_error": _pct(k2) if k2 == k2 else "?"})
    return out


def context(out):
    """The template's values for the study whose tables are in ``out``."""
    with open(os.path.join(out, "params.json")) as f:
        p = json.load(f)
    study, mat, gas = p.get("study", {}), p.get("material", {}), p.get("gas", {})
    figures = [f for f in ("fig2_msd.png", "ratio.png", "energy_partition.png", "diffusion.png")
               if os.path.exists(os.path.join(out, f))]
    return {
        "name": study.get("name", os.path.basename(out)), "description": study.get("description", ""),
        "spec": p.get("spec", "?"), "n_ok": p.get("n_runs_ok", 0), "n_excluded": p.get("n_runs_excluded", 0),
        "n_missing": p.get("n_runs_missing", 0),
        "yade_versions": ", ".join(p.get("yade_versions", [])) or "?",
        "rot_algorithms": ", ".join(p.get("rot_algorithms", [])) or "?",
        "clumpprops_versions": ", ".join(p.get("clumpprops_versions", [])) or "?",
        "n_particles": p.get("n_particles"), "shapes": ", ".join(p.get("shapes", {})),
        "volume_fraction": _num(gas.get("volume_fraction", p.get("volume_fraction"))),
        "box_length": _num(p.get("box_length"), ".4g"), "t_end": _num(p.get("t_end")), "dt": _num(p.get("dt"), ".3g"),
        "t_eq": f"t_eq = {_num(p['t_eq'])} s" if isinstance(p.get("t_eq"), (int, float))
                else "t_eq detected per run (auto: the whole run from an equilibrated start)",
        "grains": _grains(p),
        "density": _num(mat.get("density")), "youngs_modulus": _num(mat.get("youngs_modulus")),
        "poisson": _num(mat.get("poisson")),
        "paired": _paired_rows(out), "figures": figures, "not_drawn": gas_plots.not_drawn(out),
    }


def render(out):
    """The page's Markdown for the study whose tables are in ``out``."""
    import jinja2

    env = jinja2.Environment(loader=jinja2.FileSystemLoader(TEMPLATES), keep_trailing_newline=True,
                             undefined=jinja2.StrictUndefined)
    return env.get_template("study.md.j2").render(**context(out))


def write(out, log=print):
    """Write ``out``/README.md; returns its path."""
    path = os.path.join(out, "README.md")
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as f:
        f.write(render(out))
    os.replace(tmp, path)
    log(f"[plot] wrote {path}")
    return path
