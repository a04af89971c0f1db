"""What LIGGGHTS and LAMMPS compute for a clump without clumpprops, against the exact values.

    .venv/bin/python tests/engine_errors.py

(as a script: Python puts tests/ on sys.path, whose engine helpers ``_engines`` it shares with the
engine tests; clumpprops is the installed package, the repository's own in the editable install
``make setup`` makes.)

Clumps: the paper's dimer (d = 0.1333 m, D = d/2, rho = 1140 kg/m^3) and a 10-sphere
clump with heavy (also triple) overlaps (seed 3, below).  Runs Debian's liggghts 3.8.0
(``particletemplate/multisphere`` without ``mass``/``inertia_tensor``: its Monte Carlo over
ntry points, values from its log, 7 digits) and lmp (``fix rigid/small`` without infile:
summed spheres, values from ``compute rigid/local``).  Prints relative errors and writes
results/engines/engine_errors.json.
"""
from __future__ import annotations

import json
import re
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from _engines import LAMMPS, LIGGGHTS, LIGGGHTS_BOX, quat_to_matrix, read_dump

from clumpprops import mass_properties
from clumpprops.io import Clump, export

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "results" / "engines" / "engine_errors.json"

RHO = 1140.0
D = 0.1333


def ten_sphere_clump(seed=3):
    rng = np.random.default_rng(seed)
    return Clump(rng.uniform(-0.05, 0.05, (10, 3)), rng.uniform(0.025, 0.045, 10), name="ten")


DIMER = Clump(np.array([[0, 0, -D / 4], [0, 0, D / 4]]), np.array([D / 2, D / 2]), name="dimer")

LIG = LIGGGHTS_BOX + """fix m1 all property/global youngsModulus peratomtype 1.e7
fix m2 all property/global poissonsRatio peratomtype 0.4
fix m3 all property/global coefficientRestitution peratomtypepair 1 0.9
fix m4 all property/global coefficientFriction peratomtypepair 1 0.0
pair_style gran model hertz tangential history
pair_coeff * *
fix pts1 all particletemplate/multisphere {seed} atom_type 1 density constant 1140 nspheres {n} ntry {ntry} spheres file {file} scale 1 type 1
"""


def liggghts_mc(clump, ntry, seed, work):
    export([clump], "liggghts", work, density=RHO, force=True)   # once per seed: the same files again
    (work / "in.mc").write_text(LIG.format(seed=seed, n=clump.n_spheres, ntry=ntry, file=f"{clump.name}_spheres.multisphere"))
    subprocess.run([LIGGGHTS, "-in", "in.mc", "-log", "log.mc"], cwd=work, capture_output=True, check=True, timeout=600)
    log = (work / "log.mc").read_text()
    mass = float(re.search(r"mass = ([^,]+),", log).group(1))
    I = np.array([list(map(float, m.group(1).split(","))) for m in re.finditer(r"Inertia tensor: (.*)", log)][-3:])
    return mass, I


def lammps_sum(clump, work):
    export([clump], "lammps", work, density=RHO)
    (work / "in.sum").write_text(f"""units si
atom_style hybrid sphere molecular
boundary f f f
read_data {clump.name}.data
pair_style zero 0.5
pair_coeff * *
neighbor 0.01 bin
neigh_modify exclude molecule/intra all
thermo_style custom step
fix r all rigid/small molecule
compute rl all rigid/local r mass x y z inertiax inertiay inertiaz quatw quati quatj quatk
dump d all local 1 rl.dump c_rl[*]
dump_modify d format float %.17g
run 0
""")
    subprocess.run([LAMMPS, "-in", "in.sum", "-log", "none"], cwd=work, capture_output=True, check=True, timeout=120)
    a = read_dump(work / "rl.dump")[0][1][0]
    Q = quat_to_matrix(a[7:11])
    return a[0], Q @ np.diag(a[4:7]) @ Q.T


def errors(mass, I, exact):
    mom = np.linalg.eigvalsh(I)
    return {
        "mass": mass / exact.mass - 1,
        "principal_moments": (mom / exact.principal_moments - 1).tolist(),
        "tensor_max_over_I3": float(np.max(np.abs(I - exact.inertia)) / exact.principal_moments[-1]),
    }


def main():
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for clump in (DIMER, ten_sphere_clump()):
            ex = mass_properties(clump.centers, clump.radii, density=RHO)
            sm = mass_properties(clump.centers, clump.radii, density=RHO, method="sum")
            res = {"exact": {"mass": ex.mass, "principal_moments": ex.principal_moments.tolist()}}
            work = Path(tmp) / clump.name
            work.mkdir()
            m, I = lammps_sum(clump, work)
            res["LAMMPS fix rigid/small (sum)"] = errors(m, I, ex)
            res["clumpprops sum"] = errors(sm.mass, sm.inertia, ex)
            for ntry in (100000, 1000000):
                runs = [errors(*liggghts_mc(clump, ntry, seed, work), ex) for seed in (15485863, 86028121, 32452843)]
                res[f"LIGGGHTS Monte Carlo ntry={ntry} (3 seeds)"] = runs
            out[clump.name] = res
    for name, res in out.items():
        print(f"== {name}: exact mass {res['exact']['mass']:.6f} kg, principal moments "
              + " ".join(f"{x:.6e}" for x in res["exact"]["principal_moments"]))
        for k, v in res.items():
            if k == "exact":
                continue
            for e in (v if isinstance(v, list) else [v]):
                print(f"  {k:45s} mass {100 * e['mass']:+8.3f} %  moments "
                      + " ".join(f"{100 * x:+8.3f} %" for x in e["principal_moments"])
                      + f"  tensor {100 * e['tensor_max_over_I3']:.3f} % of I3")
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
