"""``clumpprops fit MESH --spheres N``: a clump of about N spheres for a closed triangle mesh, and how
far its exact mass properties are from the mesh's own.

Usage (see ``docs/fit.md``)::

    clumpprops fit MESH --spheres N [-o OUT.txt] [--force] [--scale F] [--density RHO]
                        [--generator euclidean|multisphere] [--overlap F] [--divisions K] [--json]

It reads MESH (any closed triangle mesh trimesh reads: STL, OBJ, PLY, OFF, ...), places the spheres
with CLUMP's Euclidean method (Angelidakis et al. 2021: the largest sphere that fits in the part of a
voxelisation not yet covered, N times; each sphere removes the voxels within ``(1 - overlap) r`` of
its centre), with each centre refined and each radius computed from exact distances to the mesh's
triangles, or with the ``multisphere`` package's MSS method (``--generator multisphere``), writes
the clump as ``x y z r`` lines to OUT (default: MESH with the suffix ``.spheres.txt``; never over
an existing file without ``--force``, never over MESH) and prints the
clump's exact properties (:func:`clumpprops.mass_properties`) against the mesh's (trimesh's
``mass_properties``) at the same density: volume, centre of mass, principal moments, the angle
between principal axes, and the error the summed spheres (method ``"sum"``) add on top.

Errors (missing or unreadable mesh, a mesh that is not closed) print one line
``clumpprops fit: error: ...`` on stderr and exit with status 1; bad options exit with status 2.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import sys
import types
from typing import Optional, Sequence

import numpy as np

from ._argtypes import _positive_float, _positive_int
from .api import mass_properties

PROG = "clumpprops fit"
DEFAULT_DENSITY = 1000.0  # kg/m^3, as the main command
DEFAULT_OVERLAP = 0.6     # CLUMP's Euclidean example
DEFAULT_DIVISIONS = 50    # voxels along the mesh's shortest bounding-box edge (CLUMP's default)
AXIS_GAP = 1e-6           # relative gap below which two of the mesh's principal moments count as equal
ROWS = ("volume_m3", "mass_kg", "I1_kgm2", "I2_kgm2", "I3_kgm2")


class FitError(Exception):
    """A user-facing error of ``clumpprops fit``: printed as one line, exit status 1."""


def load_mesh(path: str, scale: float = 1.0):
    """Read a closed triangle mesh.

    Parameters
    ----------
    path : str
        A mesh file trimesh reads (STL, OBJ, PLY, OFF, ...).
    scale : float
        Factor from the file's length unit to m (0.001 for a file in mm).

    Returns
    -------
    trimesh.Trimesh
        The mesh in m, with outward normals.

    Raises
    ------
    FitError
        If trimesh is missing, the file cannot be read, holds no triangles or is not watertight.
    """
    try:
        import trimesh
    except ImportError:
        raise FitError("fit needs trimesh: pip install clumpprops[fit]") from None
    if not os.path.isfile(path):
        raise FitError(f"cannot read {path}: no such file")
    try:
        mesh = trimesh.load(path, force="mesh")
    except Exception as exc:  # trimesh raises many kinds on a malformed file
        raise FitError(f"cannot read {path} as a triangle mesh: {exc}") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise FitError(f"{path} holds no triangles")
    if not mesh.is_watertight:
        raise FitError(f"{path} is not a closed surface (not watertight): it has no volume to fit")
    if mesh.volume < 0:
        mesh.invert()
    return mesh.apply_scale(scale) if scale != 1.0 else mesh


class _Clearance:
    """Exact clearance of a point: its distance to the mesh's surface and to the covered balls."""

    def __init__(self, mesh, overlap: float):
        self.triangles = np.asarray(mesh.triangles, dtype=float)
        self.keep = 1.0 - overlap
        self.centers: list = []
        self.radii: list = []

    def _surface_distances(self, x, triangles):
        from trimesh.triangles import closest_point

        near = closest_point(triangles, np.broadcast_to(x, (len(triangles), 3)))
        return np.sqrt(np.sum((near - x) ** 2, axis=1))

    def __call__(self, x, triangles=None) -> float:
        x = np.asarray(x, dtype=float)
        d = float(np.min(self._surface_distances(x, self.triangles if triangles is None else triangles)))
        if self.centers:
            d = min(d, float(np.min(np.linalg.norm(np.asarray(self.centers) - x, axis=1)
                                    - self.keep * np.asarray(self.radii))))
        return d

    def refine(self, seed, step: float):
        """The centre within ``step`` of ``seed`` with the largest clearance, and that clearance."""
        from scipy.optimize import minimize

        seed = np.asarray(seed, dtype=float)
        # distances are 1-Lipschitz: within 3 steps of the seed, no other triangle can be the nearest
        dist = self._surface_distances(seed, self.triangles)
        near = self.triangles[dist <= dist.min() + 6.0 * step]
        simplex = seed + np.vstack([np.zeros(3), 0.5 * step * np.eye(3)])
        res = minimize(lambda x: -self(x, near), seed, method="Nelder-Mead",
                       options={"initial_simplex": simplex, "xatol": 1e-4 * step, "fatol": 1e-6 * step,
                                "maxiter": 300})
        best, at_seed = self(res.x), self(seed)
        if np.linalg.norm(res.x - seed) <= step and best >= at_seed:
            return res.x, best
        return seed, at_seed

    def add(self, center, radius: float) -> None:
        self.centers.append(np.asarray(center, dtype=float))
        self.radii.append(float(radius))


