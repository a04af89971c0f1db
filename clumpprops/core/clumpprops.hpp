// clumpprops.hpp -- exact mass properties of sphere clumps (unions of spheres), header-only C++17.
//
// Three methods on one clump (N spheres, centres relative to a clump origin o):
//   exact_moments     the union of the spheres, any overlap pattern (docs/exact_method.md)
//   pairwise_moments  the paper's eqs. (1)-(7): summed spheres minus pairwise lenses, with the
//                     geometric triple-overlap check
//   sum_moments       overlaps counted twice (YADE appendClumped, LAMMPS fix rigid)
// Each returns the volume moments V = int dV, S = int x dV, Q = int x x^T dV about o; finish()
// turns them into mass, centre of mass, inertia about the centre of mass and principal axes.
//
// No dependencies beyond the standard library, no allocation in the steady state (a Workspace
// keeps its buffers), one thread.  Engines can include this file directly; the Python package
// wraps it in clumpprops/core/_core.cpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <tuple>
#include <utility>
#include <vector>

namespace clumpprops {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;
constexpr double kFourPi = 4.0 * kPi;
// pairs whose rim circle is smaller than this (relative to both radii) are treated as tangent
constexpr double kRhoTangent = 1e-6;
// a sphere protruding from another by at most this fraction of the smaller radius is inside it
// (scale-aware containment, docs/exact_method.md section 2a)
constexpr double kTauNested = 1e-13;
// two cap circles of one unit sphere closer than this everywhere are one circle (prune_caps)
constexpr double kCoincidentCaps = 1e-13;
// rule S (touching circles, docs/exact_method.md 2a): a pair of circles of one unit sphere whose
// crossing half-angle alpha (on the smaller circle) has |sin^2 alpha| below kNearTouchingSin2 is
// decided and located in double-double (Arrangement::near_touching); it does not cross when it has
// no crossing there or its half-chord rho sin(alpha) is at most kTouchingChord (two points closer
// than that are not ordered reliably after rounding)
constexpr double kNearTouchingSin2 = 1e-4;
constexpr double kTouchingChord = 1e-14;
// event lists up to this length are insertion-sorted, longer ones with std::sort
constexpr int kSmallSort = 32;
// clumps above this many spheres are checked for duplicate and contained spheres before the pair search
constexpr int kDedupAbove = 64;
// safety net inside Arrangement (coincident circles are merged before it): |R|, |m| below this
constexpr double kCoincident = 1e-14;

struct Moments {
  double V = 0.0;
  double S[3] = {0.0, 0.0, 0.0};
  double Q[9] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  double A = 0.0;  // surface area of the union (exact_moments only): sum of r^2 times exposed solid angle
  void clear() { *this = Moments(); }
};

struct Pair {
  int a, b;      // a < b, indices inside the clump
  double D;      // centre distance
  double e[3];   // (c_b - c_a) / D, (0, 0, 1) if D == 0
};

struct Cap {
  int owner, other;  // cap cut on sphere `owner` by sphere `other`
  double n[3];       // unit axis towards `other`
  double h, rho;     // cap u.n > h on the unit sphere, rho = sqrt(1 - h^2) (from factored forms)
};

// Triple overlap found by the pairwise method's check (local sphere indices, sorted).
struct TripleOverlap {
  int i = -1, j = -1, k = -1;
  long count = 0;
};

// ------------------------------------------------------------------ small helpers
inline double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// the first n entries of a workspace vector set to value (the vector only grows: no allocation in
// the steady state, no call per use)
template <class T>
inline T* filled(std::vector<T>& v, std::size_t n, T value) {
  if (v.size() < n) v.resize(n);
  T* p = v.data();
  for (std::size_t i = 0; i < n; ++i) p[i] = value;
  return p;
}

// insertion sort: the arrays sorted per sphere or per circle are short
template <class T, class Less>
inline void small_sort(T* a, int n, Less less) {
  for (int i = 1; i < n; ++i) {
    T x = a[i];
    int j = i - 1;
    while (j >= 0 && less(x, a[j])) {
      a[j + 1] = a[j];
      --j;
    }
    a[j + 1] = x;
  }
}

// pseudo-angle of (x, y): monotone in atan2(y, x) mod 2 pi, in [0, 4); relative resolution of
// double near every angle (used only to sort crossing points; angles come from atan2).
inline double diamond(double x, double y) {
  if (y >= 0.0) return x >= 0.0 ? y / (x + y + (x + y == 0.0 ? 1.0 : 0.0)) : 1.0 - x / (-x + y);
  return x < 0.0 ? 2.0 - y / (-x - y) : 3.0 + x / (x - y);
}

// ------------------------------------------------------------------ double-double arithmetic
// A value hi + lo with |lo| <= ulp(hi)/2 (about 106 bits), from error-free transformations: two_sum
// (additions only) and two_prod (std::fma: exact on every IEEE platform, in hardware or in libm).
// Used only for the crossing points of nearly touching circles (Arrangement::compute), which are rare.
struct DD {
  double hi, lo;
};
inline DD dd_two_sum(double a, double b) {
  const double s = a + b, bb = s - a;
  return {s, (a - (s - bb)) + (b - bb)};
}
inline DD dd_fast_two_sum(double a, double b) {  // |a| >= |b| (or a == 0)
  const double s = a + b;
  return {s, b - (s - a)};
}
inline DD dd_two_prod(double a, double b) {
  const double p = a * b;
  return {p, std::fma(a, b, -p)};
}
inline DD dd_add(DD a, DD b) {
  DD s = dd_two_sum(a.hi, b.hi);
  const DD t = dd_two_sum(a.lo, b.lo);
  s.lo += t.hi;
  s = dd_fast_two_sum(s.hi, s.lo);
  s.lo += t.lo;
  return dd_fast_two_sum(s.hi, s.lo);
}
inline DD dd_neg(DD a) { return {-a.hi, -a.lo}; }
inline DD dd_sub(DD a, DD b) { return dd_add(a, dd_neg(b)); }
inline DD dd_mul(DD a, DD b) {
  DD p = dd_two_prod(a.hi, b.hi);
  p.lo += a.hi * b.lo + a.lo * b.hi;
  return dd_fast_two_sum(p.hi, p.lo);
}
inline DD dd_mul(DD a, double b) {
  DD p = dd_two_prod(a.hi, b);
  p.lo += a.lo * b;
  return dd_fast_two_sum(p.hi, p.lo);
}
inline DD dd_sqrt(DD a) {  // a > 0
  const double x = std::sqrt(a.hi);
  const DD r = dd_sub(a, dd_two_prod(x, x));
  return dd_fast_two_sum(x, r.hi / (2.0 * x));
}
inline DD dd_div(DD a, DD b) {
  const double q1 = a.hi / b.hi;
  DD r = dd_sub(a, dd_mul(b, q1));
  const double q2 = r.hi / b.hi;
  r = dd_sub(r, dd_mul(b, q2));
  const double q3 = r.hi / b.hi;
  return dd_add(dd_fast_two_sum(q1, q2), DD{q3, 0.0});
}

// ------------------------------------------------------------------ pair search
// Overlapping pairs (D < r_a + r_b), a < b.  All pairs for small clumps.  Above, a uniform grid
// (cell list) with cells at least as wide as the largest r_a + r_b: a pair can only overlap if its
// cells are neighbours, so a clump where each sphere meets a bounded number of others costs
// O(N + overlaps).  Where a grid does not suit (radii too uneven: cells sized by the largest
// sphere would hold many small ones; extreme magnitudes), sort and sweep along the axis of largest
// extent (a pair can only overlap if its intervals c_x +- r overlap): O(N log N + candidates).
// Candidates are screened with comparisons that only reject pairs the exact test
// fl(sqrt(dx^2 + dy^2 + dz^2)) < r_a + r_b rejects too (margins far above round-off, and only
// where no square underflows), so the pairs are those of the plain loops; the grid also emits them
// in the plain loops' order (a, then b), the sweep in its own order (the exact method does not
// depend on it; the pairwise method's sums do, to round-off).
struct PairSearch {
  std::vector<int> order;
  std::vector<double> lo, hi, sw;  // sweep order: interval ends; (c_x, c_y, c_z, r) of each sphere
  std::vector<int> cell, cell_start, gidx;  // grid: cell of each sphere; CSR of the cells; spheres in cell order
  std::vector<double> gsw;                  // (c_x, c_y, c_z, r) in cell order
  std::vector<Pair> tmp;                    // pairs in the grid's order

  // exact overlap test of spheres a < b, and the pair (D, unit direction)
  static bool test(const double* c, const double* r, int a, int b, Pair& p) {
    const double dx = c[3 * b] - c[3 * a], dy = c[3 * b + 1] - c[3 * a + 1], dz = c[3 * b + 2] - c[3 * a + 2];
    const double s = r[a] + r[b];
    const double d2 = dx * dx + dy * dy + dz * dz;
    // d2 > s^2 (1 + 1e-12) implies fl(sqrt(d2)) >= s; s^2 must be a normal number for that
    const double s2 = s * s;
    if (d2 > s2 * (1.0 + 1e-12) && s2 > 1e-290) return false;
    const double D = std::sqrt(d2);
    if (!(D < s)) return false;
    p.a = a;
    p.b = b;
    p.D = D;
    if (D > 0.0) {
      p.e[0] = dx / D;
      p.e[1] = dy / D;
      p.e[2] = dz / D;
    } else {
      p.e[0] = 0.0;
      p.e[1] = 0.0;
      p.e[2] = 1.0;
    }
    return true;
  }
  static void test(const double* c, const double* r, int a, int b, std::vector<Pair>& out) {
    Pair p;
    if (test(c, r, a, b, p)) out.push_back(p);
  }

