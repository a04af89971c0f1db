// Thin pybind11 wrapper of clumpprops.hpp: one call computes a block of clumps into
// caller-allocated numpy arrays (no Python work per clump).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstring>
#include <limits>
#include <vector>
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
// area: null, or (M,) receiving each clump's surface area (method EXACT; NaN for the others).
static py::tuple run_block(int method, carr centers, carr radii, py::object starts_obj, std::int64_t n_regular,
                           std::int64_t m0, std::int64_t m1, double density, bool check, bool principal, carr mass,
                           carr volume, carr com, carr inertia, carr moments, carr axes, double* area) {
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
      if (area) area[m] = res.area;
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

static py::tuple run(int method, carr centers, carr radii, py::object starts_obj, std::int64_t n_regular, std::int64_t m0,
                     std::int64_t m1, double density, bool check, bool principal, carr mass, carr volume, carr com,
                     carr inertia, carr moments, carr axes) {
  return run_block(method, centers, radii, starts_obj, n_regular, m0, m1, density, check, principal, mass, volume, com,
                   inertia, moments, axes, nullptr);
}

// run_area(..., the arguments of run, area (M,)): run, plus the surface area of each clump in the
// same pass (exact method: the exposed solid angle of each sphere, which the volume needs anyway).
static py::tuple run_area(int method, carr centers, carr radii, py::object starts_obj, std::int64_t n_regular,
                          std::int64_t m0, std::int64_t m1, double density, bool check, bool principal, carr mass,
                          carr volume, carr com, carr inertia, carr moments, carr axes, carr area) {
  if (area.size() != mass.size()) throw std::invalid_argument("area must match the number of clumps");
  return run_block(method, centers, radii, starts_obj, n_regular, m0, m1, density, check, principal, mass, volume, com,
                   inertia, moments, axes, area.mutable_data());
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

// Reads a python sequence of n numbers (or of n 3-sequences when width == 3) into out; false if it is
// not one.  prefix: the sequence may be longer, its first n items are read.
static bool read_numbers(PyObject* seq, std::size_t n, int width, std::vector<double>& out, bool prefix = false) {
  PyObject* fast = PySequence_Fast(seq, "");
  if (!fast) {
    PyErr_Clear();
    return false;
  }
  const std::size_t size = static_cast<std::size_t>(PySequence_Fast_GET_SIZE(fast));
  bool ok = prefix ? size >= n : size == n;
  PyObject** items = PySequence_Fast_ITEMS(fast);
  for (std::size_t i = 0; ok && i < n; ++i) {
    if (width == 1) {
      out.push_back(PyFloat_AsDouble(items[i]));
      continue;
    }
    PyObject* row = PySequence_Fast(items[i], "");
    ok = row && PySequence_Fast_GET_SIZE(row) == width;
    for (int a = 0; ok && a < width; ++a) out.push_back(PyFloat_AsDouble(PySequence_Fast_ITEMS(row)[a]));
    Py_XDECREF(row);
  }
  Py_DECREF(fast);
  if (PyErr_Occurred()) {
    PyErr_Clear();
    ok = false;
  }
  return ok;
}

// (w, x, y, z) of the rotation A = V^T, V row-major with right-handed columns: largest-component
// branch, as Eigen's Quaternion(Matrix3) and the oracle tests/_yade_oracles.quaternion_one (same branches, same formulas).
static void quaternion_of_axes(const double* V, double* q) {
  // A = V^T: a_ij = V[j][i]
  const double a00 = V[0], a01 = V[3], a02 = V[6], a10 = V[1], a11 = V[4], a12 = V[7], a20 = V[2], a21 = V[5], a22 = V[8];
  const double sq[4] = {1.0 + (a00 + a11 + a22), 1.0 + a00 - a11 - a22, 1.0 - a00 + a11 - a22, 1.0 - a00 - a11 + a22};
  int big = 0;
  for (int k = 1; k < 4; ++k)
    if (sq[k] > sq[big]) big = k;
  const double s = 2.0 * std::sqrt(std::max(sq[big], 0.5));
  double t[4];
  if (big == 0) {
    t[0] = 0.25 * s, t[1] = (a21 - a12) / s, t[2] = (a02 - a20) / s, t[3] = (a10 - a01) / s;
  } else if (big == 1) {
    t[0] = (a21 - a12) / s, t[1] = 0.25 * s, t[2] = (a01 + a10) / s, t[3] = (a02 + a20) / s;
  } else if (big == 2) {
    t[0] = (a02 - a20) / s, t[1] = (a01 + a10) / s, t[2] = 0.25 * s, t[3] = (a12 + a21) / s;
  } else {
    t[0] = (a10 - a01) / s, t[1] = (a02 + a20) / s, t[2] = (a12 + a21) / s, t[3] = 0.25 * s;
  }
  const double n = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2] + t[3] * t[3]);
  for (int k = 0; k < 4; ++k) q[k] = t[k] / n;
}

