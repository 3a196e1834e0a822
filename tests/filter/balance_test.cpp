// The balance layer of the QP mode (core/include/dynfilter/core/balance.hpp): centroidal
// quantities from the mass matrix against an independent sum over the URDF's links (both
// backends), references the figure cannot follow (hanging in the air, a 40° slope) ending
// in a clear status instead of teleports, landings and push-offs of a sole. The CMU walk's
// first steps: balance_walk_test.cpp.
#include <algorithm>
#include <fstream>
#include <iterator>
#include <limits>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/core/balance.hpp"
#include "dynfilter/core/reference_leash.hpp"
#include "dynfilter/core/dynamics_filter.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/qp_engines/qp_engines.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {


Eigen::Vector3d comFromLinks(const IDynamicsModel& model, const urdf::RobotDescription& robot) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double mass = 0.0;
  for (std::size_t i = 0; i < robot.links.size(); ++i) {
    const auto& inertial = robot.links[i].inertial;
    if (!inertial.present) continue;
    sum += inertial.mass_kg * (model.bodyPose(static_cast<int>(i)) * inertial.p_LCom);
    mass += inertial.mass_kg;
  }
  return sum / mass;
}

class Centroidal : public testing::TestWithParam<std::string> {};

TEST_P(Centroidal, FromTheMassMatrixMatchesTheLinksAndItsOwnDerivative) {
  const auto robot = urdf::loadUrdfFile(test::humanFigurePath());
  auto model = test::makeModel(GetParam(), robot, ModelOptions{});
  const ModelInfo& info = model->info();
  std::mt19937 rng(7);
  Eigen::VectorXd q, v, q_plus(info.nq), q_minus(info.nq);
  Eigen::MatrixXd A(info.nv, info.nv);
  for (int trial = 0; trial < 10; ++trial) {
    randomState(info, rng, 1.0, q, v);
    model->setState(q, v);
    model->massMatrix(A);
    const CentroidalState s = centroidalState(A, q, v, info.total_mass);
    EXPECT_LE((s.c_W - comFromLinks(*model, robot)).norm(), 1e-9) << "trial " << trial;
    // ċ against a central difference of c along v.
    const double h = 1e-6;
    integrateConfiguration(true, q, v, h, q_plus);
    integrateConfiguration(true, q, v, -h, q_minus);
    model->setState(q_plus, v);
    const Eigen::Vector3d c_plus = comFromLinks(*model, robot);
    model->setState(q_minus, v);
    const Eigen::Vector3d c_minus = comFromLinks(*model, robot);
    EXPECT_LE((s.cdot_W - (c_plus - c_minus) / (2 * h)).norm(), 1e-6 * (1.0 + s.cdot_W.norm()))
        << "trial " << trial;
  }
}

INSTANTIATE_TEST_SUITE_P(Backends, Centroidal, testing::Values("dart", "ode"));

// A standing reference the figure cannot follow: reports why, never re-seeds.
struct Unfollowable {
  std::uint32_t status = 0;
  int reason = 0;
  std::uint64_t reseeds = 0;
  bool finite = true;
};

Unfollowable standStill(const ModelOptions& model_options, double lift_m, double seconds) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), model_options);
  const ModelInfo& info = model->info();
  ReferenceFrame ref(info.nq, info.nv);
  ref.q = info.neutralConfiguration();
  ModelOptions flat;
  auto level = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), flat);
  ref.q[2] = standingBaseHeight(*level, ref.q) + lift_m;
  const FilterOptions options = test::qpDefaults(1e-3);
  DynamicsFilter filter(*model, options, qp_engines::factory(QpSolverSettings{}.engine));
  filter.reset(ref);
  Unfollowable u;
  for (int k = 0; k < static_cast<int>(seconds / options.dt_s); ++k) {
    ref.time_s = k * options.dt_s;
    const FilterOutput& out = filter.step(ref);
    u.finite = u.finite && out.q.allFinite() && out.tau_J.allFinite();
  }
  u.status = filter.output().status;
  u.reason = filter.output().infeasible_reason;
  u.reseeds = filter.output().counters.reseeds;
  return u;
}

TEST(Balance, AReferenceHangingInTheAirEndsInAClearStatusNotInTeleports) {
  const Unfollowable u = standStill(ModelOptions{}, 0.5, 1.0);
  EXPECT_TRUE(u.finite);
  EXPECT_NE(u.status & kStatusReferenceInfeasible, 0u) << "status " << u.status;
  EXPECT_EQ(u.reason, static_cast<int>(InfeasibleReason::kNoSupport));
  EXPECT_EQ(u.reseeds, 0u);
  EXPECT_NE(std::string(toString(InfeasibleReason::kNoSupport)).find("hanging"), std::string::npos);
}

