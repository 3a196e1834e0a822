#include "dynfilter/lcm/messages.hpp"

#include "dynfilter/core/contact_qp.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <exception>

namespace dynfilter::messages {
namespace {

MessageCheck fail(MessageError error, const char* reason, int index = -1) {
  MessageCheck check;
  check.error = error;
  check.reason = reason;
  check.index = index;
  return check;
}

// Wire layout (LCM: an 8-byte fingerprint, then the fields in declaration order, big
// endian, fixed arrays inline). The counts sit after fixed-size fields only, so their
// offsets are constants; the tests check them against the generated encoder.
constexpr std::size_t kFingerprintBytes = 8;
// reference_frame_t: utime, sequence, base_position[3], base_quaternion[4],
// base_linear_velocity[3], base_angular_velocity[3], base_acceleration[6],
// has_task_target (1 byte), task_position[3], task_quaternion[4], num_joints, num_contact_hints
constexpr std::size_t kReferenceJointCountOffset =
    kFingerprintBytes + 8 + 8 + 8 * (3 + 4 + 3 + 3 + 6) + 1 + 8 * (3 + 4);
constexpr std::size_t kReferenceHintCountOffset = kReferenceJointCountOffset + 4;
// robot_state_t: utime, base_position[3], base_quaternion[4], base_linear_velocity[3],
// base_angular_velocity[3], num_joints
constexpr std::size_t kRobotStateJointCountOffset = kFingerprintBytes + 8 + 8 * (3 + 4 + 3 + 3);

std::int64_t readBigEndian64(const unsigned char* p) {
  std::uint64_t value = 0;
  for (int i = 0; i < 8; ++i) value = (value << 8) | p[i];
  std::int64_t result;
  std::memcpy(&result, &value, sizeof result);
  return result;
}

std::int32_t readBigEndian32(const unsigned char* p) {
  std::uint32_t value = 0;
  for (int i = 0; i < 4; ++i) value = (value << 8) | p[i];
  std::int32_t result;
  std::memcpy(&result, &value, sizeof result);
  return result;
}

// Checks the fingerprint and that the message holds at least @p min_size bytes.
MessageCheck checkHeader(const void* data, std::size_t size, std::size_t min_size,
                         std::int64_t fingerprint) {
  if (data == nullptr || size < min_size)
    return fail(MessageError::kMalformed, "message too short");
  if (size > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    return fail(MessageError::kMalformed, "message too long");
  if (readBigEndian64(static_cast<const unsigned char*>(data)) != fingerprint)
    return fail(MessageError::kMalformed, "wrong message type (fingerprint)");
  return {};
}

// The generated decoder trusts the message: it resizes arrays to their counts and takes
// string lengths as they come (a length of 0 or below makes std::string throw or read far
// past the buffer). So the byte layout is walked first: the counts against the model, every
// string length within the bytes that are left.
class WireCursor {
 public:
  WireCursor(const unsigned char* bytes, std::size_t size, std::size_t pos)
      : bytes_(bytes), size_(size), pos_(pos) {}
  bool skip(std::size_t n) {
    if (size_ - pos_ < n) return false;
    pos_ += n;
    return true;
  }
  // @p count LCM strings: int32 length including the terminating NUL, then the bytes.
  bool skipStrings(int count) {
    for (int i = 0; i < count; ++i) {
      if (size_ - pos_ < 4) return false;
      const std::int32_t length = readBigEndian32(bytes_ + pos_);
      pos_ += 4;
      if (length < 1 || static_cast<std::size_t>(length) > size_ - pos_) return false;
      if (bytes_[pos_ + static_cast<std::size_t>(length) - 1] != 0) return false;
      pos_ += static_cast<std::size_t>(length);
    }
    return true;
  }

 private:
  const unsigned char* bytes_;
  std::size_t size_, pos_;
};

// Decodes a message whose layout has been checked; nothing may throw out of here.
template <class Message>
MessageCheck decodeChecked(Message& msg, const void* data, std::size_t size) {
  try {
    if (msg.decode(data, 0, static_cast<int>(size)) < 0)
      return fail(MessageError::kMalformed, "message truncated or malformed");
  } catch (const std::exception&) {
    return fail(MessageError::kMalformed, "malformed string in message");
  }
  return {};
}

bool finite(const double* values, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(values[i])) return false;
  return true;
}

// First non-finite entry of values[0..n), or -1.
int firstNonFinite(const std::vector<double>& values, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(values[i])) return i;
  return -1;
}

bool unitQuaternion(const double* quaternion) {
  const double norm = std::sqrt(quaternion[0] * quaternion[0] + quaternion[1] * quaternion[1] +
                                quaternion[2] * quaternion[2] + quaternion[3] * quaternion[3]);
  return std::abs(norm - 1.0) <= kUnitQuaternionTolerance;
}

// Writes the normalised quaternion (w, x, y, z).
template <class Out>
void writeNormalised(const double* quaternion, Out&& out) {
  const double norm = std::sqrt(quaternion[0] * quaternion[0] + quaternion[1] * quaternion[1] +
                                quaternion[2] * quaternion[2] + quaternion[3] * quaternion[3]);
  for (int i = 0; i < 4; ++i) out[i] = quaternion[i] / norm;
}

bool arrayTooShort(std::size_t size, int count) {
  return size < static_cast<std::size_t>(count);
}

template <class Vector>
void resizeIfNeeded(Vector& v, Eigen::Index n) {
  if (v.size() != n) v.setZero(n);
}

}  // namespace

