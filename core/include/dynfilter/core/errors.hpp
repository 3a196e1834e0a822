#pragma once
/// @file
/// Exceptions thrown on bad configuration (never on the per-tick path).

#include <stdexcept>
#include <string>

namespace dynfilter {

/// A model file (URDF) or model build failed. what() reads
/// "<file>:<line>: <element>: <reason>" so that the user can jump to the spot.
class ModelError : public std::runtime_error {
 public:
  /// @param file    source file (or a label such as "<string>")
  /// @param line    1-based line in @p file, 0 when unknown
  /// @param element the offending element, e.g. `joint "l_knee"`
  /// @param reason  what is wrong, in plain words
  ModelError(std::string file, int line, std::string element, std::string reason);

  const std::string& file() const { return file_; }
  int line() const { return line_; }
  const std::string& element() const { return element_; }
  const std::string& reason() const { return reason_; }

 private:
  std::string file_;
  int line_;
  std::string element_;
  std::string reason_;
};

/// A state or input passed to a model is invalid (wrong size, non-finite,
/// quaternion not unit norm). what() names the offending entry.
class InvalidStateError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

}  // namespace dynfilter
