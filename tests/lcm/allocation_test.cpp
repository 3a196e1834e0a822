// No heap allocation when receiving and sending in steady state: the same joint order as
// the previous message (any order), reused messages and buffers. Allocations are counted
// by tests/support/allocation_counter.cpp (operator new and malloc).
#include <atomic>
#include <cstdlib>
#include <new>

#include <limits>

#include <gtest/gtest.h>

#include "lcm/lcm_test_support.hpp"
#include "support/allocation_counter.hpp"

namespace {
namespace alloc = dynfilter::test::allocations;

// Counts every heap allocation (operator new and the malloc family) while alive.
struct Counting {
  Counting() {
    alloc::resetCounts();
    alloc::g_counting = true;
  }
  ~Counting() { alloc::g_counting = false; }
};
long countedAllocations() { return alloc::g_core_new + alloc::g_core_malloc; }
}  // namespace

namespace dynfilter::messages {
namespace {

// Reads frames[0] for a model of @p info (its names cached), then counts the heap
// allocations of reading the others; @p accepted counts those read without error.
long allocationsAfterTheFirst(const ModelInfo& info, const std::vector<std::vector<std::uint8_t>>& frames,
                              int& accepted) {
  ReferenceFrameReader reader(info);
  ReferenceInput input(info);
  EXPECT_TRUE(reader.read(frames[0].data(), frames[0].size(), input).ok());
  accepted = 0;
  Counting counting;
  for (std::size_t k = 1; k < frames.size(); ++k)
    accepted += reader.read(frames[k].data(), frames[k].size(), input).ok() ? 1 : 0;
  return countedAllocations();
}

TEST(LcmAllocation, ReceivingFramesInARepeatedOrderDoesNotAllocate) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  const ModelInfo& info = test::humanInfo();
  std::mt19937 rng(31);
  // Frames with the names in a fixed shuffled order, encoded beforehand.
  std::vector<std::vector<std::uint8_t>> frames;
  std::vector<std::uint8_t> bad;
  std::vector<int> order(static_cast<std::size_t>(info.nj));
  for (int j = 0; j < info.nj; ++j) order[static_cast<std::size_t>(j)] = (j * 7) % info.nj;
  for (int k = 0; k < 50; ++k) {
    reference_frame_t msg;
    fillReferenceFrame(info, test::randomFrame(info, rng, 0.01 * k), 10000 * k, k, msg);
    reference_frame_t shuffled = msg;
    for (std::size_t i = 0; i < order.size(); ++i) {
      const auto j = static_cast<std::size_t>(order[i]);
      shuffled.joint_names[i] = msg.joint_names[j];
      shuffled.q[i] = msg.q[j];
      shuffled.qd[i] = msg.qd[j];
      shuffled.qdd[i] = msg.qdd[j];
    }
    frames.push_back(test::encoded(shuffled));
    if (k == 3) {  // and one with a NaN, rejected after decoding
      shuffled.qd[5] = std::numeric_limits<double>::quiet_NaN();
      bad = test::encoded(shuffled);
    }
  }
  frames.push_back(bad);  // a rejected frame does not allocate either
  int accepted = 0;
  EXPECT_EQ(allocationsAfterTheFirst(info, frames, accepted), 0);
  EXPECT_EQ(accepted, 49);
}

TEST(LcmAllocation, ReceivingTheWholeRobotsFramesIntoAModelWithLockedJointsDoesNotAllocate) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  const test::LockedPair pair;
  std::mt19937 rng(33);
  std::vector<std::vector<std::uint8_t>> frames;
  for (int k = 0; k < 20; ++k) {
    reference_frame_t msg;
    fillReferenceFrame(pair.whole, test::randomFrame(pair.whole, rng, 0.01 * k), 10000 * k, k, msg);
    frames.push_back(test::encoded(msg));
  }
  int accepted = 0;
  EXPECT_EQ(allocationsAfterTheFirst(pair.model, frames, accepted), 0);
  EXPECT_EQ(accepted, 19);
}

TEST(LcmAllocation, ReceivingRobotStatesDoesNotAllocate) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  const ModelInfo& info = test::humanInfo();
  std::mt19937 rng(32);
  std::vector<std::vector<std::uint8_t>> states;
  for (int k = 0; k < 20; ++k) {
    Eigen::VectorXd q, v;
    randomState(info, rng, 1.0, q, v);
    robot_state_t msg;
    fillRobotState(info, 1000 * k, q, v, nullptr, msg);
    states.push_back(test::encoded(msg));
  }
  RobotStateReader reader(info);
  RobotStateInput input(info);
  ASSERT_TRUE(reader.read(states[0].data(), states[0].size(), input).ok());
  long allocations = 0;
  {
    Counting counting;
    for (std::size_t k = 1; k < states.size(); ++k) (void)reader.read(states[k].data(), states[k].size(), input);
    allocations = countedAllocations();
  }
  EXPECT_EQ(input.utime, 19000);
  EXPECT_EQ(allocations, 0);
}

TEST(LcmAllocation, FillingAndEncodingTheOutputsDoesNotAllocate) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  const ModelInfo& info = test::humanInfo();
  std::mt19937 rng(33);
  FilterOutput out(info.nq, info.nv, info.nj, 8);
  randomState(info, rng, 1.0, out.q, out.v);
  out.num_contacts = 2;
  out.contacts[0].body = 3;
  out.contacts[1].body = static_cast<int>(info.body_names.size()) - 1;
  torque_command_t command;
  contact_state_t contacts;
  filter_status_t status;
  std::vector<std::uint8_t> buffer;
  StatusReport report;
  report.detail = "unknown joint name";
  const auto tick = [&](int k) {
    out.status = (k % 2 == 0) ? kStatusOk : (kStatusImpact | kStatusTorqueClamped);
    out.num_contacts = 1 + k % 2;
    CommandStamps stamps;
    stamps.utime = k;
    bool ok = fillTorqueCommand(info, out, stamps, out.status, nullptr, command);
    ok = ok && encodeMessage(command, buffer) > 0;
    fillContactState(info, out, k, contacts);
    ok = ok && encodeMessage(contacts, buffer) > 0;
    report.utime = k;
    fillFilterStatus(out, report, status);
    ok = ok && encodeMessage(status, buffer) > 0;
    return ok;
  };
  ASSERT_TRUE(tick(0));
  ASSERT_TRUE(tick(1));  // warm-up: every vector and string at its size
  long allocations = 0;
  int ok = 0;
  {
    Counting counting;
    for (int k = 2; k < 50; ++k) ok += tick(k) ? 1 : 0;
    allocations = countedAllocations();
  }
  EXPECT_EQ(ok, 48);
  EXPECT_EQ(allocations, 0);
}

}  // namespace
}  // namespace dynfilter::messages
