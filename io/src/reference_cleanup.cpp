#include "dynfilter/io/reference_cleanup.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "dynfilter/core/kinematic_tree.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/core/balance.hpp"
#include "dynfilter/core/polygon.hpp"
#include "dynfilter/io/input_error.hpp"
#include "dynfilter/io/pose_ik.hpp"
#include "foot_ik_weights.hpp"
#include "dynfilter/io/reference_balance.hpp"

namespace dynfilter::io {
namespace {

// A sole point this close to the ground touches it (skate measure), m.
constexpr double kTouchHeight = 0.005;

// A stance run whose reference sole is tilted from its flat pose by more than this on
// average stands on its toes or heel (kneeling, tiptoe): it is held where and as the
// reference holds it, not flattened.
constexpr double kMaxFlatStanceTiltRad = 0.35;

// A flat stance sole rolls over its toe or heel edge only where the reference's sole
// pitches by more than this from the run's level (rad): heel-off, not the capture's jitter.
constexpr double kRollDeadbandRad = 0.05;
// The body's weight (1/m, 1/rad) while such a leg's stance pose is solved: held where the
// reference has it, the leg alone reaches for the flat pose.
constexpr double kHeldBodyWeight = 100.0;
// The flat pose counts as reached within these (m, rad).
constexpr double kReachedPositionM = 1e-3;
constexpr double kReachedTiltRad = 0.01;

// A foot: its body and sole points (body frame) from the neutral stance.
struct Foot {
  std::string link;
  int body = -1;
  std::vector<Eigen::Vector3d> sole;  // p_BS
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_flat = Eigen::Matrix3d::Identity();  // R_WB at the neutral stance
};

struct Setup {
  std::vector<Foot> feet;
  double leg_length_m = 0.0;
};

double groundHeight(const IDynamicsModel& model, const Eigen::Vector3d& p_W) {
  const Environment& env = model.environment();
  return env.has_ground ? env.ground.signedDistance(p_W) : p_W.z();
}

Eigen::Vector3d groundNormal(const IDynamicsModel& model) {
  const Environment& env = model.environment();
  return env.has_ground ? env.ground.n_W : Eigen::Vector3d::UnitZ();
}

Setup findFeet(IDynamicsModel& model, const ReferenceCleanupOptions& options) {
  options.validate();
  const ModelInfo& info = model.info();
  if (!info.floating_base) throw std::invalid_argument("cleanupReference: the model must have a floating base");
  Setup setup;
  ContactList contacts(256);
  setup.leg_length_m = standingContacts(model, info.neutralConfiguration(), contacts);
  std::vector<int> bodies;
  for (const std::string& name : options.feet) {
    const int b = info.findBody(name);
    if (b < 0)
      throw std::invalid_argument("cleanup.feet: \"" + name + "\" is not a link of model " + info.name);
    bodies.push_back(b);
  }
  const std::vector<StandingSole> soles = standingSoles(contacts);
  if (bodies.empty())
    for (const StandingSole& sole : soles) bodies.push_back(sole.body);
  std::sort(bodies.begin(), bodies.end());
  if (bodies.empty())
    throw std::invalid_argument("cleanupReference: model " + info.name +
                                " touches the ground with no body at its neutral stance");
  for (const int b : bodies) {
    Foot f;
    f.link = info.body_names[static_cast<std::size_t>(b)];
    f.body = b;
    const auto sole = std::find_if(soles.begin(), soles.end(), [b](const StandingSole& s) { return s.body == b; });
    if (sole == soles.end())
      throw std::invalid_argument("cleanup.feet: link \"" + f.link +
                                  "\" does not touch the ground at the neutral stance");
    f.sole = sole->points_B;
    f.centre = sole->centre_B;
    f.R_flat = model.bodyPose(b).linear();
    setup.feet.push_back(f);
  }
  return setup;
}

// Height above the ground (m) of the lowest sole point with the foot's body at X_WB.
double lowestSolePoint(const IDynamicsModel& model, const Foot& f, const Eigen::Isometry3d& X_WB) {
  double h = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& p : f.sole) h = std::min(h, groundHeight(model, X_WB * p));
  return h;
}

// Lowest sole point above the ground (m) and the sole centre (world) at the current state.
void soleState(const IDynamicsModel& model, const Foot& f, double& height_m, Eigen::Vector3d& centre_W) {
  const Eigen::Isometry3d X = model.bodyPose(f.body);
  height_m = lowestSolePoint(model, f, X);
  centre_W = X * f.centre;
}

// Runs of equal values: [begin, end) pairs.
std::vector<std::pair<int, int>> runsOf(const std::vector<char>& x, char value) {
  std::vector<std::pair<int, int>> runs;
  const int n = static_cast<int>(x.size());
  for (int k = 0; k < n;) {
    if (x[static_cast<std::size_t>(k)] != value) {
      ++k;
      continue;
    }
    int e = k;
    while (e < n && x[static_cast<std::size_t>(e)] == value) ++e;
    runs.emplace_back(k, e);
    k = e;
  }
  return runs;
}

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

double limitExcess(const ModelInfo& info, int j, double x) {
  return std::max({0.0, info.q_lower[j] - x, x - info.q_upper[j]});
}

void limitSummary(const ModelInfo& info, const std::vector<ReferenceFrame>& frames, int& outside,
                  double& rms) {
  outside = 0;
  double sum = 0.0;
  for (int j = 0; j < info.nj; ++j) {
    bool out = false;
    for (const ReferenceFrame& f : frames) {
      const double e = limitExcess(info, j, f.q[info.configurationIndex(j)]);
      sum += e * e;
      out |= e > 0;
    }
    outside += out;
  }
  rms = info.nj > 0 ? std::sqrt(sum / (static_cast<double>(info.nj) * frames.size())) : 0.0;
}

ContactSchedule schedule(const ReferenceMotion& motion, IDynamicsModel& model, const Setup& setup,
                         const ReferenceCleanupOptions& options) {
  const ModelInfo& info = model.info();
  const int n = static_cast<int>(motion.frames.size());
  const int nf = static_cast<int>(setup.feet.size());
  ContactSchedule s;
  for (const Foot& f : setup.feet) {
    s.links.push_back(f.link);
    s.bodies.push_back(f.body);
  }
  std::vector<std::vector<double>> height(static_cast<std::size_t>(nf), std::vector<double>(static_cast<std::size_t>(n)));
  std::vector<std::vector<Eigen::Vector3d>> centre(static_cast<std::size_t>(nf), std::vector<Eigen::Vector3d>(static_cast<std::size_t>(n)));
  std::vector<std::vector<Eigen::Isometry3d>> pose(static_cast<std::size_t>(nf), std::vector<Eigen::Isometry3d>(static_cast<std::size_t>(n)));
  std::vector<Eigen::Vector3d> com(static_cast<std::size_t>(n));
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(info.nv);
  Eigen::MatrixXd A(info.nv, info.nv);
  for (int k = 0; k < n; ++k) {
    const Eigen::VectorXd& q = motion.frames[static_cast<std::size_t>(k)].q;
    model.setState(q, v0);
    model.massMatrix(A);
    com[static_cast<std::size_t>(k)] = centroidalState(A, q, v0, info.total_mass).c_W;
    s.time_s.push_back(motion.frames[static_cast<std::size_t>(k)].time_s);
    for (int i = 0; i < nf; ++i) {
      const Foot& f = setup.feet[static_cast<std::size_t>(i)];
      soleState(model, f, height[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)],
                centre[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)]);
      pose[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] = model.bodyPose(f.body);
    }
  }
  const Eigen::Vector3d normal = groundNormal(model);
  const Eigen::Matrix3d R_PW = groundPlaneFrame(model);
  const double h_max = options.contact_height * setup.leg_length_m;
  const double v_max = options.contact_speed * setup.leg_length_m;
  const double duration = s.time_s.back() - s.time_s.front();
  const double dt = duration / std::max(1, n - 1);
  const int min_frames = std::max(1, static_cast<int>(std::lround(options.min_phase_s / std::max(dt, 1e-9))));
  s.stance.assign(static_cast<std::size_t>(n), std::vector<char>(static_cast<std::size_t>(nf), 0));
  // Per foot and frame: in stance when slow along the ground and low (within h_max).
  std::vector<std::vector<char>> slow(static_cast<std::size_t>(nf), std::vector<char>(static_cast<std::size_t>(n), 0));
  std::vector<std::vector<char>> st(static_cast<std::size_t>(nf), std::vector<char>(static_cast<std::size_t>(n), 0));
  for (int i = 0; i < nf; ++i) {
    const auto& c = centre[static_cast<std::size_t>(i)];
    for (int k = 0; k < n; ++k) {
      const int a = std::max(0, k - 1), b = std::min(n - 1, k + 1);
      const double span = std::max(s.time_s[static_cast<std::size_t>(b)] - s.time_s[static_cast<std::size_t>(a)], 1e-9);
      const Eigen::Vector3d d = c[static_cast<std::size_t>(b)] - c[static_cast<std::size_t>(a)];
      const double speed = (d - d.dot(normal) * normal).norm() / span;  // along the ground
      // Still: slow in every direction (a swing foot's apex is slow only for an instant).
      slow[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] = d.norm() / span <= 0.5 * v_max;
      st[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] =
          speed <= v_max && height[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] <= h_max;
    }
  }
  // A foot is still at frame k when it is slow in every direction over min_phase_s
  // around k.
  std::vector<std::vector<char>> still = slow;
  for (int i = 0; i < nf; ++i)
    for (int k = 0; k < n; ++k)
      for (int j = std::max(0, k - min_frames / 2); j <= std::min(n - 1, k + min_frames / 2); ++j)
        still[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] &= slow[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
  // Support completion: where the CoM stands outside the stance feet by more than
  // kSupportSlack, a still foot within kHoverFactor h_max of the ground is in stance too
  // (lowest first). A figure retargeted with a wide stance stands with one foot hovering a
  // few centimetres up; the subject stood on both.
  constexpr double kSupportSlack = 0.02;  // m
  constexpr double kHoverFactor = 3.0;
  std::array<Eigen::Vector2d, 128> points, hull;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector2d c_P = (R_PW * com[static_cast<std::size_t>(k)]).head<2>();
    for (int added = 0; added < nf; ++added) {
      int m = 0;
      for (int i = 0; i < nf; ++i) {
        if (!st[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)]) continue;
        for (const Eigen::Vector3d& p : setup.feet[static_cast<std::size_t>(i)].sole)
          if (m < static_cast<int>(points.size()))
            points[static_cast<std::size_t>(m++)] = (R_PW * (pose[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] * p)).head<2>();
      }
      const int h = polygon::convexHull(points, m, hull);
      if (h > 0 && (polygon::clampToHull(c_P, hull, h) - c_P).norm() <= kSupportSlack) break;
      int best = -1;
      for (int i = 0; i < nf; ++i) {
        const double hi = height[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)];
        if (st[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] || !still[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] ||
            hi > kHoverFactor * h_max)
          continue;
        if (best < 0 || hi < height[static_cast<std::size_t>(best)][static_cast<std::size_t>(k)]) best = i;
      }
      if (best < 0) break;
      st[static_cast<std::size_t>(best)][static_cast<std::size_t>(k)] = 1;
    }
  }
  for (int i = 0; i < nf; ++i) {
    std::vector<char>& foot = st[static_cast<std::size_t>(i)];
    // Short swing gaps inside stance become stance; then short stance runs become swing.
    for (const char value : {char(0), char(1)})
      for (const auto& [b, e] : runsOf(foot, value))
        if (e - b < min_frames && b > 0 && e < n)
          std::fill(foot.begin() + b, foot.begin() + e, static_cast<char>(1 - value));
    for (const auto& [b, e] : runsOf(foot, 1))
      if (e - b < min_frames) std::fill(foot.begin() + b, foot.begin() + e, 0);
    for (int k = 0; k < n; ++k) s.stance[static_cast<std::size_t>(k)][static_cast<std::size_t>(i)] = foot[static_cast<std::size_t>(k)];
  }
  return s;
}

}  // namespace