TEST(Balance, StandingOnA40DegreeSlopeEndsInAClearStatusNotInTeleports) {
  ModelOptions steep;
  steep.environment.ground = GroundPlane::sloped(40.0 * M_PI / 180.0);
  const Unfollowable u = standStill(steep, 0.0, 0.6);
  EXPECT_TRUE(u.finite);
  EXPECT_NE(u.status & kStatusReferenceInfeasible, 0u) << "status " << u.status;
  EXPECT_EQ(u.reason, static_cast<int>(InfeasibleReason::kOutsideCone));
  EXPECT_EQ(u.reseeds, 0u);
}

TEST(Balance, AFollowableStandingReferenceIsNotReportedInfeasible) {
  // Control for the two above: the same standing reference on level ground.
  const Unfollowable u = standStill(ModelOptions{}, 0.0, 0.5);
  EXPECT_TRUE(u.finite);
  EXPECT_EQ(u.status & kStatusReferenceInfeasible, 0u) << "status " << u.status;
  EXPECT_EQ(u.reseeds, 0u);
}

// A standing reference whose feet leave the ground for 0.12 s (lifted 3 cm: no body in
// stance) while its centre of mass, at rest, needs the ground's support: a foot rolling on
// an edge or gliding in a retargeted clip, not a flight. The figure keeps the links it
// holds instead of letting go of the ground; the status says the reference is unsupported
// only after 0.25 s of it, so not here.
TEST(Balance, AnUnsupportedReferenceThatNeedsSupportDoesNotLetGoOfTheGround) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const ModelInfo& info = model->info();
  ReferenceFrame ref(info.nq, info.nv);
  ref.q = info.neutralConfiguration();
  const double stand_z = standingBaseHeight(*model, ref.q);
  ref.q[2] = stand_z;
  const FilterOptions options = test::qpDefaults(1e-3);
  DynamicsFilter filter(*model, options, qp_engines::factory(QpSolverSettings{}.engine));
  filter.reset(ref);
  int fewest_contacts = 100;
  std::uint32_t status_union = 0;
  for (int k = 0; k < 600; ++k) {
    ref.time_s = k * options.dt_s;
    ref.q[2] = stand_z + (ref.time_s >= 0.3 && ref.time_s < 0.42 ? 0.03 : 0.0);
    const FilterOutput& out = filter.step(ref);
    if (k >= 50) fewest_contacts = std::min(fewest_contacts, out.num_contacts);
    status_union |= out.status;
  }
  EXPECT_GE(fewest_contacts, 2);
  EXPECT_EQ(filter.output().counters.links_released, 0u);
  EXPECT_EQ(filter.output().counters.reseeds, 0u);
  EXPECT_EQ(status_union & (kStatusReseeded | kStatusReferenceInfeasible | kStatusQpFallback), 0u)
      << "status union " << status_union;
}

// The DCM target where the reference's CoP stays inside its support is the reference's own
// DCM, c + ċ/ω, exactly: a standing figure swaying 1 cm along x at 0.5 Hz and bobbing 1 cm
// at 1 Hz (its pendulum's ω changes with its height and vertical acceleration), the whole
// future in the preview. Before the target was the reference's DCM moved by what its support
// cannot carry, it came from integrating the reference's CoP backwards with the present ω,
// which the bobbing makes disagree.
TEST(Balance, TheDcmTargetOfAReferenceInsideItsSupportIsItsOwnDcm) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const ModelInfo& info = model->info();
  Eigen::VectorXd q0 = info.neutralConfiguration();
  q0[2] = standingBaseHeight(*model, q0);
  const double a = 0.01, w_sway = M_PI, w_bob = 2.0 * M_PI;
  auto frameAt = [&](double t) {
    ReferenceFrame f(info.nq, info.nv);
    f.time_s = t;
    f.q = q0;
    f.q[0] += a * std::sin(w_sway * t);
    f.q[2] += a * std::sin(w_bob * t);
    f.v[0] = a * w_sway * std::cos(w_sway * t);
    f.v[2] = a * w_bob * std::cos(w_bob * t);
    f.vdot[0] = -a * w_sway * w_sway * std::sin(w_sway * t);
    f.vdot[2] = -a * w_bob * w_bob * std::sin(w_bob * t);
    return f;
  };
  BalanceOptions options;
  options.preview_s = 10.0;
  options.preview_capacity = 1024;
  BalanceLayer layer(*model, options);
  for (int k = 0; k <= 400; ++k) ASSERT_TRUE(layer.pushPreview(*model, frameAt(k / 100.0)));
  double worst = 0.0;
  for (const double t : {0.305, 0.81, 1.333, 2.0, 2.52}) {
    layer.prepare(*model, frameAt(t), 1e-3);
    const BalanceState& s = layer.state();
    const double omega = std::sqrt(kStandardGravity / s.reference.c_W.z());
    const Eigen::Vector2d xi = s.reference.c_W.head<2>() + s.reference.cdot_W.head<2>() / omega;
    worst = std::max(worst, (s.dcm_desired - xi).norm());
    EXPECT_EQ(s.infeasible, InfeasibleReason::kNone);
  }
  EXPECT_LT(worst, 1e-9);
}

