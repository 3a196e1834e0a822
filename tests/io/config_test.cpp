// YAML filter configuration: the shipped default file equals the structs' defaults, keys
// override exactly their field, and every error names its key path, line and column.
#include <cmath>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "dynfilter/io/config.hpp"
#include "io/io_test_support.hpp"

namespace dynfilter::io {
namespace {

using testing_io::expectInputError;
using testing_io::tempPath;
using testing_io::writeFile;

void expectSameFilterOptions(const FilterOptions& a, const FilterOptions& b) {
  EXPECT_EQ(a.dt_s, b.dt_s);
  EXPECT_EQ(a.feedback.base_linear_kp, b.feedback.base_linear_kp);
  EXPECT_EQ(a.feedback.base_linear_kd, b.feedback.base_linear_kd);
  EXPECT_EQ(a.feedback.base_angular_kp, b.feedback.base_angular_kp);
  EXPECT_EQ(a.feedback.base_angular_kd, b.feedback.base_angular_kd);
  EXPECT_EQ(a.feedback.joint_kp, b.feedback.joint_kp);
  EXPECT_EQ(a.feedback.joint_kd, b.feedback.joint_kd);
  EXPECT_EQ(a.task.enabled, b.task.enabled);
  EXPECT_EQ(a.task.body, b.task.body);
  EXPECT_EQ(a.task.p_BP, b.task.p_BP);
  EXPECT_EQ(a.task.kp_linear, b.task.kp_linear);
  EXPECT_EQ(a.task.kd_linear, b.task.kd_linear);
  EXPECT_EQ(a.task.kp_angular, b.task.kp_angular);
  EXPECT_EQ(a.task.kd_angular, b.task.kd_angular);
  EXPECT_EQ(a.task.joint_weight, b.task.joint_weight);
  EXPECT_EQ(a.task.as_constraint_rows, b.task.as_constraint_rows);
  EXPECT_EQ(a.contacts.max_links, b.contacts.max_links);
  EXPECT_EQ(a.contacts.stabilization_kp, b.contacts.stabilization_kp);
  EXPECT_EQ(a.contacts.stabilization_kd, b.contacts.stabilization_kd);
  EXPECT_EQ(a.contacts.merge_distance_m, b.contacts.merge_distance_m);
  EXPECT_EQ(a.contacts.release_force_n, b.contacts.release_force_n);
  EXPECT_EQ(a.contacts.release_ticks, b.contacts.release_ticks);
  EXPECT_EQ(a.contacts.reengage_depth_m, b.contacts.reengage_depth_m);
  EXPECT_EQ(a.contacts.plastic_impact, b.contacts.plastic_impact);
  EXPECT_EQ(a.contacts.initial_penetration_tolerance_m, b.contacts.initial_penetration_tolerance_m);
  EXPECT_EQ(a.solver.accel_weight, b.solver.accel_weight);
  EXPECT_EQ(a.solver.force_weight, b.solver.force_weight);
  EXPECT_EQ(a.solver.sr_damping, b.solver.sr_damping);
  EXPECT_EQ(a.mode, b.mode);
  EXPECT_EQ(a.qp.accel_weight, b.qp.accel_weight);
  EXPECT_EQ(a.qp.force_weight, b.qp.force_weight);
  EXPECT_EQ(a.qp.torque_weight, b.qp.torque_weight);
  EXPECT_EQ(a.qp.min_normal_force_n, b.qp.min_normal_force_n);
  EXPECT_EQ(a.qp.friction_facets, b.qp.friction_facets);
  EXPECT_EQ(a.qp.cop_margin_m, b.qp.cop_margin_m);
  EXPECT_EQ(a.qp.liftoff_clearance_m, b.qp.liftoff_clearance_m);
  EXPECT_EQ(a.qp.release_transition_s, b.qp.release_transition_s);
  EXPECT_EQ(a.qp.joint_limit_horizon_s, b.qp.joint_limit_horizon_s);
  EXPECT_EQ(a.qp.joint_limit_max_decel, b.qp.joint_limit_max_decel);
  EXPECT_EQ(a.qp.enforce_torque_limits, b.qp.enforce_torque_limits);
  EXPECT_EQ(a.qp.enforce_joint_limits, b.qp.enforce_joint_limits);
  EXPECT_EQ(a.qp.yaw_slip, b.qp.yaw_slip);
  EXPECT_EQ(a.qp.tangential_slip, b.qp.tangential_slip);
  EXPECT_EQ(a.qp.solver.eps_abs, b.qp.solver.eps_abs);
  EXPECT_EQ(a.qp.solver.max_iterations, b.qp.solver.max_iterations);
  EXPECT_EQ(a.qp.solver.warm_start, b.qp.solver.warm_start);
  EXPECT_EQ(a.qp.solver.engine, b.qp.solver.engine);
  EXPECT_EQ(a.divergence.max_base_error_m, b.divergence.max_base_error_m);
  EXPECT_EQ(a.divergence.max_base_rotation_rad, b.divergence.max_base_rotation_rad);
  EXPECT_EQ(a.divergence.max_joint_error_rad, b.divergence.max_joint_error_rad);
  EXPECT_EQ(a.divergence.max_base_residual_rel, b.divergence.max_base_residual_rel);
  EXPECT_EQ(a.divergence.max_degraded_ticks, b.divergence.max_degraded_ticks);
  EXPECT_EQ(a.balance.enabled, b.balance.enabled);
  EXPECT_EQ(a.balance.com_weight, b.balance.com_weight);
  EXPECT_EQ(a.balance.dcm_gain, b.balance.dcm_gain);
  EXPECT_EQ(a.balance.height_kp, b.balance.height_kp);
  EXPECT_EQ(a.balance.height_kd, b.balance.height_kd);
  EXPECT_EQ(a.balance.angular_momentum_damping, b.balance.angular_momentum_damping);
  EXPECT_EQ(a.balance.angular_momentum_weight, b.balance.angular_momentum_weight);
  EXPECT_EQ(a.balance.preview_s, b.balance.preview_s);
  EXPECT_EQ(a.balance.preview_capacity, b.balance.preview_capacity);
  EXPECT_EQ(a.balance.stance_height_m, b.balance.stance_height_m);
  EXPECT_EQ(a.balance.stance_speed_mps, b.balance.stance_speed_mps);
  EXPECT_EQ(a.balance.sole_weight, b.balance.sole_weight);
  EXPECT_EQ(a.balance.sole_kp, b.balance.sole_kp);
  EXPECT_EQ(a.balance.sole_kd, b.balance.sole_kd);
  EXPECT_EQ(a.balance.sole_margin_m, b.balance.sole_margin_m);
  EXPECT_EQ(a.balance.flat_landing_max_tilt_rad, b.balance.flat_landing_max_tilt_rad);
  EXPECT_EQ(a.leash.enabled, b.leash.enabled);
  EXPECT_EQ(a.leash.max_offset_m, b.leash.max_offset_m);
  EXPECT_EQ(a.leash.max_heading_rad, b.leash.max_heading_rad);
}

void expectSameEnvironment(const Environment& a, const Environment& b) {
  EXPECT_EQ(a.has_ground, b.has_ground);
  EXPECT_EQ(a.ground.n_W, b.ground.n_W);
  EXPECT_EQ(a.ground.offset_m, b.ground.offset_m);
  EXPECT_EQ(a.ground.friction, b.ground.friction);
  ASSERT_EQ(a.boxes.size(), b.boxes.size());
  for (std::size_t i = 0; i < a.boxes.size(); ++i) {
    EXPECT_EQ(a.boxes[i].name, b.boxes[i].name);
    EXPECT_EQ(a.boxes[i].size_m, b.boxes[i].size_m);
    EXPECT_TRUE(a.boxes[i].X_WO.isApprox(b.boxes[i].X_WO, 1e-15));
    EXPECT_EQ(a.boxes[i].friction, b.boxes[i].friction);
  }
}

TEST(ConfigFile, ShippedDefaultFileEqualsTheDefaultStructs) {
  const std::string path = test::sourcePath("tools/config/default.yaml");
  const FilterConfig config = loadFilterConfig(path);
  expectSameFilterOptions(config.filter, FilterOptions{});
  expectSameEnvironment(config.environment, Environment{});
}

TEST(ConfigFile, ShippedDefaultFileListsEveryKeyOnceWithAComment) {
  const std::string text = testing_io::readWholeFile(test::sourcePath("tools/config/default.yaml"));
  std::map<std::string, int> count;
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(start, end - start);
    start = end + 1;
    const std::size_t first = line.find_first_not_of(' ');
    if (first == std::string::npos || line[first] == '#') continue;
    const std::size_t colon = line.find(':', first);
    ASSERT_NE(colon, std::string::npos) << line;
    ++count[line.substr(first, colon - first)];
    EXPECT_NE(line.find(" # ", colon), std::string::npos) << "no comment on: " << line;
  }
  const std::map<std::string, int> expected{
      {"dt_s", 1}, {"feedback", 1}, {"base_linear_kp", 1}, {"base_linear_kd", 1},
      {"base_angular_kp", 1}, {"base_angular_kd", 1}, {"joint_kp", 1}, {"joint_kd", 1},
      {"task", 1}, {"enabled", 3}, {"body", 1}, {"p_BP", 1}, {"kp_linear", 1},
      {"kd_linear", 1}, {"kp_angular", 1}, {"kd_angular", 1}, {"joint_weight", 1},
      {"as_constraint_rows", 1}, {"initial_penetration_tolerance_m", 1},
      {"contacts", 1}, {"max_links", 1}, {"stabilization_kp", 1}, {"stabilization_kd", 1},
      {"merge_distance_m", 1}, {"release_force_n", 1}, {"release_ticks", 1},
      {"reengage_depth_m", 1}, {"plastic_impact", 1}, {"solver", 1}, {"accel_weight", 2},
      {"force_weight", 2}, {"sr_damping", 1}, {"environment", 1}, {"mode", 1}, {"qp", 1},
      {"torque_weight", 1}, {"min_normal_force_n", 1}, {"friction_facets", 1},
      {"cop_margin_m", 1}, {"liftoff_clearance_m", 1}, {"release_transition_s", 1},
      {"joint_limit_horizon_s", 1}, {"joint_limit_max_decel", 1},
      {"enforce_torque_limits", 1}, {"enforce_joint_limits", 1}, {"yaw_slip", 1}, {"tangential_slip", 1}, {"eps_abs", 1},
      {"max_iterations", 1}, {"warm_start", 1}, {"engine", 1}, {"divergence", 1}, {"max_base_error_m", 1},
      {"max_base_rotation_rad", 1}, {"max_joint_error_rad", 1}, {"max_base_residual_rel", 1},
      {"max_degraded_ticks", 1}, {"balance", 1}, {"com_weight", 1}, {"dcm_gain", 1},
      {"height_kp", 1}, {"height_kd", 1}, {"angular_momentum_damping", 1},
      {"angular_momentum_weight", 1}, {"preview_s", 1}, {"preview_capacity", 1},
      {"stance_height_m", 1}, {"stance_speed_mps", 1}, {"sole_weight", 1}, {"sole_kp", 1},
      {"sole_kd", 1}, {"sole_margin_m", 1}, {"flat_landing_max_tilt_rad", 1}, {"roll_tilt_rad", 1},
      {"ground", 1}, {"slope_deg", 1}, {"heading_deg", 1}, {"height_m", 1}, {"friction", 1},
      {"boxes", 1}, {"leash", 1}, {"max_offset_m", 1}, {"max_heading_rad", 1}};
  EXPECT_EQ(count, expected);
}

TEST(ConfigFile, EmptyTextGivesDefaults) {
  for (const char* text : {"", "# only a comment\n", "---\n"}) {
    const FilterConfig config = parseFilterConfig(text, "empty.yaml");
    expectSameFilterOptions(config.filter, FilterOptions{});
    expectSameEnvironment(config.environment, Environment{});
  }
}

TEST(ConfigFile, AKeyOverridesExactlyItsField) {
  const FilterConfig config = parseFilterConfig(
      "dt_s: 0.002\n"
      "feedback:\n"
      "  joint_kp: 123.5\n"
      "task: {enabled: false, body: head, p_BP: [0.1, -0.2, 3e-1]}\n"
      "contacts:\n"
      "  max_links: 12\n"
      "  plastic_impact: false\n"
      "solver: {sr_damping: 1e-6}\n"
      "leash: {enabled: true, max_offset_m: 0.25}\n",
      "override.yaml");
  FilterOptions expected;
  expected.dt_s = 0.002;
  expected.feedback.joint_kp = 123.5;
  expected.task.enabled = false;
  expected.task.body = "head";
  expected.task.p_BP = Eigen::Vector3d(0.1, -0.2, 0.3);
  expected.contacts.max_links = 12;
  expected.contacts.plastic_impact = false;
  expected.solver.sr_damping = 1e-6;
  expected.leash.enabled = true;
  expected.leash.max_offset_m = 0.25;
  expectSameFilterOptions(config.filter, expected);
  expectSameEnvironment(config.environment, Environment{});
}

TEST(ConfigFile, EnvironmentGroundAndBoxes) {
  const FilterConfig config = parseFilterConfig(
      "environment:\n"
      "  ground: {slope_deg: 5, heading_deg: 90, height_m: 0.25, friction: 0.6}\n"
      "  boxes:\n"
      "    - name: step\n"
      "      size_m: [0.4, 1.0, 0.15]\n"
      "      position_m: [1.0, 0.0, 0.075]\n"
      "      rpy_deg: [0, 0, 90]\n"
      "      friction: 0.9\n"
      "    - {name: table}\n",
      "env.yaml");
  const Environment& env = config.environment;
  EXPECT_TRUE(env.has_ground);
  const GroundPlane g = GroundPlane::sloped(5 * M_PI / 180, 90 * M_PI / 180, 0.25, 0.6);
  EXPECT_EQ(env.ground.n_W, g.n_W);
  EXPECT_EQ(env.ground.offset_m, g.offset_m);
  EXPECT_EQ(env.ground.friction, 0.6);
  ASSERT_EQ(env.boxes.size(), 2u);
  EXPECT_EQ(env.boxes[0].name, "step");
  EXPECT_EQ(env.boxes[0].size_m, Eigen::Vector3d(0.4, 1.0, 0.15));
  EXPECT_EQ(env.boxes[0].X_WO.translation(), Eigen::Vector3d(1.0, 0.0, 0.075));
  // Yaw 90°: the box's x axis points along world y.
  EXPECT_LT((env.boxes[0].X_WO.linear() * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(),
            1e-15);
  EXPECT_EQ(env.boxes[0].friction, 0.9);
  EXPECT_EQ(env.boxes[1].name, "table");
  EXPECT_EQ(env.boxes[1].size_m, EnvironmentBox{}.size_m);
  EXPECT_TRUE(env.boxes[1].X_WO.isApprox(Eigen::Isometry3d::Identity()));
}

TEST(ConfigFile, RollPitchYawFollowUrdfOrder) {
  const FilterConfig config = parseFilterConfig(
      "environment: {boxes: [{rpy_deg: [30, -20, 50]}]}\n", "rpy.yaml");
  const double r = 30 * M_PI / 180, p = -20 * M_PI / 180, y = 50 * M_PI / 180;
  const Eigen::Matrix3d Rx = Eigen::AngleAxisd(r, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Matrix3d Ry = Eigen::AngleAxisd(p, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(y, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_TRUE(config.environment.boxes.at(0).X_WO.linear().isApprox(Rz * Ry * Rx, 1e-15));
}

TEST(ConfigFile, GroundNone) {
  const FilterConfig config = parseFilterConfig("environment:\n  ground: none\n", "none.yaml");
  EXPECT_FALSE(config.environment.has_ground);
}

// ---------------------------------------------------------------------------------------
// Errors

void expectConfigError(const std::string& text, int line, int column, const std::string& needle) {
  expectInputError([&] { parseFilterConfig(text, "cfg.yaml"); }, "cfg.yaml", line, column, needle);
}

TEST(ConfigFileErrors, UnknownKeyNamesItsFullPathAndPosition) {
  expectConfigError("dt_s: 0.001\nfeedback:\n  joint_kp: 1\n  joint_kpp: 2\n", 4, 3,
                    "feedback.joint_kpp: unknown key (known here: base_linear_kp,");
  expectConfigError("dt: 0.001\n", 1, 1, "dt: unknown key");
  expectConfigError("environment:\n  boxes:\n    - name: a\n    - {name: b, colour: red}\n", 4, 17,
                    "environment.boxes[1].colour: unknown key");
  expectConfigError("environment:\n  ground: {slope: 3}\n", 2, 12,
                    "environment.ground.slope: unknown key");
}

TEST(ConfigFileErrors, DuplicateKey) {
  expectConfigError("task:\n  kp_linear: 1\n  kp_linear: 2\n", 3, 3, "task.kp_linear: duplicate key");
}

TEST(ConfigFileErrors, WrongTypesNameThePathAndPosition) {
  expectConfigError("dt_s: fast\n", 1, 7, "dt_s: expected a finite number, got \"fast\"");
  expectConfigError("dt_s: .nan\n", 1, 7, "dt_s: expected a finite number");
  expectConfigError("divergence:\n  max_base_error_m: [1]\n", 2, 21,
                    "divergence.max_base_error_m: expected a finite number, got a sequence");
  expectConfigError("contacts:\n  max_links: 2.5\n", 2, 14, "contacts.max_links: expected an integer, got \"2.5\"");
  expectConfigError("task:\n  enabled: maybe\n", 2, 12, "task.enabled: expected true or false");
  expectConfigError("task:\n  body: [a, b]\n", 2, 9, "task.body: expected a string, got a sequence");
  expectConfigError("feedback: 3\n", 1, 11, "feedback: expected a map, got \"3\"");
  expectConfigError("environment:\n  ground: flat\n", 2, 11,
                    "environment.ground: expected a map or none, got \"flat\"");
  expectConfigError("environment:\n  boxes: {name: a}\n", 2, 10,
                    "environment.boxes: expected a sequence of boxes, got a map");
  expectConfigError("- 1\n- 2\n", 1, 1, "expected a map of options, got a sequence");
}

TEST(ConfigFileErrors, WrongVectorLengths) {
  expectConfigError("task:\n  p_BP: [1, 2]\n", 2, 9, "task.p_BP: expected a sequence of 3 numbers, got 2");
  expectConfigError("environment:\n  boxes:\n    - size_m: [1, 2, 3, 4]\n", 3, 15,
                    "environment.boxes[0].size_m: expected a sequence of 3 numbers, got 4");
  expectConfigError("task:\n  p_BP: [1, x, 3]\n", 2, 13, "task.p_BP[1]: expected a finite number, got \"x\"");
  expectConfigError("task:\n  p_BP: 1\n", 2, 9, "task.p_BP: expected a sequence of 3 numbers, got \"1\"");
}

TEST(ConfigFileErrors, SyntaxErrorHasThePositionOfTheParser) {
  const InputError e = expectInputError(
      [] { parseFilterConfig("task:\n  p_BP: [1, 2, 3\ndt_s: 1\n", "cfg.yaml"); }, "cfg.yaml", 3, 5,
      "YAML syntax error");
  EXPECT_GT(e.line(), 0);
}

TEST(ConfigFileErrors, ValuesRejectedByValidateAreLocatedAtTheirKey) {
  expectConfigError("feedback: {joint_kp: 1}\ndt_s: -0.001\n", 2, 1, "dt_s: filter option dt_s");
  // A group rule ("feedback.*") is located at its section.
  expectConfigError("dt_s: 0.001\nfeedback:\n  joint_kd: -1\n", 2, 1, "feedback: filter option feedback.*");
  expectConfigError("contacts:\n  release_ticks: 1\n  max_links: 0\n", 3, 3,
                    "contacts.max_links: filter option contacts.max_links");
  expectConfigError("environment:\n  boxes:\n    - {name: a}\n    - {name: b, size_m: [1, -1, 1]}\n", 4, 17,
                    "environment.boxes[1].size_m: environment: box 1 \"b\": size must be finite and positive");
  expectConfigError("leash:\n  max_heading_rad: 0\n", 2, 3,
                    "leash.max_heading_rad: filter option leash.max_heading_rad");
  expectConfigError("environment:\n  ground: {friction: -0.1}\n", 2, 12,
                    "environment.ground.friction: environment: ground friction must be >= 0");
}

TEST(ConfigFileErrors, LoadReportsTheFileAndMissingFiles) {
  const std::string path = tempPath("bad.yaml");
  writeFile(path, "solver:\n  accel_weigth: 1\n");
  expectInputError([&] { loadFilterConfig(path); }, path, 2, 3, "solver.accel_weigth: unknown key");
  const std::string missing = tempPath("missing.yaml");
  expectInputError([&] { loadFilterConfig(missing); }, missing, 0, 0,
                   "cannot open file: No such file or directory");
}

// ---------------------------------------------------------------------------------------
// The QP mode's keys

TEST(ConfigFile, ModeQpAndItsSectionParse) {
  const FilterConfig config = parseFilterConfig(
      "mode: qp\n"
      "qp:\n"
      "  accel_weight: 2.5\n"
      "  force_weight: 1e-5\n"
      "  torque_weight: 0\n"
      "  min_normal_force_n: 5\n"
      "  friction_facets: 8\n"
      "  cop_margin_m: 0.01\n"
      "  liftoff_clearance_m: 0.03\n"
      "  release_transition_s: 0.1\n"
      "  joint_limit_horizon_s: 0.02\n"
      "  joint_limit_max_decel: 80\n"
      "  enforce_torque_limits: false\n"
      "  enforce_joint_limits: false\n"
      "  yaw_slip: false\n"
      "  tangential_slip: false\n"
      "  eps_abs: 1e-9\n"
      "  max_iterations: 50\n"
      "  warm_start: false\n"
      "  engine: proxqp\n",
      "qp.yaml");
  FilterOptions expected;
  expected.mode = FilterMode::kQp;
  expected.qp.accel_weight = 2.5;
  expected.qp.force_weight = 1e-5;
  expected.qp.torque_weight = 0.0;
  expected.qp.min_normal_force_n = 5.0;
  expected.qp.friction_facets = 8;
  expected.qp.cop_margin_m = 0.01;
  expected.qp.liftoff_clearance_m = 0.03;
  expected.qp.release_transition_s = 0.1;
  expected.qp.joint_limit_horizon_s = 0.02;
  expected.qp.joint_limit_max_decel = 80.0;
  expected.qp.enforce_torque_limits = false;
  expected.qp.enforce_joint_limits = false;
  expected.qp.yaw_slip = false;
  expected.qp.tangential_slip = false;
  expected.qp.solver.eps_abs = 1e-9;
  expected.qp.solver.max_iterations = 50;
  expected.qp.solver.warm_start = false;
  expected.qp.solver.engine = "proxqp";
  expectSameFilterOptions(config.filter, expected);
  // mode alone switches the solver and keeps every qp default; paper is the default.
  const FilterConfig qp_only = parseFilterConfig("mode: qp\n", "mode.yaml");
  FilterOptions qp_defaults;
  qp_defaults.mode = FilterMode::kQp;
  expectSameFilterOptions(qp_only.filter, qp_defaults);
  EXPECT_EQ(parseFilterConfig("mode: paper\n", "paper.yaml").filter.mode, FilterMode::kPaper);
  EXPECT_EQ(parseFilterConfig("", "empty.yaml").filter.mode, FilterMode::kPaper);
}

TEST(ConfigFileErrors, UnknownModeNamesTheKeyAndLine) {
  expectConfigError("dt_s: 0.001\nmode: banana\n", 2, 7, "mode: expected paper or qp, got \"banana\"");
  expectConfigError("mode: QP\n", 1, 7, "mode: expected paper or qp, got \"QP\"");  // case matters
  expectConfigError("mode: [qp]\n", 1, 7, "mode:");
}

TEST(ConfigFileErrors, QpOptionsOutOfRangeNameTheOption) {
  // Two facets cannot make a friction pyramid: validate's rule, located at the key.
  expectConfigError("mode: qp\nqp:\n  friction_facets: 2\n", 3, 3,
                    "qp.friction_facets: filter option qp.friction_facets must be in [3, 16]");
  expectConfigError("qp:\n  friction_facets: 17\n", 2, 3, "qp.friction_facets");
  expectConfigError("qp:\n  friction_facets: 4.5\n", 2, 20,
                    "qp.friction_facets: expected an integer, got \"4.5\"");
  expectConfigError("qp:\n  min_normal_force_n: -1\n", 2, 3,
                    "qp.min_normal_force_n: filter option qp.min_normal_force_n must be >= 0");
  expectConfigError("qp:\n  frction_facets: 4\n", 2, 3, "qp.frction_facets: unknown key");
}

}  // namespace
}  // namespace dynfilter::io
