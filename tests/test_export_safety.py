"""Export never loses a file: not the input (whatever the options), not an existing output
(unless --force), and a refused export writes nothing at all."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from clumpprops import io as cio

SPHERES = "0 0 0 1\n0 0 1.2 1\n"          # a LIGGGHTS sphere file in mm: x y z r


ROOT = Path(__file__).resolve().parents[1]   # this checkout's clumpprops, whatever the folder runs from
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}


def run(tmp_path, *args):
    return subprocess.run([sys.executable, "-m", "clumpprops", "export", *map(str, args)], cwd=tmp_path,
                          capture_output=True, text=True, env=ENV)


def test_exporting_a_liggghts_file_beside_itself_twice_leaves_the_input_alone(tmp_path):
    """The export writes NAME_spheres.multisphere beside stone1.multisphere; run again, it refuses
    (or with --force replaces its own outputs): the millimetre input is never scaled twice."""
    src = tmp_path / "stone1.multisphere"
    src.write_text(SPHERES)
    r = run(tmp_path, "stone1.multisphere", "--to", "liggghts", "--scale", "0.001")
    assert r.returncode == 0 and src.read_text() == SPHERES
    first = (tmp_path / "stone1_spheres.multisphere").read_text()
    r = run(tmp_path, "stone1.multisphere", "--to", "liggghts", "--scale", "0.001")
    assert r.returncode == 1 and "stone1_spheres.multisphere: exists; nothing written" in r.stderr
    r = run(tmp_path, "stone1.multisphere", "--to", "liggghts", "--scale", "0.001", "--force")
    assert r.returncode == 0 and src.read_text() == SPHERES
    assert (tmp_path / "stone1_spheres.multisphere").read_text() == first     # scaled once, from the input


@pytest.mark.parametrize("engine,name,text", [
    ("yade", "s_textclumps.txt", "0 0 0 1 0\n0 0 1.2 1 0\n"),
    ("lammps", "stone1.mol", "2 atoms\n\nCoords\n\n1 0 0 0\n2 0 0 1.2\n\nTypes\n\n1 1\n2 1\n\n"
                             "Diameters\n\n1 2\n2 2\n"),
])
def test_an_export_never_writes_over_its_input_even_with_force(tmp_path, engine, name, text):
    src = tmp_path / name
    src.write_text(text)
    for extra in ([], ["--force"]):             # --force replaces outputs, never the input
        r = run(tmp_path, name, "--to", engine, "--scale", "0.001", "--name", name.split("_")[0].split(".")[0], *extra)
        assert r.returncode == 1 and r.stdout == "", r.stderr
        assert f"{name}: is the input file" in r.stderr and len(r.stderr.splitlines()) == 1
        assert src.read_text() == text
        assert sorted(p.name for p in tmp_path.iterdir()) == [name]   # nothing else either


def test_an_existing_output_is_replaced_only_with_force_and_a_refusal_writes_nothing(tmp_path):
    src = tmp_path / "stone1.multisphere"
    src.write_text(SPHERES)
    assert run(tmp_path, src, "--to", "liggghts", "--scale", "0.001", "--out", "out").returncode == 0
    deck = tmp_path / "out" / "stone1_liggghts.in"
    deck.write_text("my edits\n")
    (tmp_path / "out" / "stone1_spheres.multisphere").unlink()        # one output gone, the other edited
    r = run(tmp_path, src, "--to", "liggghts", "--scale", "0.001", "--out", "out")
    assert r.returncode == 1 and "stone1_liggghts.in: exists; nothing written" in r.stderr
    assert deck.read_text() == "my edits\n" and not (tmp_path / "out" / "stone1_spheres.multisphere").exists()
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["stone1_liggghts.in"]   # no staging left
    r = run(tmp_path, src, "--to", "liggghts", "--scale", "0.001", "--out", "out", "--force")
    assert r.returncode == 0 and "mass" in deck.read_text() and (tmp_path / "out" / "stone1_spheres.multisphere").exists()


@pytest.mark.parametrize("engine", ["liggghts", "lammps", "deme", "mclump", "yade"])
def test_the_library_refuses_the_same_for_every_engine(tmp_path, engine):
    src = tmp_path / "in.csv"
    src.write_text("x,y,z,r\n0,0,0,1\n0,0,1.2,1\n")
    clumps = cio.read(str(src))
    first = cio.export(clumps, engine, tmp_path / "o", source=str(src))
    assert first and all(p.exists() for p in first)
    with pytest.raises(cio.ExportRefused, match="exists; nothing written"):
        cio.export(clumps, engine, tmp_path / "o", source=str(src))
    assert cio.export(clumps, engine, tmp_path / "o", source=str(src), force=True) == first


def test_liggghts_sphere_files_hold_only_numbers(tmp_path):
    """LIGGGHTS 3.8.0 stops on '#' lines in a sphere file (run with -screen none): the sphere file
    is x y z r lines only, and its provenance is in the template file."""
    src = tmp_path / "two.csv"
    src.write_text("0,0,0,1\n0,0,1.2,1\n")
    paths = cio.export(cio.read(str(src)), "liggghts", tmp_path / "o", source=str(src))
    sphere_file = next(p for p in paths if p.suffix == ".multisphere")
    rows = sphere_file.read_text().splitlines()
    assert len(rows) == 2 and all(len(r.split()) == 4 and not r.startswith("#") for r in rows)
    deck = next(p for p in paths if p.name.endswith("_liggghts.in")).read_text()
    assert "2 spheres in two_spheres.multisphere" in deck


def test_the_liggghts_template_names_its_sphere_file_in_out_never_the_users_own(tmp_path):
    """A run from --out reads the exported metre file; the user's millimetre file of the same
    clump (here in the folder above) has another name, so no run picks it up instead."""
    (tmp_path / "stone1.multisphere").write_text(SPHERES)
    r = run(tmp_path, "stone1.multisphere", "--to", "liggghts", "--scale", "0.001", "--out", "data")
    assert r.returncode == 0, r.stderr
    fixes = [ln for ln in (tmp_path / "data" / "stone1_liggghts.in").read_text().splitlines() if ln.startswith("fix pts")]
    (name,) = [ln.split(" spheres file ")[1].split()[0] for ln in fixes]
    assert "/" not in name and name != "stone1.multisphere" and not (tmp_path / name).exists()
    rows = np.loadtxt(tmp_path / "data" / name)
    assert rows.shape == (2, 4) and np.allclose(rows[:, 3], 0.001) and np.allclose(rows[:, 2], [-0.0006, 0.0006])
    assert (tmp_path / "stone1.multisphere").read_text() == SPHERES


SINGLE = "0,0,0,0.01\n"          # one sphere of radius 1 cm


@pytest.mark.parametrize("engine", ["liggghts", "deme", "mclump", "yade"])
def test_a_one_sphere_clump_is_written_as_the_engines_sphere(tmp_path, engine):
    src = tmp_path / "ball.csv"
    src.write_text(SINGLE)
    paths = cio.export(cio.read(str(src)), engine, tmp_path / "o", density=1000.0, source=str(src))
    mass = 1000.0 * 4.0 / 3.0 * np.pi * 0.01 ** 3
    text = {p.name: p.read_text() for p in paths}
    if engine == "liggghts":       # LIGGGHTS refuses nspheres 1: a plain particletemplate/sphere
        (line,) = [ln for ln in text["ball_liggghts.in"].splitlines() if ln.startswith("fix pts1 ")]
        assert "particletemplate/sphere" in line and line.endswith("radius constant 0.01") and "nspheres" not in line
        assert sorted(text) == ["ball_liggghts.in"]
    elif engine == "deme":
        (clump,) = json.loads(text["ball_deme.json"])["clumps"]
        assert np.isclose(clump["mass"], mass, rtol=1e-15) and clump["relPos"] == [[0.0, 0.0, 0.0]]
        assert np.allclose(clump["moi"], 0.4 * mass * 0.01 ** 2, rtol=1e-14)
    elif engine == "mclump":
        assert np.isclose(float(text["Mass.txt"]), mass, rtol=1e-15)
        assert np.allclose(np.loadtxt((tmp_path / "o" / "ball" / "Clump" / "Clump.txt"), delimiter=","), [0, 0, 0, 0.01])
    else:
        rows = [ln.split() for ln in text["ball_textclumps.txt"].splitlines() if not ln.startswith("#")]
        assert rows == [["0.0", "0.0", "0.0", "0.01", "0"]]


def test_a_one_sphere_clump_is_refused_for_lammps_in_one_line(tmp_path):
    """LAMMPS' fix rigid stops on a one-atom body ("One or zero atoms in rigid body")."""
    (tmp_path / "ball.csv").write_text(SINGLE)
    r = run(tmp_path, "ball.csv", "--to", "lammps", "--out", "p")
    assert r.returncode == 1 and len(r.stderr.splitlines()) == 1
    assert "clump ball has one sphere: LAMMPS' fix rigid refuses one-atom bodies" in r.stderr
    assert not (tmp_path / "p").exists()


