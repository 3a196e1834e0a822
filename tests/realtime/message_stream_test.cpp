// The stream policy on its own: which messages of a sender belong to the followed stream
// when clocks are wrong, senders restart and stray messages arrive.
#include <limits>
#include <stdexcept>

#include <gtest/gtest.h>

#include "dynfilter/realtime/message_stream.hpp"
#include "support/test_support.hpp"

namespace dynfilter::realtime {
namespace {

constexpr double kPeriod = 1.0 / 60.0;   // a 60 Hz sender
constexpr double kSenderAhead = 1000.0;  // its clock is 1000 s ahead of the receiver's

// The k-th message of a well-behaved sender: (stamp, receive time), 1 ms transport delay.
double stampOf(int k) { return kSenderAhead + k * kPeriod; }
double receiveOf(int k) { return k * kPeriod + 1e-3; }

TEST(MessageStream, AFutureStampedMessageIsRejectedAndTheStreamGoesOn) {
  MessageStream stream(StreamOptions{});
  EXPECT_EQ(stream.judge(stampOf(0), receiveOf(0), 0), StreamVerdict::kNewStream);
  for (int k = 1; k < 30; ++k) ASSERT_EQ(stream.judge(stampOf(k), receiveOf(k), k), StreamVerdict::kAccepted);
  // One message stamped an hour ahead (a sender with a wrong clock on the same channel).
  EXPECT_EQ(stream.judge(stampOf(30) + test::kSecondsPerHour, receiveOf(30), 7), StreamVerdict::kOffStreamClock);
  // The real stream is not disturbed: not one of its messages is lost.
  for (int k = 30; k < 60; ++k) ASSERT_EQ(stream.judge(stampOf(k), receiveOf(k), k), StreamVerdict::kAccepted) << k;
  EXPECT_EQ(stream.counters().streams, 1u);
  EXPECT_EQ(stream.counters().rejected, 1u);
  EXPECT_EQ(stream.counters().off_stream_clock, 1u);
  EXPECT_EQ(stream.lastRejection(), StreamVerdict::kOffStreamClock);
  EXPECT_NEAR(stream.clockOffset(), -kSenderAhead + 1e-3, 1e-9);
}

TEST(MessageStream, AFutureStampedFirstMessageLocksTheRealStreamOutForTwoMessagesOnly) {
  StreamOptions options;
  options.new_stream_messages = 3;
  MessageStream stream(options);
  EXPECT_EQ(stream.judge(stampOf(0) + test::kSecondsPerHour, receiveOf(0)), StreamVerdict::kNewStream);
  // The real stream is off the (bogus) stream's clock: its first two are evidence ...
  EXPECT_EQ(stream.judge(stampOf(1), receiveOf(1)), StreamVerdict::kOffStreamClock);
  EXPECT_EQ(stream.judge(stampOf(2), receiveOf(2)), StreamVerdict::kOffStreamClock);
  // ... the third makes it the stream.
  EXPECT_EQ(stream.judge(stampOf(3), receiveOf(3)), StreamVerdict::kNewStream);
  for (int k = 4; k < 20; ++k) ASSERT_EQ(stream.judge(stampOf(k), receiveOf(k)), StreamVerdict::kAccepted);
  EXPECT_EQ(stream.counters().streams, 2u);
  EXPECT_EQ(stream.counters().rejected, 2u);
  EXPECT_NEAR(stream.clockOffset(), -kSenderAhead + 1e-3, 1e-9);
}

TEST(MessageStream, ARestartedSenderIsFollowed) {
  MessageStream stream(StreamOptions{});
  for (int k = 0; k < 100; ++k) stream.judge(stampOf(k), receiveOf(k), k);
  ASSERT_EQ(stream.counters().streams, 1u);
  // The sender restarts: its stamps (motion time) and sequence numbers start again at 0.
  int accepted_from = -1;
  for (int k = 0; k < 10; ++k) {
    const StreamVerdict v = stream.judge(k * kPeriod, receiveOf(100 + k), k);
    if (accepted(v) && accepted_from < 0) accepted_from = k;
    if (accepted_from < 0) {
      EXPECT_EQ(v, StreamVerdict::kOffStreamClock) << k;
    }
  }
  EXPECT_EQ(accepted_from, 2) << "followed from its third message";
  EXPECT_EQ(stream.counters().streams, 2u);
  EXPECT_NEAR(stream.lastStamp(), 9 * kPeriod, 1e-12);
}

TEST(MessageStream, ASmallClockJumpBackIsFollowedToo) {
  MessageStream stream(StreamOptions{});
  for (int k = 0; k < 100; ++k) stream.judge(stampOf(k), receiveOf(k));
  // The sender's clock steps back 0.2 s (within the clock tolerance): its stamps are
  // before the previous one until they catch up, which would take 0.2 s.
  EXPECT_EQ(stream.judge(stampOf(100) - 0.2, receiveOf(100)), StreamVerdict::kNotAfterPrevious);
  EXPECT_EQ(stream.judge(stampOf(101) - 0.2, receiveOf(101)), StreamVerdict::kNotAfterPrevious);
  EXPECT_EQ(stream.judge(stampOf(102) - 0.2, receiveOf(102)), StreamVerdict::kNewStream);
  EXPECT_EQ(stream.counters().not_after_previous, 2u);
}

TEST(MessageStream, AStrayOldMessageInsideALiveStreamIsRejectedEveryTime) {
  MessageStream stream(StreamOptions{});
  for (int k = 0; k < 10; ++k) stream.judge(stampOf(k), receiveOf(k), k);
  // A stale copy of an old message after every genuine one, and runs of two (fewer than
  // the three that make a stream): all rejected, the stream never switches.
  for (int k = 10; k < 200; ++k) {
    ASSERT_EQ(stream.judge(stampOf(k), receiveOf(k), k), StreamVerdict::kAccepted) << k;
    const int strays = 1 + k % 2;
    for (int s = 0; s < strays; ++s)
      ASSERT_EQ(stream.judge(stampOf(k - 5 + s), receiveOf(k) + 1e-4, k - 5 + s),
                StreamVerdict::kNotAfterPrevious);
    // A repeated message (same stamp) is not after the previous one either.
    if (k % 50 == 0) {
      ASSERT_EQ(stream.judge(stampOf(k), receiveOf(k) + 2e-4, k), StreamVerdict::kNotAfterPrevious);
    }
  }
  EXPECT_EQ(stream.counters().streams, 1u);
  EXPECT_EQ(stream.counters().accepted, 200u);
  EXPECT_EQ(stream.counters().rejected, 190u + 95u + 3u);
}

TEST(MessageStream, AfterSilenceTheNextMessageStartsANewStreamAtOnce) {
  StreamOptions options;
  options.silence_s = 0.25;
  MessageStream stream(options);
  for (int k = 0; k < 10; ++k) stream.judge(stampOf(k), receiveOf(k));
  // 0.3 s later a sender with another clock: no evidence window needed.
  EXPECT_EQ(stream.judge(5.0, receiveOf(9) + 0.3), StreamVerdict::kNewStream);
  EXPECT_EQ(stream.judge(5.0 + kPeriod, receiveOf(9) + 0.3 + kPeriod), StreamVerdict::kAccepted);
  EXPECT_EQ(stream.counters().streams, 2u);
}

TEST(MessageStream, ASequenceRestartOnASteadyClockIsANewStream) {
  MessageStream stream(StreamOptions{});
  for (int k = 0; k < 10; ++k) stream.judge(stampOf(k), receiveOf(k), 500 + k);
  // Same clock (stamps go on), numbers start again: the sender restarted.
  EXPECT_EQ(stream.judge(stampOf(10), receiveOf(10), 1), StreamVerdict::kNewStream);
  EXPECT_EQ(stream.judge(stampOf(11), receiveOf(11), 2), StreamVerdict::kAccepted);
  EXPECT_EQ(stream.counters().streams, 2u);
  EXPECT_EQ(stream.counters().rejected, 0u);
}

TEST(MessageStream, OnTheReceiversClockStampsFarFromTheReceiveTimeNeverStartAStream) {
  StreamOptions options;
  options.max_clock_offset_s = 0.1;
  MessageStream stream(options);
  for (int k = 0; k < 5; ++k)  // stamped an hour ahead, again and again
    EXPECT_EQ(stream.judge(receiveOf(k) + test::kSecondsPerHour, receiveOf(k)), StreamVerdict::kFarFromReceiveTime);
  EXPECT_FALSE(stream.active());
  EXPECT_EQ(stream.judge(receiveOf(5) - 1e-3, receiveOf(5)), StreamVerdict::kNewStream);
  EXPECT_EQ(stream.judge(receiveOf(6) + test::kSecondsPerHour, receiveOf(6)), StreamVerdict::kFarFromReceiveTime);
  EXPECT_EQ(stream.judge(receiveOf(7) - 1e-3, receiveOf(7)), StreamVerdict::kAccepted);
  EXPECT_EQ(stream.counters().far_from_receive_time, 6u);
  EXPECT_EQ(stream.counters().streams, 1u);
}

TEST(MessageStream, TheClockOffsetFollowsASlowDrift) {
  MessageStream stream(StreamOptions{});
  // The sender's clock runs 1000 ppm fast: over 20 minutes 1.2 s, beyond the 0.5 s
  // tolerance, yet every message stays on the stream.
  for (int k = 0; k < 72000; ++k) {
    const double receive = k * kPeriod;
    ASSERT_TRUE(accepted(stream.judge(kSenderAhead + receive * 1.001, receive))) << k;
  }
  EXPECT_EQ(stream.counters().streams, 1u);
  EXPECT_NEAR(stream.clockOffset(), -kSenderAhead - 0.001 * 71999 * kPeriod, 2e-3);
}

TEST(MessageStream, BadOptionsThrow) {
  StreamOptions o;
  o.new_stream_messages = 0;
  EXPECT_THROW(MessageStream{o}, std::invalid_argument);
  o = StreamOptions{};
  o.clock_tolerance_s = -1.0;
  EXPECT_THROW(MessageStream{o}, std::invalid_argument);
  o = StreamOptions{};
  o.silence_s = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(MessageStream{o}, std::invalid_argument);
}

}  // namespace
}  // namespace dynfilter::realtime
