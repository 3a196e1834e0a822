// The dynamics filter inside a DART simulation the user built: a world with a ground box
// and the human figure loaded by DART's own URDF loader. The filter is attached to that
// skeleton (no second copy of the robot), plays the squat toward data/squat_reference.csv
// and the world's own step — DART's constraint solver with Bullet contacts — moves the
// figure with the filter's joint torques only.
//
//   dart_attach models/human_figure.urdf data/squat_reference.csv [--mode paper|qp]
//
// Prints the worst base error, tilt and joint error over the clip and whether the figure
// stood; exits 1 if it did not (base error > 5 cm, tilt > 0.2 rad or a joint > 0.2 rad).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>

#include <dart/collision/bullet/BulletCollisionDetector.hpp>
#include <dart/constraint/ConstraintSolver.hpp>
#include <dart/constraint/ContactConstraint.hpp>
#include <dart/dynamics/BoxShape.hpp>
#include <dart/dynamics/ShapeNode.hpp>
#include <dart/dynamics/WeldJoint.hpp>
#include <dart/simulation/World.hpp>
#include <dart/utils/urdf/DartLoader.hpp>

#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/dart/attached_filter.hpp"
#include "dynfilter/io/reference_motion.hpp"
#include "dynfilter/daqp/daqp_solver.hpp"

using namespace dart::dynamics;

// The user's ground: a static 20 m × 20 m box whose top face is z = 0.
SkeletonPtr makeGround() {
  auto ground = Skeleton::create("ground");
  WeldJoint::Properties joint;
  joint.mT_ParentBodyToJoint.translation() = Eigen::Vector3d(0, 0, -0.1);
  auto* body = ground->createJointAndBodyNodePair<WeldJoint>(nullptr, joint).second;
  auto* shape = body->createShapeNodeWith<CollisionAspect, DynamicsAspect>(
      std::make_shared<BoxShape>(Eigen::Vector3d(20, 20, 0.2)));
  shape->getDynamicsAspect()->setFrictionCoeff(0.8);
  return ground;
}

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s robot.urdf reference.csv [--mode paper|qp]\n", argv[0]);
    return 2;
  }
  const bool qp = argc > 4 && std::strcmp(argv[3], "--mode") == 0 && std::strcmp(argv[4], "qp") == 0;
  try {
    // ---- the user's simulation --------------------------------------------------------
    auto world = dart::simulation::World::create("user_world");
    world->setTimeStep(1e-3);
    world->getConstraintSolver()->setCollisionDetector(
        dart::collision::BulletCollisionDetector::create());
    // Contacts a little softer than DART's default CFM (1e-5), so that a sole rests slightly
    // inside the ground. With hard contacts the filter holds the soles exactly at the surface;
    // at zero depth Bullet's box-box contact turns degenerate, the feet rock and the figure
    // falls within about a second (measured; 1e-3 stands, 1e-2 sinks and falls too).
    dart::constraint::ContactConstraint::setConstraintForceMixing(1e-3);
    dart::utils::DartLoader loader;
    SkeletonPtr robot = loader.parseSkeleton(std::filesystem::absolute(argv[1]).string());
    if (robot == nullptr) throw std::runtime_error(std::string("cannot load ") + argv[1]);
    world->addSkeleton(robot);
    world->addSkeleton(makeGround());

    // ---- attach the filter -------------------------------------------------------------
    dynfilter::FilterOptions options;
    options.dt_s = world->getTimeStep();
    if (qp) options.mode = dynfilter::FilterMode::kQp;
    dynfilter::dart_backend::AttachedFilter filter(robot, world, options,
                                                   dynfilter::daqp::factory());
    const dynfilter::ModelInfo& info = filter.model().info();
    const auto motion = dynfilter::io::readReferenceMotion(argv[2], info);
    const auto& frames = motion.frames;
    filter.placeAt(frames.front());  // the figure's start pose

    // ---- the user's loop: one filter tick per world step ---------------------------------
    dynfilter::ReferenceFrame ref(info.nq, info.nv);
    Eigen::VectorXd error(info.nv), q(info.nq), v(info.nv);
    double max_base = 0.0, max_tilt = 0.0, max_joint = 0.0;
    std::size_t k = 0;
    const double t_end = frames.back().time_s;
    long ticks = 0;
    for (double t = frames.front().time_s; t <= t_end; t += options.dt_s, ++ticks) {
      while (k + 2 < frames.size() && frames[k + 1].time_s <= t) ++k;
      dynfilter::interpolateReference(true, frames[k], frames[k + 1], t, ref);
      filter.step(ref);
      world->step();
      filter.model().readSkeletonState(q, v);  // what the world did
      dynfilter::differenceConfiguration(true, q, ref.q, error);
      max_base = std::max(max_base, (q.head<3>() - ref.q.head<3>()).norm());
      max_tilt = std::max(max_tilt, error.segment<3>(3).norm());
      max_joint = std::max(max_joint, error.tail(info.nj).cwiseAbs().maxCoeff());
    }
    const bool stood = max_base < 0.05 && max_tilt < 0.2 && max_joint < 0.2;
    std::printf("dart_attach: %s mode, %ld ticks (%.2f s): max base error %.4f m, max tilt %.4f "
                "rad, max joint error %.4f rad, final base height %.4f m: %s\n",
                qp ? "qp" : "paper", ticks, ticks * options.dt_s, max_base, max_tilt, max_joint,
                q[2], stood ? "STOOD" : "FELL");
    return stood ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dart_attach: %s\n", e.what());
    return 2;
  }
}
