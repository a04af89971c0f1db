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
