#include "dynfilter/core/errors.hpp"

#include <utility>

namespace dynfilter {
namespace {
std::string formatModelError(const std::string& file, int line, const std::string& element,
                             const std::string& reason) {
  std::string s = file;
  if (line > 0) s += ":" + std::to_string(line);
  s += ": ";
  if (!element.empty()) s += element + ": ";
  return s + reason;
}
}  // namespace

ModelError::ModelError(std::string file, int line, std::string element, std::string reason)
    : std::runtime_error(formatModelError(file, line, element, reason)),
      file_(std::move(file)),
      line_(line),
      element_(std::move(element)),
      reason_(std::move(reason)) {}

}  // namespace dynfilter