// The standing pose @p q0 swaying along x by a sin(w t), with its velocity and acceleration.
ReferenceFrame swayingFrame(const ModelInfo& info, const Eigen::VectorXd& q0, double a, double w, double t) {
  ReferenceFrame f(info.nq, info.nv);
  f.time_s = t;
  f.q = q0;
  f.q[0] += a * std::sin(w * t);
  f.v[0] = a * w * std::cos(w * t);
  f.vdot[0] = -a * w * w * std::sin(w * t);
  return f;
}

// The backward pass reuses each segment's CoP excess while its samples stay (offline the
// window holds seconds of samples that every tick shares). A reference swaying 8 cm at
// 1.5 Hz needs a CoP outside its soles, so the excesses are not zero; the layer prepared tick
// after tick must give, bit for bit, the target of a fresh layer prepared once at that
// tick from the same samples — also after the model's ground changed under the same layer
// (a 5° slope: the segments' CoPs are measured from the ground).
TEST(Balance, TheCachedBackwardPassGivesTheTargetOfAFreshLayer) {
  auto flat = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  ModelOptions sloped_options;
  sloped_options.environment.ground = GroundPlane::sloped(5.0 * M_PI / 180.0);
  auto sloped = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), sloped_options);
  const ModelInfo& info = flat->info();
  Eigen::VectorXd q0 = info.neutralConfiguration();
  q0[2] = standingBaseHeight(*flat, q0);
  const double a = 0.08, w = 3.0 * M_PI;
  auto frameAt = [&](double t) { return swayingFrame(info, q0, a, w, t); };
  BalanceOptions options;
  options.preview_s = 10.0;
  options.preview_capacity = 1024;
  // The preview arrives as on-line, 0.5 s ahead of the tick: segments at its end are
  // computed before their after-samples exist and must be computed again when they come.
  const double ahead_s = 0.5;
  BalanceLayer layer(*flat, options);
  int pushed = 0;
  double largest_offset = 0.0;
  int compared = 0;
  for (int k = 0; k < 300; ++k) {
    const double t = 0.2 + k * 2e-3;
    while (pushed / 120.0 <= t + ahead_s) ASSERT_TRUE(layer.pushPreview(*flat, frameAt(pushed++ / 120.0)));
    IDynamicsModel& model = t < 0.6 ? *flat : *sloped;
    layer.prepare(model, frameAt(t), 2e-3);
    if (k % 25 != 0 && k != 100) continue;  // k = 100: the first tick on the slope
    BalanceLayer fresh(model, options);
    for (int j = 0; j <= 400; ++j) {
      if (j / 120.0 <= t - 0.1 || j / 120.0 > t + ahead_s) continue;
      ASSERT_TRUE(fresh.pushPreview(*flat, frameAt(j / 120.0)));
    }
    fresh.prepare(model, frameAt(t), 2e-3);
    EXPECT_EQ(layer.state().dcm_desired.x(), fresh.state().dcm_desired.x()) << "t = " << t;
    EXPECT_EQ(layer.state().dcm_desired.y(), fresh.state().dcm_desired.y()) << "t = " << t;
    const BalanceState& st = layer.state();
    const double omega = std::sqrt(kStandardGravity / st.reference.c_W.z());
    const Eigen::Vector2d xi = st.reference.c_W.head<2>() + st.reference.cdot_W.head<2>() / omega;
    largest_offset = std::max(largest_offset, (st.dcm_desired - xi).norm());
    ++compared;
  }
  EXPECT_EQ(compared, 12);
  EXPECT_GT(largest_offset, 0.01) << "the reference's CoP must leave its support for the excesses to matter";
}

