#include "dynfilter/core/hull_contacts.hpp"

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
  const Eigen::Vector3d t1 = contactTangent(n, X_WB.linear().col(0));
  const Eigen::Vector3d t2 = n.cross(t1);
  std::array<Eigen::Vector3d, kMaxHullGroundContacts> direction;
  for (int k = 0; k < kMaxHullGroundContacts; ++k) {
    const double a = k * (2.0 * M_PI / kMaxHullGroundContacts);
    direction[static_cast<std::size_t>(k)] = std::cos(a) * t1 + std::sin(a) * t2;
  }
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

}  // namespace dynfilter
