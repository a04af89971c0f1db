"""``python -m clumpprops FILE``: run as a subprocess, numbers checked against the library.

The reader (clumpprops.textclumps) is also tested directly against the grouping
rules of YADE's ``ymport.textClumps`` (consecutive equal ids form a clump).
"""
from __future__ import annotations

import csv
import io
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import clumpprops
from clumpprops import mass_properties
from clumpprops.io import Clump, ClumpFileError
from clumpprops.textclumps import parse_text_clumps, read_text_clumps

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "clumps.txt"
PY = sys.executable


def run(*args, stdin=None, cwd=ROOT):
    return subprocess.run(
        [PY, "-m", "clumpprops", *map(str, args)],
        input=stdin,
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=120,
    )





DIMER = """#format x_y_z_r_clumpId
# the paper's dimer, d = 0.1333 m, D = d/2
0 0 -0.033325 0.06665 0
0 0 0.033325 0.06665 0
"""


@pytest.fixture
def tmpfile(tmp_path):
    def make(text, name="clumps.txt"):
        p = tmp_path / name
        p.write_text(text)
        return p

    return make


# ---------------------------------------------------------------- reader
def test_reader_mirrors_yade_grouping():
    text = """#format x_y_z_r_clumpId
# comment
0 0 0 1 7

   # indented comment
1 0 0 1 7
5 0 0 1 3
9 0 0 1 7   extra words are ignored, as in YADE
9 0 3 1 7
"""
    cl = parse_text_clumps(text.splitlines(True), "t")
    assert [c.clump_id for c in cl] == [7, 3, 7]
    assert [c.n_spheres for c in cl] == [2, 1, 2]
    assert [c.lines for c in cl] == [(3, 6), (7,), (8, 9)]
    assert [c.repeated_id for c in cl] == [False, False, True]
    np.testing.assert_array_equal(cl[2].centers, [[9, 0, 0], [9, 0, 3]])
    np.testing.assert_array_equal(cl[0].radii, [1.0, 1.0])


def test_reader_scale_and_shift_as_in_ymport():
    cl = parse_text_clumps(["1 2 3 0.5 0\n"], scale=1e-3, shift=(10.0, 0.0, 0.0))
    np.testing.assert_allclose(cl[0].centers, [[10.001, 0.002, 0.003]])
    np.testing.assert_allclose(cl[0].radii, [0.0005])


@pytest.mark.parametrize(
    "line,match",
    [
        ("0 0 0 1", r":2: expected 5 columns"),
        ("0 0 x 1 0", r":2: z is not a number"),
        ("0 0 0 nan 0", r":2: r is not finite"),
        ("0 inf 0 1 0", r":2: y is not finite"),
        ("0 0 0 0 0", r":2: radius must be > 0"),
        ("0 0 0 -1 0", r":2: radius must be > 0"),
        ("0 0 0 1 1.0", r":2: clumpId must be an integer"),
        ("0 0 0 1 1.23457e+06", r":2: clumpId '1.23457e\+06' is in exponent form: YADE's export.textClumps writes ids with %g"),
        ("0 0 0 1 1e+06", r":2: clumpId '1e\+06' is in exponent form"),
        ("0 0 0 1 99999999999999999999", r":2: clumpId '99999999999999999999' is out of range"),
    ],
)
def test_reader_errors_name_the_line(line, match):
    with pytest.raises(ClumpFileError, match=match) as info:
        parse_text_clumps(["0 0 0 1 0\n", line + "\n"], "f.txt")
    assert info.value.lineno == 2
    assert isinstance(info.value, ValueError)


def test_reader_empty_file():
    with pytest.raises(ClumpFileError, match="no spheres"):
        parse_text_clumps(["# only a comment\n", "\n"], "f.txt")


def test_yade_export_format_round_trip(tmpfile):
    # what yade.export.textClumps writes: '#format' header, optional '# comment', tab-separated %g
    text = "#format x_y_z_r_clumpId\n# exported\n0\t0\t-0.033325\t0.06665\t12\n0\t0\t0.033325\t0.06665\t12\n"
    cl = read_text_clumps(tmpfile(text))
    assert len(cl) == 1 and cl[0].clump_id == 12 and cl[0].n_spheres == 2