// The reference leash moves the preview with the reference (BalanceLayer::transformPreview):
// a layer whose samples were moved by a turn about the vertical and a shift must give the
// target of a fresh layer fed the moved frames, and that target is the moved one.
TEST(Balance, APreviewMovedByTheLeashGivesTheTargetOfTheMovedReference) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const ModelInfo& info = model->info();
  Eigen::VectorXd q0 = info.neutralConfiguration();
  q0[2] = standingBaseHeight(*model, q0);
  const double a = 0.08, w = 3.0 * M_PI;  // a CoP outside the soles: the excesses matter
  auto frameAt = [&](double t) { return swayingFrame(info, q0, a, w, t); };
  const Eigen::Isometry3d X = Eigen::Translation3d(0.3, -0.2, 0.0) *
                              Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitZ()) *
                              Eigen::Translation3d(-0.1, 0.05, 0.0);
  auto moved = [&](double t) {
    ReferenceFrame f = frameAt(t);
    moveBase(X, f.q);
    return f;
  };
  BalanceOptions options;
  options.preview_s = 2.0;
  BalanceLayer layer(*model, options), fresh(*model, options), unmoved(*model, options);
  for (int k = 0; k <= 240; ++k) {
    ASSERT_TRUE(layer.pushPreview(*model, frameAt(k / 120.0)));
    ASSERT_TRUE(unmoved.pushPreview(*model, frameAt(k / 120.0)));
    ASSERT_TRUE(fresh.pushPreview(*model, moved(k / 120.0)));
  }
  const double t = 0.31;
  layer.prepare(*model, frameAt(t - 0.01), 1e-3);  // its excesses cached on the unmoved samples
  layer.transformPreview(X);
  layer.prepare(*model, moved(t), 1e-3);
  fresh.prepare(*model, moved(t), 1e-3);
  unmoved.prepare(*model, frameAt(t), 1e-3);
  const Eigen::Vector2d xi = layer.state().dcm_desired;
  // The fresh layer finds its supports by collision at the moved pose: the engine's
  // contact points agree to ~1e-8 m.
  EXPECT_LT((xi - fresh.state().dcm_desired).norm(), 1e-7);
  const Eigen::Vector2d xi0 = unmoved.state().dcm_desired;
  EXPECT_LT((xi - (X * Eigen::Vector3d(xi0.x(), xi0.y(), 0.0)).head<2>()).norm(), 1e-9);
  const double omega = std::sqrt(kStandardGravity / unmoved.state().reference.c_W.z());
  const Eigen::Vector2d own = unmoved.state().reference.c_W.head<2>() + unmoved.state().reference.cdot_W.head<2>() / omega;
  EXPECT_GT((xi0 - own).norm(), 0.01) << "the excesses must move the target for the test to see them";
}

// Flat landing: a sole that touches down on its heel edge holds a face link over its whole
// sole, anchored flat on the ground about the heel; a steeper sole keeps its edge link.
// The virtual links the default contact options make from the collisions at @p q (v = 0).
VirtualLinkSet linksAt(IDynamicsModel& model, const Eigen::VectorXd& q) {
  model.setState(q, Eigen::VectorXd::Zero(model.nv()));
  ContactList candidates(64);
  model.detectContacts(candidates);
  VirtualLinkSet links(ContactOptions{}, model.nv());
  std::uint32_t status = 0;
  links.update(model, candidates, status);
  return links;
}

// The link @p body holds (the last one), or a default link (body −1) when it holds none.
VirtualLink linkOf(const VirtualLinkSet& links, int body) {
  VirtualLink found;
  for (int i = 0; i < links.size(); ++i)
    if (links[i].body == body) found = links[i];
  return found;
}

struct Landing {
  int changed = 0;
  VirtualLink before, after;
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
};

Landing landOnHeel(double ankle_pitch_rad, double max_tilt_rad, double reference_ankle_pitch_rad = 0.0,
                   const urdf::UrdfLoadOptions& load = {}) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath(), load), ModelOptions{});
  const ModelInfo& info = model->info();
  BalanceOptions options;
  options.flat_landing_max_tilt_rad = max_tilt_rad;
  BalanceLayer layer(*model, options);
  Eigen::VectorXd q = info.neutralConfiguration();
  q[info.configurationIndex(info.findJoint("r_ankle_pitch"))] = ankle_pitch_rad;  // toes up
  q[info.configurationIndex(info.findJoint("l_knee"))] = 1.0;                      // left foot up
  q[2] = standingBaseHeight(*model, q) - 0.001;  // the right heel 1 mm into the ground
  ReferenceFrame reference(info.nq, info.nv);  // the reference's sole at this pitch
  reference.q = q;
  reference.q[info.configurationIndex(info.findJoint("r_ankle_pitch"))] = reference_ankle_pitch_rad;
  layer.prepare(*model, reference, 1e-3);
  VirtualLinkSet links = linksAt(*model, q);
  Landing l;
  const int foot = info.findBody("r_foot");
  l.before = linkOf(links, foot);
  l.changed = layer.flattenLandings(*model, links);
  l.after = linkOf(links, foot);
  l.X_WB = model->bodyPose(foot);
  return l;
}

