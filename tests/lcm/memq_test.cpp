// Messages through a real lcm::LCM on the in-process memq:// provider (no network): what
// arrives, decoded into a reused message and validated, is what was sent.
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "lcm/lcm_test_support.hpp"

namespace dynfilter::messages {
namespace {

// A raw (untyped) handler: lcm-cpp's typed handlers decode into a new message per call.
struct ReferenceReceiver {
  explicit ReferenceReceiver(const ModelInfo& info) : reader(info), input(info) {}
  void onMessage(const ::lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    ++received;
    last_channel = channel;
    check = reader.read(rbuf->data, rbuf->data_size, input);
  }
  ReferenceFrameReader reader;
  ReferenceInput input;
  MessageCheck check;
  int received = 0;
  std::string last_channel;
};

struct StateReceiver {
  explicit StateReceiver(const ModelInfo& info) : reader(info), input(info) {}
  void onMessage(const ::lcm::ReceiveBuffer* rbuf, const std::string&) {
    ++received;
    check = reader.read(rbuf->data, rbuf->data_size, input);
  }
  RobotStateReader reader;
  RobotStateInput input;
  MessageCheck check;
  int received = 0;
};

TEST(LcmMemq, AReferenceFrameArrivesDecodedAndValidated) {
  const ModelInfo& info = test::humanInfo();
  ::lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  ReferenceReceiver receiver(info);
  ASSERT_NE(lcm.subscribe(kReferenceChannel, &ReferenceReceiver::onMessage, &receiver), nullptr);

  std::mt19937 rng(21);
  std::vector<std::uint8_t> buffer;
  reference_frame_t msg;
  for (int k = 0; k < 3; ++k) {
    const ReferenceFrame sent = test::randomFrame(info, rng, 10.0 + 0.02 * k);
    fillReferenceFrame(info, sent, 10000000 + 20000 * k, 100 + k, msg);
    const int size = encodeMessage(msg, buffer);
    ASSERT_GT(size, 0);
    ASSERT_EQ(lcm.publish(kReferenceChannel, buffer.data(), static_cast<unsigned>(size)), 0);
    ASSERT_GT(lcm.handleTimeout(1000), 0);
    ASSERT_EQ(receiver.received, k + 1);
    EXPECT_EQ(receiver.last_channel, kReferenceChannel);
    ASSERT_TRUE(receiver.check.ok()) << receiver.check.reason;
    EXPECT_EQ(receiver.input.frame.time_s, sent.time_s);
    EXPECT_TRUE(receiver.input.frame.q.head<3>() == sent.q.head<3>());
    EXPECT_LT((receiver.input.frame.q.segment<4>(3) - sent.q.segment<4>(3)).cwiseAbs().maxCoeff(), 1e-15);
    EXPECT_TRUE(receiver.input.frame.q.tail(info.nj) == sent.q.tail(info.nj));
    EXPECT_EQ(receiver.input.frame.v, sent.v);
    EXPECT_EQ(receiver.input.frame.vdot, sent.vdot);
    EXPECT_EQ(receiver.input.sequence, 100 + k);
  }

  // A typed publish (lcm-cpp encodes it) of a bad frame: received, rejected, output kept.
  const ReferenceInput before = receiver.input;
  msg.utime += 20000;
  msg.joint_names[3] = "l_kneee";
  ASSERT_EQ(lcm.publish(kReferenceChannel, &msg), 0);
  ASSERT_GT(lcm.handleTimeout(1000), 0);
  EXPECT_EQ(receiver.received, 4);
  EXPECT_EQ(receiver.check.error, MessageError::kUnknownJoint);
  EXPECT_EQ(receiver.check.index, 3);
  EXPECT_EQ(receiver.input.frame.q, before.frame.q);
  EXPECT_EQ(receiver.input.utime, before.utime);

  // Nothing else is pending.
  EXPECT_EQ(lcm.handleTimeout(10), 0);
}

TEST(LcmMemq, ARobotStateArrivesOnItsOwnChannel) {
  const ModelInfo& info = test::humanInfo();
  ::lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  ReferenceReceiver references(info);
  StateReceiver states(info);
  lcm.subscribe(kReferenceChannel, &ReferenceReceiver::onMessage, &references);
  lcm.subscribe(kRobotStateChannel, &StateReceiver::onMessage, &states);

  std::mt19937 rng(22);
  Eigen::VectorXd q, v;
  randomState(info, rng, 1.0, q, v);
  const Eigen::VectorXd tau = Eigen::VectorXd::Constant(info.nj, 2.5);
  robot_state_t msg;
  fillRobotState(info, 777, q, v, &tau, msg);
  ASSERT_EQ(lcm.publish(kRobotStateChannel, &msg), 0);
  ASSERT_GT(lcm.handleTimeout(1000), 0);
  EXPECT_EQ(references.received, 0);
  ASSERT_EQ(states.received, 1);
  ASSERT_TRUE(states.check.ok()) << states.check.reason;
  EXPECT_EQ(states.input.utime, 777);
  EXPECT_TRUE(states.input.q.tail(info.nj) == q.tail(info.nj));
  EXPECT_EQ(states.input.v, v);
  EXPECT_EQ(states.input.tau, tau);

  // A robot state on the reference channel is not mistaken for a reference frame.
  ASSERT_EQ(lcm.publish(kReferenceChannel, &msg), 0);
  ASSERT_GT(lcm.handleTimeout(1000), 0);
  EXPECT_EQ(references.received, 1);
  EXPECT_EQ(references.check.error, MessageError::kMalformed);
}

}  // namespace
}  // namespace dynfilter::messages