void ReferenceCleanupOptions::validate() const {
  auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("cleanup.") + what);
  };
  require(std::isfinite(contact_height) && contact_height > 0, "contact_height: must be > 0");
  require(std::isfinite(contact_speed) && contact_speed > 0, "contact_speed: must be > 0");
  require(std::isfinite(min_phase_s) && min_phase_s >= 0, "min_phase_s: must be >= 0");
  require(std::isfinite(base_weight) && base_weight >= 0, "base_weight: must be >= 0");
  require(std::isfinite(posture_weight) && posture_weight > 0, "posture_weight: must be > 0");
  require(std::isfinite(leg_weight) && leg_weight > 0, "leg_weight: must be > 0");
  require(std::isfinite(continuity_weight) && continuity_weight >= 0, "continuity_weight: must be >= 0");
  require(std::isfinite(lowpass_hz) && lowpass_hz >= 0, "lowpass_hz: must be >= 0 (0: off)");
  require(std::isfinite(zmp_margin_m) && zmp_margin_m >= 0, "zmp_margin_m: must be >= 0");
  require(balance_iterations >= 1 && balance_iterations <= 20, "balance_iterations: must be in [1, 20]");
  require(std::isfinite(max_com_shift_m) && max_com_shift_m > 0, "max_com_shift_m: must be > 0");
  require(smoothing_window >= 3 && smoothing_window % 2 == 1, "smoothing_window: must be odd and >= 3");
}

