"""File readers: the numpy fast path against the line-by-line validators, the strict number
grammar, and reader quirks (digit separators, non-ASCII digits, a byte order mark, .mol
Masses and duplicate atom ids) reported as one ``FILE:LINE: ...`` line."""
from __future__ import annotations

import re

import numpy as np
import pytest

from clumpprops.io import ClumpFileError, read
from clumpprops.io import molecule as M
from clumpprops.io import tables as R
from clumpprops._numtext import fast_table, strict_float, strict_int
from clumpprops.textclumps import parse_text_clumps, read_text_clumps

# refused by every reader (Python's float() reads the first six as numbers), then words that are numbers
REFUSED = ["1_0", "1_000.5", "\u0661\u0660", "\u0661.5", "\uff15", "\u0967", "0x10", "1d3", "1e", "e5", "+-1", "nan(1)",
           "1.5.", "1e5.0", "\u00bd", "\u00b2", "1,0", "infinityx", "", "."]
NUMBERS = ["0", "-0", "+5", "1.", ".5", "+.5e-3", "1E+06", "6.02214076e23", "1e-320", "INF", "-Infinity", "nan",
           "0.1000000000000000055511151231257827"]


def _python_route(word):
    """An independent statement of the grammar: Python's float() on ASCII words without a digit separator."""
    if not word.isascii() or "_" in word or word != word.strip():
        raise ValueError(word)
    return float(word)


@pytest.mark.parametrize("word", REFUSED + NUMBERS)
def test_strict_grammar_numpy_and_python_agree(word):
    """strict_float, numpy's C reader (the fast path) and a hand-written grammar accept the same words,
    with the same float64 value."""
    refs = []
    for parse in (strict_float, _python_route):
        try:
            refs.append(parse(word))
        except ValueError:
            refs.append(None)
    rows = fast_table([f"{word} 1"] if word else [" 1"], np.dtype([("a", "f8"), ("b", "f8")]))
    refs.append(None if rows is None else float(rows["a"][0]))
    expected = None if word in REFUSED else float(word)
    for got in refs:
        assert (got is None) == (expected is None), (word, refs)
        if expected is not None:
            assert np.array_equal(got, expected, equal_nan=True), (word, refs)


@pytest.mark.parametrize("word,ok", [("12", True), ("-3", True), ("+0", True), ("1_0", False), ("\u0661", False),
                                     ("\uff15", False), ("3.0", False), ("1e3", False), ("", False)])
def test_strict_int_and_numpy_int_agree(word, ok):
    rows = fast_table([f"{word} 1"], np.dtype([("a", "i8"), ("b", "f8")]))
    assert (rows is not None) == ok
    if ok:
        assert strict_int(word) == int(word) == rows["a"][0]
    else:
        with pytest.raises(ValueError):
            strict_int(word)


# ------------------------------------------------------------------ quirks, one line each
def _one_line(exc, where, *parts):
    text = str(exc.value)
    assert "\n" not in text and where in text, text
    for p in parts:
        assert p in text, text