TEST(Balance, ASoleLandingOnItsHeelHoldsAFlatFaceOverTheWholeSole) {
  const double tilt = 0.2;  // rad, toes up
  const Landing l = landOnHeel(-tilt, 0.5);
  ASSERT_NE(l.before.body, -1) << "the heel touches";
  EXPECT_NE(l.before.kind, ContactKind::kFace);
  EXPECT_EQ(l.changed, 1);
  EXPECT_EQ(l.after.kind, ContactKind::kFace);
  EXPECT_EQ(l.after.num_axes, 6);
  // The sole's box: 0.259 m x 0.0986 m (models/human_figure.urdf), centred on the link frame.
  EXPECT_NEAR(l.after.support_max.x() - l.after.support_min.x(), 0.2594, 1e-3);
  EXPECT_NEAR(l.after.support_max.y() - l.after.support_min.y(), 0.0986, 1e-3);
  EXPECT_NEAR(l.after.support_max.x(), -l.after.support_min.x(), 1e-6);
  // Anchored flat on the ground, the link frame tilted from it by the sole's tilt: the
  // link error its stabilisation removes.
  EXPECT_NEAR(l.after.X_WA.translation().z(), 0.0, 1e-9);
  EXPECT_NEAR(l.after.X_WA.linear().col(2).dot(Eigen::Vector3d::UnitZ()), 1.0, 1e-12);
  const Eigen::Isometry3d X_WC = l.X_WB * l.after.X_BC;
  EXPECT_NEAR(logSO3(l.after.X_WA.linear().transpose() * X_WC.linear()).norm(), tilt, 0.02);
  // The heel stays where it touched: its point, flat on the anchor, is the old link's.
  const Eigen::Vector3d heel_C = l.after.X_BC.inverse() * l.before.X_BC.translation();
  const Eigen::Vector3d heel_flat = l.after.X_WA * Eigen::Vector3d(heel_C.x(), heel_C.y(), 0.0);
  EXPECT_LE((heel_flat - l.before.X_WA.translation()).norm(), 1e-9);
  EXPECT_LT(heel_C.x(), -0.1) << "the heel is at the back of the sole";
}

TEST(Balance, ASoleLandingSteeperThanTheLimitKeepsItsEdge) {
  const Landing steep = landOnHeel(-0.2, 0.1);
  EXPECT_EQ(steep.changed, 0);
  EXPECT_EQ(steep.after.kind, steep.before.kind);
  const Landing off = landOnHeel(-0.2, 0.0);  // flat landing off
  EXPECT_EQ(off.changed, 0);
}

// A leg of five joints (the ankle rolls welded, as on robots without one) cannot lay its
// sole flat wherever it lands: a flat face link would make the rest of the body do it (on a
// Unitree H1 description the QP then relaxed from the soccer kick's first tick and the robot
// fell at 0.18 s). Its sole keeps the link it landed on.
TEST(Balance, ASoleOfAFiveJointLegKeepsTheLinkItLandedOn) {
  urdf::UrdfLoadOptions welded;
  welded.lock_joints = {"l_ankle_roll", "r_ankle_roll"};
  const Landing l = landOnHeel(-0.2, 0.5, -0.05, welded);
  ASSERT_NE(l.before.body, -1) << "the heel touches";
  EXPECT_NE(l.before.kind, ContactKind::kFace);
  EXPECT_EQ(l.changed, 0);
  EXPECT_EQ(l.after.kind, l.before.kind);
  EXPECT_EQ(landOnHeel(-0.2, 0.5, -0.05).changed, 1) << "the same landing with six joints";
}

TEST(Balance, ASoleLandsFlatOnlyOnceTheReferenceHasItFlat) {
  const Landing heel_strike = landOnHeel(-0.2, 0.5, -0.2);  // the reference on its heel too
  EXPECT_EQ(heel_strike.changed, 0);
  EXPECT_EQ(heel_strike.after.kind, heel_strike.before.kind);
  const Landing foot_flat = landOnHeel(-0.2, 0.5, -0.05);
  EXPECT_EQ(foot_flat.changed, 1);
}

// Rolling soles: the filter's right sole stands flat (a face link); the reference has the
// same sole on its toes, heel 0.2 rad up, and lifts it 0.1 s later (push-off). The face
// becomes an edge link along the toe edge, marked rolling, so the sole can hinge there.
// @p text with every @p from replaced by @p to.
std::string replacedAll(std::string text, const std::string& from, const std::string& to) {
  for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
  return text;
}

