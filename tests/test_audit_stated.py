"""clumpprops.io.stated and the audit's diagnosis of the values files state: small files written
here in each engine's layout, with the overlap error, a wrong reference point or a non-principal
frame put in on purpose."""
from __future__ import annotations

import json

import numpy as np
import pytest

from clumpprops import io as cio
from clumpprops.audit import diagnose, methods
from clumpprops.audit.cli import main
from clumpprops.io.stated import read_rigid_infile, read_stated

CENTERS = np.array([[0.0, 0.0, 0.0], [0.9, 0.1, 0.0], [0.3, 0.8, 0.2]])
RADII = np.array([0.6, 0.45, 0.5])
RHO = 1000.0


def _r(x):
    """A number as the files write it (a Python float's repr, also for numpy 2's scalars)."""
    return repr(float(x))


def _props(centers):
    return methods.exact(centers, RADII, RHO), methods.summed(centers, RADII, RHO)


def _findings(stated, centers):
    ex, su = _props(centers)
    return diagnose(stated, ex, su)


def _tensor6(I):
    return [I[0, 0], I[0, 1], I[0, 2], I[1, 1], I[1, 2], I[2, 2]]


def test_liggghts_summed_mass_is_an_overlap_error(tmp_path):
    ex, su = _props(CENTERS)
    rel = CENTERS - ex.com  # the sphere file about the centre of mass, as LIGGGHTS assumes
    (tmp_path / "tri.multisphere").write_text("\n".join(" ".join(map(_r, [*c, r])) for c, r in zip(rel, RADII)) + "\n")
    script = (f"fix pts all particletemplate/multisphere 15485863 atom_type 1 density constant {RHO} nspheres 3 &\n"
              f"  ntry 1000000 spheres file tri.multisphere scale 1.0 type 1 mass {_r(su.mass)} &\n"
              "  inertia_tensor " + " ".join(map(_r, _tensor6(ex.extra["inertia"]))) + " use_density\n")
    (tmp_path / "in.tri").write_text("# a deck\n" + script)
    (st,) = read_stated(tmp_path / "in.tri")
    assert st.mass == su.mass and np.allclose(st.clump.centers, rel)
    d = _findings(st, rel)
    assert d["mass_error"] == pytest.approx(su.mass / ex.mass - 1.0)
    assert any(f.startswith("overlap error: the mass") for f in d["findings"])
    assert not any("reference point" in f for f in d["findings"])
    assert np.allclose(d["moment_errors"], 0.0, atol=1e-12)


def test_liggghts_inline_spheres_with_the_summed_tensor(tmp_path):
    ex, su = _props(CENTERS)
    rel = CENTERS - su.com
    _, su_rel = _props(rel)
    spheres = " ".join(" ".join(map(_r, [*c, r])) for c, r in zip(rel, RADII))
    (tmp_path / "in.inline").write_text(
        f"fix t all particletemplate/multisphere 1 atom_type 1 density constant {RHO} nspheres 3 ntry 100000 "
        f"spheres {spheres} type 1 mass {_r(su.mass)} inertia_tensor " + " ".join(map(_r, _tensor6(su_rel.extra["inertia"])))
        + " use_density\n")
    (st,) = read_stated(tmp_path / "in.inline")
    d = _findings(st, rel)
    assert "overlap error: the tensor is the summed spheres'" in d["findings"]
    assert any("reference point" in f for f in d["findings"])  # the summed centre of mass is not the union's