const char* toString(MessageError error) {
  switch (error) {
    case MessageError::kOk: return "kOk";
    case MessageError::kMalformed: return "kMalformed";
    case MessageError::kWrongJointCount: return "kWrongJointCount";
    case MessageError::kBadCount: return "kBadCount";
    case MessageError::kUnknownJoint: return "kUnknownJoint";
    case MessageError::kDuplicateJoint: return "kDuplicateJoint";
    case MessageError::kUnknownBody: return "kUnknownBody";
    case MessageError::kDuplicateBody: return "kDuplicateBody";
    case MessageError::kNonFinite: return "kNonFinite";
    case MessageError::kNonUnitQuaternion: return "kNonUnitQuaternion";
  }
  return "unknown MessageError";
}

// ---------------------------------------------------------------------------------------
// JointNameMap
// ---------------------------------------------------------------------------------------

JointNameMap::JointNameMap(const ModelInfo& info)
    : nj_(info.nj),
      locked_(static_cast<int>(info.locked_joint_names.size())),
      cached_names_(static_cast<std::size_t>(maxCount())),
      indices_(static_cast<std::size_t>(maxCount()), -1),
      scratch_(static_cast<std::size_t>(maxCount()), -1),
      seen_(static_cast<std::size_t>(maxCount()), 0) {
  by_name_.reserve(static_cast<std::size_t>(maxCount()));
  for (int j = 0; j < info.nj; ++j) by_name_.emplace(info.joint_names[static_cast<std::size_t>(j)], j);
  // Locked joints after the model's: nj, nj + 1, ...
  for (int l = 0; l < locked_; ++l) by_name_.emplace(info.locked_joint_names[static_cast<std::size_t>(l)], nj_ + l);
}

