"""The predictor tests' tiny spec and table reader."""
import csv
import os
import re

from studies.timestep import collisions as tc

TEST_SPEC = os.path.join(tc.ROOT, "studies", "specs", "test.toml")


def dimer025_spec(tmp_path, material_extra=""):
    """The test spec with its dimer at D/d_s = 0.25 (a shape with a committed collision map and gas
    interval), written to ``tmp_path``."""
    with open(TEST_SPEC) as f:
        text = f.read()
    text = re.sub(r"^overlap = 0\.5 ", "overlap = 0.25", text, flags=re.M)
    text = text.replace("[shapes.dimer]", "[shapes.dimer025]").replace('shape = "dimer"', 'shape = "dimer025"')
    text = text.replace("poisson = 0.40\n", "poisson = 0.40\n" + material_extra, 1)
    path = tmp_path / "tiny.toml"
    path.write_text(text)
    return str(path)


def read_table(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], [dict(zip(rows[0], r)) for r in rows[1:]]