def test_lammps_molecule_inertia_about_the_origin(tmp_path):
    ex, _ = _props(CENTERS)
    d = ex.com
    I0 = ex.extra["inertia"] + ex.mass * (d @ d * np.eye(3) - np.outer(d, d))  # about the file origin
    xx, yy, zz, yz, xz, xy = I0[0, 0], I0[1, 1], I0[2, 2], I0[1, 2], I0[0, 2], I0[0, 1]
    lines = ["clump molecule", "", "3 atoms", f"{_r(ex.mass)} mass", "0 0 0 com",
             " ".join(map(_r, [xx, yy, zz, yz, xz, xy])) + " inertia", "", "Coords", ""]
    lines += [f"{i + 1} " + " ".join(map(_r, c)) for i, c in enumerate(CENTERS)]
    lines += ["", "Types", ""] + [f"{i + 1} 1" for i in range(3)]
    lines += ["", "Diameters", ""] + [f"{i + 1} {_r(2 * r)}" for i, r in enumerate(RADII)]
    f = tmp_path / "tri.mol"
    f.write_text("\n".join(lines) + "\n")
    (st,) = read_stated(f)
    assert st.engine == "LAMMPS molecule" and st.mass == ex.mass
    res = _findings(st, CENTERS)
    assert any(x.startswith("wrong reference point") for x in res["findings"])
    assert any("the exact one about [0.0, 0.0, 0.0]" in x for x in res["findings"])
    assert max(abs(e) for e in res["moment_errors"]) > 0.05


def test_deme_moi_in_a_frame_that_is_not_principal(tmp_path):
    ex, _ = _props(CENTERS)
    rel = CENTERS - ex.com
    item = {"name": "tri", "mass": ex.mass, "moi": np.diag(ex.extra["inertia"]).tolist(), "radii": RADII.tolist(),
            "relPos": rel.tolist()}
    f = tmp_path / "tri_deme.json"
    f.write_text(json.dumps({"clumps": [item]}))
    (st,) = read_stated(f)
    assert st.diagonal_only
    res = _findings(st, rel)
    assert any(x.startswith("frame not principal") for x in res["findings"])
    assert not any("reference point" in x or "overlap" in x for x in res["findings"])


@pytest.mark.parametrize("engine", ["deme", "mclump"])
def test_files_clumpprops_writes_agree_with_the_exact_values(tmp_path, engine):
    clump = cio.Clump(CENTERS, RADII, name="tri")
    paths = cio.export([clump], engine, tmp_path, density=RHO)
    target = next(p for p in paths if p.suffix == ".json") if engine == "deme" else tmp_path / "tri"
    (st,) = read_stated(target)
    res = _findings(st, st.clump.centers)
    assert res["findings"] == ["agrees with the exact values"], res


def test_rigid_infile_with_summed_values_through_the_cli(tmp_path, capsys):
    _, su = _props(CENTERS)
    I = su.extra["inertia"]
    (tmp_path / "bodies.inf").write_text("# fix rigid infile\n1\n1 " + " ".join(map(_r, [
        su.mass, *su.com, I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])) + " 0 0 0 0 0 0 0 0 0\n")
    (body,) = read_rigid_infile(tmp_path / "bodies.inf")
    assert body.clump is None and np.allclose(body.reference, su.com)
    csv = tmp_path / "tri.csv"
    csv.write_text("x,y,z,r\n" + "\n".join(",".join(map(_r, [*c, r])) for c, r in zip(CENTERS, RADII)) + "\n")
    assert main([str(csv), "--stated", str(tmp_path / "bodies.inf"), "--ntry", "20000", "--seed", "2",
                 "--tolerance", "0.05"]) == 0
    out = capsys.readouterr().out
    assert "stated: LAMMPS fix rigid infile (body 1)" in out
    assert "overlap error: the mass is the summed spheres'" in out


def test_the_audit_takes_the_density_a_liggghts_script_states(tmp_path, capsys):
    rho = 2500.0
    ex = methods.exact(CENTERS, RADII, rho)
    rel = CENTERS - ex.com
    spheres = " ".join(" ".join(map(_r, [*c, r])) for c, r in zip(rel, RADII))
    (tmp_path / "in.rho").write_text(
        f"fix t all particletemplate/multisphere 1 atom_type 1 density constant {rho} nspheres 3 ntry 100000 "
        f"spheres {spheres} type 1 mass {_r(ex.mass)} inertia_tensor " + " ".join(map(_r, _tensor6(ex.extra["inertia"])))
        + " use_density\n")
    assert main([str(tmp_path / "in.rho"), "--ntry", "20000", "--seed", "1", "--tolerance", "0.05"]) == 0
    out = capsys.readouterr().out
    assert "density 2500 kg/m^3" in out and "agrees with the exact values" in out
    assert main([str(tmp_path / "in.rho"), "--density", "1000", "--ntry", "20000", "--seed", "1", "--tolerance", "0.05"]) == 0
    assert "agrees with the exact values" not in capsys.readouterr().out


