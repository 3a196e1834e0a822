// Fuzz target: what the `dynfilter` process does with the bytes of an LCM message on its
// reference and robot-state channels: ReferenceFrameReader::read / RobotStateReader::read
// (fingerprint, counts and string lengths in the raw bytes, decode, validation) for the
// human figure with a floating base and with a fixed base (--fixed-base). Each message is
// read twice by the same reader (the second read takes the cached joint-name path; time
// order is the stream's matter, realtime/MessageStream). Nothing may throw; an accepted message must come out finite, with a unit
// base quaternion, and a rejection must leave the output untouched.
#include <cmath>
#include <cstring>
#include <string>

#include "dynfilter/lcm/messages.hpp"
#include "fuzz_support.hpp"

namespace {
constexpr const char* kTarget = "lcm_fuzz";
using dynfilter::fuzz::violated;

void checkUnit(const Eigen::Ref<const Eigen::VectorXd>& quaternion, const char* what) {
  if (std::abs(quaternion.norm() - 1.0) > 1e-12) violated(kTarget, std::string(what) + " not unit");
}

void readReference(const dynfilter::ModelInfo& info, const std::uint8_t* data, std::size_t size) {
  dynfilter::messages::ReferenceFrameReader reader(info);
  dynfilter::messages::ReferenceInput out(info);
  for (int pass = 0; pass < 2; ++pass) {
    const dynfilter::ReferenceFrame before = out.frame;
    const dynfilter::messages::MessageCheck check = reader.read(data, size, out);
    if (!check.ok()) {
      if (check.reason == nullptr) violated(kTarget, "rejection without a reason");
      if (!out.frame.q.cwiseEqual(before.q).all() || !out.frame.v.cwiseEqual(before.v).all() ||
          !out.frame.vdot.cwiseEqual(before.vdot).all())
        violated(kTarget, "a rejected reference frame changed the output");
      continue;
    }
    const dynfilter::ReferenceFrame& f = out.frame;
    if (f.q.size() != info.nq || f.v.size() != info.nv || f.vdot.size() != info.nv)
      violated(kTarget, "accepted reference frame has the wrong sizes");
    if (!f.q.allFinite() || !f.v.allFinite() || !f.vdot.allFinite() ||
        !out.task_position.allFinite())
      violated(kTarget, "accepted reference frame is not finite");
    if (info.floating_base) checkUnit(f.q.segment<4>(3), "base quaternion");
    if (out.has_task_target) checkUnit(out.task_quaternion, "task quaternion");
    if (out.num_contact_hints < 0 ||
        out.num_contact_hints > static_cast<int>(info.body_names.size()))
      violated(kTarget, "contact hint count out of range");
    for (int h = 0; h < out.num_contact_hints; ++h) {
      const int body = out.contact_hint_bodies[static_cast<std::size_t>(h)];
      if (body < 0 || body >= static_cast<int>(info.body_names.size()))
        violated(kTarget, "contact hint body out of range");
    }
  }
}

void readState(const dynfilter::ModelInfo& info, const std::uint8_t* data, std::size_t size) {
  dynfilter::messages::RobotStateReader reader(info);
  dynfilter::messages::RobotStateInput out(info);
  for (int pass = 0; pass < 2; ++pass) {
    const Eigen::VectorXd before = out.q;
    const dynfilter::messages::MessageCheck check = reader.read(data, size, out);
    if (!check.ok()) {
      if (!out.q.cwiseEqual(before).all())
        violated(kTarget, "a rejected robot state changed the output");
      continue;
    }
    if (out.q.size() != info.nq || out.v.size() != info.nv || out.tau.size() != info.nj)
      violated(kTarget, "accepted robot state has the wrong sizes");
    if (!out.q.allFinite() || !out.v.allFinite() || !out.tau.allFinite())
      violated(kTarget, "accepted robot state is not finite");
    if (info.floating_base) checkUnit(out.q.segment<4>(3), "base quaternion");
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using dynfilter::fuzz::modelInfo;
  try {
    for (const bool floating_base : {true, false}) {
      const dynfilter::ModelInfo& info = modelInfo("models/human_figure.urdf", floating_base);
      readReference(info, data, size);
      readState(info, data, size);
    }
  } catch (...) {
    dynfilter::fuzz::unexpectedException(kTarget);
  }
  return 0;
}
