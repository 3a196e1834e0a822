#pragma once
// Internal: what SkeletonModel needs to know about a skeleton in a world. attachDartModel
// fills it from the user's skeleton, makeDartModel from the skeleton it built from a URDF.

#include <memory>
#include <unordered_map>
#include <vector>

#include <dart/collision/CollisionFilter.hpp>
#include <dart/collision/CollisionGroup.hpp>
#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/ShapeFrame.hpp>

#include "dart_skeleton_builder.hpp"
#include "dynfilter/core/ground_contacts.hpp"
#include "dynfilter/core/model_info.hpp"
#include "dynfilter/dart/skeleton_model.hpp"

namespace dynfilter::dart_backend {

struct SkeletonModelSetup {
  ModelInfo info;
  Environment environment;
  dart::dynamics::SkeletonPtr skeleton;
  dart::simulation::WorldPtr world;
  std::vector<LinkFrame> links;  ///< by body index (ModelInfo::body_names)
  /// Body index of each of the skeleton's collision ShapeFrames.
  std::unordered_map<const dart::dynamics::ShapeFrame*, int> body_of_shape;
  /// Object index (ContactCandidate::object) of each BodyNode of the other skeletons.
  std::unordered_map<const dart::dynamics::BodyNode*, int> object_of_body;
  /// dof_of_v[i]: DART DoF index of velocity coordinate i (dim nv).
  std::vector<int> dof_of_v;
  /// Velocity index of the first of the three coordinates of each ball joint.
  std::vector<int> ball_v;
  /// Per DART DoF (dim ndofs, or all empty: the inverse of dof_of_v, factor 1, offset 0):
  /// the velocity coordinate that drives it and how. A mimic follower's DoF is
  /// q_dof = factor · q_leader + offset, v_dof = factor · v_leader.
  std::vector<int> v_of_dof;
  std::vector<double> factor_of_dof;
  std::vector<double> offset_of_dof;
  bool has_mimic = false;
  /// The built world's ground twins (null for a user's world): in the world's own
  /// simulation a convex-hull mesh meets only the plane (Bullet's GImpact algorithm),
  /// every other shape only the slab.
  const dart::dynamics::ShapeFrame* ground_slab = nullptr;
  const dart::dynamics::ShapeFrame* ground_plane = nullptr;
  /// For a URDF-built world with a ground: the hulls and cylinders whose ground contacts
  /// detectContacts computes from their geometry (core/ground_contacts.hpp), the same way
  /// as the ODE backend; the query filter then leaves their engine contacts out. Empty for
  /// a user's world.
  GroundContactShapes ground_shapes;
  DartMassMatrix mass_matrix = DartMassMatrix::kBodySum;
};

/// Keeps only pairs with exactly one shape on @p robot; against the ground twins (either
/// may be null) a MeshShape meets only @p ground_plane and any other shape only
/// @p ground_slab; without @p engine_ground_contacts meshes and cylinders meet neither.
std::shared_ptr<dart::collision::CollisionFilter> makeRobotVersusOthersFilter(
    const dart::dynamics::Skeleton* robot, const dart::dynamics::ShapeFrame* ground_slab,
    const dart::dynamics::ShapeFrame* ground_plane, bool engine_ground_contacts);

/// DART hands a MeshShape to Bullet as a btGImpactMeshShape but registers no collision
/// algorithm for it: registers Bullet's GImpact algorithm on @p group's dispatcher and
/// takes the meshes' default margin off. Throws std::logic_error if @p group is not Bullet's.
void enableHullContacts(dart::collision::CollisionGroup* group);

/// The model over @p setup's skeleton; (q, v) start as the skeleton's current state.
std::unique_ptr<SkeletonModel> makeSkeletonModel(SkeletonModelSetup setup);

}  // namespace dynfilter::dart_backend