MessageCheck JointNameMap::map(const std::vector<std::string>& names, int count) {
  if (count < nj_ || count > maxCount())
    return fail(MessageError::kWrongJointCount, "joint count differs from the model's");
  if (arrayTooShort(names.size(), count))
    return fail(MessageError::kBadCount, "fewer joint names than num_joints");
  const std::size_t n = static_cast<std::size_t>(count);

  if (cached_count_ == count) {
    bool same = true;
    for (std::size_t i = 0; i < n && same; ++i) same = names[i] == cached_names_[i];
    if (same) return {};
  }

  std::fill(seen_.begin(), seen_.end(), 0);
  int locked = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto it = by_name_.find(names[i]);
    if (it == by_name_.end())
      return fail(MessageError::kUnknownJoint, "unknown joint name", static_cast<int>(i));
    const auto j = static_cast<std::size_t>(it->second);
    if (seen_[j] != 0)
      return fail(MessageError::kDuplicateJoint, "joint name given twice", static_cast<int>(i));
    seen_[j] = 1;
    const bool is_locked = it->second >= nj_;
    locked += is_locked ? 1 : 0;
    scratch_[i] = is_locked ? -1 : it->second;
  }
  // Distinct known names: every model joint is present exactly when the rest are locked ones.
  if (count - locked != nj_) return fail(MessageError::kWrongJointCount, "joint count differs from the model's");
  indices_.swap(scratch_);
  for (std::size_t i = 0; i < n; ++i) cached_names_[i] = names[i];  // allocates only for new names
  cached_count_ = count;
  return {};
}

// ---------------------------------------------------------------------------------------
// Reference frames
// ---------------------------------------------------------------------------------------

ReferenceInput::ReferenceInput(const ModelInfo& info)
    : frame(info.nq, info.nv),
      contact_hint_bodies(info.body_names.size(), -1),
      contact_hint_active(info.body_names.size(), 0) {}

ReferenceFrameReader::ReferenceFrameReader(const ModelInfo& info)
    : info_(info),
      names_(info),
      hint_scratch_(info.body_names.size(), -1),
      body_seen_(info.body_names.size(), 0) {
  body_by_name_.reserve(info.body_names.size());
  for (std::size_t b = 0; b < info.body_names.size(); ++b)
    body_by_name_.emplace(info.body_names[b], static_cast<int>(b));
  // Room for a full message, so that decoding a valid one does not allocate.
  const auto n = static_cast<std::size_t>(names_.maxCount());
  message_.num_joints = info.nj;
  message_.joint_names.reserve(n);
  message_.q.reserve(n);
  message_.qd.reserve(n);
  message_.qdd.reserve(n);
  message_.joint_names.resize(static_cast<std::size_t>(info.nj));
  message_.q.resize(static_cast<std::size_t>(info.nj));
  message_.qd.resize(static_cast<std::size_t>(info.nj));
  message_.qdd.resize(static_cast<std::size_t>(info.nj));
  message_.contact_hint_bodies.reserve(info.body_names.size());
  message_.contact_hint_active.reserve(info.body_names.size());
}

MessageCheck ReferenceFrameReader::read(const void* data, std::size_t size, ReferenceInput& out) {
  MessageCheck check = checkHeader(data, size, kReferenceHintCountOffset + 4,
                                   reference_frame_t::getHash());
  if (!check.ok()) return check;
  const auto* bytes = static_cast<const unsigned char*>(data);
  const std::int32_t num_joints = readBigEndian32(bytes + kReferenceJointCountOffset);
  const std::int32_t num_hints = readBigEndian32(bytes + kReferenceHintCountOffset);
  if (num_joints < info_.nj || num_joints > names_.maxCount())
    return fail(MessageError::kWrongJointCount, "joint count differs from the model's");
  if (num_hints < 0 || static_cast<std::size_t>(num_hints) > info_.body_names.size())
    return fail(MessageError::kBadCount, "contact hint count negative or above the number of bodies");
  WireCursor cursor(bytes, size, kReferenceHintCountOffset + 4);
  if (!cursor.skipStrings(num_joints) || !cursor.skip(3 * 8 * static_cast<std::size_t>(num_joints)) ||
      !cursor.skipStrings(num_hints) || !cursor.skip(static_cast<std::size_t>(num_hints)))
    return fail(MessageError::kMalformed, "message truncated or malformed string");
  check = decodeChecked(message_, data, size);
  if (!check.ok()) return check;
  return convert(message_, out);
}