// The state of a clump's correction member (clumpprops/yade/correction.py): the mass, offset from
// the target centre of mass, principal moments and axes that make the spheres plus the correction
// sum, the way YADE's Clump::updateProperties sums them, to a target (mass, com (3), inertia (9,
// row-major)).  Sums about the target COM; sphere mass rho 4/3 pi r^3, own inertia 0.4 m r^2, as
// YADE's utils.sphere sets them; Jacobi for the axes.  status: kCorrOk, kCorrHeavy (strict: the
// target is heavier than the summed spheres, m_s), kCorrOutside (strict: the correction's centroid
// lies norm from the COM, beyond the clump's reach), kCorrNotFinite.
enum CorrectionStatus { kCorrOk = 0, kCorrHeavy = 1, kCorrOutside = 2, kCorrNotFinite = 3 };

struct Correction {
  int status = kCorrOk;
  double mc = 0, off[3] = {0, 0, 0}, w[3] = {0, 0, 0}, V[9] = {0}, q[4] = {0}, ms = 0, norm = 0, reach = 0;
};

static Correction correction_of(const double* x, const double* r, const double* rho, Py_ssize_t n, double mass,
                                const double* c, const double* a, bool strict) {
  Correction t;
  double ms = 0, sx = 0, sy = 0, sz = 0, ixx = 0, iyy = 0, izz = 0, ixy = 0, ixz = 0, iyz = 0, reach = 0, smd = 0;
  double sp = 0, spd = 0;  // a density spread's share of m_c and of S (see yade.correction.correction_terms)
  for (Py_ssize_t i = 0; i < n; ++i) {
    const double ri = r[i], mi = rho[i] * ((4.0 / 3.0) * clumpprops::kPi * std::pow(ri, 3.0));
    const double ji = 0.4 * mi * std::pow(ri, 2.0);
    const double dx = x[3 * i] - c[0], dy = x[3 * i + 1] - c[1], dz = x[3 * i + 2] - c[2];
    ms += mi;
    sx += mi * dx;
    sy += mi * dy;
    sz += mi * dz;
    const double sq = dx * dx + dy * dy + dz * dz;
    ixx += mi * (sq - dx * dx) + ji;
    iyy += mi * (sq - dy * dy) + ji;
    izz += mi * (sq - dz * dz) + ji;
    ixy -= mi * (dx * dy);
    ixz -= mi * (dx * dz);
    iyz -= mi * (dy * dz);
    const double dist = std::sqrt(sq) + ri;
    smd += mi * dist;
    if (rho[i] != rho[0]) {
      const double spread = mi * std::fabs(rho[i] - rho[0]) / rho[i];
      sp += spread;
      spd += spread * dist;
    }
    if (dist > reach) reach = dist;
  }
  const double eps = std::numeric_limits<double>::epsilon();
  const double mc = mass - ms, s_noise = 64.0 * eps * smd + spd;
  const bool roundoff = std::fabs(mc) * reach <= s_noise;  // no offset (see yade.correction.correction_terms)
  const double ox = roundoff ? 0.0 : -sx / mc, oy = roundoff ? 0.0 : -sy / mc, oz = roundoff ? 0.0 : -sz / mc;
  t.ms = ms;
  t.reach = reach;
  t.norm = std::sqrt(ox * ox + oy * oy + oz * oz);
  if (strict && mc > 64.0 * eps * ms + sp) {
    t.status = kCorrHeavy;
    return t;
  }
  if (strict && !roundoff && t.norm > reach + (reach * 1e-9 + s_noise / std::fabs(mc))) {
    t.status = kCorrOutside;
    return t;
  }
  if (!std::isfinite(mc) || !std::isfinite(ox) || !std::isfinite(oy) || !std::isfinite(oz)) {
    t.status = kCorrNotFinite;
    return t;
  }
  const double osq = ox * ox + oy * oy + oz * oz;
  const double j01 = 0.5 * ((a[1] - ixy + mc * (ox * oy)) + (a[3] - ixy + mc * (oy * ox)));
  const double j02 = 0.5 * ((a[2] - ixz + mc * (ox * oz)) + (a[6] - ixz + mc * (oz * ox)));
  const double j12 = 0.5 * ((a[5] - iyz + mc * (oy * oz)) + (a[7] - iyz + mc * (oz * oy)));
  const double J[9] = {a[0] - ixx - mc * (osq - ox * ox), j01, j02, j01, a[4] - iyy - mc * (osq - oy * oy), j12,
                       j02, j12, a[8] - izz - mc * (osq - oz * oz)};
  clumpprops::eigh3(J, t.w, t.V);
  quaternion_of_axes(t.V, t.q);
  t.mc = mc;
  t.off[0] = ox, t.off[1] = oy, t.off[2] = oz;
  return t;
}