ContactSchedule findContactSchedule(const ReferenceMotion& motion, IDynamicsModel& model,
                                    const ReferenceCleanupOptions& options) {
  if (motion.frames.size() < 2) throw std::invalid_argument("findContactSchedule: fewer than 2 frames");
  const Setup setup = findFeet(model, options);
  return schedule(motion, model, setup, options);
}

std::vector<FootReport> measureFeet(const ReferenceMotion& motion, IDynamicsModel& model,
                                    const ContactSchedule& schedule) {
  ReferenceCleanupOptions options;
  options.feet = schedule.links;
  const Setup setup = findFeet(model, options);
  const ModelInfo& info = model.info();
  const Eigen::Vector3d normal = groundNormal(model);
  const int n = static_cast<int>(motion.frames.size());
  std::vector<FootReport> out(setup.feet.size());
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(info.nv);
  // Per sole point: where it touched down in the current stance run (NaN: not touching).
  std::vector<std::vector<Eigen::Vector3d>> touched(setup.feet.size());
  for (std::size_t i = 0; i < setup.feet.size(); ++i)
    touched[i].assign(setup.feet[i].sole.size(), Eigen::Vector3d::Constant(std::nan("")));
  for (int k = 0; k < n; ++k) {
    model.setState(motion.frames[static_cast<std::size_t>(k)].q, v0);
    for (std::size_t i = 0; i < setup.feet.size(); ++i) {
      FootReport& r = out[i];
      const Foot& f = setup.feet[i];
      r.link = f.link;
      double h = 0.0;
      Eigen::Vector3d c;
      soleState(model, f, h, c);
      r.penetration_before_m = std::max(r.penetration_before_m, -h);
      const bool st = schedule.stance[static_cast<std::size_t>(k)][i] != 0;
      const bool began = st && (k == 0 || schedule.stance[static_cast<std::size_t>(k - 1)][i] == 0);
      if (began) ++r.stance_runs;
      if (!st) {
        for (Eigen::Vector3d& p : touched[i]) p.setConstant(std::nan(""));
        continue;
      }
      r.stance_fraction += 1.0 / n;
      // Skate: a sole point on the ground slides along it. A foot that rolls over its heel
      // or toe does not skate: the points it leaves stop counting.
      const Eigen::Isometry3d X = model.bodyPose(f.body);
      for (std::size_t s = 0; s < f.sole.size(); ++s) {
        const Eigen::Vector3d p = X * f.sole[s];
        if (groundHeight(model, p) > kTouchHeight) {
          touched[i][s].setConstant(std::nan(""));
          continue;
        }
        if (!touched[i][s].allFinite()) touched[i][s] = p;
        Eigen::Vector3d d = p - touched[i][s];
        d -= d.dot(normal) * normal;
        r.skate_before_m = std::max(r.skate_before_m, d.norm());
      }
    }
  }
  return out;
}