MessageCheck ReferenceFrameReader::convert(const reference_frame_t& msg, ReferenceInput& out) {
  // Counts first: the arrays are only touched within them.
  MessageCheck check = names_.map(msg.joint_names, msg.num_joints);
  if (check.error == MessageError::kWrongJointCount || check.error == MessageError::kBadCount)
    return check;
  const int n = msg.num_joints;
  if (arrayTooShort(msg.q.size(), n) || arrayTooShort(msg.qd.size(), n) ||
      arrayTooShort(msg.qdd.size(), n))
    return fail(MessageError::kBadCount, "joint arrays shorter than num_joints");
  const int num_hints = msg.num_contact_hints;
  if (num_hints < 0 || static_cast<std::size_t>(num_hints) > info_.body_names.size())
    return fail(MessageError::kBadCount, "contact hint count negative or above the number of bodies");
  if (arrayTooShort(msg.contact_hint_bodies.size(), num_hints) ||
      arrayTooShort(msg.contact_hint_active.size(), num_hints))
    return fail(MessageError::kBadCount, "contact hint arrays shorter than num_contact_hints");
  if (!check.ok()) return check;  // joint names

  std::fill(body_seen_.begin(), body_seen_.end(), 0);
  for (int h = 0; h < num_hints; ++h) {
    const auto it = body_by_name_.find(msg.contact_hint_bodies[static_cast<std::size_t>(h)]);
    if (it == body_by_name_.end())
      return fail(MessageError::kUnknownBody, "contact hint names an unknown link", h);
    const auto b = static_cast<std::size_t>(it->second);
    if (body_seen_[b] != 0)
      return fail(MessageError::kDuplicateBody, "contact hint names a link twice", h);
    body_seen_[b] = 1;
    hint_scratch_[static_cast<std::size_t>(h)] = it->second;
  }

  if (!finite(msg.base_position, 3) || !finite(msg.base_quaternion, 4) ||
      !finite(msg.base_linear_velocity, 3) || !finite(msg.base_angular_velocity, 3) ||
      !finite(msg.base_acceleration, 6))
    return fail(MessageError::kNonFinite, "base value not finite");
  if (!finite(msg.task_position, 3) || !finite(msg.task_quaternion, 4))
    return fail(MessageError::kNonFinite, "task target not finite");
  for (const std::vector<double>* values : {&msg.q, &msg.qd, &msg.qdd}) {
    const int bad = firstNonFinite(*values, n);
    if (bad >= 0) return fail(MessageError::kNonFinite, "joint value not finite", bad);
  }
  if (info_.floating_base && !unitQuaternion(msg.base_quaternion))
    return fail(MessageError::kNonUnitQuaternion, "base quaternion not unit");
  const bool has_task = msg.has_task_target != 0;
  if (has_task && !unitQuaternion(msg.task_quaternion))
    return fail(MessageError::kNonUnitQuaternion, "task quaternion not unit");

  // Accepted: write the output.
  ReferenceFrame& frame = out.frame;
  resizeIfNeeded(frame.q, info_.nq);
  resizeIfNeeded(frame.v, info_.nv);
  resizeIfNeeded(frame.vdot, info_.nv);
  frame.time_s = static_cast<double>(msg.utime) / 1e6;  // correctly rounded
  if (info_.floating_base) {
    for (int i = 0; i < 3; ++i) {
      frame.q[i] = msg.base_position[i];
      frame.v[i] = msg.base_linear_velocity[i];
      frame.v[3 + i] = msg.base_angular_velocity[i];
    }
    writeNormalised(msg.base_quaternion, frame.q.segment<4>(3));
    for (int i = 0; i < 6; ++i) frame.vdot[i] = msg.base_acceleration[i];
  }
  const std::vector<int>& joint = names_.indices();
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const int j = joint[k];
    if (j < 0) continue;  // a locked joint
    frame.q[info_.configurationIndex(j)] = msg.q[k];
    frame.v[info_.velocityIndex(j)] = msg.qd[k];
    frame.vdot[info_.velocityIndex(j)] = msg.qdd[k];
  }
  out.utime = msg.utime;
  out.sequence = msg.sequence;
  out.has_task_target = has_task;
  if (has_task) {
    for (int i = 0; i < 3; ++i) out.task_position[i] = msg.task_position[i];
    writeNormalised(msg.task_quaternion, out.task_quaternion);
  } else {
    out.task_position.setZero();
    out.task_quaternion = Eigen::Vector4d(1.0, 0.0, 0.0, 0.0);
  }
  if (out.contact_hint_bodies.size() < info_.body_names.size()) {
    out.contact_hint_bodies.resize(info_.body_names.size(), -1);
    out.contact_hint_active.resize(info_.body_names.size(), 0);
  }
  out.num_contact_hints = num_hints;
  for (int h = 0; h < num_hints; ++h) {
    const auto k = static_cast<std::size_t>(h);
    out.contact_hint_bodies[k] = hint_scratch_[k];
    out.contact_hint_active[k] = msg.contact_hint_active[k] != 0 ? 1 : 0;
  }
  return {};
}

