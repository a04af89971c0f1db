"""Export never loses a file: not the input (whatever the options), not an existing output
(unless --force), and a refused export writes nothing at all."""
import subprocess
import sys

import pytest

from clumpprops import io as cio

SPHERES = "0 0 0 1\n0 0 1.2 1\n"          # a LIGGGHTS sphere file in mm: x y z r


def run(tmp_path, *args):
    return subprocess.run([sys.executable, "-m", "clumpprops", "export", *map(str, args)], cwd=tmp_path,
                          capture_output=True, text=True)


def test_exporting_a_liggghts_file_beside_itself_leaves_the_input_alone(tmp_path):
    src = tmp_path / "stone1.multisphere"
    src.write_text(SPHERES)
    for extra in ([], ["--force"]):             # --force replaces outputs, never the input
        r = run(tmp_path, "stone1.multisphere", "--to", "liggghts", "--scale", "0.001", *extra)
        assert r.returncode == 1 and r.stdout == ""
        assert "stone1.multisphere: is the input file" in r.stderr and len(r.stderr.splitlines()) == 1
        assert src.read_text() == SPHERES
        assert sorted(p.name for p in tmp_path.iterdir()) == ["stone1.multisphere"]   # nothing else either


def test_an_existing_output_is_replaced_only_with_force_and_a_refusal_writes_nothing(tmp_path):
    src = tmp_path / "stone1.multisphere"
    src.write_text(SPHERES)
    assert run(tmp_path, src, "--to", "liggghts", "--scale", "0.001", "--out", "out").returncode == 0
    deck = tmp_path / "out" / "stone1_liggghts.in"
    deck.write_text("my edits\n")
    (tmp_path / "out" / "stone1.multisphere").unlink()        # one output gone, the other edited
    r = run(tmp_path, src, "--to", "liggghts", "--scale", "0.001", "--out", "out")
    assert r.returncode == 1 and "stone1_liggghts.in: exists; nothing written" in r.stderr
    assert deck.read_text() == "my edits\n" and not (tmp_path / "out" / "stone1.multisphere").exists()
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["stone1_liggghts.in"]   # no staging left
    r = run(tmp_path, src, "--to", "liggghts", "--scale", "0.001", "--out", "out", "--force")
    assert r.returncode == 0 and "mass" in deck.read_text() and (tmp_path / "out" / "stone1.multisphere").exists()


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


def test_liggghts_sphere_files_hold_only_numbers_and_a_one_sphere_clump_is_refused(tmp_path):
    """LIGGGHTS 3.8.0 stops on '#' lines in a sphere file (run with -screen none) and refuses
    nspheres 1: the sphere file is x y z r lines only (the provenance is in the deck), and a
    one-sphere clump is refused in one line instead of written."""
    src = tmp_path / "two.csv"
    src.write_text("0,0,0,1\n0,0,1.2,1\n")
    paths = cio.export(cio.read(str(src)), "liggghts", tmp_path / "o", source=str(src))
    sphere_file = next(p for p in paths if p.suffix == ".multisphere")
    rows = sphere_file.read_text().splitlines()
    assert len(rows) == 2 and all(len(r.split()) == 4 and not r.startswith("#") for r in rows)
    deck = next(p for p in paths if p.name.endswith("_liggghts.in")).read_text()
    assert "2 spheres in two.multisphere" in deck
    one = tmp_path / "one.csv"
    one.write_text("0,0,0,1\n")
    r = run(tmp_path, one, "--to", "liggghts", "--out", "p")
    assert r.returncode == 1 and "has one sphere" in r.stderr and len(r.stderr.splitlines()) == 1
    assert not (tmp_path / "p").exists()


def test_an_export_listing_piped_into_a_closed_pipe_ends_quietly(tmp_path):
    """As when piped into head: the reader is gone before the listing is written."""
    import os
    src = tmp_path / "two.csv"
    src.write_text("0,0,0,1\n0,0,1.2,1\n")
    r_fd, w_fd = os.pipe()
    os.close(r_fd)                                 # nobody reads: the first write breaks the pipe
    try:
        r = subprocess.run([sys.executable, "-m", "clumpprops", "export", "two.csv", "--to", "lammps"],
                           cwd=tmp_path, stdout=w_fd, stderr=subprocess.PIPE, text=True)
    finally:
        os.close(w_fd)
    assert r.returncode == 0 and r.stderr == "", r.stderr