  // Uniform grid; false (nothing done) where it does not suit.
  bool grid(const double* c, const double* r, int n, std::vector<Pair>& out) {
    double mn[3] = {c[0], c[1], c[2]}, mx[3] = {c[0], c[1], c[2]}, rmax = r[0], rsum = 0.0;
    for (int i = 0; i < n; ++i) {
      for (int x = 0; x < 3; ++x) {
        mn[x] = std::min(mn[x], c[3 * i + x]);
        mx[x] = std::max(mx[x], c[3 * i + x]);
      }
      rmax = std::max(rmax, r[i]);
      rsum += r[i];
    }
    // radii within a factor 3 of their mean (else many small spheres per cell), no square of a
    // distance that can underflow across a cell (the exact test's underflow cases stay in one
    // neighbourhood), nothing that overflows
    if (n > 100000000 || !(rmax <= 3.0 * (rsum / n)) || !(rmax > 1e-140 && rmax < 1e100)) return false;
    double ext[3];
    for (int x = 0; x < 3; ++x) {
      ext[x] = mx[x] - mn[x];
      if (!(ext[x] < 1e300)) return false;
    }
    // cell width h: every overlapping pair has |dx| <= D <= fl(D) (1 + 3 eps) < 2 rmax (1 + 3 eps)
    // per axis; the 1e-6 margin keeps such pairs in neighbouring cells despite the rounding of
    // (c - min) * (1 / h) (relative 3.4e-16 of a quotient below 4 N + 64 < 1e9).  At most ~4 N cells.
    const double limit = 4.0 * n + 64.0;
    double h = std::max(2.0 * rmax * (1.0 + 1e-6), std::max(ext[0], std::max(ext[1], ext[2])) / limit);
    double dim[3];
    for (;;) {
      for (int x = 0; x < 3; ++x) dim[x] = std::floor(ext[x] / h) + 1.0;
      if (dim[0] * dim[1] * dim[2] <= limit) break;
      h *= 1.25;
    }
    const int nx = static_cast<int>(dim[0]), ny = static_cast<int>(dim[1]), nz = static_cast<int>(dim[2]);
    const int ncell = nx * ny * nz;
    const double inv_h = 1.0 / h;
    int* cl = filled(cell, n, 0);
    int* cs = filled(cell_start, static_cast<std::size_t>(ncell) + 1, 0);
    int ic[3];
    for (int i = 0; i < n; ++i) {
      for (int x = 0; x < 3; ++x) ic[x] = std::min(static_cast<int>((c[3 * i + x] - mn[x]) * inv_h), static_cast<int>(dim[x]) - 1);
      cl[i] = (ic[2] * ny + ic[1]) * nx + ic[0];
      ++cs[cl[i] + 1];
    }
    for (int k = 0; k < ncell; ++k) cs[k + 1] += cs[k];
    if (gidx.size() < static_cast<std::size_t>(n)) gidx.resize(n);
    if (gsw.size() < 4 * static_cast<std::size_t>(n)) gsw.resize(4 * static_cast<std::size_t>(n));
    if (order.size() < static_cast<std::size_t>(ncell)) order.resize(ncell);
    int* fillp = order.data();  // fill pointers
    for (int k = 0; k < ncell; ++k) fillp[k] = cs[k];
    for (int i = 0; i < n; ++i) {  // spheres of a cell in index order
      const int q = fillp[cl[i]]++;
      gidx[q] = i;
      for (int x = 0; x < 3; ++x) gsw[4 * q + x] = c[3 * i + x];
      gsw[4 * q + 3] = r[i];
    }
    // half shell: each sphere against the later spheres of its cell and the next cell in x (one
    // contiguous range), and the three cells of the next row in y and the nine of the next layer
    // in z; the pairs found go to tmp, then in the plain loops' order (a, then b) to out
    const int* gi = gidx.data();
    const double* g = gsw.data();
    tmp.clear();
    auto scan = [&](int q, int q0, int q1) {
      const double* sa = g + 4 * q;
      const double ax = sa[0], ay = sa[1], az = sa[2], ra = sa[3];
      for (int u = q0; u < q1; ++u) {
        // the exact test's own rejection (same operands, same rounding as in test), before its call
        const double* sb = g + 4 * u;
        const double dx = sb[0] - ax, dy = sb[1] - ay, dz = sb[2] - az;
        const double s = ra + sb[3];
        const double s2 = s * s;
        if (dx * dx + dy * dy + dz * dz > s2 * (1.0 + 1e-12) && s2 > 1e-290) continue;
        const int i = gi[q], j = gi[u];
        test(c, r, std::min(i, j), std::max(i, j), tmp);
      }
    };
    for (int z = 0; z < nz; ++z)
      for (int y = 0; y < ny; ++y)
        for (int x = 0; x < nx; ++x) {
          const int k = (z * ny + y) * nx + x;
          const int xm = std::max(x - 1, 0), xp = std::min(x + 1, nx - 1);
          for (int q = cs[k]; q < cs[k + 1]; ++q) {
            scan(q, q + 1, cs[(z * ny + y) * nx + xp + 1]);
            if (y + 1 < ny) {
              const int row = (z * ny + y + 1) * nx;
              scan(q, cs[row + xm], cs[row + xp + 1]);
            }
            if (z + 1 < nz)
              for (int yy = std::max(y - 1, 0); yy <= std::min(y + 1, ny - 1); ++yy) {
                const int row = ((z + 1) * ny + yy) * nx;
                scan(q, cs[row + xm], cs[row + xp + 1]);
              }
          }
        }
    // counting sort by a, then b within each a (a few pairs each)
    const int P = static_cast<int>(tmp.size());
    int* cnt = filled(cell, n + 1, 0);  // the cells are no longer needed
    for (int t = 0; t < P; ++t) ++cnt[tmp[t].a + 1];
    for (int i = 0; i < n; ++i) cnt[i + 1] += cnt[i];
    out.resize(P);
    for (int t = 0; t < P; ++t) out[cnt[tmp[t].a]++] = tmp[t];
    // cnt[i] is now the end of a = i
    for (int i = 0, b0 = 0; i < n; ++i) {
      const int b1 = cnt[i];
      if (b1 - b0 > 1) small_sort(out.data() + b0, b1 - b0, [](const Pair& p, const Pair& q) { return p.b < q.b; });
      b0 = b1;
    }
    return true;
  }

  void overlapping(const double* c, const double* r, int n, std::vector<Pair>& out) {
    out.clear();
    if (n <= 40) {
      for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j) test(c, r, i, j, out);
      return;
    }
    if (grid(c, r, n, out)) return;
    double mn[3] = {c[0], c[1], c[2]}, mx[3] = {c[0], c[1], c[2]};
    for (int i = 1; i < n; ++i)
      for (int x = 0; x < 3; ++x) {
        mn[x] = std::min(mn[x], c[3 * i + x]);
        mx[x] = std::max(mx[x], c[3 * i + x]);
      }
    int ax = 0;
    for (int x = 1; x < 3; ++x)
      if (mx[x] - mn[x] > mx[ax] - mn[ax]) ax = x;
    // intervals widened by the round-off of their ends and of the exact test: fl(D) < r_a + r_b
    // implies |dx| < (r_a + r_b)(1 + 3 eps), and c -+ r are rounded relative to |c| + r
    order.resize(n);
    lo.resize(n);
    auto margin = [&](int i) { return 1e-12 * r[i] + 1e-15 * (std::fabs(c[3 * i + ax]) + r[i]); };
    for (int i = 0; i < n; ++i) {
      order[i] = i;
      lo[i] = (c[3 * i + ax] - r[i]) - margin(i);
    }
    std::sort(order.begin(), order.end(), [&](int p, int q) { return lo[p] < lo[q] || (lo[p] == lo[q] && p < q); });
    // contiguous copies in sweep order
    hi.resize(n);
    sw.resize(4 * static_cast<std::size_t>(n));
    for (int p = 0; p < n; ++p) {
      const int i = order[p];
      hi[p] = (c[3 * i + ax] + r[i]) + margin(i);
      for (int x = 0; x < 3; ++x) sw[4 * p + x] = c[3 * i + x];
      sw[4 * p + 3] = r[i];
    }
    for (int p = 0; p < n; ++p) lo[p] = (sw[4 * p + ax] - sw[4 * p + 3]) - margin(order[p]);  // lo in sweep order
    // the two other axes (the sweep axis' intervals overlap already)
    const int o1 = ax == 0 ? 1 : 0, o2 = ax == 2 ? 1 : 2;
    for (int p = 0; p < n; ++p) {
      const double* sp = &sw[4 * p];
      const double hp = hi[p];
      for (int q = p + 1; q < n; ++q) {
        if (!(lo[q] < hp)) break;
        const double* sq = &sw[4 * q];
        // |c_y difference| > s (1 + 1e-12) implies D >= s (no underflow: s > 1e-140)
        const double s = sp[3] + sq[3];
        const double lim = s * (1.0 + 1e-12);
        if (((std::fabs(sq[o1] - sp[o1]) > lim) | (std::fabs(sq[o2] - sp[o2]) > lim)) && s > 1e-140) continue;
        const int i = order[p], j = order[q];
        test(c, r, std::min(i, j), std::max(i, j), out);
      }
    }
  }
};

// ------------------------------------------------------------------ whole spheres, the summed baseline
inline void add_ball(const double* c, double r, Moments& m) {
  const double v = (4.0 / 3.0) * kPi * r * r * r;
  const double iso = v * r * r / 5.0;
  m.V += v;
  for (int x = 0; x < 3; ++x) m.S[x] += v * c[x];
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y) m.Q[3 * x + y] += v * c[x] * c[y] + (x == y ? iso : 0.0);
}

inline void sum_moments(const double* c, const double* r, int n, Moments& m) {
  m.clear();
  for (int i = 0; i < n; ++i) add_ball(c + 3 * i, r[i], m);
}

// ------------------------------------------------------------------ unit-sphere moments -> volume moments
// Moments of the exposed region E of one unit sphere: a = int_E 1, m1 = int_E u, m2 = int_E u u^T,
// and m3 = int_E u u u (dOmega) contracted with the sphere centre c: m3c_xy = sum_z m3_xyz c_z
// (the only way m3 enters).  Volume moments (divergence theorem, docs/exact_method.md sec. 1) need
// only a, m1, m2 c and the symmetric r m2 + m3c (r the sphere's radius), which are what is kept.
struct SurfaceMoments {
  double a;
  double m1[3];
  double m2c[3];  // m2 c
  double Qs[9];   // r m2 + m3c
};

inline void add_from_surface(const double* c, double r, const SurfaceMoments& s, Moments& out) {
  const double cm1 = dot3(c, s.m1);
  const double base = r * s.a + cm1;
  const double r2 = r * r;
  out.V += r2 / 3.0 * base;
  const double* m2c = s.m2c;
  for (int x = 0; x < 3; ++x) out.S[x] += r2 / 4.0 * (c[x] * base + r2 * s.m1[x] + r * m2c[x]);
  const double f = r2 / 5.0;
  for (int x = 0; x < 3; ++x)
    for (int y = x; y < 3; ++y) {
      const double q = f * (c[x] * c[y] * base + r2 * (c[x] * s.m1[y] + s.m1[x] * c[y]) +
                            r * (c[x] * m2c[y] + m2c[x] * c[y]) + r2 * s.Qs[3 * x + y]);
      out.Q[3 * x + y] += q;
      if (y != x) out.Q[3 * y + x] += q;
    }
}

// the unit sphere minus one cap u.n > h, closed form (docs/exact_method.md; 1 - h from rho^2/(1+h))
inline void single_cap(const double* n, double h, double rho, const double* c, double r, SurfaceMoments& s) {
  const double w = h > 0.0 ? rho * rho / (1.0 + h) : 1.0 - h;  // 1 - h
  const double oph = 2.0 - w;
  const double one_m_h2 = w * oph;
  const double one_m_h3 = w * (1.0 + h + h * h);
  const double one_m_h4 = one_m_h2 * (1.0 + h * h);
  s.a = kFourPi - 2.0 * kPi * w;
  for (int x = 0; x < 3; ++x) s.m1[x] = -(kPi * one_m_h2) * n[x];
  const double c_nn = 2.0 * kPi * one_m_h3 / 3.0, c_p = kPi * (w - one_m_h3 / 3.0);
  double m2[9];
  for (int x = 0; x < 3; ++x)
    for (int y = x; y < 3; ++y) {
      const double nn = n[x] * n[y];
      const double P = (x == y ? 1.0 : 0.0) - nn;
      m2[3 * x + y] = m2[3 * y + x] = (x == y ? kFourPi / 3.0 : 0.0) - (c_nn * nn + c_p * P);
    }
  for (int x = 0; x < 3; ++x) s.m2c[x] = m2[3 * x] * c[0] + m2[3 * x + 1] * c[1] + m2[3 * x + 2] * c[2];
  const double alpha = 0.5 * kPi * one_m_h4;
  const double beta = kPi * (0.5 * one_m_h2 - 0.25 * one_m_h4);
  // m3 = -(alpha n n n + beta sym(n P)), sym(n P)_xyz = n_x P_yz + n_y P_xz + n_z P_xy; contracted with c
  const double nc = dot3(n, c);
  double Pc[3];
  for (int x = 0; x < 3; ++x) Pc[x] = c[x] - n[x] * nc;
  for (int x = 0; x < 3; ++x)
    for (int y = x; y < 3; ++y) {
      const double Pxy = (x == y ? 1.0 : 0.0) - n[x] * n[y];
      const double m3c = -(alpha * n[x] * n[y] * nc + beta * (n[x] * Pc[y] + n[y] * Pc[x] + nc * Pxy));
      s.Qs[3 * x + y] = s.Qs[3 * y + x] = r * m2[3 * x + y] + m3c;
    }
}

// ------------------------------------------------------------------ the arrangement of caps on one sphere
// The exposed region of a unit sphere with K >= 2 caps (docs/exact_method.md, sections 2-3).
class Arrangement {
 public:
  struct Circle {
    double n[3], e1[3], e2[3];
    double h, rho;
    double om, op;  // 1 - h, 1 + h without cancellation (rho^2 / (1 +- h) where they are small)
    int rank;
  };
  struct Event {
    double key;  // pseudo-angle on the circle (sort key)
    double c, s;  // cos t, sin t of the point in the circle's own frame
    int type;     // +1: the circle enters the other cap here, -1: leaves it
  };
  // An exposed arc of one circle: from (c1, s1) = (cos t1, sin t1) counter-clockwise over length L
  // (the whole circle: L = 2 pi), in the circle's frame
  struct Arc {
    int circle;
    double c1, s1, c2, s2, L;
  };

  std::vector<Circle> C;
  std::vector<double> M;  // K x K, [k*K + j]: mean of f_kj(t) = u_k(t).n_j - h_j = M + A cos t + B sin t
  std::vector<signed char> cross, coinc;  // K x K, symmetric
  std::vector<Event> ev;  // circle k's events at [k * 2(K-1), k * 2(K-1) + nev[k])
  std::vector<int> nev;
  std::vector<int> enter_gt_leave;  // per circle: crossed caps whose entry key > exit key (inside at t = 0)
  bool record_arcs = false;  // keep the exposed arcs of each compute in `arcs`
  std::vector<Arc> arcs;