def test_reader_clumps_are_the_io_clump_type(tmpfile):
    """textClumps and clumpprops.io.read give the same record for a file: one Clump type."""
    from clumpprops.io import read

    path = tmpfile("0 0 0 1 7\n1 0 0 1 7\n5 0 0 2 3\n9 0 0 1 7\n")
    parsed = read_text_clumps(path)
    via_io = read(path, "yade")
    assert all(type(c) is Clump for c in list(parsed) + via_io)
    assert [c.clump_id for c in via_io] == [c.clump_id for c in parsed] == [7, 3, 7]
    assert [c.repeated_id for c in via_io] == [c.repeated_id for c in parsed] == [False, False, True]
    assert [c.lines for c in via_io] == [c.lines for c in parsed] == [(1, 2), (3,), (4,)]
    assert [(c.first_line, c.last_line) for c in parsed] == [(1, 2), (3, 3), (4, 4)]
    assert parsed[0].source == str(path)
    for a, b in zip(parsed, via_io):
        np.testing.assert_array_equal(a.centers, b.centers)
        np.testing.assert_array_equal(a.radii, b.radii)
    assert repr(parsed[1]) == f"Clump(name='clump', clump_id=3, n_spheres=1, source={str(path)!r}, lines 3-3)"


def test_textclumps_names_are_deprecated_aliases():
    import clumpprops.textclumps as tc

    with pytest.warns(DeprecationWarning, match="TextClumpsError is deprecated: it is clumpprops.io.ClumpFileError"):
        err = tc.TextClumpsError
    with pytest.warns(DeprecationWarning, match="TextClump is deprecated: it is clumpprops.io.Clump"):
        rec = tc.TextClump
    assert err is ClumpFileError and rec is Clump
    with pytest.raises(err, match=r"^f.txt:1: x is not a number: 'a'$"):
        parse_text_clumps(["a 0 0 1 0\n"], "f.txt")
    with pytest.raises(AttributeError):
        tc.NoSuchName  # noqa: B018


def test_file_error_is_one_line():
    exc = ClumpFileError("two\n  lines   here", "f.txt", 3)
    assert str(exc) == "f.txt:3: two lines here"
    assert (exc.source, exc.lineno, exc.reason) == ("f.txt", 3, "two\n  lines   here")
    assert str(ClumpFileError("no line", "f.txt")) == "f.txt: no line"


# ---------------------------------------------------------------- CLI output vs library
def _library(centers_list, radii_list, method, density):
    return [mass_properties(c, r, density=density, method=method) for c, r in zip(centers_list, radii_list)]


EX_CENTERS = [
    np.array([[0, 0, -0.033325], [0, 0, 0.033325]]),
    np.array([[1.00, 0, 0], [1.07, 0, 0], [1.07, 0.06, 0]]),
]
EX_RADII = [np.array([0.06665, 0.06665]), np.array([0.05, 0.04, 0.03])]


@pytest.mark.parametrize("method", ["pairwise", "sum", "exact"])
def test_csv_matches_library(method):
    out = run(EXAMPLE, "--method", method, "--density", "1140", "--format", "csv")
    assert out.returncode == 0, out.stderr
    assert out.stderr == ""
    rows = list(csv.DictReader(io.StringIO(out.stdout)))
    assert [r["id"] for r in rows] == ["0", "1"]
    assert [r["n_spheres"] for r in rows] == ["2", "3"]
    ref = _library(EX_CENTERS, EX_RADII, method, 1140.0)
    summed = _library(EX_CENTERS, EX_RADII, "sum", 1140.0)
    for row, mp, sm in zip(rows, ref, summed):
        assert float(row["mass_kg"]) == pytest.approx(mp.mass, rel=1e-15)
        assert float(row["volume_m3"]) == pytest.approx(mp.volume, rel=1e-15)
        com = [float(row[k]) for k in ("com_x_m", "com_y_m", "com_z_m")]
        np.testing.assert_allclose(com, mp.center_of_mass, rtol=1e-15, atol=1e-15)
        I = [float(row[k]) for k in ("I1_kgm2", "I2_kgm2", "I3_kgm2")]
        np.testing.assert_allclose(I, mp.principal_moments, rtol=1e-15)
        assert float(row["overlap_percent"]) == pytest.approx(100 * (sm.mass / mp.mass - 1), rel=1e-12, abs=1e-12)


def test_paper_dimer_overlap_correction_in_table(tmpfile):
    out = run(tmpfile(DIMER), "--method", "pairwise", "--density", "1140")
    assert out.returncode == 0, out.stderr
    lines = [l for l in out.stdout.splitlines() if l and not l.startswith("#")]
    header, row = lines[0].split(), lines[1].split()
    assert header[:4] == ["id", "n", "mass", "volume"] and header[-1] == "overlap_%"
    assert row[0] == "0" and row[1] == "2"
    # 9/4 pi R^3 rho and 100 (32/27 - 1) = 18.519 %
    assert float(row[2]) == pytest.approx(9 / 4 * math.pi * 0.06665**3 * 1140, rel=1e-5)
    assert float(row[-1]) == pytest.approx(100 * 5 / 27, abs=1e-3)
    assert "density=1140 kg/m^3" in out.stdout and "method=pairwise" in out.stdout


