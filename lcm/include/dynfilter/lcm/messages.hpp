#pragma once
/// @file
/// Conversions between the core's structs and the LCM messages of package `dynfilter`
/// (lcmtypes/*.lcm), for the real-time processes and their tests.
///
/// Receiving (reference frames, robot states) is the per-tick path: nothing here throws,
/// and once the first frame has been accepted nothing allocates as long as the joint
/// names keep coming in the same order (any order, as long as it repeats). Every check
/// returns a MessageCheck: an enum, a static reason string and the offending entry. A
/// rejected message leaves the output and the reader's state untouched. The readers check
/// what a message says, not when: whether a stamp belongs to the stream the loop follows
/// (a restarted sender, a wrong clock, a stray old message) is the real-time layer's
/// stream policy (dynfilter/realtime/message_stream.hpp), which knows the receive time.
///
/// Sending: the fill functions write into a reused message (no allocation once its
/// vectors and strings have their size), and encodeMessage() into a reused byte buffer
/// for lcm::LCM::publish(channel, data, size).

#include <cstddef>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "dynfilter/contact_state_t.hpp"
#include "dynfilter/core/filter_output.hpp"
#include "dynfilter/core/model_info.hpp"
#include "dynfilter/core/reference_frame.hpp"
#include "dynfilter/filter_status_t.hpp"
#include "dynfilter/reference_frame_t.hpp"
#include "dynfilter/robot_state_t.hpp"
#include "dynfilter/torque_command_t.hpp"

namespace dynfilter::messages {

/// Default channel names (the processes make them configurable).
inline constexpr const char* kReferenceChannel = "DYNFILTER_REFERENCE";
inline constexpr const char* kRobotStateChannel = "DYNFILTER_ROBOT_STATE";
inline constexpr const char* kTorqueCommandChannel = "DYNFILTER_TORQUE_COMMAND";
inline constexpr const char* kContactStateChannel = "DYNFILTER_CONTACT_STATE";
inline constexpr const char* kFilterStatusChannel = "DYNFILTER_STATUS";

/// Why a received message was rejected.
enum class MessageError : int {
  kOk = 0,
  kMalformed,           ///< not a complete, well-formed message of the expected type
  kWrongJointCount,     ///< num_joints differs from the model's number of joints
  kBadCount,            ///< a count is negative, too large, or longer than its array
  kUnknownJoint,        ///< a joint name the model does not have
  kDuplicateJoint,      ///< a joint name given twice
  kUnknownBody,         ///< a contact hint names a link the model does not have
  kDuplicateBody,       ///< a contact hint names a link twice
  kNonFinite,           ///< a NaN or infinite number
  kNonUnitQuaternion,   ///< a quaternion whose norm is off 1 by more than 1e-6
};

/// Name of the enum value, e.g. "kUnknownJoint" (static string).
const char* toString(MessageError error);

/// Outcome of receiving one message. Never allocates.
struct MessageCheck {
  MessageError error = MessageError::kOk;
  /// Short static description, e.g. "unknown joint name".
  const char* reason = "ok";
  /// The offending entry of the message: the position in joint_names (or in the contact
  /// hints for body errors); -1 when it is a base or message-wide field.
  int index = -1;

  bool ok() const { return error == MessageError::kOk; }
};

/// Maps the joint names of a message to the model's joint indices. The last successful
/// mapping is cached: names equal to the previous message's cost one string comparison
/// each and no allocation. A message names every joint of the model once, in any order,
/// and may also name joints the model has locked (ModelInfo::locked_joint_names): a stream
/// for the whole robot feeds a model with some joints welded; their values are not read.
class JointNameMap {
 public:
  explicit JointNameMap(const ModelInfo& info);