// ---------------------------------------------------------------------------------------
// Robot states
// ---------------------------------------------------------------------------------------

RobotStateInput::RobotStateInput(const ModelInfo& info)
    : q(Eigen::VectorXd::Zero(info.nq)),
      v(Eigen::VectorXd::Zero(info.nv)),
      tau(Eigen::VectorXd::Zero(info.nj)) {}

RobotStateReader::RobotStateReader(const ModelInfo& info) : info_(info), names_(info) {
  const auto n = static_cast<std::size_t>(names_.maxCount());
  message_.joint_names.reserve(n);
  message_.q.reserve(n);
  message_.qd.reserve(n);
  message_.tau.reserve(n);
  message_.num_joints = info.nj;
  message_.joint_names.resize(static_cast<std::size_t>(info.nj));
  message_.q.resize(static_cast<std::size_t>(info.nj));
  message_.qd.resize(static_cast<std::size_t>(info.nj));
  message_.tau.resize(static_cast<std::size_t>(info.nj));
}

MessageCheck RobotStateReader::read(const void* data, std::size_t size, RobotStateInput& out) {
  MessageCheck check =
      checkHeader(data, size, kRobotStateJointCountOffset + 4, robot_state_t::getHash());
  if (!check.ok()) return check;
  const auto* bytes = static_cast<const unsigned char*>(data);
  const std::int32_t num_joints = readBigEndian32(bytes + kRobotStateJointCountOffset);
  if (num_joints < info_.nj || num_joints > names_.maxCount())
    return fail(MessageError::kWrongJointCount, "joint count differs from the model's");
  WireCursor cursor(bytes, size, kRobotStateJointCountOffset + 4);
  if (!cursor.skipStrings(num_joints) || !cursor.skip(3 * 8 * static_cast<std::size_t>(num_joints)))
    return fail(MessageError::kMalformed, "message truncated or malformed string");
  check = decodeChecked(message_, data, size);
  if (!check.ok()) return check;
  return convert(message_, out);
}

MessageCheck RobotStateReader::convert(const robot_state_t& msg, RobotStateInput& out) {
  MessageCheck check = names_.map(msg.joint_names, msg.num_joints);
  if (check.error == MessageError::kWrongJointCount || check.error == MessageError::kBadCount)
    return check;
  const int n = msg.num_joints;
  if (arrayTooShort(msg.q.size(), n) || arrayTooShort(msg.qd.size(), n) ||
      arrayTooShort(msg.tau.size(), n))
    return fail(MessageError::kBadCount, "joint arrays shorter than num_joints");
  if (!check.ok()) return check;

  if (!finite(msg.base_position, 3) || !finite(msg.base_quaternion, 4) ||
      !finite(msg.base_linear_velocity, 3) || !finite(msg.base_angular_velocity, 3))
    return fail(MessageError::kNonFinite, "base value not finite");
  for (const std::vector<double>* values : {&msg.q, &msg.qd, &msg.tau}) {
    const int bad = firstNonFinite(*values, n);
    if (bad >= 0) return fail(MessageError::kNonFinite, "joint value not finite", bad);
  }
  if (info_.floating_base && !unitQuaternion(msg.base_quaternion))
    return fail(MessageError::kNonUnitQuaternion, "base quaternion not unit");

  resizeIfNeeded(out.q, info_.nq);
  resizeIfNeeded(out.v, info_.nv);
  resizeIfNeeded(out.tau, info_.nj);
  if (info_.floating_base) {
    for (int i = 0; i < 3; ++i) {
      out.q[i] = msg.base_position[i];
      out.v[i] = msg.base_linear_velocity[i];
      out.v[3 + i] = msg.base_angular_velocity[i];
    }
    writeNormalised(msg.base_quaternion, out.q.segment<4>(3));
  }
  const std::vector<int>& joint = names_.indices();
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const int j = joint[k];
    if (j < 0) continue;  // a locked joint
    out.q[info_.configurationIndex(j)] = msg.q[k];
    out.v[info_.velocityIndex(j)] = msg.qd[k];
    out.tau[j] = msg.tau[k];
  }
  out.utime = msg.utime;
  return {};
}

