// Thin pybind11 wrapper of clumpprops.hpp: one call computes a block of clumps into
// caller-allocated numpy arrays (no Python work per clump).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstring>
#include <stdexcept>

#include "clumpprops.hpp"

namespace py = pybind11;
using clumpprops::Engine;
using clumpprops::Method;
using clumpprops::Result;
using clumpprops::Status;

using carr = py::array_t<double, py::array::c_style>;
using iarr = py::array_t<std::int64_t, py::array::c_style>;

// run(method, centers (S,3), radii (S,), starts (M+1,) or None, n_regular, m0, m1, density, check,
//     principal, mass (M,), volume (M,), com (M,3), inertia (M,3,3), moments (M,3), axes (M,3,3))
// Computes clumps m0 .. m1-1.  Returns (status, clump, i, j, k, count): status 0 ok; otherwise
// the first failing clump (its index) and, for a triple overlap, the sphere indices in it.
static py::tuple run(int method, carr centers, carr radii, py::object starts_obj, std::int64_t n_regular, std::int64_t m0,
                     std::int64_t m1, double density, bool check, bool principal, carr mass, carr volume, carr com,
                     carr inertia, carr moments, carr axes) {
  const double* c = centers.data();
  const double* r = radii.data();
  const std::int64_t S = radii.size();
  if (centers.size() != 3 * S) throw std::invalid_argument("centers must be (S, 3) to match radii (S,)");
  const std::int64_t* st = nullptr;
  iarr starts;
  if (!starts_obj.is_none()) {
    starts = starts_obj.cast<iarr>();
    st = starts.data();
  } else if (n_regular <= 0) {
    throw std::invalid_argument("need starts or n_regular > 0");
  }
  const std::int64_t M = mass.size();
  if (m0 < 0 || m1 > M || m0 > m1) throw std::invalid_argument("bad clump range");
  if (volume.size() != M || com.size() != 3 * M || inertia.size() != 9 * M || (principal && (moments.size() != 3 * M || axes.size() != 9 * M)))
    throw std::invalid_argument("output arrays do not match the number of clumps");
  auto clump_span = [&](std::int64_t m, std::int64_t& s0, std::int64_t& n) {
    if (st) {
      s0 = st[m];
      n = st[m + 1] - st[m];
    } else {
      s0 = m * n_regular;
      n = n_regular;
    }
  };
  {
    std::int64_t s0, n;
    clump_span(m1 > m0 ? m1 - 1 : m0, s0, n);
    if (m1 > m0 && (s0 < 0 || s0 + n > S)) throw std::invalid_argument("clump ranges exceed the sphere arrays");
  }
  double* pm = mass.mutable_data();
  double* pv = volume.mutable_data();
  double* pc = com.mutable_data();
  double* pi = inertia.mutable_data();
  double* pw = principal ? moments.mutable_data() : nullptr;
  double* pa = principal ? axes.mutable_data() : nullptr;
  int status = 0;
  std::int64_t bad = -1;
  clumpprops::TripleOverlap t;
  {
    py::gil_scoped_release release;
    thread_local Engine tl_engine;
    Engine& eng = tl_engine;  // one TLS look-up per call, not per clump
    Result res;
    for (std::int64_t m = m0; m < m1; ++m) {
      std::int64_t s0, n;
      clump_span(m, s0, n);
      const Status s = eng.clump(static_cast<Method>(method), c + 3 * s0, r + s0, static_cast<int>(n), density, principal, res, check);
      if (s != clumpprops::kOk) {
        status = s;
        bad = m;
        t = eng.triple;
        break;
      }
      pm[m] = res.mass;
      pv[m] = res.volume;
      std::memcpy(pc + 3 * m, res.com, 3 * sizeof(double));
      std::memcpy(pi + 9 * m, res.inertia, 9 * sizeof(double));
      if (principal) {
        std::memcpy(pw + 3 * m, res.moments, 3 * sizeof(double));
        std::memcpy(pa + 9 * m, res.axes, 9 * sizeof(double));
      }
    }
  }
  return py::make_tuple(status, bad, t.i, t.j, t.k, t.count);
}

// eigh(inertia (M,3,3)) -> moments (M,3), axes (M,3,3): ascending, right-handed (Jacobi)
static void principal(carr inertia, carr moments, carr axes) {
  const std::int64_t M = inertia.size() / 9;
  if (moments.size() != 3 * M || axes.size() != 9 * M) throw std::invalid_argument("output shapes");
  const double* I = inertia.data();
  double* w = moments.mutable_data();
  double* V = axes.mutable_data();
  py::gil_scoped_release release;
  for (std::int64_t m = 0; m < M; ++m) clumpprops::eigh3(I + 9 * m, w + 3 * m, V + 9 * m);
}

