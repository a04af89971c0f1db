"""Clumps built inside the ``yade`` executable (``yade -n -x script.py``), not only after ``import yade``.

``yade`` runs Debian's /usr/bin/python3 without the project venv and without the script's folder
on sys.path, so a script must put the repository root on sys.path itself (as
examples/yade_paper_dimer.py does); or be run as ``.venv/bin/python /usr/bin/yade -n -x script.py`` (here: the venv running pytest).
"""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
YADE = shutil.which("yade")
assert YADE is not None, "the yade executable is missing: run scripts/setup.sh"

SCRIPT = r'''
import os, sys, json
sys.path.insert(0, {root!r})
import numpy as np
import clumpprops
from clumpprops import yade as cy
cy.install_guards()
from yade import utils
from yade.wrapper import FrictMat
O.materials.append(FrictMat(density=2650, label="m"))
rng = np.random.default_rng(3)
res = []
for n in (2, 5, 12):
    c = [np.zeros(3)]; r = [0.05]
    while len(c) < n:
        k = rng.integers(len(c)); u = rng.normal(size=3); u /= np.linalg.norm(u); rn = rng.uniform(0.02, 0.05)
        c.append(c[k] + u * (r[k] + rn) * 0.6); r.append(rn)
    cid, mids = cy.append_clump([utils.sphere(tuple(x), rr, material="m") for x, rr in zip(c, r)])
    res.append(cid)
O.save({save!r}); O.reset(); O.load({save!r})
O.bodies.updateClumpProperties(discretization=0)
out = {{"errors": [max(cy.clump_errors(cid).values()) for cid in res], "python": sys.executable,
        "clumpprops": clumpprops.__file__}}
print("RESULT " + json.dumps(out))
'''


def _run(cmd, script, tmp_path):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    p = subprocess.run(cmd + [str(script)], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    return p.stdout


@pytest.mark.parametrize("launcher", ["yade", "venv-python-yade"])
def test_clumps_in_yade_executable(tmp_path, launcher):
    script = tmp_path / "build.py"
    script.write_text(SCRIPT.format(root=str(ROOT), save=str(tmp_path / "s.yade.gz")))
    # the venv running the tests (.venv, or .venv-debian13 inside the Debian 13 root)
    cmd = [YADE, "-n", "-x"] if launcher == "yade" else [sys.executable, YADE, "-n", "-x"]
    out = _run(cmd, script, tmp_path)
    line = [l for l in out.splitlines() if l.startswith("RESULT ")][-1]
    res = json.loads(line[len("RESULT "):])
    assert max(res["errors"]) < 1e-12, res
    assert res["clumpprops"].startswith(str(ROOT))


def test_readme_example_runs_in_yade(tmp_path):
    out = _run([YADE, "-n", "-x"], ROOT / "examples" / "yade_paper_dimer.py", tmp_path)
    assert "YADE appendClumped" in out and "error:+18.5%" in out
    assert "append_clump vs library" in out


def test_readme_example_runs_with_plain_python(tmp_path):
    out = _run([sys.executable], ROOT / "examples" / "yade_paper_dimer.py", tmp_path)
    assert "append_clump vs library" in out