// m_c, offset (3), moments (3), axes (9, row-major; right-handed columns), orientation (w, x, y, z) of
// A = V^T (4): the 20 floats both adapter entry points return.
template <class Put>
static void put_correction(const Correction& t, Put&& put) {
  put(t.mc);
  for (int i = 0; i < 3; ++i) put(t.off[i]);
  for (int i = 0; i < 3; ++i) put(t.w[i]);
  for (int i = 0; i < 9; ++i) put(t.V[i]);
  for (int i = 0; i < 4; ++i) put(t.q[i]);
}

// The sphere input of both adapter entry points, read into x, r, rho; false if not plain numbers.
static bool read_spheres(py::handle pts, py::handle radii, py::handle densities, std::vector<double>& x,
                         std::vector<double>& r, std::vector<double>& rho, Py_ssize_t& n) {
  n = PyObject_Length(radii.ptr());
  if (n <= 0) {
    PyErr_Clear();
    return false;
  }
  x.clear();
  r.clear();
  rho.clear();
  return read_numbers(pts.ptr(), n, 3, x) && read_numbers(radii.ptr(), n, 1, r) &&
         read_numbers(densities.ptr(), n, 1, rho);
}

// The YADE adapter's clump (clumpprops/yade/build.py): target properties and the state of the
// correction member in one call on python sequences, so a clump costs no numpy array.
// adapter_clump(method, pts [(x, y, z), ...], radii [...], densities [...], strict) -> None when the
// input is not plain numbers, the core reports an error, or (strict) the target is not a union of the
// spheres: the caller then asks adapter_correction which error to raise.  Otherwise 34 floats: mass,
// com (3), inertia (9, row-major), scale (largest |principal moment|), and the 20 of put_correction.
// The target uses the first sphere's density.
static py::object adapter_clump(int method, py::handle pts, py::handle radii, py::handle densities, bool strict) {
  thread_local std::vector<double> x, r, rho;
  Py_ssize_t n = 0;
  if (!read_spheres(pts, radii, densities, x, r, rho, n)) return py::none();
  thread_local Engine eng;
  Result res;
  if (eng.clump(static_cast<Method>(method), x.data(), r.data(), static_cast<int>(n), rho[0], true, res, true) != clumpprops::kOk)
    return py::none();
  const Correction t = correction_of(x.data(), r.data(), rho.data(), n, res.mass, res.com, res.inertia, strict);
  if (t.status != kCorrOk) return py::none();
  const double scale = std::max(std::fabs(res.moments[0]), std::max(std::fabs(res.moments[1]), std::fabs(res.moments[2])));
  PyObject* out = PyTuple_New(34);
  int k = 0;
  auto put = [&](double v) { PyTuple_SET_ITEM(out, k++, PyFloat_FromDouble(v)); };
  put(res.mass);
  for (int i = 0; i < 3; ++i) put(res.com[i]);
  for (int i = 0; i < 9; ++i) put(res.inertia[i]);
  put(scale);
  put_correction(t, put);
  return py::reinterpret_steal<py::object>(out);
}

