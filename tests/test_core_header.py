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
import clumpprops.core  # noqa: F401  (cp.core)

# the header as the package ships it (beside the compiled core): the tree's in a checkout, the
# installed one when the tests run against a wheel
HPP = Path(cp.core.__file__).resolve().parent / "clumpprops.hpp"
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


def _compile(tmp_path, name, program, opt):
    """Build a standalone C++17 program that includes only the header (warnings are errors)."""
    src = tmp_path / f"{name}.cpp"
    src.write_text(program)
    exe = tmp_path / name
    subprocess.run(["g++", "-std=c++17", opt, "-Wall", "-Wextra", "-Werror", f"-I{HPP.parent}", str(src), "-o", str(exe)],
                   check=True, capture_output=True, text=True)
    return exe


@pytest.mark.skipif(shutil.which("g++") is None, reason="no C++ compiler")
def test_header_compiles_standalone_and_agrees_with_python(tmp_path):
    exe = _compile(tmp_path, "use_core", PROGRAM, "-O1")
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split("\n")
    a = np.array(out[0].split(), float)
    mp = cp.mass_properties([[0.0, 0.0, 0.0], [0.7, 0.1, 0.0], [0.3, 0.6, 0.2]], [0.5, 0.45, 0.4], 1140.0)
    np.testing.assert_allclose(a, [mp.mass, *np.diag(mp.inertia)], rtol=1e-15)
    b = np.array(out[1].split(), float)
    d = 0.1333
    dim = cp.mass_properties([[0, 0, -d / 4], [0, 0, d / 4]], [d / 2, d / 2], 1140.0, method="pairwise")
    np.testing.assert_allclose(b, [dim.mass, *dim.principal_moments], rtol=1e-15)
    assert abs(b[0] - 2.385820156555343) < 1e-12  # the README's number


PAIRS_PROGRAM = r"""
#include "clumpprops.hpp"
#include <cmath>
#include <cstdio>
#include <random>
// The pair search of large clumps (uniform grid, or sort and sweep where radii are uneven) against
// the plain loops over all pairs: the same pairs, bit for bit, in the same order when the grid ran.
int main() {
  std::mt19937_64 g(7);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  clumpprops::PairSearch ps;
  std::vector<clumpprops::Pair> a, b;
  long grid = 0, sweep = 0;
  for (int t = 0; t < 1500; ++t) {
    const int n = 41 + static_cast<int>(g() % 300);
    const int mode = t % 6;
    // magnitudes where squared distances stay normal numbers: below, the plain loops' test
    // fl(sqrt(dx^2 + dy^2 + dz^2)) < r_a + r_b sees distances that underflow to 0 as overlaps, which
    // an interval sweep does not (the grid declines radii below 1e-140)
    const double scale = (t % 4 == 0) ? std::pow(10.0, -150.0 + 300.0 * U(g)) : 1.0;
    const double L = 1.0 + 15.0 * U(g);
    std::vector<double> c(3 * n), r(n);
    for (int i = 0; i < n; ++i) {
      for (int x = 0; x < 3; ++x) c[3 * i + x] = scale * L * U(g) * (x == 0 ? 3.0 : 1.0);
      if (mode == 1 && i > 0 && U(g) < 0.3)  // duplicates
        for (int x = 0; x < 3; ++x) c[3 * i + x] = c[3 * (i - 1) + x];
      if (mode == 2)  // a lattice: exactly tangent pairs
        for (int x = 0; x < 3; ++x) c[3 * i + x] = std::round(c[3 * i + x] / scale) * scale;
      if (mode == 5)  // all in a line
        c[3 * i + 1] = c[3 * i + 2] = 0.0;
      r[i] = scale * (mode == 3 ? 0.5 + 0.5 * U(g) : (mode == 4 ? std::pow(10.0, -2.0 * U(g)) : 0.5));
    }
    a.clear();
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) clumpprops::PairSearch::test(c.data(), r.data(), i, j, a);
    b.clear();
    const bool used = ps.grid(c.data(), r.data(), n, b);
    if (!used) ps.overlapping(c.data(), r.data(), n, b);
    (used ? grid : sweep)++;
    bool same = a.size() == b.size();
    for (std::size_t k = 0; same && k < a.size(); ++k) {
      if (used)
        same = a[k].a == b[k].a && a[k].b == b[k].b && a[k].D == b[k].D && a[k].e[0] == b[k].e[0];
      else {  // the sweep's own order: find the pair
        bool found = false;
        for (const auto& p : b) found = found || (p.a == a[k].a && p.b == a[k].b && p.D == a[k].D);
        same = found;
      }
    }
    if (!same) {
      std::printf("mismatch at t=%d (n=%d, mode %d, grid %d): %zu pairs, search %zu\n", t, n, mode, used, a.size(), b.size());
      return 1;
    }
  }
  std::printf("%ld %ld\n", grid, sweep);
  return 0;
}
"""


@pytest.mark.skipif(shutil.which("g++") is None, reason="no C++ compiler")
def test_pair_search_grid_and_sweep_match_all_pairs(tmp_path):
    exe = _compile(tmp_path, "pairs", PAIRS_PROGRAM, "-O2")
    run = subprocess.run([str(exe)], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout
    grid, sweep = map(int, run.stdout.split())
    assert grid > 500 and sweep > 100  # both paths exercised