  static void basis(const double* n, double* e1, double* e2) {
    double ax[3] = {1.0, 0.0, 0.0};
    if (!(std::fabs(n[0]) < 0.9)) {
      ax[0] = 0.0;
      ax[1] = 1.0;
    }
    const double d = dot3(ax, n);
    for (int x = 0; x < 3; ++x) e1[x] = ax[x] - d * n[x];
    const double l = std::sqrt(dot3(e1, e1));
    for (int x = 0; x < 3; ++x) e1[x] /= l;
    e2[0] = n[1] * e1[2] - n[2] * e1[1];
    e2[1] = n[2] * e1[0] - n[0] * e1[2];
    e2[2] = n[0] * e1[1] - n[1] * e1[0];
  }

  // caps: K caps of one sphere, sorted by `other` (their rank for ties)
  void compute(const Cap* caps, int K, const double* centre, double r, SurfaceMoments& out);

  // Whether circle a crosses cap b (s = sgn(n_a.n_b)) and, if so, cos and sin of the crossing half-angle
  // on a, in double-double from the stored circles (model: below): the decision is right unless
  // sin^2 alpha is below ~1e-32 / (rho_a |n_a -+ n_b|), and both values have relative error ~1e-16 (the
  // double route: ~1e-16 / sin^2 alpha in sin alpha; docs/exact_method.md 2a, rule S).
  static bool near_touching(const Circle& a, const Circle& b, double s, double& ca, double& sa);

 private:
  // trigonometric sums over the exposed arcs of one circle (t: the circle's own angle), and the
  // pole's atan2 part dG and sign sg of the area form
  struct ArcSums {
    double Dt = 0, Ic = 0, Is = 0, S2 = 0, Ics = 0, S3 = 0, C3 = 0;  // S3, C3: sums of sin^3, cos^3 differences
    double dG = 0, sg = 0;
  };
  // the sums over all circles that make the surface moments
  struct Totals {
    double area_U = 0.0;
    bool in_U = false;
    double J1[3] = {0, 0, 0}, J2c[3] = {0, 0, 0}, QS[9] = {0};
  };
  void load_circles(const Cap* caps, int K);
  void find_crossings(int K);
  void intersect_pair(int k, int j, int K);
  void add_crossing_events(int ia, int ib, double a, double b, double Ra, double ca, double sa, int K);
  void choose_pole(int K, double* q);
  bool covered_by_uncrossed_cap(int k, int K) const;
  bool exposed_arc_sums(int k, int K, const double* q, ArcSums& s);
  void add_circle_moments(const Circle& ck, const ArcSums& s, const double* centre, double r, Totals& t) const;
  static void finish(const Totals& t, const double* centre, double r, SurfaceMoments& out);
};

inline bool Arrangement::near_touching(const Circle& a, const Circle& b, double s, double& ca, double& sa) {
  // the model of a circle: the unit sphere cut by the plane u.N = H with N = n / |n| (unit to ~1e-32) and
  // H, om = 1 - H, op = 1 + H from rho^2 / (1 +- h) on the side where it is small (as om, op in double),
  // so its radius sqrt(om op) is rho to ~1e-16 relative also for tiny circles
  auto model = [](const Circle& c, DD* N, DD& H, DD& om, DD& op) {
    DD A{0.0, 0.0};
    for (int x = 0; x < 3; ++x) A = dd_add(A, dd_two_prod(c.n[x], c.n[x]));
    const DD len = dd_sqrt(A);
    for (int x = 0; x < 3; ++x) N[x] = dd_div(DD{c.n[x], 0.0}, len);
    const DD r2 = dd_two_prod(c.rho, c.rho);
    if (c.h > 0.0) {
      om = dd_div(r2, dd_two_sum(1.0, c.h));
      op = dd_sub(DD{2.0, 0.0}, om);
      H = dd_sub(DD{1.0, 0.0}, om);
    } else {
      op = dd_div(r2, dd_two_sum(1.0, -c.h));
      om = dd_sub(DD{2.0, 0.0}, op);
      H = dd_sub(op, DD{1.0, 0.0});
    }
  };
  DD Na[3], Nb[3], Ha, oma, opa, Hb, omb, opb;
  model(a, Na, Ha, oma, opa);
  model(b, Nb, Hb, omb, opb);
  // d = N_b - s N_a, d2 = |d|^2; for unit N: N_a.d = -s d2 / 2 and |N_a x d|^2 = d2 (1 - d2 / 4)
  DD d2{0.0, 0.0};
  for (int x = 0; x < 3; ++x) {
    const DD dx = dd_sub(Nb[x], s > 0.0 ? Na[x] : dd_neg(Na[x]));
    d2 = dd_add(d2, dd_mul(dx, dx));
  }
  // On plane a (u.N_a = H_a), u.N_b - H_b = u.d - (H_b - s H_a); with u = H_a N_a + v, |v|^2 = om_a op_a, this
  // is v.d_perp - Y with d_perp = d + (s d2 / 2) N_a, |d_perp|^2 = X = d2 (1 - d2 / 4) and
  // Y = (H_b - s H_a) + s H_a d2 / 2.  Hence cos alpha = Y / sqrt(W), sin^2 alpha = (W - Y^2) / W, W = om_a op_a X.
  const DD X = dd_mul(d2, dd_sub(DD{1.0, 0.0}, dd_mul(d2, 0.25)));
  const DD hd = dd_mul(dd_mul(Ha, d2), 0.5 * s);
  const DD Y = dd_add(s > 0.0 ? dd_sub(Hb, Ha) : dd_add(Hb, Ha), hd);
  const DD W = dd_mul(dd_mul(oma, opa), X);
  const DD Z = dd_sub(W, dd_mul(Y, Y));
  if (!(W.hi > 0.0 && Z.hi > 0.0)) return false;
  ca = std::max(-1.0, std::min(1.0, Y.hi / std::sqrt(W.hi)));
  sa = std::sqrt(Z.hi / W.hi);
  return true;
}

inline void Arrangement::choose_pole(int K, double* q) {
  // candidate poles: 26 directions of a cube and 6 irrational ones.  The 1-form of the area is
  // singular at -q: take the first candidate whose -q is at least delta (angle) from every circle,
  // trying delta = 0.35, 0.15, 0.05 rad; else the candidate farthest from all circles.
  static const double cand[32][3] = {
      {0.5773502691896258, 0.5773502691896258, 0.5773502691896258},
      {-0.31622776601683794, 0.6324555320336759, 0.7071067811865476},
      {0.8017837257372732, -0.5345224838248488, 0.2672612419124244},
      {-0.6859943405700354, -0.5144957554275265, 0.5144957554275265},
      {0.2182178902359924, 0.4364357804719848, -0.8728715609439696},
      {-0.4082482904638631, -0.8164965809277261, -0.4082482904638631},
      {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1},
      {0.7071067811865476, 0.7071067811865476, 0}, {0.7071067811865476, -0.7071067811865476, 0},
      {-0.7071067811865476, 0.7071067811865476, 0}, {-0.7071067811865476, -0.7071067811865476, 0},
      {0.7071067811865476, 0, 0.7071067811865476}, {0.7071067811865476, 0, -0.7071067811865476},
      {-0.7071067811865476, 0, 0.7071067811865476}, {-0.7071067811865476, 0, -0.7071067811865476},
      {0, 0.7071067811865476, 0.7071067811865476}, {0, 0.7071067811865476, -0.7071067811865476},
      {0, -0.7071067811865476, 0.7071067811865476}, {0, -0.7071067811865476, -0.7071067811865476},
      {0.5773502691896258, 0.5773502691896258, -0.5773502691896258},
      {0.5773502691896258, -0.5773502691896258, 0.5773502691896258},
      {0.5773502691896258, -0.5773502691896258, -0.5773502691896258},
      {-0.5773502691896258, 0.5773502691896258, 0.5773502691896258},
      {-0.5773502691896258, 0.5773502691896258, -0.5773502691896258},
      {-0.5773502691896258, -0.5773502691896258, 0.5773502691896258},
      {-0.5773502691896258, -0.5773502691896258, -0.5773502691896258},
      {-0.5773502691896258, 0.5773502691896258, -0.5773502691896258}};
  static const double cosd[3] = {std::cos(0.35), std::cos(0.15), std::cos(0.05)};
  static const double sind[3] = {std::sin(0.35), std::sin(0.15), std::sin(0.05)};
  for (int di = 0; di < 3; ++di) {
    const double cd = cosd[di], sd = sind[di];
    for (const auto& qq : cand) {
      bool ok = true;
      for (int k = 0; k < K && ok; ++k) {
        const Circle& c = C[k];
        const double x = -dot3(qq, c.n);  // cos of the angle between -q and n
        // |angle - alpha| >= delta  <=>  angle >= alpha + delta or angle <= alpha - delta, where
        // alpha = acos(h); alpha + delta <= pi <=> h >= -cos(delta), alpha - delta >= 0 <=> h <= cos(delta)
        const bool far_out = c.h >= -cd && x <= c.h * cd - c.rho * sd;
        const bool far_in = c.h <= cd && x >= c.h * cd + c.rho * sd;
        ok = far_out || far_in;
      }
      if (ok) {
        q[0] = qq[0];
        q[1] = qq[1];
        q[2] = qq[2];
        return;
      }
    }
  }
  double best = -1.0;
  int ib = 0;
  for (int p = 0; p < 32; ++p) {
    double mn = 1e300;
    for (int k = 0; k < K; ++k) {
      const double x = std::max(-1.0, std::min(1.0, -dot3(cand[p], C[k].n)));
      mn = std::min(mn, std::fabs(std::acos(x) - std::atan2(C[k].rho, C[k].h)));
    }
    if (mn > best) {
      best = mn;
      ib = p;
    }
  }
  q[0] = cand[ib][0];
  q[1] = cand[ib][1];
  q[2] = cand[ib][2];
}

// The steps of compute: the circles (load_circles), their crossing points (find_crossings), the pole of
// the area form (choose_pole), then per circle its exposed arcs (covered_by_uncrossed_cap,
// exposed_arc_sums) and their moments (add_circle_moments), summed into the surface moments (finish).
inline void Arrangement::compute(const Cap* caps, int K, const double* centre, double r, SurfaceMoments& out) {
  load_circles(caps, K);
  find_crossings(K);
  if (record_arcs) arcs.clear();
  double q[3];
  choose_pole(K, q);
  Totals t;
  for (int k = 0; k < K; ++k) {
    const Circle& ck = C[k];
    if (-dot3(q, ck.n) > ck.h) t.in_U = true;
    if (covered_by_uncrossed_cap(k, K)) continue;
    ArcSums s;
    if (!exposed_arc_sums(k, K, q, s)) continue;
    add_circle_moments(ck, s, centre, r, t);
  }
  finish(t, centre, r, out);
}

// the circles of the caps, with 1 - h, 1 + h without cancellation and a frame (n, e1, e2) each
inline void Arrangement::load_circles(const Cap* caps, int K) {
  if (C.size() < static_cast<std::size_t>(K)) C.resize(K);  // grows only: no per-call construction
  for (int k = 0; k < K; ++k) {
    Circle& c = C[k];
    for (int x = 0; x < 3; ++x) c.n[x] = caps[k].n[x];
    c.h = caps[k].h;
    c.rho = caps[k].rho;
    c.rank = caps[k].other;
    c.om = c.h > 0.0 ? c.rho * c.rho / (1.0 + c.h) : 1.0 - c.h;
    c.op = c.h < 0.0 ? c.rho * c.rho / (1.0 - c.h) : 1.0 + c.h;
    basis(c.n, c.e1, c.e2);
  }
}

// Every pair of circles once (k < j): the means M, the crossing and coincidence flags, the events.
inline void Arrangement::find_crossings(int K) {
  const std::size_t KK = static_cast<std::size_t>(K) * K;
  const int stride = 2 * (K - 1);  // at most two events per other circle
  if (M.size() < KK) M.resize(KK);
  filled(cross, KK, static_cast<signed char>(0));
  filled(coinc, KK, static_cast<signed char>(0));
  if (ev.size() < static_cast<std::size_t>(K) * stride) ev.resize(static_cast<std::size_t>(K) * stride);
  filled(nev, K, 0);
  filled(enter_gt_leave, K, 0);
  for (int k = 0; k < K; ++k)
    for (int j = k + 1; j < K; ++j) intersect_pair(k, j, K);
}

