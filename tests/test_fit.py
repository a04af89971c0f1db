"""``clumpprops fit MESH --spheres N``: the fitted clump and the printed comparison with the mesh.

The mesh's reference values are recomputed here from its tetrahedra (the volume and second moments
of the cone of each triangle from the origin), and the clump's from closed forms of spheres, so the
printed numbers are checked against routes that share nothing with trimesh or the compiled core."""
import json
import math
import sys
from importlib.util import find_spec

import numpy as np
import pytest

from clumpprops.cli import main

trimesh = pytest.importorskip("trimesh", reason="clumpprops fit needs trimesh (pip install clumpprops[fit])")

RHO = 2500.0


def _write(mesh, path):
    mesh.export(str(path))
    return str(path)


def _ellipsoid(subdivisions=2, semi_axes=(0.02, 0.01, 0.007)):
    return trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0).apply_scale(semi_axes)


def _run(capsys, *argv):
    status = main(["fit", *map(str, argv)])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def _fit_json(capsys, mesh_file, n, out, *extra):
    status, text, err = _run(capsys, mesh_file, "--spheres", n, "-o", out, "--density", RHO, "--json", *extra)
    assert status == 0, err
    return json.loads(text)


def _spheres(path):
    table = np.loadtxt(path, ndmin=2)
    return table[:, :3], table[:, 3]


def _tetra_moments(path):
    """Volume, centre of mass and inertia about it (unit density) of a closed mesh, from its tetrahedra."""
    tri = np.asarray(trimesh.load(path, force="mesh").triangles, dtype=float)
    det = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2]))  # 6 x signed volume
    volume = det.sum() / 6.0
    com = (det[:, None] * tri.sum(axis=1)).sum(axis=0) / 24.0 / volume
    # int x x^T over the tetrahedron (0, a, b, c) = det/120 (sum_i v_i v_i^T + (sum_i v_i)(sum_i v_i)^T)
    s = tri.sum(axis=1)
    second = (det[:, None, None] * (np.einsum("nki,nkj->nij", tri, tri) + np.einsum("ni,nj->nij", s, s))).sum(0) / 120.0
    second -= volume * np.outer(com, com)
    inertia = np.trace(second) * np.eye(3) - second
    return volume, com, inertia


def _summed_spheres(centers, radii):
    """Volume and inertia about its centre of mass (unit density) of the spheres counted one by one."""
    vols = 4.0 / 3.0 * math.pi * radii ** 3
    com = (vols[:, None] * centers).sum(axis=0) / vols.sum()
    d = centers - com
    inertia = sum(v * ((0.4 * r * r + dd @ dd) * np.eye(3) - np.outer(dd, dd)) for v, r, dd in zip(vols, radii, d))
    return vols.sum(), inertia


def test_one_sphere_in_an_icosphere_is_closer_than_the_icosphere_to_its_sphere(tmp_path, capsys):
    radius = 0.01
    ico = trimesh.creation.icosphere(subdivisions=3, radius=radius)
    mesh_file = _write(ico, tmp_path / "ico.stl")
    doc = _fit_json(capsys, mesh_file, 1, tmp_path / "ico.txt")
    centers, radii = _spheres(tmp_path / "ico.txt")
    assert radii.shape == (1,)
    ico_error = abs(ico.volume / (4.0 / 3.0 * math.pi * radius ** 3) - 1.0)
    fit_error = abs(doc["error_exact"]["volume_m3"])
    assert 0 < fit_error < ico_error
    assert np.linalg.norm(centers[0]) < 1e-3 * radius
    assert doc["error_exact"]["axis_angle_deg"] == [None, None, None]  # a sphere has no principal axes


HAVE_MULTISPHERE = find_spec("multisphere") is not None
NO_MULTISPHERE = pytest.mark.skipif(not HAVE_MULTISPHERE,
                                    reason="multisphere not installed (pip install clumpprops[fit])")
GENERATORS = ["euclidean", pytest.param("multisphere", marks=NO_MULTISPHERE)]