struct Roll {
  int changed = 0;
  VirtualLink before, after;
  Eigen::Vector3d toes_B = Eigen::Vector3d::Zero();  // the right sole footprint's x (body frame)
};

// A figure's names for the push-off: its knees, its right ankle's pitch and its right sole.
struct PushOffFigure {
  std::string urdf, left_knee, right_knee, right_ankle_pitch, right_sole;
};

PushOffFigure humanFigurePushOff() { return {test::humanFigurePath(), "l_knee", "r_knee", "r_ankle_pitch", "r_foot"}; }

Roll pushOff(double roll_tilt_rad, bool lifts_soon, double reference_ankle_pitch_rad = 0.2,
             const PushOffFigure& figure = humanFigurePushOff()) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(figure.urdf), ModelOptions{});
  const ModelInfo& info = model->info();
  BalanceOptions options;
  options.roll_tilt_rad = roll_tilt_rad;
  BalanceLayer layer(*model, options);
  Eigen::VectorXd q = info.neutralConfiguration();
  q[info.configurationIndex(info.findJoint(figure.left_knee))] = 1.0;  // left foot up
  q[2] = standingBaseHeight(*model, q) - 0.001;                        // the right sole 1 mm in, flat
  ReferenceFrame now(info.nq, info.nv);
  now.q = q;
  now.q[info.configurationIndex(info.findJoint(figure.right_ankle_pitch))] = reference_ankle_pitch_rad;  // heel up
  now.q[2] = standingBaseHeight(*model, now.q);
  ReferenceFrame later = now;
  later.time_s = 0.1;
  later.q[info.configurationIndex(info.findJoint(figure.right_knee))] = 1.0;  // the right foot up
  later.q[info.configurationIndex(info.findJoint(figure.left_knee))] = 0.0;
  later.q[2] = standingBaseHeight(*model, later.q);
  if (lifts_soon) {
    layer.pushPreview(*model, now);
    layer.pushPreview(*model, later);
  }
  layer.prepare(*model, now, 1e-3);
  VirtualLinkSet links = linksAt(*model, q);
  Roll r;
  const int foot = info.findBody(figure.right_sole);
  for (std::size_t s = 0; s < layer.soleBodies().size(); ++s)
    if (layer.soleBodies()[s] == foot) r.toes_B = layer.soleFootprints()[s].X_BS.linear().col(0);
  r.before = linkOf(links, foot);
  r.changed = layer.rollSoles(links);
  r.after = linkOf(links, foot);
  return r;
}

TEST(Balance, ASolePushingOffRollsOnItsToeEdge) {
  const Roll r = pushOff(0.1, true);
  ASSERT_EQ(r.before.kind, ContactKind::kFace) << "the flat sole holds a face";
  EXPECT_EQ(r.changed, 1);
  EXPECT_EQ(r.after.kind, ContactKind::kEdge);
  EXPECT_TRUE(r.after.rolling);
  // The edge: across the sole at its front (the toe), as long as the sole is wide.
  const Eigen::Vector3d edge_B = r.after.X_BC.translation();
  EXPECT_NEAR(edge_B.x(), r.before.X_BC.translation().x() + r.before.support_max.x(), 1e-9);
  EXPECT_NEAR(r.after.support_max.x() - r.after.support_min.x(),
              r.before.support_max.y() - r.before.support_min.y(), 1e-9);
  EXPECT_NEAR(std::fabs(r.after.X_BC.linear().col(0).dot(r.before.X_BC.linear().col(1))), 1.0, 1e-9);
  // The anchor stays on the ground where the face's toe edge was.
  EXPECT_NEAR(r.after.X_WA.translation().z(), r.before.X_WA.translation().z(), 1e-9);
}

TEST(Balance, ASoleKeepsItsFaceWhenTheReferenceDoesNotLiftItOrRollingIsOff) {
  EXPECT_EQ(pushOff(0.1, false).changed, 0);  // heel up, but no lift in the preview
  // Toes up (as a level reference sole looks on a downhill slope), lifted soon: no roll.
  const Roll toes_up = pushOff(0.1, true, -0.2);
  EXPECT_EQ(toes_up.changed, 0);
  EXPECT_EQ(toes_up.after.kind, ContactKind::kFace);
  const Roll off = pushOff(0.0, true);
  EXPECT_EQ(off.changed, 0);
  EXPECT_EQ(off.after.kind, ContactKind::kFace);
}