// One pair k < j: the means M_kj, M_jk of f_kj = M_kj + A cos t + B sin t (on k, in its frame) and of
// f_jk, without cancellation (docs/exact_method.md, section 2a): with s = sgn(n_k.n_j) and
// d = n_j - s n_k (small for nearly (anti)parallel axes, exact to an ulp),
//   A_kj, B_kj = rho_k e1_k.d, rho_k e2_k.d   (e1, e2 are orthogonal to n_k: the s n_k part is 0)
//   M_kj = h_k g - h_j = (s h_k - h_j) - s h_k |d|^2/2,   g = s (1 - |d|^2/2),
// s h_k - h_j from 1 - h and 1 + h (om, op: relative accuracy) where it cancels; the other
// orientation uses n_k - s n_j = -s d and s h_j - h_k = -s (s h_k - h_j), both exact.  The
// dot-product form lost ~1e-16 absolute in M and A, B, i.e. a relative 1e-16 / |n_k -+ n_j|.
// Each crossing is computed once, on the circle of the pair with the smaller radius rho (the
// lower one on a tie: its position error ~ rho eps / sin(alpha), rho sin(alpha) the half-chord
// shared by both circles, is the smaller one), and located on the other from the same point.
inline void Arrangement::intersect_pair(int k, int j, int K) {
  const Circle& ck = C[k];
  const Circle& cj = C[j];
  const std::size_t kj = static_cast<std::size_t>(k) * K + j, jk = static_cast<std::size_t>(j) * K + k;
  const double g = dot3(ck.n, cj.n);
  const double s = g >= 0.0 ? 1.0 : -1.0;
  const double d[3] = {cj.n[0] - s * ck.n[0], cj.n[1] - s * ck.n[1], cj.n[2] - s * ck.n[2]};
  const double half_d2 = 0.5 * dot3(d, d);
  // s h_k - h_j = a - b (a = s h_k, b = h_j): (1 - b) - (1 - a) where a, b > 0, (1 + a) - (1 + b) where
  // a, b < 0, a - b otherwise (no cancellation there); the oracle's values, without a branch on s
  const double a_ = s * ck.h, b_ = cj.h;
  const double u = 0.5 + 0.5 * s;  // 1 or 0: 1 - a = om_k (s = 1) or op_k (s = -1), 1 + a the other
  const double one_m_a = u * ck.om + (1.0 - u) * ck.op, one_p_a = u * ck.op + (1.0 - u) * ck.om;
  const double dpp = cj.om - one_m_a, dnn = one_p_a - cj.op, dmix = a_ - b_;
  const double dh = (a_ > 0.0 && b_ > 0.0) ? dpp : ((a_ < 0.0 && b_ < 0.0) ? dnn : dmix);
  const double mk = dh - s * ck.h * half_d2, mj = -s * dh - s * cj.h * half_d2;
  M[kj] = mk;
  M[jk] = mj;
  if (g > 0.0 && std::fabs(mk) <= kCoincident) {
    const double ak = ck.rho * dot3(ck.e1, d), bk = ck.rho * dot3(ck.e2, d);
    if (std::sqrt(ak * ak + bk * bk) <= kCoincident) {
      coinc[kj] = coinc[jk] = 1;  // one circle, caps on the same side
      return;
    }
  }
  // computed on circle a (the smaller), located on circle b; d_ab = sd * d
  const bool on_j = cj.rho < ck.rho;
  const Circle& ca_c = on_j ? cj : ck;
  const Circle& cb_c = on_j ? ck : cj;
  const double sd = on_j ? -s : 1.0;
  const double ma = on_j ? mj : mk;
  const double a = sd * (ca_c.rho * dot3(ca_c.e1, d)), b = sd * (ca_c.rho * dot3(ca_c.e2, d));
  const double Ra = std::sqrt(a * a + b * b);
  if (!(Ra > 0.0)) return;
  // f_ab > 0 (inside cap b) for |t - phi| < alpha, cos alpha = -M / R.  Nearly touching circles
  // (|sin^2 alpha| small, either side of 1 in |cos alpha|): the ~1e-16 error of cos alpha in double is
  // an error ~1e-16 / sin(alpha) in alpha, so the crossing decision and the near-concurrent crossing
  // points of three such circles would be inconsistent; both come from double-double instead
  double ca = -ma / Ra;
  const double sa2 = (1.0 - ca) * (1.0 + ca);
  double sa = 0.0;
  if (std::fabs(sa2) < kNearTouchingSin2) {
    if (!near_touching(ca_c, cb_c, s, ca, sa)) return;
  } else {
    if (!(std::fabs(ca) < 1.0)) return;
    sa = std::sqrt(sa2);
  }
  // rule S: circles that do not cross, or whose two crossing points are at most 2 kTouchingChord
  // apart, touch; each is then covered by the other cap or not, by the sign of M (|M| ~ R there)
  if (ca_c.rho * sa <= kTouchingChord) return;
  cross[kj] = cross[jk] = 1;
  add_crossing_events(on_j ? j : k, on_j ? k : j, a, b, Ra, ca, sa, K);
}

// The two crossing points of circle ia (centre direction phi = atan2(b, a) of cap ib seen on ia,
// half-angle cos, sin = ca, sa) as events on ia, and the same points located on circle ib.
inline void Arrangement::add_crossing_events(int ia, int ib, double a, double b, double Ra, double ca, double sa,
                                             int K) {
  const Circle& ca_c = C[ia];
  const Circle& cb_c = C[ib];
  const int stride = 2 * (K - 1);
  const double cp = a / Ra, sp = b / Ra;
  // leave at phi + ac, enter at phi - ac (f_ab = M + R cos(t - phi) decreases through 0 at phi + ac)
  const double cl = cp * ca - sp * sa, sl = sp * ca + cp * sa;
  const double ce = cp * ca + sp * sa, se = sp * ca - cp * sa;
  double Pl[3], Pe[3];
  for (int x = 0; x < 3; ++x) {
    Pl[x] = ca_c.h * ca_c.n[x] + ca_c.rho * (cl * ca_c.e1[x] + sl * ca_c.e2[x]);
    Pe[x] = ca_c.h * ca_c.n[x] + ca_c.rho * (ce * ca_c.e1[x] + se * ca_c.e2[x]);
  }
  const double kl = diamond(cl, sl), ke = diamond(ce, se);
  Event* eva = ev.data() + static_cast<std::size_t>(ia) * stride;
  eva[nev[ia]++] = {kl, cl, sl, -1};
  eva[nev[ia]++] = {ke, ce, se, +1};
  if (ke > kl) ++enter_gt_leave[ia];
  // on b: where a leaves cap b, b enters cap a, and vice versa
  double xl = dot3(Pl, cb_c.e1), yl = dot3(Pl, cb_c.e2), xe = dot3(Pe, cb_c.e1), ye = dot3(Pe, cb_c.e2);
  const double nl = std::sqrt(xl * xl + yl * yl), ne = std::sqrt(xe * xe + ye * ye);
  if (nl > 0.0) {
    xl /= nl;
    yl /= nl;
  }
  if (ne > 0.0) {
    xe /= ne;
    ye /= ne;
  }
  const double jl = diamond(xl, yl), je = diamond(xe, ye);
  Event* evb = ev.data() + static_cast<std::size_t>(ib) * stride;
  evb[nev[ib]++] = {jl, xl, yl, +1};
  evb[nev[ib]++] = {je, xe, ye, -1};
  if (jl > je) ++enter_gt_leave[ib];
}

// caps that do not cross circle k cover all of it or none of it
inline bool Arrangement::covered_by_uncrossed_cap(int k, int K) const {
  for (int j = 0; j < K; ++j) {
    if (j == k) continue;
    const std::size_t kj = static_cast<std::size_t>(k) * K + j;
    if (cross[kj]) continue;
    const bool covered = coinc[kj] ? C[j].rank < C[k].rank  // of one circle, the lower-ranked cap bounds the region
                                   : M[kj] > 0.0;  // f_kj keeps its sign on the circle: the sign of its mean
    if (covered) return true;
  }
  return false;
}

// The exposed arcs of circle k (depth of coverage by the crossed caps: +1 on entering a cap, -1 on
// leaving) and their sums; false if none of the circle is exposed.
inline bool Arrangement::exposed_arc_sums(int k, int K, const double* q, ArcSums& s) {
  const Circle& ck = C[k];
  Event* E = ev.data() + static_cast<std::size_t>(k) * (2 * (K - 1));
  const int P = nev[k];
  // pole in the circle's frame
  const double qn = dot3(q, ck.n), qe1 = dot3(q, ck.e1), qe2 = dot3(q, ck.e2);
  const double Dd = 1.0 + ck.h * qn;
  const double qh = std::sqrt(qe1 * qe1 + qe2 * qe2);
  const double Rr = ck.rho * qh;
  const double kk = std::fabs(ck.h + qn) / (Dd + Rr);
  s.sg = (ck.h + qn > 0.0) ? 1.0 : ((ck.h + qn < 0.0) ? -1.0 : 0.0);
  const double iqh = qh > 0.0 ? 1.0 / qh : 0.0;
  const double cdl = qh > 0.0 ? qe1 * iqh : 1.0, sdl = qe2 * iqh;
  // G(t) - (t - dl)/2 = atan2(Y, X), Y = (k - 1) sin(t - dl), X = (1 + k) + (1 - k) cos(t - dl)
  auto GYX = [&](double c, double sn, double& Y, double& X) {
    const double sp = sn * cdl - c * sdl, cpp = c * cdl + sn * sdl;
    Y = (kk - 1.0) * sp;
    X = (1.0 + kk) + (1.0 - kk) * cpp;
  };
  if (P == 0) {
    s.Dt = kTwoPi;  // the full circle: every trigonometric moment but the constant vanishes
    s.dG = 0.0;
    if (record_arcs) arcs.push_back({k, 1.0, 0.0, 1.0, 0.0, kTwoPi});
    return true;
  }
  auto by_key = [](const Event& x, const Event& y) { return x.key < y.key || (x.key == y.key && x.type > y.type); };
  // insertion sort for the usual few events, O(P log P) for the many of dense clumps
  if (P <= kSmallSort)
    small_sort(E, P, by_key);
  else
    std::sort(E, E + P, by_key);
  int depth = enter_gt_leave[k];
  for (int p = 0; p < P; ++p) {
    depth += E[p].type;
    if (depth != 0) continue;
    const bool wrap = p + 1 >= P;
    const Event& e1 = E[p];
    const Event& e2 = E[wrap ? 0 : p + 1];
    const double c1 = e1.c, s1 = e1.s, c2 = e2.c, s2 = e2.s;
    // arc length t2 - t1 in [0, 2 pi) from one atan2 of the two end points, its branch from the
    // keys: a key difference of 1 is exactly a quarter turn (diamond), so a difference below 1
    // is an arc below pi, above 3 one above pi (the ambiguous lengths near 0 and 2 pi are
    // decided by the sorted order, as the depth walk is)
    double L = std::atan2(c1 * s2 - s1 * c2, c1 * c2 + s1 * s2);
    const double Lkey = (e2.key - e1.key) + (wrap ? 4.0 : 0.0);
    if (Lkey > 3.0 || (L < 0.0 && Lkey >= 1.0)) L += kTwoPi;
    if (record_arcs) arcs.push_back({k, c1, s1, c2, s2, L});
    s.Dt += L;
    s.Ic += s2 - s1;
    s.Is += c1 - c2;
    s.S2 += 2.0 * (s2 * c2 - s1 * c1);
    s.Ics += 0.5 * (s2 * s2 - s1 * s1);
    s.S3 += s2 * s2 * s2 - s1 * s1 * s1;
    s.C3 += c2 * c2 * c2 - c1 * c1 * c1;
    // atan2(Y2, X2) - atan2(Y1, X1) in one atan2: with X1, X2 > 0 (k > 0: X >= 2 min(1, k)) both
    // lie in (-pi/2, pi/2), so their difference is in (-pi, pi) and needs no branch
    double Y1, X1, Y2, X2;
    GYX(c1, s1, Y1, X1);
    GYX(c2, s2, Y2, X2);
    if (X1 > 0.0 && X2 > 0.0)
      s.dG += std::atan2(Y2 * X1 - X2 * Y1, X1 * X2 + Y1 * Y2);
    else
      s.dG += std::atan2(Y2, X2) - std::atan2(Y1, X1);
  }
  return !(s.Dt == 0.0 && s.dG == 0.0);
}