def test_json_has_full_tensor_and_units(tmpfile):
    out = run(EXAMPLE, "--method", "pairwise", "--format", "json", "--density", "2500")
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    assert doc["method"] == "pairwise" and doc["density"] == 2500.0
    assert doc["units"]["mass"] == "kg"
    ref = _library(EX_CENTERS, EX_RADII, "pairwise", 2500.0)
    for item, mp in zip(doc["clumps"], ref):
        np.testing.assert_allclose(item["inertia"], mp.inertia, rtol=1e-15, atol=1e-18)
        np.testing.assert_allclose(item["principal_axes"], mp.principal_axes, atol=1e-15)
        assert item["mass"] == pytest.approx(mp.mass, rel=1e-15)
    assert doc["clumps"][1]["first_line"] == 9 and doc["clumps"][1]["last_line"] == 11


def test_default_method_and_density():
    out = run(EXAMPLE, "--format", "json")
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    assert doc["method"] == clumpprops.DEFAULT_METHOD
    assert doc["density"] == 1000.0  # YADE's default material density
    ref = mass_properties(EX_CENTERS[0], EX_RADII[0], density=1000.0)
    assert doc["clumps"][0]["mass"] == pytest.approx(ref.mass, rel=1e-15)


def test_stdin_and_scale(tmpfile):
    mm = "0 0 -33.325 66.65 0\n0 0 33.325 66.65 0\n"  # the dimer in millimetres
    out = run("-", "--scale", "0.001", "--method", "sum", "--format", "csv", stdin=mm)
    assert out.returncode == 0, out.stderr
    row = next(csv.DictReader(io.StringIO(out.stdout)))
    ref = mass_properties(EX_CENTERS[0], EX_RADII[0], density=1000.0, method="sum")
    assert float(row["mass_kg"]) == pytest.approx(ref.mass, rel=1e-14)


def test_repeated_id_warns_and_starts_a_new_clump(tmpfile):
    out = run(tmpfile("0 0 0 1 0\n0 0 5 1 1\n0 0 10 1 0\n"), "--method", "sum", "--format", "csv")
    assert out.returncode == 0
    assert "warning" in out.stderr and ":3:" in out.stderr and "clump id 0" in out.stderr
    assert [r["id"] for r in csv.DictReader(io.StringIO(out.stdout))] == ["0", "1", "0"]


@pytest.mark.parametrize("method", ["montecarlo"])
def test_montecarlo_options_are_passed(method):
    a = run(EXAMPLE, "--method", method, "--samples", "20000", "--seed", "3", "--format", "json")
    b = run(EXAMPLE, "--method", method, "--samples", "20000", "--seed", "3", "--format", "json")
    assert a.returncode == 0, a.stderr
    da, db = json.loads(a.stdout), json.loads(b.stdout)
    assert da["clumps"][0]["mass"] == db["clumps"][0]["mass"]  # same seed, same numbers
    ref = mass_properties(EX_CENTERS[0], EX_RADII[0], density=1000.0, method=method, n_samples=20000, seed=3)
    assert da["clumps"][0]["mass"] == pytest.approx(ref.mass, rel=1e-12)
    assert "mass_standard_error" in da["clumps"][0]


@pytest.mark.parametrize("method", ["voxel"])
def test_voxel_discretization_is_passed(method):
    out = run(EXAMPLE, "--method", method, "--discretization", "12", "--format", "csv")
    assert out.returncode == 0, out.stderr
    row = next(csv.DictReader(io.StringIO(out.stdout)))
    ref = mass_properties(EX_CENTERS[0], EX_RADII[0], density=1000.0, method=method, discretization=12)
    assert float(row["mass_kg"]) == pytest.approx(ref.mass, rel=1e-14)


# ---------------------------------------------------------------- errors: one line, no traceback
def _one_line_error(out, *needles, code=1):
    assert out.returncode == code, (out.returncode, out.stdout, out.stderr)
    assert "Traceback" not in out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 if code == 1 else True, out.stderr
    assert lines[-1].startswith("clumpprops: error:"), out.stderr
    for n in needles:
        assert n in lines[-1], (n, out.stderr)
    assert out.stdout == ""


def test_missing_file(tmp_path):
    _one_line_error(run(tmp_path / "nope.txt"), "nope.txt", "No such file")