  /// Maps names[0..count). On success indices()[i] is the model joint of names[i], or −1
  /// for a locked joint. Fails with kWrongJointCount, kBadCount, kUnknownJoint or
  /// kDuplicateJoint.
  MessageCheck map(const std::vector<std::string>& names, int count);
  /// Model joint index of each message entry after a successful map() (first count used).
  const std::vector<int>& indices() const { return indices_; }
  /// Most entries a message may have: the model's joints and the joints it locks.
  int maxCount() const { return nj_ + locked_; }

 private:
  int nj_;
  int locked_ = 0;
  std::unordered_map<std::string, int> by_name_;
  std::vector<std::string> cached_names_;
  int cached_count_ = -1;  // entries of the cached names; −1: none yet
  std::vector<int> indices_, scratch_;
  std::vector<unsigned char> seen_;
};

/// A received reference frame in the model's coordinates plus what the core's
/// ReferenceFrame does not carry.
struct ReferenceInput {
  ReferenceFrame frame;          ///< time_s = utime / 10⁶ (sender's clock)
  std::int64_t utime = 0;
  std::int64_t sequence = 0;
  bool has_task_target = false;
  Eigen::Vector3d task_position = Eigen::Vector3d::Zero();  ///< world (m)
  Eigen::Vector4d task_quaternion{1.0, 0.0, 0.0, 0.0};      ///< (w, x, y, z), normalised
  int num_contact_hints = 0;
  std::vector<int> contact_hint_bodies;  ///< capacity: number of bodies; first num valid
  std::vector<unsigned char> contact_hint_active;  ///< 1: meant to be in contact

  ReferenceInput() = default;
  /// Sized for @p info.
  explicit ReferenceInput(const ModelInfo& info);
};

/// Receives reference_frame_t messages for one model: decodes, validates, converts.
class ReferenceFrameReader {
 public:
  explicit ReferenceFrameReader(const ModelInfo& info);

  /// One received message (the bytes of an lcm::ReceiveBuffer). The fingerprint and the
  /// counts are checked against the model before any array is decoded; the message is
  /// decoded into a reused object, then validated as by convert().
  MessageCheck read(const void* data, std::size_t size, ReferenceInput& out);

  /// Validates a decoded message and, when valid, writes it into @p out (which must be
  /// sized for the model, see ReferenceInput(const ModelInfo&)). Checks, in order: counts
  /// (joint count equal to the model's, hint count within the bodies, arrays as long as
  /// their counts), joint names (known, each once, any order), hint bodies (known, each
  /// once), finite numbers, unit base quaternion (floating base) and task quaternion
  /// (when has_task_target) within 1e-6 — then normalised.
  MessageCheck convert(const reference_frame_t& msg, ReferenceInput& out);

  /// The message decoded by the last read(), valid or not.
  const reference_frame_t& message() const { return message_; }

 private:
  ModelInfo info_;
  JointNameMap names_;
  std::unordered_map<std::string, int> body_by_name_;
  std::vector<int> hint_scratch_;
  std::vector<unsigned char> body_seen_;
  reference_frame_t message_;
};

/// A received robot state in the model's coordinates.
struct RobotStateInput {
  std::int64_t utime = 0;
  Eigen::VectorXd q;    ///< dim nq
  Eigen::VectorXd v;    ///< dim nv
  Eigen::VectorXd tau;  ///< dim nj, measured joint torques (0 when not measured)

  RobotStateInput() = default;
  explicit RobotStateInput(const ModelInfo& info);
};

/// Receives robot_state_t messages for one model, like ReferenceFrameReader.
class RobotStateReader {
 public:
  explicit RobotStateReader(const ModelInfo& info);

  MessageCheck read(const void* data, std::size_t size, RobotStateInput& out);
  /// Checks counts, names, finite numbers and the unit base quaternion (floating base,
  /// then normalised).
  MessageCheck convert(const robot_state_t& msg, RobotStateInput& out);

  const robot_state_t& message() const { return message_; }