QUIRK_FILES = [
    # (name, text, FILE:LINE, words of the message)
    ("sep.csv", "x,y,z,r\n0,0,0,0.1\n1_0,0,0,0.1\n", "sep.csv:3:", ["x is not a number", "'1_0'"]),
    ("arab.csv", "0,0,0,0.1\n0,\u0661,0,0.1\n", "arab.csv:2:", ["y is not a number"]),
    ("sep.multisphere", "0 0 0 0.1\n0 0 0 1_0\n", "sep.multisphere:2:", ["r is not a number", "'1_0'"]),
    ("type.multisphere", "0 0 0 0.1 1\n0 0 0 0.1 1_0\n", "type.multisphere:2:", ["atom type) must be an integer"]),
    ("arab.multisphere", "# c\n\u0661 0 0 0.1\n", "arab.multisphere:2:", ["x is not a number"]),
    ("sep.txt", "0 0 0 0.1 0\n0 0 1_0 0.1 0\n", "sep.txt:2:", ["z is not a number", "'1_0'"]),
    ("id.txt", "0 0 0 0.1 0\n0 0 1 0.1 1_0\n", "id.txt:2:", ["clumpId must be an integer", "'1_0'"]),
    ("arabid.txt", "0 0 0 0.1 \u0661\n", "arabid.txt:1:", ["clumpId must be an integer"]),
    ("sep.mol", "t\n\n1 atoms\n\nCoords\n\n1 0 0 1_0\n\nDiameters\n\n1 0.2\n", "sep.mol:7:", ["z is not a number"]),
    ("arab.mol", "t\n\n1 atoms\n\nCoords\n\n\u0661 0 0 0\n\nDiameters\n\n1 0.2\n", "arab.mol:7:",
     ["atom id must be an integer"]),
    ("mass.mol", "t\n\n2 atoms\n\nCoords\n\n1 0 0 0\n2 0.1 0 0\n\nDiameters\n\n1 0.2\n2 0.2\n\nMasses\n\n1 0.004\n2 heavy\n",
     "mass.mol:18:", ["mass is not a number", "'heavy'"]),
    ("dup.mol", "t\n\n2 atoms\n\nCoords\n\n1 0 0 0\n2 0.1 0 0\n1 0.2 0 0\n\nDiameters\n\n1 0.2\n2 0.2\n",
     "dup.mol:9:", ["atom id 1 appears twice in Coords", "first on line 7"]),
    ("dupd.mol", "t\n\n2 atoms\n\nCoords\n\n1 0 0 0\n2 0.1 0 0\n\nDiameters\n\n2 0.2\n2 0.3\n1 0.2\n",
     "dupd.mol:13:", ["atom id 2 appears twice in Diameters", "first on line 12"]),
]


@pytest.mark.parametrize("name,text,where,parts", QUIRK_FILES, ids=[q[0] for q in QUIRK_FILES])
def test_reader_quirks_are_one_line_errors(tmp_path, name, text, where, parts):
    (tmp_path / name).write_text(text, encoding="utf-8")
    with pytest.raises(ClumpFileError) as exc:
        read(tmp_path / name)
    _one_line(exc, where, *parts)


BOM_FILES = [
    ("b.csv", "x,y,z,r\n0,0,0,0.1\n0,0,0.1,0.1\n"),
    ("b.multisphere", "0 0 0 0.1\n0 0 0.1 0.1\n"),
    ("b.txt", "0 0 0 0.1 3\n0 0 0.1 0.1 3\n"),
]


@pytest.mark.parametrize("name,text", BOM_FILES, ids=[b[0] for b in BOM_FILES])
def test_utf8_byte_order_mark_is_skipped(tmp_path, name, text):
    """Files saved by editors that start with a BOM read as the same file without it."""
    (tmp_path / ("plain_" + name)).write_text(text, encoding="utf-8")
    (tmp_path / name).write_text(text, encoding="utf-8-sig")
    assert (tmp_path / name).read_bytes()[:3] == b"\xef\xbb\xbf"
    (a,), (b,) = read(tmp_path / ("plain_" + name)), read(tmp_path / name)
    assert np.array_equal(a.centers, b.centers) and np.array_equal(a.radii, b.radii) and a.lines == b.lines


def test_byte_order_mark_in_text_clumps_lines_and_mid_file():
    cl = parse_text_clumps(["\ufeff0 0 0 1 5\n", "1 0 0 1 5\n"], "t")
    assert cl[0].clump_id == 5 and cl[0].n_spheres == 2
    with pytest.raises(ClumpFileError, match=r"^t:2: x is not a number"):  # only at the start of the file
        parse_text_clumps(["0 0 0 1 5\n", "\ufeff1 0 0 1 5\n"], "t")


