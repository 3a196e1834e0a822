// Fuzz target: the filter's YAML configuration reader (dynfilter::io::parseFilterConfig,
// the string form of loadFilterConfig). Documented error: InputError. An accepted
// configuration must pass FilterOptions::validate and Environment::validate.
#include <stdexcept>
#include <string>

#include "dynfilter/io/config.hpp"
#include "dynfilter/io/input_error.hpp"
#include "fuzz_support.hpp"

namespace {
constexpr const char* kTarget = "config_fuzz";
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  dynfilter::io::FilterConfig config;
  try {
    config = dynfilter::io::parseFilterConfig(text, "fuzz.yaml");
  } catch (const dynfilter::io::InputError&) {
    return 0;
  } catch (...) {
    dynfilter::fuzz::unexpectedException(kTarget);
  }
  try {
    config.filter.validate();
    config.environment.validate();
  } catch (const std::invalid_argument& e) {
    dynfilter::fuzz::violated(kTarget,
                              std::string("accepted an invalid configuration: ") + e.what());
  }
  return 0;
}
