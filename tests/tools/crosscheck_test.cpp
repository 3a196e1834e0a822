// dynfilter-crosscheck as a user runs it: DART against ODE on real files.
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "support/test_support.hpp"

namespace {

dynfilter::test::ProgramRun crosscheck(const std::string& args) { return dynfilter::test::runProgram(DYNFILTER_CROSSCHECK_BIN, args); }

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(Crosscheck, HumanFigureAgreesBetweenDartAndOde) {
  const std::string json = testing::TempDir() + "/crosscheck.json";
  const dynfilter::test::ProgramRun r = crosscheck(dynfilter::test::humanFigurePath() + " --states 100 --json " + json);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("mass matrix A"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("PASS"), std::string::npos);
  // The JSON carries q, v and each backend's A and b for every state.
  const auto j = nlohmann::json::parse(readFile(json));
  ASSERT_EQ(j["states"].size(), 100u);
  const auto& s0 = j["states"][0];
  EXPECT_EQ(s0["A"]["dart"].size(), 38u);
  EXPECT_EQ(s0["A"]["ode"].size(), 38u);
  EXPECT_EQ(s0["q"].size(), 39u);
  EXPECT_LT(s0["relative_error"]["mass_matrix"].get<double>(), 1e-9);
}

TEST(Crosscheck, QuadrupedAgreesBetweenDartAndOde) {
  const dynfilter::test::ProgramRun r =
      crosscheck(dynfilter::test::testModelPath("quadruped.urdf") + " --states 100");
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

TEST(Crosscheck, AWrongInertiaInOneEngineIsCaught) {
  // The second engine gets a human figure whose left thigh is 2 % heavier.
  std::string urdf = readFile(dynfilter::test::humanFigurePath());
  const std::regex thigh_mass(R"((<link name="l_thigh">\s*<inertial>\s*<origin[^>]*>\s*<mass value=")([0-9.]+))");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(urdf, m, thigh_mass));
  const double mass = std::stod(m[2].str());
  urdf = m.prefix().str() + m[1].str() + std::to_string(1.02 * mass) + m.suffix().str();
  const std::string wrong = testing::TempDir() + "/wrong_thigh.urdf";
  std::ofstream(wrong) << urdf;
  const dynfilter::test::ProgramRun r = crosscheck(dynfilter::test::humanFigurePath() + " --model-b " + wrong +
                                     " --states 10");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("FAIL"), std::string::npos) << r.output;
}

TEST(Crosscheck, AFilteredMotionSatisfiesEq12InTheOtherBackend) {
  const std::string out = testing::TempDir() + "/squat_for_crosscheck.csv";
  const dynfilter::test::ProgramRun filtered = dynfilter::test::runProgram(DYNFILTER_OFFLINE_BIN, dynfilter::test::sourcePath("data/squat_reference.csv") +
                                     " -o " + out + " --no-progress -q");
  ASSERT_EQ(filtered.exit_code, 0) << filtered.output;
  const dynfilter::test::ProgramRun ok = crosscheck("--filtered " + out + " --filtered-backend dart");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("re-evaluated with the ode backend"), std::string::npos) << ok.output;

  // Tamper with one torque: the other backend must notice. Replace the l_hip_pitch.tau
  // value of the 100th data row by 0.
  std::ifstream in(out);
  std::string header, line, text;
  std::getline(in, header);
  text = header + "\n";
  std::size_t col = 0;
  {
    std::stringstream h(header);
    std::string name;
    for (std::size_t i = 0; std::getline(h, name, ','); ++i)
      if (name == "waist_pitch.tau") col = i;
  }
  ASSERT_GT(col, 0u);
  for (int row = 1; std::getline(in, line); ++row) {
    if (row == 100) {
      std::stringstream ss(line);
      std::string field, rebuilt;
      for (std::size_t i = 0; std::getline(ss, field, ','); ++i)
        rebuilt += (i ? "," : "") + (i == col ? std::string("0") : field);
      line = rebuilt;
    }
    text += line + "\n";
  }
  in.close();
  std::ofstream(out) << text;
  const dynfilter::test::ProgramRun bad = crosscheck("--filtered " + out + " --filtered-backend dart");
  EXPECT_EQ(bad.exit_code, 1) << bad.output;
}

}  // namespace
