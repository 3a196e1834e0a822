#pragma once
/// @file
/// Which received messages belong to the stream the loop follows. A sender stamps its
/// messages on its own clock (utime); the receiver knows when each one arrived on its
/// clock. A stream is a run of messages whose stamps increase and whose clock offset
/// (receive time − stamp) stays put. Judged per message:
/// - on the stream (offset within clock_tolerance_s of the stream's, stamp after the
///   previous accepted one): accepted;
/// - off the stream's clock (a stamp an hour ahead, a sender restarted at 0, a clock
///   jump) or not after the previous stamp (a stray old message): rejected, with its
///   reason. Rejected messages that are consistent among themselves are evidence of a new
///   stream: after new_stream_messages of them in a row, without an accepted message in
///   between, the stream is followed from there on (the sender restarted or its clock
///   jumped);
/// - any message after the stream was silent for silence_s: a new stream at once.
/// So a single stray message is dropped without disturbing the stream, and the real
/// stream is never locked out for longer than new_stream_messages of its own messages or
/// silence_s, whichever comes first. Optionally (max_clock_offset_s), for a sender on the
/// receiver's clock (same host, synchronised clocks), stamps further than that from the
/// receive time are rejected outright and never start a stream. Transport-free; does not
/// allocate.

#include <cstdint>

namespace dynfilter::realtime {

struct StreamOptions {
  /// How far a message's clock offset (receive time − stamp, s) may move from its
  /// stream's before the message is judged off the stream's clock. Above the transport's
  /// delay jitter, below the jumps to detect.
  double clock_tolerance_s = 0.5;
  /// Messages in a row, consistent among themselves but not with the stream, that make a
  /// new stream (≥ 1).
  int new_stream_messages = 3;
  /// The stream silent for this long (s): the next message starts a new stream.
  double silence_s = 0.25;
  /// > 0: the sender stamps on the receiver's clock; a message stamped further than this
  /// (s) from its receive time is rejected (kFarFromReceiveTime). 0: clocks may differ.
  double max_clock_offset_s = 0.0;
};

/// What became of one message.
enum class StreamVerdict : int {
  kAccepted = 0,        ///< on the followed stream
  kNewStream,           ///< accepted as the first message of a new stream (history reset)
  kFarFromReceiveTime,  ///< |stamp − receive time| > max_clock_offset_s
  kOffStreamClock,      ///< stamp off the stream's clock by more than clock_tolerance_s
  kNotAfterPrevious,    ///< stamp not after the previous accepted one (stray or repeated)
};

/// Name of the value, e.g. "kOffStreamClock" (static string).
const char* toString(StreamVerdict verdict);
/// Short static description, e.g. "stamp off the stream's clock".
const char* describe(StreamVerdict verdict);
inline bool accepted(StreamVerdict v) {
  return v == StreamVerdict::kAccepted || v == StreamVerdict::kNewStream;
}

/// Counts since construction.
struct StreamCounters {
  std::uint64_t accepted = 0;  ///< including the first message of each stream
  std::uint64_t rejected = 0;
  std::uint64_t streams = 0;   ///< streams followed (the first one included)
  std::uint64_t far_from_receive_time = 0;
  std::uint64_t off_stream_clock = 0;
  std::uint64_t not_after_previous = 0;
};

class MessageStream {
 public:
  /// Throws std::invalid_argument on a negative or non-finite option or
  /// new_stream_messages < 1.
  explicit MessageStream(const StreamOptions& options);

  /// Judges a message stamped @p stamp_s (sender's clock) received at @p receive_s
  /// (receiver's clock), both in s, and updates the stream when it is accepted. A
  /// non-negative @p sequence (+1 per message at the sender) makes a sequence number
  /// below the previous one a new stream too, even on a consistent clock.
  StreamVerdict judge(double stamp_s, double receive_s, std::int64_t sequence = -1);

  /// Whether a stream is being followed (a message was accepted).
  bool active() const { return active_; }
  /// Receive time − stamp of the stream (s), tracked slowly over its messages.
  double clockOffset() const { return offset_s_; }
  /// The last accepted message's stamp and receive time (s).
  double lastStamp() const { return last_stamp_s_; }
  double lastReceive() const { return last_receive_s_; }
  /// The verdict on the last rejected message (kAccepted if none was rejected yet).
  StreamVerdict lastRejection() const { return last_rejection_; }
  const StreamCounters& counters() const { return counters_; }
  /// Forgets the stream: the next message starts a new one. Counters are kept.
  void reset();

 private:
  // A run of rejected messages consistent among themselves.
  struct Run {
    int count = 0;
    double offset_s = 0.0, last_stamp_s = 0.0;
    std::int64_t last_sequence = -1;
  };
  StreamVerdict start(double stamp_s, double receive_s, std::int64_t sequence);
  StreamVerdict reject(StreamVerdict why, double stamp_s, double receive_s,
                       std::int64_t sequence);

  StreamOptions options_;
  bool active_ = false;
  double offset_s_ = 0.0, last_stamp_s_ = 0.0, last_receive_s_ = 0.0;
  std::int64_t last_sequence_ = -1;
  Run run_;
  StreamVerdict last_rejection_ = StreamVerdict::kAccepted;
  StreamCounters counters_;
};

}  // namespace dynfilter::realtime
