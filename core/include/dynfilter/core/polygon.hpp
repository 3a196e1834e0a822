#pragma once
/// @file
/// Convex polygons in a plane (support polygons): the hull of a point set and the nearest
/// point of a hull. Fixed-capacity arrays, no allocation (usable on the per-tick path).

#include <algorithm>
#include <array>
#include <cstddef>

#include <Eigen/Core>

namespace dynfilter::polygon {

/// z of (a − o) × (b − o): > 0 when o, a, b turn counter-clockwise.
inline double cross2(const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

/// Convex hull (counter-clockwise, collinear points dropped) of points[0, n) into @p hull;
/// returns its size, at most M. Sorts @p points in place.
template <std::size_t N, std::size_t M>
int convexHull(std::array<Eigen::Vector2d, N>& points, int n, std::array<Eigen::Vector2d, M>& hull) {
  n = std::min(n, static_cast<int>(N));
  if (n <= 0) return 0;
  std::sort(points.begin(), points.begin() + n, [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  if (n == 1) {
    hull[0] = points[0];
    return 1;
  }
  std::array<Eigen::Vector2d, 2 * N> h;
  int k = 0;
  for (int i = 0; i < n; ++i) {
    while (k >= 2 && cross2(h[k - 2], h[k - 1], points[i]) <= 1e-12) --k;
    h[k++] = points[i];
  }
  for (int i = n - 2, t = k + 1; i >= 0; --i) {
    while (k >= t && cross2(h[k - 2], h[k - 1], points[i]) <= 1e-12) --k;
    h[k++] = points[i];
  }
  const int size = std::min<int>(std::max(k - 1, 1), static_cast<int>(M));
  for (int i = 0; i < size; ++i) hull[i] = h[i];
  return size;
}

/// The point of the convex polygon hull[0, n) (counter-clockwise) nearest to @p p: p itself
/// when inside; p when n is 0.
template <std::size_t M>
Eigen::Vector2d clampToHull(const Eigen::Vector2d& p, const std::array<Eigen::Vector2d, M>& hull, int n) {
  if (n <= 0) return p;
  if (n == 1) return hull[0];
  bool inside = n >= 3;
  for (int i = 0; i < n && inside; ++i) inside = cross2(hull[i], hull[(i + 1) % n], p) >= 0.0;
  if (inside) return p;
  Eigen::Vector2d best = hull[0];
  double best_d = (p - best).squaredNorm();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d a = hull[i], e = hull[(i + 1) % n] - a;
    const double s = std::clamp(e.dot(p - a) / std::max(e.squaredNorm(), 1e-18), 0.0, 1.0);
    const Eigen::Vector2d x = a + s * e;
    const double d = (p - x).squaredNorm();
    if (d < best_d) {
      best_d = d;
      best = x;
    }
  }
  return best;
}

}  // namespace dynfilter::polygon
