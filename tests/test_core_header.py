"""clumpprops/core/clumpprops.hpp is usable on its own from C++ (as a DEM engine would include it):
a small program compiled with -Wall -Wextra -Werror computes a clump through clumpprops::Engine and
must print what the Python API gives."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import clumpprops as cp

HPP = Path(__file__).resolve().parent.parent / "clumpprops" / "core" / "clumpprops.hpp"
PROGRAM = r"""
#include "clumpprops.hpp"
#include <cstdio>
int main() {
  // three spheres with a triple overlap, and the paper's dimer
  const double c3[9] = {0.0, 0.0, 0.0, 0.7, 0.1, 0.0, 0.3, 0.6, 0.2};
  const double r3[3] = {0.5, 0.45, 0.4};
  const double d = 0.1333;
  const double c2[6] = {0.0, 0.0, -d / 4, 0.0, 0.0, d / 4};
  const double r2[2] = {d / 2, d / 2};
  clumpprops::Engine e;
  clumpprops::Result res;
  if (e.clump(clumpprops::kExact, c3, r3, 3, 1140.0, true, res) != clumpprops::kOk) return 1;
  std::printf("%.17g %.17g %.17g %.17g\n", res.mass, res.inertia[0], res.inertia[4], res.inertia[8]);
  if (e.clump(clumpprops::kPairwise, c2, r2, 2, 1140.0, true, res) != clumpprops::kOk) return 2;
  std::printf("%.17g %.17g %.17g %.17g\n", res.mass, res.moments[0], res.moments[1], res.moments[2]);
  return 0;
}
"""


@pytest.mark.skipif(shutil.which("g++") is None, reason="no C++ compiler")
def test_header_compiles_standalone_and_agrees_with_python(tmp_path):
    src = tmp_path / "use_core.cpp"
    src.write_text(PROGRAM)
    exe = tmp_path / "use_core"
    subprocess.run(["g++", "-std=c++17", "-O1", "-Wall", "-Wextra", "-Werror", f"-I{HPP.parent}", str(src), "-o", str(exe)],
                   check=True, capture_output=True, text=True)
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split("\n")
    a = np.array(out[0].split(), float)
    mp = cp.mass_properties([[0.0, 0.0, 0.0], [0.7, 0.1, 0.0], [0.3, 0.6, 0.2]], [0.5, 0.45, 0.4], 1140.0)
    np.testing.assert_allclose(a, [mp.mass, *np.diag(mp.inertia)], rtol=1e-15)
    b = np.array(out[1].split(), float)
    d = 0.1333
    dim = cp.mass_properties([[0, 0, -d / 4], [0, 0, d / 4]], [d / 2, d / 2], 1140.0, method="pairwise")
    np.testing.assert_allclose(b, [dim.mass, *dim.principal_moments], rtol=1e-15)
    assert abs(b[0] - 2.385820156555343) < 1e-12  # the README's number