CleanupResult cleanupReference(const ReferenceMotion& input, IDynamicsModel& model,
                               const ReferenceCleanupOptions& options, const QpSolverFactory& qp_solver) {
  if (input.frames.size() < 2) throw std::invalid_argument("cleanupReference: fewer than 2 frames");
  // Everything below works on the low-passed motion; the report compares with the input.
  ReferenceMotion motion = input;
  if (options.lowpass_hz > 0) lowPassConfigurations(motion.frames, true, options.lowpass_hz);
  const ModelInfo& info = model.info();
  const Setup setup = findFeet(model, options);
  CleanupResult result;
  result.schedule = schedule(motion, model, setup, options);
  const ContactSchedule& sched = result.schedule;
  const int n = static_cast<int>(motion.frames.size());
  const int nf = static_cast<int>(setup.feet.size());
  const Eigen::Vector3d normal = groundNormal(model);
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(info.nv);

  // Reference foot poses.
  std::vector<std::vector<Eigen::Isometry3d>> X_ref(static_cast<std::size_t>(nf), std::vector<Eigen::Isometry3d>(static_cast<std::size_t>(n)));
  for (int k = 0; k < n; ++k) {
    model.setState(motion.frames[static_cast<std::size_t>(k)].q, v0);
    for (int i = 0; i < nf; ++i)
      X_ref[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] = model.bodyPose(setup.feet[static_cast<std::size_t>(i)].body);
  }

  // Foot targets: stance pose per run, blended in and out; no sole point below the ground.
  auto flatPose = [&](const Foot& f, const Eigen::Matrix3d& R_ref, const Eigen::Vector3d& centre_W) {
    // Heading of the reference foot relative to its flat orientation, about the normal.
    const Eigen::Matrix3d R_rel = R_ref * f.R_flat.transpose();
    Eigen::Vector3d x = R_rel * (f.R_flat * Eigen::Vector3d::UnitX());
    Eigen::Vector3d x0 = f.R_flat * Eigen::Vector3d::UnitX();
    x -= x.dot(normal) * normal;
    x0 -= x0.dot(normal) * normal;
    const double psi = std::atan2(x0.cross(x).dot(normal), x0.dot(x));
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.linear() = Eigen::AngleAxisd(psi, normal).toRotationMatrix() * f.R_flat;
    X.translation() = centre_W - X.linear() * f.centre;
    X.translation() -= lowestSolePoint(model, f, X) * normal;
    return X;
  };
  // Posture weights: legs (joints between the base and a foot) give way.
  const KinematicTree tree = kinematicTreeOf(model);
  Eigen::VectorXd weights = Eigen::VectorXd::Constant(info.nv, options.posture_weight);
  weights.head<6>().setConstant(options.base_weight);
  for (const Foot& f : setup.feet)
    for (const int j : tree.jointsBetween(tree.base_body, f.body)) weights[info.velocityIndex(j)] = options.leg_weight;
  Eigen::VectorXd held = weights;
  held.head<6>().setConstant(kHeldBodyWeight);
  // A stance pose of a leg that cannot orient its sole freely: the pose nearest the flat one
  // p (sole centre on it, turned least) that the leg reaches with the body held at the
  // reference's frame k; p itself where the leg reaches it.
  std::vector<int> tilted_runs(static_cast<std::size_t>(nf), 0);
  std::vector<double> tilt_max(static_cast<std::size_t>(nf), 0.0);
  auto reachedPose = [&](int i, const Eigen::Isometry3d& P, int k) {
    const Foot& f = setup.feet[static_cast<std::size_t>(i)];
    if (tree.posesFreely(f.body)) return P;
    IkTarget t;
    t.body = f.body;
    t.p_BP = f.centre;
    t.p_WP = P * f.centre;
    t.R_WB = P.linear();
    t.position_weight = kFootPositionWeight;
    t.orientation_weight = kFootOrientationWeight;
    IkOptions o;
    o.max_iterations = 100;
    o.tolerance = 1e-9;
    const Eigen::VectorXd& q_k = motion.frames[static_cast<std::size_t>(k)].q;
    Eigen::VectorXd q = q_k;
    solvePoseIk(model, {t}, q_k, held, o, q);
    double position_m = 0.0, turn_rad = 0.0;
    ikTargetError(model, t, position_m, turn_rad);
    if (position_m <= kReachedPositionM && turn_rad <= kReachedTiltRad) return P;
    Eigen::Isometry3d X = model.bodyPose(f.body);
    const Eigen::Vector3d n_W = X.linear() * f.R_flat.transpose() * normal;
    const double tilt_rad = std::acos(std::clamp(n_W.dot(normal), -1.0, 1.0));
    X.translation() -= lowestSolePoint(model, f, X) * normal;
    ++tilted_runs[static_cast<std::size_t>(i)];
    tilt_max[static_cast<std::size_t>(i)] = std::max(tilt_max[static_cast<std::size_t>(i)], tilt_rad);
    return X;
  };
  std::vector<std::vector<Eigen::Isometry3d>> X_goal = X_ref;
  for (int i = 0; i < nf; ++i) {
    const Foot& f = setup.feet[static_cast<std::size_t>(i)];
    auto& goal = X_goal[static_cast<std::size_t>(i)];
    const auto& ref = X_ref[static_cast<std::size_t>(i)];
    std::vector<char> st(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) st[static_cast<std::size_t>(k)] = sched.stance[static_cast<std::size_t>(k)][static_cast<std::size_t>(i)];
    const std::vector<std::pair<int, int>> runs = runsOf(st, 1);
    // Per run: its stance pose, and the correction of the reference's foot at the run's
    // first and last frame (sole centre moved by dp, orientation turned by R in world).
    struct Correction {
      Eigen::Vector3d dp = Eigen::Vector3d::Zero();
      Eigen::Quaterniond R = Eigen::Quaterniond::Identity();
    };
    auto correction = [&](const Eigen::Isometry3d& P, const Eigen::Isometry3d& X) {
      Correction c;
      c.dp = P * f.centre - X * f.centre;
      c.R = Eigen::Quaterniond(P.linear() * X.linear().transpose());
      return c;
    };
    std::vector<Eigen::Isometry3d> pose(runs.size());
    std::vector<Correction> at_start(runs.size()), at_end(runs.size());
    // Heel-off: at the end of a flat run the reference's sole pitches away from the run's
    // own level (its median pitch) over its toe edge (or its heel edge). From the last frame
    // within kRollDeadbandRad of that level on, the flat pose rolls over that edge by the
    // pitch beyond the deadband; the edge stays where it is.
    const Eigen::Vector3d fwd_B = f.R_flat.transpose() * Eigen::Vector3d::UnitX();
    double toe = -std::numeric_limits<double>::infinity(), heel = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector3d& p : f.sole) {
      toe = std::max(toe, fwd_B.dot(p - f.centre));
      heel = std::min(heel, fwd_B.dot(p - f.centre));
    }
    auto pitchOf = [&](int k) {  // > 0: toes down, heel up
      const Eigen::Vector3d x = ref[static_cast<std::size_t>(k)].linear() * fwd_B;
      return std::atan2(-x.dot(normal), (x - x.dot(normal) * normal).norm());
    };
    std::vector<int> roll_from(runs.size());
    std::vector<double> level(runs.size(), 0.0);
    auto stanceGoal = [&](std::size_t run, int k) {
      const Eigen::Isometry3d& P = pose[run];
      if (k < roll_from[run]) return P;
      const double d = pitchOf(k) - level[run];
      const double excess = std::copysign(std::max(0.0, std::fabs(d) - kRollDeadbandRad), d);
      Eigen::Vector3d fwd_W = P.linear() * fwd_B;
      fwd_W = (fwd_W - fwd_W.dot(normal) * normal).normalized();
      const Eigen::Vector3d edge_B = f.centre + (excess > 0 ? toe : heel) * fwd_B;
      Eigen::Isometry3d X = P;
      X.linear() = Eigen::AngleAxisd(excess, normal.cross(fwd_W)).toRotationMatrix() * P.linear();
      X.translation() = P * edge_B - X.linear() * edge_B;
      return X;
    };
    for (std::size_t r = 0; r < runs.size(); ++r) {
      const auto [b, e] = runs[r];
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      Eigen::Vector3d xs = Eigen::Vector3d::Zero();
      for (int k = b; k < e; ++k) {
        c += ref[static_cast<std::size_t>(k)] * f.centre;
        xs += ref[static_cast<std::size_t>(k)].linear() * f.R_flat.transpose() * (f.R_flat * Eigen::Vector3d::UnitX());
      }
      c /= static_cast<double>(e - b);
      double tilt = 0.0;
      for (int k = b; k < e; ++k) {
        const Eigen::Vector3d n_k = ref[static_cast<std::size_t>(k)].linear() * f.R_flat.transpose() * normal;
        tilt += std::acos(std::clamp(n_k.dot(normal), -1.0, 1.0)) / static_cast<double>(e - b);
      }
      if (tilt > kMaxFlatStanceTiltRad) {
        // On its toes or heel: the reference's pose in the run's middle, at the mean place,
        // no sole point below the ground.
        Eigen::Isometry3d X = ref[static_cast<std::size_t>((b + e) / 2)];
        X.translation() += c - X * f.centre;
        const double h = lowestSolePoint(model, f, X);
        if (h < 0) X.translation() -= h * normal;
        pose[r] = X;
      } else {
        // Mean heading: the flat pose of the mean forward direction.
        const Eigen::Vector3d x0 = f.R_flat * Eigen::Vector3d::UnitX();
        const Eigen::Matrix3d R_heading = Eigen::Quaterniond::FromTwoVectors(x0, xs.normalized()).toRotationMatrix();
        pose[r] = reachedPose(i, flatPose(f, R_heading * f.R_flat, c), (b + e) / 2);
      }
      roll_from[r] = e;
      if (tilt <= kMaxFlatStanceTiltRad) {
        std::vector<double> pitch(static_cast<std::size_t>(e - b));
        for (int k = b; k < e; ++k) pitch[static_cast<std::size_t>(k - b)] = pitchOf(k);
        std::vector<double> sorted = pitch;
        std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
        level[r] = sorted[sorted.size() / 2];
        while (roll_from[r] > b && std::fabs(pitch[static_cast<std::size_t>(roll_from[r] - 1 - b)] - level[r]) > kRollDeadbandRad)
          --roll_from[r];
      }
      at_start[r] = correction(stanceGoal(r, b), ref[static_cast<std::size_t>(b)]);
      at_end[r] = correction(stanceGoal(r, e - 1), ref[static_cast<std::size_t>(e - 1)]);
    }
    // In stance the stance pose; in a swing the reference's foot corrected by what ended
    // the last stance blended smoothly into what starts the next (over the whole swing, so
    // the target never jumps and accelerates as little as the swing allows); before the
    // first and after the last stance, by that stance's correction.
    std::size_t r = 0;
    for (int k = 0; k < n; ++k) {
      while (r < runs.size() && runs[r].second <= k) ++r;  // the first run not yet over
      Eigen::Isometry3d X = ref[static_cast<std::size_t>(k)];
      if (r < runs.size() && runs[r].first <= k) {
        X = stanceGoal(r, k);
      } else if (!runs.empty()) {
        Correction c;
        if (r == 0) {
          c = at_start[0];
        } else if (r == runs.size()) {
          c = at_end[runs.size() - 1];
        } else {
          const int e = runs[r - 1].second, b = runs[r].first;  // swing frames [e, b)
          const double s = smoothstep((k - e + 1.0) / (b - e + 1.0));
          c.dp = (1.0 - s) * at_end[r - 1].dp + s * at_start[r].dp;
          c.R = at_end[r - 1].R.slerp(s, at_start[r].R);
        }
        const Eigen::Vector3d p = X * f.centre + c.dp;
        X.linear() = c.R.toRotationMatrix() * X.linear();
        X.translation() = p - X.linear() * f.centre;
      }
      const double h = lowestSolePoint(model, f, X);
      if (h < 0) X.translation() -= h * normal;
      goal[static_cast<std::size_t>(k)] = X;
    }
  }

  std::vector<IkTarget> targets(static_cast<std::size_t>(nf));
  for (int i = 0; i < nf; ++i) {
    targets[static_cast<std::size_t>(i)].body = setup.feet[static_cast<std::size_t>(i)].body;
    targets[static_cast<std::size_t>(i)].p_BP = setup.feet[static_cast<std::size_t>(i)].centre;
    targets[static_cast<std::size_t>(i)].position_weight = kFootPositionWeight;
    targets[static_cast<std::size_t>(i)].orientation_weight = kFootOrientationWeight;
  }
  IkOptions ik;
  ik.max_iterations = 100;
  ik.tolerance = 1e-9;
  ik.continuity_weight = options.continuity_weight;
  // One IK pass over the clip: the feet at their goals, everything else held at the
  // reference with its base moved by shift_W[k] (the balance stage's CoM shift).
  auto solvePass = [&](const ReferenceMotion& posture, const std::vector<Eigen::Vector3d>& shift_W,
                       ReferenceMotion& out) {
    out = posture;
    Eigen::VectorXd q_prev, dv_ref(info.nv);
    for (int k = 0; k < n; ++k) {
      Eigen::VectorXd q_ref = posture.frames[static_cast<std::size_t>(k)].q;
      q_ref.head<3>() += shift_W[static_cast<std::size_t>(k)];
      for (int i = 0; i < nf; ++i) {
        const Eigen::Isometry3d& X = X_goal[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)];
        targets[static_cast<std::size_t>(i)].p_WP = X * setup.feet[static_cast<std::size_t>(i)].centre;
        targets[static_cast<std::size_t>(i)].R_WB = X.linear();
      }
      // Start from the previous frame's answer moved by the reference's own change, and
      // hold the answer near it (continuity): the clip follows one branch of the IK's
      // solutions instead of jumping between local minima where a foot target is hard.
      Eigen::VectorXd q = q_ref;
      if (k > 0) {
        Eigen::VectorXd q_ref_prev = posture.frames[static_cast<std::size_t>(k - 1)].q;
        q_ref_prev.head<3>() += shift_W[static_cast<std::size_t>(k - 1)];
        differenceConfiguration(true, q_ref_prev, q_ref, dv_ref);
        integrateConfiguration(true, q_prev, dv_ref, 1.0, q);
      }
      const Eigen::VectorXd q_predicted = q;
      solvePoseIk(model, targets, q_ref, weights, ik, q, k > 0 ? &q_predicted : nullptr);
      Eigen::Quaterniond a(q_ref[3], q_ref[4], q_ref[5], q_ref[6]), b(q[3], q[4], q[5], q[6]);
      if (a.dot(b) < 0) q.segment<4>(3) *= -1.0;
      out.frames[static_cast<std::size_t>(k)].q = q;
      q_prev = q;
    }
  };
  // The IK's answer can turn quickly where a foot target is hard to reach (a leg
  // straightening at a stance change): it is low-passed and solved again with the smoothed
  // answer as the posture, so that the feet stay exact.
  auto solveClip = [&](const std::vector<Eigen::Vector3d>& shift_W, ReferenceMotion& out) {
    solvePass(motion, shift_W, out);
    if (options.lowpass_hz > 0) {
      lowPassConfigurations(out.frames, true, options.lowpass_hz);
      const ReferenceMotion smoothed = out;
      solvePass(smoothed, std::vector<Eigen::Vector3d>(shift_W.size(), Eigen::Vector3d::Zero()), out);
    }
    estimateDerivatives(out.frames, true, options.smoothing_window, true, true);
  };
  std::vector<Eigen::Vector3d> shift_W(static_cast<std::size_t>(n), Eigen::Vector3d::Zero());
  solveClip(shift_W, result.motion);

  // Balance: the ZMP into the stance soles' support (shrunk by zmp_margin_m), by moving the
  // base along the ground onto the nearest CoM path a pendulum can follow, the feet kept.
  CleanupReport& rep = result.report;
  auto supportOf = [&](const ReferenceMotion& m) {
    std::vector<std::vector<Eigen::Vector3d>> support(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) {
      model.setState(m.frames[static_cast<std::size_t>(k)].q, v0);
      for (int i = 0; i < nf; ++i) {
        if (!sched.stance[static_cast<std::size_t>(k)][static_cast<std::size_t>(i)]) continue;
        const Foot& f = setup.feet[static_cast<std::size_t>(i)];
        const Eigen::Isometry3d X = model.bodyPose(f.body);
        for (const Eigen::Vector3d& p : f.sole) {
          const Eigen::Vector3d r = p - f.centre;
          const double shrink = std::max(0.0, 1.0 - options.zmp_margin_m / std::max(r.norm(), 1e-9));
          support[static_cast<std::size_t>(k)].push_back(X * (f.centre + shrink * r));
        }
      }
    }
    return support;
  };
  auto summarise = [&](const std::vector<ZmpSample>& z, int& frames_outside, double& max_m, double& rms_m) {
    frames_outside = 0;
    max_m = 0.0;
    double sum = 0.0;
    for (const ZmpSample& s : z) {
      frames_outside += s.defined && s.outside_m > 1e-4;
      max_m = std::max(max_m, s.outside_m);
      sum += s.outside_m * s.outside_m;
    }
    rms_m = std::sqrt(sum / std::max<std::size_t>(1, z.size()));
  };
  std::vector<ZmpSample> zmp = zmpAgainstSupport(result.motion, model, supportOf(result.motion));
  summarise(zmp, rep.zmp_frames_outside_before, rep.zmp_outside_max_before_m, rep.zmp_outside_rms_before_m);
  rep.zmp_frames_outside_after = rep.zmp_frames_outside_before;
  rep.zmp_outside_max_after_m = rep.zmp_outside_max_before_m;
  rep.zmp_outside_rms_after_m = rep.zmp_outside_rms_before_m;
  if (options.balance && rep.zmp_frames_outside_before > 0) {
    if (!qp_solver)
      throw std::invalid_argument("cleanupReference: the balance stage (balance: true) needs a QP solver");
    // The CoM path nearest the reference's that the pendulum can follow on its support,
    // then the base moved along the ground until the IK's CoM (feet kept) lies on it.
    const Eigen::Matrix3d R_PW = groundPlaneFrame(model);
    const std::vector<PendulumSample> samples = pendulumSamples(result.motion, model, supportOf(result.motion));
    FeasibleComOptions fc;
    fc.max_shift_m = options.max_com_shift_m;
    const std::vector<Eigen::Vector2d> target = feasibleComPath(samples, fc, qp_solver, &rep.com_path);
    std::vector<Eigen::Vector2d> com(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) com[static_cast<std::size_t>(k)] = samples[static_cast<std::size_t>(k)].c;
    ReferenceMotion trial;
    Eigen::MatrixXd A(info.nv, info.nv);
    for (int it = 0; it < options.balance_iterations; ++it) {
      for (int k = 0; k < n; ++k) {
        const Eigen::Vector2d d = target[static_cast<std::size_t>(k)] - com[static_cast<std::size_t>(k)];
        // The base moves no further than the path may (a CoM the feet's reach holds back
        // is not chased).
        Eigen::Vector2d shift = (R_PW * shift_W[static_cast<std::size_t>(k)]).head<2>() + d;
        shift = shift.cwiseMax(-options.max_com_shift_m).cwiseMin(options.max_com_shift_m);
        shift_W[static_cast<std::size_t>(k)] = R_PW.topRows<2>().transpose() * shift;
      }
      solveClip(shift_W, trial);
      result.motion = trial;
      double worst = 0.0;
      for (int k = 0; k < n; ++k) {
        const ReferenceFrame& f = trial.frames[static_cast<std::size_t>(k)];
        model.setState(f.q, f.v);
        model.massMatrix(A);
        com[static_cast<std::size_t>(k)] = (R_PW * centroidalState(A, f.q, f.v, info.total_mass).c_W).head<2>();
        worst = std::max(worst, (target[static_cast<std::size_t>(k)] - com[static_cast<std::size_t>(k)]).norm());
      }
      rep.com_path_error_m = worst;
      if (worst < 1e-3) break;
    }
    zmp = zmpAgainstSupport(result.motion, model, supportOf(result.motion));
    summarise(zmp, rep.zmp_frames_outside_after, rep.zmp_outside_max_after_m, rep.zmp_outside_rms_after_m);
    for (const Eigen::Vector3d& s : shift_W) {
      rep.com_shift_max_m = std::max(rep.com_shift_max_m, s.norm());
      rep.com_shift_rms_m += s.squaredNorm() / n;
    }
    rep.com_shift_rms_m = std::sqrt(rep.com_shift_rms_m);
  }

  // Report.
  rep.leg_length_m = setup.leg_length_m;
  double total = 0.0;
  for (int j = 0; j < info.nj; ++j) {
    JointChangeReport r;
    r.joint = info.joint_names[static_cast<std::size_t>(j)];
    const int qi = info.configurationIndex(j);
    double sum = 0.0;
    for (int k = 0; k < n; ++k) {
      const double d = result.motion.frames[static_cast<std::size_t>(k)].q[qi] - input.frames[static_cast<std::size_t>(k)].q[qi];
      r.max_change_rad = std::max(r.max_change_rad, std::fabs(d));
      sum += d * d;
    }
    total += sum;
    r.rms_change_rad = std::sqrt(sum / n);
    rep.joints.push_back(r);
  }
  rep.rms_change_rad = info.nj > 0 ? std::sqrt(total / (static_cast<double>(info.nj) * n)) : 0.0;
  for (int k = 0; k < n; ++k)
    rep.base_position_change_max_m =
        std::max(rep.base_position_change_max_m,
                 (result.motion.frames[static_cast<std::size_t>(k)].q.head<3>() - input.frames[static_cast<std::size_t>(k)].q.head<3>()).norm());
  rep.feet = measureFeet(input, model, sched);
  const std::vector<FootReport> after = measureFeet(result.motion, model, sched);
  for (std::size_t i = 0; i < rep.feet.size(); ++i) {
    rep.feet[i].skate_after_m = after[i].skate_before_m;
    rep.feet[i].penetration_after_m = after[i].penetration_before_m;
    rep.feet[i].tilted_runs = tilted_runs[i];
    rep.feet[i].tilt_max_rad = tilt_max[i];
  }
  limitSummary(info, input.frames, rep.joints_outside_before, rep.limit_excess_rms_before_rad);
  limitSummary(info, result.motion.frames, rep.joints_outside_after, rep.limit_excess_rms_after_rad);
  return result;
}

