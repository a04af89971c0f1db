"""Input formats detected by content: every real-file layout the main command and clumpprops.io read.

The files are written here, small, in each layout (CLUMP and MClump comma tables named .txt,
LAMMPS molecule files under any name, LIGGGHTS sphere lists and input scripts, the DEME JSON and
MClump folder that ``clumpprops export`` writes); the dimer of two unit spheres 1 apart has the
union volume 8 pi/3 - 5 pi/12 = 9 pi/4 (two balls less one lens), an independent check.
"""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

from clumpprops.cli import main as cli_main
from clumpprops.io import FORMATS, ClumpFileError, detect_format, export, read

DIMER_VOLUME = 9.0 * math.pi / 4.0  # unit spheres at distance 1: 2 (4 pi/3) - pi (4 + 1)(2 - 1)^2 / 12

LAYOUTS = {  # name -> (file name, text, format detected)
    "clump_csv_txt": ("clump.txt", "0,0,0,1\n1,0,0,1\n", "csv"),
    "clump_csv_header_txt": ("clump.txt", "x,y,z,r\n0,0,0,1\n1,0,0,1\n", "csv"),
    "mclump_spaced_commas": ("Clump_2.txt", "0, 0, 0, 1\n1, 0, 0, 1\n", "csv"),
    "liggghts_test": ("stone1.test", "0 0 0 1\n1 0 0 1\n", "liggghts"),
    "liggghts_header": ("stone1.test", "x y z r\n0 0 0 1\n1 0 0 1\n", "liggghts"),
    "lammps_vshape": ("molecule.vshape", "# dimer\n\n2 atoms\n\nCoords\n\n1 0 0 0\n2 1 0 0\n\nDiameters\n\n1 2\n2 2\n",
                      "lammps"),
    "lammps_data": ("molecule.data", "dimer\n\n2 atoms\n2 mass\n\nCoords\n\n1 0 0 0\n2 1 0 0\n\nDiameters\n\n1 2\n2 2\n",
                    "lammps"),
    "yade_textclumps": ("clumps.dat", "0 0 0 1 7\n1 0 0 1 7\n", "yade"),
}


def _write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize("layout", sorted(LAYOUTS))
def test_layout_is_detected_and_read(tmp_path, layout):
    name, text, fmt = LAYOUTS[layout]
    p = _write(tmp_path, name, text)
    assert detect_format(p) == fmt
    (c,) = read(p)
    assert np.array_equal(c.centers, [[0, 0, 0], [1, 0, 0]]) and np.array_equal(c.radii, [1, 1])


@pytest.mark.parametrize("layout", sorted(LAYOUTS))
def test_main_command_reads_the_layout(tmp_path, layout, capsys):
    name, text, _ = LAYOUTS[layout]
    p = _write(tmp_path, name, text)
    assert cli_main([str(p), "--format", "csv"]) == 0, capsys.readouterr().err
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 2
    volume = float(out[1].split(",")[3])
    assert volume == pytest.approx(DIMER_VOLUME, rel=1e-14)


def test_lammps_molecule_without_diameters_asks_for_diameter(tmp_path, capsys):
    p = _write(tmp_path, "molecule.vshape", "vshape\n\n2 atoms\n\nCoords\n\n1 0 0 0\n2 1 0 0\n")
    assert cli_main([str(p)]) == 1
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and "--diameter D" in err and "as lammps" in err and str(p) in err
    assert cli_main([str(p), "--diameter", "2", "--format", "csv"]) == 0
    assert float(capsys.readouterr().out.splitlines()[1].split(",")[3]) == pytest.approx(DIMER_VOLUME, rel=1e-14)
    (c,) = read(p, diameter=4.0, scale=0.5)
    assert np.array_equal(c.radii, [1.0, 1.0]) and np.array_equal(c.centers[1], [0.5, 0, 0])


def test_diameter_is_refused_where_it_does_not_apply(tmp_path, capsys):
    name, text, _ = LAYOUTS["lammps_vshape"]
    p = _write(tmp_path, name, text)
    with pytest.raises(ClumpFileError, match=r"molecule.vshape:10: the file has a Diameters section"):
        read(p, diameter=2.0)
    q = _write(tmp_path, "c.csv", "0,0,0,1\n")
    with pytest.raises(ValueError, match="only to LAMMPS"):
        read(q, diameter=2.0)
    assert cli_main([str(q), "--diameter", "2"]) == 1
    assert "as csv: --diameter applies only to LAMMPS" in capsys.readouterr().err


