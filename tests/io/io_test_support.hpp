#pragma once
// Shared helpers of the dynfilter::io tests: the human figure's ModelInfo, a small
// fixed-base ModelInfo, temporary files and an InputError matcher.

#include <cstdio>
#include <fstream>
#include <functional>
#include <string>

#include <gtest/gtest.h>

#include "dynfilter/core/model_info.hpp"
#include "dynfilter/io/input_error.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter::io::testing_io {

/// The human figure's ModelInfo (floating base, 32 joints), built once.
inline const ModelInfo& humanInfo() {
  static const ModelInfo info =
      test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{})->info();
  return info;
}

/// A fixed-base ModelInfo with two joints "hinge" and "slide" (the reader and writer only
/// look at sizes and names).
inline ModelInfo fixedInfo() {
  ModelInfo info;
  info.name = "fixed_arm";
  info.floating_base = false;
  info.nq = info.nv = info.nj = 2;
  info.joint_names = {"hinge", "slide"};
  info.body_names = {"base", "upper", "lower"};
  return info;
}

/// A path in GoogleTest's temporary directory, unique per test; a file left there by an
/// earlier run is removed.
inline std::string tempPath(const std::string& name) {
  const ::testing::TestInfo* t = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::string path = ::testing::TempDir() + "dynfilter_io_" + t->test_suite_name() + "_" +
                           t->name() + "_" + name;
  std::remove(path.c_str());
  return path;
}

inline void writeFile(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  ASSERT_TRUE(out.good()) << path;
}

inline bool fileExists(const std::string& path) {
  std::ifstream in(path);
  return in.good();
}

inline std::string readWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Exact decimal text of a double, independent of the library's formatting.
inline std::string num(double x) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.17g", x);
  return buffer;
}

/// Runs @p f, expects an InputError at @p file:@p line:@p column whose reason contains
/// @p needle, and returns it.
inline InputError expectInputError(const std::function<void()>& f, const std::string& file,
                                   int line, int column, const std::string& needle) {
  try {
    f();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), file);
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_EQ(e.column(), column) << e.what();
    EXPECT_NE(e.reason().find(needle), std::string::npos)
        << "reason \"" << e.reason() << "\" lacks \"" << needle << "\"";
    std::string prefix = file;
    if (line > 0) prefix += ":" + std::to_string(line);
    if (line > 0 && column > 0) prefix += ":" + std::to_string(column);
    prefix += ": ";
    EXPECT_EQ(std::string(e.what()), prefix + e.reason());
    return e;
  }
  ADD_FAILURE() << "no InputError (expected \"" << needle << "\")";
  return InputError(file, 0, "none");
}

}  // namespace dynfilter::io::testing_io
