#include "dynfilter/io/input_error.hpp"

#include <utility>

namespace dynfilter::io {
namespace {
std::string formatInputError(const std::string& file, int line, int column,
                             const std::string& reason) {
  std::string s = file;
  if (line > 0) {
    s += ':' + std::to_string(line);
    if (column > 0) s += ':' + std::to_string(column);
  }
  return s + ": " + reason;
}
}  // namespace

InputError::InputError(std::string file, int line, int column, std::string reason)
    : std::runtime_error(formatInputError(file, line, column, reason)),
      file_(std::move(file)),
      line_(line > 0 ? line : 0),
      column_(line > 0 && column > 0 ? column : 0),
      reason_(std::move(reason)) {}

InputError::InputError(std::string file, int line, std::string reason)
    : InputError(std::move(file), line, 0, std::move(reason)) {}

}  // namespace dynfilter::io
