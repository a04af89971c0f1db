"""``clumpprops show``: the PNG, and the arrows it draws are the principal axes."""
import numpy as np
import pytest

import clumpprops
from clumpprops.cli import main
from clumpprops.show import principal_arrows

pytest.importorskip("matplotlib")
CLUMPS = "0 0 0 1.0 0\n1.2 0 0 0.8 0\n0 0 0 1 1\n0 1.5 0 0.7 1\n0.5 0 1 0.6 1\n"


@pytest.fixture
def clump_file(tmp_path):
    path = tmp_path / "c.txt"
    path.write_text(CLUMPS)
    return path


def test_arrows_are_the_principal_axes():
    """A rod along (1, 1, 0): the least-moment arrow points along the rod, the others across it."""
    t = np.linspace(-1.0, 1.0, 5)[:, None]
    c, r = t * np.array([1.0, 1.0, 0.0]) / np.sqrt(2) + [3.0, -2.0, 1.0], np.full(5, 0.3)
    mp = clumpprops.mass_properties(c, r)
    arrows = principal_arrows(c, r, mp)
    assert len(arrows) == 3
    rod = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    assert abs(arrows[0].direction @ rod) == pytest.approx(1.0, abs=1e-12)
    for a in arrows[1:]:
        assert a.direction @ rod == pytest.approx(0.0, abs=1e-12)
    for a, moment in zip(arrows, mp.principal_moments):
        assert a.start == pytest.approx(np.asarray(mp.center_of_mass), abs=1e-14)
        assert a.moment == pytest.approx(moment, rel=1e-15)
        assert f"{moment:.4g}" in a.label
        d = a.end - a.start
        assert np.cross(d, a.direction) == pytest.approx(np.zeros(3), abs=1e-12)
    # the least-moment arrow reaches the end of the rod: half its length plus a radius
    assert np.linalg.norm(arrows[0].end - arrows[0].start) == pytest.approx(1.0 + 0.3, rel=1e-12)
    assert np.linalg.norm(arrows[1].end - arrows[1].start) == pytest.approx(0.3, rel=1e-12)


def test_png_has_the_size_and_is_not_blank(tmp_path, clump_file, capsys):
    from matplotlib.image import imread

    out = tmp_path / "c.png"
    assert main(["show", str(clump_file), "-o", str(out), "--clump", "1", "--size", "400"]) == 0
    img = imread(out)
    assert img.shape[:2] == (400, 400)
    rgb = img[..., :3]
    assert rgb.std() > 0.05 and (rgb < 0.9).any()  # drawn, not a blank canvas
    assert capsys.readouterr().out.strip() == str(out)


def test_never_overwrites_without_force(tmp_path, clump_file, capsys):
    out = tmp_path / "c.png"
    out.write_bytes(b"user's picture")
    assert main(["show", str(clump_file), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "exists" in err and "--force" in err
    assert out.read_bytes() == b"user's picture"
    assert main(["show", str(clump_file), "-o", str(out), "--force", "--size", "100"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_clump_out_of_range_is_one_line(tmp_path, clump_file, capsys):
    assert main(["show", str(clump_file), "-o", str(tmp_path / "x.png"), "--clump", "5"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "2 clump(s)" in err
    assert not (tmp_path / "x.png").exists()


def test_listed_in_the_top_level_help(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    assert "show" in capsys.readouterr().out
