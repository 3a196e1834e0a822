// makeDartModel: the skeleton model over a skeleton and world built from a URDF
// description — the same model a user gets from attachDartModel on their own skeleton.
#include "dynfilter/dart/dart_model.hpp"

#include <stdexcept>
#include <utility>

#include <dart/collision/bullet/BulletCollisionDetector.hpp>
#include <dart/constraint/ConstraintSolver.hpp>
#include <dart/simulation/World.hpp>

#include "dart_skeleton_builder.hpp"
#include "skeleton_model_setup.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"

namespace dynfilter::dart_backend {

std::unique_ptr<IDynamicsModel> makeDartModel(const urdf::RobotDescription& robot,
                                              const ModelOptions& options,
                                              DartMassMatrix mass_matrix) {
  urdf::validateForDynamics(robot, options.floating_base);
  options.environment.validate();
  if (!options.gravity_W.allFinite()) throw std::invalid_argument("gravity is not finite");

  BuiltRobot built = buildRobotSkeleton(robot, options.floating_base);
  BuiltEnvironment env = buildEnvironmentSkeleton(options.environment);
  built.skeleton->setGravity(options.gravity_W);
  for (std::size_t i = 0; i < built.skeleton->getNumJoints(); ++i)
    built.skeleton->getJoint(i)->setLimitEnforcement(options.enforce_joint_limits_in_simulation);

  SkeletonModelSetup setup;
  setup.world = dart::simulation::World::create("dynfilter");
  setup.world->getConstraintSolver()->setCollisionDetector(
      dart::collision::BulletCollisionDetector::create());
  setup.world->setGravity(options.gravity_W);
  setup.world->addSkeleton(built.skeleton);
  setup.world->addSkeleton(env.skeleton);
  // The world's own contacts (World::step) follow the same pairs as detectContacts: the
  // robot against the environment, hulls against the ground plane, the rest the slab.
  setup.world->getConstraintSolver()->getCollisionOption().collisionFilter =
      makeRobotVersusOthersFilter(built.skeleton.get(), env.ground_slab, env.ground_plane, true);
  enableHullContacts(setup.world->getConstraintSolver()->getCollisionGroup().get());

  setup.info = urdf::makeModelInfo(robot, options.floating_base);
  setup.environment = options.environment;
  setup.skeleton = built.skeleton;
  setup.links = std::move(built.links);
  for (const auto& [shape, link] : built.link_of_shape) setup.body_of_shape[shape] = link;
  for (std::size_t k = 0; k < env.skeleton->getNumBodyNodes(); ++k)
    setup.object_of_body[env.skeleton->getBodyNode(k)] = env.object_of_body[k];
  setup.dof_of_v = std::move(built.dof_of_v);
  setup.v_of_dof = std::move(built.v_of_dof);
  setup.factor_of_dof = std::move(built.factor_of_dof);
  setup.offset_of_dof = std::move(built.offset_of_dof);
  setup.has_mimic = built.has_mimic;
  setup.ground_slab = env.ground_slab;
  setup.ground_plane = env.ground_plane;
  if (options.environment.has_ground) setup.ground_shapes = urdf::groundContactShapes(robot);
  setup.mass_matrix = mass_matrix;

  auto model = makeSkeletonModel(std::move(setup));
  model->setState(model->info().neutralConfiguration(), Eigen::VectorXd::Zero(model->nv()));
  return model;
}

std::unique_ptr<IDynamicsModel> loadDartModel(const std::string& urdf_path,
                                              const ModelOptions& options,
                                              DartMassMatrix mass_matrix) {
  return makeDartModel(urdf::loadUrdfFile(urdf_path), options, mass_matrix);
}

}  // namespace dynfilter::dart_backend
