// Event-driven molecular dynamics of identical elastic hard spheres in a periodic cubic box.
//
// A second engine for the sphere gas (studies/hard_sphere_md.py, docs/kinetic_theory.md):
// the N-body periodic gas with every correlation the Boltzmann equation leaves out (Enskog's
// excluded volume, ring and three-body collisions, recollisions through the periodic images),
// integrated exactly: free flight between collisions, the elastic hard-sphere collision rule
// (equal masses: the normal components of the two velocities are exchanged), events in time order.
//
// Algorithm (Rapaport, "The art of molecular dynamics simulation", ch. 14; Alder & Wainwright
// 1959): a cubic cell grid of side >= sigma, each particle's next event (its earliest collision
// with a particle of the 27 neighbouring cells, or its crossing into the next cell, whichever is
// first) in a priority queue with lazy invalidation (a per-particle stamp for superseded events, a
// per-particle collision counter for partners that collided since the prediction).  Positions are
// kept unwrapped and advanced lazily; the cell of a particle is an integer triple updated at its
// crossings (never recomputed from a rounded position).
//
// C ABI for ctypes (no Python headers, no pybind11: studies/hard_sphere_md.py compiles it with g++ on first use).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <queue>
#include <vector>

namespace {

const double INF = std::numeric_limits<double>::infinity();

struct Event {
    double t;
    int i;
    std::uint32_t stamp;
    int partner;            // >= 0: collision with partner; -1 - axis*2 - (dir>0): crossing
    std::int64_t pcount;    // the partner's collision count at prediction
    bool operator>(const Event& o) const { return t > o.t; }
};

struct Gas {
    int n, nc;
    double box, sigma, sig2, cell;
    double t = 0.0;
    std::vector<double> x, v, tl;          // unwrapped positions at their own times tl, velocities
    std::vector<std::int64_t> ic;          // unwrapped integer cell coordinates (3 per particle)
    std::vector<std::int64_t> count;       // collisions per particle
    std::vector<std::uint32_t> stamp;
    std::vector<std::vector<int>> members; // particles per cell
    std::vector<int> slot;                 // index of a particle in its cell's member list
    std::priority_queue<Event, std::vector<Event>, std::greater<Event>> queue;
    std::int64_t n_coll = 0;

    static int wrap(std::int64_t k, int m) { int r = static_cast<int>(k % m); return r < 0 ? r + m : r; }
    int cell_of(int i) const {
        return (wrap(ic[3 * i], nc) * nc + wrap(ic[3 * i + 1], nc)) * nc + wrap(ic[3 * i + 2], nc);
    }
    void add(int i) { auto& m = members[cell_of(i)]; slot[i] = static_cast<int>(m.size()); m.push_back(i); }
    void remove(int i) {
        auto& m = members[cell_of(i)];
        int last = m.back();
        m[slot[i]] = last;
        slot[last] = slot[i];
        m.pop_back();
    }
    template <class F>
    void for_neighbours(int i, F f) const {   // f(j) for every particle j of the 27 cells around i's (i too)
        int cx = wrap(ic[3 * i], nc), cy = wrap(ic[3 * i + 1], nc), cz = wrap(ic[3 * i + 2], nc);
        for (int a = -1; a <= 1; ++a)
            for (int b = -1; b <= 1; ++b)
                for (int c = -1; c <= 1; ++c)
                    for (int j : members[(wrap(cx + a, nc) * nc + wrap(cy + b, nc)) * nc + wrap(cz + c, nc)]) f(j);
    }
    void advance(int i) {                  // bring particle i to the current time
        double dt = t - tl[i];
        if (dt != 0.0) {
            for (int k = 0; k < 3; ++k) x[3 * i + k] += v[3 * i + k] * dt;
            tl[i] = t;
        }
    }
    // time from now to the collision of i and j (both advanced to now), INF if none
    double collision_time(int i, int j) const {
        double dr[3], dv[3], b = 0.0, dv2 = 0.0, r2 = 0.0;
        for (int k = 0; k < 3; ++k) {
            double xi = x[3 * i + k] + v[3 * i + k] * (t - tl[i]);
            double xj = x[3 * j + k] + v[3 * j + k] * (t - tl[j]);
            double d = xi - xj;
            d -= box * std::nearbyint(d / box);
            dr[k] = d;
            dv[k] = v[3 * i + k] - v[3 * j + k];
            b += dr[k] * dv[k];
            dv2 += dv[k] * dv[k];
            r2 += dr[k] * dr[k];
        }
        if (b >= 0.0) return INF;          // separating (or at rest relative to each other)
        double c = r2 - sig2;
        if (c <= 0.0) return 0.0;          // touching and approaching (round-off): collide now
        double disc = b * b - dv2 * c;
        if (disc <= 0.0) return INF;       // miss
        return c / (-b + std::sqrt(disc));
    }
    void predict(int i) {
        advance(i);
        double best = INF;
        int partner = -1;
        // the crossing out of the current cell, axis by axis
        for (int k = 0; k < 3; ++k) {
            double vk = v[3 * i + k];
            if (vk == 0.0) continue;
            double wall = (vk > 0.0 ? ic[3 * i + k] + 1 : ic[3 * i + k]) * cell;
            double dtk = std::max(0.0, (wall - x[3 * i + k]) / vk);
            if (dtk < best) { best = dtk; partner = -1 - 2 * k - (vk > 0.0 ? 1 : 0); }
        }
        for_neighbours(i, [&](int j) {
            if (j == i) return;
            double tc = collision_time(i, j);
            if (tc < best) { best = tc; partner = j; }
        });
        ++stamp[i];
        if (best < INF)
            queue.push(Event{t + best, i, stamp[i], partner, partner >= 0 ? count[partner] : 0});
    }
    void collide(int i, int j) {
        advance(i);
        advance(j);
        double dr[3], r2 = 0.0, dvn = 0.0;
        for (int k = 0; k < 3; ++k) {
            double d = x[3 * i + k] - x[3 * j + k];
            d -= box * std::nearbyint(d / box);
            dr[k] = d;
            r2 += d * d;
        }
        for (int k = 0; k < 3; ++k) dvn += (v[3 * i + k] - v[3 * j + k]) * dr[k];
        dvn /= r2;                          // (dv . dr) / |dr|^2: exchange the normal components
        for (int k = 0; k < 3; ++k) {
            v[3 * i + k] -= dvn * dr[k];
            v[3 * j + k] += dvn * dr[k];
        }
        ++count[i];
        ++count[j];
        ++n_coll;
    }
    void cross(int i, int code) {
        advance(i);
        int k = (-1 - code) / 2, dir = ((-1 - code) % 2) ? 1 : -1;
        remove(i);
        ic[3 * i + k] += dir;
        add(i);
    }
    // process every event up to time t_stop (inclusive), then set the clock to t_stop
    void run_until(double t_stop) {
        while (!queue.empty() && queue.top().t <= t_stop) {
            Event e = queue.top();
            queue.pop();
            if (e.stamp != stamp[e.i]) continue;
            t = e.t;
            if (e.partner >= 0) {
                if (count[e.partner] != e.pcount) { predict(e.i); continue; }
                collide(e.i, e.partner);
                predict(e.i);
                predict(e.partner);
            } else {
                cross(e.i, e.partner);
                predict(e.i);
            }
        }
        t = t_stop;
    }
    double min_gap() const {               // min over pairs in neighbouring cells of |dr| / sigma - 1
        double g = INF;
        for (int i = 0; i < n; ++i)
            for_neighbours(i, [&](int j) {
                if (j <= i) return;
                double r2 = 0.0;
                for (int k = 0; k < 3; ++k) {
                    double d = (x[3 * i + k] + v[3 * i + k] * (t - tl[i])) - (x[3 * j + k] + v[3 * j + k] * (t - tl[j]));
                    d -= box * std::nearbyint(d / box);
                    r2 += d * d;
                }
                g = std::min(g, std::sqrt(r2) / sigma - 1.0);
            });
        return g;
    }
};

}  // namespace