// The correction member of a clump against a given target (any method's: the baselines too).
// adapter_correction(pts, radii, densities, target [mass, com (3), inertia (9, row-major), ...], strict)
// -> None when the input is not plain numbers; else (status, ...): (0, the 20 floats of
// put_correction), (1, summed spheres' mass) for a target heavier than its spheres, (2, distance of the
// correction's centroid from the COM, reach of the clump) for a centroid outside the clump, (3,) for a
// correction that is not finite.  The caller words the errors (they name the clump).
static py::object adapter_correction(py::handle pts, py::handle radii, py::handle densities, py::handle target,
                                     bool strict) {
  std::vector<double> x, r, rho, tg;
  Py_ssize_t n = 0;
  if (!read_spheres(pts, radii, densities, x, r, rho, n) || !read_numbers(target.ptr(), 13, 1, tg, true))
    return py::none();
  const Correction t = correction_of(x.data(), r.data(), rho.data(), n, tg[0], &tg[1], &tg[4], strict);
  if (t.status == kCorrHeavy) return py::make_tuple(static_cast<int>(t.status), t.ms);
  if (t.status == kCorrOutside) return py::make_tuple(static_cast<int>(t.status), t.norm, t.reach);
  if (t.status != kCorrOk) return py::make_tuple(static_cast<int>(t.status));
  PyObject* out = PyTuple_New(21);
  int k = 0;
  PyTuple_SET_ITEM(out, k++, PyLong_FromLong(kCorrOk));
  auto put = [&](double v) { PyTuple_SET_ITEM(out, k++, PyFloat_FromDouble(v)); };
  put_correction(t, put);
  return py::reinterpret_steal<py::object>(out);
}

// Relative errors (mass, centre of mass / radius of gyration, inertia / scale) of a rigid body's
// state row = (mass, x, y, z, moments (3), quaternion x, y, z, w: YADE's order) against a target:
// the first 14 floats of adapter_clump (mass, com, inertia row-major, scale); tests compare it with
// the oracle tests/_yade_oracles.errors_one; a NaN anywhere gives a NaN error (never a pass).
static py::tuple state_errors(py::handle row_obj, py::handle target_obj) {
  std::vector<double> row, t;
  if (!read_numbers(row_obj.ptr(), 11, 1, row)) throw std::invalid_argument("state_errors: row must be 11 numbers");
  if (!read_numbers(target_obj.ptr(), 14, 1, t, true))
    throw std::invalid_argument("state_errors: target must start with 14 numbers");
  double x = row[7], y = row[8], z = row[9], w = row[10];
  const double n = std::sqrt(x * x + y * y + z * z + w * w);
  x /= n, y /= n, z /= n, w /= n;
  const double R[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - z * w),     2 * (x * z + y * w),
                       2 * (x * y + z * w),     1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                       2 * (x * z - y * w),     2 * (y * z + x * w),     1 - 2 * (x * x + y * y)};
  const double mass = t[0], *com = &t[1], *I = &t[4], scale = t[13];
  double e_i = 0.0;
  for (int i = 0; i < 3; ++i)
    for (int l = 0; l < 3; ++l) {
      const double e = std::fabs(R[3 * i] * row[4] * R[3 * l] + R[3 * i + 1] * row[5] * R[3 * l + 1] +
                                 R[3 * i + 2] * row[6] * R[3 * l + 2] - I[3 * i + l]);
      if (e > e_i || std::isnan(e)) e_i = e;  // a NaN stays: nothing compares greater
    }
  const double tr = std::max(I[0] + I[4] + I[8], 0.0);
  const double gyr = mass > 0 ? std::sqrt(tr / (2.0 * mass)) : 1.0;
  const double e_m = mass != 0.0 ? std::fabs(row[0] - mass) / std::fabs(mass) : INFINITY;
  const double dc = std::sqrt((row[1] - com[0]) * (row[1] - com[0]) + (row[2] - com[1]) * (row[2] - com[1]) +
                              (row[3] - com[2]) * (row[3] - com[2]));
  return py::make_tuple(e_m, dc / std::max(gyr, 1e-300), e_i / std::max(scale, 1e-300));
}