def test_malformed_line_reports_line_number(tmpfile):
    p = tmpfile("# header\n0 0 0 1 0\n0 0 1 one 0\n")
    _one_line_error(run(p), f"{p}:3:", "r is not a number")


def test_short_line(tmpfile):
    p = tmpfile("0 0 0 1 0\n\n0 0 1 1\n")
    _one_line_error(run(p), ":3:", "expected 5 columns")


def test_triple_overlap_with_pairwise_names_clump_and_lines(tmpfile):
    p = tmpfile("5 5 5 1 0\n0 0 0 1 4\n1 0 0 1 4\n0.5 0.8 0 1 4\n")
    _one_line_error(run(p, "--method", "pairwise"), "clump id 4", "lines 2-4", "triple overlap")


@pytest.mark.parametrize("method", ["exact"])
def test_triple_overlap_is_fine_for_exact(tmpfile, method):
    p = tmpfile("0 0 0 1 4\n1 0 0 1 4\n0.5 0.8 0 1 4\n")
    out = run(p, "--method", method)
    assert out.returncode == 0, out.stderr


def test_empty_file(tmpfile):
    _one_line_error(run(tmpfile("# nothing\n")), "no spheres")


def test_binary_file(tmpfile, tmp_path):
    p = tmp_path / "bin.txt"
    p.write_bytes(b"\xff\xfe\x00\x81" * 10)
    _one_line_error(run(p), "bin.txt")


@pytest.mark.parametrize(
    "args,needle",
    [
        (["--method", "nope"], "invalid choice"),
        (["--density", "0"], "--density"),
        (["--density", "abc"], "--density"),
        (["--format", "xml"], "invalid choice"),
        (["--method", "pairwise", "--samples", "10"], "--samples/--seed apply only to --method montecarlo"),
        (["--method", "sum", "--discretization", "5"], "--discretization applies only to --method voxel"),
        (["--samples", "-3", "--method", "montecarlo"], "--samples"),
    ],
)
def test_bad_options_exit_2(args, needle):
    out = run(EXAMPLE, *args)
    assert out.returncode == 2
    assert "Traceback" not in out.stderr
    assert needle in out.stderr


def test_help_mentions_units_and_default_density():
    out = run("--help")
    assert out.returncode == 0
    assert "kg/m^3" in out.stdout and "1000" in out.stdout and "textClumps" in out.stdout


def test_main_is_importable_and_returns_status(tmpfile, capsys):
    from clumpprops.cli import main

    assert main([str(tmpfile(DIMER)), "--method", "sum", "--format", "csv"]) == 0
    assert "0,2," in capsys.readouterr().out
    assert main([str(tmpfile("0 0 0 1 0\n0 0 1\n"))]) == 1
    assert "expected 5 columns" in capsys.readouterr().err


# ---------------------------------------------------------------- edges: only documented errors are caught, big files, big ids


def test_library_input_error_is_one_line(tmpfile):
    """Moments that overflow float64 are a documented library ValueError: one line, exit 1."""
    p = tmpfile("1e200 0 0 1e200 0\n1.5e200 0 0 1e200 0\n")
    _one_line_error(run(p), "overflow")


@pytest.mark.parametrize(
    "where, exc",
    [("compute", RuntimeError("a bug")), ("compute", IndexError("a bug")), ("format", RuntimeError("a bug")),
     ("format", ValueError("a bug")), ("format", IndexError("a bug"))],
)
def test_undocumented_exceptions_are_bugs_and_propagate(tmpfile, monkeypatch, where, exc):
    """The CLI catches only the library's documented errors; anything else shows its traceback.
    A ValueError is documented only where the library validates input (mass_properties)."""
    from clumpprops import cli

    def boom(*a, **k):
        raise exc

    if where == "compute":  # (a ValueError from mass_properties is its documented input error)
        monkeypatch.setattr(cli, "mass_properties", boom)
    else:
        monkeypatch.setitem(cli.FORMATTERS, "table", boom)
    with pytest.raises(type(exc), match="a bug"):
        cli.main([str(tmpfile(DIMER))])