def test_a_template_that_states_nothing_is_said_so_and_not_misdiagnosed(tmp_path, capsys):
    """A LIGGGHTS template without mass/inertia_tensor leaves them to LIGGGHTS' Monte Carlo: no
    error columns, no reference-point finding, and the audit shows the exact shape descriptors."""
    from clumpprops.cli import main
    (tmp_path / "s.multisphere").write_text("0 0 0 1\n1.2 0 0 0.8\n0.3 0.9 0 0.7\n")
    (tmp_path / "in.s").write_text("fix pts1 all particletemplate/multisphere 15485863 atom_type 1 density constant "
                                   "2500 nspheres 3 ntry 100000 spheres file s.multisphere scale 1 type 1\n")
    assert main(["audit", str(tmp_path / "in.s"), "--seed", "1", "--tolerance", "0.05"]) == 0
    out = capsys.readouterr().out
    stated = next(l for l in out.splitlines() if l.startswith("stated:"))
    assert stated.split()[-4:] == ["-", "-", "-", "-"]
    assert "states no mass or inertia" in out and "wrong reference point" not in out
    shape_line = next(l for l in out.splitlines() if l.startswith("# shape:"))
    assert "surface area" in shape_line and "sphericity" in shape_line


@pytest.mark.parametrize("order,swapped", [("voigt", False), ("documented", True)])
def test_a_molecule_header_about_the_origin_is_named_with_its_order(tmp_path, order, swapped):
    """A LAMMPS molecule header whose inertia is the tensor about the file's origin (LAMMPS'
    examples/rigid/molecule.data is one), perturbed by 0.3 % as a sampled estimate would be, in
    LAMMPS' reading order (Voigt: xx yy zz yz xz xy) or in the documented one (xx yy zz xy xz yz)."""
    shifted = CENTERS + np.array([5.0, 4.0, 3.0])
    ex, _ = _props(shifted)
    d = ex.com
    I0 = ex.extra["inertia"] + ex.mass * (d @ d * np.eye(3) - np.outer(d, d))
    I0 = I0 * (1.0 + 0.003 * np.array([[1, -1, 1], [-1, 1, 1], [1, 1, -1]]))
    six = ([I0[0, 0], I0[1, 1], I0[2, 2], I0[1, 2], I0[0, 2], I0[0, 1]] if order == "voigt"
           else [I0[0, 0], I0[1, 1], I0[2, 2], I0[0, 1], I0[0, 2], I0[1, 2]])
    rows = "\n".join(f"{i + 1} {_r(c[0])} {_r(c[1])} {_r(c[2])}" for i, c in enumerate(shifted))
    dia = "\n".join(f"{i + 1} {_r(2 * r)}" for i, r in enumerate(RADII))
    (tmp_path / "m.data").write_text(f"made elsewhere\n\n3 atoms\n\n{_r(ex.mass)} mass\n\n" + " ".join(map(_r, d))
                                     + " com\n\n" + " ".join(map(_r, six)) + " inertia\n\nCoords\n\n" + rows
                                     + "\n\nDiameters\n\n" + dia + "\n")
    (st,) = read_stated(tmp_path / "m.data")
    found = [f for f in _findings(st, shifted)["findings"] if f.startswith("the tensor is")]
    assert len(found) == 1 and "about the file's origin" in found[0]
    assert ("swapped" in found[0]) == swapped
