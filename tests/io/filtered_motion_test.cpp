// Filtered motion writer: the two files' headers and values read by an independent parser,
// atomic commit, and the bit-exact round trip through the reference reader.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/io/filtered_motion.hpp"
#include "dynfilter/io/reference_motion.hpp"
#include "io/io_test_support.hpp"

namespace dynfilter::io {
namespace {

using testing_io::expectInputError;
using testing_io::fileExists;
using testing_io::fixedInfo;
using testing_io::humanInfo;
using testing_io::readWholeFile;
using testing_io::tempPath;
using testing_io::writeFile;

// ---------------------------------------------------------------------------------------
// A tiny CSV reader written for this test: LF lines, comma separated, double-quoted fields
// with "" escapes, nothing else. What a pandas-style consumer relies on.
struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  std::size_t col(const std::string& name) const {
    for (std::size_t i = 0; i < header.size(); ++i)
      if (header[i] == name) return i;
    ADD_FAILURE() << "no column " << name;
    return 0;
  }
  double num(std::size_t row, const std::string& name) const {
    const std::string& s = rows.at(row).at(col(name));
    char* end = nullptr;
    const double x = std::strtod(s.c_str(), &end);
    EXPECT_EQ(*end, '\0') << "not a number: " << s;
    return x;
  }
  const std::string& text(std::size_t row, const std::string& name) const {
    return rows.at(row).at(col(name));
  }
};

std::vector<std::string> splitLine(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        out.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        out.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  return out;
}

Table readTable(const std::string& path) {
  const std::string text = readWholeFile(path);
  Table t;
  std::size_t start = 0;
  EXPECT_FALSE(text.empty());
  EXPECT_EQ(text.back(), '\n') << "last line not terminated";
  while (start < text.size()) {
    const std::size_t end = text.find('\n', start);
    const std::string line = text.substr(start, end - start);
    EXPECT_EQ(line.find('\r'), std::string::npos);
    if (t.header.empty())
      t.header = splitLine(line);
    else
      t.rows.push_back(splitLine(line));
    EXPECT_EQ(splitLine(line).size(), t.header.size()) << line;
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return t;
}

// ---------------------------------------------------------------------------------------

// A filter output with distinct values everywhere; the quaternion is unit up to rounding.
FilterOutput sampleOutput(const ModelInfo& info, std::mt19937& rng, double time_s, int contacts) {
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  FilterOutput out(info.nq, info.nv, info.nj, 8);
  out.time_s = time_s;
  out.status = kStatusImpact | kStatusContactOverflow;
  for (int i = 0; i < info.nq; ++i) out.q[i] = u(rng);
  if (info.floating_base)
    out.q.segment<4>(3) = Eigen::Vector4d(u(rng), u(rng), u(rng), u(rng)).normalized();
  for (int i = 0; i < info.nv; ++i) {
    out.v[i] = u(rng);
    out.vdot[i] = u(rng) * 1e3;
    out.tracking_error[i] = u(rng) * 1e-3;
  }
  for (int i = 0; i < info.nj; ++i) out.tau_J[i] = u(rng) * 100;
  for (int i = 0; i < 6; ++i) out.task_error[i] = u(rng) * 1e-2;
  out.eq12_residual = 1.5e-9;
  out.base_residual_n = 3.25e-7;
  out.max_penetration_m = 1e-4 / 3.0;
  out.solve_time_s = 7.5e-5;
  out.tick_time_s = 1.25e-4;
  out.num_contacts = contacts;
  for (int c = 0; c < contacts; ++c) {
    ContactOutput& k = out.contacts[static_cast<std::size_t>(c)];
    k.body = c % static_cast<int>(info.body_names.size());
    k.object = c - 1;
    k.kind = c == 0 ? ContactKind::kFace : (c == 1 ? ContactKind::kEdge : ContactKind::kPoint);
    k.p_WC = Eigen::Vector3d(u(rng), u(rng), u(rng));
    k.n_W = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    for (int i = 0; i < 6; ++i) k.wrench_W[i] = u(rng) * 300;
    k.normal_force_n = u(rng) * 500;
    k.cop_A = Eigen::Vector2d(u(rng) * 0.1, u(rng) * 0.05);
    k.pivot = c == 0 ? -1 : (c == 1 ? 1 : 0);
    if (c == 2) k.slide_W = Eigen::Vector3d(u(rng), u(rng), 0.0).normalized();
  }
  return out;
}

std::vector<std::string> expectedMainHeader(const ModelInfo& info) {
  std::vector<std::string> h{"time", "status"};
  auto add = [&](std::initializer_list<const char*> names) {
    for (const char* n : names) h.emplace_back(n);
  };
  if (info.floating_base) add({"base_x", "base_y", "base_z", "base_qw", "base_qx", "base_qy", "base_qz"});
  for (const auto& j : info.joint_names) h.push_back(j);
  if (info.floating_base) add({"base_vx", "base_vy", "base_vz", "base_wx", "base_wy", "base_wz"});
  for (const auto& j : info.joint_names) h.push_back(j + ".v");
  if (info.floating_base)
    add({"base_ax", "base_ay", "base_az", "base_alphax", "base_alphay", "base_alphaz"});
  for (const auto& j : info.joint_names) h.push_back(j + ".a");
  for (const auto& j : info.joint_names) h.push_back(j + ".tau");
  if (info.floating_base)
    add({"err.base_x", "err.base_y", "err.base_z", "err.base_rx", "err.base_ry", "err.base_rz"});
  for (const auto& j : info.joint_names) h.push_back("err." + j);
  add({"task_err.x", "task_err.y", "task_err.z", "task_err.rx", "task_err.ry", "task_err.rz",
       "eq12_residual", "base_residual_n", "max_penetration_m", "num_contacts", "solve_time_s",
       "tick_time_s"});
  return h;
}

TEST(FilteredMotionWriter, MainFileHeaderAndValuesReadByAnIndependentParser) {
  const ModelInfo& info = humanInfo();
  const std::string path = tempPath("filtered.csv");
  std::mt19937 rng(11);
  std::vector<FilterOutput> outs;
  for (int k = 0; k < 3; ++k) outs.push_back(sampleOutput(info, rng, 0.001 * (k + 1), k));
  {
    FilteredMotionWriter writer(path, info);
    for (const auto& o : outs) writer.append(o);
    EXPECT_EQ(writer.rows(), 3u);
    writer.commit();
  }
  const Table t = readTable(path);
  EXPECT_EQ(t.header, expectedMainHeader(info));
  EXPECT_EQ(t.header.size(), 2u + 39 + 38 + 38 + 32 + 38 + 6 + 6);
  ASSERT_EQ(t.rows.size(), 3u);
  const int knee = info.findJoint("r_knee");
  for (std::size_t k = 0; k < 3; ++k) {
    const FilterOutput& o = outs[k];
    EXPECT_EQ(t.num(k, "time"), o.time_s);
    EXPECT_EQ(t.text(k, "status"), "33");
    EXPECT_EQ(t.num(k, "base_x"), o.q[0]);
    EXPECT_EQ(t.num(k, "base_qw"), o.q[3]);
    EXPECT_EQ(t.num(k, "base_qz"), o.q[6]);
    EXPECT_EQ(t.num(k, "r_knee"), o.q[info.configurationIndex(knee)]);
    EXPECT_EQ(t.num(k, "base_vx"), o.v[0]);
    EXPECT_EQ(t.num(k, "base_wz"), o.v[5]);
    EXPECT_EQ(t.num(k, "r_knee.v"), o.v[info.velocityIndex(knee)]);
    EXPECT_EQ(t.num(k, "base_ay"), o.vdot[1]);
    EXPECT_EQ(t.num(k, "base_alphax"), o.vdot[3]);
    EXPECT_EQ(t.num(k, "r_knee.a"), o.vdot[info.velocityIndex(knee)]);
    EXPECT_EQ(t.num(k, "r_knee.tau"), o.tau_J[knee]);
    EXPECT_EQ(t.num(k, "err.base_z"), o.tracking_error[2]);
    EXPECT_EQ(t.num(k, "err.base_rx"), o.tracking_error[3]);
    EXPECT_EQ(t.num(k, "err.r_knee"), o.tracking_error[info.velocityIndex(knee)]);
    EXPECT_EQ(t.num(k, "task_err.y"), o.task_error[1]);
    EXPECT_EQ(t.num(k, "task_err.rz"), o.task_error[5]);
    EXPECT_EQ(t.num(k, "eq12_residual"), 1.5e-9);
    EXPECT_EQ(t.num(k, "base_residual_n"), 3.25e-7);
    EXPECT_EQ(t.num(k, "max_penetration_m"), 1e-4 / 3.0);
    EXPECT_EQ(t.text(k, "num_contacts"), std::to_string(k));
    EXPECT_EQ(t.num(k, "solve_time_s"), 7.5e-5);
    EXPECT_EQ(t.num(k, "tick_time_s"), 1.25e-4);
    // Every field of the row, in order.
    std::size_t c = 2;
    for (int i = 0; i < info.nq; ++i) EXPECT_EQ(std::strtod(t.rows[k][c++].c_str(), nullptr), o.q[i]);
    for (int i = 0; i < info.nv; ++i) EXPECT_EQ(std::strtod(t.rows[k][c++].c_str(), nullptr), o.v[i]);
    for (int i = 0; i < info.nv; ++i) EXPECT_EQ(std::strtod(t.rows[k][c++].c_str(), nullptr), o.vdot[i]);
    for (int i = 0; i < info.nj; ++i) EXPECT_EQ(std::strtod(t.rows[k][c++].c_str(), nullptr), o.tau_J[i]);
    for (int i = 0; i < info.nv; ++i)
      EXPECT_EQ(std::strtod(t.rows[k][c++].c_str(), nullptr), o.tracking_error[i]);
  }
}

TEST(FilteredMotionWriter, ContactsFileHasOneRowPerValidContact) {
  const ModelInfo& info = humanInfo();
  const std::string path = tempPath("with_contacts.csv");
  std::mt19937 rng(5);
  std::vector<FilterOutput> outs{sampleOutput(info, rng, 0.5, 2), sampleOutput(info, rng, 0.501, 0),
                                 sampleOutput(info, rng, 0.502, 3)};
  // Invalid entries beyond num_contacts must not appear.
  outs[1].contacts[0].body = 9999;
  {
    FilteredMotionWriter writer(path, info);
    for (const auto& o : outs) writer.append(o);
    writer.commit();
  }
  const std::string contacts = path.substr(0, path.size() - 4) + ".contacts.csv";
  EXPECT_EQ(FilteredMotionWriter::contactsPathFor(path), contacts);
  const Table t = readTable(contacts);
  EXPECT_EQ(t.header, (std::vector<std::string>{"time", "index", "body", "object", "kind", "px", "py",
                                                "pz", "nx", "ny", "nz", "fx", "fy", "fz", "mx", "my",
                                                "mz", "normal_force_n", "cop_x", "cop_y",
                                                "support_x_min", "support_x_max",
                                                "support_y_min", "support_y_max", "pivot",
                                                "slide_x", "slide_y", "slide_z"}));
  ASSERT_EQ(t.rows.size(), 5u);
  const std::pair<std::size_t, int> which[5] = {{0, 0}, {0, 1}, {2, 0}, {2, 1}, {2, 2}};
  const char* kinds[3] = {"face", "edge", "point"};
  for (std::size_t r = 0; r < 5; ++r) {
    const FilterOutput& o = outs[which[r].first];
    const ContactOutput& c = o.contacts[static_cast<std::size_t>(which[r].second)];
    EXPECT_EQ(t.num(r, "time"), o.time_s);
    EXPECT_EQ(t.text(r, "index"), std::to_string(which[r].second));
    EXPECT_EQ(t.text(r, "body"), info.body_names[static_cast<std::size_t>(c.body)]);
    EXPECT_EQ(t.text(r, "object"), std::to_string(c.object));
    EXPECT_EQ(t.text(r, "kind"), kinds[which[r].second]);
    EXPECT_EQ(t.num(r, "px"), c.p_WC.x());
    EXPECT_EQ(t.num(r, "pz"), c.p_WC.z());
    EXPECT_EQ(t.num(r, "ny"), c.n_W.y());
    EXPECT_EQ(t.num(r, "fx"), c.wrench_W[0]);
    EXPECT_EQ(t.num(r, "fz"), c.wrench_W[2]);
    EXPECT_EQ(t.num(r, "mx"), c.wrench_W[3]);
    EXPECT_EQ(t.num(r, "mz"), c.wrench_W[5]);
    EXPECT_EQ(t.num(r, "normal_force_n"), c.normal_force_n);
    EXPECT_EQ(t.num(r, "cop_x"), c.cop_A.x());
    EXPECT_EQ(t.num(r, "cop_y"), c.cop_A.y());
    EXPECT_EQ(t.text(r, "pivot"), std::to_string(c.pivot));
    EXPECT_EQ(t.num(r, "slide_x"), c.slide_W.x());
    EXPECT_EQ(t.num(r, "slide_y"), c.slide_W.y());
    EXPECT_EQ(t.num(r, "slide_z"), c.slide_W.z());
  }
  EXPECT_EQ(t.text(0, "object"), "-1");  // the ground
}

TEST(FilteredMotionWriter, BodyNamesAreGivenAndQuotedWhenNeeded) {
  const ModelInfo info = fixedInfo();
  const std::string path = tempPath("names.csv");
  std::mt19937 rng(2);
  FilterOutput o = sampleOutput(info, rng, 1.0, 2);
  o.contacts[0].body = 0;
  o.contacts[1].body = 1;
  {
    FilteredMotionWriter writer(path, info, {"left, \"foot\"", "right_foot"});
    writer.append(o);
    writer.commit();
  }
  const std::string raw = readWholeFile(FilteredMotionWriter::contactsPathFor(path));
  EXPECT_NE(raw.find(",\"left, \"\"foot\"\"\","), std::string::npos) << raw;
  const Table t = readTable(FilteredMotionWriter::contactsPathFor(path));
  ASSERT_EQ(t.rows.size(), 2u);
  EXPECT_EQ(t.text(0, "body"), "left, \"foot\"");
  EXPECT_EQ(t.text(1, "body"), "right_foot");
}

TEST(FilteredMotionWriter, FixedBaseHasNoBaseColumns) {
  const ModelInfo info = fixedInfo();
  EXPECT_EQ(FilteredMotionWriter::mainColumns(info),
            (std::vector<std::string>{"time", "status", "hinge", "slide", "hinge.v", "slide.v",
                                      "hinge.a", "slide.a", "hinge.tau", "slide.tau", "err.hinge",
                                      "err.slide", "task_err.x", "task_err.y", "task_err.z",
                                      "task_err.rx", "task_err.ry", "task_err.rz", "eq12_residual",
                                      "base_residual_n", "max_penetration_m", "num_contacts",
                                      "solve_time_s", "tick_time_s"}));
  EXPECT_EQ(FilteredMotionWriter::mainColumns(humanInfo()), expectedMainHeader(humanInfo()));
}

// ---------------------------------------------------------------------------------------
// Atomicity

std::vector<std::string> temporariesOf(const std::string& path) {
  std::vector<std::string> found;
  const std::filesystem::path p(path);
  for (const auto& entry : std::filesystem::directory_iterator(p.parent_path())) {
    const std::string name = entry.path().filename().string();
    for (const std::string& stem : {p.filename().string(), p.stem().string() + ".contacts.csv"})
      if (name.rfind(stem + ".tmp", 0) == 0) found.push_back(name);
  }
  return found;
}

TEST(FilteredMotionWriter, NothingAppearsBeforeCommitAndTemporariesGoAway) {
  const ModelInfo& info = humanInfo();
  const std::string path = tempPath("atomic.csv");
  const std::string contacts = FilteredMotionWriter::contactsPathFor(path);
  std::remove(contacts.c_str());
  std::mt19937 rng(1);
  {
    FilteredMotionWriter writer(path, info);
    writer.append(sampleOutput(info, rng, 0.0, 1));
    EXPECT_FALSE(fileExists(path));
    EXPECT_FALSE(fileExists(contacts));
    EXPECT_EQ(temporariesOf(path).size(), 2u);
    writer.commit();
    EXPECT_TRUE(fileExists(path));
    EXPECT_TRUE(fileExists(contacts));
    EXPECT_TRUE(temporariesOf(path).empty());
    EXPECT_THROW(writer.append(sampleOutput(info, rng, 0.1, 0)), std::logic_error);
    EXPECT_THROW(writer.commit(), std::logic_error);
  }
  EXPECT_EQ(readTable(path).rows.size(), 1u);
}

TEST(FilteredMotionWriter, DestructorWithoutCommitLeavesOldFilesUntouched) {
  const ModelInfo& info = humanInfo();
  const std::string path = tempPath("abandoned.csv");
  const std::string contacts = FilteredMotionWriter::contactsPathFor(path);
  writeFile(path, "previous run\n");
  std::remove(contacts.c_str());
  std::mt19937 rng(1);
  {
    FilteredMotionWriter writer(path, info);
    for (int k = 0; k < 100; ++k) writer.append(sampleOutput(info, rng, 0.001 * k, 2));
    EXPECT_EQ(temporariesOf(path).size(), 2u);
  }
  EXPECT_EQ(readWholeFile(path), "previous run\n");
  EXPECT_FALSE(fileExists(contacts));
  EXPECT_TRUE(temporariesOf(path).empty());
}

TEST(FilteredMotionWriter, BadOutputIsRejectedBeforeWriting) {
  const ModelInfo& info = humanInfo();
  const std::string path = tempPath("bad.csv");
  std::mt19937 rng(1);
  FilteredMotionWriter writer(path, info);
  FilterOutput o = sampleOutput(info, rng, 0.0, 1);
  o.tau_J.resize(3);
  EXPECT_THROW(writer.append(o), std::invalid_argument);
  o = sampleOutput(info, rng, 0.0, 1);
  o.contacts[0].body = static_cast<int>(info.body_names.size());
  EXPECT_THROW(writer.append(o), std::invalid_argument);
  o = sampleOutput(info, rng, 0.0, 1);
  o.num_contacts = 9;
  EXPECT_THROW(writer.append(o), std::invalid_argument);
  EXPECT_EQ(writer.rows(), 0u);
  writer.commit();
  EXPECT_TRUE(readTable(path).rows.empty());
}

TEST(FilteredMotionWriter, UncreatableFileIsAnInputError) {
  const std::string path = tempPath("no_such_dir/out.csv");
  expectInputError([&] { FilteredMotionWriter writer(path, humanInfo()); }, path, 0, 0,
                   "cannot create temporary file: No such file or directory");
}

TEST(FilteredMotionWriter, ContactsPathIsNextToTheMainFile) {
  EXPECT_EQ(FilteredMotionWriter::contactsPathFor("out/run1.csv"), "out/run1.contacts.csv");
  EXPECT_EQ(FilteredMotionWriter::contactsPathFor("run1"), "run1.contacts.csv");
  EXPECT_EQ(FilteredMotionWriter::contactsPathFor("/a/b.c/run.v2.csv"), "/a/b.c/run.v2.contacts.csv");
}

// ---------------------------------------------------------------------------------------
// Round trip through the reference reader

void expectRoundTrip(const ModelInfo& info, const std::string& path) {
  std::mt19937 rng(99);
  std::vector<FilterOutput> outs;
  for (int k = 0; k < 50; ++k) outs.push_back(sampleOutput(info, rng, 0.1 + 0.001 * k, k % 3));
  {
    FilteredMotionWriter writer(path, info);
    for (const auto& o : outs) writer.append(o);
    writer.commit();
  }
  ReferenceReadOptions options;
  expectInputError([&] { readReferenceMotion(path, info, options); }, path, 1, 2,
                   "unknown column \"status\"");
  options.allow_extra_columns = true;
  const ReferenceMotion m = readReferenceMotion(path, info, options);
  EXPECT_TRUE(m.had_velocities);
  EXPECT_TRUE(m.had_accelerations);
  ASSERT_EQ(m.frames.size(), outs.size());
  for (std::size_t k = 0; k < outs.size(); ++k) {
    EXPECT_EQ(m.frames[k].time_s, outs[k].time_s);
    for (int i = 0; i < info.nq; ++i) EXPECT_EQ(m.frames[k].q[i], outs[k].q[i]) << k << " q " << i;
    for (int i = 0; i < info.nv; ++i) {
      EXPECT_EQ(m.frames[k].v[i], outs[k].v[i]) << k << " v " << i;
      EXPECT_EQ(m.frames[k].vdot[i], outs[k].vdot[i]) << k << " vdot " << i;
    }
  }
}

TEST(FilteredMotionWriter, RoundTripThroughTheReferenceReaderIsBitExact) {
  expectRoundTrip(humanInfo(), tempPath("roundtrip.csv"));
}

TEST(FilteredMotionWriter, RoundTripIsBitExactForAFixedBase) {
  expectRoundTrip(fixedInfo(), tempPath("roundtrip_fixed.csv"));
}

TEST(FilteredMotionWriter, ExtremeValuesRoundTripBitExactly) {
  const ModelInfo info = fixedInfo();
  const std::string path = tempPath("extreme.csv");
  const double values[] = {5e-324, -2.2250738585072014e-308, 1.7976931348623157e308, 0.1,
                           -0.0, 1.0 / 3.0, 123456789.123456789, 1e-5};
  std::vector<FilterOutput> outs;
  double t = 0.0;
  for (double x : values) {
    FilterOutput o(2, 2, 2, 0);
    o.time_s = t;
    t = std::nextafter(t, 1.0);  // consecutive doubles
    o.q << x, -x;
    o.v << x / 2, x;
    o.vdot << -x, x;
    outs.push_back(o);
  }
  {
    FilteredMotionWriter writer(path, info);
    for (const auto& o : outs) writer.append(o);
    writer.commit();
  }
  ReferenceReadOptions options;
  options.allow_extra_columns = true;
  const ReferenceMotion m = readReferenceMotion(path, info, options);
  ASSERT_EQ(m.frames.size(), outs.size());
  for (std::size_t k = 0; k < outs.size(); ++k) {
    EXPECT_EQ(m.frames[k].time_s, outs[k].time_s);
    EXPECT_EQ(std::signbit(m.frames[k].q[0]), std::signbit(outs[k].q[0]));
    EXPECT_TRUE((m.frames[k].q.array() == outs[k].q.array()).all()) << k;
    EXPECT_TRUE((m.frames[k].v.array() == outs[k].v.array()).all()) << k;
    EXPECT_TRUE((m.frames[k].vdot.array() == outs[k].vdot.array()).all()) << k;
  }
}

}  // namespace
}  // namespace dynfilter::io

