// dynfilter-offline as a user runs it: real files in, real files out, exit codes.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "support/test_support.hpp"

namespace {

dynfilter::test::ProgramRun runOffline(const std::string& args) { return dynfilter::test::runProgram(DYNFILTER_OFFLINE_BIN, args); }

std::vector<std::vector<std::string>> readCsv(const std::string& path) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream ss(line);
    std::string f;
    while (std::getline(ss, f, ',')) fields.push_back(f);
    rows.push_back(fields);
  }
  return rows;
}

int column(const std::vector<std::string>& header, const std::string& name) {
  for (std::size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return static_cast<int>(i);
  return -1;
}

bool exists(const std::string& path) { return std::ifstream(path).good(); }

const std::string kSquat = dynfilter::test::sourcePath("data/squat_reference.csv");

TEST(Offline, FiltersTheSquatIntoAConsistentMotion) {
  const std::string out = testing::TempDir() + "/squat_out.csv";
  std::remove(out.c_str());
  const dynfilter::test::ProgramRun run = runOffline(kSquat + " -o " + out + " --no-progress");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("max Eq. 12 residual"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("tracking RMS"), std::string::npos);
  const auto rows = readCsv(out);
  const auto reference = readCsv(kSquat);
  // One row per reference frame (the reference has 2 comment lines and a header).
  ASSERT_EQ(rows.size(), reference.size() - 2);
  const int residual = column(rows[0], "base_residual_n");
  const int time = column(rows[0], "time");
  ASSERT_GE(residual, 0);
  for (std::size_t r = 1; r < rows.size(); ++r) {
    EXPECT_LT(std::stod(rows[r][static_cast<std::size_t>(residual)]), 1e-8 * 70.0 * 9.81);
    EXPECT_NEAR(std::stod(rows[r][static_cast<std::size_t>(time)]),
                std::stod(reference[r + 2][0]), 1e-9);
  }
  const auto contacts = readCsv(out.substr(0, out.size() - 4) + ".contacts.csv");
  ASSERT_GT(contacts.size(), 1u);
  const int fz = column(contacts[0], "normal_force_n");
  for (std::size_t r = 1; r < contacts.size(); ++r)
    EXPECT_GT(std::stod(contacts[r][static_cast<std::size_t>(fz)]), 0.0);
}

// The tool's own output (every tick: q, v and v̇ with torques, errors and residuals beside
// them) is a consistent motion: read back with --skip-extra-columns and filtered again, it
// comes back unchanged up to the solver's precision. Without the flag the file is rejected
// at its first column outside the format.
TEST(Offline, ItsOwnOutputFilteredAgainComesBackUnchanged) {
  const std::string once = testing::TempDir() + "/squat_once.csv";
  const std::string twice = testing::TempDir() + "/squat_twice.csv";
  ASSERT_EQ(runOffline(kSquat + " -o " + once + " --no-progress -q --every-tick").exit_code, 0);
  const dynfilter::test::ProgramRun rejected = runOffline(once + " -o " + twice + " --no-progress -q");
  EXPECT_NE(rejected.exit_code, 0);
  EXPECT_NE(rejected.output.find(":1:2: unknown column \"status\""), std::string::npos) << rejected.output;
  const dynfilter::test::ProgramRun run = runOffline(once + " -o " + twice + " --no-progress -q --skip-extra-columns");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const auto rows = readCsv(twice);
  ASSERT_GT(rows.size(), 1000u);
  double max_error = 0.0;
  int joints = 0;
  for (std::size_t c = 0; c < rows[0].size(); ++c) {
    if (rows[0][c].rfind("err.", 0) != 0 || rows[0][c].rfind("err.base", 0) == 0) continue;
    ++joints;
    for (std::size_t r = 1; r < rows.size(); ++r) max_error = std::max(max_error, std::abs(std::stod(rows[r][c])));
  }
  EXPECT_EQ(joints, 32);
  // Measured (paper mode, the default): 4.9e-5 rad; the QP mode gives 9.3e-4 rad.
  EXPECT_LT(max_error, 5e-4);
}

TEST(Offline, BodyPositionsForPicturesMatchTheFilteredBase) {
  const std::string out = testing::TempDir() + "/squat_bodies_out.csv";
  const std::string bodies = testing::TempDir() + "/squat_bodies.csv";
  const dynfilter::test::ProgramRun run = runOffline(kSquat + " -o " + out + " --no-progress -q --bodies-csv " + bodies);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const auto main = readCsv(out);
  const auto rows = readCsv(bodies);
  ASSERT_EQ(rows.size(), 1 + 2 * (main.size() - 1)) << "a reference and a filtered row per frame";
  const int pelvis_z = column(rows[0], "pelvis.z");
  const int base_z = column(main[0], "base_z");
  ASSERT_GT(pelvis_z, 1);
  for (std::size_t r = 1; r < main.size(); r += 50) {
    const auto& filtered = rows[2 * r];  // rows 2r−1 (reference) and 2r (filtered)
    ASSERT_EQ(filtered[1], "filtered");
    EXPECT_NEAR(std::stod(filtered[static_cast<std::size_t>(pelvis_z)]),
                std::stod(main[r][static_cast<std::size_t>(base_z)]), 1e-6);
  }
}

TEST(Offline, AReferenceMadeOnLevelGroundFollowsTheSlopeGiven) {
  // The squat drifting 0.3 m/s along x, on a 10° slope descending along x: every reference
  // frame's base sinks with the plane under it (tan 10° per metre along x), within the few
  // millimetres it gives way so that the legs reach the feet carried onto the plane
  // (io::followTerrain, whose own test checks the feet to 1e-5 m).
  std::ifstream in(kSquat);
  const std::string moving = testing::TempDir() + "/moving_squat.csv";
  std::ofstream file(moving);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (n > 3) {
      std::vector<std::string> f;
      std::stringstream ss(line);
      std::string x;
      while (std::getline(ss, x, ',')) f.push_back(x);
      f[1] = std::to_string(std::stod(f[1]) + 0.3 * std::stod(f[0]));
      line.clear();
      for (std::size_t i = 0; i < f.size(); ++i) line += (i ? "," : "") + f[i];
    }
    file << line << "\n";
  }
  file.close();
  const std::string out = testing::TempDir() + "/slope_out.csv";
  const std::string bodies = testing::TempDir() + "/slope_bodies.csv";
  const dynfilter::test::ProgramRun run = runOffline(moving + " -o " + out + " --no-progress -q --slope-deg 10 " +
                                       "--slope-heading-deg 0 --bodies-csv " + bodies);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const auto rows = readCsv(bodies);
  const auto reference = readCsv(kSquat);
  const int x = column(rows[0], "pelvis.x"), z = column(rows[0], "pelvis.z");
  ASSERT_GT(z, 1);
  ASSERT_EQ(rows.size(), 1 + 2 * (reference.size() - 3));
  const double x0 = std::stod(rows[1][static_cast<std::size_t>(x)]);
  for (std::size_t r = 1; r + 3 < reference.size(); r += 40) {
    const auto& ref = rows[2 * r - 1];
    ASSERT_EQ(ref[1], "reference");
    const double dx = std::stod(ref[static_cast<std::size_t>(x)]) - x0;
    EXPECT_NEAR(std::stod(ref[static_cast<std::size_t>(z)]),
                std::stod(reference[r + 2][3]) - std::tan(10.0 * M_PI / 180.0) * dx, 0.005)
        << "frame " << r;
  }
  EXPECT_GT(std::stod(rows[rows.size() - 2][static_cast<std::size_t>(x)]) - x0, 1.0) << "it moved";
}

