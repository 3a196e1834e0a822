#include "dynfilter/core/ground_contacts.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

namespace dynfilter {
namespace {

// Extremes closer than this count as a tie, won by the lower vertex index, so that two
// engines' poses that differ by round-off pick the same vertex.
constexpr double kTieM = 1e-9;

using Directions = std::array<Eigen::Vector3d, kMaxHullGroundContacts>;

// The eight directions of the plane with normal n: the body's x axis projected onto it,
// turned by multiples of 45°.
Directions planeDirections(const Eigen::Vector3d& n, const Eigen::Vector3d& x_W) {
  const Eigen::Vector3d t1 = contactTangent(n, x_W);
  const Eigen::Vector3d t2 = n.cross(t1);
  Directions d;
  for (int k = 0; k < kMaxHullGroundContacts; ++k) {
    const double a = k * (2.0 * M_PI / kMaxHullGroundContacts);
    d[static_cast<std::size_t>(k)] = std::cos(a) * t1 + std::sin(a) * t2;
  }
  return d;
}

// Whether @p p beats @p best along @p d: farther by more than kTieM, or as far and deeper.
bool beats(const Eigen::Vector3d& p, const Eigen::Vector3d& best, const Eigen::Vector3d& d,
           const GroundPlane& ground) {
  const double ahead = d.dot(p) - d.dot(best);
  if (ahead > kTieM) return true;
  return ahead >= -kTieM && ground.signedDistance(p) < ground.signedDistance(best) - kTieM;
}

// Offers the points of the circle (centre e, unit radius directions x, y spanning its
// plane, radius r) on or below @p ground that can be farthest along @p d: the unconstrained
// farthest point when it is below, else the ends of the arc below, and the deepest point
// (it wins ties, e.g. along a cylinder's axis).
void offerRim(const Eigen::Vector3d& e, const Eigen::Vector3d& x, const Eigen::Vector3d& y, double r,
              const GroundPlane& ground, const Eigen::Vector3d& d, bool& found, Eigen::Vector3d& best) {
  const auto at = [&](double theta) { return Eigen::Vector3d(e + r * (std::cos(theta) * x + std::sin(theta) * y)); };
  const auto offer = [&](const Eigen::Vector3d& p) {
    if (!found || beats(p, best, d, ground)) best = p;
    found = true;
  };
  // n·p(θ) − offset = h + r ρ cos(θ − φ).
  const double h = ground.signedDistance(e);
  const double alpha = ground.n_W.dot(x), beta = ground.n_W.dot(y), rho = std::hypot(alpha, beta);
  const double farthest = std::atan2(d.dot(y), d.dot(x));
  if (r * rho <= 1e-12) {  // a level rim: all of it or none of it is below
    if (h <= 0.0) offer(at(farthest));
    return;
  }
  const double c = -h / (r * rho);  // below ⟺ cos(θ − φ) ≤ c
  if (c < -1.0) return;
  const double phi = std::atan2(beta, alpha);
  offer(at(phi + M_PI));  // the deepest point
  if (c >= 1.0) {
    offer(at(farthest));
    return;
  }
  const double gamma = std::acos(c);  // below: θ − φ ∈ [γ, 2π − γ]
  double from_phi = std::remainder(farthest - phi, 2.0 * M_PI);
  if (from_phi < 0.0) from_phi += 2.0 * M_PI;
  if (from_phi >= gamma && from_phi <= 2.0 * M_PI - gamma) offer(at(farthest));
  offer(at(phi + gamma));
  offer(at(phi - gamma));
}

}  // namespace

BodyHull BodyHull::make(int body, const Eigen::Isometry3d& X_BS, Eigen::Matrix3Xd p_SV) {
  if (p_SV.cols() == 0) throw std::invalid_argument("BodyHull: no vertices");
  if (!p_SV.allFinite()) throw std::invalid_argument("BodyHull: non-finite vertex");
  BodyHull h;
  h.body = body;
  h.X_BS = X_BS;
  const Eigen::Vector3d lo = p_SV.rowwise().minCoeff(), hi = p_SV.rowwise().maxCoeff();
  h.p_SCenter = 0.5 * (lo + hi);
  h.radius_m = (p_SV.colwise() - h.p_SCenter).colwise().norm().maxCoeff();
  h.p_SV = std::move(p_SV);
  return h;
}

int appendHullGroundContacts(const BodyHull& hull, const Eigen::Isometry3d& X_WB,
                             const GroundPlane& ground, ContactList& out) {
  const Eigen::Isometry3d X_WS = X_WB * hull.X_BS;
  if (ground.signedDistance(X_WS * hull.p_SCenter) > hull.radius_m) return 0;
  const Eigen::Vector3d& n = ground.n_W;
  const Directions direction = planeDirections(n, X_WB.linear().col(0));
  std::array<int, kMaxHullGroundContacts> best;
  std::array<double, kMaxHullGroundContacts> reach;
  best.fill(-1);
  reach.fill(-std::numeric_limits<double>::infinity());
  for (Eigen::Index i = 0; i < hull.p_SV.cols(); ++i) {
    const Eigen::Vector3d p_WV = X_WS * hull.p_SV.col(i);
    if (ground.signedDistance(p_WV) > 0.0) continue;
    for (std::size_t k = 0; k < direction.size(); ++k) {
      const double s = direction[k].dot(p_WV);
      if (s > reach[k] + kTieM) {
        reach[k] = s;
        best[k] = static_cast<int>(i);
      }
    }
  }
  int added = 0;
  for (std::size_t k = 0; k < best.size(); ++k) {
    if (best[k] < 0) continue;
    bool seen = false;
    for (std::size_t j = 0; j < k; ++j) seen = seen || best[j] == best[k];
    if (seen) continue;
    ContactCandidate c;
    c.body = hull.body;
    c.object = kGroundObject;
    c.p_WC = X_WS * hull.p_SV.col(best[k]);
    c.p_BC = hull.X_BS * hull.p_SV.col(best[k]);
    c.n_W = n;
    c.depth_m = -ground.signedDistance(c.p_WC);
    if (out.push(c)) ++added;
  }
  return added;
}

int appendCylinderGroundContacts(const BodyCylinder& cylinder, const Eigen::Isometry3d& X_WB,
                                 const GroundPlane& ground, ContactList& out) {
  const Eigen::Isometry3d X_WS = X_WB * cylinder.X_BS;
  const double r = cylinder.radius_m, half = 0.5 * cylinder.length_m;
  if (ground.signedDistance(X_WS.translation()) > std::hypot(r, half)) return 0;
  const Eigen::Vector3d x = X_WS.linear().col(0), y = X_WS.linear().col(1), a = X_WS.linear().col(2);
  const Directions direction = planeDirections(ground.n_W, X_WB.linear().col(0));
  std::array<Eigen::Vector3d, kMaxHullGroundContacts> chosen;
  int count = 0;
  for (const Eigen::Vector3d& d : direction) {
    bool found = false;
    Eigen::Vector3d best = Eigen::Vector3d::Zero();
    for (const double side : {-1.0, 1.0})
      offerRim(X_WS.translation() + side * half * a, x, y, r, ground, d, found, best);
    if (!found) continue;
    bool seen = false;
    for (int j = 0; j < count; ++j) seen = seen || (chosen[static_cast<std::size_t>(j)] - best).norm() < kTieM;
    if (!seen) chosen[static_cast<std::size_t>(count++)] = best;
  }
  int added = 0;
  const Eigen::Isometry3d X_BW = X_WB.inverse();
  for (int j = 0; j < count; ++j) {
    ContactCandidate c;
    c.body = cylinder.body;
    c.object = kGroundObject;
    c.p_WC = chosen[static_cast<std::size_t>(j)];
    c.p_BC = X_BW * c.p_WC;
    c.n_W = ground.n_W;
    c.depth_m = std::max(0.0, -ground.signedDistance(c.p_WC));
    if (out.push(c)) ++added;
  }
  return added;
}

int appendGroundContacts(const GroundContactShapes& shapes, const IDynamicsModel& model,
                         const GroundPlane& ground, ContactList& out) {
  int added = 0;
  for (const BodyHull& hull : shapes.hulls)
    added += appendHullGroundContacts(hull, model.bodyPose(hull.body), ground, out);
  for (const BodyCylinder& cylinder : shapes.cylinders)
    added += appendCylinderGroundContacts(cylinder, model.bodyPose(cylinder.body), ground, out);
  return added;
}

}  // namespace dynfilter
