"""``clumpprops FILE --shape``: the exact shape descriptors in the table, csv and json formats."""
import csv
import io
import json

import numpy as np
import pytest

from clumpprops import shape_descriptors
from clumpprops.cli import main

DIMER = "0 0 0 0.5 1\n0 0 0.4 0.5 1\n1 1 1 0.3 2\n"
AREA = 2 * np.pi * 0.5 * (0.5 + 0.2) * 2  # two exposed zones of the dimer (Archimedes), m^2


@pytest.fixture
def clump_file(tmp_path):
    path = tmp_path / "clumps.txt"
    path.write_text(DIMER)
    return str(path)


def _run(capsys, *argv):
    status = main(list(argv))
    out = capsys.readouterr()
    return status, out.out, out.err


def test_json_holds_every_descriptor(capsys, clump_file):
    status, out, _ = _run(capsys, clump_file, "--shape", "--format", "json")
    assert status == 0
    clumps = json.loads(out)["clumps"]
    first, second = clumps[0]["shape"], clumps[1]["shape"]
    assert first["surface_area"] == pytest.approx(AREA, rel=1e-14)
    assert second["surface_area"] == pytest.approx(4 * np.pi * 0.3**2, rel=1e-14)
    assert second["sphericity"] == pytest.approx(1.0, rel=1e-14)
    assert first["bounding_radius"] == pytest.approx(0.7, rel=1e-13)
    expected = shape_descriptors([[0, 0, 0], [0, 0, 0.4]], [0.5, 0.5]).to_dict()
    assert set(first) == set(expected)


def test_csv_adds_columns(capsys, clump_file):
    status, out, _ = _run(capsys, clump_file, "--shape", "--format", "csv")
    assert status == 0
    rows = list(csv.DictReader(io.StringIO(out)))
    assert len(rows) == 2
    assert float(rows[0]["surface_area_m2"]) == pytest.approx(AREA, rel=1e-14)
    assert float(rows[0]["elongation"]) == pytest.approx(1.0 / 1.4, rel=1e-14)
    assert float(rows[1]["kappa_3"]) == pytest.approx(0.4, rel=1e-14)


def test_table_adds_a_shape_block(capsys, clump_file):
    status, out, _ = _run(capsys, clump_file, "--shape")
    assert status == 0
    lines = out.splitlines()
    head = next(k for k, line in enumerate(lines) if "sphericity" in line and "kappa_1" in line)
    first = lines[head + 1].split()
    assert first[0] == "1" and float(first[1]) == pytest.approx(AREA, rel=1e-5)


def test_without_shape_the_output_is_unchanged(capsys, clump_file):
    _, plain, _ = _run(capsys, clump_file, "--format", "json")
    assert "shape" not in json.loads(plain)["clumps"][0]
    _, table, _ = _run(capsys, clump_file)
    assert "sphericity" not in table