#include "dynfilter/io/filtered_motion_reader.hpp"

namespace dynfilter::io {
namespace {

TEST(FilteredMotionReader, ReadsBackStatesTorquesAndContactWrenchesExactly) {
  const ModelInfo& info = humanInfo();
  std::mt19937 rng(77);
  const std::string path = tempPath("read_back.csv");
  std::vector<FilterOutput> outs;
  for (int k = 0; k < 4; ++k) outs.push_back(sampleOutput(info, rng, 0.25 * k, k % 3));
  {
    FilteredMotionWriter writer(path, info);
    for (const auto& o : outs) writer.append(o);
    writer.commit();
  }
  const auto frames = readFilteredMotion(path, info);
  ASSERT_EQ(frames.size(), outs.size());
  for (std::size_t k = 0; k < outs.size(); ++k) {
    EXPECT_EQ(frames[k].state.time_s, outs[k].time_s);
    EXPECT_EQ(frames[k].state.v, outs[k].v);
    EXPECT_EQ(frames[k].state.vdot, outs[k].vdot);
    EXPECT_EQ(frames[k].tau_J, outs[k].tau_J);
    ASSERT_EQ(static_cast<int>(frames[k].contacts.size()), outs[k].num_contacts);
    for (int c = 0; c < outs[k].num_contacts; ++c) {
      const auto& written = outs[k].contacts[static_cast<std::size_t>(c)];
      const auto& read = frames[k].contacts[static_cast<std::size_t>(c)];
      EXPECT_EQ(read.body, written.body);
      EXPECT_EQ(read.p_WC, written.p_WC);
      EXPECT_EQ(read.wrench_W, written.wrench_W);
    }
  }
}

TEST(FilteredMotionReader, AContactOnAnUnknownBodyNamesTheLine) {
  const ModelInfo& info = humanInfo();
  std::mt19937 rng(78);
  const std::string path = tempPath("unknown_body.csv");
  {
    FilteredMotionWriter writer(path, info);
    writer.append(sampleOutput(info, rng, 0.0, 1));
    writer.append(sampleOutput(info, rng, 0.1, 0));
    writer.commit();
  }
  const std::string contacts = FilteredMotionWriter::contactsPathFor(path);
  std::string text = readWholeFile(contacts);
  const std::string body = info.body_names[0];
  text.replace(text.find("," + body + ","), body.size() + 2, ",tail,");
  writeFile(contacts, text);
  try {
    readFilteredMotion(path, info);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 2);
    EXPECT_NE(std::string(e.what()).find("unknown body \"tail\""), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dynfilter::io