@pytest.mark.parametrize("engine,options", [("liggghts", ["--deck"]), ("lammps", ["--deck"]), ("deme", []),
                                            ("mclump", []), ("yade", ["--deck"])])
def test_every_file_an_export_writes_is_refused_when_it_exists(tmp_path, engine, options):
    """Each output file alone (templates, decks, MClump's nested files) blocks the export without --force."""
    (tmp_path / "two.csv").write_text("0,0,0,1\n0,0,1.2,1\n")
    assert run(tmp_path, "two.csv", "--to", engine, "--out", "all", *options).returncode == 0
    written = sorted(p.relative_to(tmp_path / "all") for p in (tmp_path / "all").rglob("*") if p.is_file())
    assert len(written) >= 2
    for k, rel in enumerate(written):
        out = tmp_path / f"o{k}"
        (out / rel).parent.mkdir(parents=True, exist_ok=True)
        (out / rel).write_text("mine\n")
        r = run(tmp_path, "two.csv", "--to", engine, "--out", out.name, *options)
        assert r.returncode == 1 and f"{rel}: exists; nothing written" in r.stderr, (rel, r.stderr)
        assert [p for p in out.rglob("*") if p.is_file()] == [out / rel] and (out / rel).read_text() == "mine\n"


@pytest.mark.parametrize("args,message", [
    (["--to", "deme", "--deck"], "--deck applies to --to liggghts, lammps, yade"),
    (["--to", "lammps", "--spin", "1", "2", "3"], "--spin applies with --deck"),
    (["--to", "lammps", "--deck", "--steps", "1"], "--steps must be at least 2"),
    (["--to", "lammps", "--deck", "--velocity", "1", "nan", "0"], "finite numbers"),
])
def test_deck_option_errors_are_one_line(tmp_path, args, message):
    (tmp_path / "two.csv").write_text("0,0,0,1\n0,0,1.2,1\n")
    r = run(tmp_path, "two.csv", *args)
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1 and message in r.stderr, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["two.csv"]


