// The dynamics filter inside an ODE simulation the user built: a world with a ground
// plane and the human figure made from its URDF by the user's own code (figure_world.cpp:
// urdfdom, one body per link, hinges). The filter is attached to those bodies and joints
// (no second copy of the robot), plays the squat toward data/squat_reference.csv, and
// every tick the user's own step — ODE's contact joints and dWorldStep — moves the figure
// with the filter's joint torques only (dJointAddHingeTorque).
//
//   ode_attach models/human_figure.urdf data/squat_reference.csv [--mode paper|qp]
//
// Prints the worst base error, tilt and joint error over the clip and whether the figure
// stood; exits 1 if it did not (base error > 5 cm, tilt > 0.2 rad or a joint > 0.2 rad).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/io/reference_motion.hpp"
#include "dynfilter/ode/attached_filter.hpp"
#include "dynfilter/daqp/daqp_solver.hpp"
#include "figure_world.hpp"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s robot.urdf reference.csv [--mode paper|qp]\n", argv[0]);
    return 2;
  }
  const bool qp = argc > 4 && std::strcmp(argv[3], "--mode") == 0 && std::strcmp(argv[4], "qp") == 0;
  try {
    FigureWorld user(argv[1]);  // the user's simulation

    // ---- attach the filter -------------------------------------------------------------
    dynfilter::FilterOptions options;
    options.dt_s = 1e-3;
    if (qp) options.mode = dynfilter::FilterMode::kQp;
    dynfilter::ode_backend::AttachedFilter filter(user.robot, options, dynfilter::daqp::factory());
    const dynfilter::ModelInfo& info = filter.model().info();
    const auto motion = dynfilter::io::readReferenceMotion(argv[2], info);
    const auto& frames = motion.frames;
    filter.placeAt(frames.front());  // poses the user's bodies

    // ---- the user's loop: one filter tick per world step ---------------------------------
    dynfilter::ReferenceFrame ref(info.nq, info.nv);
    Eigen::VectorXd error(info.nv), q(info.nq), v(info.nv);
    double max_base = 0.0, max_tilt = 0.0, max_joint = 0.0;
    std::size_t k = 0;
    long ticks = 0;
    for (double t = frames.front().time_s; t <= frames.back().time_s; t += options.dt_s, ++ticks) {
      while (k + 2 < frames.size() && frames[k + 1].time_s <= t) ++k;
      dynfilter::interpolateReference(true, frames[k], frames[k + 1], t, ref);
      filter.step(ref);
      user.step(options.dt_s);
      filter.model().readBodyState(q, v);  // what the world did
      dynfilter::differenceConfiguration(true, q, ref.q, error);
      max_base = std::max(max_base, (q.head<3>() - ref.q.head<3>()).norm());
      max_tilt = std::max(max_tilt, error.segment<3>(3).norm());
      max_joint = std::max(max_joint, error.tail(info.nj).cwiseAbs().maxCoeff());
    }
    const bool stood = max_base < 0.05 && max_tilt < 0.2 && max_joint < 0.2;
    std::printf("ode_attach: %s mode, %ld ticks (%.2f s): max base error %.4f m, max tilt %.4f "
                "rad, max joint error %.4f rad, final base height %.4f m: %s\n",
                qp ? "qp" : "paper", ticks, ticks * options.dt_s, max_base, max_tilt, max_joint,
                q[2], stood ? "STOOD" : "FELL");
    return stood ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ode_attach: %s\n", e.what());
    return 2;
  }
}
