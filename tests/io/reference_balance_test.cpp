// The reference's centroidal feasibility and its nearest feasible CoM path
// (dynfilter/io/reference_balance.hpp), the clean-up's balance stage and support completion (reference_cleanup.hpp), and the low-pass of
// configurations (reference_motion.hpp): closed forms on the mini humanoid.

#include <cmath>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/core/balance.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/io/reference_balance.hpp"
#include "dynfilter/io/reference_cleanup.hpp"
#include "dynfilter/io/reference_motion.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter::io {
namespace {

// @p frames frames 10 ms apart, all at @p q (v, v̇ zero).
ReferenceMotion stillMotion(const ModelInfo& info, const Eigen::VectorXd& q, int frames) {
  ReferenceMotion motion;
  for (int k = 0; k < frames; ++k) {
    ReferenceFrame f(info.nq, info.nv);
    f.time_s = 0.01 * k;
    f.q = q;
    motion.frames.push_back(f);
  }
  return motion;
}

Eigen::Vector3d comOf(IDynamicsModel& model, const Eigen::VectorXd& q) {
  const ModelInfo& info = model.info();
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(info.nv);
  Eigen::MatrixXd A(info.nv, info.nv);
  model.setState(q, v0);
  model.massMatrix(A);
  return centroidalState(A, q, v0, info.total_mass).c_W;
}

// @p n pendulum samples 1/120 s apart at rest at @p c, 0.9 m high, on the unit square
// [0, 1]² (counter-clockwise).
std::vector<PendulumSample> stillPendulum(int n, const Eigen::Vector2d& c) {
  std::vector<PendulumSample> samples(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    PendulumSample& s = samples[static_cast<std::size_t>(k)];
    s.time_s = k / 120.0;
    s.c = c;
    s.load = 1.0;
    s.beta_s2 = 0.9 / 9.81;
    s.support = {{0.0, 0.0}, {1.0, 0.0}, {1.0, 1.0}, {0.0, 1.0}};
  }
  return samples;
}

// At rest the ZMP is the CoM: a CoM inside its support stays where it is; one 5 cm outside
// an edge moves onto that edge, the nearest path whose ZMP stays inside once the shift must
// be still at the clip's ends (without, a pendulum falling back out of a cosh would be
// nearer), over two windows that continue each other.
TEST(ReferenceBalance, TheFeasibleComPathOfAStillPendulumIsItsNearestPointInTheSupport) {
  const auto solver = proxqp::factory();
  FeasibleComReport report;
  const std::vector<Eigen::Vector2d> inside =
      feasibleComPath(stillPendulum(400, Eigen::Vector2d(0.3, 0.6)), FeasibleComOptions{}, solver, &report);
  for (const Eigen::Vector2d& c : inside) EXPECT_LT((c - Eigen::Vector2d(0.3, 0.6)).norm(), 1e-5);
  EXPECT_EQ(report.windows, 2);  // 3.3 s in 3 s windows, half overlapping
  EXPECT_EQ(report.unsolved, 0);
  const std::vector<Eigen::Vector2d> outside =
      feasibleComPath(stillPendulum(400, Eigen::Vector2d(1.05, 0.5)), FeasibleComOptions{}, solver, &report);
  for (std::size_t k = 0; k < outside.size(); ++k) EXPECT_LT((outside[k] - Eigen::Vector2d(1.0, 0.5)).norm(), 1e-4) << k;
  EXPECT_LT(report.max_violation_m, 1e-5);
  EXPECT_THROW(feasibleComPath(stillPendulum(10, Eigen::Vector2d::Zero()), FeasibleComOptions{}, {}),
               std::invalid_argument);
  FeasibleComOptions bad;
  bad.window_s = 0.05;
  EXPECT_THROW(feasibleComPath(stillPendulum(10, Eigen::Vector2d::Zero()), bad, solver), std::invalid_argument);
}

// Standing still, the ZMP is the CoM's ground projection; accelerating the whole figure
// along x by a (no rotation, L = 0) moves it to c − h a / g.
TEST(ReferenceBalance, ZmpOfAStillAndOfAnAcceleratingFigure) {
  auto model = test::makeMiniHumanoid();
  const ModelInfo& info = model->info();
  Eigen::VectorXd q0 = info.neutralConfiguration();
  q0[2] = standingBaseHeight(*model, q0);
  for (const double a : {0.0, 1.5}) {
    SCOPED_TRACE(a);
    ReferenceMotion motion;
    for (int k = 0; k < 61; ++k) {
      ReferenceFrame f(info.nq, info.nv);
      f.time_s = 0.01 * k;
      f.q = q0;
      f.q[0] += 0.5 * a * f.time_s * f.time_s;
      motion.frames.push_back(f);
    }
    estimateDerivatives(motion.frames, true, 7, true, true);
    // Support: a large square under the figure, so that the ZMP is inside.
    std::vector<std::vector<Eigen::Vector3d>> support(motion.frames.size());
    for (auto& s : support)
      for (const double x : {-1.0, 1.0})
        for (const double y : {-1.0, 1.0}) s.emplace_back(x, y, 0.0);
    const std::vector<ZmpSample> z = zmpAgainstSupport(motion, *model, support);
    for (std::size_t k = 0; k < z.size(); ++k) {
      const Eigen::Vector3d c = comOf(*model, motion.frames[k].q);
      ASSERT_TRUE(z[k].defined) << k;
      EXPECT_NEAR(z[k].com_height_m, c.z(), 1e-9);
      EXPECT_NEAR(z[k].zmp.x(), c.x() - c.z() * a / 9.81, 1e-6) << k;
      EXPECT_NEAR(z[k].zmp.y(), c.y(), 1e-6) << k;
      EXPECT_NEAR(z[k].vertical_load, 1.0, 1e-6);
      EXPECT_NEAR(z[k].outside_m, 0.0, 1e-12);
    }
    // No support: not defined.
    const std::vector<ZmpSample> none =
        zmpAgainstSupport(motion, *model, std::vector<std::vector<Eigen::Vector3d>>(motion.frames.size()));
    for (const ZmpSample& s : none) EXPECT_FALSE(s.defined);
  }
}

// A still figure whose base stands 0.21 m ahead of its feet (legs slanted, upper body
// upright): its CoM, and so its ZMP, is in front of the toes. The balance stage moves the
// base back until the ZMP is over the soles; the feet do not move.
TEST(ReferenceCleanup, BalanceStageBringsTheZmpOverTheFeet) {
  auto model = test::makeMiniHumanoid();
  const ModelInfo& info = model->info();
  const double b = 0.35;
  Eigen::VectorXd q = info.neutralConfiguration();
  for (const char* side : {"l", "r"}) {
    q[info.configurationIndex(info.findJoint(std::string("coxa_") + side + "_y"))] = b;
    q[info.configurationIndex(info.findJoint(std::string("talo_") + side + "_y"))] = -b;
  }
  q[2] = standingBaseHeight(*model, q);
  ReferenceMotion motion = stillMotion(info, q, 81);
  estimateDerivatives(motion.frames, true, 7, true, true);
  ReferenceCleanupOptions options;
  options.balance = false;
  const CleanupResult off = cleanupReference(motion, *model, options, {});
  EXPECT_EQ(off.report.zmp_frames_outside_before, 81);
  EXPECT_GT(off.report.zmp_outside_max_before_m, 0.03);
  EXPECT_EQ(off.report.zmp_frames_outside_after, 81);
  EXPECT_EQ(off.report.com_shift_max_m, 0.0);
  options.balance = true;
  EXPECT_THROW(cleanupReference(motion, *model, options, {}), std::invalid_argument);  // no QP solver
  const CleanupResult on = cleanupReference(motion, *model, options, proxqp::factory());
  EXPECT_EQ(on.report.com_path.unsolved, 0);
  EXPECT_LT(on.report.com_path_error_m, 1e-3);
  EXPECT_EQ(on.report.zmp_frames_outside_before, 81);
  EXPECT_LT(on.report.zmp_outside_max_after_m, 2e-3);
  EXPECT_GT(on.report.com_shift_max_m, 0.03);
  for (const FootReport& f : on.report.feet) {
    EXPECT_LT(f.skate_after_m, 1e-3) << f.link;
    EXPECT_LT(f.penetration_after_m, 1e-3) << f.link;
  }
  // The CoM over the soles (x in [−0.06, 0.12] about the ankles, less the 2 cm margin, which
  // shrinks the sole towards its centre: its toe edge moves back by 1.8 cm), within the 2 mm
  // the ZMP may still be out.
  const Eigen::Vector3d c = comOf(*model, on.motion.frames[40].q);
  model->setState(on.motion.frames[40].q, Eigen::VectorXd::Zero(info.nv));
  const double ankle_x = model->bodyPose(info.findBody("sole_l")).translation().x();
  EXPECT_LT(c.x() - ankle_x, 0.12 - 0.018 + 2e-3);
  EXPECT_GT(c.x() - ankle_x, -0.04);
  model->setState(off.motion.frames[40].q, Eigen::VectorXd::Zero(info.nv));
  EXPECT_NEAR(model->bodyPose(info.findBody("sole_l")).translation().x(), ankle_x, 1e-3);
}

// Both feet still; the left one 5 cm up (hip, knee and ankle bent, sole level), the CoM
// between the feet: the left foot is in stance too. 11.5 cm up it is not.
TEST(ReferenceCleanup, AHoveringFootUnderTheCentreOfMassIsInStance) {
  auto model = test::makeMiniHumanoid();
  const ModelInfo& info = model->info();
  for (const double lift_m : {0.05, 0.115}) {
    SCOPED_TRACE(lift_m);
    const double a = std::acos(1.0 - lift_m / 0.62);
    Eigen::VectorXd q = info.neutralConfiguration();
    q[2] = standingBaseHeight(*model, q);
    q[info.configurationIndex(info.findJoint("coxa_l_y"))] = -a;
    q[info.configurationIndex(info.findJoint("genu_l"))] = 2.0 * a * 0.3 / 0.31;
    q[info.configurationIndex(info.findJoint("talo_l_y"))] = -a;
    const ContactSchedule s = findContactSchedule(stillMotion(info, q, 61), *model, ReferenceCleanupOptions{});
    ASSERT_EQ(s.links, (std::vector<std::string>{"sole_l", "sole_r"}));
    for (const auto& row : s.stance) {
      EXPECT_EQ(row[0], lift_m < 0.1 ? 1 : 0);
      EXPECT_EQ(row[1], 1);
    }
  }
}

// A figure standing still on both soles tilted by the same ankle angle, its lowest points
// on the ground. Tilted by 0.5 rad it stands on its toes or heels (tiptoe, kneeling): the
// clean-up holds each sole as the reference does. Tilted by 0.2 rad the tilt is taken for a
// retargeting error and the soles are laid flat.
TEST(ReferenceCleanup, ASoleStandingOnItsEdgeKeepsItsTiltAFlatOneIsLevelled) {
  auto model = test::makeMiniHumanoid();
  const ModelInfo& info = model->info();
  for (const double tilt : {0.5, -0.5, 0.2}) {
    SCOPED_TRACE(tilt);
    Eigen::VectorXd q = info.neutralConfiguration();
    for (const char* ankle : {"talo_l_y", "talo_r_y"}) q[info.configurationIndex(info.findJoint(ankle))] = tilt;
    q[2] = standingBaseHeight(*model, q);
    ReferenceCleanupOptions options;
    options.lowpass_hz = 0.0;
    const CleanupResult r = cleanupReference(stillMotion(info, q, 61), *model, options, proxqp::factory());
    for (const auto& row : r.schedule.stance) EXPECT_EQ(row, (std::vector<char>{1, 1}));
    for (const char* ankle : {"talo_l_y", "talo_r_y"}) {
      const double after = r.motion.frames[30].q[info.configurationIndex(info.findJoint(ankle))];
      if (std::fabs(tilt) > 0.35)
        EXPECT_NEAR(after, tilt, 1e-3) << ankle;
      else
        EXPECT_NEAR(after, 0.0, 0.02) << ankle;
    }
  }
}

// Heel-off: a figure stands flat for 0.6 s, then both ankles turn by ±0.3 rad over 0.3 s
// with the base raised so that the lowest sole edge stays on the ground (on its toes, or on
// its heels). The clean-up keeps the run's flat pose, and from where the sole leaves the
// run's level rolls it over that edge: at the end the sole is pitched by the reference's
// 0.3 rad less the 0.05 rad dead band, and the edge it stands on has not moved. (Laid flat,
// as a constant tilt is, it would end level.)
TEST(ReferenceCleanup, AStanceSoleRollsOverTheEdgeTheReferenceLiftsItsHeelOrToesOver) {
  auto model = test::makeMiniHumanoid();
  const ModelInfo& info = model->info();
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(info.nv);
  const int sole = info.findBody("sole_l");
  model->setState(info.neutralConfiguration(), v0);
  const Eigen::Vector3d fwd_B = model->bodyPose(sole).linear().transpose() * Eigen::Vector3d::UnitX();
  auto pitchOf = [&](const Eigen::VectorXd& q) {
    model->setState(q, v0);
    const Eigen::Vector3d x = model->bodyPose(sole).linear() * fwd_B;
    return std::atan2(-x.z(), x.head<2>().norm());
  };
  // The mean of the sole's points within 5 mm of the ground (world) at q.
  auto lowestPoint = [&](const Eigen::VectorXd& q) {
    ContactList contacts(64);
    Eigen::VectorXd lowered = q;
    lowered[2] -= 0.005;
    model->setState(lowered, v0);
    model->detectContacts(contacts);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int n = 0;
    for (const ContactCandidate& c : contacts)
      if (c.body == sole) {
        sum += c.p_WC;
        ++n;
      }
    return Eigen::Vector3d(sum / std::max(n, 1) + Eigen::Vector3d(0.0, 0.0, 0.005));
  };
  for (const double turn : {0.3, -0.3}) {
    SCOPED_TRACE(turn);
    ReferenceMotion motion = stillMotion(info, info.neutralConfiguration(), 90);
    for (int k = 0; k < 90; ++k) {
      Eigen::VectorXd& q = motion.frames[static_cast<std::size_t>(k)].q;
      const double s = k < 60 ? 0.0 : (k - 60) / 29.0;
      for (const char* ankle : {"talo_l_y", "talo_r_y"})
        q[info.configurationIndex(info.findJoint(ankle))] = turn * s * s * (3.0 - 2.0 * s);
      q[2] = standingBaseHeight(*model, q);
    }
    const double reference_pitch = pitchOf(motion.frames[89].q);
    ASSERT_GT(std::fabs(reference_pitch), 0.25);
    ReferenceCleanupOptions options;
    options.lowpass_hz = 0.0;
    const CleanupResult r = cleanupReference(motion, *model, options, proxqp::factory());
    for (const auto& row : r.schedule.stance) ASSERT_EQ(row, (std::vector<char>{1, 1}));
    EXPECT_NEAR(pitchOf(r.motion.frames[30].q), 0.0, 0.01);
    EXPECT_NEAR(pitchOf(r.motion.frames[89].q), std::copysign(std::fabs(reference_pitch) - 0.05, turn), 0.01);
    // The edge it stands on, at the end, is where that edge was while the sole was flat.
    const Eigen::Vector3d edge_end = lowestPoint(r.motion.frames[89].q);
    model->setState(r.motion.frames[89].q, v0);
    const Eigen::Isometry3d X_end = model->bodyPose(sole);
    model->setState(r.motion.frames[30].q, v0);
    const Eigen::Vector3d edge_flat = model->bodyPose(sole) * (X_end.inverse() * edge_end);
    EXPECT_LT((edge_end - edge_flat).norm(), 1e-3);
    EXPECT_LT(std::fabs(edge_end.z()), 1e-3);
  }
}

TEST(LowPassConfigurations, KeepsLinesAndDampsNoiseAsItsGaussian) {
  const int n = 1001;
  const double dt = 0.001, cutoff = 8.0, sigma = 0.1325 / cutoff;
  std::vector<ReferenceFrame> frames(n, ReferenceFrame(3, 3));
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    frames[static_cast<std::size_t>(k)].time_s = t;
    frames[static_cast<std::size_t>(k)].q << 0.7, 0.3 + 2.0 * t, 0.01 * std::sin(2.0 * M_PI * 30.0 * t);
  }
  lowPassConfigurations(frames, false, cutoff);
  const double gain = std::exp(-0.5 * std::pow(2.0 * M_PI * 30.0 * sigma, 2));
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    const Eigen::VectorXd& q = frames[static_cast<std::size_t>(k)].q;
    EXPECT_NEAR(q[0], 0.7, 1e-12);
    if (k < 60 || k > n - 61) continue;  // the kernel reaches past the ends there
    EXPECT_NEAR(q[1], 0.3 + 2.0 * t, 1e-9) << k;
    EXPECT_NEAR(q[2], 0.01 * gain * std::sin(2.0 * M_PI * 30.0 * t), 2e-5) << k;
  }
  EXPECT_THROW(lowPassConfigurations(frames, false, 0.0), std::invalid_argument);
}

