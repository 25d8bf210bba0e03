#include "mpm/detect/loop_classes.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "mpm/core/particle_bins.hpp"
#include "mpm/core/polygon.hpp"
#include "mpm/detect/detect_internal.hpp"

namespace pfm {

const char* loop_class_name(LoopClass c) {
  switch (c) {
    case LoopClass::kBody:
      return "body";
    case LoopClass::kIsland:
      return "island";
    case LoopClass::kSpuriousLoop:
      return "spurious_loop";
    case LoopClass::kSpuriousIsland:
      return "spurious_island";
    case LoopClass::kRealHole:
      return "real_hole";
    case LoopClass::kSpuriousHole:
      return "spurious_hole";
  }
  return "";
}

namespace {

double distance_to_polygon(const std::vector<Vec2>& p, const Vec2& x) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < p.size(); ++k) {
    const Vec2& a = p[k];
    const Vec2 d = p[(k + 1) % p.size()] - a;
    const double t = std::clamp((x - a).dot(d) / std::max(d.squaredNorm(), 1e-300), 0.0, 1.0);
    best = std::min(best, (a + t * d - x).norm());
  }
  return best;
}

void bounding_box(const std::vector<Vec2>& p, Vec2& lo, Vec2& hi) {
  lo = hi = p.front();
  for (const Vec2& x : p) {
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
}

}  // namespace

LoopClasses classify_loops(const DetectedBoundary& boundary, std::span<const Vec2> particles,
                           double spacing) {
  LoopClasses out;
  const std::size_t n_loops = boundary.contours.size();
  out.of_loop.assign(n_loops, LoopClass::kIsland);
  if (n_loops == 0) return out;
  const ParticleBins bins(particles, spacing);
  const double radius = 0.5 * spacing;
  std::size_t body = n_loops;
  std::vector<std::vector<int>> held(n_loops);           // the particles inside each island
  std::vector<std::pair<double, std::size_t>> material;  // (area, loop) of the closed ones
  for (std::size_t c = 0; c < n_loops; ++c) {
    const Contour& contour = boundary.contours[c];
    if (!contour.closed || contour.points.size() < 3) {
      out.of_loop[c] = LoopClass::kBody;  // an open chain bounds the material on the grid edge
      continue;
    }
    const std::vector<Vec2>& p = contour.points;
    Vec2 lo, hi;
    bounding_box(p, lo, hi);
    const double area = polygon_signed_area(p);
    if (area > 0.0) {
      material.emplace_back(area, c);
      continue;
    }
    // A hole: look for a free disk's centre on a lattice of a quarter spacing, from the middle of
    // the hole's box outwards (where a free disk most likely is: a real hole is then found after
    // a few centres, each of which costs two passes over the loop's points).
    bool real = false;
    const double step = 0.25 * spacing;
    const Vec2 first = lo + Vec2::Constant(radius);
    const int n_x = static_cast<int>(std::floor((hi.x() - radius - first.x()) / step)) + 1;
    const int n_y = static_cast<int>(std::floor((hi.y() - radius - first.y()) / step)) + 1;
    const auto middle_out = [](int k, int n) {
      return n / 2 + (k % 2 == 0 ? k / 2 : -(k + 1) / 2);
    };
    for (int b = 0; b < n_y && !real; ++b) {
      for (int a = 0; a < n_x && !real; ++a) {
        const Vec2 centre = first + step * Vec2(middle_out(a, n_x), middle_out(b, n_y));
        if (!point_in_polygon(p, centre) || distance_to_polygon(p, centre) < radius) continue;
        bool free = true;
        bins.for_each_slot_in_box(
            centre - Vec2::Constant(radius), centre + Vec2::Constant(radius), [&](int k) {
              const Vec2& q = particles[static_cast<std::size_t>(bins.particle_at(k))];
              if ((q - centre).norm() < radius) free = false;
            });
        real = free;
      }
    }
    out.of_loop[c] = real ? LoopClass::kRealHole : LoopClass::kSpuriousHole;
  }
  // Material loops by decreasing area: the first that holds a particle is the body, for which
  // one particle found is enough (it may hold the whole cloud); the others list theirs.
  std::stable_sort(material.begin(), material.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  for (const auto& [area, c] : material) {
    const std::vector<Vec2>& p = boundary.contours[c].points;
    Vec2 lo, hi;
    bounding_box(p, lo, hi);
    const bool first = body == n_loops;
    bool found = false;
    // A copy of the binding for the lambda (clang 14, which make fuzz uses, cannot capture one).
    const auto loop = c;
    bins.for_each_slot_in_box(lo, hi, [&](int k) {
      if (first && found) return;
      const int q = bins.particle_at(k);
      const Vec2& x = particles[static_cast<std::size_t>(q)];
      if (x.x() >= lo.x() && x.x() <= hi.x() && x.y() >= lo.y() && x.y() <= hi.y() &&
          point_in_polygon(p, x)) {
        found = true;
        if (!first) held[loop].push_back(q);
      }
    });
    if (!found) {
      out.of_loop[c] = LoopClass::kSpuriousLoop;
    } else if (first) {
      body = c;
      out.of_loop[c] = LoopClass::kBody;
    }
  }
  // An island whose points touch the points of the rest (closer than kContactSpacings) has
  // not separated: the field split material in contact (a row of points, a thin neck).
  std::vector<char> mine(particles.size(), 0);
  const double contact = kContactSpacings * spacing;
  std::vector<std::size_t> outside;
  for (std::size_t c = 0; c < n_loops; ++c) {
    if (out.of_loop[c] != LoopClass::kIsland || !boundary.contours[c].closed) continue;
    std::sort(held[c].begin(), held[c].end());
    for (const int q : held[c]) mine[static_cast<std::size_t>(q)] = 1;
    bool touches = false;
    for (const int q : held[c]) {
      const Vec2& x = particles[static_cast<std::size_t>(q)];
      outside.clear();
      bins.for_each_slot_in_box(x - Vec2::Constant(contact), x + Vec2::Constant(contact),
                                [&](int k) {
                                  const auto r = static_cast<std::size_t>(bins.particle_at(k));
                                  if (!mine[r] && (particles[r] - x).norm() < contact)
                                    outside.push_back(r);
                                });
      std::sort(outside.begin(), outside.end());
      for (const std::size_t r : outside) out.contacts.push_back({static_cast<std::size_t>(q), r});
      touches = touches || !outside.empty();
    }
    for (const int q : held[c]) mine[static_cast<std::size_t>(q)] = 0;
    if (touches) out.of_loop[c] = LoopClass::kSpuriousIsland;
  }
  for (const LoopClass c : out.of_loop) {
    out.bodies += c == LoopClass::kBody;
    out.islands += c == LoopClass::kIsland;
    out.spurious_loops += c == LoopClass::kSpuriousLoop;
    out.spurious_islands += c == LoopClass::kSpuriousIsland;
    out.real_holes += c == LoopClass::kRealHole;
    out.spurious_holes += c == LoopClass::kSpuriousHole;
  }
  return out;
}

}  // namespace pfm