def test_mol_masses_checked_and_extra_atoms_named(tmp_path):
    base = "t\n\n1 atoms\n\nCoords\n\n1 0 0 0\n\nDiameters\n\n1 0.2\n"
    cases = {"m0.mol": (base + "\nMasses\n\n1 0\n", "m0.mol:15: mass must be > 0"),
             "minf.mol": (base + "\nMasses\n\n1 inf\n", "minf.mol:15: mass is not finite"),
             "mcols.mol": (base + "\nMasses\n\n1\n", "mcols.mol:15: Masses line must be 'id mass'"),
             "extra.mol": (base + "2 0.2\n", "extra.mol:12: atom 2 of the Diameters section is not in Coords")}
    for name, (text, message) in cases.items():
        (tmp_path / name).write_text(text)
        with pytest.raises(ClumpFileError) as exc:
            read(tmp_path / name)
        assert f"/{message}" in str(exc.value) and "\n" not in str(exc.value), str(exc.value)
    (tmp_path / "ok.mol").write_text(base + "\nMasses\n\n1 0.0042\n")
    (c,) = read(tmp_path / "ok.mol")
    assert c.radii.tolist() == [0.1] and c.lines == (7,)


# ------------------------------------------------------------------ fast path == line-by-line validator
def _random_table(n, seed):
    rng = np.random.default_rng(seed)
    a = rng.uniform(-5, 5, (n, 4))
    a[:, 3] = rng.uniform(0.01, 1, n)
    a[::7] = np.round(a[::7], 2)  # short forms too
    return a


def _formats(a):
    """The same spheres as text in each reader's format, with comments and blank lines mixed in."""
    rows = [[repr(float(v)) for v in row] for row in a]
    csv = ["# spheres", "x,y,z,r"] + [",".join(r) if i % 5 else " , ".join(r) for i, r in enumerate(rows)]
    lig = ["# spheres", ""] + [" ".join(r) + ("  # note" if i % 3 == 0 else "") for i, r in enumerate(rows)]
    mcl = [",".join(r) + ("\n" if i % 4 == 0 else "") for i, r in enumerate(rows)]  # blank lines between
    n = len(rows)
    ids = np.random.default_rng(1).permutation(n) + 1
    mol = ["title", "", f"{n} atoms", "", "Coords", ""] + [f"{k} {' '.join(rows[k - 1][:3])}" for k in ids]
    mol += ["", "Diameters", ""] + [f"{k} {float(a[k - 1, 3]) * 2!r}" for k in ids[::-1]]
    mol += ["", "Masses", ""] + [f"{k} 1.5" for k in ids]
    return {"csv": (csv, R._csv_rows), "liggghts": (lig, R._liggghts_rows), "mclump": (mcl, R._mclump_rows),
            "lammps": (mol, None)}


@pytest.mark.parametrize("fmt", ["csv", "liggghts", "mclump", "lammps"])
def test_fast_path_equals_line_by_line_validator(tmp_path, fmt, monkeypatch):
    """The numpy reader gives bitwise the rows and line numbers of the Python validator (which the
    fast path must be taken for: checked by making the validator unavailable)."""
    a = _random_table(500, 3)
    text, _ = _formats(a)[fmt]
    path = tmp_path / f"t.{ {'csv': 'csv', 'liggghts': 'ms', 'mclump': 'txt', 'lammps': 'mol'}[fmt]}"
    path.write_text("\n".join(text) + "\n")
    (fast,) = read(path, fmt=fmt)
    slow_name = {"csv": "_csv_rows", "liggghts": "_liggghts_rows", "mclump": "_mclump_rows", "lammps": "_mol_rows"}[fmt]
    monkeypatch.setattr(R, "_fast_spheres", lambda *a, **k: None)
    monkeypatch.setattr(M, "_mol_fast", lambda *a, **k: None)
    (slow,) = read(path, fmt=fmt)
    assert np.array_equal(fast.centers, slow.centers) and np.array_equal(fast.radii, slow.radii)
    assert fast.lines == slow.lines
    if fmt == "lammps":  # atoms in id order, radius = diameter / 2
        ids = np.random.default_rng(1).permutation(len(a)) + 1
        assert np.array_equal(fast.centers, a[:, :3]) and np.allclose(fast.radii, a[:, 3], rtol=2e-16, atol=0)
        assert fast.lines[0] == 7 + int(np.flatnonzero(ids == 1)[0])
    else:
        assert np.array_equal(fast.centers, a[:, :3]) and np.array_equal(fast.radii, a[:, 3])
    monkeypatch.undo()
    monkeypatch.setattr(M if fmt == "lammps" else R, slow_name, lambda *a, **k: pytest.fail("the fast path was not taken"))
    read(path, fmt=fmt)


