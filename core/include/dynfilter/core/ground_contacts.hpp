#pragma once
/// @file
/// Contacts of convex collision hulls and cylinders with the ground plane, computed from
/// their geometry the same way for every backend.
///
/// Collision engines report a hull or a cylinder lying on a plane differently (Bullet keeps
/// four points per manifold, ODE up to the caller's buffer in its own order), so the virtual
/// links, and with them the filtered motion, would depend on the engine. Both backends ask
/// these functions instead for their own URDF-built shapes against their own ground.

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynfilter/core/contact.hpp"
#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/environment.hpp"

namespace dynfilter {

/// Most contact points one hull reports against the ground.
constexpr int kMaxHullGroundContacts = 8;

/// The vertices of one convex collision hull fixed to a robot body.
struct BodyHull {
  int body = -1;                                            ///< robot body index (ModelInfo::body_names)
  Eigen::Isometry3d X_BS = Eigen::Isometry3d::Identity();  ///< hull frame S in the body frame B
  Eigen::Matrix3Xd p_SV;                                    ///< vertices in S (m), 3 × n
  Eigen::Vector3d p_SCenter = Eigen::Vector3d::Zero();      ///< centre of the bounding sphere, S (m)
  double radius_m = 0.0;                                    ///< its radius (m)

  /// A hull of @p body with vertices @p p_SV (3 × n, n ≥ 1); computes the bounding sphere.
  /// Throws std::invalid_argument on an empty or non-finite vertex set.
  static BodyHull make(int body, const Eigen::Isometry3d& X_BS, Eigen::Matrix3Xd p_SV);
};

/// Appends to @p out the contacts of @p hull, posed by the body pose @p X_WB, with
/// @p ground: of the vertices on or below the plane, the extreme ones along eight
/// directions of the plane (the body's x axis projected onto it, turned by multiples of
/// 45°), each once; at most kMaxHullGroundContacts. The points keep the support polygon's
/// bounding rectangle along the body's heading, which is what a face link's support is made
/// of. p_WC is the vertex itself (on the body), n_W the plane's normal, depth_m its depth
/// below the plane. Returns the number appended. Never allocates.
int appendHullGroundContacts(const BodyHull& hull, const Eigen::Isometry3d& X_WB,
                             const GroundPlane& ground, ContactList& out);

/// A collision cylinder fixed to a robot body, its axis along the z of its frame S.
struct BodyCylinder {
  int body = -1;                                            ///< robot body index
  Eigen::Isometry3d X_BS = Eigen::Isometry3d::Identity();  ///< cylinder frame S in the body frame B
  double radius_m = 0.0;                                    ///< (m, > 0)
  double length_m = 0.0;                                    ///< along S's z, centred on its origin (m, > 0)
};

/// appendHullGroundContacts for a cylinder: of the points of its two rims on or below the
/// plane, the extreme ones along the same eight directions (exact points of the rims, not of
/// a polygon; of equally far ones the deepest), each once (points closer than 1e-9 m
/// merged); at most kMaxHullGroundContacts. A rim level with the plane gives its points
/// along those directions; a tilted one the ends of its arc below the plane and its deepest
/// point. Returns the number appended. Never allocates.
int appendCylinderGroundContacts(const BodyCylinder& cylinder, const Eigen::Isometry3d& X_WB,
                                 const GroundPlane& ground, ContactList& out);

/// The shapes of a robot whose ground contacts a backend computes with the functions above
/// instead of its collision engine. Empty for a user's world, which keeps its engine's
/// contacts.
struct GroundContactShapes {
  std::vector<BodyHull> hulls;
  std::vector<BodyCylinder> cylinders;
  bool empty() const { return hulls.empty() && cylinders.empty(); }
};

/// Appends to @p out the ground contacts of every shape of @p shapes, each posed by
/// @p model's current body pose. Returns the number appended. Never allocates.
int appendGroundContacts(const GroundContactShapes& shapes, const IDynamicsModel& model,
                         const GroundPlane& ground, ContactList& out);

}  // namespace dynfilter
