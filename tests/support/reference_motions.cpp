#include "support/reference_motions.hpp"

#include <cmath>
#include <fstream>

#include <Eigen/Geometry>

#include <nlohmann/json.hpp>

#include "dynfilter/core/dynamics_simulator.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "support/test_support.hpp"

namespace dynfilter::test {

double humanFigureStandingHeight() {
  std::ifstream in(sourcePath("models/human_figure.json"));
  return nlohmann::json::parse(in)["standing_pelvis_height_m"].get<double>();
}

std::vector<ReferenceFrame> simulateStandingSway(IDynamicsModel& model, double seconds,
                                                 double dt, double squat_amplitude,
                                                 double frequency_hz, int substeps) {
  const ModelInfo& info = model.info();
  Eigen::VectorXd q = info.neutralConfiguration();
  q[2] = humanFigureStandingHeight() - 5e-4;
  DynamicsSimulator sim(model, ContactOptions{}, dt / substeps);
  sim.reset(q, Eigen::VectorXd::Zero(info.nv));

  // Desired joint trajectory: squat (hips and ankles flex, knees twice as much), arms
  // swinging in opposition, waist turning.
  auto joint = [&info](const char* name) { return info.findJoint(name); };
  const double w = 2.0 * M_PI * frequency_hz;
  auto desired = [&](double t, Eigen::VectorXd& qd, Eigen::VectorXd& vd) {
    qd = info.neutralConfiguration().tail(info.nj);
    vd.setZero(info.nj);
    const double s = 0.5 * squat_amplitude * (1.0 - std::cos(w * t));
    const double sd = 0.5 * squat_amplitude * w * std::sin(w * t);
    for (const char* side : {"l_", "r_"}) {
      const std::string p = side;
      qd[joint((p + "hip_pitch").c_str())] = -s;
      vd[joint((p + "hip_pitch").c_str())] = -sd;
      qd[joint((p + "knee").c_str())] = 2.0 * s;
      vd[joint((p + "knee").c_str())] = 2.0 * sd;
      qd[joint((p + "ankle_pitch").c_str())] = -s;
      vd[joint((p + "ankle_pitch").c_str())] = -sd;
    }
    qd[joint("l_shoulder_pitch")] = -0.3 * std::sin(w * t);
    vd[joint("l_shoulder_pitch")] = -0.3 * w * std::cos(w * t);
    qd[joint("r_shoulder_pitch")] = 0.3 * std::sin(w * t);
    vd[joint("r_shoulder_pitch")] = 0.3 * w * std::cos(w * t);
    qd[joint("waist_yaw")] = 0.1 * std::sin(w * t);
    vd[joint("waist_yaw")] = 0.1 * w * std::cos(w * t);
  };

  std::vector<ReferenceFrame> frames;
  const int steps = static_cast<int>(std::lround(seconds / dt));
  // Joint PD scaled by each joint's own inertia (diagonal of A at the start), so that
  // light distal joints stay stable under explicit integration: ω = 20 rad/s, ζ = 1.
  Eigen::MatrixXd A(info.nv, info.nv);
  model.setState(q, Eigen::VectorXd::Zero(info.nv));
  model.massMatrix(A);
  const Eigen::VectorXd inertia = A.diagonal().tail(info.nj);
  const double omega = 20.0;
  const Eigen::VectorXd kp = omega * omega * inertia, kd = 2.0 * omega * inertia;
  Eigen::VectorXd qd, vd, tau(info.nj), frame_q, frame_v, frame_vdot;
  for (int k = 0; k < steps; ++k) {
    const double t = k * dt;
    for (int sub = 0; sub < substeps; ++sub) {
      desired(t + sub * dt / substeps, qd, vd);
      tau = kp.cwiseProduct(qd - sim.q().tail(info.nj)) +
            kd.cwiseProduct(vd - sim.v().tail(info.nj));
      sim.step(tau);
      if (sub == 0) {
        frame_q = sim.stepStartQ();
        frame_v = sim.stepStartV();
        frame_vdot = sim.vdot();
      }
    }
    ReferenceFrame frame;
    frame.time_s = t;
    frame.q = frame_q;
    frame.v = frame_v;
    frame.vdot = frame_vdot;
    frames.push_back(std::move(frame));
  }
  return frames;
}

void walkOffAndTurn(std::vector<ReferenceFrame>& frames, double speed_mps, double turn_rate_radps) {
  if (frames.empty()) return;
  const Eigen::Vector3d p0 = frames.front().q.head<3>();
  const double t0 = frames.front().time_s;
  for (ReferenceFrame& f : frames) {
    const double t = f.time_s - t0;
    const Eigen::Isometry3d X = Eigen::Translation3d(p0 + Eigen::Vector3d(speed_mps * t, 0.0, 0.0)) *
                                Eigen::AngleAxisd(turn_rate_radps * t, Eigen::Vector3d::UnitZ()) *
                                Eigen::Translation3d(-p0);
    moveBase(X, f.q);
  }
}

void hingedBoardsLyingAndLifted(IDynamicsModel& model, ReferenceFrame& lying, ReferenceFrame& lifted) {
  const ModelInfo& info = model.info();
  lying = ReferenceFrame(info.nq, info.nv);
  lying.q = info.neutralConfiguration();
  lying.q[2] = standingBaseHeight(model, lying.q);
  lifted = lying;
  lifted.q[info.configurationIndex(info.findJoint("hinge"))] = -0.3;
}

}  // namespace dynfilter::test