// The moments of the exposed arcs of one circle, added to the totals.
inline void Arrangement::add_circle_moments(const Circle& ck, const ArcSums& s, const double* centre, double r,
                                            Totals& t) const {
  const double Dt = s.Dt, Ic = s.Ic, Is = s.Is;
  const double Icc = 0.5 * Dt + 0.25 * s.S2, Iss = 0.5 * Dt - 0.25 * s.S2, Ics = s.Ics;
  // cubic moments: int cos^3 = [sin - sin^3/3], int sin^3 = [-cos + cos^3/3], int cos^2 sin = [-cos^3/3],
  // int cos sin^2 = [sin^3/3] over the arcs
  const double S3t = s.S3 / 3.0, C3t = s.C3 / 3.0;
  const double Iccc = Ic - S3t, Isss = Is + C3t, Iccs = -C3t, Icss = S3t;
  // area: -h dt + 2 sgn(h + q.n) [G(t2) - G(t1)], G(t) = (t - dl)/2 + atan2 part
  t.area_U += -ck.h * Dt + 2.0 * s.sg * (0.5 * Dt + s.dG);
  // In the circle's frame E = (n, e1, e2): u(t) = sum_q b_q E_q w_q(t), nu = u' x u = sum_p a_p E_p w_p(t)
  // with w = (1, cos t, sin t), b = (h, rho, rho), a = (-rho^2, h rho, h rho), W_pq.. = int w_p w_q .. dt
  // over the exposed arcs.  Then
  //   J1 = sum_p W_p a_p E_p,   J2 + J2^T = sum_xy W_xy s_xy E_x (x) E_y,  s_xy = a_x b_y + a_y b_x,
  // and m3 enters only contracted with the sphere centre c (local coordinates cl):
  //   (J3_xyz + J3_yxz + J3_zxy) c_z = sum_xy Lk_xy E_x (x) E_y,  Lk_xy = s_xy T_xy + b_x b_y U_xy,
  //   T_xy = sum_r W_xyr b_r cl_r = h Z + rho V,  U_xy = sum_p a_p cl_p W_pxy = -rho^2 Z + h rho V,
  //   Z_xy = cl_0 W_xy,  V_xy = cl_1 W_xy1 + cl_2 W_xy2.
  // Only r m2 + m3c and m2 c are needed (add_from_surface), so one symmetric matrix
  // Lc = r/6 (J2 + J2^T) + Lk/12 (local) is rotated per circle.
  const double r6 = r / 6.0;
  const double h = ck.h, rho = ck.rho;
  const double* n = ck.n;
  const double* e1 = ck.e1;
  const double* e2 = ck.e2;
  const double cl0 = dot3(n, centre), cl1 = dot3(e1, centre), cl2 = dot3(e2, centre);
  // the six entries xy = 00, 01, 02, 11, 12, 22
  const double W2[6] = {Dt, Ic, Is, Icc, Ics, Iss};
  const double W31[6] = {Ic, Icc, Ics, Iccc, Iccs, Icss};  // W_xy1
  const double W32[6] = {Is, Ics, Iss, Iccs, Icss, Isss};  // W_xy2
  const double s01 = rho * (h * h - rho * rho), s11 = 2.0 * h * rho * rho;
  const double sv[6] = {-2.0 * rho * rho * h, s01, s01, s11, s11, s11};
  const double hr = h * rho, rr = rho * rho;
  const double bb[6] = {h * h, hr, hr, rr, rr, rr};
  double L2[6], Lc[6];
  for (int e = 0; e < 6; ++e) {
    const double Z = cl0 * W2[e], V = cl1 * W31[e] + cl2 * W32[e];
    L2[e] = W2[e] * sv[e];
    Lc[e] = r6 * L2[e] + (sv[e] * (h * Z + rho * V) + bb[e] * (hr * V - rr * Z)) * (1.0 / 12.0);
  }
  // (J2 + J2^T) c = sum_x v2_x E_x, v2 = L2 cl;  J1
  const double v20 = L2[0] * cl0 + L2[1] * cl1 + L2[2] * cl2;
  const double v21 = L2[1] * cl0 + L2[3] * cl1 + L2[4] * cl2;
  const double v22 = L2[2] * cl0 + L2[4] * cl1 + L2[5] * cl2;
  const double j0 = -(rr * Dt), j1 = hr * Ic, j2 = hr * Is;
  for (int x = 0; x < 3; ++x) {
    t.J1[x] += j0 * n[x] + j1 * e1[x] + j2 * e2[x];
    t.J2c[x] += v20 * n[x] + v21 * e1[x] + v22 * e2[x];
  }
  // rotate Lc to the sphere's axes: sum_pq Lc_pq E_p E_q^T (upper triangle)
  double RC0[3], RC1[3], RC2[3];
  for (int j = 0; j < 3; ++j) {
    RC0[j] = Lc[0] * n[j] + Lc[1] * e1[j] + Lc[2] * e2[j];
    RC1[j] = Lc[1] * n[j] + Lc[3] * e1[j] + Lc[4] * e2[j];
    RC2[j] = Lc[2] * n[j] + Lc[4] * e1[j] + Lc[5] * e2[j];
  }
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j) t.QS[3 * i + j] += n[i] * RC0[j] + e1[i] * RC1[j] + e2[i] * RC2[j];
}

// a, m1, m2 c and r m2 + m3c of the exposed region from the totals
inline void Arrangement::finish(const Totals& t, const double* centre, double r, SurfaceMoments& out) {
  const double a = kFourPi - (t.area_U + (t.in_U ? kFourPi : 0.0));
  out.a = a;
  for (int x = 0; x < 3; ++x) out.m1[x] = 0.5 * t.J1[x];
  // m2 c = a c / 3 + (J2 + J2^T) c / 6;  r m2 + m3c with m3 c = [sym(J3) + T(J1)] c / 12,
  // T(v)_xyz c_z = delta_xy (v.c) + c_x v_y + c_y v_x
  for (int x = 0; x < 3; ++x) out.m2c[x] = a / 3.0 * centre[x] + t.J2c[x] / 6.0;
  const double J1c = dot3(t.J1, centre);
  for (int x = 0; x < 3; ++x)
    for (int y = x; y < 3; ++y)
      out.Qs[3 * x + y] = out.Qs[3 * y + x] = t.QS[3 * x + y] + (x == y ? r * a / 3.0 + J1c / 12.0 : 0.0) +
                                              (centre[x] * t.J1[y] + centre[y] * t.J1[x]) / 12.0;
}
// ------------------------------------------------------------------ the exact method
struct ExactWorkspace {
  PairSearch search;
  std::vector<Pair> pairs;
  std::vector<signed char> buried;
  std::vector<Cap> caps, sorted;
  std::vector<int> start, count;
  std::vector<signed char> drop, copy, coinc;
  std::vector<double> alpha;
  std::vector<int> order;
  std::vector<double> unique_c, unique_r;
  std::vector<int> by_size;                     // moments_of_reaching_caps: caps by decreasing size,
  std::vector<signed char> chosen;              // the subset's flags, its caps,
  std::vector<Cap> subset;                      // and the caps reaching its exposed region
  std::vector<std::tuple<int, int, int>> reach;
  Arrangement arr;
};

// whether sphere a lies in sphere b by exact_caps' scale-aware rule (and, where each lies in the
// other, a is the one exact_caps buries: the later in the order larger radius first, then lower index)
inline bool buried_by(const double* c, const double* r, int a, int b) {
  const double dx = c[3 * b] - c[3 * a], dy = c[3 * b + 1] - c[3 * a + 1], dz = c[3 * b + 2] - c[3 * a + 2];
  const double D = std::sqrt(dx * dx + dy * dy + dz * dz);
  const double tol = kTauNested * std::min(r[a], r[b]);
  if (!((r[a] - r[b]) + D <= tol)) return false;
  const bool b_in_a = (r[b] - r[a]) + D <= tol;
  return !b_in_a || r[b] > r[a] || (r[b] == r[a] && b < a);
}

// For clumps of more than kDedupAbove spheres, the spheres that cannot change the union are
// dropped before the pair search: exact duplicates (same centre and radius, bit for bit; the first
// of each group stays) and spheres that exact_caps would bury inside one of the kContainers
// largest spheres.  The rest go to w.unique_c, w.unique_r in input order; returns false if none
// is dropped.  O(n log n); n identical or nested spheres then cost O(n) memory instead of the n^2/2
// pairs of the search, and the exact method's answer is unchanged (the union is).
constexpr int kContainers = 8;
inline bool drop_redundant(const double* c, const double* r, int n, ExactWorkspace& w) {
  if (n <= kDedupAbove) return false;
  w.order.resize(n);
  for (int i = 0; i < n; ++i) w.order[i] = i;
  auto key = [&](int i) { return std::make_tuple(-r[i], c[3 * i], c[3 * i + 1], c[3 * i + 2]); };
  std::sort(w.order.begin(), w.order.end(), [&](int a, int b) { return key(a) < key(b) || (key(a) == key(b) && a < b); });
  signed char* drop = filled(w.drop, n, static_cast<signed char>(0));
  bool any = false;
  for (int q = 1; q < n; ++q)
    if (key(w.order[q]) == key(w.order[q - 1])) drop[w.order[q]] = any = 1;
  // containers: the largest distinct spheres (w.order is by decreasing radius), in that order
  int used = 0;
  for (int q = 0; q < n && used < kContainers; ++q) {
    const int b = w.order[q];
    if (drop[b]) continue;
    ++used;
    for (int a = 0; a < n; ++a)
      if (a != b && !drop[a] && buried_by(c, r, a, b)) drop[a] = any = 1;
  }
  if (!any) return false;
  w.unique_c.clear();
  w.unique_r.clear();
  for (int i = 0; i < n; ++i)
    if (!drop[i]) {
      w.unique_c.insert(w.unique_c.end(), c + 3 * i, c + 3 * i + 3);
      w.unique_r.push_back(r[i]);
    }
  return true;
}

// Caps of every sphere (sorted by owner, then other) and the buried spheres.
inline void exact_caps(const double* c, const double* r, int n, ExactWorkspace& w) {
  w.search.overlapping(c, r, n, w.pairs);
  signed char* buried = filled(w.buried, n, static_cast<signed char>(0));
  // containment, scale-aware: a is inside b when its protrusion (r_a - r_b) + D is at most
  // tau min(r_a, r_b).  Of two spheres inside each other (near-identical), exactly one goes: the
  // later in the order (larger radius first, then lower index), so one of each group stays.
  for (const Pair& p : w.pairs) {
    const double ra = r[p.a], rb = r[p.b];
    const double tol = kTauNested * std::min(ra, rb);
    const bool a_in_b = (ra - rb) + p.D <= tol;
    const bool b_in_a = (rb - ra) + p.D <= tol;
    const bool a_first = ra >= rb;
    if (a_in_b && !(b_in_a && a_first)) buried[p.a] = 1;
    if (b_in_a && !(a_in_b && !a_first)) buried[p.b] = 1;
  }
  w.caps.clear();
  for (const Pair& p : w.pairs) {
    const double ra = r[p.a], rb = r[p.b], D = p.D;
    if (buried[p.a] || buried[p.b]) continue;  // (every containment pair buried one of its spheres)
    const double delta = ra + rb - D;
    const double omh_a = delta * ((rb - ra) + D) / (2.0 * ra * D);
    const double oph_a = ((ra - rb) + D) * (ra + D + rb) / (2.0 * ra * D);
    const double omh_b = delta * ((ra - rb) + D) / (2.0 * rb * D);
    const double oph_b = ((rb - ra) + D) * (rb + D + ra) / (2.0 * rb * D);
    const double dr = (ra - rb) * (ra + rb);
    const double h_a = (D * D + dr) / (2.0 * ra * D), h_b = (D * D - dr) / (2.0 * rb * D);
    const double rho_a = std::sqrt(std::max(omh_a * oph_a, 0.0)), rho_b = std::sqrt(std::max(omh_b * oph_b, 0.0));
    if (std::max(rho_a, rho_b) < kRhoTangent) {
      // near-tangent pair: tangent.  Externally: no caps; internally: the inner sphere is buried
      if (h_a < 0.0) buried[p.a] = 1;
      if (h_b < 0.0) buried[p.b] = 1;
      continue;
    }
    Cap ca{p.a, p.b, {p.e[0], p.e[1], p.e[2]}, h_a, rho_a};
    Cap cb{p.b, p.a, {-p.e[0], -p.e[1], -p.e[2]}, h_b, rho_b};
    w.caps.push_back(ca);
    w.caps.push_back(cb);
  }
  // drop caps of or by buried spheres; group by owner, sort by other
  int* count = filled(w.count, n, 0);
  std::size_t kept = 0;
  for (const Cap& cp : w.caps)
    if (!buried[cp.owner] && !buried[cp.other]) {
      w.caps[kept++] = cp;
      ++count[cp.owner];
    }
  w.caps.resize(kept);
  int* start = filled(w.start, n + 1, 0);
  for (int i = 0; i < n; ++i) start[i + 1] = start[i] + count[i];
  if (w.sorted.size() < kept) w.sorted.resize(kept);
  Cap* sorted = w.sorted.data();
  int* fill = count;  // reuse as fill pointer
  for (int i = 0; i < n; ++i) fill[i] = start[i];
  for (const Cap& cp : w.caps) sorted[fill[cp.owner]++] = cp;
  for (int i = 0; i < n; ++i)
    if (start[i + 1] - start[i] > 1)
      small_sort(sorted + start[i], start[i + 1] - start[i], [](const Cap& x, const Cap& y) { return x.other < y.other; });
}

