"""The project README's headline numbers ("What the study has found so far") against the committed
tables, so that the README stays true with every landing of new runs:

* every ``value [low, high]`` interval of that section stands, to the letter, in the generated
  report results/README.md (itself checked against the tables in tests/test_report.py);
* the findings table names every effects.csv comparison (but the spheres and the same-spin
  control): its value to the report's two decimals, its seed pairs and, where given, its
  half-width, in the table row that answers that question.
"""
import math
import re

import pandas as pd
import pytest

from studies import spec as S
from studies.report import interval, pct

MINUS = "\u2212"

# the findings table's rows (by the start of their first cell): the effects.csv rows they give, in
# the order they give them, as (shape, overlap, protocol, Young's modulus [Pa], case); and whether
# the row gives each one's 95 % interval (True) or its value alone (False)
TABLE = {
    "the paper's dimer, uncorrected vs exact, same velocities": ([("dimer", 0.5, "paired", 1e7, "uncorrected")], True),
    "... mass corrected alone": ([("dimer", 0.5, "paired", 1e7, "mass_only")], True),
    "... inertia corrected alone": ([("dimer", 0.5, "paired", 1e7, "inertia_only")], True),
    "... same kinetic energy": ([("dimer", 0.5, "equal_energy", 1e7, "uncorrected")], True),
    "triangle trimer, tetrahedron, dimers at": ([
        ("trimer_triangle", 0.5, "paired", 1e7, "uncorrected"),
        ("tetrahedron", 0.5, "paired", 1e7, "uncorrected"),
        ("dimer", 0.25, "paired", 1e7, "uncorrected"),
        ("dimer", 0.75, "paired", 1e7, "uncorrected")], False),
    "the same shapes, same kinetic energy": ([
        ("trimer_triangle", 0.5, "equal_energy", 1e7, "uncorrected"),
        ("tetrahedron", 0.5, "equal_energy", 1e7, "uncorrected"),
        ("dimer", 0.25, "equal_energy", 1e7, "uncorrected"),
        ("dimer", 0.75, "equal_energy", 1e7, "uncorrected")], False),
    "the hard-particle limit": ([
        ("dimer", 0.5, "paired", 1e8, "mass_only"),
        ("dimer", 0.5, "paired", 1e9, "mass_only")], True),
}
NOT_IN_TABLE = {"spheres", "paired_same_spin"}     # a case and a protocol the table does not carry


def _norm(s):
    return s.replace(MINUS, "-")


@pytest.fixture(scope="module")
def section():
    text = open(S.ROOT + "/README.md", encoding="utf-8").read()
    head = "## What the study has found so far"
    assert head in text
    return _norm(text.split(head, 1)[1].split("\n## ", 1)[0])


@pytest.fixture(scope="module")
def table(section):
    rows = {}
    for line in section.splitlines():
        if line.startswith("| ") and not line.startswith("| question") and not line.startswith("|---"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            rows[cells[0]] = cells
    return rows


@pytest.fixture(scope="module")
def effects():
    df = pd.read_csv(S.ROOT + "/results/effects.csv")
    return {(r.shape, float(r.overlap), r.protocol, float(r.youngs_modulus), r.case): r
            for r in df.itertuples()}


def test_every_interval_of_the_findings_is_the_reports(section):
    report = _norm(open(S.ROOT + "/results/README.md", encoding="utf-8").read())
    found = re.findall(r"[+-]?\d+\.\d+(?: %)? \[[+-]?\d+\.\d+, [+-]?\d+\.\d+\]", section)
    assert len(found) >= 8
    missing = [f for f in found if f not in report]
    assert not missing, f"README findings intervals not in results/README.md: {missing}"


def test_the_findings_table_gives_every_effect(table, effects):
    wanted = {k for k, r in effects.items() if r.case not in NOT_IN_TABLE and r.protocol not in NOT_IN_TABLE}
    given = {k for keys, _ in TABLE.values() for k in keys}
    assert given == wanted, f"effects.csv rows the README table does not give: {sorted(wanted - given)}; " \
                            f"given but not in effects.csv: {sorted(given - wanted)}"
    for start, (keys, with_interval) in TABLE.items():
        row = [cells for first, cells in table.items() if first.startswith(start)]
        assert len(row) == 1, f"README findings table: no single row starting {start!r}"
        first, answer, pairs = row[0][:3]
        # the values in order, each with the report's interval where the row gives intervals
        at = 0
        for k in keys:
            e = effects[k]
            v = pct(e.relative)
            if with_interval:
                v += " " + interval(e.relative_ci_low, e.relative_ci_high)
            pos = answer.find(v, at)
            assert pos >= 0, f"{start}: {v} ({k}) not in {answer!r} after position {at}"
            at = pos + len(v)
        # the seed pairs: "N each", or one count per value
        n = [int(effects[k].n_pairs) for k in keys]
        counts = [int(x) for x in re.findall(r"\d+", pairs)]
        if "each" in pairs:
            assert counts == [n[0]] and len(set(n)) == 1, (start, pairs, n)
        else:
            assert counts == n, (start, pairs, n)
        # the half-widths, where the row states them
        hw = re.search(r"half-widths ([\d., ]+) %", answer)
        if hw:
            got = [float(x) for x in hw.group(1).split(",")]
            want = [100 * (effects[k].relative_ci_high - effects[k].relative_ci_low) / 2 for k in keys]
            assert len(got) == len(want) and all(math.isclose(g, w, abs_tol=0.0051) for g, w in zip(got, want)), \
                (start, got, want)
        else:
            # a range of half-widths ("half-widths 0.9-1.4 %") must contain every one
            rng = re.search(r"half-widths (\d+\.\d+)-(\d+\.\d+) %", answer)
            if rng:
                a, b = float(rng.group(1)), float(rng.group(2))
                for k in keys:
                    h = 100 * (effects[k].relative_ci_high - effects[k].relative_ci_low) / 2
                    assert a - 0.051 <= h <= b + 0.051, (start, k, h)