SCRIPT = """# a LIGGGHTS input script
atom_style sphere
fix m1 all property/global youngsModulus peratomtype 5e6
fix pts1 all particletemplate/multisphere 15485863 atom_type 1 density constant 2500 nspheres 2 ntry 1000000 &
    spheres 0 0 0 1 &
            1 0 0 1 type 1
fix pts2 all particletemplate/multisphere 15485867 atom_type 1 density constant 2500 nspheres 2 ntry 1000000 &
    spheres file shapes/stone1.test scale 0.5 type 1  # from a sphere file
fix pdd1 all particledistribution/discrete 15485869 2 pts1 0.5 pts2 0.5
"""


def test_liggghts_script_templates_one_clump_per_fix(tmp_path, monkeypatch, capsys):
    (tmp_path / "shapes").mkdir()
    _write(tmp_path / "shapes", "stone1.test", "0 0 0 2\n2 0 0 2\n")
    p = _write(tmp_path, "in.insert", SCRIPT)
    monkeypatch.chdir(tmp_path / "shapes")  # the sphere file is found relative to the script, not the cwd
    assert detect_format(p) == "liggghts-script"
    a, b = read(p)
    assert (a.name, b.name) == ("pts1", "pts2")
    assert a.lines == (5, 6) and b.source.endswith("stone1.test")
    for c in (a, b):
        assert np.array_equal(c.centers, [[0, 0, 0], [1, 0, 0]]) and np.array_equal(c.radii, [1, 1])
    assert cli_main([str(p), "--format", "csv"]) == 0
    rows = capsys.readouterr().out.splitlines()[1:]
    assert [r.split(",")[0] for r in rows] == ["pts1", "pts2"]
    assert all(float(r.split(",")[3]) == pytest.approx(DIMER_VOLUME, rel=1e-14) for r in rows)


@pytest.mark.parametrize("bad,message", [
    ("nspheres 2 ntry 10 spheres 0 0 0 1 1 0 0", "fewer than nspheres=2"),
    ("nspheres 1 ntry 10 spheres 0 0 0 ${r}", "r is not a number"),
    ("nspheres 1 ntry 10 spheres 0 0 0 -1", "radius must be > 0"),
    ("ntry 10 spheres 0 0 0 1", "without 'nspheres'"),
    ("nspheres 1 ntry 10 spheres file missing.test scale 1", "sphere file 'missing.test' not found"),
])
def test_liggghts_script_errors_name_the_line(tmp_path, bad, message):
    p = _write(tmp_path, "in.bad", f"atom_style sphere\nfix t all particletemplate/multisphere 1 atom_type 1 {bad}\n")
    with pytest.raises(ClumpFileError, match=rf"^{p}:2: .*{re.escape(message)}"):
        read(p)


CLUMPS_TEXT = "0 0 0 1 3\n1.3 0.2 -0.1 0.7 3\n0.4 1.1 0.3 0.5 3\n5 5 5 0.4 8\n5.5 5.1 4.9 0.6 8\n"


@pytest.mark.parametrize("engine", ["deme", "mclump", "yade"])
def test_round_trip_keeps_the_source_frame(tmp_path, engine):
    src = _write(tmp_path, "two.clumps", CLUMPS_TEXT)
    original = read(src)
    written = export(original, engine, tmp_path / engine, density=2500.0)
    if engine == "deme":
        back = read(next(p for p in written if p.suffix == ".json"))
    elif engine == "mclump":
        back = [read(p)[0] for p in written if p.name == "clumpprops.txt"]
    else:
        back = read(next(p for p in written if p.suffix == ".txt"))
    assert len(back) == len(original)
    if engine != "yade":  # textClumps names clumps by their ids
        assert [c.name for c in back] == [c.name for c in original]
    for a, b in zip(original, back):
        assert np.array_equal(b.radii, a.radii)
        assert np.allclose(b.centers, a.centers, rtol=0, atol=4e-15 * np.abs(a.centers).max())
        assert not np.allclose(b.centers, a.centers - a.centers.mean(axis=0), atol=1e-3)  # not centred