// ---------------------------------------------------------------------------------------
// Sending
// ---------------------------------------------------------------------------------------
namespace {

void copyNames(const ModelInfo& info, std::vector<std::string>& names) {
  names.resize(static_cast<std::size_t>(info.nj));
  for (std::size_t j = 0; j < names.size(); ++j) names[j] = info.joint_names[j];
}

// Base pose and twist of (q, v) into the message's fixed arrays; identity for a fixed base.
template <class Message>
void writeBase(const ModelInfo& info, const Eigen::Ref<const Eigen::VectorXd>& q,
               const Eigen::Ref<const Eigen::VectorXd>& v, Message& msg) {
  for (int i = 0; i < 3; ++i) {
    msg.base_position[i] = info.floating_base ? q[i] : 0.0;
    msg.base_linear_velocity[i] = info.floating_base ? v[i] : 0.0;
    msg.base_angular_velocity[i] = info.floating_base ? v[3 + i] : 0.0;
  }
  for (int i = 0; i < 4; ++i)
    msg.base_quaternion[i] = info.floating_base ? q[3 + i] : (i == 0 ? 1.0 : 0.0);
}

template <class Vector>
void jointsOf(const ModelInfo& info, const Vector& full, bool configuration,
              std::vector<double>& out) {
  out.resize(static_cast<std::size_t>(info.nj));
  for (int j = 0; j < info.nj; ++j)
    out[static_cast<std::size_t>(j)] =
        full[configuration ? info.configurationIndex(j) : info.velocityIndex(j)];
}

bool finiteVector(const std::vector<double>& values) {
  return firstNonFinite(values, static_cast<int>(values.size())) < 0;
}

}  // namespace

void fillReferenceFrame(const ModelInfo& info, const ReferenceFrame& frame, std::int64_t utime,
                        std::int64_t sequence, reference_frame_t& msg) {
  msg.utime = utime;
  msg.sequence = sequence;
  writeBase(info, frame.q, frame.v, msg);
  for (int i = 0; i < 6; ++i) msg.base_acceleration[i] = info.floating_base ? frame.vdot[i] : 0.0;
  msg.has_task_target = 0;
  for (int i = 0; i < 3; ++i) msg.task_position[i] = 0.0;
  for (int i = 0; i < 4; ++i) msg.task_quaternion[i] = i == 0 ? 1.0 : 0.0;
  msg.num_joints = info.nj;
  msg.num_contact_hints = 0;
  copyNames(info, msg.joint_names);
  jointsOf(info, frame.q, true, msg.q);
  jointsOf(info, frame.v, false, msg.qd);
  jointsOf(info, frame.vdot, false, msg.qdd);
  msg.contact_hint_bodies.clear();
  msg.contact_hint_active.clear();
}

