"""The predictions table, ``results/predictions.csv``: its columns, the gas intervals beside each
prediction, and how a new prediction or a changed gas table updates it.

``python -m studies predict`` (:mod:`studies.predict`) writes the table; ``python -m
studies.report`` refreshes its gas columns (:func:`refresh_gas`).  Nothing here runs YADE.
"""
from __future__ import annotations

import csv
import os
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "results", "predictions.csv")
EFFECTS = os.path.join(ROOT, "results", "effects.csv")
HCS_EFFECTS = os.path.join(ROOT, "results", "hcs_effects.csv")
COLUMNS = ["shape", "youngs_modulus", "restitution", "friction", "case", "observable", "predicted",
           "predicted_se", "cpu_s", "gas_relative", "gas_ci_low", "gas_ci_high"]
GAS = ("gas_relative", "gas_ci_low", "gas_ci_high")
KEY = ("shape", "youngs_modulus", "restitution", "friction", "case", "observable")

__all__ = ["OUT", "EFFECTS", "HCS_EFFECTS", "COLUMNS", "is_elastic", "gas_intervals", "hcs_intervals", "merged",
           "refresh_gas", "write_table"]


def is_elastic(law):
    """True for an elastic, frictionless contact law (restitution 1, friction 0)."""
    return law[1] == 1.0 and law[2] == 0.0


def _intervals(path, key, keep=lambda r: True):
    """``{key(row): (relative, ci_low, ci_high)}`` of the rows of an effects table that ``keep``;
    empty when ``path`` does not exist."""
    if not os.path.exists(path):
        return {}
    with open(path, newline="") as f:
        return {key(r): tuple(float(r[k]) for k in ("relative", "relative_ci_low", "relative_ci_high"))
                for r in csv.DictReader(f) if keep(r)}


def gas_intervals(path=EFFECTS):
    """The committed gas effects: (shape, overlap, protocol, youngs_modulus, case) -> (relative,
    ci_low, ci_high); empty when ``path`` does not exist.

    Parameters
    ----------
    path : str
        A table with the columns of ``results/effects.csv``.

    Returns
    -------
    dict
    """
    return _intervals(path, lambda r: (r["shape"], f"{float(r['overlap']):g}" if r["overlap"] else "", r["protocol"],
                                       float(r["youngs_modulus"]), r["case"]))


def hcs_intervals(path=HCS_EFFECTS):
    """The committed cooling-gas effects of the paired protocol: (shape, youngs_modulus, restitution,
    friction, case, observable) -> (relative, ci_low, ci_high); empty when ``path`` does not exist.

    Parameters
    ----------
    path : str
        A table with the columns of ``results/hcs_effects.csv``.

    Returns
    -------
    dict
    """
    return _intervals(path, lambda r: (r["shape"], float(r["youngs_modulus"]), float(r["restitution"]),
                                       float(r["friction"]), r["case"], r["observable"]),
                      keep=lambda r: r["protocol"] == "paired")


def merged(rows, path, gas=None, hcs_gas=None):
    """``rows`` with the rows of the table at ``path`` that they do not replace: a row of another
    (shape, youngs_modulus, restitution, friction) stays, its gas columns brought up to date from
    ``gas`` (:func:`gas_intervals`) where its shape is a template (effects.csv names it by the
    template's file stem, with no overlap), and from ``hcs_gas`` (:func:`hcs_intervals`) for a
    cooling row.

    Parameters
    ----------
    rows : list of dict
        New rows (keys ``COLUMNS``).
    path : str
        The table (absent: ``rows`` alone).
    gas : dict, optional
        The committed elastic gas intervals.
    hcs_gas : dict, optional
        The committed cooling gas intervals.

    Returns
    -------
    list of dict
    """
    if not os.path.exists(path):
        return list(rows)
    with open(path, newline="") as f:
        old = list(csv.DictReader(f))
    law = lambda r: (r["shape"], r["youngs_modulus"], r["restitution"], r["friction"])     # noqa: E731
    new = {law(r) for r in rows}
    kept = []
    for r in old:
        if law(r) in new or set(r) != set(COLUMNS):
            continue
        case, _, prot = r["case"].partition("/")
        contact = (float(r["youngs_modulus"]), float(r["restitution"]), float(r["friction"]))
        if is_elastic(contact):
            g = (gas or {}).get((r["shape"], "", prot, contact[0], case))
        else:
            g = (hcs_gas or {}).get((r["shape"], *contact, case, r["observable"]))
        if g is not None:
            r = dict(r, gas_relative=f"{g[0]:.6g}", gas_ci_low=f"{g[1]:.6g}", gas_ci_high=f"{g[2]:.6g}")
        kept.append(r)
    return kept + list(rows)


def refresh_gas(path=OUT, gas_path=EFFECTS, hcs_path=HCS_EFFECTS):
    """Bring the gas columns of the predictions table at ``path`` up to date with the gas tables,
    running nothing (``python -m studies.report`` calls it after the gas tables change).  A row
    whose gas table has its interval gets it; a row without one keeps what it holds.

    Parameters
    ----------
    path : str
        The predictions table (absent: nothing to do).
    gas_path, hcs_path : str
        The elastic and the cooling gas effects tables.

    Returns
    -------
    int
        The rows whose gas columns changed; the file is rewritten (atomically) only when some did.

    Raises
    ------
    ValueError
        A table whose header is not ``COLUMNS``: it is left as it is, never emptied.
    """
    if not os.path.exists(path):
        return 0
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        old = list(reader)
        header = reader.fieldnames
    if header != COLUMNS or any(None in r for r in old):
        raise ValueError(f"{path}: its columns are not {', '.join(COLUMNS)}; not refreshed")
    new = merged([], path, gas_intervals(gas_path), hcs_intervals(hcs_path))
    if [tuple(r[k] for k in KEY) for r in new] != [tuple(r[k] for k in KEY) for r in old]:
        raise ValueError(f"{path}: refreshing its gas columns would change its rows; not refreshed")
    changed = sum(any(a[k] != b[k] for k in GAS) for a, b in zip(old, new))
    if changed:
        write_table(new, path)
    return changed


def write_table(rows, path):
    """Write ``rows`` (dicts with the keys ``COLUMNS``) as CSV to ``path``, through a temporary file
    in the same folder, so that a reader never sees half a table."""
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".predictions-", suffix=".csv", dir=folder)
    try:
        with os.fdopen(fd, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=COLUMNS)
            w.writeheader()
            w.writerows(rows)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
