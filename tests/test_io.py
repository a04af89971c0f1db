"""clumpprops.io: every exporter read back by an importer, the engine-specific layouts, the
``clumpprops export`` command, and one-line errors for bad files."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from clumpprops import mass_properties
from clumpprops.io import Clump, ClumpFileError, detect_format, export, read
from clumpprops.cli import main as cli_main
from clumpprops.io import deme

ROOT = Path(__file__).resolve().parents[1]
RHO = 1140.0
D = 0.1333
DIMER = Clump(np.array([[0, 0, -D / 4], [0, 0, D / 4]]), np.array([D / 2, D / 2]), name="dimer")
rng = np.random.default_rng(11)
TEN = Clump(rng.uniform(-0.05, 0.05, (10, 3)) + [0.3, -0.2, 1.7], rng.uniform(0.02, 0.04, 10), name="ten")
CLUMPS = [DIMER, TEN]


def props(c):
    return mass_properties(c.centers, c.radii, density=RHO)


def same_body(a, b, frame="any"):
    """Mass, volume and principal moments equal to round-off; COM/tensor according to frame."""
    pa, pb = props(a), props(b)
    assert pa.mass == pytest.approx(pb.mass, rel=1e-13)
    assert np.allclose(pa.principal_moments, pb.principal_moments, rtol=1e-12, atol=0)
    assert np.allclose(b.radii, a.radii, rtol=1e-15, atol=0)
    return pa, pb


def test_yade_round_trip_is_bitwise(tmp_path):
    (p,) = export(CLUMPS, "yade", tmp_path, density=RHO)
    back = read(p)
    assert len(back) == 2
    for a, b in zip(CLUMPS, back):
        assert np.array_equal(a.centers, b.centers) and np.array_equal(a.radii, b.radii)
    text = p.read_text()
    assert text.startswith("#format x_y_z_r_clumpId") and "density 1140.0 kg/m^3" in text and "method exact" in text


@pytest.mark.parametrize("engine,suffix", [("liggghts", ".multisphere"), ("lammps", ".mol")])
def test_centred_formats_round_trip(tmp_path, engine, suffix):
    export(CLUMPS, engine, tmp_path, density=RHO)
    for a in CLUMPS:
        (b,) = read(tmp_path / (f"{a.name}_spheres{suffix}" if engine == "liggghts" else f"{a.name}{suffix}"))
        pa, pb = same_body(a, b)
        assert np.allclose(b.centers, a.centers - pa.center_of_mass, rtol=0, atol=1e-15)
        assert np.max(np.abs(pb.center_of_mass)) < 1e-15
        assert np.allclose(pb.inertia, pa.inertia, rtol=0, atol=1e-13 * pa.principal_moments.max())


@pytest.mark.parametrize("engine", ["deme", "mclump"])
def test_principal_frame_formats_round_trip(tmp_path, engine):
    export(CLUMPS, engine, tmp_path, density=RHO)
    for a in CLUMPS:
        src = tmp_path / f"{a.name}_deme.csv" if engine == "deme" else tmp_path / a.name
        (b,) = read(src, fmt="csv" if engine == "deme" else None)
        pa, pb = same_body(a, b)
        assert np.max(np.abs(pb.center_of_mass)) < 1e-15
        # principal frame: the tensor is diagonal with the ascending principal moments
        assert np.allclose(pb.inertia, np.diag(pa.principal_moments), rtol=0, atol=1e-13 * pa.principal_moments.max())
        # and back to the source frame: source = com + axes @ x_p
        assert np.allclose(pa.center_of_mass + b.centers @ pa.principal_axes.T, a.centers, rtol=0, atol=1e-15)


def test_deme_json_and_mclump_inertia_files(tmp_path):
    export(CLUMPS, "deme", tmp_path, density=RHO, stem="all")
    doc = json.loads((tmp_path / "all_deme.json").read_text())
    assert doc["density"] == RHO and doc["method"] == "exact" and doc["units"]["moi"] == "kg m^2"
    for a, item in zip(CLUMPS, doc["clumps"]):
        p = props(a)
        assert item["mass"] == p.mass and item["moi"] == list(p.principal_moments)
        assert item["float32_relative_rounding"]["mass"] < 6e-8 and not item["float32_warnings"]
    export([DIMER], "mclump", tmp_path, density=RHO)
    p = props(DIMER)
    assert float((tmp_path / "dimer/Inertia/Mass.txt").read_text()) == p.mass
    toi = np.array([[float(x) for x in ln.split(",")] for ln in (tmp_path / "dimer/Inertia/TOI.txt").read_text().split()])
    assert np.array_equal(toi, np.diag(p.principal_moments))
    pd = np.array([[float(x) for x in ln.split(",")] for ln in (tmp_path / "dimer/Inertia/PD.txt").read_text().split()])
    assert np.array_equal(pd, np.eye(3))
    assert "density 1140.0" in (tmp_path / "dimer/clumpprops.txt").read_text()


def test_deme_float32_warning():
    # moments of nanometre spheres in SI units are below float32's normal range
    rep = deme.float32_report(1e-15, [1e-40, 2e-40, 3e-40], np.array([[1e-6, 0, 0], [-1e-6, 0, 0]]), np.array([1e-6, 1e-6]))
    assert any("moi" in p for p in deme.float32_problems(rep))
    rep = deme.float32_report(1.0, [1.0, 1.0 + 1e-9, 2.0], np.zeros((1, 3)), np.ones(1))
    assert rep["moments_collapse"] and deme.float32_problems(rep)
    rep = deme.float32_report(2.0, [1.0, 1.5, 2.0], np.array([[0.1, 0.2, 0.3]]), np.array([0.1]))
    assert deme.float32_problems(rep) == []


def test_liggghts_fix_line_order_and_centring(tmp_path):
    export([TEN], "liggghts", tmp_path, density=RHO)
    p = props(TEN)
    line = [ln for ln in (tmp_path / "ten_liggghts.in").read_text().splitlines() if ln.startswith("fix pts1")][0]
    w = line.split()
    I = p.inertia
    vals = [float(x) for x in w[w.index("inertia_tensor") + 1: w.index("inertia_tensor") + 7]]
    assert vals == [I[0, 0], I[0, 1], I[0, 2], I[1, 1], I[1, 2], I[2, 2]]  # LIGGGHTS' parse order
    assert float(w[w.index("mass") + 1]) == p.mass and w[-1] == "use_density"
    assert w[w.index("density") + 2] == "1140.0" and w[w.index("nspheres") + 1] == "10"


def test_lammps_infile_columns(tmp_path):
    export(CLUMPS, "lammps", tmp_path, density=RHO, stem="both")
    rows = [ln.split() for ln in (tmp_path / "both.rigid").read_text().splitlines() if not ln.startswith("#")]
    assert rows[0] == ["2"] and len(rows) == 3
    for k, (a, r) in enumerate(zip(CLUMPS, rows[1:])):
        p = props(a)
        v = [float(x) for x in r]
        I = p.inertia
        assert v[0] == k + 1 and v[1] == p.mass and v[2:5] == list(p.center_of_mass)
        assert v[5:11] == [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
        assert v[11:] == [0.0] * 9
    mol = (tmp_path / "ten.mol").read_text().splitlines()
    assert len(mol[0]) < 200  # LAMMPS reads the title into a 256-character buffer
    inertia = [ln for ln in mol if ln.endswith(" inertia")][0].split()[:6]
    I = props(TEN).inertia
    assert [float(x) for x in inertia] == [I[0, 0], I[1, 1], I[2, 2], I[1, 2], I[0, 2], I[0, 1]]


def test_repeated_yade_ids_get_distinct_names(tmp_path):
    (tmp_path / "r.txt").write_text("0 0 0 0.1 0\n0.1 0 0 0.1 0\n1 0 0 0.1 1\n1.1 0 0 0.1 1\n"
                                    "2 0 0 0.1 0\n2.1 0 0 0.1 0\n")
    names = [c.name for c in read(tmp_path / "r.txt")]
    assert names == ["r_0", "r_1", "r_0_line5"]
    assert len(export(read(tmp_path / "r.txt"), "liggghts", tmp_path / "o")) == 4


def test_csv_with_and_without_header_and_scale(tmp_path):
    body = "\n".join(f"{float(x)!r},{float(y)!r},{float(z)!r},{float(r)!r}"
                     for (x, y, z), r in zip(TEN.centers * 1000, TEN.radii * 1000))
    (tmp_path / "a.csv").write_text("x,y,z,r\n" + body + "\n")
    (tmp_path / "b.csv").write_text("# in mm\n" + body + "\n")
    a, = read(tmp_path / "a.csv", scale=0.001)
    b, = read(tmp_path / "b.csv", scale=0.001)
    assert np.array_equal(a.centers, b.centers)
    assert np.allclose(a.centers, TEN.centers, rtol=1e-15, atol=0) and np.allclose(a.radii, TEN.radii, rtol=1e-15, atol=0)
    assert a.lines[0] == 2 and b.lines[0] == 2


def run_cli(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "clumpprops", *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          timeout=120)


def test_cli_export_every_engine(tmp_path, capsys):
    r = run_cli("export", ROOT / "examples" / "clumps.txt", "--to", "liggghts", "--out", tmp_path / "sub", "--density", "1140")
    assert r.returncode == 0 and r.stderr == "", r.stderr
    assert "clumps_0: 2 spheres, mass 2.385820157 kg" in r.stdout
    for engine in ("liggghts", "lammps", "deme", "mclump", "yade"):
        status = cli_main(["export", str(ROOT / "examples" / "clumps.txt"), "--to", engine, "--out", str(tmp_path / engine),
                           "--density", "1140"])
        out, err = capsys.readouterr()
        assert status == 0 and err == "", err
        assert "clumps_0: 2 spheres, mass 2.385820157 kg" in out
        assert len([ln for ln in out.splitlines() if not ln.startswith("#")]) >= 1
    # the old form still works
    assert cli_main([str(ROOT / "examples" / "clumps.txt"), "--density", "1140"]) == 0
    assert "2.38582" in capsys.readouterr().out


def test_cli_export_mm_file_and_from(tmp_path):
    (tmp_path / "d.dat").write_text(f"0 0 {-D * 250!r} {D * 500!r}\n0 0 {D * 250!r} {D * 500!r}\n")
    r = run_cli("export", tmp_path / "d.dat", "--from", "liggghts", "--scale", "0.001", "--to", "yade", "--out", tmp_path,
                "--density", "1140")
    assert r.returncode == 0, r.stderr
    (b,) = read(tmp_path / "d_textclumps.txt")
    assert props(b).mass == pytest.approx(2.385820156555343, rel=1e-14)
    assert "scale 0.001" in (tmp_path / "d_textclumps.txt").read_text()


BAD = [
    ("cols.csv", "x,y,z,r\n0,0,0,0.1\n0,0,0.1\n", "cols.csv:3: expected 4 comma-separated columns"),
    ("nan.csv", "0,0,0,0.1\n0,nan,0,0.1\n", "nan.csv:2: y is not finite"),
    ("neg.multisphere", "# c\n0 0 0 0.1\n0.1 0 0 -0.05\n", "neg.multisphere:3: radius must be > 0"),
    ("word.multisphere", "0 0 zero 0.1\n", "word.multisphere:1: z is not a number"),
    ("cols.multisphere", "0 0 0\n", "cols.multisphere:1: expected 4 columns"),
    ("empty.csv", "x,y,z,r\n", "empty.csv:1: end of file and no spheres found (empty clump)"),
    ("empty.txt", "#format x_y_z_r_clumpId\n# nothing\n", "empty.txt:2: end of file and no spheres found (empty clump)"),
    ("neg.txt", "0 0 0 -1 0\n", "neg.txt:1: radius must be > 0"),
    ("nodiam.mol", "title\n\n1 atoms\n\nCoords\n\n1 0 0 0\n", "nodiam.mol:7: end of file and no Diameters section"),
    ("negd.mol", "title\n\n1 atoms\n\nCoords\n\n1 0 0 0\n\nDiameters\n\n1 -0.2\n", "negd.mol:11: diameter must be > 0"),
    ("clump.xyz", "Atoms. Timestep: 0\nC 0 0 0\n", "clump.xyz: unknown format (extension '.xyz', and its first lines show none)"),
]


@pytest.mark.parametrize("name,text,message", BAD, ids=[b[0] for b in BAD])
def test_bad_files_give_one_line_errors(tmp_path, name, text, message, capsys, monkeypatch):
    (tmp_path / name).write_text(text)
    with pytest.raises(ClumpFileError) as exc:
        read(tmp_path / name)
    assert message in str(exc.value)
    monkeypatch.chdir(tmp_path)
    status = cli_main(["export", name, "--to", "lammps", "--out", "out"])  # in-process: same code as the console script
    out, err = capsys.readouterr()
    assert status == 1 and out == ""
    assert err.count("\n") == 1 and err.startswith("clumpprops: error: ") and message in err
    assert not (tmp_path / "out").exists()


def test_bad_file_as_a_subprocess(tmp_path):
    (tmp_path / "nan.csv").write_text("0,0,0,0.1\n0,nan,0,0.1\n")
    r = run_cli("export", "nan.csv", "--to", "deme", cwd=tmp_path)
    assert r.returncode == 1 and r.stderr == "clumpprops: error: nan.csv:2: y is not finite: 'nan'\n"


def test_pairwise_triple_overlap_names_the_clump(tmp_path, capsys):
    (tmp_path / "t.txt").write_text("0 0 0 0.1 0\n0.05 0 0 0.1 0\n# next\n0 0 0 0.1 1\n0.1 0 0 0.1 1\n0.05 0.05 0 0.1 1\n")
    assert cli_main(["export", str(tmp_path / "t.txt"), "--to", "yade", "--method", "pairwise", "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "t.txt:4: clump t_1: spheres (0, 1, 2) share a common region" in err


def test_bad_mclump_and_options(tmp_path, capsys):
    (tmp_path / "c" / "Clump").mkdir(parents=True)
    (tmp_path / "c" / "Clump" / "Clump.txt").write_text("0,0,0,0.1\n0 0 0 0.1\n")
    assert cli_main(["export", str(tmp_path / "c"), "--to", "yade", "--out", str(tmp_path)]) == 1
    assert "Clump.txt:2: expected 4 comma-separated columns" in capsys.readouterr().err
    for bad in (["--to", "nowhere"], ["--to", "yade", "--from", "xyz"], ["--to", "yade", "--density", "-1"]):
        with pytest.raises(SystemExit) as exc:
            cli_main(["export", str(tmp_path / "c"), *bad])
        assert exc.value.code == 2


@pytest.mark.parametrize("name, text, fmt", [
    ("clump.txt", "0.0,0.0,0.0,1.0\n0.0,0.0,1.2,1.0\n", "csv"),                    # CLUMP's comma table
    ("clumpprops.txt", "x,y,z,r\n0,0,0,1\n0,0,1.2,1\n", "csv"),                   # with its header row
    ("molecule.data", "# LAMMPS molecule\n\n2 atoms\n\nCoords\n\n1 0 0 0\n2 0 0 1.2\n\nDiameters\n\n1 2\n2 2\n",
     "lammps"),
    ("molecule.vshape", "# v\n\n2 atoms\n\nCoords\n\n1 0 0 0\n2 0 0 1.2\n\nDiameters\n\n1 2\n2 2\n", "lammps"),
    ("stone1.test", "0 0 0 1\n0 0 1.2 1\n", "liggghts"),                          # LIGGGHTS' example name
    ("clumps.dat", "0 0 0 1 7\n0 0 1.2 1 7\n", "yade"),                           # x y z r clumpId
    ("stone.multisphere", "0 0 0 1 1\n0 0 1.2 1 1\n", "liggghts"),                # 5th column: atom type
])
def test_the_format_comes_from_the_content_where_the_name_does_not_tell_or_misleads(tmp_path, name, text, fmt):
    p = tmp_path / name
    p.write_text(text)
    assert detect_format(p) == fmt
    (c,) = read(p)
    assert c.n_spheres == 2 and c.radii[0] == pytest.approx(1.0 if fmt != "lammps" else 1.0)
