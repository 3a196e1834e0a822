// Fuzz target: the BVH reader (dynfilter::io::readBvh, which takes a path: the bytes go to
// a temporary file) with the default options and with the CMU clips' options (length scale,
// T-pose detection), then the forward kinematics of the first and the last frame as the
// retargeting runs it. Documented error: InputError.
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "dynfilter/io/bvh.hpp"
#include "dynfilter/io/input_error.hpp"
#include "fuzz_support.hpp"

namespace {
constexpr const char* kTarget = "bvh_fuzz";

void checkMotion(const dynfilter::io::BvhMotion& motion) {
  using dynfilter::fuzz::violated;
  int channels = 0;
  for (std::size_t j = 0; j < motion.joints.size(); ++j) {
    const dynfilter::io::BvhJoint& joint = motion.joints[j];
    if (joint.parent >= static_cast<int>(j)) violated(kTarget, "a parent after its child");
    if (!joint.channels.empty() && joint.first_channel != channels)
      violated(kTarget, "channel columns out of order at joint " + joint.name);
    channels += static_cast<int>(joint.channels.size());
  }
  if (channels != motion.channelCount())
    violated(kTarget, "channel count differs from the columns");
  if (!(motion.frame_time_s > 0.0)) violated(kTarget, "frame time not > 0");
  if (!motion.frames.allFinite()) violated(kTarget, "frame values not finite");
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = dynfilter::fuzz::writeTempFile(data, size, ".bvh");
  dynfilter::io::BvhReadOptions cmu;
  cmu.length_scale = 0.0254 / 0.45;
  cmu.detect_t_pose = true;
  std::vector<Eigen::Isometry3d> X_world;
  for (const dynfilter::io::BvhReadOptions& options : {dynfilter::io::BvhReadOptions{}, cmu}) {
    try {
      const dynfilter::io::BvhMotion motion = dynfilter::io::readBvh(path, options);
      checkMotion(motion);
      if (motion.frameCount() > 0) {
        dynfilter::io::bvhForwardKinematics(motion, 0, X_world);
        dynfilter::io::bvhForwardKinematics(motion, motion.frameCount() - 1, X_world);
      }
    } catch (const dynfilter::io::InputError&) {
    } catch (...) {
      dynfilter::fuzz::unexpectedException(kTarget);
    }
  }
  return 0;
}