def fit_spheres(mesh, n_spheres: int, overlap: float = DEFAULT_OVERLAP, divisions: int = DEFAULT_DIVISIONS):
    """Place about ``n_spheres`` spheres in a closed mesh (CLUMP's Euclidean method, exact distances).

    Parameters
    ----------
    mesh : trimesh.Trimesh
        A watertight mesh (see :func:`load_mesh`), in m.
    n_spheres : int
        Number of spheres wanted; fewer when the voxelisation is covered first.
    overlap : float
        In [0, 1): a sphere of radius r removes the voxels within ``(1 - overlap) r`` of its centre,
        so 0 gives touching spheres and larger values more overlap.
    divisions : int
        Voxels along the shortest edge of the mesh's bounding box (the voxelisation only seeds the
        centres; radii come from exact distances).

    Returns
    -------
    centers : ndarray, shape (M, 3)
        Sphere centres in the mesh's frame, m (M <= n_spheres).
    radii : ndarray, shape (M,)
        Sphere radii, m: each the exact distance from its centre to the nearer of the mesh's
        surface and the part already covered.

    Raises
    ------
    ValueError
        If ``overlap`` is outside [0, 1) or ``n_spheres`` or ``divisions`` is not positive.
    """
    from scipy.ndimage import distance_transform_edt

    if not 0.0 <= overlap < 1.0 or n_spheres < 1 or divisions < 1:
        raise ValueError(f"need 0 <= overlap < 1, n_spheres >= 1 and divisions >= 1; "
                         f"got {overlap}, {n_spheres}, {divisions}")
    pitch = float(np.min(mesh.extents)) / divisions
    grid = mesh.voxelized(pitch=pitch, method="subdivide").fill()
    inside = np.pad(np.asarray(grid.matrix, dtype=bool), 1)
    index = np.indices(inside.shape).reshape(3, -1).T
    points = grid.indices_to_points(index - 1).reshape(inside.shape + (3,))
    clearance = _Clearance(mesh, overlap)
    for _ in range(n_spheres):
        if not inside.any():
            break
        edt = distance_transform_edt(inside)
        ties = np.argwhere(edt == edt.max())
        seeds = points[tuple(ties.T)]
        seed = seeds[np.argmax(np.linalg.norm(seeds - mesh.centroid, axis=1))]  # CLUMP: the farthest tie
        center, radius = clearance.refine(seed, pitch)
        if radius <= 0:
            break
        clearance.add(center, radius)
        inside &= np.linalg.norm(points - center, axis=-1) > (1.0 - overlap) * radius
    return np.asarray(clearance.centers).reshape(-1, 3), np.asarray(clearance.radii)


