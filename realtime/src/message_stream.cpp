#include "dynfilter/realtime/message_stream.hpp"

#include <cmath>
#include <stdexcept>

namespace dynfilter::realtime {
namespace {

// Gain of the slow tracking of the stream's clock offset (drift between the two clocks).
constexpr double kOffsetGain = 0.02;

bool validDuration(double s) { return std::isfinite(s) && s >= 0.0; }

}  // namespace

const char* toString(StreamVerdict verdict) {
  switch (verdict) {
    case StreamVerdict::kAccepted: return "kAccepted";
    case StreamVerdict::kNewStream: return "kNewStream";
    case StreamVerdict::kFarFromReceiveTime: return "kFarFromReceiveTime";
    case StreamVerdict::kOffStreamClock: return "kOffStreamClock";
    case StreamVerdict::kNotAfterPrevious: return "kNotAfterPrevious";
  }
  return "unknown";
}

const char* describe(StreamVerdict verdict) {
  switch (verdict) {
    case StreamVerdict::kAccepted: return "accepted";
    case StreamVerdict::kNewStream: return "new stream";
    case StreamVerdict::kFarFromReceiveTime: return "stamp too far from the receive time";
    case StreamVerdict::kOffStreamClock: return "stamp off the stream's clock";
    case StreamVerdict::kNotAfterPrevious: return "stamp not after the previous message's";
  }
  return "unknown";
}

MessageStream::MessageStream(const StreamOptions& options) : options_(options) {
  if (!validDuration(options.clock_tolerance_s) || !validDuration(options.silence_s) ||
      !validDuration(options.max_clock_offset_s))
    throw std::invalid_argument(
        "StreamOptions: clock_tolerance_s, silence_s and max_clock_offset_s must be finite "
        "and >= 0");
  if (options.new_stream_messages < 1)
    throw std::invalid_argument("StreamOptions: new_stream_messages must be >= 1");
}

void MessageStream::reset() {
  active_ = false;
  run_ = Run{};
}

StreamVerdict MessageStream::start(double stamp_s, double receive_s, std::int64_t sequence) {
  active_ = true;
  offset_s_ = receive_s - stamp_s;
  last_stamp_s_ = stamp_s;
  last_receive_s_ = receive_s;
  last_sequence_ = sequence;
  run_ = Run{};
  ++counters_.accepted;
  ++counters_.streams;
  return StreamVerdict::kNewStream;
}

StreamVerdict MessageStream::reject(StreamVerdict why, double stamp_s, double receive_s,
                                    std::int64_t sequence) {
  // Evidence of a new stream: does this message continue the run of rejected ones?
  const double offset = receive_s - stamp_s;
  const bool continues = run_.count > 0 && stamp_s > run_.last_stamp_s &&
                         std::abs(offset - run_.offset_s) <= options_.clock_tolerance_s &&
                         (sequence < 0 || run_.last_sequence < 0 || sequence > run_.last_sequence);
  if (continues) {
    ++run_.count;
    run_.last_stamp_s = stamp_s;
    run_.last_sequence = sequence;
  } else {
    run_ = Run{1, offset, stamp_s, sequence};
  }
  if (run_.count >= options_.new_stream_messages) return start(stamp_s, receive_s, sequence);
  ++counters_.rejected;
  if (why == StreamVerdict::kOffStreamClock) ++counters_.off_stream_clock;
  else ++counters_.not_after_previous;
  last_rejection_ = why;
  return why;
}

StreamVerdict MessageStream::judge(double stamp_s, double receive_s, std::int64_t sequence) {
  if (options_.max_clock_offset_s > 0.0 &&
      !(std::abs(receive_s - stamp_s) <= options_.max_clock_offset_s)) {
    ++counters_.rejected;
    ++counters_.far_from_receive_time;
    last_rejection_ = StreamVerdict::kFarFromReceiveTime;
    return StreamVerdict::kFarFromReceiveTime;
  }
  if (!active_ || receive_s - last_receive_s_ > options_.silence_s)
    return start(stamp_s, receive_s, sequence);
  const double deviation = (receive_s - stamp_s) - offset_s_;
  if (!(std::abs(deviation) <= options_.clock_tolerance_s))
    return reject(StreamVerdict::kOffStreamClock, stamp_s, receive_s, sequence);
  if (!(stamp_s > last_stamp_s_))
    return reject(StreamVerdict::kNotAfterPrevious, stamp_s, receive_s, sequence);
  // A later stamp with a lower sequence number: the sender restarted on a steady clock.
  if (sequence >= 0 && last_sequence_ >= 0 && sequence < last_sequence_)
    return start(stamp_s, receive_s, sequence);
  offset_s_ += kOffsetGain * deviation;
  last_stamp_s_ = stamp_s;
  last_receive_s_ = receive_s;
  last_sequence_ = sequence;
  run_ = Run{};
  ++counters_.accepted;
  return StreamVerdict::kAccepted;
}

}  // namespace dynfilter::realtime