void writeContactScheduleCsv(const std::string& path, const ContactSchedule& schedule) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) throw InputError(path, 0, std::string("cannot write: ") + std::strerror(errno));
  std::fprintf(file, "time");
  for (const std::string& link : schedule.links) std::fprintf(file, ",%s", link.c_str());
  std::fprintf(file, "\n");
  for (std::size_t k = 0; k < schedule.time_s.size(); ++k) {
    std::fprintf(file, "%.17g", schedule.time_s[k]);
    for (const char s : schedule.stance[k]) std::fprintf(file, ",%d", s ? 1 : 0);
    std::fprintf(file, "\n");
  }
  const bool failed = std::ferror(file) != 0;
  if (std::fclose(file) != 0 || failed) throw InputError(path, 0, "write failed");
}

std::string formatCleanupReport(const CleanupReport& report) {
  std::ostringstream out;
  char line[256];
  std::snprintf(line, sizeof line, "clean-up (leg length %.3f m): joint changes (deg), max / RMS\n",
                report.leg_length_m);
  out << line;
  for (const JointChangeReport& j : report.joints) {
    if (j.max_change_rad < 1e-6) continue;
    std::snprintf(line, sizeof line, "  %-26s %7.2f / %6.2f\n", j.joint.c_str(),
                  j.max_change_rad * 180.0 / M_PI, j.rms_change_rad * 180.0 / M_PI);
    out << line;
  }
  std::snprintf(line, sizeof line,
                "  overall RMS change %.4f rad; base moved by at most %.1f mm\n", report.rms_change_rad,
                1e3 * report.base_position_change_max_m);
  out << line;
  for (const FootReport& f : report.feet) {
    std::snprintf(line, sizeof line,
                  "  foot %-22s %2d stance runs (%4.1f %% of frames): skate %.1f -> %.2f mm, "
                  "penetration %.1f -> %.2f mm\n",
                  f.link.c_str(), f.stance_runs, 100.0 * f.stance_fraction, 1e3 * f.skate_before_m,
                  1e3 * f.skate_after_m, 1e3 * f.penetration_before_m, 1e3 * f.penetration_after_m);
    out << line;
    if (f.tilted_runs > 0) {
      std::snprintf(line, sizeof line,
                    "  foot %-22s %2d stance runs held at the tilt its leg reaches (up to %.1f deg): "
                    "fewer than %d joints cannot lay the sole flat there\n",
                    f.link.c_str(), f.tilted_runs, f.tilt_max_rad * 180.0 / M_PI, kJointsToPoseFreely);
      out << line;
    }
  }
  std::snprintf(line, sizeof line,
                "  ZMP outside the stance support: %d -> %d frames, max %.1f -> %.1f mm, RMS %.1f -> %.1f mm; "
                "base shifted along the ground by at most %.1f mm (RMS %.1f)\n",
                report.zmp_frames_outside_before, report.zmp_frames_outside_after,
                1e3 * report.zmp_outside_max_before_m, 1e3 * report.zmp_outside_max_after_m,
                1e3 * report.zmp_outside_rms_before_m, 1e3 * report.zmp_outside_rms_after_m,
                1e3 * report.com_shift_max_m, 1e3 * report.com_shift_rms_m);
  out << line;
  if (report.com_path.windows > 0) {
    std::snprintf(line, sizeof line,
                  "  balance: CoM path from %d QPs (%d short of tolerance), its ZMP up to %.1f mm outside "
                  "the support; the IK's CoM within %.1f mm of it\n",
                  report.com_path.windows, report.com_path.unsolved, 1e3 * report.com_path.max_violation_m,
                  1e3 * report.com_path_error_m);
    out << line;
  }
  std::snprintf(line, sizeof line,
                "  joint limits: %d joints outside before, %d after; excess %.4f -> %.4f rad RMS\n",
                report.joints_outside_before, report.joints_outside_after,
                report.limit_excess_rms_before_rad, report.limit_excess_rms_after_rad);
  out << line;
  return out.str();
}

}  // namespace dynfilter::io
