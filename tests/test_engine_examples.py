"""The runnable engine inputs of docs/engines.md (examples/engines/) run in the real engines and
report clumpprops' exact values for the paper's dimer."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from clumpprops import mass_properties
from clumpprops.cli import main as cli_main

from _engines import LAMMPS, LIGGGHTS, read_dump, run, thermo_rows

EX = Path(__file__).resolve().parents[1] / "examples" / "engines"
D = 0.1333
EXACT = mass_properties([[0, 0, -D / 4], [0, 0, D / 4]], [D / 2, D / 2], density=1140.0)


def _export(tmp_path, engine, capsys):
    assert cli_main(["export", str(EX / "dimer.csv"), "--to", engine, "--density", "1140", "--out", str(tmp_path)]) == 0
    capsys.readouterr()


def test_liggghts_example(tmp_path, capsys):
    _export(tmp_path, "liggghts", capsys)
    shutil.copy(EX / "in.liggghts", tmp_path)
    head, rows = thermo_rows(run(LIGGGHTS, tmp_path / "in.liggghts", tmp_path))[-1]
    assert rows[-1][head.index("mass")] == pytest.approx(EXACT.mass, rel=1e-15)
    assert rows[-1][head.index("wIw")] == pytest.approx(EXACT.inertia[0, 0], rel=1e-14)


@pytest.mark.parametrize("inp,step", [("in.lammps", 0), ("in.lammps_mol", 1)])
def test_lammps_examples(tmp_path, capsys, inp, step):
    _export(tmp_path, "lammps", capsys)
    shutil.copy(EX / inp, tmp_path)
    run(LAMMPS, tmp_path / inp, tmp_path)
    a = read_dump(tmp_path / "rigid.dump")[step][1][0]
    assert a[0] == pytest.approx(EXACT.mass, rel=1e-15)
    assert np.allclose(np.sort(a[4:7]), EXACT.principal_moments, rtol=1e-14, atol=0)
