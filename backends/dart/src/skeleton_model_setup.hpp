#pragma once
// Internal: what SkeletonModel needs to know about a skeleton in a world. attachDartModel
// fills it from the user's skeleton, makeDartModel from the skeleton it built from a URDF.

#include <memory>
#include <unordered_map>
#include <vector>

#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/ShapeFrame.hpp>

#include "dart_skeleton_builder.hpp"
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
  DartMassMatrix mass_matrix = DartMassMatrix::kBodySum;
};

/// The model over @p setup's skeleton; (q, v) start as the skeleton's current state.
std::unique_ptr<SkeletonModel> makeSkeletonModel(SkeletonModelSetup setup);

}  // namespace dynfilter::dart_backend