def test_export_help_names_every_file_and_where_it_goes():
    r = subprocess.run([sys.executable, "-m", "clumpprops", "export", "--help"], capture_output=True, text=True)
    assert r.returncode == 0
    for name in ("NAME_spheres.multisphere", "STEM_liggghts.in", "STEM.rigid", "STEM.data", "NAME.mol",
                 "STEM_deme.json", "NAME_deme.csv", "NAME/Clump/Clump.txt", "STEM_textclumps.txt",
                 "STEM_deck_liggghts.in", "STEM_deck_lammps.in", "STEM_deck_yade.py", "files written into --out"):
        assert name in r.stdout, name


def test_an_export_listing_piped_into_a_closed_pipe_ends_quietly(tmp_path):
    """As when piped into head: the reader is gone before the listing is written."""
    src = tmp_path / "two.csv"
    src.write_text("0,0,0,1\n0,0,1.2,1\n")
    r_fd, w_fd = os.pipe()
    os.close(r_fd)                                 # nobody reads: the first write breaks the pipe
    try:
        r = subprocess.run([sys.executable, "-m", "clumpprops", "export", "two.csv", "--to", "lammps"],
                           cwd=tmp_path, env=ENV, stdout=w_fd, stderr=subprocess.PIPE, text=True)
    finally:
        os.close(w_fd)
    assert r.returncode == 0 and r.stderr == "", r.stderr
