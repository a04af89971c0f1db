"""The runnable decks (``clumpprops export FILE --to liggghts|lammps --deck``) run inside Debian's
LIGGGHTS 3.8.0 and LAMMPS on one free, spinning, asymmetric clump (4 overlapping unequal spheres,
the file's axes not principal).

* mass and inertia tensor as the engine reports them: the translational kinetic energy of a
  body sent off at ``--velocity`` gives m; the rotational energy w.I.w/2 at six ``--spin``
  values gives the tensor (thermo, 17 digits); both equal the exact values to 1e-10;
* the angular momentum L = R I_body R^T w, with R and w read from the member positions and
  velocities the deck dumps at the first and last step, is the same at both ends to 1e-8
  with the exact tensor, and visibly not with the summed-sphere tensor.
"""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from clumpprops import mass_properties
from clumpprops.io import Clump, export

from _engines import ASYM_C, ASYM_R, LAMMPS, LIGGGHTS, LIGGGHTS_BOX, RHO, read_dump, run, thermo_rows

SPINS = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, 0, 1), (0, 1, 1)]
ENGINES = {"liggghts": LIGGGHTS, "lammps": LAMMPS}


def export_deck(tmp_path, engine, *options):
    """``clumpprops export asym.csv --to ENGINE --deck OPTIONS`` into tmp_path/out; the deck's path."""
    src = tmp_path / "asym.csv"
    src.write_text("".join(f"{x!r},{y!r},{z!r},{r!r}\n" for (x, y, z), r in zip(ASYM_C.tolist(), ASYM_R.tolist())))
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "clumpprops", "export", str(src), "--to", engine, "--out", str(out),
                        "--density", repr(RHO), "--deck", "--force", *map(str, options)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return out / f"asym_deck_{engine}.in"


def energies(engine, deck):
    """(ke, erotate) of the first thermo row with the body in it."""
    head, rows = [(h, [row for row in rs if row[1] > 0]) for h, rs in thermo_rows(run(ENGINES[engine], deck, deck.parent))
                  if any(row[1] > 0 for row in rs)][0]
    col = {name.removeprefix("c_"): k for k, name in enumerate(head)}  # LIGGGHTS prints ke, LAMMPS c_ke
    return rows[0][col["ke"]], rows[0][col["er"]]


def first_and_last(engine, out):
    """Member positions and velocities (id order) at the first and the last dumped step."""
    if engine == "liggghts":
        frames = [read_dump(out / f"asym_liggghts_{w}.dump") for w in ("start", "end")]
        (a, fa), (b, fb) = [next(iter(f.items())) for f in frames]
    else:
        f = read_dump(out / "asym_lammps.dump")
        (a, fa), (b, fb) = min(f.items()), max(f.items())
    cols = fa[0]
    pick = [cols.index(c) for c in ("x", "y", "z", "vx", "vy", "vz")]
    return b - a, fa[1][:, pick], fb[1][:, pick]


def rotation_and_spin(rows, body):
    """R (body -> space, Kabsch on the member positions) and w (least squares on v = v_c + w x d)."""
    x, v = rows[:, :3], rows[:, 3:]
    d, f = x - x.mean(0), body - body.mean(0)
    U, _, Vt = np.linalg.svd(f.T @ d)
    R = (U @ Vt).T
    assert np.linalg.det(R) > 0 and np.max(np.abs(d - f @ R.T)) < 1e-9, "not a rigid placement of the clump"
    cross = np.concatenate([np.array([[0, dz, -dy], [-dz, 0, dx], [dy, -dx, 0]]) for dx, dy, dz in d])
    w = np.linalg.lstsq(cross, (v - v.mean(0)).ravel(), rcond=None)[0]
    return R, w


def angular_momentum_drift(I_body, start, end, body):
    Ls = []
    for rows in (start, end):
        R, w = rotation_and_spin(rows, body)
        Ls.append(R @ I_body @ R.T @ w)
    return float(np.linalg.norm(Ls[1] - Ls[0]) / np.linalg.norm(Ls[0]))


def _rel(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b)))


