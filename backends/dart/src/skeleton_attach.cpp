// attachDartModel: reads coordinates, names, limits and collision shapes off a user's
// skeleton and hands them to the one SkeletonModel implementation.
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <dart/dynamics/BallJoint.hpp>
#include <dart/dynamics/DegreeOfFreedom.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/PrismaticJoint.hpp>
#include <dart/dynamics/RevoluteJoint.hpp>
#include <dart/dynamics/ShapeNode.hpp>
#include <dart/dynamics/WeldJoint.hpp>

#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "skeleton_model_setup.hpp"

namespace dynfilter::dart_backend {
namespace {

[[noreturn]] void refuse(const dart::dynamics::Skeleton& skeleton, const std::string& what,
                         const std::string& reason) {
  throw ModelError("<skeleton \"" + skeleton.getName() + "\">", 0, what, reason);
}

bool isIdentity(const Eigen::Isometry3d& X) { return X.isApprox(Eigen::Isometry3d::Identity(), 1e-12); }

// Symmetric bound from a DART [lower, upper] pair: the smaller magnitude.
double symmetricBound(double lower, double upper) { return std::min(-lower, upper); }

}  // namespace

std::unique_ptr<SkeletonModel> attachDartModel(const dart::dynamics::SkeletonPtr& skeleton,
                                               const dart::simulation::WorldPtr& world,
                                               const AttachOptions& options) {
  if (skeleton == nullptr || world == nullptr)
    throw std::invalid_argument("attachDartModel: null skeleton or world");
  if (!(options.friction >= 0.0) || !std::isfinite(options.friction))
    throw std::invalid_argument("attachDartModel: friction must be finite and ≥ 0");
  const auto& skel = *skeleton;
  if (!world->hasSkeleton(skeleton)) refuse(skel, "world \"" + world->getName() + "\"", "does not hold the skeleton");
  if (skel.getNumTrees() != 1)
    refuse(skel, "trees", std::to_string(skel.getNumTrees()) + " (one root joint expected)");

  SkeletonModelSetup setup;
  setup.skeleton = skeleton;
  setup.world = world;
  setup.mass_matrix = options.mass_matrix;
  setup.environment.has_ground = false;  // the world's shapes are the environment
  setup.environment.ground.friction = options.friction;

  ModelInfo& info = setup.info;
  info.name = skel.getName();
  const auto* root = skel.getRootJoint();
  info.floating_base = root->getType() == dart::dynamics::FreeJoint::getStaticType();
  if (info.floating_base && (!isIdentity(root->getTransformFromParentBodyNode()) ||
                             !isIdentity(root->getTransformFromChildBodyNode())))
    refuse(skel, "joint \"" + root->getName() + "\"",
           "a root FreeJoint with offset transforms (the base pose must be the body pose)");

  for (std::size_t k = 0; k < skel.getNumJoints(); ++k) {
    const auto* joint = skel.getJoint(k);
    const std::string& type = joint->getType();
    const bool supported = type == dart::dynamics::RevoluteJoint::getStaticType() ||
                           type == dart::dynamics::PrismaticJoint::getStaticType() ||
                           type == dart::dynamics::BallJoint::getStaticType() ||
                           type == dart::dynamics::WeldJoint::getStaticType() ||
                           (k == 0 && type == dart::dynamics::FreeJoint::getStaticType());
    if (!supported)
      refuse(skel, "joint \"" + joint->getName() + "\"",
             "type " + type +
                 " (supported: FreeJoint at the root, RevoluteJoint, PrismaticJoint, BallJoint, "
                 "WeldJoint)");
  }

  const int base = info.floating_base ? kFloatingBaseNv : 0;
  const int ndofs = static_cast<int>(skel.getNumDofs());
  info.nj = ndofs - base;
  info.nv = ndofs;
  info.nq = info.nj + (info.floating_base ? kFloatingBaseNq : 0);
  info.q_lower.resize(info.nj);
  info.q_upper.resize(info.nj);
  info.v_max.resize(info.nj);
  info.tau_max.resize(info.nj);
  setup.dof_of_v.assign(static_cast<std::size_t>(ndofs), -1);
  if (info.floating_base) {
    // Our base velocity is [v_B; ω_B]; DART's FreeJoint uses [ω_B; v_B], both in B.
    for (int i = 0; i < 3; ++i) {
      setup.dof_of_v[static_cast<std::size_t>(i)] = 3 + i;
      setup.dof_of_v[static_cast<std::size_t>(3 + i)] = i;
    }
  }
  for (int j = 0; j < info.nj; ++j) {
    const auto* dof = skel.getDof(static_cast<std::size_t>(base + j));
    setup.dof_of_v[static_cast<std::size_t>(base + j)] = base + j;
    info.joint_names.push_back(dof->getName());
    info.q_lower[j] = dof->getPositionLowerLimit();
    info.q_upper[j] = dof->getPositionUpperLimit();
    info.v_max[j] = symmetricBound(dof->getVelocityLowerLimit(), dof->getVelocityUpperLimit());
    info.tau_max[j] = symmetricBound(dof->getForceLowerLimit(), dof->getForceUpperLimit());
    const auto* joint = dof->getJoint();
    if (joint->getType() == dart::dynamics::BallJoint::getStaticType() &&
        dof->getIndexInJoint() == 0)
      setup.ball_v.push_back(base + j);
  }
  for (std::size_t k = 0; k < skel.getNumBodyNodes(); ++k) {
    auto* node = skeleton->getBodyNode(k);
    info.body_names.push_back(node->getName());
    setup.links.push_back(LinkFrame{node, Eigen::Isometry3d::Identity()});
    for (const auto* shape : node->getShapeNodesWith<dart::dynamics::CollisionAspect>())
      setup.body_of_shape[shape] = static_cast<int>(k);
  }
  info.total_mass = skel.getMass();

  int object = 0;
  for (std::size_t s = 0; s < world->getNumSkeletons(); ++s) {
    const auto other = world->getSkeleton(s);
    if (other == skeleton) continue;
    for (std::size_t k = 0; k < other->getNumBodyNodes(); ++k)
      setup.object_of_body[other->getBodyNode(k)] = object++;
  }
  return makeSkeletonModel(std::move(setup));
}

}  // namespace dynfilter::dart_backend