def multisphere_spheres(mesh, n_spheres: int, divisions: int = DEFAULT_DIVISIONS):
    """Place up to ``n_spheres`` spheres in a closed mesh with the ``multisphere`` package (MSS).

    Parameters
    ----------
    mesh : trimesh.Trimesh
        A watertight mesh (see :func:`load_mesh`), in m.
    n_spheres : int
        Largest number of spheres (``max_spheres``).
    divisions : int
        Voxels along the shortest edge of the mesh's bounding box (``div``).

    Returns
    -------
    centers : ndarray, shape (M, 3)
        Sphere centres in the mesh's frame, m.
    radii : ndarray, shape (M,)
        Sphere radii, m (multiples of the voxel size; a sphere may reach past the mesh).

    Raises
    ------
    FitError
        If ``multisphere`` is not installed.
    """
    mss = _import_multisphere()
    with contextlib.redirect_stdout(io.StringIO()):  # it prints why it stopped
        pack = mss.multisphere_from_mesh(mesh, div=divisions, max_spheres=n_spheres)
    return np.asarray(pack.centers, dtype=float).reshape(-1, 3), np.asarray(pack.radii, dtype=float).reshape(-1)


def _import_multisphere():
    """``import multisphere``; its package imports PyVista for its plots only, so a placeholder
    stands in for PyVista while it loads when PyVista is not installed (the plots are not used)."""
    placeholder = None
    try:
        import pyvista  # noqa: F401
    except ImportError:
        placeholder = sys.modules["pyvista"] = types.ModuleType("pyvista")
    try:
        import multisphere
    except ImportError:
        raise FitError("--generator multisphere needs the multisphere package: pip install clumpprops[fit]") from None
    finally:
        if placeholder is not None and sys.modules.get("pyvista") is placeholder:
            del sys.modules["pyvista"]
    return multisphere


GENERATORS = ("euclidean", "multisphere")


def _principal(inertia):
    moments, axes = np.linalg.eigh(0.5 * (inertia + inertia.T))
    return moments, axes


def _axis_angles_deg(axes_a, axes_b):
    """Angle between corresponding principal axes (columns), degrees, sign-free."""
    cos = np.clip(np.abs(np.sum(axes_a * axes_b, axis=0)), 0.0, 1.0)
    return np.degrees(np.arccos(cos))


def compare(mesh, centers, radii, density: float) -> dict:
    """The clump's exact and summed mass properties against the mesh's, at one density.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The watertight mesh, m.
    centers : array_like, shape (M, 3)
        Sphere centres, m.
    radii : array_like, shape (M,)
        Sphere radii, m.
    density : float
        kg/m^3, for the mesh and the spheres.

    Returns
    -------
    dict
        ``"spheres"``: the number of spheres; ``"mesh"``, ``"exact"`` and ``"sum"``: each
        ``{"volume_m3", "mass_kg", "I1_kgm2", "I2_kgm2", "I3_kgm2", "center_of_mass_m",
        "principal_axes"}`` (moments ascending, about the centre of mass; the axes as the columns
        of a (3, 3) array, in the same order); ``"error_exact"`` and
        ``"error_sum"``: relative errors against the mesh of the ``ROWS`` quantities, the centre of
        mass offset (m) and the principal-axis angles (degrees; None where the mesh's moment is
        repeated, so its axis is not defined); ``"sum_adds"``: the summed values
        relative to the exact ones, minus 1.
    """
    props = mesh.mass_properties
    ref = _values(props["volume"], props["volume"] * density, props["center_mass"],
                  np.asarray(props["inertia"]) * density)
    out = {"mesh": ref, "spheres": int(len(radii))}
    for method in ("exact", "sum"):
        mp = mass_properties(centers, radii, density=density, method=method)
        out[method] = _values(mp.volume, mp.mass, mp.center_of_mass, mp.inertia)
        out["error_" + method] = _errors(out[method], ref)
    out["sum_adds"] = {k: out["sum"][k] / out["exact"][k] - 1.0 for k in ROWS}
    return out


