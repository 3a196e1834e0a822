// Reference motion CSV reader: the format, every error with its location, and the
// derivative estimation on analytic motions.
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/io/reference_motion.hpp"
#include "io/io_test_support.hpp"

namespace dynfilter::io {
namespace {

using testing_io::expectInputError;
using testing_io::fixedInfo;
using testing_io::humanInfo;
using testing_io::num;
using testing_io::tempPath;
using testing_io::writeFile;

// ---------------------------------------------------------------------------------------
// Writing test files (independently of the library's writer)

std::vector<std::string> columnsFor(const ModelInfo& info, bool with_v, bool with_a) {
  std::vector<std::string> c{"time"};
  if (info.floating_base)
    for (const char* n : {"base_x", "base_y", "base_z", "base_qw", "base_qx", "base_qy", "base_qz"})
      c.emplace_back(n);
  for (const auto& j : info.joint_names) c.push_back(j);
  if (with_v) {
    if (info.floating_base)
      for (const char* n : {"base_vx", "base_vy", "base_vz", "base_wx", "base_wy", "base_wz"})
        c.emplace_back(n);
    for (const auto& j : info.joint_names) c.push_back(j + ".v");
  }
  if (with_a) {
    if (info.floating_base)
      for (const char* n :
           {"base_ax", "base_ay", "base_az", "base_alphax", "base_alphay", "base_alphaz"})
        c.emplace_back(n);
    for (const auto& j : info.joint_names) c.push_back(j + ".a");
  }
  return c;
}

// Values of one frame in the order of columnsFor().
std::vector<double> valuesFor(const ModelInfo& info, const ReferenceFrame& f, bool with_v,
                              bool with_a) {
  std::vector<double> x{f.time_s};
  for (int i = 0; i < info.nq; ++i) x.push_back(f.q[i]);
  if (with_v)
    for (int i = 0; i < info.nv; ++i) x.push_back(f.v[i]);
  if (with_a)
    for (int i = 0; i < info.nv; ++i) x.push_back(f.vdot[i]);
  return x;
}

std::string joinLine(const std::vector<std::string>& fields) {
  std::string s;
  for (std::size_t i = 0; i < fields.size(); ++i) s += (i ? "," : "") + fields[i];
  return s;
}

// Header then one line per frame; columns permuted by @p order (indices into columnsFor).
std::vector<std::string> csvLines(const ModelInfo& info, const std::vector<ReferenceFrame>& frames,
                                  bool with_v, bool with_a, std::vector<std::size_t> order = {}) {
  const std::vector<std::string> columns = columnsFor(info, with_v, with_a);
  if (order.empty())
    for (std::size_t i = 0; i < columns.size(); ++i) order.push_back(i);
  std::vector<std::string> lines;
  std::vector<std::string> fields;
  for (std::size_t i : order) fields.push_back(columns[i]);
  lines.push_back(joinLine(fields));
  for (const ReferenceFrame& f : frames) {
    const std::vector<double> x = valuesFor(info, f, with_v, with_a);
    fields.clear();
    for (std::size_t i : order) fields.push_back(num(x[i]));
    lines.push_back(joinLine(fields));
  }
  return lines;
}

std::string joinLines(const std::vector<std::string>& lines, const char* eol = "\n") {
  std::string s;
  for (const auto& l : lines) s += l + eol;
  return s;
}

// A few frames of a valid human-figure motion with distinct, exactly representable values.
std::vector<ReferenceFrame> sampleFrames(const ModelInfo& info, int n, unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<ReferenceFrame> frames;
  for (int k = 0; k < n; ++k) {
    ReferenceFrame f(info.nq, info.nv);
    f.time_s = 0.01 * k;
    for (int i = 0; i < info.nq; ++i) f.q[i] = u(rng);
    if (info.floating_base) {
      // (w, x, y, z) = (0.5, 0.5, 0.5, 0.5): exactly unit norm in binary.
      f.q.segment<4>(3) = Eigen::Vector4d(0.5, -0.5, 0.5, 0.5);
    }
    for (int i = 0; i < info.nv; ++i) {
      f.v[i] = u(rng);
      f.vdot[i] = u(rng);
    }
    frames.push_back(f);
  }
  return frames;
}

// Index of column @p name in a header line (0-based).
std::size_t columnIndex(const ModelInfo& info, bool v, bool a, const std::string& name) {
  const auto c = columnsFor(info, v, a);
  return static_cast<std::size_t>(std::find(c.begin(), c.end(), name) - c.begin());
}

// Replaces field @p column (0-based) of a CSV line.
std::string replaceField(const std::string& line, std::size_t column, const std::string& text) {
  std::vector<std::string> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    fields.push_back(line.substr(start, comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  fields.at(column) = text;
  return joinLine(fields);
}

// ---------------------------------------------------------------------------------------
// The format

TEST(ReferenceMotionReader, ReadsShuffledColumnsCommentsBlankLinesAndCrlfExactly) {
  const ModelInfo& info = humanInfo();
  const auto frames = sampleFrames(info, 5);
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < columnsFor(info, false, false).size(); ++i) order.push_back(i);
  std::reverse(order.begin(), order.end());  // time last, joints first
  std::vector<std::string> lines = csvLines(info, frames, false, false, order);
  lines.insert(lines.begin(), "# a human figure motion");
  lines.insert(lines.begin() + 2, "   # comment between header and data");
  lines.insert(lines.begin() + 4, "");
  lines.push_back("# trailing comment");
  const std::string path = tempPath("motion.csv");
  writeFile(path, "\xEF\xBB\xBF" + joinLines(lines, "\r\n"));

  const ReferenceMotion m = readReferenceMotion(path, info);
  EXPECT_EQ(m.source, path);
  EXPECT_FALSE(m.had_velocities);
  EXPECT_FALSE(m.had_accelerations);
  ASSERT_EQ(m.frames.size(), frames.size());
  for (std::size_t k = 0; k < frames.size(); ++k) {
    EXPECT_EQ(m.frames[k].time_s, frames[k].time_s);
    ASSERT_EQ(m.frames[k].q.size(), info.nq);
    EXPECT_EQ(m.frames[k].v.size(), info.nv);
    EXPECT_EQ(m.frames[k].vdot.size(), info.nv);
    for (int i = 0; i < info.nq; ++i) EXPECT_EQ(m.frames[k].q[i], frames[k].q[i]) << k << " " << i;
  }
}

TEST(ReferenceMotionReader, JointColumnLandsAtItsConfigurationIndex) {
  const ModelInfo& info = humanInfo();
  auto frames = sampleFrames(info, 3);
  const int j = info.findJoint("l_knee");
  ASSERT_GE(j, 0);
  frames[1].q[info.configurationIndex(j)] = -1.25;
  const std::string path = tempPath("knee.csv");
  writeFile(path, joinLines(csvLines(info, frames, false, false)));
  const ReferenceMotion m = readReferenceMotion(path, info);
  EXPECT_EQ(m.frames[1].q[info.configurationIndex(j)], -1.25);
  EXPECT_EQ(m.frames[1].q[0], frames[1].q[0]);
}

TEST(ReferenceMotionReader, ReadsGivenVelocitiesAndAccelerationsExactly) {
  const ModelInfo& info = humanInfo();
  const auto frames = sampleFrames(info, 4);
  const std::string path = tempPath("va.csv");
  writeFile(path, joinLines(csvLines(info, frames, true, true)));
  const ReferenceMotion m = readReferenceMotion(path, info);
  EXPECT_TRUE(m.had_velocities);
  EXPECT_TRUE(m.had_accelerations);
  for (std::size_t k = 0; k < frames.size(); ++k) {
    EXPECT_TRUE((m.frames[k].v.array() == frames[k].v.array()).all()) << k;
    EXPECT_TRUE((m.frames[k].vdot.array() == frames[k].vdot.array()).all()) << k;
  }
}

TEST(ReferenceMotionReader, QuotedFieldsAndSpacesAroundFieldsAreAccepted) {
  const ModelInfo info = fixedInfo();
  const std::string path = tempPath("quoted.csv");
  writeFile(path, "\"time\", hinge ,\"slide\"\n0, 1.5 ,\"-2\"\n+0.5,1e-3,.25\n");
  const ReferenceMotion m = readReferenceMotion(path, info);
  ASSERT_EQ(m.frames.size(), 2u);
  EXPECT_EQ(m.frames[0].q, Eigen::Vector2d(1.5, -2.0));
  EXPECT_EQ(m.frames[1].time_s, 0.5);
  EXPECT_EQ(m.frames[1].q, Eigen::Vector2d(1e-3, 0.25));
}

TEST(ReferenceMotionReader, FixedBaseModelReadsJointsOnly) {
  const ModelInfo info = fixedInfo();
  const std::string path = tempPath("fixed.csv");
  writeFile(path, "time,slide,hinge\n0,0.1,0.2\n0.1,0.3,0.4\n0.2,0.5,0.8\n");
  const ReferenceMotion m = readReferenceMotion(path, info);
  ASSERT_EQ(m.frames.size(), 3u);
  EXPECT_EQ(m.frames[2].q, Eigen::Vector2d(0.8, 0.5));
  ASSERT_EQ(m.frames[1].v.size(), 2);
  // Three points of a quadratic: the fit is exact.
  EXPECT_NEAR(m.frames[1].v[0], (0.8 - 0.2) / 0.2, 1e-12);
  EXPECT_NEAR(m.frames[1].v[1], (0.5 - 0.1) / 0.2, 1e-12);
}

TEST(ReferenceMotionReader, ColumnsOfLockedJointsAreNotRead) {
  // A reference made for the whole robot, read by a model with one joint welded
  // (--lock-joints): that joint's columns are listed and skipped, any other name still fails.
  ModelInfo info = fixedInfo();
  info.locked_joint_names = {"wrist"};
  const std::string path = tempPath("locked.csv");
  writeFile(path,
            "time,slide,wrist,hinge,slide.v,wrist.v,hinge.v\n"
            "0,0.1,9,0.2,1,9,2\n0.1,0.3,9,0.4,3,9,4\n");
  const ReferenceMotion m = readReferenceMotion(path, info);
  ASSERT_EQ(m.frames.size(), 2u);
  EXPECT_EQ(m.frames[1].q, Eigen::Vector2d(0.4, 0.3));
  EXPECT_EQ(m.frames[1].v, Eigen::Vector2d(4, 3));
  EXPECT_EQ(m.ignored_columns, (std::vector<std::string>{"wrist", "wrist.v"}));
  info.locked_joint_names.clear();
  expectInputError([&] { readReferenceMotion(path, info); }, path, 1, 3, "unknown column \"wrist\"");
}

TEST(ReferenceMotionReader, QuaternionWithinToleranceIsNormalised) {
  const ModelInfo& info = humanInfo();
  auto frames = sampleFrames(info, 3);
  const Eigen::Vector4d unit = Eigen::Vector4d(0.1, 0.7, -0.5, 0.3).normalized();
  frames[1].q.segment<4>(3) = unit * (1.0 + 8e-4);  // within the default 1e-3
  const std::string path = tempPath("quat.csv");
  writeFile(path, joinLines(csvLines(info, frames, false, false)));
  const ReferenceMotion m = readReferenceMotion(path, info);
  const Eigen::Vector4d read = m.frames[1].q.segment<4>(3);
  EXPECT_NEAR(read.norm(), 1.0, 1e-15);
  EXPECT_LT((read - unit).norm(), 1e-15);
}

// ---------------------------------------------------------------------------------------
// Errors, each with its location

struct ReferenceMotionErrors : ::testing::Test {
  const ModelInfo& info = humanInfo();
  std::vector<std::string> lines = csvLines(info, sampleFrames(info, 4), false, false);
  std::string path = tempPath("bad.csv");
  ReferenceReadOptions options;

  InputError expectError(int line, int column, const std::string& needle) {
    writeFile(path, joinLines(lines));
    return expectInputError([&] { readReferenceMotion(path, info, options); }, path, line, column,
                            needle);
  }
  std::size_t column(const std::string& name) const { return columnIndex(info, false, false, name); }
};

TEST_F(ReferenceMotionErrors, MissingJointColumnIsNamed) {
  const std::size_t c = column("l_knee");
  for (std::size_t i = 0; i < lines.size(); ++i) {
    // Drop the field from every line.
    std::string l = replaceField(lines[i], c, "@DROP@");
    l.replace(l.find(",@DROP@"), 7, "");
    lines[i] = l;
  }
  lines.insert(lines.begin(), "# comment");
  expectError(2, 0, "missing column \"l_knee\"");
}

TEST_F(ReferenceMotionErrors, MissingBaseColumnIsNamed) {
  lines[0] = replaceField(lines[0], column("base_qy"), "base_qq");
  options.allow_extra_columns = true;
  expectError(1, 0, "missing column \"base_qy\"");
}

TEST_F(ReferenceMotionErrors, UnknownColumnIsNamedWithItsIndex) {
  lines[0] = replaceField(lines[0], column("l_knee"), "l_kneee");
  const auto e = expectError(1, static_cast<int>(column("l_knee")) + 1, "unknown column \"l_kneee\"");
  EXPECT_EQ(e.column(), 1 + 7 + humanInfo().findJoint("l_knee") + 1);
}

TEST_F(ReferenceMotionErrors, DuplicateColumnIsNamedWithBothIndices) {
  lines[0] = replaceField(lines[0], column("l_knee"), "base_x");
  expectError(1, static_cast<int>(column("l_knee")) + 1, "duplicate column \"base_x\" (also column 2)");
}

TEST_F(ReferenceMotionErrors, WrongNumberOfFieldsGivesLineAndCounts) {
  lines[3] += ",0.5";
  expectError(4, 0, "expected 40 fields, found 41");
  lines[3] = lines[3].substr(0, lines[3].rfind(','));
  lines[3] = lines[3].substr(0, lines[3].rfind(','));
  expectError(4, 0, "expected 40 fields, found 39");
}

TEST_F(ReferenceMotionErrors, TextThatIsNotANumberGivesLineColumnAndText) {
  const std::size_t c = column("r_elbow");
  lines[2] = replaceField(lines[2], c, "1.2.3");
  expectError(3, static_cast<int>(c) + 1, "column \"r_elbow\": not a number: \"1.2.3\"");
  lines[2] = replaceField(lines[2], c, "");
  expectError(3, static_cast<int>(c) + 1, "not a number: \"\"");
  lines[2] = replaceField(lines[2], c, "0x10");
  expectError(3, static_cast<int>(c) + 1, "not a number: \"0x10\"");
}

TEST_F(ReferenceMotionErrors, NanAndInfAreRejected) {
  const std::size_t c = column("base_z");
  lines[4] = replaceField(lines[4], c, "NaN");
  expectError(5, static_cast<int>(c) + 1, "column \"base_z\": not a finite number: \"NaN\"");
  lines[4] = replaceField(lines[4], c, "-inf");
  expectError(5, static_cast<int>(c) + 1, "not a finite number: \"-inf\"");
  lines[4] = replaceField(lines[4], c, "1e999");
  expectError(5, static_cast<int>(c) + 1, "out of range: \"1e999\"");
}

TEST_F(ReferenceMotionErrors, TimeMustIncreaseStrictly) {
  lines[3] = replaceField(lines[3], 0, "0.01");  // same as line 3
  expectError(4, 1, "time 0.01 s is not after the previous frame's 0.01 s (line 3)");
  lines[3] = replaceField(lines[3], 0, "0.005");
  expectError(4, 1, "time 0.005 s is not after");
}

TEST_F(ReferenceMotionErrors, QuaternionOffUnitNormIsRejected) {
  const std::size_t c = column("base_qw");
  lines[2] = replaceField(lines[2], c, "0.52");  // norm = sqrt(0.52² + 0.75) ≈ 1.01015
  expectError(3, static_cast<int>(c) + 1, "base quaternion norm 1.01014");
  expectError(3, static_cast<int>(c) + 1, "differs from 1 by more than 0.001");
  options.quaternion_tolerance = 0.02;
  writeFile(path, joinLines(lines));
  EXPECT_NO_THROW(readReferenceMotion(path, info, options));
}

TEST_F(ReferenceMotionErrors, FewerThanTwoFrames) {
  lines.resize(2);
  expectError(2, 0, "at least 2 frames, found 1");
  lines.resize(1);
  lines.push_back("# only a comment");
  expectError(1, 0, "at least 2 frames, found 0");
}

TEST_F(ReferenceMotionErrors, EmptyFile) {
  lines.clear();
  expectError(0, 0, "empty file");
  lines = {"# nothing but", "", "# comments"};
  expectError(0, 0, "empty file");
}

TEST_F(ReferenceMotionErrors, UnreadableFile) {
  const std::string missing = tempPath("does_not_exist.csv");
  const auto e = expectInputError([&] { readReferenceMotion(missing, info); }, missing, 0, 0,
                                  "cannot open file: No such file or directory");
  EXPECT_EQ(std::string(e.what()), missing + ": cannot open file: No such file or directory");
}

TEST_F(ReferenceMotionErrors, PartialVelocitiesNameTheFirstMissingColumn) {
  lines = csvLines(info, sampleFrames(info, 4), true, false);
  const auto cols = columnsFor(info, true, false);
  const std::size_t wy = static_cast<std::size_t>(std::find(cols.begin(), cols.end(), "base_wy") - cols.begin());
  const std::size_t knee = static_cast<std::size_t>(std::find(cols.begin(), cols.end(), "l_knee.v") - cols.begin());
  lines[0] = replaceField(lines[0], knee, "unknown_a");
  lines[0] = replaceField(lines[0], wy, "unknown_b");
  options.allow_extra_columns = true;
  expectError(1, 0, "incomplete velocity columns: missing \"base_wy\" (give all 38 or none)");
}

TEST_F(ReferenceMotionErrors, PartialAccelerationsNameTheFirstMissingColumn) {
  lines = csvLines(info, sampleFrames(info, 4), false, true);
  const auto cols = columnsFor(info, false, true);
  const std::size_t c = static_cast<std::size_t>(std::find(cols.begin(), cols.end(), "r_knee.a") - cols.begin());
  lines[0] = replaceField(lines[0], c, "extra");
  options.allow_extra_columns = true;
  expectError(1, 0, "incomplete acceleration columns: missing \"r_knee.a\"");
}

TEST_F(ReferenceMotionErrors, ExtraColumnsAreAllowedOnlyWhenAskedAndNotParsed) {
  for (std::size_t i = 0; i < lines.size(); ++i) lines[i] += i == 0 ? ",comment" : ",not a number";
  expectError(1, 41, "unknown column \"comment\"");
  options.allow_extra_columns = true;
  writeFile(path, joinLines(lines));
  EXPECT_EQ(readReferenceMotion(path, info, options).frames.size(), 4u);
}

TEST_F(ReferenceMotionErrors, MalformedQuoteIsRejected) {
  lines[2] = replaceField(lines[2], 3, "\"0.5");
  expectError(3, 4, "malformed quoted field");
}

TEST(ReferenceMotionReader, BaseColumnsAreRejectedForAFixedBase) {
  const ModelInfo info = fixedInfo();
  const std::string path = tempPath("fixed_base.csv");
  writeFile(path, "time,hinge,slide,base_x\n0,1,2,3\n1,1,2,3\n");
  expectInputError([&] { readReferenceMotion(path, info); }, path, 1, 4,
                   "column \"base_x\" is a base column but model \"fixed_arm\" has a fixed base");
}

TEST(ReferenceMotionReader, InvalidOptionsAreRejected) {
  const ModelInfo info = fixedInfo();
  ReferenceReadOptions options;
  options.smoothing_window = 4;
  EXPECT_THROW(readReferenceMotion("unused.csv", info, options), std::invalid_argument);
  options.smoothing_window = 1;
  EXPECT_THROW(readReferenceMotion("unused.csv", info, options), std::invalid_argument);
  options.smoothing_window = 5;
  options.quaternion_tolerance = 0.0;
  EXPECT_THROW(readReferenceMotion("unused.csv", info, options), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------
// Derivative estimation on analytic motions

// Joint j: a_j sin(w_j t + φ_j); base on a helix p(t) = (r cos Ωt, r sin Ωt, c t) while
// rotating at the constant body rate ω_B: R(t) = R0 expSO3(ω_B t). With varying_rate the
// rotation is R(t) = R0 exp(α(t) u1) exp(β(t) u2) instead, whose body rate
// ω_B = R2ᵀ u1 α̇ + u2 β̇ changes in time and direction.
struct AnalyticMotion {
  bool varying_rate = false;
  double r = 0.5, Omega = 1.0, c = 0.2;
  Eigen::Vector3d omega_B{0.3, -0.2, 0.5};
  Eigen::Matrix3d R0 = expSO3(Eigen::Vector3d(0.4, 0.1, -0.3));
  Eigen::Vector3d u1 = Eigen::Vector3d(1.0, 2.0, -1.0).normalized();
  Eigen::Vector3d u2 = Eigen::Vector3d(-0.5, 0.3, 1.0).normalized();

  double amp(int j) const { return 0.2 + 0.01 * j; }   // rad
  double freq(int j) const { return 0.5 + 0.05 * j; }  // rad/s
  double phase(int j) const { return 0.3 * j; }
  // Max over the joints of A w³ and A w⁴ (the fit's truncation errors scale with them).
  double maxAw3(int nj) const {
    double m = 0;
    for (int j = 0; j < nj; ++j) m = std::max(m, amp(j) * std::pow(freq(j), 3));
    return m;
  }
  double maxAw4(int nj) const {
    double m = 0;
    for (int j = 0; j < nj; ++j) m = std::max(m, amp(j) * std::pow(freq(j), 4));
    return m;
  }

  double alpha(double t, int d) const {  // d-th derivative of α(t) = 0.4 t + 0.3 sin 1.3t
    const double w = 1.3;
    if (d == 0) return 0.4 * t + 0.3 * std::sin(w * t);
    if (d == 1) return 0.4 + 0.3 * w * std::cos(w * t);
    return -0.3 * w * w * std::sin(w * t);
  }
  double beta(double t, int d) const {  // d-th derivative of β(t) = 0.5 sin(0.9 t + 0.2)
    const double w = 0.9;
    if (d == 0) return 0.5 * std::sin(w * t + 0.2);
    if (d == 1) return 0.5 * w * std::cos(w * t + 0.2);
    return -0.5 * w * w * std::sin(w * t + 0.2);
  }

  Eigen::Vector3d p(double t) const { return {r * std::cos(Omega * t), r * std::sin(Omega * t), c * t}; }
  Eigen::Vector3d pd(double t) const {
    return {-r * Omega * std::sin(Omega * t), r * Omega * std::cos(Omega * t), c};
  }
  Eigen::Vector3d pdd(double t) const {
    return {-r * Omega * Omega * std::cos(Omega * t), -r * Omega * Omega * std::sin(Omega * t), 0.0};
  }
  Eigen::Matrix3d R(double t) const {
    if (!varying_rate) return R0 * expSO3(omega_B * t);
    return R0 * expSO3(alpha(t, 0) * u1) * expSO3(beta(t, 0) * u2);
  }
  Eigen::Vector3d omega(double t) const {
    if (!varying_rate) return omega_B;
    const Eigen::Vector3d w1 = expSO3(beta(t, 0) * u2).transpose() * u1;
    return w1 * alpha(t, 1) + u2 * beta(t, 1);
  }
  Eigen::Vector3d omegaDot(double t) const {
    if (!varying_rate) return Eigen::Vector3d::Zero();
    const Eigen::Vector3d w1 = expSO3(beta(t, 0) * u2).transpose() * u1;
    return -beta(t, 1) * u2.cross(w1) * alpha(t, 1) + w1 * alpha(t, 2) + u2 * beta(t, 2);
  }

  ReferenceFrame frame(const ModelInfo& info, double t) const {
    ReferenceFrame f(info.nq, info.nv);
    f.time_s = t;
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.linear() = R(t);
    X.translation() = p(t);
    setBasePoseInConfiguration(X, f.q);
    for (int j = 0; j < info.nj; ++j)
      f.q[info.configurationIndex(j)] = amp(j) * std::sin(freq(j) * t + phase(j));
    return f;
  }
  // Analytic v and v̇ (base: v_B = Rᵀ ṗ, ω_B; v̇_B = Rᵀ p̈ − ω_B × v_B, ω̇_B).
  void derivatives(const ModelInfo& info, double t, Eigen::VectorXd& v, Eigen::VectorXd& a) const {
    v.resize(info.nv);
    a.resize(info.nv);
    const Eigen::Vector3d vB = R(t).transpose() * pd(t);
    const Eigen::Vector3d w = omega(t);
    v.head<3>() = vB;
    v.segment<3>(3) = w;
    a.head<3>() = R(t).transpose() * pdd(t) - w.cross(vB);
    a.segment<3>(3) = omegaDot(t);
    for (int j = 0; j < info.nj; ++j) {
      v[info.velocityIndex(j)] = amp(j) * freq(j) * std::cos(freq(j) * t + phase(j));
      a[info.velocityIndex(j)] = -amp(j) * freq(j) * freq(j) * std::sin(freq(j) * t + phase(j));
    }
  }
};

struct DerivativeErrors {
  double base_v_interior = 0, base_w_interior = 0, joint_v_interior = 0;
  double base_a_interior = 0, base_alpha_interior = 0, joint_a_interior = 0;
  double v_ends = 0, a_ends = 0;
};

// Reads an analytic motion sampled at @p rate_hz from a CSV written at full precision and
// returns the largest errors of the estimated v and v̇ (interior: full windows; ends: the
// first and last window/2 frames, fitted one-sidedly).
DerivativeErrors differentiateAnalytic(double rate_hz, double duration_s, int window,
                                       bool varying_rate = false) {
  const ModelInfo& info = humanInfo();
  AnalyticMotion motion;
  motion.varying_rate = varying_rate;
  std::vector<ReferenceFrame> frames;
  const int n = static_cast<int>(std::lround(duration_s * rate_hz)) + 1;
  for (int k = 0; k < n; ++k) frames.push_back(motion.frame(info, 0.25 + k / rate_hz));
  const std::string path = tempPath("analytic_" + std::to_string(static_cast<int>(rate_hz)) +
                                    (varying_rate ? "_varying" : "") + ".csv");
  writeFile(path, joinLines(csvLines(info, frames, false, false)));
  ReferenceReadOptions options;
  options.smoothing_window = window;
  const ReferenceMotion m = readReferenceMotion(path, info, options);
  EXPECT_EQ(static_cast<int>(m.frames.size()), n);
  DerivativeErrors e;
  Eigen::VectorXd v, a;
  for (int k = 0; k < n; ++k) {
    const ReferenceFrame& f = m.frames[static_cast<std::size_t>(k)];
    motion.derivatives(info, f.time_s, v, a);
    const Eigen::VectorXd dv = (f.v - v).cwiseAbs(), da = (f.vdot - a).cwiseAbs();
    if (k < window / 2 || k >= n - window / 2) {
      e.v_ends = std::max(e.v_ends, dv.maxCoeff());
      e.a_ends = std::max(e.a_ends, da.maxCoeff());
      continue;
    }
    e.base_v_interior = std::max(e.base_v_interior, dv.head<3>().maxCoeff());
    e.base_w_interior = std::max(e.base_w_interior, dv.segment<3>(3).maxCoeff());
    e.joint_v_interior = std::max(e.joint_v_interior, dv.tail(info.nj).maxCoeff());
    e.base_a_interior = std::max(e.base_a_interior, da.head<3>().maxCoeff());
    e.base_alpha_interior = std::max(e.base_alpha_interior, da.segment<3>(3).maxCoeff());
    e.joint_a_interior = std::max(e.joint_a_interior, da.tail(info.nj).maxCoeff());
  }
  return e;
}

void printErrors(const char* label, const DerivativeErrors& e) {
  std::printf(
      "%s: interior max |error|: v_B %.2e m/s, w_B %.2e rad/s, joints %.2e rad/s; "
      "dv_B/dt %.2e m/s2, dw_B/dt %.2e rad/s2, joint acc %.2e rad/s2; "
      "first/last 3 frames: v %.2e, acc %.2e\n",
      label, e.base_v_interior, e.base_w_interior, e.joint_v_interior, e.base_a_interior,
      e.base_alpha_interior, e.joint_a_interior, e.v_ends, e.a_ends);
}

// Truncation error of the symmetric 7-point quadratic fit: (7/6) h² f‴ for the first
// derivative, (67/84) h² f⁗ for the second.
double velocityBound(double h, double f3) { return 7.0 / 6.0 * h * h * f3; }
double accelerationBound(double h, double f4) { return 67.0 / 84.0 * h * h * f4; }

TEST(ReferenceDerivatives, HelixAndSinusoidsAt1kHzWindow7) {
  const DerivativeErrors e = differentiateAnalytic(1000.0, 2.0, 7);
  printErrors("1 kHz, window 7", e);
  const AnalyticMotion m;
  const double h = 1e-3;
  EXPECT_LT(e.base_v_interior, 1e-6);
  EXPECT_LT(e.base_w_interior, 1e-6);
  EXPECT_LT(e.joint_v_interior, 1.01 * velocityBound(h, m.maxAw3(32)));
  EXPECT_LT(e.base_a_interior, 1e-6);
  EXPECT_LT(e.base_alpha_interior, 1e-6);
  EXPECT_LT(e.joint_a_interior, 1.01 * accelerationBound(h, m.maxAw4(32)));
  EXPECT_LT(e.v_ends, 3e-5);  // one-sided fits at the ends
  EXPECT_LT(e.a_ends, 3e-2);
}

TEST(ReferenceDerivatives, VaryingBodyRateAt1kHzWindow7) {
  const DerivativeErrors e = differentiateAnalytic(1000.0, 2.0, 7, true);
  printErrors("1 kHz, window 7, varying body rate", e);
  EXPECT_LT(e.base_v_interior, 2e-6);
  EXPECT_LT(e.base_w_interior, 2e-6);
  EXPECT_LT(e.base_a_interior, 2e-5);
  EXPECT_LT(e.base_alpha_interior, 2e-5);
  EXPECT_LT(e.v_ends, 3e-5);
  EXPECT_LT(e.a_ends, 3e-2);
}

TEST(ReferenceDerivatives, HelixAndSinusoidsAt120HzWindow7) {
  const DerivativeErrors e = differentiateAnalytic(120.0, 4.0, 7);
  printErrors("120 Hz, window 7", e);
  const AnalyticMotion m;
  const double h = 1.0 / 120.0;
  EXPECT_LT(e.base_v_interior, 5e-5);
  EXPECT_LT(e.base_w_interior, 1e-9);
  EXPECT_LT(e.joint_v_interior, 1.01 * velocityBound(h, m.maxAw3(32)));
  EXPECT_LT(e.base_a_interior, 5e-5);
  EXPECT_LT(e.base_alpha_interior, 1e-9);
  EXPECT_LT(e.joint_a_interior, 1.01 * accelerationBound(h, m.maxAw4(32)));
  EXPECT_LT(e.v_ends, 2e-3);
  EXPECT_LT(e.a_ends, 0.2);
}

TEST(ReferenceDerivatives, VaryingBodyRateAt120HzWindow7) {
  const DerivativeErrors e = differentiateAnalytic(120.0, 4.0, 7, true);
  printErrors("120 Hz, window 7, varying body rate", e);
  EXPECT_LT(e.base_v_interior, 1e-4);
  EXPECT_LT(e.base_w_interior, 1e-4);
  EXPECT_LT(e.base_a_interior, 1e-3);
  EXPECT_LT(e.base_alpha_interior, 1e-3);
}

// On a uniform grid an interior quadratic Savitzky–Golay fit is a linear filter with a
// known response to a sinusoid A sin(w t + φ):
//   v̂ = A w cos(θ) Σ_j j sin(j w h) / (w h Σ_j j²),
//   â = 2 A sin(θ) Σ_j (j² − m̄) cos(j w h) / (h² Σ_j (j² − m̄)²),  m̄ = mean of j²,
// (θ = w t_k + φ, j over the window). The estimate must equal it, not just be close to
// the true derivative.
TEST(ReferenceDerivatives, InteriorFramesMatchTheSavitzkyGolayResponse) {
  const double h = 1.0 / 120.0;
  const double A[2] = {0.7, 0.3}, w[2] = {3.0, 11.0}, phi[2] = {0.2, -1.0};
  for (int window : {5, 7, 11}) {
    const int half = window / 2;
    std::vector<ReferenceFrame> frames;
    for (int k = 0; k < 60; ++k) {
      ReferenceFrame f(2, 2);
      f.time_s = k * h;
      for (int i = 0; i < 2; ++i) f.q[i] = A[i] * std::sin(w[i] * f.time_s + phi[i]);
      frames.push_back(f);
    }
    estimateDerivatives(frames, false, window, true, true);
    double s2 = 0, mean = 0, d = 0;
    for (int j = -half; j <= half; ++j) s2 += j * j;
    mean = s2 / window;
    for (int j = -half; j <= half; ++j) d += (j * j - mean) * (j * j - mean);
    for (int k = half; k < 60 - half; ++k) {
      for (int i = 0; i < 2; ++i) {
        const double theta = w[i] * k * h + phi[i];
        double odd = 0, even = 0;
        for (int j = -half; j <= half; ++j) {
          odd += j * std::sin(j * w[i] * h);
          even += (j * j - mean) * std::cos(j * w[i] * h);
        }
        const double v = A[i] * std::cos(theta) * odd / (h * s2);
        const double a = 2.0 * A[i] * std::sin(theta) * even / (h * h * d);
        const ReferenceFrame& f = frames[static_cast<std::size_t>(k)];
        EXPECT_NEAR(f.v[i], v, 1e-11) << "window " << window << " frame " << k;
        EXPECT_NEAR(f.vdot[i], a, 1e-8) << "window " << window << " frame " << k;
      }
    }
  }
}

TEST(ReferenceDerivatives, ErrorShrinksQuadraticallyWithTheStep) {
  const DerivativeErrors coarse = differentiateAnalytic(250.0, 2.0, 7);
  const DerivativeErrors fine = differentiateAnalytic(500.0, 2.0, 7);
  const double ratio = coarse.joint_v_interior / fine.joint_v_interior;
  EXPECT_GT(ratio, 3.5);
  EXPECT_LT(ratio, 4.5);
  const double base_ratio = coarse.base_v_interior / fine.base_v_interior;
  EXPECT_GT(base_ratio, 3.5);
  EXPECT_LT(base_ratio, 4.5);
}

// Non-uniform time stamps: a quadratic joint trajectory and a base moving with a constant
// body twist (ξ_j = V (t_j − t_k) exactly) are reproduced exactly, ends included.
TEST(ReferenceDerivatives, NonUniformTimeIsExactForQuadraticsAndConstantTwists) {
  const ModelInfo& info = humanInfo();
  Vector6d V;
  V << 0.4, -0.3, 0.2, 0.5, 0.7, -0.6;
  Eigen::Isometry3d X0 = Eigen::Isometry3d::Identity();
  X0.linear() = expSO3(Eigen::Vector3d(0.2, -0.5, 0.3));
  X0.translation() = Eigen::Vector3d(1.0, 2.0, 0.9);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.4, 0.4);
  const double h = 1.0 / 120.0;
  std::vector<ReferenceFrame> frames;
  for (int k = 0; k < 40; ++k) {
    ReferenceFrame f(info.nq, info.nv);
    f.time_s = k * h + jitter(rng) * h;
    setBasePoseInConfiguration(X0 * expSE3(V * f.time_s), f.q);
    for (int j = 0; j < info.nj; ++j)
      f.q[info.configurationIndex(j)] = 0.1 * j - 0.5 * f.time_s + (0.3 - 0.02 * j) * f.time_s * f.time_s;
    frames.push_back(f);
  }
  const std::string path = tempPath("nonuniform.csv");
  writeFile(path, joinLines(csvLines(info, frames, false, false)));
  const ReferenceMotion m = readReferenceMotion(path, info);
  double v_err = 0, a_err = 0;
  for (const ReferenceFrame& f : m.frames) {
    v_err = std::max(v_err, (f.v.head<6>() - V).cwiseAbs().maxCoeff());
    a_err = std::max(a_err, f.vdot.head<6>().cwiseAbs().maxCoeff());
    for (int j = 0; j < info.nj; ++j) {
      const double c2 = 0.3 - 0.02 * j;
      v_err = std::max(v_err, std::abs(f.v[info.velocityIndex(j)] - (-0.5 + 2 * c2 * f.time_s)));
      a_err = std::max(a_err, std::abs(f.vdot[info.velocityIndex(j)] - 2 * c2));
    }
  }
  EXPECT_LT(v_err, 1e-10);
  EXPECT_LT(a_err, 1e-7);
}

TEST(ReferenceDerivatives, ShortMotionsShrinkTheWindow) {
  // Two frames: the line through them, zero acceleration. Three frames: the parabola.
  std::vector<ReferenceFrame> two(2, ReferenceFrame(2, 2)), three(3, ReferenceFrame(2, 2));
  two[0].time_s = 0.0, two[1].time_s = 0.5;
  two[0].q << 1.0, 2.0;
  two[1].q << 2.0, 1.0;
  estimateDerivatives(two, false, 7, true, true);
  for (const auto& f : two) {
    EXPECT_NEAR(f.v[0], 2.0, 1e-14);
    EXPECT_NEAR(f.v[1], -2.0, 1e-14);
    EXPECT_EQ(f.vdot, Eigen::Vector2d::Zero());
  }
  const double t[3] = {0.0, 0.1, 0.4};
  for (int k = 0; k < 3; ++k) {
    three[static_cast<std::size_t>(k)].time_s = t[k];
    three[static_cast<std::size_t>(k)].q << 3.0 * t[k] * t[k], -t[k];
  }
  estimateDerivatives(three, false, 5, true, true);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(three[static_cast<std::size_t>(k)].v[0], 6.0 * t[k], 1e-12);
    EXPECT_NEAR(three[static_cast<std::size_t>(k)].v[1], -1.0, 1e-12);
    EXPECT_NEAR(three[static_cast<std::size_t>(k)].vdot[0], 6.0, 1e-10);
  }
}

TEST(ReferenceDerivatives, GivenVelocitiesAreKeptAndAccelerationsEstimated) {
  const ModelInfo info = fixedInfo();
  std::string text = "time,hinge,slide,hinge.v,slide.v\n";
  for (int k = 0; k < 10; ++k) {
    const double t = 0.1 * k;
    text += num(t) + "," + num(t * t) + "," + num(-2 * t * t) + ",7," + num(-8.0 + k) + "\n";
  }
  const std::string path = tempPath("v_only.csv");
  writeFile(path, text);
  const ReferenceMotion m = readReferenceMotion(path, info);
  EXPECT_TRUE(m.had_velocities);
  EXPECT_FALSE(m.had_accelerations);
  for (int k = 0; k < 10; ++k) {
    const ReferenceFrame& f = m.frames[static_cast<std::size_t>(k)];
    EXPECT_EQ(f.v[0], 7.0);  // from the file, not the fit
    EXPECT_EQ(f.v[1], -8.0 + k);
    EXPECT_NEAR(f.vdot[0], 2.0, 1e-9);  // second derivative of the position fit
    EXPECT_NEAR(f.vdot[1], -4.0, 1e-9);
  }
}

TEST(ReferenceDerivatives, SmoothingWindowSmoothsNoise) {
  // Noise on a line: a wider window gives a derivative closer to the slope.
  const ModelInfo info = fixedInfo();
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 1e-3);
  std::vector<ReferenceFrame> frames;
  for (int k = 0; k < 500; ++k) {
    ReferenceFrame f(2, 2);
    f.time_s = k * 0.01;
    f.q << 0.5 * f.time_s + noise(rng), noise(rng);
    frames.push_back(f);
  }
  auto rms = [&](int window) {
    auto copy = frames;
    estimateDerivatives(copy, false, window, true, false);
    double s = 0;
    for (std::size_t k = 20; k + 20 < copy.size(); ++k) s += std::pow(copy[k].v[0] - 0.5, 2);
    return std::sqrt(s / static_cast<double>(copy.size() - 40));
  };
  const double r3 = rms(3), r7 = rms(7), r21 = rms(21);
  // White noise σ: the slope of a least-squares fit has σ / (h sqrt(Σ j²)).
  EXPECT_NEAR(r3, 1e-3 / (0.01 * std::sqrt(2.0)), 0.25 * 1e-3 / (0.01 * std::sqrt(2.0)));
  EXPECT_NEAR(r7, 1e-3 / (0.01 * std::sqrt(28.0)), 0.25 * 1e-3 / (0.01 * std::sqrt(28.0)));
  EXPECT_LT(r21, r7);
}

}  // namespace
}  // namespace dynfilter::io