// Which of N points lie strictly inside some of M spheres (|x - c|^2 < r^2): the hit test of the
// sampled estimates (clumpprops.audit's Monte Carlo and quasi-Monte Carlo), with an early exit.
static py::array_t<bool> union_hits(carr points, carr centers, carr radii) {
  if (points.ndim() != 2 || points.shape(1) != 3 || centers.ndim() != 2 || centers.shape(1) != 3 ||
      radii.ndim() != 1 || radii.shape(0) != centers.shape(0))
    throw std::invalid_argument("union_hits: points (N, 3), centers (M, 3) and radii (M,)");
  const py::ssize_t n = points.shape(0), m = centers.shape(0);
  py::array_t<bool> out(n);
  const double* x = points.data();
  const double* c = centers.data();
  const double* r = radii.data();
  bool* hit = out.mutable_data();
  std::vector<double> r2(m);
  for (py::ssize_t j = 0; j < m; ++j) r2[j] = r[j] * r[j];
  {
    py::gil_scoped_release release;
    for (py::ssize_t i = 0; i < n; ++i) {
      const double px = x[3 * i], py_ = x[3 * i + 1], pz = x[3 * i + 2];
      bool in = false;
      for (py::ssize_t j = 0; j < m && !in; ++j) {
        const double dx = px - c[3 * j], dy = py_ - c[3 * j + 1], dz = pz - c[3 * j + 2];
        in = dx * dx + dy * dy + dz * dz < r2[j];
      }
      hit[i] = in;
    }
  }
  return out;
}

PYBIND11_MODULE(_core, mod) {
  mod.doc() = "clumpprops' compiled core (clumpprops/core/clumpprops.hpp): exact, pairwise and summed moments";
  mod.def("run", &run);
  mod.def("run_area", &run_area);
  mod.def("principal", &principal);
  mod.def("adapter_clump", &adapter_clump);
  mod.def("adapter_correction", &adapter_correction);
  mod.def("state_errors", &state_errors);
  mod.def("union_hits", &union_hits);
  mod.attr("EXACT") = static_cast<int>(clumpprops::kExact);
  mod.attr("PAIRWISE") = static_cast<int>(clumpprops::kPairwise);
  mod.attr("SUM") = static_cast<int>(clumpprops::kSum);
  mod.attr("OK") = 0;
  mod.attr("OVERFLOW") = static_cast<int>(clumpprops::kOverflow);
  mod.attr("NONPOSITIVE_VOLUME") = static_cast<int>(clumpprops::kNonPositiveVolume);
  mod.attr("TRIPLE") = static_cast<int>(clumpprops::kTriple);
  mod.attr("BAD_INPUT") = static_cast<int>(clumpprops::kBadInput);
}
