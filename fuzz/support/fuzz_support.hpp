#pragma once
/// @file
/// Helpers shared by the fuzz targets (fuzz/targets/*_fuzz.cpp): the bytes as a file for
/// the readers that take a path, the models whose ModelInfo some readers need, and the
/// report of an exception the parser does not document.

#include <cstddef>
#include <cstdint>
#include <string>

#include "dynfilter/core/model_info.hpp"

namespace dynfilter::fuzz {

/// Writes the bytes to this process's temporary file for @p suffix (one file per suffix,
/// rewritten on every call, removed at exit) and returns its path. Prefers /dev/shm.
const std::string& writeTempFile(const std::uint8_t* data, std::size_t size,
                                 const std::string& suffix);

/// ModelInfo of a URDF in the source tree (path relative to it), through the project's
/// loader (urdf::loadUrdfFile + validateForDynamics + makeModelInfo); loaded once.
const ModelInfo& modelInfo(const std::string& relative_path, bool floating_base);

/// Call inside a catch (...) block: prints the target, the exception's dynamic type and
/// what() to stderr, then aborts (a finding for libFuzzer and a failure for the replay).
[[noreturn]] void unexpectedException(const char* target);

/// Prints @p what for @p target to stderr and aborts: a broken post-condition of a parser.
[[noreturn]] void violated(const char* target, const std::string& what);

}  // namespace dynfilter::fuzz

/// Every fuzz target: libFuzzer's entry point (also compiled into the replay driver).
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);