@pytest.mark.parametrize("engine", sorted(ENGINES))
def test_the_deck_reports_the_exact_mass_and_inertia_tensor(tmp_path, engine):
    exact = mass_properties(ASYM_C, ASYM_R, density=RHO)
    v = np.array([0.1, -0.05, 0.02])
    ke, _ = energies(engine, export_deck(tmp_path, engine, "--velocity", *v, "--steps", 2))
    mass = 2 * ke / (v @ v)
    E = [2 * energies(engine, export_deck(tmp_path, engine, "--spin", *w, "--steps", 2))[1] for w in SPINS]
    I = np.diag(E[:3])
    I[0, 1] = I[1, 0] = (E[3] - E[0] - E[1]) / 2
    I[0, 2] = I[2, 0] = (E[4] - E[0] - E[2]) / 2
    I[1, 2] = I[2, 1] = (E[5] - E[1] - E[2]) / 2
    print(f"{engine} deck: mass rel. error {abs(mass / exact.mass - 1):.1e}, tensor {_rel(I, exact.inertia):.1e}")
    assert abs(mass / exact.mass - 1) < 1e-10
    assert _rel(I, exact.inertia) < 1e-10
    assert abs(np.trace(exact.inertia) / np.trace(I) - 1) < 1e-10 and abs(I[0, 1]) > 1e-3 * I[0, 0]  # not principal


@pytest.mark.parametrize("engine", sorted(ENGINES))
def test_a_free_spin_in_the_deck_keeps_its_angular_momentum_with_the_exact_tensor(tmp_path, engine):
    exact = mass_properties(ASYM_C, ASYM_R, density=RHO)
    summed = mass_properties(ASYM_C, ASYM_R, density=RHO, method="sum")
    deck = export_deck(tmp_path, engine, "--velocity", 0.1, -0.05, 0.02, "--spin", 2.0, -1.0, 3.0, "--steps", 2000)
    run(ENGINES[engine], deck, deck.parent, timeout=300)
    steps, start, end = first_and_last(engine, deck.parent)
    assert steps >= 1999
    body = ASYM_C - exact.center_of_mass  # the file's axes: R(first step) is the identity
    assert np.max(np.abs(rotation_and_spin(start, body)[0] - np.eye(3))) < 1e-9
    assert np.max(np.abs(rotation_and_spin(start, body)[1] - [2.0, -1.0, 3.0])) < 1e-9
    drift = angular_momentum_drift(exact.inertia, start, end, body)
    drift_sum = angular_momentum_drift(summed.inertia, start, end, ASYM_C - summed.center_of_mass)
    print(f"{engine} deck, {steps} steps: angular momentum drift {drift:.1e} with the exact tensor, "
          f"{drift_sum:.1e} with the summed one")
    assert drift < 1e-8
    assert drift_sum > 1e-4


def test_liggghts_reads_the_exported_templates_under_screen_none(tmp_path):
    """LIGGGHTS 3.8.0 crashes on a '#' line in a sphere file when run with -screen none; the
    exported sphere file has none (and the same file with one comment line does crash)."""
    export([Clump(ASYM_C, ASYM_R, name="asym")], "liggghts", tmp_path, density=RHO)
    deck = tmp_path / "in.templates"
    deck.write_text(LIGGGHTS_BOX + "neighbor 0.01 bin\n"
                    "fix m1 all property/global youngsModulus peratomtype 1.e7\n"
                    "fix m2 all property/global poissonsRatio peratomtype 0.4\n"
                    "fix m3 all property/global coefficientRestitution peratomtypepair 1 0.9\n"
                    "fix m4 all property/global coefficientFriction peratomtypepair 1 0.0\n"
                    "pair_style gran model hertz tangential history\npair_coeff * *\ntimestep 1e-5\n"
                    "include asym_liggghts.in\nrun 0\n")

    def status():
        return subprocess.run([LIGGGHTS, "-in", deck.name, "-log", "log.out", "-screen", "none"], cwd=tmp_path,
                              capture_output=True, timeout=120, stdin=subprocess.DEVNULL).returncode

    assert status() == 0 and "Loop time" in (tmp_path / "log.out").read_text()
    spheres = tmp_path / "asym_spheres.multisphere"
    spheres.write_text("# x y z r\n" + spheres.read_text())
    assert status() != 0
