"""The union mesh and the VTK and STL exporters: watertight, within tolerance of the exact volume and area."""
import numpy as np
import pytest

import clumpprops
from clumpprops import io as cio
from clumpprops.io.cli import main as export_main
from clumpprops.mesh import principal_extents, segments_for, union_mesh

manifold3d = pytest.importorskip("manifold3d")
meshio = pytest.importorskip("meshio")
trimesh = pytest.importorskip("trimesh")


def _dimer_area(r1, r2, d):
    """Closed form: the two spheres' areas minus the caps inside the other sphere (Archimedes' zones)."""
    x = (d * d + r1 * r1 - r2 * r2) / (2 * d)  # the intersection circle's plane, from the first centre
    return 2 * np.pi * r1 * (r1 + x) + 2 * np.pi * r2 * (r2 + (d - x))


def _clump(seed, n):
    rng = np.random.default_rng(seed)
    c = rng.normal(scale=0.6, size=(n, 3))
    return c, rng.uniform(0.4, 1.0, n)


def test_dimer_closed_form_is_the_library_area():
    """The test's closed form against the library's exact area (two independent routes)."""
    sd = clumpprops.shape_descriptors([[0, 0, 0], [1.2, 0, 0]], [1.0, 0.8])
    assert sd.surface_area == pytest.approx(_dimer_area(1.0, 0.8, 1.2), rel=1e-12)


@pytest.mark.parametrize("tol", [1e-2, 1e-3])
def test_dimer_mesh_volume_and_area_within_tolerance(tol):
    c, r = np.array([[0.0, 0, 0], [1.2, 0, 0]]), np.array([1.0, 0.8])
    m = union_mesh(c, r, tol)
    tm = trimesh.Trimesh(m.vertices, m.faces, process=False)
    assert tm.is_watertight and tm.is_volume
    exact_v = float(clumpprops.mass_properties(c, r).volume)
    assert abs(tm.volume / exact_v - 1) <= tol
    assert abs(tm.area / _dimer_area(1.0, 0.8, 1.2) - 1) <= tol
    assert tm.volume == pytest.approx(m.volume, rel=1e-9)


@pytest.mark.parametrize("seed,n", [(0, 5), (1, 20), (2, 50)])
def test_general_clump_mesh_within_tolerance(seed, n):
    c, r = _clump(seed, n)
    m = union_mesh(c, r, 1e-3)
    tm = trimesh.Trimesh(m.vertices, m.faces, process=False)
    assert tm.is_watertight and tm.is_winding_consistent
    sd = clumpprops.shape_descriptors(c, r)
    assert abs(tm.volume / sd.volume - 1) <= 1e-3
    assert abs(tm.area / sd.surface_area - 1) <= 1e-3
    assert len(tm.split(only_watertight=False)) == 1  # one connected surface, not overlapping shells


def test_segments_grow_as_tolerance_shrinks():
    n = [segments_for(t) for t in (1e-1, 1e-2, 1e-3, 1e-4)]
    assert n == sorted(n) and n[0] < n[-1] and all(k % 4 == 0 for k in n)
    with pytest.raises(ValueError):
        segments_for(0.0)


def test_principal_extents_of_a_dimer():
    lo, hi = principal_extents([[0, 0, 0], [1.0, 0, 0]], [0.5, 0.5], [0.5, 0, 0], np.eye(3))
    assert lo == pytest.approx([-1.0, -0.5, -0.5]) and hi == pytest.approx([1.0, 0.5, 0.5])


@pytest.fixture
def clump_file(tmp_path):
    path = tmp_path / "c.txt"
    path.write_text("0 0 0 1.0 0\n1.2 0 0 0.8 0\n0 0 0 1 1\n0 1.5 0 0.7 1\n0.5 0 1 0.6 1\n")
    return path


def test_vtk_export_reads_back_points_radii_and_axes(tmp_path, clump_file):
    clumps = cio.read(str(clump_file))
    paths = cio.export(clumps, "vtk", tmp_path / "out", density=2500.0)
    assert [p.name for p in paths] == ["c_0.vtu", "c_1.vtu"]
    for c, p in zip(clumps, paths):
        mp = clumpprops.mass_properties(c.centers, c.radii, density=2500.0)
        got = meshio.read(p)
        n = c.n_spheres
        assert np.array_equal(got.points[:n], c.centers)
        assert np.array_equal(got.point_data["radius"][:n], c.radii)
        assert np.array_equal(got.point_data["diameter"][:n], 2 * c.radii)
        assert np.array_equal(got.points[n], mp.center_of_mass)
        lines = got.cells_dict["line"]
        assert lines.shape == (3, 2)
        lo, hi = principal_extents(c.centers, c.radii, mp.center_of_mass, mp.principal_axes)
        for k, (a, b) in enumerate(lines):
            seg = got.points[b] - got.points[a]
            axis = np.asarray(mp.principal_axes)[:, k]
            assert abs(seg @ axis) == pytest.approx(np.linalg.norm(seg), rel=1e-12)  # along the axis
            assert np.linalg.norm(seg) == pytest.approx(hi[k] - lo[k], rel=1e-12)  # the union's extent
        moments = got.cell_data_dict["principal_moment"]["line"]
        assert moments == pytest.approx(np.asarray(mp.principal_moments), rel=1e-15)


def test_stl_export_is_watertight_within_tolerance(tmp_path, clump_file, capsys):
    out = tmp_path / "out"
    assert export_main([str(clump_file), "--to", "stl", "--out", str(out), "--tolerance", "1e-3"]) == 0
    for c in cio.read(str(clump_file)):
        tm = trimesh.load(out / f"{c.name}.stl")
        assert tm.is_watertight
        sd = clumpprops.shape_descriptors(c.centers, c.radii)
        assert abs(tm.volume / sd.volume - 1) <= 1e-3  # STL stores float32: 1e-7 relative on top
        assert abs(tm.area / sd.surface_area - 1) <= 1e-3
    capsys.readouterr()
    assert export_main([str(clump_file), "--to", "stl", "--out", str(out)]) == 1  # exists: refused
    assert "exists" in capsys.readouterr().err


def test_bad_tolerance_is_a_usage_error(clump_file, tmp_path):
    with pytest.raises(SystemExit) as exc:
        export_main([str(clump_file), "--to", "stl", "--out", str(tmp_path), "--tolerance", "-1"])
    assert exc.value.code == 2
