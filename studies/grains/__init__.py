"""Grain templates of the gas studies: textClumps files of many-sphere clumps.

``python -m studies.grains`` writes, beside each template ``NAME.txt``, ``NAME.json``: the
clump in its body frame (members centred on the exact centre of mass, principal axes along x, y,
z) with its exact (union of the spheres) and summed (YADE's ``appendClumped``) mass properties
at the study density, and their relative errors.  The files are the record a reader checks a
grain against; the studies compute the same values from the ``.txt`` (``studies.shapes``).
"""
import json
import os

import numpy as np

from studies import shapes

HERE = os.path.dirname(os.path.abspath(__file__))
DENSITY = 1140.0       # kg/m^3, the paper's material


def templates():
    """Names of the grain templates (``*.txt`` in this folder)."""
    return sorted(f[:-4] for f in os.listdir(HERE) if f.endswith(".txt"))


def describe(name, density=DENSITY):
    """The record of one template: shape dict, members, radii, exact and summed properties, errors."""
    shape = {"kind": "file", "path": os.path.join("studies", "grains", name + ".txt")}
    p = shapes.properties(shape, density)
    ex, sm = p["exact"], p["sum"]
    k2_ex = np.asarray(ex["principal_moments"]) / ex["mass"]
    k2_sm = np.diag(np.asarray(sm["inertia"])) / sm["mass"]     # the summed tensor in the exact body frame
    return dict(p, name=name, density=density, n_spheres=len(p["radii"]),
                mass_error=sm["mass"] / ex["mass"] - 1.0,
                k2_error=(k2_sm / k2_ex - 1.0).tolist())


def main():
    for name in templates():
        out = os.path.join(HERE, name + ".json")
        with open(out, "w") as f:
            json.dump(describe(name), f, indent=1)
            f.write("\n")
        print("wrote", os.path.relpath(out))


if __name__ == "__main__":
    main()