BAD_WORDS = REFUSED + ["nan", "inf", "-1e-300", "0", "-0.0", "0x", "#"]


@pytest.mark.parametrize("fmt", ["csv", "liggghts", "mclump", "yade", "lammps"])
def test_every_bad_word_is_refused_on_its_line(tmp_path, fmt):
    """A bad word in any column of line ~300 of a large file: the reader (fast path first) raises the
    line-by-line validator's message for that line, never a silently accepted value."""
    a = _random_table(600, 5)
    rng = np.random.default_rng(9)
    for word in BAD_WORDS:
        col = int(rng.integers(0, 4))
        if word in ("-1e-300", "0", "-0.0"):
            col = 3  # a radius <= 0 (a coordinate may be 0)
        rows = [[repr(float(v)) for v in row] for row in a]
        rows[300][col] = word
        if fmt == "lammps":
            sec = "Coords" if col < 3 else "Diameters"
            lines = ["t", "", "600 atoms", "", "Coords", ""] + [f"{k + 1} {' '.join(r[:3])}" for k, r in enumerate(rows)]
            lines += ["", "Diameters", ""] + [f"{k + 1} {r[3]}" for k, r in enumerate(rows)]
            lineno = 7 + 300 if sec == "Coords" else 7 + 600 + 3 + 300
            name = "f.mol"
        else:
            sep = "," if fmt in ("csv", "mclump") else " "
            lines = [sep.join(r) + (" 1" if fmt == "yade" else "") for r in rows]
            lineno, name = 301, {"csv": "f.csv", "liggghts": "f.ms", "mclump": "Clump.txt", "yade": "f.txt"}[fmt]
        (tmp_path / name).write_text("\n".join(lines) + "\n", encoding="utf-8")
        if word == "#" and fmt in ("csv", "liggghts", "yade") and col == 0:
            continue  # a comment line there (elsewhere a '#' leaves the line short or is not a number)
        with pytest.raises(ClumpFileError) as exc:
            read(tmp_path / name, fmt=fmt)
        assert re.search(rf"{re.escape(name)}:{lineno}: ", str(exc.value)), (word, str(exc.value))


def test_text_clumps_fast_and_line_by_line_agree_on_refusals():
    """textClumps: every refused word, in each of the five columns, fails on its line."""
    good = [f"{i * 0.5!r} 0 0 0.25 {i // 2}\n" for i in range(200)]
    for word in REFUSED + ["3.0", "1e+06", "99999999999999999999"]:
        for col in range(5):
            line = ["1", "2", "3", "0.5", "7"]
            line[col] = word
            if word == "" or (col < 4 and word in ("3.0", "1e+06", "99999999999999999999")):
                continue
            with pytest.raises(ClumpFileError) as exc:
                parse_text_clumps(good + [" ".join(line) + "\n"] + good, "t")
            assert exc.value.lineno == 201, (word, col, str(exc.value))


def test_text_clumps_file_with_bom(tmp_path):
    p = tmp_path / "b.txt"
    p.write_text("#format x_y_z_r_clumpId\n0 0 0 1 4\n", encoding="utf-8-sig")
    assert read_text_clumps(p)[0].clump_id == 4


@pytest.mark.parametrize("sep", ["\t", "\x0b", "\x0c", "\x1c", "\x85", "\u2003", "\u3000", "\u200b"])
def test_unusual_whitespace_splits_as_python_split(sep):
    """numpy's reader splits words where str.split() does (Unicode whitespace); where it does not
    (a zero-width space is not whitespace) the line-by-line path decides, with the same result."""
    from array import array

    from clumpprops import textclumps as tc

    line = f"1{sep}2 3 4 5\n"
    expect_split = len(line.split()) == 5
    assert tc._fast_chunk([line], 0, array("d"), array("q"), array("q")) == expect_split
    if expect_split:
        cl = parse_text_clumps([line], "t")
        assert cl.centers.tolist() == [[1.0, 2.0, 3.0]] and cl.radii.tolist() == [4.0] and cl.ids.tolist() == [5]
    else:
        with pytest.raises(ClumpFileError, match=r"^t:1: expected 5 columns"):
            parse_text_clumps([line], "t")