// The caps of one sphere that matter (docs/exact_method.md, section 2a), compacted in place:
// 1. coincident circles (|h_k g - h_j| + rho_k |n_k x n_j| <= tol seen from both circles, g = n_k.n_j)
//    are one circle, decided once here: of equally oriented caps the lowest-ranked is kept; two
//    oppositely oriented ones (complementary caps) cover the whole sphere: returns -1 (the sphere
//    contributes nothing);
// 2. of the rest, cap j lying in cap k (angle(n_j, n_k) + alpha_j <= alpha_k) is dropped.
// Returns the new K (or -1).
inline int prune_caps(Cap* caps, int K, ExactWorkspace& w) {
  if (K < 2) return K;  // one cap: closed form (single_cap), no angular radius needed
  double* alpha_ = filled(w.alpha, K, static_cast<double>(NAN));  // angular radii atan2(rho, h), when first needed
  signed char* drop = filled(w.drop, K, static_cast<signed char>(0));
  signed char* coinc = filled(w.coinc, static_cast<std::size_t>(K) * K, static_cast<signed char>(0));
  auto alpha = [&](int k) {
    double& a = alpha_[k];
    if (std::isnan(a)) a = std::atan2(caps[k].rho, caps[k].h);
    return a;
  };
  for (int k = 0; k < K; ++k)
    for (int j = k + 1; j < K; ++j) {
      const double* a = caps[k].n;
      const double* b = caps[j].n;
      const double g = dot3(a, b);
      // cheap exclusion: coincident circles have nearly equal h and nearly parallel axes
      if (std::fabs(g) < 0.5) continue;
      const double cx = a[1] * b[2] - a[2] * b[1], cy = a[2] * b[0] - a[0] * b[2], cz = a[0] * b[1] - a[1] * b[0];
      const double sn = std::sqrt(cx * cx + cy * cy + cz * cz);
      const double dkj = std::fabs(caps[k].h * g - caps[j].h) + caps[k].rho * sn;
      const double djk = std::fabs(caps[j].h * g - caps[k].h) + caps[j].rho * sn;
      if (dkj <= kCoincidentCaps && djk <= kCoincidentCaps) {
        if (g < 0.0) return -1;  // complementary caps: the sphere is covered entirely
        coinc[static_cast<std::size_t>(k) * K + j] = coinc[static_cast<std::size_t>(j) * K + k] = 1;
        // the same cap twice: keep the lower-ranked
        if (caps[k].other < caps[j].other)
          drop[j] = 1;
        else
          drop[k] = 1;
      }
    }
  auto inside = [&](int j, int k) {  // cap j within cap k
    const double d = dot3(caps[j].n, caps[k].n);
    // theta <= alpha_k - alpha_j needs cos(theta) >= cos(alpha_k - alpha_j) = h_k h_j + rho_k rho_j:
    // clearly apart, skip the atan2s
    if (d < caps[k].h * caps[j].h + caps[k].rho * caps[j].rho - 1e-9) return false;
    if (alpha(k) - alpha(j) < 0.0) return false;
    const double* a = caps[j].n;
    const double* b = caps[k].n;
    const double cx = a[1] * b[2] - a[2] * b[1], cy = a[2] * b[0] - a[0] * b[2], cz = a[0] * b[1] - a[1] * b[0];
    const double theta = std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), d);
    return theta + alpha(j) <= alpha(k);
  };
  // a cap dropped as a coincident copy is no container (its kept twin is): remember those flags
  signed char* copy = filled(w.copy, K, static_cast<signed char>(0));
  for (int k = 0; k < K; ++k) copy[k] = drop[k];
  for (int j = 0; j < K; ++j)
    for (int k = 0; k < K && !drop[j]; ++k) {
      if (k == j || copy[k] || coinc[static_cast<std::size_t>(j) * K + k]) continue;
      if (inside(j, k)) drop[j] = 1;
    }
  int m = 0;
  for (int k = 0; k < K; ++k)
    if (!drop[k]) caps[m++] = caps[k];
  return m;
}

// ------------------------------------------------------------------ caps that cannot reach the exposed region
// A sphere with many caps (dense clumps: every neighbour cuts one) has an exposed region bounded by
// a few of them; the others lie in the union of the rest and change nothing.  The region is found
// from a subset S of the caps, the largest first: the arrangement of S gives the region E_S (which
// contains the true region E) and its boundary arcs.  A cap outside S that keeps clear of every
// boundary arc of E_S (by kCapClearance) and whose axis point lies in a cap of S (by kInsideCap)
// lies outside E_S entirely; if every cap outside S does, E = E_S and the moments of E_S are the
// sphere's.  Otherwise the caps that reach E_S join S (those covering most of its boundary first)
// and the arrangement is computed again.  A cap is dropped only where the margins decide it, so
// the result is the arrangement of all caps, to round-off (docs/exact_method.md, section 2).
constexpr int kCoveredCapsAbove = 48;  // spheres with more caps than this go through the subset
constexpr int kFirstCaps = 24;         // the size of the first subset
constexpr double kCapClearance = 1e-9;  // f_j = u.n_j - h_j below -this on every arc: cap j is clear of it
constexpr double kInsideCap = 1e-12;    // a point with f_k above this lies in cap k

// The largest value of f_j(u) = u.n_j - h_j on one exposed arc, and whether the arc starts inside cap j.
inline double max_on_arc(const Arrangement::Circle& ck, const Arrangement::Arc& arc, const Cap& cj,
                         bool& starts_inside) {
  const double M = ck.h * dot3(ck.n, cj.n) - cj.h;
  const double A = ck.rho * dot3(ck.e1, cj.n), B = ck.rho * dot3(ck.e2, cj.n);
  const double R = std::sqrt(A * A + B * B);
  const double f1 = M + A * arc.c1 + B * arc.s1;
  starts_inside = f1 > 0.0;
  if (arc.L >= kTwoPi) return M + R;
  double best = std::max(f1, M + A * arc.c2 + B * arc.s2);
  if (R > 0.0) {  // the circle's point nearest n_j, if on the arc
    const double cp = A / R, sp = B / R;
    double t = std::atan2(arc.c1 * sp - arc.s1 * cp, arc.c1 * cp + arc.s1 * sp);
    if (t < 0.0) t += kTwoPi;
    if (t <= arc.L) best = M + R;
  }
  return best;
}

// Whether cap j can reach the exposed region of the arrangement (the caps of S, in arr); score: how
// much of the region's boundary it covers (arcs it enters, arcs starting inside it).
inline bool reaches_exposed_region(const Arrangement& arr, const Cap& cj, const Cap* subset, int Ks, int& score) {
  score = 0;
  if (arr.arcs.empty()) return false;  // nothing exposed
  bool reaches = false;
  for (const Arrangement::Arc& arc : arr.arcs) {
    bool starts_inside = false;
    const double f = max_on_arc(arr.C[arc.circle], arc, cj, starts_inside);
    if (f > -kCapClearance) reaches = true;
    score += (f > 0.0) + starts_inside;
  }
  if (reaches) return true;
  // clear of the boundary: cap j lies inside E_S or outside it, as its axis point does
  for (int k = 0; k < Ks; ++k)
    if (dot3(cj.n, subset[k].n) - subset[k].h > kInsideCap) return false;
  return true;
}

// The caps outside the subset (chosen) that reach its exposed region, in w.reach as (-score, size
// rank, cap); false if there is none.
inline bool caps_reaching_region(const Cap* caps, int K, const signed char* chosen, int Ks, ExactWorkspace& w) {
  w.reach.clear();
  for (int q = 0; q < K; ++q) {
    const int k = w.by_size[q];
    int score = 0;
    if (!chosen[k] && reaches_exposed_region(w.arr, caps[k], w.subset.data(), Ks, score))
      w.reach.push_back({-score, q, k});
  }
  return !w.reach.empty();
}

// Surface moments of one sphere from its K caps (K > kCoveredCapsAbove), computed on the subset of
// the caps that reach the exposed region (above).  Returns false if the sphere is covered entirely.
inline bool moments_of_reaching_caps(const Cap* caps, int K, const double* centre, double r, SurfaceMoments& s,
                                     ExactWorkspace& w) {
  w.by_size.resize(K);  // caps by decreasing angular radius (increasing h)
  for (int k = 0; k < K; ++k) w.by_size[k] = k;
  std::sort(w.by_size.begin(), w.by_size.end(),
            [&](int a, int b) { return caps[a].h < caps[b].h || (caps[a].h == caps[b].h && a < b); });
  signed char* chosen = filled(w.chosen, K, static_cast<signed char>(0));
  int n_chosen = std::min(K, kFirstCaps);
  for (int q = 0; q < n_chosen; ++q) chosen[w.by_size[q]] = 1;
  Arrangement& arr = w.arr;
  arr.record_arcs = true;
  for (;;) {
    w.subset.clear();
    for (int k = 0; k < K; ++k)
      if (chosen[k]) w.subset.push_back(caps[k]);  // in the caps' order (by neighbour)
    const int Ks = prune_caps(w.subset.data(), static_cast<int>(w.subset.size()), w);
    if (Ks < 0) break;  // complementary caps: nothing exposed
    arr.compute(w.subset.data(), Ks, centre, r, s);  // one cap: only its arc is used
    if (Ks == 1) single_cap(w.subset[0].n, w.subset[0].h, w.subset[0].rho, centre, r, s);
    if (!caps_reaching_region(caps, K, chosen, Ks, w)) {
      arr.record_arcs = false;
      return true;
    }
    // where at least half of the other caps reach the region, all join (their circles bound it, as
    // on a sphere studded with small ones); else those covering most of the boundary first, then
    // the larger, the subset growing by half
    const int n_reach = static_cast<int>(w.reach.size());
    int add = n_reach;
    if (2 * n_reach < K - n_chosen) {
      std::sort(w.reach.begin(), w.reach.end());
      add = std::min(n_reach, std::max(n_chosen / 2, kFirstCaps));
    }
    for (int t = 0; t < add; ++t) chosen[std::get<2>(w.reach[t])] = 1;
    n_chosen += add;
  }
  arr.record_arcs = false;
  return false;
}

// Surface moments of one sphere from its K >= 1 caps (compacted in place); false if the sphere is
// covered entirely.
inline bool exposed_region_moments(Cap* caps, int K, const double* centre, double r, SurfaceMoments& s,
                                   ExactWorkspace& w) {
  if (K > kCoveredCapsAbove) return moments_of_reaching_caps(caps, K, centre, r, s, w);
  K = prune_caps(caps, K, w);
  if (K < 0) return false;  // covered entirely by complementary caps
  if (K == 1)
    single_cap(caps[0].n, caps[0].h, caps[0].rho, centre, r, s);
  else
    w.arr.compute(caps, K, centre, r, s);
  return true;
}