 private:
  ModelInfo info_;
  JointNameMap names_;
  robot_state_t message_;
};

// ---------------------------------------------------------------------------------------
// Sending
// ---------------------------------------------------------------------------------------

/// A reference frame in the model's coordinates as a message: names in model order, no
/// task target, no contact hints. For a fixed-base model the base is the identity pose.
void fillReferenceFrame(const ModelInfo& info, const ReferenceFrame& frame, std::int64_t utime,
                        std::int64_t sequence, reference_frame_t& msg);

/// A robot state (q: nq, v: nv) as a message; @p tau (dim nj) may be null (zeros).
void fillRobotState(const ModelInfo& info, std::int64_t utime,
                    const Eigen::Ref<const Eigen::VectorXd>& q,
                    const Eigen::Ref<const Eigen::VectorXd>& v, const Eigen::VectorXd* tau,
                    robot_state_t& msg);

/// What a torque command answers.
struct CommandStamps {
  std::int64_t utime = 0;               ///< the tick (filter's clock, µs)
  std::int64_t reference_utime = 0;     ///< newest reference frame used
  std::int64_t reference_sequence = 0;  ///< its sequence number
  std::int64_t robot_state_utime = 0;   ///< robot state the tick started from; 0 if none
};

/// The tick's command: @p tau (dim nj; null → output.tau_J, e.g. pass the clamped
/// RealtimeFilter::command()) and the filtered q, v, v̇. @p status is written to the
/// message as is. Returns false when any number written is not finite: do not publish.
bool fillTorqueCommand(const ModelInfo& info, const FilterOutput& output,
                       const CommandStamps& stamps, std::uint32_t status,
                       const Eigen::VectorXd* tau, torque_command_t& msg);

/// The tick's contacts (the first output.num_contacts), body names from
/// ModelInfo::body_names.
void fillContactState(const ModelInfo& info, const FilterOutput& output, std::int64_t utime,
                      contact_state_t& msg);

/// What filter_status_t carries beyond the tick's FilterOutput.
struct StatusReport {
  std::int64_t utime = 0;
  std::uint32_t extra_status = 0;  ///< OR-ed into output.status (e.g. RealtimeFilter::status())
  const char* detail = nullptr;    ///< appended to the reason, e.g. a MessageCheck::reason
  const char* mode = "paper";      ///< "paper" or "qp"
  int task_rows = 0;               ///< constraint rows of the task point (Eq. 16), if any
  double latency_us = 0.0;
  std::int64_t frames_received = 0;
  std::int64_t frames_accepted = 0;
  std::int64_t frames_rejected = 0;
  std::int64_t frames_dropped = 0;
  std::int64_t ticks = 0;
  std::int64_t missed_ticks = 0;
  std::int64_t reseeds = 0;
  std::int64_t reference_streams = 0;
  std::int64_t states_received = 0;
  std::int64_t states_rejected = 0;
  std::int64_t state_streams = 0;
};

/// Short description of each set bit, "; "-separated ("ok" for 0), into @p out without
/// allocating once @p out has the capacity (fillFilterStatus reserves it).
void describeStatus(std::uint32_t status, std::string& out);

/// The name of status bit @p bit (0-based, FilterStatusBits order), nullptr if unknown.
const char* statusBitName(int bit);

/// The status message: status bits and reason ("<bits>: <detail>"), solver size (virtual
/// links and their constraint rows: 3, 5 or 6 per link, plus task_rows), residuals,
/// timings (µs) and counters.
void fillFilterStatus(const FilterOutput& output, const StatusReport& report,
                      filter_status_t& msg);

/// Encodes @p msg into @p buffer (grown when too small, never shrunk). Returns the number
/// of bytes to publish, or a negative number on failure.
template <class Message>
int encodeMessage(const Message& msg, std::vector<std::uint8_t>& buffer) {
  const int size = msg.getEncodedSize();
  if (size < 0) return -1;
  if (buffer.size() < static_cast<std::size_t>(size)) buffer.resize(static_cast<std::size_t>(size));
  return msg.encode(buffer.data(), 0, size);
}

}  // namespace dynfilter::messages