def test_mclump_folder_stays_in_the_principal_frame(tmp_path):
    (a,) = read(_write(tmp_path, "s.csv", "0,0,0,1\n1.2,0.1,0,0.7\n0.3,1,0.2,0.5\n"))
    (folder,) = {p.parents[1] if p.parent.name in ("Clump", "Inertia") else p.parent
                 for p in export([a], "mclump", tmp_path / "m")}
    (b,) = read(folder)
    (c,) = read(folder / "clumpprops.txt")
    assert np.abs(b.centers - c.centers).max() > 0.1 and np.allclose(c.centers, a.centers, rtol=0, atol=1e-15)


@pytest.mark.parametrize("fmt,reason", [("lammps", "no Coords section"), ("yade", "expected 5 columns"),
                                        ("liggghts", "expected 4 columns"), ("deme", "not JSON"),
                                        ("liggghts-script", "no 'fix ... particletemplate/multisphere'")])
def test_wrong_from_is_one_line_with_format_file_and_line(tmp_path, capsys, fmt, reason):
    p = _write(tmp_path, "clump.txt", "0,0,0,1\n1,0,0,1\n")
    assert cli_main([str(p), "--from", fmt]) == 1
    captured = capsys.readouterr()
    assert captured.out == ""
    (line,) = captured.err.splitlines()
    assert line.startswith(f"clumpprops: error: {p}:") and f": as {fmt}: " in line and reason in line, line
    assert line.split(f"{p}:", 1)[1].split(":", 1)[0].isdigit(), line


def test_stdin_is_textclumps_only(capsys, monkeypatch):
    import io
    import sys

    monkeypatch.setattr(sys, "stdin", io.StringIO("0 0 0 1 0\n1 0 0 1 0\n"))
    assert cli_main(["-", "--format", "csv"]) == 0
    assert float(capsys.readouterr().out.splitlines()[1].split(",")[3]) == pytest.approx(DIMER_VOLUME, rel=1e-14)
    assert cli_main(["-", "--from", "csv"]) == 1
    assert "textClumps only" in capsys.readouterr().err


def test_formats_listed_and_every_one_detected():
    assert set(FORMATS) == {"csv", "liggghts", "mclump", "yade", "lammps", "liggghts-script", "deme"}


@pytest.mark.parametrize("command", ["export", "show"])
def test_export_and_show_take_the_diameter_of_a_molecule_without_diameters(tmp_path, command):
    """The subcommands that read a clump file share the main command's input options."""
    p = _write(tmp_path, "molecule.vshape", "vshape\n\n2 atoms\n\nCoords\n\n1 0 0 0\n2 1 0 0\n")
    args = {"export": ["export", str(p), "--to", "yade", "--out", str(tmp_path / "out")],
            "show": ["show", str(p), "-o", str(tmp_path / "v.png")]}[command]
    assert cli_main(args) == 1                          # radii unknown: refused
    assert cli_main(args + ["--diameter", "2"]) == 0
    if command == "export":
        (c,) = read(tmp_path / "out" / "molecule_textclumps.txt")
        assert np.array_equal(c.radii, [1.0, 1.0])
        assert np.linalg.norm(c.centers[1] - c.centers[0]) == pytest.approx(1.0, rel=1e-15)
    else:
        assert (tmp_path / "v.png").stat().st_size > 10_000


def test_a_four_column_whitespace_txt_is_an_xyzr_list(tmp_path, capsys):
    """CLUMP's whitespace tables and `clumpprops fit`'s output are `x y z r` lines named .txt: read
    as one clump by the main command, not refused as textClumps without ids."""
    p = _write(tmp_path, "grain.spheres.txt", "0 0 0 1\n1 0 0 1\n")
    assert detect_format(p) == "liggghts"
    assert cli_main([str(p), "--format", "csv"]) == 0
    assert float(capsys.readouterr().out.splitlines()[1].split(",")[3]) == pytest.approx(DIMER_VOLUME, rel=1e-14)
    assert cli_main([str(p), "--from", "yade"]) == 1          # forced textClumps: the ids are missing
    assert "expected 5 columns" in capsys.readouterr().err