def _values(volume, mass, com, inertia):
    moments, axes = _principal(np.asarray(inertia, dtype=float))
    vals = {"volume_m3": float(volume), "mass_kg": float(mass), "center_of_mass_m": [float(c) for c in com]}
    vals.update({f"I{k + 1}_kgm2": float(m) for k, m in enumerate(moments)})
    vals["principal_axes"] = axes
    return vals


def _distinct(moments, k, rel=AXIS_GAP):
    """Whether principal moment k stands apart from the others (so that its axis is defined)."""
    gaps = np.abs(np.delete(moments, k) - moments[k])
    return bool(np.all(gaps > rel * np.max(np.abs(moments))))


def _errors(vals, ref):
    err = {k: vals[k] / ref[k] - 1.0 for k in ROWS}
    err["com_offset_m"] = float(np.linalg.norm(np.subtract(vals["center_of_mass_m"], ref["center_of_mass_m"])))
    moments = np.array([ref[f"I{k + 1}_kgm2"] for k in range(3)])
    angles = _axis_angles_deg(vals["principal_axes"], ref["principal_axes"])
    err["axis_angle_deg"] = [float(a) if _distinct(moments, k) else None for k, a in enumerate(angles)]
    return err


def format_report(result: dict, mesh_path: str, out_path: str) -> str:
    """The comparison of :func:`compare` as a table.

    Parameters
    ----------
    result : dict
        What :func:`compare` returns.
    mesh_path, out_path : str
        The mesh read and the sphere file written, for the header line.

    Returns
    -------
    str
        A header line and one row per quantity: the mesh's value, the exact clump's, its error in %,
        the summed clump's, its error in %, and what the sum adds to the exact value in %.  Angles
        between principal axes are in degrees, "undefined" where the mesh's moment is repeated.
    """
    head = f"# {mesh_path}: {result['spheres']} spheres written to {out_path}\n"
    lines = [("quantity", "mesh", "clump", "error_%", "sum", "sum_error_%", "sum_adds_%")]
    ee, es = result["error_exact"], result["error_sum"]
    for k in ROWS:
        lines.append((k, f"{result['mesh'][k]:.6e}", f"{result['exact'][k]:.6e}", f"{100 * ee[k]:+.4f}",
                      f"{result['sum'][k]:.6e}", f"{100 * es[k]:+.4f}", f"{100 * result['sum_adds'][k]:+.4f}"))
    lines.append(("com_offset_m", "0", f"{ee['com_offset_m']:.3e}", "-", f"{es['com_offset_m']:.3e}", "-", "-"))
    for k in range(3):
        lines.append((f"axis{k + 1}_angle_deg", "0", _angle(ee["axis_angle_deg"][k]), "-",
                      _angle(es["axis_angle_deg"][k]), "-", "-"))
    widths = [max(len(r[j]) for r in lines) for j in range(len(lines[0]))]
    body = "\n".join("  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in lines)
    return head + body + "\n"


def _angle(deg):
    return "undefined" if deg is None else f"{deg:.3f}"


def _public(result: dict) -> dict:
    """``result`` with its arrays as lists, for JSON."""
    return {k: ({kk: (vv.tolist() if isinstance(vv, np.ndarray) else vv) for kk, vv in v.items()}
                if isinstance(v, dict) else v) for k, v in result.items()}


def write_spheres(path: str, centers, radii, force: bool = False) -> None:
    """Write ``x y z r`` lines (m), refusing to replace an existing file unless ``force``.

    Parameters
    ----------
    path : str
        Output file.
    centers : array_like, shape (M, 3)
        Sphere centres, m.
    radii : array_like, shape (M,)
        Sphere radii, m.
    force : bool
        Replace ``path`` if it exists.

    Raises
    ------
    FitError
        If ``path`` exists and ``force`` is false, or it cannot be written.
    """
    table = np.column_stack([np.asarray(centers, dtype=float).reshape(-1, 3), np.asarray(radii, dtype=float)])
    text = "".join(" ".join(repr(float(v)) for v in row) + "\n" for row in table)
    try:
        with open(path, "w" if force else "x") as f:
            f.write(text)
    except FileExistsError:
        raise FitError(f"{path} exists; pass --force to replace it or -o to choose another file") from None
    except OSError as exc:
        raise FitError(f"cannot write {path}: {exc.strerror or exc}") from None


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``clumpprops fit``."""
    p = _Parser(prog=PROG, description=(
        "Fit a clump of about N spheres to a closed triangle mesh (CLUMP's Euclidean method with exact "
        "distances, or the multisphere package), write it as 'x y z r' lines and print its exact mass properties against the mesh's "
        "own at the same density, with the error the summed spheres add. Reads MESH (STL, OBJ, PLY, OFF; "
        "m); writes OUT only."))
    p.add_argument("mesh", metavar="MESH", help="closed (watertight) triangle mesh, lengths in m")
    p.add_argument("--spheres", type=_positive_int, required=True, metavar="N", help="number of spheres wanted")
    p.add_argument("-o", "--output", metavar="OUT", help="sphere file to write (default: MESH's name + .spheres.txt)")
    p.add_argument("--force", action="store_true", help="replace OUT if it exists")
    p.add_argument("--scale", type=_positive_float, default=1.0, metavar="F",
                   help="multiply the mesh's lengths by F to get m, e.g. 0.001 for a mesh in mm (default: 1)")
    p.add_argument("--density", type=_positive_float, default=DEFAULT_DENSITY, help="kg/m^3 (default: 1000)")
    p.add_argument("--generator", choices=GENERATORS, default="euclidean",
                   help="euclidean: CLUMP's method with exact radii, spheres inside the mesh (default); "
                        "multisphere: the multisphere package (MSS), fills the volume faster as N grows")
    p.add_argument("--overlap", type=float, default=DEFAULT_OVERLAP,
                   help=f"euclidean only, in [0, 1): each sphere covers (1 - overlap) of its radius "
                        f"(default: {DEFAULT_OVERLAP})")
    p.add_argument("--divisions", type=_positive_int, default=DEFAULT_DIVISIONS,
                   help=f"voxels along the mesh's shortest bounding-box edge (default: {DEFAULT_DIVISIONS})")
    p.add_argument("--json", action="store_true", help="print the comparison as JSON")
    return p


def _output_path(args) -> str:
    out = args.output or os.path.splitext(args.mesh)[0] + ".spheres.txt"
    if os.path.exists(out) and os.path.samefile(out, args.mesh):
        raise FitError(f"{out} is the input mesh; choose another file with -o")
    return out


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of ``clumpprops fit``; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not 0.0 <= args.overlap < 1.0:
        parser.error(f"--overlap must be in [0, 1), got {args.overlap}")
    try:
        mesh = load_mesh(args.mesh, args.scale)
        out = _output_path(args)
        if args.generator == "multisphere":
            centers, radii = multisphere_spheres(mesh, args.spheres, args.divisions)
        else:
            centers, radii = fit_spheres(mesh, args.spheres, args.overlap, args.divisions)
        if len(radii) == 0:
            raise FitError(f"{args.mesh}: no sphere fits at --divisions {args.divisions}; raise it")
        result = compare(mesh, centers, radii, args.density)
        write_spheres(out, centers, radii, force=args.force)
    except FitError as exc:
        print(f"{PROG}: error: " + " ".join(str(exc).split()), file=sys.stderr)
        return 1
    if args.json:
        sys.stdout.write(json.dumps(dict(_public(result), mesh_file=args.mesh, output=out), indent=2) + "\n")
    else:
        sys.stdout.write(format_report(result, args.mesh, out))
    return 0