def test_bug_shows_traceback_in_subprocess(tmp_path):
    """As a command: a bug (here an injected TypeError in the formatter) exits non-zero with a traceback."""
    code = (
        "import sys, clumpprops.cli as c\n"
        "c.FORMATTERS['table'] = lambda *a: None + 1\n"
        f"sys.exit(c.main([{str(EXAMPLE)!r}]))\n"
    )
    p = subprocess.run([PY, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert p.returncode == 1 and "Traceback" in p.stderr and "TypeError" in p.stderr


def test_large_plain_integer_ids(tmpfile):
    """Ids >= 10**6 written as integers (not %g) are read as they are."""
    text = "0 0 0 1 1000000\n1 0 0 1 1000000\n5 0 0 1 1000003\n9 0 0 1 123456789012\n"
    out = run(tmpfile(text), "--format", "csv", "--method", "sum")
    assert out.returncode == 0, out.stderr
    ids = [int(r["id"]) for r in csv.DictReader(io.StringIO(out.stdout))]
    assert ids == [1000000, 1000003, 123456789012]


def test_yade_g_format_ids_are_refused_clearly(tmpfile):
    """export.textClumps writes ids >= 10**6 with %g: 1234567 and 1234568 both become 1.23457e+06 and
    would merge into one clump; refused with the reason and the way out."""
    text = "#format x_y_z_r_clumpId\n0\t0\t0\t1\t999999\n5\t0\t0\t1\t1.23457e+06\n9\t0\t0\t1\t1.23457e+06\n"
    _one_line_error(run(tmpfile(text)), ":3:", "exponent form", "export.textClumps", "%g", "merge")


def _big_file(path, n_lines):
    """n_lines sphere lines (dimers, ids ascending) plus a header, written in blocks."""
    block = 10_000
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 10, (block, 3))
    r = rng.uniform(0.01, 0.05, block)
    prefix = [f"{a:g}\t{c:g}\t{d:g}\t{e:g}\t" for (a, c, d), e in zip(x.tolist(), r.tolist())]
    with open(path, "w") as f:
        f.write("#format x_y_z_r_clumpId\n")
        for b in range(n_lines // block):
            ids = map(str, range(b * block // 2, (b + 1) * block // 2))
            f.write("".join(f"{p0}{i}\n{p1}{i}\n" for p0, p1, i in zip(prefix[::2], prefix[1::2], ids)))


PARSE_BIG = """
import resource, sys, time
t = time.process_time()
from clumpprops.textclumps import read_text_clumps
cl = read_text_clumps(sys.argv[1])
# peak RSS of this image: VmHWM (getrusage's ru_maxrss keeps the pytest parent's peak across exec)
hwm = next(int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmHWM:"))
print(len(cl), sum(1 for _ in range(0)), cl.centers.shape[0], time.process_time() - t, hwm)
"""


def test_million_lines_parse_fast_with_bounded_memory(tmp_path):
    """10**6 lines: under a few seconds of CPU, memory ~100 bytes per sphere (measured here: ~1.1 s CPU,
    ~170 MB peak including Python and numpy; the text is read in blocks of 65536 lines)."""
    f = tmp_path / "big.txt"
    _big_file(f, 1_000_000)
    p = subprocess.run([PY, "-c", PARSE_BIG, str(f)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    n_clumps, _, n_spheres, cpu, maxrss_kb = p.stdout.split()
    assert int(n_clumps) == 500_000 and int(n_spheres) == 1_000_000
    assert float(cpu) < 5.0, cpu
    assert int(maxrss_kb) < 400_000, maxrss_kb  # the file is 40 MB of text; Python lists of floats would need ~1 GB


def test_fast_and_careful_parsers_agree():
    """The numpy block reader and the line-by-line reader (YADE's rules) give the same arrays; a block
    the numpy reader refuses ('1_0', which Python's float() would read as 10) goes line by line, which words the error."""
    from clumpprops import textclumps as tc

    text = ["#format x_y_z_r_clumpId\n", "# c\n", "\n"] + [
        f"{i * 0.1:.17g} {-i:.17g} 1e-3 0.{i + 1} {i // 3}  extra words\n" for i in range(300)
    ] + ["   # indented comment\n", "1 2 3 4 7\n"]
    from array import array

    assert tc._fast_chunk(text, 0, array("d"), array("q"), array("q"))  # the numpy path is taken
    fast = tc.parse_text_clumps(text, "t")
    orig = tc._fast_chunk
    try:
        tc._fast_chunk = lambda *a: False
        slow = tc.parse_text_clumps(text, "t")
    finally:
        tc._fast_chunk = orig
    for name in ("centers", "radii", "lines", "starts", "ids", "repeated"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(slow, name))
    assert not tc._fast_chunk(["1_0 2 3 4 7\n"], 0, array("d"), array("q"), array("q"))
    with pytest.raises(ClumpFileError, match=r"^t:306: x is not a number: '1_0'$"):
        tc.parse_text_clumps(text + ["1_0 2 3 4 7\n"], "t")  # Python's float() would read 10