// Which end of a sole holds its toes comes from the model, not from the link frame's x: the
// ankle stands over the heel's half. The test figure with its feet turned to point along −x
// of their links (as on a robot that faces −x of its base) rolls onto its −x edge when the
// reference raises that heel; with the link frame's x taken for the toes it was flattened.
TEST(Balance, ASoleRollsOnTheEdgeItsToesPointTo) {
  for (const double toes : {1.0, -1.0}) {
    SCOPED_TRACE(toes > 0 ? "toes along +x" : "toes along -x");
    const std::string path = test::editedTestModel(
        "mini_humanoid.urdf",
        [toes](const std::string& text) {
          return toes > 0 ? text : replacedAll(text, R"(<origin xyz="0.03 0 -0.04"/>)", R"(<origin xyz="-0.03 0 -0.04"/>)");
        },
        "mini_humanoid_toes.urdf");
    const Roll r = pushOff(0.1, true, 0.2 * toes, {path, "genu_l", "genu_r", "talo_r_y", "sole_r"});
    EXPECT_NEAR(r.toes_B.x(), toes, 1e-9) << "the footprint's x points to the toes";
    ASSERT_EQ(r.before.kind, ContactKind::kFace) << "the flat sole holds a face";
    EXPECT_EQ(r.changed, 1);
    EXPECT_EQ(r.after.kind, ContactKind::kEdge);
    EXPECT_TRUE(r.after.rolling);
    // The edge lies across the sole at its toes' end: 9 cm from the middle of an 18 cm sole.
    EXPECT_NEAR((r.after.X_BC.translation() - r.before.X_BC.translation()).x(), 0.09 * toes, 1e-6);
  }
}

// The mini humanoid with @p extra small bodies on tiny chest joints, written before its
// legs (bodies are numbered in file order: the soles come after them).
std::string miniHumanoidWithExtraBodies(int extra) {
  std::string bodies;
  for (int k = 0; k < extra; ++k) {
    const std::string n = std::to_string(k);
    bodies += "<link name=\"tag_" + n + "\"><inertial><mass value=\"0.001\"/>"
              "<inertia ixx=\"1e-7\" ixy=\"0\" ixz=\"0\" iyy=\"1e-7\" iyz=\"0\" izz=\"1e-7\"/></inertial></link>"
              "<joint name=\"tag_" + n + "_joint\" type=\"revolute\"><parent link=\"chest\"/><child link=\"tag_" + n +
              "\"/><origin xyz=\"0 0 0.3\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint>\n";
  }
  return test::editedTestModel(
      "mini_humanoid.urdf",
      [&bodies](std::string text) { return text.insert(text.find("  <link name=\"hipz_l\">"), bodies); },
      "mini_humanoid_" + std::to_string(extra) + "_extra.urdf");
}

// A model with more than 64 bodies (a humanoid with hands has 53-60) has its soles' stance
// in the schedule wherever they are numbered: here bodies 77 and 86. With 64 bits, bodies
// past 63 were never in the reference's stance, never lifted soon and always held.
// More bodies than the set holds are refused with the count.
TEST(Balance, TheStanceOfBodiesNumberedPast64IsTracked) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(miniHumanoidWithExtraBodies(70)), ModelOptions{});
  const ModelInfo& info = model->info();
  BalanceLayer layer(*model, BalanceOptions{});
  ASSERT_EQ(layer.soleBodies().size(), 2u);
  ReferenceFrame frame(info.nq, info.nv);
  frame.q = info.neutralConfiguration();
  frame.q[info.configurationIndex(info.findJoint("genu_l"))] = 1.0;  // the left foot up
  frame.q[2] = standingBaseHeight(*model, frame.q);
  layer.prepare(*model, frame, 1e-3);
  const int right = info.findBody("sole_r"), left = info.findBody("sole_l");
  ASSERT_GE(std::min(right, left), 64);
  EXPECT_TRUE(layer.referenceStance()[static_cast<std::size_t>(right)]) << "the right sole stands";
  EXPECT_FALSE(layer.referenceStance()[static_cast<std::size_t>(left)]) << "the left sole is up";
  EXPECT_EQ(layer.referenceStance().count(), 1u);

  auto big = test::makeModel("dart", urdf::loadUrdfFile(miniHumanoidWithExtraBodies(kMaxSetBodies)), ModelOptions{});
  try {
    BalanceLayer refused(*big, BalanceOptions{});
    ADD_FAILURE() << "a model with more bodies than a BodySet holds was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("at most 256 bodies"), std::string::npos) << e.what();
  }
}