TEST(Offline, ABrokenReferenceIsRejectedAndNothingIsWritten) {
  // Copy the squat and put a NaN into line 10 (a data line), column 12.
  std::ifstream in(kSquat);
  const std::string bad = testing::TempDir() + "/bad_reference.csv";
  std::ofstream outfile(bad);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (n == 10) {
      std::vector<std::string> f;
      std::stringstream ss(line);
      std::string field;
      while (std::getline(ss, field, ',')) f.push_back(field);
      f[11] = "nan";
      line.clear();
      for (std::size_t i = 0; i < f.size(); ++i) line += (i ? "," : "") + f[i];
    }
    outfile << line << "\n";
  }
  outfile.close();
  const std::string out = testing::TempDir() + "/never_written.csv";
  std::remove(out.c_str());
  const dynfilter::test::ProgramRun run = runOffline(bad + " -o " + out);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.output.find("bad_reference.csv:10:12"), std::string::npos) << run.output;
  EXPECT_FALSE(exists(out));
  EXPECT_FALSE(exists(testing::TempDir() + "/never_written.contacts.csv"));
}

TEST(Offline, AnUnknownModelFileIsAClearError) {
  const dynfilter::test::ProgramRun run = runOffline(kSquat + " -o /tmp/x.csv --model /nonexistent/robot.urdf");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.output.find("/nonexistent/robot.urdf"), std::string::npos);
}

}  // namespace

// The squat (120 Hz, 4 ticks a frame at 500 Hz) whose base jumps 2 m along x from frame
// 200 on: the interpolated reference passes the 0.5 m guard inside a frame interval, so
// the figure re-seeds on ticks that write no row.
std::string writeJumpingSquat() {
  std::ifstream in(kSquat);
  const std::string jumping = testing::TempDir() + "/jumping_squat.csv";
  std::ofstream file(jumping);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (n >= 3 + 200) {
      std::vector<std::string> f;
      std::stringstream ss(line);
      std::string x;
      while (std::getline(ss, x, ',')) f.push_back(x);
      f[1] = std::to_string(std::stod(f[1]) + 2.0);
      line.clear();
      for (std::size_t i = 0; i < f.size(); ++i) line += (i ? "," : "") + f[i];
    }
    file << line << "\n";
  }
  file.close();
  return jumping;
}