extern "C" {

// Run the gas from (pos0, vel0) (n x 3, m and m/s; positions anywhere, taken modulo the box) and
// record it at n_frames frames t = 0, frame_dt, 2 frame_dt, ...: unwrapped positions into pos_out
// and velocities into vel_out (n_frames x n x 3 each).  n_cells: cells per side (box / n_cells >=
// sigma, and >= 4: two particles in neighbouring cells are then at most half the box apart along
// each axis, so the minimum image is the neighbouring one; with 3 it may be another image).  With check_gaps != 0, min_gap_out receives the smallest |r_ij| / sigma - 1
// seen over the frames.  n_coll_out: the number of collisions.  Returns 0, or
// -1 bad arguments, -2 overlapping start.
int hsmd_run(int n, double box, double sigma, int n_cells, const double* pos0, const double* vel0,
             int n_frames, double frame_dt, double* pos_out, double* vel_out, int check_gaps,
             double* min_gap_out, long long* n_coll_out) {
    if (n < 2 || !(box > 0.0) || !(sigma > 0.0) || n_cells < 4 || box / n_cells < sigma || n_frames < 1 ||
        !(frame_dt > 0.0))
        return -1;
    Gas g;
    g.n = n;
    g.nc = n_cells;
    g.box = box;
    g.sigma = sigma;
    g.sig2 = sigma * sigma;
    g.cell = box / n_cells;
    g.x.assign(3 * n, 0.0);
    g.v.assign(vel0, vel0 + 3 * n);
    g.tl.assign(n, 0.0);
    g.ic.assign(3 * n, 0);
    g.count.assign(n, 0);
    g.stamp.assign(n, 0);
    g.members.assign(static_cast<size_t>(n_cells) * n_cells * n_cells, std::vector<int>());
    g.slot.assign(n, 0);
    for (int i = 0; i < n; ++i) {
        for (int k = 0; k < 3; ++k) {
            double p = pos0[3 * i + k] - box * std::floor(pos0[3 * i + k] / box);
            std::int64_t c = static_cast<std::int64_t>(std::floor(p / g.cell));
            if (c >= n_cells) c = n_cells - 1;
            g.x[3 * i + k] = p;
            g.ic[3 * i + k] = c;
        }
        g.add(i);
    }
    double gap0 = g.min_gap();
    if (gap0 < 0.0) return -2;
    double gap = gap0;
    for (int i = 0; i < n; ++i) g.predict(i);
    for (int f = 0; f < n_frames; ++f) {
        g.run_until(f * frame_dt);
        double* po = pos_out + static_cast<size_t>(f) * 3 * n;
        double* vo = vel_out + static_cast<size_t>(f) * 3 * n;
        for (int i = 0; i < n; ++i)
            for (int k = 0; k < 3; ++k) {
                po[3 * i + k] = g.x[3 * i + k] + g.v[3 * i + k] * (g.t - g.tl[i]);
                vo[3 * i + k] = g.v[3 * i + k];
            }
        if (check_gaps) gap = std::min(gap, g.min_gap());
    }
    if (min_gap_out) *min_gap_out = gap;
    if (n_coll_out) *n_coll_out = g.n_coll;
    return 0;
}

}  // extern "C"