@pytest.mark.parametrize("generator", GENERATORS)
def test_printed_numbers_equal_an_independent_computation(tmp_path, capsys, generator):
    mesh_file = _write(_ellipsoid(), tmp_path / "ell.stl")
    doc = _fit_json(capsys, mesh_file, 5, tmp_path / "ell.txt", "--generator", generator)
    volume, com, inertia = _tetra_moments(mesh_file)
    mesh_moments = np.linalg.eigvalsh(RHO * inertia)
    assert doc["mesh"]["volume_m3"] == pytest.approx(volume, rel=1e-12)
    assert doc["mesh"]["center_of_mass_m"] == pytest.approx(com, abs=1e-15)
    assert [doc["mesh"][f"I{k}_kgm2"] for k in (1, 2, 3)] == pytest.approx(mesh_moments, rel=1e-10)
    centers, radii = _spheres(tmp_path / "ell.txt")
    assert len(radii) == 5 == doc["spheres"]
    sum_volume, sum_inertia = _summed_spheres(centers, radii)
    sum_moments = np.linalg.eigvalsh(RHO * sum_inertia)
    assert doc["sum"]["volume_m3"] == pytest.approx(sum_volume, rel=1e-12)
    assert doc["error_sum"]["volume_m3"] == pytest.approx(sum_volume / volume - 1, rel=1e-10)
    for k in range(3):
        assert doc["error_sum"][f"I{k + 1}_kgm2"] == pytest.approx(sum_moments[k] / mesh_moments[k] - 1, rel=1e-9)
    # the exact union lies between the largest sphere and the sum; the sum adds what the overlaps hold
    assert 4.0 / 3.0 * math.pi * radii.max() ** 3 < doc["exact"]["volume_m3"] < sum_volume
    assert doc["sum_adds"]["volume_m3"] == pytest.approx(sum_volume / doc["exact"]["volume_m3"] - 1, rel=1e-12)


def test_the_table_prints_the_json_numbers(tmp_path, capsys):
    mesh_file = _write(_ellipsoid(subdivisions=1), tmp_path / "ell.stl")
    doc = _fit_json(capsys, mesh_file, 3, tmp_path / "a.txt", "--divisions", 20)
    status, text, _ = _run(capsys, mesh_file, "--spheres", 3, "-o", tmp_path / "b.txt", "--density", RHO,
                           "--divisions", 20)
    assert status == 0
    rows = {line.split()[0]: line.split()[1:] for line in text.splitlines()[1:]}
    assert float(rows["volume_m3"][0]) == pytest.approx(doc["mesh"]["volume_m3"], rel=1e-6)
    assert float(rows["I3_kgm2"][2]) == pytest.approx(100 * doc["error_exact"]["I3_kgm2"], abs=1e-4)
    assert float(rows["mass_kg"][5]) == pytest.approx(100 * doc["sum_adds"]["mass_kg"], abs=1e-4)


@pytest.mark.parametrize("generator", GENERATORS)
def test_errors_shrink_as_spheres_are_added(tmp_path, capsys, generator):
    mesh_file = _write(_ellipsoid(), tmp_path / "ell.stl")
    few = _fit_json(capsys, mesh_file, 5, tmp_path / "n5.txt", "--generator", generator)["error_exact"]
    many = _fit_json(capsys, mesh_file, 20, tmp_path / "n20.txt", "--generator", generator)["error_exact"]
    for key in ("volume_m3", "I1_kgm2", "I2_kgm2", "I3_kgm2"):
        assert abs(many[key]) < abs(few[key]), key
    assert max(many["axis_angle_deg"]) < 2.0  # the ellipsoid's axes are distinct; the clump keeps them


def test_missing_mesh_is_one_line_and_status_1(tmp_path, capsys):
    status, out, err = _run(capsys, tmp_path / "nothing.stl", "--spheres", 3)
    assert status == 1 and out == ""
    assert err.count("\n") == 1 and "nothing.stl" in err and "no such file" in err


def test_open_mesh_is_refused(tmp_path, capsys):
    ico = trimesh.creation.icosphere(subdivisions=1)
    open_mesh = trimesh.Trimesh(ico.vertices, ico.faces[1:], process=False)
    mesh_file = _write(open_mesh, tmp_path / "open.stl")
    status, _, err = _run(capsys, mesh_file, "--spheres", 3, "-o", tmp_path / "o.txt")
    assert status == 1
    assert err.count("\n") == 1 and "not watertight" in err
    assert not (tmp_path / "o.txt").exists()


