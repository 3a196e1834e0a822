// Fuzz target: the BVH retargeting mapping reader (dynfilter::io::parseRetargetMapping, a
// YAML string). Documented error: InputError. A mapping that was accepted must give an
// axis conversion (a rotation) without throwing.
#include <string>

#include <Eigen/Core>

#include "dynfilter/io/input_error.hpp"
#include "dynfilter/io/retarget.hpp"
#include "fuzz_support.hpp"

namespace {
constexpr const char* kTarget = "retarget_mapping_fuzz";
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const dynfilter::io::RetargetMapping mapping =
        dynfilter::io::parseRetargetMapping(text, "fuzz.yaml");
    const Eigen::Matrix3d R = mapping.axisConversion();
    if (!(R * R.transpose()).isApprox(Eigen::Matrix3d::Identity(), 1e-12) ||
        R.determinant() < 0.0)
      dynfilter::fuzz::violated(kTarget, "axis conversion is not a rotation");
    if (!(mapping.length_scale > 0.0) || mapping.skip_frames < 0 || mapping.ground_frames < 1)
      dynfilter::fuzz::violated(kTarget, "accepted an out-of-range option");
  } catch (const dynfilter::io::InputError&) {
  } catch (...) {
    dynfilter::fuzz::unexpectedException(kTarget);
  }
  return 0;
}