namespace pfm::detail {

std::vector<std::array<std::size_t, 2>> bridge_pairs(std::span<const Vec2> positions,
                                                     std::span<const std::size_t> left_out,
                                                     const LoopClasses& classes, double spacing) {
  std::vector<std::array<std::size_t, 2>> pairs = classes.contacts;
  if (!left_out.empty()) {
    const double contact = kContactSpacings * spacing;
    const ParticleBins bins(positions, contact);
    for (const std::size_t p : left_out) {
      bins.for_each_near(positions[p], [&](int q) {
        const auto r = static_cast<std::size_t>(q);
        if (r != p && (positions[r] - positions[p]).norm() < contact) pairs.push_back({p, r});
      });
    }
  }
  for (auto& pair : pairs) {
    if (pair[0] > pair[1]) std::swap(pair[0], pair[1]);
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

long remove_spurious_loops(DetectedBoundary& boundary, const LoopClasses& classes) {
  const std::size_t n = boundary.contours.size();
  std::vector<char> drop(n, 0);
  for (std::size_t c = 0; c < n; ++c) {
    if (classes.of_loop[c] == LoopClass::kSpuriousLoop) drop[c] = 1;
    if (classes.of_loop[c] != LoopClass::kSpuriousHole) continue;
    drop[c] = 1;
    // Loops do not cross: one inside the hole has all its points, the first among them, inside.
    const std::vector<Vec2>& hole = boundary.contours[c].points;
    for (std::size_t d = 0; d < n; ++d) {
      if (d != c && boundary.contours[d].closed && !boundary.contours[d].points.empty() &&
          point_in_polygon(hole, boundary.contours[d].points.front())) {
        drop[d] = 1;
      }
    }
  }
  long removed = 0;
  std::vector<Contour> kept;
  for (std::size_t c = 0; c < n; ++c) {
    if (drop[c]) {
      ++removed;
    } else {
      kept.push_back(std::move(boundary.contours[c]));
    }
  }
  boundary.contours = std::move(kept);
  return removed;
}

}  // namespace pfm::detail