def test_an_existing_file_is_kept_unless_forced(tmp_path, capsys):
    mesh_file = _write(trimesh.creation.icosphere(subdivisions=1), tmp_path / "ico.stl")
    out = tmp_path / "ico.spheres.txt"  # the default name
    out.write_text("mine\n")
    status, _, err = _run(capsys, mesh_file, "--spheres", 1, "--divisions", 10)
    assert status == 1 and "--force" in err and err.count("\n") == 1
    assert out.read_text() == "mine\n"
    status, _, _ = _run(capsys, mesh_file, "--spheres", 1, "--divisions", 10, "--force")
    assert status == 0 and _spheres(out)[1].shape == (1,)
    status, _, err = _run(capsys, mesh_file, "--spheres", 1, "-o", mesh_file, "--force")
    assert status == 1 and "input mesh" in err
    assert trimesh.load(mesh_file).is_watertight


def test_main_help_lists_fit(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    assert "fit" in capsys.readouterr().out


def test_bad_overlap_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["fit", str(tmp_path / "x.stl"), "--spheres", "2", "--overlap", "1"])
    assert exc.value.code == 2


def test_scale_turns_a_millimetre_mesh_into_metres(tmp_path, capsys):
    metres = _fit_json(capsys, _write(_ellipsoid(), tmp_path / "m.stl"), 4, tmp_path / "m.txt")
    mm = _ellipsoid().apply_scale(1000.0)
    millimetres = _fit_json(capsys, _write(mm, tmp_path / "mm.stl"), 4, tmp_path / "mm.txt", "--scale", 0.001)
    assert millimetres["mesh"]["volume_m3"] == pytest.approx(metres["mesh"]["volume_m3"], rel=1e-9)
    assert millimetres["exact"]["I3_kgm2"] == pytest.approx(metres["exact"]["I3_kgm2"], rel=1e-6)
    assert _spheres(tmp_path / "mm.txt")[1] == pytest.approx(_spheres(tmp_path / "m.txt")[1], rel=1e-6)


def test_without_trimesh_the_error_says_what_to_install(tmp_path, monkeypatch):
    from clumpprops import fit

    monkeypatch.setitem(sys.modules, "trimesh", None)
    with pytest.raises(fit.FitError, match=r"pip install clumpprops\[fit\]"):
        fit.load_mesh(str(tmp_path / "grain.stl"))


@pytest.mark.parametrize("kwargs", [{"n_spheres": 0}, {"n_spheres": 2, "overlap": 1.0},
                                    {"n_spheres": 2, "divisions": 0}])
def test_fit_spheres_refuses_bad_settings(kwargs):
    from clumpprops import fit

    with pytest.raises(ValueError, match="overlap"):
        fit.fit_spheres(trimesh.creation.icosphere(subdivisions=1), **kwargs)


@NO_MULTISPHERE
def test_multisphere_leaves_no_placeholder_behind():
    from clumpprops import fit

    had_pyvista = "pyvista" in sys.modules
    centers, radii = fit.multisphere_spheres(_ellipsoid(subdivisions=1), 3, divisions=20)
    assert centers.shape == (len(radii), 3) and 1 <= len(radii) <= 3 and np.all(radii > 0)
    assert ("pyvista" in sys.modules) == had_pyvista


def test_principal_axes_follow_a_rotated_grain(tmp_path, capsys):
    rotation = trimesh.transformations.rotation_matrix(0.7, [1.0, 2.0, 3.0])
    mesh_file = _write(_ellipsoid().apply_transform(rotation), tmp_path / "turned.stl")
    doc = _fit_json(capsys, mesh_file, 5, tmp_path / "turned.txt")
    axes = np.asarray(doc["mesh"]["principal_axes"])
    # I1 is about the longest semi-axis (the unrotated x), I3 about the shortest (the unrotated z)
    assert np.abs(np.sum(axes * rotation[:3, :3], axis=0)) == pytest.approx(np.ones(3), abs=1e-3)
    # the clump's own axes, from its written spheres' sum, point the same way
    centers, radii = _spheres(tmp_path / "turned.txt")
    sum_axes = np.linalg.eigh(_summed_spheres(centers, radii)[1])[1]
    angles = np.degrees(np.arccos(np.clip(np.abs(np.sum(sum_axes * axes, axis=0)), 0, 1)))
    assert doc["error_sum"]["axis_angle_deg"] == pytest.approx(angles, abs=1e-6)