void fillRobotState(const ModelInfo& info, std::int64_t utime,
                    const Eigen::Ref<const Eigen::VectorXd>& q,
                    const Eigen::Ref<const Eigen::VectorXd>& v, const Eigen::VectorXd* tau,
                    robot_state_t& msg) {
  msg.utime = utime;
  writeBase(info, q, v, msg);
  msg.num_joints = info.nj;
  copyNames(info, msg.joint_names);
  jointsOf(info, q, true, msg.q);
  jointsOf(info, v, false, msg.qd);
  msg.tau.resize(static_cast<std::size_t>(info.nj));
  for (int j = 0; j < info.nj; ++j)
    msg.tau[static_cast<std::size_t>(j)] = tau != nullptr ? (*tau)[j] : 0.0;
}

bool fillTorqueCommand(const ModelInfo& info, const FilterOutput& output,
                       const CommandStamps& stamps, std::uint32_t status,
                       const Eigen::VectorXd* tau, torque_command_t& msg) {
  msg.utime = stamps.utime;
  msg.reference_utime = stamps.reference_utime;
  msg.reference_sequence = stamps.reference_sequence;
  msg.robot_state_utime = stamps.robot_state_utime;
  msg.status = static_cast<std::int32_t>(status);
  writeBase(info, output.q, output.v, msg);
  for (int i = 0; i < 6; ++i) msg.base_acceleration[i] = info.floating_base ? output.vdot[i] : 0.0;
  msg.num_joints = info.nj;
  copyNames(info, msg.joint_names);
  const Eigen::VectorXd& torques = tau != nullptr ? *tau : output.tau_J;
  msg.tau.resize(static_cast<std::size_t>(info.nj));
  for (int j = 0; j < info.nj; ++j) msg.tau[static_cast<std::size_t>(j)] = torques[j];
  jointsOf(info, output.q, true, msg.q);
  jointsOf(info, output.v, false, msg.qd);
  jointsOf(info, output.vdot, false, msg.qdd);
  return finite(msg.base_position, 3) && finite(msg.base_quaternion, 4) &&
         finite(msg.base_linear_velocity, 3) && finite(msg.base_angular_velocity, 3) &&
         finite(msg.base_acceleration, 6) && finiteVector(msg.tau) && finiteVector(msg.q) &&
         finiteVector(msg.qd) && finiteVector(msg.qdd);
}

void fillContactState(const ModelInfo& info, const FilterOutput& output, std::int64_t utime,
                      contact_state_t& msg) {
  msg.utime = utime;
  const int n = std::max(0, std::min(output.num_contacts, static_cast<int>(output.contacts.size())));
  msg.num_contacts = n;
  // Grown, never shrunk: entries beyond num_contacts are not sent, and keeping them keeps
  // their strings' storage for the next tick.
  if (msg.contacts.size() < static_cast<std::size_t>(n)) msg.contacts.resize(static_cast<std::size_t>(n));
  for (int c = 0; c < n; ++c) {
    const ContactOutput& in = output.contacts[static_cast<std::size_t>(c)];
    contact_t& out = msg.contacts[static_cast<std::size_t>(c)];
    if (in.body >= 0 && static_cast<std::size_t>(in.body) < info.body_names.size())
      out.body_name = info.body_names[static_cast<std::size_t>(in.body)];
    else
      out.body_name.clear();
    out.object = in.object;
    out.kind = static_cast<std::int32_t>(in.kind);
    out.active = 1;
    for (int i = 0; i < 3; ++i) {
      out.point[i] = in.p_WC[i];
      out.normal[i] = in.n_W[i];
    }
    for (int i = 0; i < 6; ++i) out.wrench[i] = in.wrench_W[i];
    out.normal_force = in.normal_force_n;
    out.cop[0] = in.cop_A[0];
    out.cop[1] = in.cop_A[1];
  }
}

namespace {
constexpr const char* kStatusBitNames[] = {
    "contact overflow", "rank deficient", "non-finite solve", "reference invalid",
    "re-seeded",        "impact",         "torque clamped",   "stale reference",
    "QP fallback",      "QP relaxed",     "reference infeasible", "QP iteration cap"};
constexpr int kStatusBitCount = static_cast<int>(sizeof kStatusBitNames / sizeof kStatusBitNames[0]);
}  // namespace