// A rolling sole turns with the reference's: the figure stands on its right toe edge with
// its heel 0.2 rad up, the ankle turning at 3 rad/s and speeding up by 20 rad/s², state and
// reference alike. The sole's rows are then met by the reference's own acceleration: they
// do not brake the push-off (without the reference's rate they ask for kd·ω less).
TEST(Balance, ARollingSolesRowsAreMetByTheReferencesOwnRoll) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const ModelInfo& info = model->info();
  BalanceLayer layer(*model, BalanceOptions{});
  ReferenceFrame reference(info.nq, info.nv);
  reference.q = info.neutralConfiguration();
  reference.q[info.configurationIndex(info.findJoint("l_knee"))] = 1.0;  // left foot up
  const int ankle = info.findJoint("r_ankle_pitch");
  reference.q[info.configurationIndex(ankle)] = 0.2;  // heel up
  reference.q[2] = standingBaseHeight(*model, reference.q) - 0.001;
  reference.v.setZero();
  reference.v[info.velocityIndex(ankle)] = 3.0;
  reference.vdot.setZero();
  reference.vdot[info.velocityIndex(ankle)] = 20.0;
  layer.prepare(*model, reference, 1e-3);
  VirtualLinkSet links = linksAt(*model, reference.q);
  const int foot = info.findBody("r_foot");
  int held = -1;
  for (int i = 0; i < links.size(); ++i)
    if (links[i].body == foot) held = i;
  ASSERT_GE(held, 0) << "the toe edge holds a link";
  links.setRolling(held, true);
  model->setState(reference.q, reference.v);
  Eigen::MatrixXd A(info.nv, info.nv);
  model->massMatrix(A);
  QpObjectiveTasks tasks(layer.maxTaskRows(), info.nv + 6 * ContactOptions{}.max_links);
  layer.buildTasks(*model, A, reference.q, reference.v, links, tasks);
  int row = 6;  // after the centroidal rows: per sole 3 rows when held, 6 in the air
  for (const int body : layer.soleBodies()) {
    bool holds = false;
    for (int i = 0; i < links.size(); ++i) holds = holds || links[i].body == body;
    if (body == foot) break;
    row += holds ? 3 : 6;
  }
  ASSERT_LE(row + 3, tasks.rows);
  const Eigen::Vector3d achieved = tasks.T.block(row, 0, 3, info.nv) * reference.vdot;
  EXPECT_LT((achieved - tasks.r.segment<3>(row)).norm(), 1e-6)
      << achieved.transpose() << " against " << tasks.r.segment<3>(row).transpose();
}

// Each sole's footprint (the face the flat landing holds) lies on the sole's lowest points
// when the model stands, in both engines: boxes, the test meshes, and a 1 cm mesh plate
// whose top vertices come first (found from the whole figure sunk into the ground, that
// plate's footprint was its top face, and every landing sank the sole by its thickness).
TEST(Balance, SoleFootprintsLieOnTheSolesLowestPoints) {
  const std::string plate_path = test::editedTestModel(
      "mini_humanoid.urdf",
      [](const std::string& text) {
        return replacedAll(text, R"(<geometry><box size="0.18 0.08 0.02"/></geometry>)",
                           R"(<geometry><mesh filename="package://dynfilter_test_meshes/meshes/thin_plate_sole.obj"/></geometry>)");
      },
      "mini_humanoid_plate_soles.urdf");
  const std::vector<std::string> urdfs = {test::testModelPath("mini_humanoid.urdf"),
                                          test::testModelPath("mesh_sole_biped.urdf"), plate_path};
  for (const std::string& path : urdfs)
    for (const char* backend : {"dart", "ode"}) {
      SCOPED_TRACE(path + " on " + backend);
      auto model = test::makeModel(backend, urdf::loadUrdfFile(path, {{test::testModelPath("")}, {}}), ModelOptions{});
      const BalanceLayer layer(*model, BalanceOptions{});
      ASSERT_EQ(layer.soleBodies().size(), 2u);
      ContactList contacts(256);
      standingContacts(*model, model->info().neutralConfiguration(), contacts);
      for (std::size_t s = 0; s < 2; ++s) {
        const int body = layer.soleBodies()[s];
        const BalanceLayer::SoleFootprint& f = layer.soleFootprints()[s];
        ASSERT_TRUE(f.valid) << model->info().body_names[static_cast<std::size_t>(body)];
        const Eigen::Vector3d n_B = f.X_BS.linear().col(2);
        double lowest = std::numeric_limits<double>::infinity();
        for (const ContactCandidate& c : contacts)
          if (c.body == body) lowest = std::min(lowest, n_B.dot(c.p_BC));
        EXPECT_NEAR(n_B.dot(f.X_BS.translation()), lowest, 1e-6)
            << model->info().body_names[static_cast<std::size_t>(body)];
        EXPECT_GT((f.max - f.min).minCoeff(), 0.07);  // every sole here is at least 8 cm wide
      }
    }
}

}  // namespace
}  // namespace dynfilter