// YADE adapter (clumpprops/yade.py, correction_terms): the state of each clump's correction member
// so that the spheres (summed the way YADE's Clump::updateProperties sums them) plus the correction
// give the target mass, COM and inertia.  Sums about the target COM.  Same arithmetic as the numpy
// version it replaces: sphere mass rho 4/3 pi r^3, own inertia 0.4 m r^2; offset -S/m_c clamped to
// the clump's reach; J = I - I_spheres - m_c (|off|^2 1 - off off^T), symmetrised, Jacobi eigen.
static void correction(carr centers, carr radii, carr densities, iarr starts, carr mass, carr com, carr inertia,
                       carr m_c, carr off, carr w, carr V) {
  const std::int64_t M = mass.size();
  if (starts.size() != M + 1 || com.size() != 3 * M || inertia.size() != 9 * M || m_c.size() != M ||
      off.size() != 3 * M || w.size() != 3 * M || V.size() != 9 * M)
    throw std::invalid_argument("correction: shapes do not match");
  const std::int64_t* st = starts.data();
  const std::int64_t S = radii.size();
  if (centers.size() != 3 * S || densities.size() != S || st[M] > S || st[0] < 0)
    throw std::invalid_argument("correction: sphere arrays do not match starts");
  const double* x = centers.data();
  const double* r = radii.data();
  const double* rho = densities.data();
  const double* pm = mass.data();
  const double* pc = com.data();
  const double* pI = inertia.data();
  double* omc = m_c.mutable_data();
  double* ooff = off.mutable_data();
  double* ow = w.mutable_data();
  double* oV = V.mutable_data();
  py::gil_scoped_release release;
  for (std::int64_t m = 0; m < M; ++m) {
    const double* c0 = pc + 3 * m;
    double ms = 0.0, S3[3] = {0, 0, 0}, Is[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0}, reach = 0.0;
    for (std::int64_t i = st[m]; i < st[m + 1]; ++i) {
      const double vol = (4.0 / 3.0) * clumpprops::kPi * std::pow(r[i], 3.0);
      const double mi = rho[i] * vol, ji = 0.4 * mi * r[i] * r[i];
      const double d[3] = {x[3 * i] - c0[0], x[3 * i + 1] - c0[1], x[3 * i + 2] - c0[2]};
      const double sq = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
      ms += mi;
      for (int a = 0; a < 3; ++a) S3[a] += mi * d[a];
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) Is[3 * a + b] += mi * ((a == b ? sq : 0.0) - d[a] * d[b]) + (a == b ? ji : 0.0);
      reach = std::max(reach, std::sqrt(sq) + r[i]);
    }
    const double mc = pm[m] - ms;
    double o[3] = {-S3[0] / mc, -S3[1] / mc, -S3[2] / mc};
    const double norm = std::sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
    if (!std::isfinite(norm) || norm > reach) {
      const double scale = (std::isfinite(norm) && norm > 0.0) ? reach / norm : 0.0;
      for (int a = 0; a < 3; ++a) {
        o[a] *= scale;
        if (!std::isfinite(o[a])) o[a] = 0.0;
      }
    }
    const double osq = o[0] * o[0] + o[1] * o[1] + o[2] * o[2];
    double J[9];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        J[3 * a + b] = pI[9 * m + 3 * a + b] - Is[3 * a + b] - mc * ((a == b ? osq : 0.0) - o[a] * o[b]);
    omc[m] = mc;
    for (int a = 0; a < 3; ++a) ooff[3 * m + a] = o[a];
    clumpprops::eigh3(J, ow + 3 * m, oV + 9 * m);  // symmetrises
  }
}

PYBIND11_MODULE(_core, mod) {
  mod.doc() = "clumpprops' compiled core (clumpprops/core/clumpprops.hpp): exact, pairwise and summed moments";
  mod.def("run", &run);
  mod.def("principal", &principal);
  mod.def("correction", &correction);
  mod.attr("EXACT") = static_cast<int>(clumpprops::kExact);
  mod.attr("PAIRWISE") = static_cast<int>(clumpprops::kPairwise);
  mod.attr("SUM") = static_cast<int>(clumpprops::kSum);
  mod.attr("OK") = 0;
  mod.attr("OVERFLOW") = static_cast<int>(clumpprops::kOverflow);
  mod.attr("NONPOSITIVE_VOLUME") = static_cast<int>(clumpprops::kNonPositiveVolume);
  mod.attr("TRIPLE") = static_cast<int>(clumpprops::kTriple);
  mod.attr("BAD_INPUT") = static_cast<int>(clumpprops::kBadInput);
}