const char* statusBitName(int bit) {
  return bit >= 0 && bit < kStatusBitCount ? kStatusBitNames[bit] : nullptr;
}

void describeStatus(std::uint32_t status, std::string& out) {
  constexpr std::uint32_t kKnownBits = (1u << kStatusBitCount) - 1u;
  out.clear();
  if (status == kStatusOk) {
    out += "ok";
    return;
  }
  for (int bit = 0; bit < kStatusBitCount; ++bit) {
    if ((status & (1u << bit)) == 0) continue;
    if (!out.empty()) out += "; ";
    out += kStatusBitNames[bit];
  }
  if ((status & ~kKnownBits) != 0) {
    if (!out.empty()) out += "; ";
    out += "unknown status bit";
  }
}

void fillFilterStatus(const FilterOutput& output, const StatusReport& report,
                      filter_status_t& msg) {
  constexpr std::size_t kReasonCapacity = 256;
  if (msg.reason.capacity() < kReasonCapacity) msg.reason.reserve(kReasonCapacity);
  const std::uint32_t status = output.status | report.extra_status;
  msg.utime = report.utime;
  msg.status = static_cast<std::int32_t>(status);
  describeStatus(status, msg.reason);
  if (report.detail != nullptr && report.detail[0] != '\0') {
    msg.reason += ": ";
    msg.reason += report.detail;
  }
  if ((output.status & kStatusReseeded) != 0 && output.reseed_reason != ReseedReason::kNone) {
    msg.reason += " (re-seed: ";
    msg.reason += toString(output.reseed_reason);
    msg.reason += ")";
  }
  if ((output.status & (kStatusQpFallback | kStatusQpRelaxed)) != 0 &&
      output.qp_violated != 0) {
    char families[96];
    msg.reason += " (QP violated: ";
    msg.reason += describeQpFamilies(output.qp_violated, families, sizeof families);
    msg.reason += ")";
  }
  msg.mode = report.mode != nullptr ? report.mode : "";
  msg.qp_status = output.qp_status;
  msg.qp_iterations = output.qp_iterations;
  msg.qp_violated = static_cast<std::int32_t>(output.qp_violated);
  msg.qp_solves = static_cast<std::int64_t>(output.counters.qp_solves);
  msg.qp_fallbacks = static_cast<std::int64_t>(output.counters.qp_fallbacks);
  msg.qp_relaxed = static_cast<std::int64_t>(output.counters.qp_relaxed);
  msg.pivot_ticks = static_cast<std::int64_t>(output.counters.pivot_ticks);
  msg.slide_ticks = static_cast<std::int64_t>(output.counters.slide_ticks);
  msg.leash_ticks = static_cast<std::int64_t>(output.counters.leash_ticks);
  const int links = std::max(0, std::min(output.num_contacts, static_cast<int>(output.contacts.size())));
  int rows = report.task_rows;
  for (int c = 0; c < links; ++c) rows += static_cast<int>(output.contacts[static_cast<std::size_t>(c)].kind);
  msg.num_virtual_links = links;
  msg.num_constraint_rows = rows;
  msg.eq12_residual = output.eq12_residual;
  msg.base_residual = output.base_residual_n;
  msg.max_penetration = output.max_penetration_m;
  msg.solve_us = output.solve_time_s * 1e6;
  msg.tick_us = output.tick_time_s * 1e6;
  msg.latency_us = report.latency_us;
  msg.frames_received = report.frames_received;
  msg.frames_accepted = report.frames_accepted;
  msg.frames_rejected = report.frames_rejected;
  msg.frames_dropped = report.frames_dropped;
  msg.ticks = report.ticks;
  msg.missed_ticks = report.missed_ticks;
  msg.reseeds = report.reseeds;
  msg.reference_streams = report.reference_streams;
  msg.states_received = report.states_received;
  msg.states_rejected = report.states_rejected;
  msg.state_streams = report.state_streams;
}

}  // namespace dynfilter::messages
