// The LCM messages and their C++ helpers: round trips through encode/decode, every
// rejection of a received message, the filter's outputs as messages, and message sizes.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <iostream>
#include <limits>
#include <numeric>

#include <gtest/gtest.h>

#include "dynfilter/core/contact_qp.hpp"

#include "lcm/lcm_test_support.hpp"

namespace dynfilter::messages {
namespace {

using test::encoded;
using test::humanInfo;
using test::randomFrame;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

void expectFramesEqual(const ReferenceFrame& a, const ReferenceFrame& b, bool floating_base) {
  EXPECT_DOUBLE_EQ(a.time_s, b.time_s);
  ASSERT_EQ(a.q.size(), b.q.size());
  for (Eigen::Index i = 0; i < a.q.size(); ++i) {
    const bool quaternion = floating_base && i >= 3 && i < 7;  // renormalised: last bit may move
    if (quaternion)
      EXPECT_NEAR(a.q[i], b.q[i], 1e-15) << "q[" << i << "]";
    else
      EXPECT_EQ(a.q[i], b.q[i]) << "q[" << i << "]";
  }
  EXPECT_EQ(a.v, b.v);
  EXPECT_EQ(a.vdot, b.vdot);
}

// Reorders the joints of a message (names and values together) by @p order.
void permuteJoints(reference_frame_t& msg, const std::vector<int>& order) {
  const reference_frame_t copy = msg;
  for (std::size_t i = 0; i < order.size(); ++i) {
    const auto k = static_cast<std::size_t>(order[i]);
    msg.joint_names[i] = copy.joint_names[k];
    msg.q[i] = copy.q[k];
    msg.qd[i] = copy.qd[k];
    msg.qdd[i] = copy.qdd[k];
  }
}

std::vector<int> shuffledOrder(int n, unsigned seed) {
  std::vector<int> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  std::mt19937 rng(seed);
  std::shuffle(order.begin(), order.end(), rng);
  return order;
}

// ---------------------------------------------------------------------------------------
// Reference frames: round trips
// ---------------------------------------------------------------------------------------

TEST(ReferenceFrameMessage, RoundTripsThroughEncodeAndDecode) {
  const ModelInfo& info = humanInfo();
  std::mt19937 rng(1);
  ReferenceFrameReader reader(info);
  ReferenceInput input(info);
  reference_frame_t msg;
  for (int k = 0; k < 5; ++k) {
    const ReferenceFrame frame = randomFrame(info, rng, 1.25 + 0.01 * k);
    const auto utime = static_cast<std::int64_t>(1250000 + 10000 * k);
    fillReferenceFrame(info, frame, utime, 7 + k, msg);
    EXPECT_EQ(msg.num_joints, 32);
    EXPECT_EQ(msg.joint_names, info.joint_names);
    const MessageCheck check = reader.read(encoded(msg).data(), encoded(msg).size(), input);
    ASSERT_TRUE(check.ok()) << check.reason;
    expectFramesEqual(input.frame, frame, true);
    EXPECT_EQ(input.utime, utime);
    EXPECT_EQ(input.sequence, 7 + k);
    EXPECT_FALSE(input.has_task_target);
    EXPECT_EQ(input.num_contact_hints, 0);
  }
}

TEST(ReferenceFrameMessage, FixedBaseModelIgnoresTheBase) {
  const ModelInfo& info = test::armInfo();
  ASSERT_FALSE(info.floating_base);
  std::mt19937 rng(2);
  const ReferenceFrame frame = randomFrame(info, rng, 0.5);
  reference_frame_t msg;
  fillReferenceFrame(info, frame, 500000, 1, msg);
  EXPECT_EQ(msg.base_quaternion[0], 1.0);
  for (double& x : msg.base_quaternion) x = 0.0;  // not a unit quaternion: ignored
  msg.base_position[2] = 3.0;
  ReferenceFrameReader reader(info);
  ReferenceInput input(info);
  const auto bytes = encoded(msg);
  const MessageCheck check = reader.read(bytes.data(), bytes.size(), input);
  ASSERT_TRUE(check.ok()) << check.reason;
  expectFramesEqual(input.frame, frame, false);
  // ...but its numbers must still be finite.
  msg.base_position[0] = kNaN;
  msg.utime += 1000;
  EXPECT_EQ(reader.convert(msg, input).error, MessageError::kNonFinite);
}

// Six frames of a robot described by @p sender, shuffled, the same shuffle again (cached),
// another, in its order, ..., read by @p reader of a model of it: the same joints, or fewer
// with the others locked and last, so that the model's coordinates are the sender's first.
void expectFramesMapInAnyOrder(const ModelInfo& sender, const ModelInfo& model, ReferenceFrameReader& reader,
                               ReferenceInput& input, std::mt19937& rng) {
  for (int k = 0; k < 6; ++k) {
    const ReferenceFrame frame = randomFrame(sender, rng, 0.1 * k);
    reference_frame_t msg;
    fillReferenceFrame(sender, frame, 100000 * k, k, msg);  // utime in µs: time_s 0.1 k
    if (k % 3 != 2) permuteJoints(msg, shuffledOrder(sender.nj, k < 3 ? 11u : 12u));
    const auto bytes = encoded(msg);
    const MessageCheck check = reader.read(bytes.data(), bytes.size(), input);
    ASSERT_TRUE(check.ok()) << k << ": " << check.reason;
    ReferenceFrame expected(model.nq, model.nv);
    expected.time_s = frame.time_s;
    expected.q = frame.q.head(model.nq);
    expected.v = frame.v.head(model.nv);
    expected.vdot = frame.vdot.head(model.nv);
    expectFramesEqual(input.frame, expected, true);
  }
}

TEST(ReferenceFrameMessage, JointNamesInAnyOrderMapToTheModelJoints) {
  const ModelInfo& info = humanInfo();
  std::mt19937 rng(3);
  ReferenceFrameReader reader(info);
  ReferenceInput input(info);
  expectFramesMapInAnyOrder(info, info, reader, input, rng);
}

TEST(ReferenceFrameMessage, AStreamForTheWholeRobotFeedsAModelWithLockedJoints) {
  const test::LockedPair pair;  // the model welds two of the robot's joints (--lock-joints)
  const ModelInfo& whole = pair.whole;
  const ModelInfo& model = pair.model;
  std::mt19937 rng(5);
  ReferenceFrameReader reader(model);
  ReferenceInput input(model);
  expectFramesMapInAnyOrder(whole, model, reader, input, rng);
  // The model's joints alone are a whole message too.
  const ReferenceFrame own = randomFrame(model, rng, 1.0);
  reference_frame_t msg;
  fillReferenceFrame(model, own, 1000000, 9, msg);
  auto bytes = encoded(msg);
  ASSERT_TRUE(reader.read(bytes.data(), bytes.size(), input).ok());
  expectFramesEqual(input.frame, own, true);
  // A locked joint does not stand in for a model joint; nor is it given twice; nor may the
  // robot have more joints than the model and its locked ones.
  const ReferenceFrame full = randomFrame(whole, rng, 2.0);
  fillReferenceFrame(whole, full, 3000, 10, msg);
  reference_frame_t missing = msg;
  missing.joint_names.erase(missing.joint_names.begin());
  missing.q.erase(missing.q.begin());
  missing.qd.erase(missing.qd.begin());
  missing.qdd.erase(missing.qdd.begin());
  missing.num_joints -= 1;
  bytes = encoded(missing);
  EXPECT_EQ(reader.read(bytes.data(), bytes.size(), input).error, MessageError::kWrongJointCount);
  reference_frame_t twice = msg;
  twice.joint_names[static_cast<std::size_t>(model.nj)] = twice.joint_names[static_cast<std::size_t>(model.nj) + 1];
  bytes = encoded(twice);
  const MessageCheck duplicate = reader.read(bytes.data(), bytes.size(), input);
  EXPECT_EQ(duplicate.error, MessageError::kDuplicateJoint);
  EXPECT_EQ(duplicate.index, model.nj + 1);
  // The names cached from a longer message do not vouch for a shorter one that starts alike.
  reference_frame_t longer = msg;
  std::vector<int> locked_first{model.nj, model.nj + 1};
  for (int j = 0; j < model.nj; ++j) locked_first.push_back(j);
  permuteJoints(longer, locked_first);
  bytes = encoded(longer);
  ASSERT_TRUE(reader.read(bytes.data(), bytes.size(), input).ok());
  reference_frame_t shorter = longer;
  for (auto* values : {&shorter.q, &shorter.qd, &shorter.qdd}) values->resize(static_cast<std::size_t>(model.nj));
  shorter.joint_names.resize(static_cast<std::size_t>(model.nj));
  shorter.num_joints = model.nj;
  bytes = encoded(shorter);
  EXPECT_EQ(reader.read(bytes.data(), bytes.size(), input).error, MessageError::kWrongJointCount);
  fillReferenceFrame(model, own, 1000000, 12, msg);
  bytes = encoded(msg);
  ASSERT_TRUE(reader.read(bytes.data(), bytes.size(), input).ok());
  const ModelInfo larger = test::paddedHumanInfo(humanInfo().nj + 3);
  fillReferenceFrame(larger, randomFrame(larger, rng, 3.0), 4000, 11, msg);
  bytes = encoded(msg);
  EXPECT_EQ(reader.read(bytes.data(), bytes.size(), input).error, MessageError::kWrongJointCount);
  expectFramesEqual(input.frame, own, true);  // every rejection left the last good frame
}

TEST(ReferenceFrameMessage, TaskTargetAndContactHintsAreValidatedAndMapped) {
  const ModelInfo& info = humanInfo();
  std::mt19937 rng(4);
  reference_frame_t msg;
  fillReferenceFrame(info, randomFrame(info, rng, 1.0), 1000000, 1, msg);
  msg.has_task_target = 1;
  msg.task_position[0] = 0.1;
  msg.task_position[1] = -0.2;
  msg.task_position[2] = 1.3;
  const double s = 1.0 + 5e-7;  // within the 1e-6 tolerance: accepted, then normalised
  msg.task_quaternion[0] = s * std::cos(0.2);
  msg.task_quaternion[1] = 0.0;
  msg.task_quaternion[2] = 0.0;
  msg.task_quaternion[3] = s * std::sin(0.2);
  const std::string left = info.body_names[info.body_names.size() - 1];
  const std::string right = info.body_names[1];
  msg.num_contact_hints = 2;
  msg.contact_hint_bodies = {left, right};
  msg.contact_hint_active = {1, 0};

  ReferenceFrameReader reader(info);
  ReferenceInput input(info);
  const auto bytes = encoded(msg);
  const MessageCheck check = reader.read(bytes.data(), bytes.size(), input);
  ASSERT_TRUE(check.ok()) << check.reason;
  EXPECT_TRUE(input.has_task_target);
  EXPECT_EQ(input.task_position, Eigen::Vector3d(0.1, -0.2, 1.3));
  EXPECT_NEAR(input.task_quaternion.norm(), 1.0, 1e-15);
  EXPECT_NEAR(input.task_quaternion[0], std::cos(0.2), 1e-15);
  EXPECT_NEAR(input.task_quaternion[3], std::sin(0.2), 1e-15);
  ASSERT_EQ(input.num_contact_hints, 2);
  EXPECT_EQ(input.contact_hint_bodies[0], info.findBody(left));
  EXPECT_EQ(input.contact_hint_bodies[1], info.findBody(right));
  EXPECT_EQ(input.contact_hint_active[0], 1);
  EXPECT_EQ(input.contact_hint_active[1], 0);
}

// ---------------------------------------------------------------------------------------
// Reference frames: every rejection
// ---------------------------------------------------------------------------------------

struct Rejection {
  const char* name;
  std::function<void(reference_frame_t&)> mutate;
  MessageError expected;
  bool encodable;  // false: the message's arrays disagree with its counts (convert() only)
  int index = -1;  // expected MessageCheck::index
};

std::vector<Rejection> referenceRejections(const ModelInfo& info) {
  const std::string body = info.body_names[2];
  std::vector<Rejection> r;
  r.push_back({"one joint missing", [](reference_frame_t& m) {
                 m.num_joints -= 1; m.joint_names.pop_back(); m.q.pop_back(); m.qd.pop_back(); m.qdd.pop_back();
               }, MessageError::kWrongJointCount, true});
  r.push_back({"one joint too many", [](reference_frame_t& m) {
                 m.num_joints += 1; m.joint_names.push_back("extra"); m.q.push_back(0); m.qd.push_back(0); m.qdd.push_back(0);
               }, MessageError::kWrongJointCount, true});
  r.push_back({"no joints", [](reference_frame_t& m) {
                 m.num_joints = 0; m.joint_names.clear(); m.q.clear(); m.qd.clear(); m.qdd.clear();
               }, MessageError::kWrongJointCount, true});
  r.push_back({"count above the names", [](reference_frame_t& m) { m.joint_names.pop_back(); },
               MessageError::kBadCount, false});
  r.push_back({"count above the values", [](reference_frame_t& m) { m.qdd.pop_back(); },
               MessageError::kBadCount, false});
  r.push_back({"negative hint count", [](reference_frame_t& m) { m.num_contact_hints = -1; },
               MessageError::kBadCount, false});
  r.push_back({"hint count above the bodies", [&info](reference_frame_t& m) {
                 const std::size_t n = info.body_names.size() + 1;
                 m.num_contact_hints = static_cast<std::int32_t>(n);
                 m.contact_hint_bodies.assign(n, info.body_names[0]);
                 m.contact_hint_active.assign(n, 1);
               }, MessageError::kBadCount, true});
  r.push_back({"hint count above its arrays", [](reference_frame_t& m) { m.num_contact_hints = 1; },
               MessageError::kBadCount, false});
  r.push_back({"unknown joint", [](reference_frame_t& m) { m.joint_names[5] = "l_kneee"; },
               MessageError::kUnknownJoint, true, 5});
  r.push_back({"joint twice", [](reference_frame_t& m) { m.joint_names[7] = m.joint_names[3]; },
               MessageError::kDuplicateJoint, true, 7});
  r.push_back({"empty joint name", [](reference_frame_t& m) { m.joint_names[0].clear(); },
               MessageError::kUnknownJoint, true, 0});
  r.push_back({"unknown hint body", [body](reference_frame_t& m) {
                 m.num_contact_hints = 2; m.contact_hint_bodies = {body, "no_such_link"}; m.contact_hint_active = {1, 1};
               }, MessageError::kUnknownBody, true, 1});
  r.push_back({"hint body twice", [body](reference_frame_t& m) {
                 m.num_contact_hints = 2; m.contact_hint_bodies = {body, body}; m.contact_hint_active = {1, 0};
               }, MessageError::kDuplicateBody, true, 1});
  r.push_back({"NaN joint position", [](reference_frame_t& m) { m.q[4] = kNaN; },
               MessageError::kNonFinite, true, 4});
  r.push_back({"infinite joint velocity", [](reference_frame_t& m) { m.qd[9] = -kInf; },
               MessageError::kNonFinite, true, 9});
  r.push_back({"NaN joint acceleration", [](reference_frame_t& m) { m.qdd[31] = kNaN; },
               MessageError::kNonFinite, true, 31});
  r.push_back({"NaN base position", [](reference_frame_t& m) { m.base_position[2] = kNaN; },
               MessageError::kNonFinite, true});
  r.push_back({"NaN base quaternion", [](reference_frame_t& m) { m.base_quaternion[0] = kNaN; },
               MessageError::kNonFinite, true});
  r.push_back({"infinite base twist", [](reference_frame_t& m) { m.base_angular_velocity[1] = kInf; },
               MessageError::kNonFinite, true});
  r.push_back({"infinite base acceleration", [](reference_frame_t& m) { m.base_acceleration[5] = kInf; },
               MessageError::kNonFinite, true});
  r.push_back({"NaN in an unused task target", [](reference_frame_t& m) { m.task_position[0] = kNaN; },
               MessageError::kNonFinite, true});
  r.push_back({"base quaternion off by 1e-5", [](reference_frame_t& m) {
                 for (double& x : m.base_quaternion) x *= 1.0 + 1e-5;
               }, MessageError::kNonUnitQuaternion, true});
  r.push_back({"zero base quaternion", [](reference_frame_t& m) {
                 for (double& x : m.base_quaternion) x = 0.0;
               }, MessageError::kNonUnitQuaternion, true});
  r.push_back({"task quaternion not unit", [](reference_frame_t& m) {
                 m.has_task_target = 1; m.task_quaternion[0] = 0.5;
               }, MessageError::kNonUnitQuaternion, true});
  return r;
}

TEST(ReferenceFrameMessage, EveryRejectionLeavesTheOutputAndTheReaderUnchanged) {
  const ModelInfo& info = humanInfo();
  std::mt19937 rng(5);
  const ReferenceFrame first = randomFrame(info, rng, 1.0);
  const ReferenceFrame second = randomFrame(info, rng, 2.0);
  reference_frame_t first_msg, second_msg;
  fillReferenceFrame(info, first, 1000000, 1, first_msg);
  fillReferenceFrame(info, second, 2000000, 2, second_msg);
  // The second frame's names shuffled, so that a failed mapping must not disturb the cache.
  permuteJoints(second_msg, shuffledOrder(info.nj, 99u));

  for (const Rejection& rejection : referenceRejections(info)) {
    for (const bool via_bytes : {false, true}) {
      if (via_bytes && !rejection.encodable) continue;
      SCOPED_TRACE(std::string(rejection.name) + (via_bytes ? " (bytes)" : " (decoded)"));
      ReferenceFrameReader reader(info);
      ReferenceInput input(info);
      ASSERT_TRUE(reader.convert(first_msg, input).ok());
      const ReferenceInput before = input;

      reference_frame_t bad = second_msg;
      rejection.mutate(bad);
      const MessageCheck check = via_bytes ? reader.read(encoded(bad).data(), encoded(bad).size(), input)
                                           : reader.convert(bad, input);
      EXPECT_EQ(check.error, rejection.expected) << toString(check.error) << ": " << check.reason;
      EXPECT_FALSE(check.ok());
      EXPECT_GT(std::strlen(check.reason), 5u);
      if (rejection.index >= 0) {
        EXPECT_EQ(check.index, rejection.index);
      }
      expectFramesEqual(input.frame, before.frame, true);
      EXPECT_EQ(input.utime, before.utime);
      EXPECT_EQ(input.sequence, before.sequence);
      EXPECT_EQ(input.num_contact_hints, before.num_contact_hints);

      // The reader still accepts the next good frame.
      const MessageCheck next = reader.convert(second_msg, input);
      ASSERT_TRUE(next.ok()) << next.reason;
      expectFramesEqual(input.frame, second, true);
    }
  }
}

// When a frame was stamped is the stream policy's matter (realtime/message_stream.hpp,
// tests/realtime): the reader passes any utime on, an hour ahead or back at 0.
TEST(ReferenceFrameMessage, TheReaderPassesEveryUtimeOnToTheStreamPolicy) {
  const ModelInfo& info = humanInfo();
  std::mt19937 rng(6);
  reference_frame_t msg;
  fillReferenceFrame(info, randomFrame(info, rng, 1.0), 1000000, 1, msg);
  ReferenceFrameReader reader(info);
  ReferenceInput input(info);
  const std::int64_t utimes[] = {1000000, 1000000 + 3600000000LL, 999999, 0};
  for (const std::int64_t utime : utimes) {
    msg.utime = utime;
    ASSERT_TRUE(reader.convert(msg, input).ok());
    EXPECT_EQ(input.utime, utime);
    EXPECT_EQ(input.frame.time_s, static_cast<double>(utime) / 1e6);
  }
}

// The bytes of a received message: the counts are checked before the generated decoder
// (which trusts them) sees the message, and malformed bytes never throw.
TEST(ReferenceFrameMessage, MalformedBytesAreRejectedWithoutDecodingOrThrowing) {
  const ModelInfo& info = humanInfo();
  std::mt19937 rng(7);
  reference_frame_t msg;
  fillReferenceFrame(info, randomFrame(info, rng, 1.0), 1000000, 1, msg);
  const std::vector<std::uint8_t> good = encoded(msg);
  ReferenceFrameReader reader(info);
  ReferenceInput input(info);

  const auto readBytes = [&](const std::vector<std::uint8_t>& bytes) {
    return reader.read(bytes.data(), bytes.size(), input);
  };
  // Where the counts are: right after the fixed-size fields (see reference_frame_t.lcm).
  const std::size_t joint_count_at = 8 + 8 + 8 + 8 * 19 + 1 + 8 * 7;
  const auto withInt32 = [&](std::size_t offset, std::uint32_t value) {
    std::vector<std::uint8_t> bytes = good;
    const std::uint8_t big_endian[4] = {
        static_cast<std::uint8_t>(value >> 24), static_cast<std::uint8_t>(value >> 16),
        static_cast<std::uint8_t>(value >> 8), static_cast<std::uint8_t>(value)};
    if (offset + 4 <= bytes.size()) std::memcpy(bytes.data() + offset, big_endian, 4);
    return bytes;
  };
  ASSERT_EQ(withInt32(joint_count_at, 32), good);  // the offset is where the encoder put it
  ASSERT_EQ(withInt32(joint_count_at + 4, 0), good);

  EXPECT_EQ(readBytes(withInt32(joint_count_at, 0x7fffffffu)).error, MessageError::kWrongJointCount);
  EXPECT_EQ(readBytes(withInt32(joint_count_at, 0xffffffffu)).error, MessageError::kWrongJointCount);
  EXPECT_EQ(readBytes(withInt32(joint_count_at + 4, 0x7fffffffu)).error, MessageError::kBadCount);
  EXPECT_EQ(readBytes(withInt32(joint_count_at + 4, 0x80000000u)).error, MessageError::kBadCount);
  // Hint count 1 with no hint in the bytes: runs off the end.
  EXPECT_EQ(readBytes(withInt32(joint_count_at + 4, 1)).error, MessageError::kMalformed);

  // The first joint name's length field: 0 and negative lengths, one past the end.
  const std::size_t name_length_at = joint_count_at + 8;
  for (const std::uint32_t length : {0u, 0xffffffffu, 0x80000000u, 100000u}) {
    const MessageCheck check = readBytes(withInt32(name_length_at, length));
    EXPECT_EQ(check.error, MessageError::kMalformed) << length;
  }
  // Truncated anywhere, empty, a null pointer.
  for (const std::size_t size : {std::size_t{0}, std::size_t{7}, std::size_t{100}, joint_count_at + 6,
                                 good.size() / 2, good.size() - 1}) {
    const std::vector<std::uint8_t> truncated(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(size));
    EXPECT_EQ(readBytes(truncated).error, MessageError::kMalformed) << size;
  }
  EXPECT_EQ(reader.read(nullptr, 0, input).error, MessageError::kMalformed);
  // Another message type on the channel.
  robot_state_t state;
  fillRobotState(info, 1, info.neutralConfiguration(), Eigen::VectorXd::Zero(info.nv), nullptr, state);
  EXPECT_EQ(readBytes(encoded(state)).error, MessageError::kMalformed);
  // Random garbage.
  std::uniform_int_distribution<int> byte(0, 255);
  for (int k = 0; k < 200; ++k) {
    std::vector<std::uint8_t> garbage = good;
    for (int flips = 0; flips < 8; ++flips)
      garbage[std::uniform_int_distribution<std::size_t>(8, garbage.size() - 1)(rng)] =
          static_cast<std::uint8_t>(byte(rng));
    (void)readBytes(garbage);  // any outcome but a crash or an exception
  }
  const MessageCheck check = readBytes(good);
  EXPECT_TRUE(check.ok()) << check.reason;
}

TEST(MessageError, EveryValueHasAName) {
  for (int e = 0; e <= static_cast<int>(MessageError::kNonUnitQuaternion); ++e)
    EXPECT_EQ(std::string(toString(static_cast<MessageError>(e))).rfind('k', 0), 0u);
}

// ---------------------------------------------------------------------------------------
// Robot states
// ---------------------------------------------------------------------------------------

TEST(RobotStateMessage, RoundTripsAndMapsShuffledNames) {
  const ModelInfo& info = humanInfo();
  std::mt19937 rng(8);
  RobotStateReader reader(info);
  RobotStateInput input(info);
  for (int k = 0; k < 4; ++k) {
    Eigen::VectorXd q, v;
    randomState(info, rng, 1.0, q, v);
    const Eigen::VectorXd tau = Eigen::VectorXd::LinSpaced(info.nj, -50.0, 50.0);
    robot_state_t msg;
    fillRobotState(info, 1000 * k, q, v, &tau, msg);
    if (k >= 2) {  // shuffled names with their values
      const robot_state_t copy = msg;
      const std::vector<int> order = shuffledOrder(info.nj, 3u);
      for (std::size_t i = 0; i < order.size(); ++i) {
        const auto j = static_cast<std::size_t>(order[i]);
        msg.joint_names[i] = copy.joint_names[j];
        msg.q[i] = copy.q[j];
        msg.qd[i] = copy.qd[j];
        msg.tau[i] = copy.tau[j];
      }
    }
    const auto bytes = encoded(msg);
    const MessageCheck check = reader.read(bytes.data(), bytes.size(), input);
    ASSERT_TRUE(check.ok()) << check.reason;
    EXPECT_EQ(input.utime, 1000 * k);
    EXPECT_TRUE(input.q.head<3>() == q.head<3>());
    EXPECT_LT((input.q.segment<4>(3) - q.segment<4>(3)).cwiseAbs().maxCoeff(), 1e-15);
    EXPECT_TRUE(input.q.tail(info.nj) == q.tail(info.nj));
    EXPECT_EQ(input.v, v);
    EXPECT_EQ(input.tau, tau);
  }
}

TEST(RobotStateMessage, AStateOfTheWholeRobotFeedsAModelWithLockedJoints) {
  const test::LockedPair pair;
  RobotStateReader reader(pair.model);
  RobotStateInput input(pair.model);
  Eigen::VectorXd q, v;
  std::mt19937 rng(9);
  randomState(pair.whole, rng, 1.0, q, v);
  const Eigen::VectorXd tau = Eigen::VectorXd::LinSpaced(pair.whole.nj, -50.0, 50.0);
  robot_state_t msg;
  fillRobotState(pair.whole, 1000, q, v, &tau, msg);
  const auto bytes = encoded(msg);
  const MessageCheck check = reader.read(bytes.data(), bytes.size(), input);
  ASSERT_TRUE(check.ok()) << check.reason;
  EXPECT_TRUE(input.q.tail(pair.model.nj) == q.segment(7, pair.model.nj));
  EXPECT_EQ(input.v, v.head(pair.model.nv));
  EXPECT_EQ(input.tau, tau.head(pair.model.nj));
}

TEST(RobotStateMessage, EveryRejectionLeavesTheOutputUnchanged) {
  const ModelInfo& info = humanInfo();
  std::mt19937 rng(9);
  Eigen::VectorXd q, v;
  randomState(info, rng, 1.0, q, v);
  robot_state_t good;
  fillRobotState(info, 2000, q, v, nullptr, good);

  struct Case {
    const char* name;
    std::function<void(robot_state_t&)> mutate;
    MessageError expected;
    bool encodable;
  };
  const std::vector<Case> cases = {
      {"joint missing", [](robot_state_t& m) {
         m.num_joints -= 1; m.joint_names.pop_back(); m.q.pop_back(); m.qd.pop_back(); m.tau.pop_back();
       }, MessageError::kWrongJointCount, true},
      {"count above the values", [](robot_state_t& m) { m.tau.pop_back(); }, MessageError::kBadCount, false},
      {"unknown joint", [](robot_state_t& m) { m.joint_names[0] = "tail"; }, MessageError::kUnknownJoint, true},
      {"joint twice", [](robot_state_t& m) { m.joint_names[1] = m.joint_names[0]; }, MessageError::kDuplicateJoint, true},
      {"NaN position", [](robot_state_t& m) { m.q[3] = kNaN; }, MessageError::kNonFinite, true},
      {"infinite torque", [](robot_state_t& m) { m.tau[3] = kInf; }, MessageError::kNonFinite, true},
      {"NaN base twist", [](robot_state_t& m) { m.base_linear_velocity[0] = kNaN; }, MessageError::kNonFinite, true},
      {"non-unit quaternion", [](robot_state_t& m) { m.base_quaternion[1] += 1e-3; }, MessageError::kNonUnitQuaternion, true},
  };
  for (const Case& c : cases) {
    for (const bool via_bytes : {false, true}) {
      if (via_bytes && !c.encodable) continue;
      SCOPED_TRACE(std::string(c.name) + (via_bytes ? " (bytes)" : " (decoded)"));
      RobotStateReader reader(info);
      RobotStateInput input(info);
      robot_state_t first = good;
      first.utime = 1000;
      ASSERT_TRUE(reader.convert(first, input).ok());
      const RobotStateInput before = input;
      robot_state_t bad = good;
      c.mutate(bad);
      const MessageCheck check =
          via_bytes ? reader.read(encoded(bad).data(), encoded(bad).size(), input) : reader.convert(bad, input);
      EXPECT_EQ(check.error, c.expected) << check.reason;
      EXPECT_EQ(input.q, before.q);
      EXPECT_EQ(input.v, before.v);
      EXPECT_EQ(input.tau, before.tau);
      EXPECT_EQ(input.utime, 1000);
      EXPECT_TRUE(reader.convert(good, input).ok());
    }
  }
  // Bytes: counts first, then the decoder.
  RobotStateReader reader(info);
  RobotStateInput input(info);
  std::vector<std::uint8_t> bytes = encoded(good);
  const std::size_t count_at = 8 + 8 + 8 * 13;
  ASSERT_EQ(bytes[count_at + 3], 32);
  bytes[count_at] = 0x7f;
  EXPECT_EQ(reader.read(bytes.data(), bytes.size(), input).error, MessageError::kWrongJointCount);
  bytes = encoded(good);
  EXPECT_EQ(reader.read(bytes.data(), bytes.size() - 3, input).error, MessageError::kMalformed);
  reference_frame_t other;
  fillReferenceFrame(info, ReferenceFrame(info.nq, info.nv), 0, 0, other);
  EXPECT_EQ(reader.read(encoded(other).data(), encoded(other).size(), input).error, MessageError::kMalformed);
}

// ---------------------------------------------------------------------------------------
// The filter's outputs as messages
// ---------------------------------------------------------------------------------------

FilterOutput sampleOutput(const ModelInfo& info, std::mt19937& rng) {
  FilterOutput out(info.nq, info.nv, info.nj, 8);
  randomState(info, rng, 1.0, out.q, out.v);
  out.vdot = Eigen::VectorXd::LinSpaced(info.nv, -3.0, 3.0);
  out.tau_J = Eigen::VectorXd::LinSpaced(info.nj, -100.0, 100.0);
  out.num_contacts = 2;
  for (int c = 0; c < 2; ++c) {
    ContactOutput& contact = out.contacts[static_cast<std::size_t>(c)];
    contact.body = info.findBody(c == 0 ? info.body_names[3] : info.body_names.back());
    contact.object = c == 0 ? kGroundObject : 0;
    contact.kind = c == 0 ? ContactKind::kFace : ContactKind::kEdge;
    contact.p_WC = Eigen::Vector3d(0.1 * c, -0.1, 0.001);
    contact.n_W = Eigen::Vector3d(0.0, std::sin(0.1), std::cos(0.1));
    contact.wrench_W << 1.0 + c, 2.0, 400.0, 0.5, -0.25, 0.125;
    contact.normal_force_n = 399.5 + c;
    contact.cop_A = Eigen::Vector2d(0.02, -0.01 * c);
  }
  out.eq12_residual = 3e-9;
  out.base_residual_n = 1e-12;
  out.max_penetration_m = 4e-4;
  out.solve_time_s = 85e-6;
  out.tick_time_s = 410e-6;
  return out;
}

TEST(TorqueCommandMessage, CarriesTheTickInModelOrderAndRoundTrips) {
  const ModelInfo& info = humanInfo();
  std::mt19937 rng(10);
  const FilterOutput out = sampleOutput(info, rng);
  CommandStamps stamps;
  stamps.utime = 5000123;
  stamps.reference_utime = 1004000;
  stamps.reference_sequence = 42;
  stamps.robot_state_utime = 0;
  torque_command_t msg;
  ASSERT_TRUE(fillTorqueCommand(info, out, stamps, kStatusImpact, nullptr, msg));
  torque_command_t back;
  const auto bytes = encoded(msg);
  ASSERT_EQ(back.decode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  EXPECT_EQ(back.utime, 5000123);
  EXPECT_EQ(back.reference_utime, 1004000);
  EXPECT_EQ(back.reference_sequence, 42);
  EXPECT_EQ(back.robot_state_utime, 0);
  EXPECT_EQ(back.status, static_cast<std::int32_t>(kStatusImpact));
  EXPECT_EQ(back.num_joints, info.nj);
  EXPECT_EQ(back.joint_names, info.joint_names);
  for (int j = 0; j < info.nj; ++j) {
    const auto k = static_cast<std::size_t>(j);
    EXPECT_EQ(back.tau[k], out.tau_J[j]);
    EXPECT_EQ(back.q[k], out.q[info.configurationIndex(j)]);
    EXPECT_EQ(back.qd[k], out.v[info.velocityIndex(j)]);
    EXPECT_EQ(back.qdd[k], out.vdot[info.velocityIndex(j)]);
  }
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(back.base_position[i], out.q[i]);
    EXPECT_EQ(back.base_linear_velocity[i], out.v[i]);
    EXPECT_EQ(back.base_angular_velocity[i], out.v[3 + i]);
  }
  for (int i = 0; i < 4; ++i) EXPECT_EQ(back.base_quaternion[i], out.q[3 + i]);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(back.base_acceleration[i], out.vdot[i]);

  // The clamped torques when given; a non-finite number means "do not publish".
  const Eigen::VectorXd clamped = out.tau_J.cwiseMax(-50.0).cwiseMin(50.0);
  ASSERT_TRUE(fillTorqueCommand(info, out, stamps, 0, &clamped, msg));
  EXPECT_EQ(*std::max_element(msg.tau.begin(), msg.tau.end()), 50.0);
  Eigen::VectorXd bad = clamped;
  bad[7] = kNaN;
  EXPECT_FALSE(fillTorqueCommand(info, out, stamps, 0, &bad, msg));
  FilterOutput bad_state = out;
  bad_state.v[2] = kInf;
  EXPECT_FALSE(fillTorqueCommand(info, bad_state, stamps, 0, nullptr, msg));
}

TEST(ContactStateMessage, NamesBodiesAndCarriesTheWrenches) {
  const ModelInfo& info = humanInfo();
  std::mt19937 rng(11);
  FilterOutput out = sampleOutput(info, rng);
  contact_state_t msg;
  fillContactState(info, out, 777, msg);
  contact_state_t back;
  auto bytes = encoded(msg);
  ASSERT_EQ(back.decode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  EXPECT_EQ(back.utime, 777);
  ASSERT_EQ(back.num_contacts, 2);
  for (int c = 0; c < 2; ++c) {
    const ContactOutput& in = out.contacts[static_cast<std::size_t>(c)];
    const contact_t& m = back.contacts[static_cast<std::size_t>(c)];
    EXPECT_EQ(m.body_name, info.body_names[static_cast<std::size_t>(in.body)]);
    EXPECT_EQ(m.object, in.object);
    EXPECT_EQ(m.kind, static_cast<int>(in.kind));
    EXPECT_EQ(m.active, 1);
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(m.point[i], in.p_WC[i]);
      EXPECT_EQ(m.normal[i], in.n_W[i]);
    }
    for (int i = 0; i < 6; ++i) EXPECT_EQ(m.wrench[i], in.wrench_W[i]);
    EXPECT_EQ(m.normal_force, in.normal_force_n);
    EXPECT_EQ(m.cop[0], in.cop_A[0]);
    EXPECT_EQ(m.cop[1], in.cop_A[1]);
  }
  // Fewer contacts next tick: only those are sent.
  out.num_contacts = 1;
  fillContactState(info, out, 778, msg);
  bytes = encoded(msg);
  ASSERT_GT(back.decode(bytes.data(), 0, static_cast<int>(bytes.size())), 0);
  EXPECT_EQ(back.num_contacts, 1);
  EXPECT_EQ(back.contacts.size(), 1u);
  out.num_contacts = 0;
  fillContactState(info, out, 779, msg);
  bytes = encoded(msg);
  ASSERT_GT(back.decode(bytes.data(), 0, static_cast<int>(bytes.size())), 0);
  EXPECT_EQ(back.num_contacts, 0);
}

TEST(FilterStatusMessage, ReportsBitsReasonSolverTimingsAndCounters) {
  const ModelInfo& info = humanInfo();
  std::mt19937 rng(12);
  FilterOutput out = sampleOutput(info, rng);
  out.status = kStatusReferenceInvalid;
  StatusReport report;
  report.utime = 123456789;
  report.extra_status = kStatusTorqueClamped;
  report.detail = "unknown joint name";
  report.task_rows = 6;
  report.latency_us = 1500.5;
  report.frames_received = 100;
  report.frames_accepted = 97;
  report.frames_rejected = 2;
  report.frames_dropped = 1;
  report.ticks = 1000;
  report.missed_ticks = 3;
  report.reseeds = 1;
  report.reference_streams = 3;
  report.states_received = 900;
  report.states_rejected = 4;
  report.state_streams = 2;
  filter_status_t msg;
  fillFilterStatus(out, report, msg);
  filter_status_t back;
  const auto bytes = encoded(msg);
  ASSERT_EQ(back.decode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  EXPECT_EQ(back.utime, 123456789);
  EXPECT_EQ(back.status, static_cast<std::int32_t>(kStatusReferenceInvalid | kStatusTorqueClamped));
  EXPECT_EQ(back.reason, "reference invalid; torque clamped: unknown joint name");
  EXPECT_EQ(back.mode, "paper");
  EXPECT_EQ(back.num_virtual_links, 2);
  EXPECT_EQ(back.num_constraint_rows, 6 + 5 + 6);
  EXPECT_EQ(back.eq12_residual, 3e-9);
  EXPECT_EQ(back.base_residual, 1e-12);
  EXPECT_EQ(back.max_penetration, 4e-4);
  EXPECT_NEAR(back.solve_us, 85.0, 1e-9);
  EXPECT_NEAR(back.tick_us, 410.0, 1e-9);
  EXPECT_EQ(back.latency_us, 1500.5);
  EXPECT_EQ(back.frames_received, 100);
  EXPECT_EQ(back.frames_accepted, 97);
  EXPECT_EQ(back.frames_rejected, 2);
  EXPECT_EQ(back.frames_dropped, 1);
  EXPECT_EQ(back.ticks, 1000);
  EXPECT_EQ(back.missed_ticks, 3);
  EXPECT_EQ(back.reseeds, 1);
  EXPECT_EQ(back.reference_streams, 3);
  EXPECT_EQ(back.states_received, 900);
  EXPECT_EQ(back.states_rejected, 4);
  EXPECT_EQ(back.state_streams, 2);

  out.status = kStatusOk;
  report = StatusReport{};
  report.mode = "qp";
  fillFilterStatus(out, report, msg);
  EXPECT_EQ(msg.reason, "ok");
  EXPECT_EQ(msg.mode, "qp");
  std::string all;
  describeStatus(0xffffffffu, all);
  EXPECT_EQ(all, "contact overflow; rank deficient; non-finite solve; reference invalid; re-seeded; "
                 "impact; torque clamped; stale reference; QP fallback; QP relaxed; reference infeasible; "
                 "QP iteration cap; "
                 "unknown status bit");

  // QP mode: the relaxation's violated families and the re-seed reason are in the reason;
  // the solver fields and counters are carried.
  out.status = kStatusQpRelaxed | kStatusReseeded;
  out.qp_status = 2;
  out.qp_iterations = 17;
  out.qp_violated = kQpFamilyFriction | kQpFamilyTorque;
  out.reseed_reason = ReseedReason::kJoint;
  out.counters.qp_solves = 1234;
  out.counters.qp_fallbacks = 5;
  out.counters.qp_relaxed = 41;
  out.counters.pivot_ticks = 7;
  out.counters.slide_ticks = 9;
  out.counters.leash_ticks = 11;
  fillFilterStatus(out, report, msg);
  EXPECT_EQ(msg.reason, "re-seeded; QP relaxed (re-seed: joint error) (QP violated: friction,torque)");
  EXPECT_EQ(msg.qp_status, 2);
  EXPECT_EQ(msg.qp_iterations, 17);
  EXPECT_EQ(msg.qp_violated, static_cast<std::int32_t>(kQpFamilyFriction | kQpFamilyTorque));
  EXPECT_EQ(msg.qp_solves, 1234);
  EXPECT_EQ(msg.qp_fallbacks, 5);
  EXPECT_EQ(msg.qp_relaxed, 41);
  EXPECT_EQ(msg.pivot_ticks, 7);
  EXPECT_EQ(msg.slide_ticks, 9);
  EXPECT_EQ(msg.leash_ticks, 11);
}

// ---------------------------------------------------------------------------------------
// Sizes: every message of a 40-joint model fits well inside one UDP datagram.
// ---------------------------------------------------------------------------------------

TEST(MessageSizes, FortyJointMessagesAreWellUnderOneDatagram) {
  constexpr int kLimitBytes = 16 * 1024;
  const ModelInfo info = test::paddedHumanInfo(40);
  ASSERT_EQ(info.nj, 40);
  std::mt19937 rng(13);

  // Largest reference frame: task target and a hint for every body.
  reference_frame_t reference;
  fillReferenceFrame(info, randomFrame(info, rng, 1.0), 1, 1, reference);
  reference.has_task_target = 1;
  reference.num_contact_hints = static_cast<std::int32_t>(info.body_names.size());
  reference.contact_hint_bodies = info.body_names;
  reference.contact_hint_active.assign(info.body_names.size(), 1);
  // ...and it is still accepted by the 40-joint reader.
  {
    ReferenceFrameReader reader(info);
    ReferenceInput input(info);
    const auto bytes = encoded(reference);
    const MessageCheck check = reader.read(bytes.data(), bytes.size(), input);
    EXPECT_TRUE(check.ok()) << check.reason;
  }
  robot_state_t state;
  Eigen::VectorXd q, v;
  randomState(info, rng, 1.0, q, v);
  fillRobotState(info, 1, q, v, nullptr, state);
  // Eight virtual links (the default max_links), the longest body names.
  FilterOutput out = sampleOutput(info, rng);
  out.num_contacts = 8;
  std::vector<std::string> longest = info.body_names;
  std::sort(longest.begin(), longest.end(),
            [](const std::string& a, const std::string& b) { return a.size() > b.size(); });
  for (int c = 0; c < 8; ++c)
    out.contacts[static_cast<std::size_t>(c)].body = info.findBody(longest[static_cast<std::size_t>(c)]);
  torque_command_t command;
  ASSERT_TRUE(fillTorqueCommand(info, out, CommandStamps{}, 0, nullptr, command));
  contact_state_t contacts;
  fillContactState(info, out, 1, contacts);
  filter_status_t status;
  StatusReport report;
  report.detail = "joint name given twice";
  out.status = 0xff;
  fillFilterStatus(out, report, status);

  const std::vector<std::pair<const char*, int>> sizes = {
      {"reference_frame_t", reference.getEncodedSize()},
      {"robot_state_t", state.getEncodedSize()},
      {"torque_command_t", command.getEncodedSize()},
      {"contact_state_t", contacts.getEncodedSize()},
      {"filter_status_t", status.getEncodedSize()},
  };
  for (const auto& [name, size] : sizes) {
    std::cout << "  " << name << ": " << size << " bytes for 40 joints\n";
    testing::Test::RecordProperty(std::string(name) + "_bytes", size);
    EXPECT_LT(size, kLimitBytes) << name;
    EXPECT_GT(size, 0) << name;
  }
  EXPECT_EQ(static_cast<int>(encoded(reference).size()), reference.getEncodedSize());
}

}  // namespace
}  // namespace dynfilter::messages