inline void exact_moments(const double* c, const double* r, int n, Moments& out, ExactWorkspace& w) {
  out.clear();
  if (drop_redundant(c, r, n, w)) {
    std::vector<double> uc, ur;  // own copies: the workspace's buffers are reused below
    uc.swap(w.unique_c);
    ur.swap(w.unique_r);
    exact_moments(uc.data(), ur.data(), static_cast<int>(ur.size()), out, w);
    uc.swap(w.unique_c);
    ur.swap(w.unique_r);
    return;
  }
  exact_caps(c, r, n, w);
  SurfaceMoments s;
  for (int i = 0; i < n; ++i) {
    if (w.buried[i]) continue;
    Cap* caps = w.sorted.data() + w.start[i];
    int K = w.start[i + 1] - w.start[i];
    if (K == 0) {
      add_ball(c + 3 * i, r[i], out);
      out.A += kFourPi * r[i] * r[i];
      continue;
    }
    if (exposed_region_moments(caps, K, c + 3 * i, r[i], s, w)) {
      add_from_surface(c + 3 * i, r[i], s, out);
      out.A += s.a * r[i] * r[i];  // the exposed solid angle is already there: the area costs one product
    }
  }
}

// ------------------------------------------------------------------ the pairwise method (paper eqs. 1-7)
// cap of height l on a sphere of radius R: volume, centroid distance b from the base plane,
// axial variance sa, transverse second moment st (per unit density)
inline void cap_moments(double R, double l, double& V, double& b, double& sa, double& st) {
  V = kPi * l * l * (3.0 * R - l) / 3.0;
  b = l * (4.0 * R - l) / (4.0 * (3.0 * R - l));
  const double l2 = l * l, l3 = l2 * l;
  const double M1 = kPi * l3 * (2.0 * R / 3.0 - l / 4.0);
  const double M2 = kPi * l3 * l * (R / 2.0 - l / 5.0);
  sa = V > 0.0 ? M2 - M1 * M1 / V : 0.0;
  st = 0.25 * kPi * l3 * (4.0 * R * R / 3.0 - R * l + l2 / 5.0);
}

// overlap region of one pair: volume, centroid, central second moment sig_t 1 + sig_ax e e^T
inline void lens_moments(double ra, double rb, const double* ca, const double* cb, double D, const double* e, double& Vl,
                         double* pos, double& sig_t, double& sig_ax) {
  const bool big_a = ra >= rb;
  const double r_small = big_a ? rb : ra, r_big = big_a ? ra : rb;
  if (D + r_small <= r_big) {
    const double* sc = big_a ? cb : ca;
    Vl = (4.0 / 3.0) * kPi * r_small * r_small * r_small;
    for (int x = 0; x < 3; ++x) pos[x] = sc[x];
    sig_t = Vl * r_small * r_small / 5.0;
    sig_ax = 0.0;
    return;
  }
  const double delta = ra + rb - D;
  const double l1 = delta * (rb - ra + D) / (2.0 * D), l2 = delta * (ra - rb + D) / (2.0 * D);
  double V1, b1, sa1, st1, V2, b2, sa2, st2;
  cap_moments(ra, l1, V1, b1, sa1, st1);
  cap_moments(rb, l2, V2, b2, sa2, st2);
  Vl = V1 + V2;
  const double zL = Vl > 0.0 ? (V1 * b1 - V2 * b2) / Vl : (V1 * b1 - V2 * b2);
  const double sa = sa1 + V1 * (b1 - zL) * (b1 - zL) + sa2 + V2 * (b2 + zL) * (b2 + zL);
  sig_t = st1 + st2;
  for (int x = 0; x < 3; ++x) pos[x] = ca[x] + (ra - l1) * e[x] + zL * e[x];
  sig_ax = sa - sig_t;
}

// distance from point p to the overlap region of balls j, k (lens or the smaller ball).  Where one ball
// lies in the other (identical and coincident balls included) the region is the smaller ball, whatever
// the order of j and k.  Otherwise the nearest point is the nearest point of one ball if that lies in the
// other ball, else on the rim circle; "lies in" allows round-off (a relative 1e-12 of the radius), so
// that two balls that differ by round-off still count as each other's region: the check then errs
// towards reporting a triple overlap (a refusal), never towards missing one (a wrong answer).
inline double distance_to_overlap(const double* p, const double* cj, double rj, const double* ck, double rk, double D,
                                  const double* e) {
  const double big = std::max(rj, rk), small = std::min(rj, rk);
  if (D + small <= big) {
    const double* cs = rj <= rk ? cj : ck;
    double v[3] = {p[0] - cs[0], p[1] - cs[1], p[2] - cs[2]};
    return std::max(std::sqrt(dot3(v, v)) - small, 0.0);
  }
  auto proj_in_other = [&](const double* cx, double rx, const double* cy, double ry) {
    double v[3] = {p[0] - cx[0], p[1] - cx[1], p[2] - cx[2]};
    const double nv = std::sqrt(dot3(v, v));
    const bool outside = nv > rx;
    double q[3];
    for (int x = 0; x < 3; ++x) q[x] = outside ? cx[x] + v[x] * (rx / (nv > 0.0 ? nv : 1.0)) : p[x];
    double w[3] = {q[0] - cy[0], q[1] - cy[1], q[2] - cy[2]};
    const bool ok = std::sqrt(dot3(w, w)) <= ry * (1.0 + 1e-12);
    const double dist = outside ? nv - rx : 0.0;
    return ok ? dist : HUGE_VAL;
  };
  double d = std::min(proj_in_other(cj, rj, ck, rk), proj_in_other(ck, rk, cj, rj));
  {
    const double delta = rj + rk - D;
    const double l1 = delta * (rk - rj + D) / (2.0 * D);
    const double rho = std::sqrt(std::max(l1 * (2.0 * rj - l1), 0.0));
    double v[3];
    for (int x = 0; x < 3; ++x) v[x] = p[x] - (cj[x] + (rj - l1) * e[x]);
    const double vpar = dot3(v, e);
    double vp[3] = {v[0] - vpar * e[0], v[1] - vpar * e[1], v[2] - vpar * e[2]};
    const double npp = std::sqrt(dot3(vp, vp));
    d = std::min(d, std::sqrt(vpar * vpar + (npp - rho) * (npp - rho)));
  }
  return d;
}

// Whether balls i, j, k share a region of positive volume, decided the same way for every order
// in which the three are listed: the three are put in a canonical order (radius, then centre),
// and the triple counts if any of them reaches the overlap region of the other two (each of the
// three tests is exact in exact arithmetic; asking all three keeps a round-off miss in one of
// them from deciding alone).
inline bool triple_overlap(const double* c, const double* r, int i, int j, int k) {
  int s[3] = {i, j, k};
  auto before = [&](int a, int b) {
    if (r[a] != r[b]) return r[a] < r[b];
    for (int x = 0; x < 3; ++x)
      if (c[3 * a + x] != c[3 * b + x]) return c[3 * a + x] < c[3 * b + x];
    return false;
  };
  small_sort(s, 3, before);
  for (int t = 0; t < 3; ++t) {
    const int p = s[t], a = s[t == 0 ? 1 : 0], b = s[t == 2 ? 1 : 2];
    const double dv[3] = {c[3 * b] - c[3 * a], c[3 * b + 1] - c[3 * a + 1], c[3 * b + 2] - c[3 * a + 2]};
    const double D = std::sqrt(dot3(dv, dv));
    double e[3] = {0.0, 0.0, 1.0};
    if (D > 0.0)
      for (int x = 0; x < 3; ++x) e[x] = dv[x] / D;
    if (distance_to_overlap(c + 3 * p, c + 3 * a, r[a], c + 3 * b, r[b], D, e) < r[p]) return true;
  }
  return false;
}

struct PairwiseWorkspace {
  PairSearch search;
  std::vector<Pair> pairs;
  std::vector<int> adj_start, adj;  // CSR adjacency: neighbours of each sphere
  std::vector<int> pair_of;         // pair index of each adjacency entry
  std::vector<int> mark;            // mark[k] = pair index (j,k) + 1 while scanning j
  std::vector<int> fill;            // fill pointers while building adj
};

// Returns false (and fills t) if three spheres share a region.
inline bool check_no_triple_overlap(const double* c, const double* r, int n, PairwiseWorkspace& w, TripleOverlap& t) {
  t = TripleOverlap();
  const auto& P = w.pairs;
  if (n < 3 || P.size() < 3) return true;
  w.adj_start.assign(n + 1, 0);
  for (const Pair& p : P) {
    ++w.adj_start[p.a + 1];
    ++w.adj_start[p.b + 1];
  }
  for (int i = 0; i < n; ++i) w.adj_start[i + 1] += w.adj_start[i];
  w.adj.resize(2 * P.size());
  w.pair_of.resize(2 * P.size());
  int* fill = filled(w.fill, n, 0);
  for (int i = 0; i < n; ++i) fill[i] = w.adj_start[i];
  for (int q = 0; q < static_cast<int>(P.size()); ++q) {
    const Pair& p = P[q];
    w.adj[fill[p.a]] = p.b;
    w.pair_of[fill[p.a]++] = q;
    w.adj[fill[p.b]] = p.a;
    w.pair_of[fill[p.b]++] = q;
  }
  w.mark.assign(n, -1);
  // triangles i < j < k: for each edge (j, k) with j < k, common neighbours i < j
  for (int j = 0; j < n; ++j) {
    for (int s = w.adj_start[j]; s < w.adj_start[j + 1]; ++s) w.mark[w.adj[s]] = w.pair_of[s];
    for (int s = w.adj_start[j]; s < w.adj_start[j + 1]; ++s) {
      const int k = w.adj[s];
      if (k <= j) continue;
      for (int u = w.adj_start[k]; u < w.adj_start[k + 1]; ++u) {
        const int i = w.adj[u];
        if (i >= j || w.mark[i] < 0) continue;
        if (triple_overlap(c, r, i, j, k)) {
          if (t.count == 0 || std::make_pair(i, std::make_pair(j, k)) < std::make_pair(t.i, std::make_pair(t.j, t.k))) {
            t.i = i;
            t.j = j;
            t.k = k;
          }
          ++t.count;
        }
      }
    }
    for (int s = w.adj_start[j]; s < w.adj_start[j + 1]; ++s) w.mark[w.adj[s]] = -1;
  }
  return t.count == 0;
}

// Returns false if the check finds a triple overlap (t says where); out is then incomplete.
inline bool pairwise_moments(const double* c, const double* r, int n, bool check, Moments& out, PairwiseWorkspace& w,
                             TripleOverlap& t) {
  sum_moments(c, r, n, out);
  auto subtract_lens = [&](const Pair& p) {
    double Vl, pos[3], st, sax;
    lens_moments(r[p.a], r[p.b], c + 3 * p.a, c + 3 * p.b, p.D, p.e, Vl, pos, st, sax);
    out.V -= Vl;
    for (int x = 0; x < 3; ++x) out.S[x] -= Vl * pos[x];
    for (int x = 0; x < 3; ++x)
      for (int y = 0; y < 3; ++y) out.Q[3 * x + y] -= Vl * pos[x] * pos[y] + sax * p.e[x] * p.e[y] + (x == y ? st : 0.0);
  };
  t = TripleOverlap();
  if (n == 2) {  // one pair at most, no triple: no search
    Pair p;
    if (PairSearch::test(c, r, 0, 1, p)) subtract_lens(p);
    return true;
  }
  w.search.overlapping(c, r, n, w.pairs);
  if (check && !check_no_triple_overlap(c, r, n, w, t)) return false;
  for (const Pair& p : w.pairs) subtract_lens(p);
  return true;
}