TEST(Offline, ReSeedsBetweenWrittenRowsShowInTheNextRowAndTheSummary) {
  const std::string jumping = writeJumpingSquat();
  const std::string out = testing::TempDir() + "/jumping_out.csv";
  const std::string events = testing::TempDir() + "/jumping_events.csv";
  const dynfilter::test::ProgramRun run =
      runOffline(jumping + " -o " + out + " --no-progress --events-csv " + events);
  ASSERT_EQ(run.exit_code, 0) << run.output;

  const auto ev = readCsv(events);
  const int ev_time = column(ev[0], "time"), ev_tick = column(ev[0], "tick"),
            ev_status = column(ev[0], "status");
  std::vector<double> reseed_times;
  bool between_rows = false;
  for (std::size_t r = 1; r < ev.size(); ++r)
    if (std::stoul(ev[r][static_cast<std::size_t>(ev_status)]) & 16u) {
      reseed_times.push_back(std::stod(ev[r][static_cast<std::size_t>(ev_time)]));
      between_rows |= std::stol(ev[r][static_cast<std::size_t>(ev_tick)]) % 4 != 0;
    }
  ASSERT_FALSE(reseed_times.empty()) << run.output;
  ASSERT_TRUE(between_rows) << "the case needs a re-seed on a tick without a row";

  // Every re-seed marks the first row at or after it, and no other row is marked.
  const auto rows = readCsv(out);
  const int time = column(rows[0], "time"), status = column(rows[0], "status");
  std::vector<bool> expected(rows.size(), false);
  for (const double t : reseed_times)
    for (std::size_t r = 1; r < rows.size(); ++r)
      if (std::stod(rows[r][static_cast<std::size_t>(time)]) >= t - 1e-9) {
        expected[r] = true;
        break;
      }
  for (std::size_t r = 1; r < rows.size(); ++r)
    EXPECT_EQ((std::stoul(rows[r][static_cast<std::size_t>(status)]) & 16u) != 0, expected[r])
        << "row " << r << " at " << rows[r][static_cast<std::size_t>(time)] << " s";

  char summary[64];
  std::snprintf(summary, sizeof summary, "re-seeds              %zu ticks, the first at %.3f s",
                reseed_times.size(), reseed_times.front());
  EXPECT_NE(run.output.find(summary), std::string::npos) << run.output;
}

// Fields of a CSV line with RFC 4180 quotes (a quoted field may hold commas).
std::vector<std::string> splitQuoted(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (const char c : line) {
    if (c == '"')
      quoted = !quoted;
    else if (c == ',' && !quoted)
      fields.emplace_back();
    else
      fields.back() += c;
  }
  return fields;
}

TEST(Offline, EventRowsKeepTheirColumnsWhenSeveralConstraintFamiliesAreViolated) {
  // In the QP mode the jumping squat's re-seeds come with relaxed ticks whose full QP
  // violated several families: "equality,unilateral,..." is one quoted field.
  const std::string events = testing::TempDir() + "/jumping_qp_events.csv";
  const dynfilter::test::ProgramRun run =
      runOffline(writeJumpingSquat() + " -o " + testing::TempDir() + "/jumping_qp_out.csv" +
                 " --no-progress -q --mode qp --events-csv " + events);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  std::ifstream in(events);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  const std::vector<std::string> header = splitQuoted(line);
  ASSERT_EQ(header.size(), 11u);
  const int violated = column(header, "qp_violated"), rotation = column(header, "base_rotation_rad");
  const int tilt = column(header, "base_tilt_rad"), heading = column(header, "base_heading_rad");
  int several = 0, rows = 0;
  while (std::getline(in, line)) {
    const std::vector<std::string> f = splitQuoted(line);
    ASSERT_EQ(f.size(), header.size()) << line;
    several += f[static_cast<std::size_t>(violated)].find(',') != std::string::npos;
    const double angle = std::stod(f[static_cast<std::size_t>(rotation)]);
    EXPECT_GE(angle, 0.0) << line;
    // The lean is part of the orientation error: never more than its whole angle.
    EXPECT_GE(std::stod(f[static_cast<std::size_t>(tilt)]), 0.0) << line;
    EXPECT_LE(std::stod(f[static_cast<std::size_t>(tilt)]), angle + 1e-5) << line;
    EXPECT_LE(std::abs(std::stod(f[static_cast<std::size_t>(heading)])), M_PI + 1e-9) << line;
    ++rows;
  }
  EXPECT_GT(rows, 0);
  EXPECT_GT(several, 0) << "the case needs a row with several families";
}
