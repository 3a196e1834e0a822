// Fuzz target: the reference-motion CSV reader (dynfilter::io::readReferenceMotion), which
// takes a path: the bytes go to a temporary file. The same file is read for three models
// (the human figure and a chain with a floating base, a double pendulum with a fixed one),
// so that a real file for any of them is a seed. Documented error: InputError (the options
// are valid, so std::invalid_argument would be a finding too).
#include <cmath>
#include <string>

#include "dynfilter/io/input_error.hpp"
#include "dynfilter/io/reference_motion.hpp"
#include "fuzz_support.hpp"

namespace {
constexpr const char* kTarget = "reference_csv_fuzz";

// What the header promises for a motion that was read.
void checkMotion(const dynfilter::io::ReferenceMotion& motion, const dynfilter::ModelInfo& info) {
  using dynfilter::fuzz::violated;
  if (motion.frames.size() < 2) violated(kTarget, "fewer than 2 frames");
  for (std::size_t k = 0; k < motion.frames.size(); ++k) {
    const dynfilter::ReferenceFrame& f = motion.frames[k];
    if (f.q.size() != info.nq || f.v.size() != info.nv || f.vdot.size() != info.nv)
      violated(kTarget, "frame " + std::to_string(k) + " has the wrong sizes");
    if (!std::isfinite(f.time_s) || !f.q.allFinite())
      violated(kTarget, "frame " + std::to_string(k) + ": time or q not finite");
    if (!f.v.allFinite() || !f.vdot.allFinite())
      violated(kTarget, "frame " + std::to_string(k) + ": v or vdot not finite (estimated " +
                            (motion.had_velocities ? "accelerations" : "derivatives") + ")");
    if (k > 0 && !(f.time_s > motion.frames[k - 1].time_s))
      violated(kTarget, "time does not increase at frame " + std::to_string(k));
    if (info.floating_base && std::abs(f.q.segment<4>(3).norm() - 1.0) > 1e-12)
      violated(kTarget, "base quaternion of frame " + std::to_string(k) + " is not unit");
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using dynfilter::fuzz::modelInfo;
  const std::string& path = dynfilter::fuzz::writeTempFile(data, size, ".csv");
  for (const dynfilter::ModelInfo* info :
       {&modelInfo("models/human_figure.urdf", true),
        &modelInfo("tests/models/floating_chain.urdf", true),
        &modelInfo("tests/models/double_pendulum.urdf", false)}) {
    try {
      checkMotion(dynfilter::io::readReferenceMotion(path, *info), *info);
    } catch (const dynfilter::io::InputError&) {
    } catch (...) {
      dynfilter::fuzz::unexpectedException(kTarget);
    }
  }
  return 0;
}
