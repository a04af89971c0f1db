"""Shared helpers for the engine checks: run LIGGGHTS / LAMMPS, read their dumps, predict free rotation.

The rigid-body prediction is independent of the engines and of the principal-axis
decomposition: R(t) from dR/dt = [w]x R with w = (R I0 R^T)^-1 L, L constant (space frame),
integrated by scipy's solve_ivp (DOP853, rtol 1e-12).
"""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

LIGGGHTS = shutil.which("liggghts") or "/usr/bin/liggghts"
LAMMPS = shutil.which("lmp") or "/usr/bin/lmp"

# two clumps used by the checks (SI): overlapping and asymmetric (4 spheres, no symmetry),
# and non-overlapping (3 spheres apart, rigidly linked)
ASYM_C = np.array([[0.0, 0.0, 0.0], [0.08, 0.01, 0.0], [0.03, 0.07, 0.02], [0.01, 0.02, 0.09]])
ASYM_R = np.array([0.05, 0.04, 0.045, 0.035])
APART_C = np.array([[0.0, 0.0, 0.0], [0.12, 0.02, 0.0], [0.03, 0.11, 0.05]])
APART_R = np.array([0.05, 0.04, 0.03])
RHO = 1140.0


def run(exe, infile: Path, cwd: Path, timeout=120):
    proc = subprocess.run([exe, "-in", infile.name, "-log", "log.out"], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, stdin=subprocess.DEVNULL)
    if proc.returncode != 0 or "ERROR" in proc.stdout:
        tail = "\n".join((proc.stdout + proc.stderr).splitlines()[-15:])
        raise AssertionError(f"{exe} failed (status {proc.returncode}):\n{tail}")
    return proc.stdout


def thermo_rows(text: str, first: str = "Step"):
    """Numeric thermo rows after each header line starting with ``first`` (up to ``Loop time``):
    list of (header, rows); other lines in between (INFO messages) are skipped."""
    out, head = [], None
    for line in text.splitlines():
        w = line.split()
        if w and w[0] == first:
            head = w
            out.append((head, []))
        elif line.startswith("Loop time"):
            head = None
        elif head and len(w) == len(head):
            try:
                out[-1][1].append([float(x) for x in w])
            except ValueError:
                pass
    return out


def read_dump(path: Path):
    """Frames of a LAMMPS/LIGGGHTS text dump: {timestep: (columns, array)}."""
    frames, lines, i = {}, Path(path).read_text().splitlines(), 0
    while i < len(lines):
        if lines[i].startswith("ITEM: TIMESTEP"):
            step = int(lines[i + 1])
            n = int(lines[i + 3])
            j = i + 4
            while not lines[j].startswith("ITEM: ATOMS") and not lines[j].startswith("ITEM: ENTRIES"):
                j += 1
            cols = lines[j].split()[2:]
            data = np.array([[float(x) for x in lines[j + 1 + k].split()] for k in range(n)]).reshape(n, len(cols))
            frames[step] = (cols, data)
            i = j + 1 + n
        else:
            i += 1
    return frames


def quat_to_matrix(q):
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def rotation_after(I0, L, t, rtol=1e-12, atol=1e-14):
    """R(t) of a free rigid body with inertia tensor I0 (space frame at t=0, R(0) = 1), angular momentum L."""
    I0 = np.asarray(I0, float)
    L = np.asarray(L, float)

    def rhs(_, y):
        R = y.reshape(3, 3)
        w = np.linalg.solve(R @ I0 @ R.T, L)
        W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        return (W @ R).ravel()

    sol = solve_ivp(rhs, (0.0, t), np.eye(3).ravel(), method="DOP853", rtol=rtol, atol=atol)
    assert sol.success
    return sol.y[:, -1].reshape(3, 3)


# the first lines of every LIGGGHTS deck the tests write: a 2 m box of SI units, one atom type
LIGGGHTS_BOX = """atom_style sphere
atom_modify map array sort 0 0
boundary f f f
newton off
communicate single vel yes
processors 1 1 1
units si
region reg block -1 1 -1 1 -1 1 units box
create_box 1 reg
"""