// A floating base turning at a constant rate keeps turning at that rate.
TEST(LowPassConfigurations, BaseOrientationAveragedOnTheGroup) {
  std::vector<ReferenceFrame> frames(201, ReferenceFrame(7, 6));
  for (int k = 0; k < 201; ++k) {
    const double yaw = 0.02 * k;
    const Eigen::Quaterniond Q(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()));
    frames[static_cast<std::size_t>(k)].time_s = 0.005 * k;
    frames[static_cast<std::size_t>(k)].q << 0.0, 0.0, 1.0, Q.w(), Q.x(), Q.y(), Q.z();
  }
  const std::vector<ReferenceFrame> in = frames;
  lowPassConfigurations(frames, true, 8.0);
  for (int k = 30; k < 170; ++k) {
    const Eigen::VectorXd& a = in[static_cast<std::size_t>(k)].q;
    const Eigen::VectorXd& b = frames[static_cast<std::size_t>(k)].q;
    // The mean of a uniform rotation about z, taken in R_k's frame, is R_k rotated about
    // z by the kernel's (symmetric) mean angle 0 — up to the curvature of the log map.
    EXPECT_LT(std::fabs(std::fabs(Eigen::Quaterniond(a[3], a[4], a[5], a[6]).dot(Eigen::Quaterniond(b[3], b[4], b[5], b[6]))) - 1.0), 1e-6) << k;
    EXPECT_NEAR(b.segment<4>(3).norm(), 1.0, 1e-12);
  }
}

}  // namespace
}  // namespace dynfilter::io