// ------------------------------------------------------------------ finishing: mass, COM, inertia, principal axes
// Jacobi rotations on a symmetric 3x3 matrix: ascending eigenvalues w, right-handed eigenvector
// columns V (A = V diag(w) V^T).  Accurate to round-off also for (near-)equal eigenvalues.
inline void eigh3(const double* Ain, double* w, double* V) {
  double a[3][3];
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y) a[x][y] = 0.5 * (Ain[3 * x + y] + Ain[3 * y + x]);
  double v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int sweep = 0; sweep < 50; ++sweep) {
    const double off = std::fabs(a[0][1]) + std::fabs(a[0][2]) + std::fabs(a[1][2]);
    if (off == 0.0) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        const double apq = a[p][q];
        const double g = 100.0 * std::fabs(apq);
        // an element below round-off of both diagonal entries is zero (its rotation would not change them)
        if (std::fabs(a[p][p]) + g == std::fabs(a[p][p]) && std::fabs(a[q][q]) + g == std::fabs(a[q][q])) {
          a[p][q] = a[q][p] = 0.0;
          continue;
        }
        if (apq == 0.0) continue;
        const double theta = (a[q][q] - a[p][p]) / (2.0 * apq);
        const double t = (theta >= 0.0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1.0));
        const double cs = 1.0 / std::sqrt(t * t + 1.0), sn = t * cs;
        const double tau = sn / (1.0 + cs);
        a[p][p] -= t * apq;
        a[q][q] += t * apq;
        a[p][q] = a[q][p] = 0.0;
        for (int r = 0; r < 3; ++r) {
          if (r == p || r == q) continue;
          const double arp = a[r][p], arq = a[r][q];
          a[r][p] = a[p][r] = arp - sn * (arq + tau * arp);
          a[r][q] = a[q][r] = arq + sn * (arp - tau * arq);
        }
        for (int r = 0; r < 3; ++r) {
          const double vrp = v[r][p], vrq = v[r][q];
          v[r][p] = vrp - sn * (vrq + tau * vrp);
          v[r][q] = vrq + sn * (vrp - tau * vrq);
        }
      }
  }
  int idx[3] = {0, 1, 2};
  double d[3] = {a[0][0], a[1][1], a[2][2]};
  if (d[idx[0]] > d[idx[1]]) std::swap(idx[0], idx[1]);
  if (d[idx[1]] > d[idx[2]]) std::swap(idx[1], idx[2]);
  if (d[idx[0]] > d[idx[1]]) std::swap(idx[0], idx[1]);
  for (int k = 0; k < 3; ++k) {
    w[k] = d[idx[k]];
    for (int r = 0; r < 3; ++r) V[3 * r + k] = v[r][idx[k]];
  }
  const double det = V[0] * (V[4] * V[8] - V[5] * V[7]) - V[1] * (V[3] * V[8] - V[5] * V[6]) +
                     V[2] * (V[3] * V[7] - V[4] * V[6]);
  if (det < 0.0)
    for (int r = 0; r < 3; ++r) V[3 * r + 2] = -V[3 * r + 2];
}

// Principal moments and axes of a body symmetric about the unit axis e (one sphere, two spheres):
// its inertia is A 1 + B e e^T, so e is an axis with moment e.I.e and every perpendicular direction
// has (tr I - e.I.e)/2.  Closed form, to round-off of I; ascending and right-handed like eigh3.
inline void eigh3_axisymmetric(const double* I, const double* e, double* w, double* V) {
  double Ie[3];
  for (int x = 0; x < 3; ++x) Ie[x] = I[3 * x] * e[0] + I[3 * x + 1] * e[1] + I[3 * x + 2] * e[2];
  const double ax = dot3(e, Ie);
  const double perp = 0.5 * ((I[0] + I[4] + I[8]) - ax);
  double e1[3], e2[3];
  // basis perpendicular to e (as Arrangement::basis)
  double t[3] = {1.0, 0.0, 0.0};
  if (!(std::fabs(e[0]) < 0.9)) {
    t[0] = 0.0;
    t[1] = 1.0;
  }
  const double d = dot3(t, e);
  for (int x = 0; x < 3; ++x) e1[x] = t[x] - d * e[x];
  const double l = std::sqrt(dot3(e1, e1));
  for (int x = 0; x < 3; ++x) e1[x] /= l;
  e2[0] = e[1] * e1[2] - e[2] * e1[1];
  e2[1] = e[2] * e1[0] - e[0] * e1[2];
  e2[2] = e[0] * e1[1] - e[1] * e1[0];
  // columns: (e1, e2, e) is right-handed; ascending order
  const double* cols[3];
  if (ax <= perp) {
    w[0] = ax;
    w[1] = w[2] = perp;
    cols[0] = e;
    cols[1] = e1;
    cols[2] = e2;  // (e, e1, e2) is right-handed too
  } else {
    w[0] = w[1] = perp;
    w[2] = ax;
    cols[0] = e1;
    cols[1] = e2;
    cols[2] = e;
  }
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) V[3 * r + k] = cols[k][r];
}

enum Status : int { kOk = 0, kOverflow = 1, kNonPositiveVolume = 2, kTriple = 3, kBadInput = 4 };

struct Result {
  double mass, volume, com[3], inertia[9], moments[3], axes[9];
  double area;  // surface area of the union (method kExact; NaN for the others)
};

// moments about the clump origin -> mass properties (docs: _properties.finish)
// axis: if not null, the body is symmetric about this unit axis (principal axes in closed form)
inline Status finish(const Moments& m, const double* origin, double density, bool principal, Result& res,
                     const double* axis = nullptr) {
  // all finite, Q * density too: x * 0 is NaN exactly for x = +-inf or NaN, and a sum with a NaN is NaN
  double z = m.V * 0.0;
  for (int x = 0; x < 3; ++x) z += m.S[x] * 0.0;
  for (int x = 0; x < 9; ++x) z += (m.Q[x] * density) * 0.0;
  if (!(z == 0.0)) return kOverflow;
  if (!(m.V > 0.0)) return kNonPositiveVolume;
  double d[3], Qc[9];
  for (int x = 0; x < 3; ++x) d[x] = m.S[x] / m.V;
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y) Qc[3 * x + y] = m.Q[3 * x + y] - m.S[x] * d[y];
  const double tr = (Qc[0] + Qc[4] + Qc[8]) * density;
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y) {
      double I = 0.5 * (Qc[3 * x + y] + Qc[3 * y + x]);
      I *= -density;
      if (x == y) I += tr;
      res.inertia[3 * x + y] = I;
    }
  double zi = 0.0;
  for (int x = 0; x < 9; ++x) zi += res.inertia[x] * 0.0;
  if (!(zi == 0.0)) return kOverflow;
  for (int x = 0; x < 3; ++x) res.com[x] = origin[x] + d[x];
  res.mass = density * m.V;
  res.volume = m.V;
  if (principal) {
    if (axis)
      eigh3_axisymmetric(res.inertia, axis, res.moments, res.axes);
    else
      eigh3(res.inertia, res.moments, res.axes);
  }
  return kOk;
}

// Clump origin: volume-weighted mean of the sphere centres, accumulated relative to the first
// sphere; rel receives the centres relative to it.
inline bool clump_origin(const double* c, const double* r, int n, double* origin, double* rel) {
  double s = 0.0, acc[3] = {0.0, 0.0, 0.0};
  for (int i = 0; i < n; ++i) {
    if (!(r[i] > 0.0) || !std::isfinite(r[i])) return false;
    for (int x = 0; x < 3; ++x)
      if (!std::isfinite(c[3 * i + x])) return false;
    s += r[i] * r[i] * r[i];
  }
  for (int i = 0; i < n; ++i) {
    const double wgt = r[i] * r[i] * r[i] / s;
    for (int x = 0; x < 3; ++x) acc[x] += wgt * (c[3 * i + x] - c[x]);
  }
  for (int x = 0; x < 3; ++x) origin[x] = c[x] + acc[x];
  for (int i = 0; i < n; ++i)
    for (int x = 0; x < 3; ++x) rel[3 * i + x] = c[3 * i + x] - origin[x];
  return true;
}

enum Method : int { kExact = 0, kPairwise = 1, kSum = 2 };

// Two spheres, pairwise (with_lens) or summed: the body is symmetric about the line of centres e, so
// its central second moments are C_ax e e^T + C_t (1 - e e^T) and reduce to scalars along that line,
// taken about the centre of mass (closed form; no 3x3 accumulation, no eigen-solver).  The same
// lens (lens_moments) and overlap test (D < r_a + r_b) as pairwise_moments.
inline Status dimer_axisymmetric(bool with_lens, const double* c, const double* r, double density, bool principal,
                                 Result& res) {
  for (int i = 0; i < 2; ++i) {
    if (!(r[i] > 0.0) || !std::isfinite(r[i])) return kBadInput;
    for (int x = 0; x < 3; ++x)
      if (!std::isfinite(c[3 * i + x])) return kBadInput;
  }
  const double dx = c[3] - c[0], dy = c[4] - c[1], dz = c[5] - c[2];
  const double D = std::sqrt(dx * dx + dy * dy + dz * dz);
  double e[3] = {0.0, 0.0, 1.0};
  if (D > 0.0) {
    e[0] = dx / D;
    e[1] = dy / D;
    e[2] = dz / D;
  }
  const double ra = r[0], rb = r[1];
  const double Va = (4.0 / 3.0) * kPi * ra * ra * ra, Vb = (4.0 / 3.0) * kPi * rb * rb * rb;
  const double ia = Va * ra * ra / 5.0, ib = Vb * rb * rb / 5.0;  // a ball's own second moment, every direction
  // parts along the axis from c_a: ball a at 0, ball b at D, minus the lens at sl
  double V = Va + Vb, S = Vb * D, Vl = 0.0, sl = 0.0, lt = 0.0, lax = 0.0;
  if (with_lens && D < ra + rb) {
    const double o[3] = {0.0, 0.0, 0.0}, cb[3] = {D, 0.0, 0.0}, ex[3] = {1.0, 0.0, 0.0};
    double pos[3], sig_t, sig_ax;
    lens_moments(ra, rb, o, cb, D, ex, Vl, pos, sig_t, sig_ax);
    sl = pos[0];
    lt = sig_t;
    lax = sig_t + sig_ax;
    V -= Vl;
    S -= Vl * sl;
  }
  const double s = S / V;  // centre of mass along the axis
  const double C_t = ia + ib - lt;
  const double C_ax = (ia + Va * s * s) + (ib + Vb * (D - s) * (D - s)) - (lax + Vl * (sl - s) * (sl - s));
  const double I_ax = 2.0 * C_t * density, I_perp = (C_ax + C_t) * density;
  const double diff = I_ax - I_perp;
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y) res.inertia[3 * x + y] = (x == y ? I_perp : 0.0) + diff * e[x] * e[y];
  for (int x = 0; x < 3; ++x) res.com[x] = c[x] + s * e[x];
  res.mass = density * V;
  res.volume = V;
  double z = V * 0.0 + res.mass * 0.0 + (C_ax * density) * 0.0 + I_ax * 0.0 + I_perp * 0.0;
  for (int x = 0; x < 3; ++x) z += res.com[x] * 0.0;
  for (int x = 0; x < 9; ++x) z += res.inertia[x] * 0.0;
  if (!(z == 0.0)) return kOverflow;
  if (!(V > 0.0)) return kNonPositiveVolume;
  if (principal) eigh3_axisymmetric(res.inertia, e, res.moments, res.axes);
  return kOk;
}

// One clump from world coordinates to mass properties.
struct Engine {
  ExactWorkspace ex;
  PairwiseWorkspace pw;
  std::vector<double> rel;
  Moments mom;
  double origin[3];
  TripleOverlap triple;

  Status clump(Method method, const double* c, const double* r, int n, double density, bool principal, Result& res,
               bool check = true) {
    res.area = std::numeric_limits<double>::quiet_NaN();
    if (n == 2 && method != kExact) return dimer_axisymmetric(method == kPairwise, c, r, density, principal, res);
    rel.resize(3 * static_cast<std::size_t>(n));
    if (n <= 0 || !clump_origin(c, r, n, origin, rel.data())) return kBadInput;
    switch (method) {
      case kExact:
        exact_moments(rel.data(), r, n, mom, ex);
        break;
      case kPairwise:
        if (!pairwise_moments(rel.data(), r, n, check, mom, pw, triple)) return kTriple;
        break;
      default:
        sum_moments(rel.data(), r, n, mom);
    }
    // one sphere or two: symmetric about the line of centres
    const double* axis = nullptr;
    double e[3] = {0.0, 0.0, 1.0};
    if (n <= 2) {
      if (n == 2) {
        const double dx = c[3] - c[0], dy = c[4] - c[1], dz = c[5] - c[2];
        const double D = std::sqrt(dx * dx + dy * dy + dz * dz);
        if (D > 0.0) {
          e[0] = dx / D;
          e[1] = dy / D;
          e[2] = dz / D;
        }
      }
      axis = e;
    }
    if (method == kExact) res.area = mom.A;
    return finish(mom, origin, density, principal, res, axis);
  }
};

}  // namespace clumpprops
