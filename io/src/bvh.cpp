#include "dynfilter/io/bvh.hpp"

#include <cerrno>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <utility>

#include "csv.hpp"

namespace dynfilter::io {
namespace {

using detail::NumberStatus;

constexpr double kPi = 3.14159265358979323846;
constexpr double kRadPerDeg = kPi / 180.0;

bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// The file split into lines; a line's '\r' before the '\n' stays in it and counts as
// blank space. A UTF-8 byte order mark in front of the first line is dropped.
std::vector<std::string_view> splitLines(std::string_view text) {
  if (text.size() >= 3 && text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  std::vector<std::string_view> lines;
  std::size_t begin = 0;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string_view::npos) end = text.size();
    lines.push_back(text.substr(begin, end - begin));
    begin = end + 1;
  }
  return lines;
}

bool isBlankLine(std::string_view line) {
  for (char c : line)
    if (!isSpace(c)) return false;
  return true;
}

struct Token {
  std::string_view text;
  int line = 0;    // 1-based
  int column = 0;  // 1-based character column
};

// Words of the header, one at a time across lines, or the rest of the current line.
class Lexer {
 public:
  explicit Lexer(const std::vector<std::string_view>& lines) : lines_(lines) {}

  // The next word, on this line or a later one; false at the end of the file.
  bool next(Token& token) {
    while (li_ < lines_.size()) {
      if (readOnLine(token)) return true;
      ++li_;
      pos_ = 0;
    }
    return false;
  }

  // The words left on the line of the last word read.
  std::vector<Token> restOfLine() {
    std::vector<Token> words;
    Token token;
    while (li_ < lines_.size() && readOnLine(token)) words.push_back(token);
    return words;
  }

  // Index of the line the lexer stands on (that of the last word read).
  std::size_t lineIndex() const { return li_; }

 private:
  bool readOnLine(Token& token) {
    const std::string_view line = lines_[li_];
    while (pos_ < line.size() && isSpace(line[pos_])) ++pos_;
    if (pos_ >= line.size()) return false;
    const std::size_t begin = pos_;
    while (pos_ < line.size() && !isSpace(line[pos_])) ++pos_;
    token.text = line.substr(begin, pos_ - begin);
    token.line = static_cast<int>(li_) + 1;
    token.column = static_cast<int>(begin) + 1;
    return true;
  }

  const std::vector<std::string_view>& lines_;
  std::size_t li_ = 0;
  std::size_t pos_ = 0;
};

bool parseChannel(std::string_view text, BvhChannel& channel) {
  static constexpr BvhChannel kAll[] = {BvhChannel::kXposition, BvhChannel::kYposition,
                                        BvhChannel::kZposition, BvhChannel::kXrotation,
                                        BvhChannel::kYrotation, BvhChannel::kZrotation};
  for (BvhChannel c : kAll)
    if (text == bvhChannelName(c)) {
      channel = c;
      return true;
    }
  return false;
}

// Parses a whole word as a non-negative integer no larger than @p max.
bool parseCount(std::string_view text, long long max, long long& value) {
  const char* first = text.data();
  const char* last = text.data() + text.size();
  const auto result = std::from_chars(first, last, value);
  return result.ec == std::errc() && result.ptr == last && value >= 0 && value <= max;
}

int axisOf(BvhChannel c) {
  switch (c) {
    case BvhChannel::kXposition:
    case BvhChannel::kXrotation: return 0;
    case BvhChannel::kYposition:
    case BvhChannel::kYrotation: return 1;
    default: return 2;
  }
}

// Everything about a joint block that is only needed while reading the header.
struct OpenBlock {
  int joint = 0;
  bool has_offset = false;
  bool has_channels = false;
};

class Reader {
 public:
  Reader(std::string path, const std::vector<std::string_view>& lines,
         const BvhReadOptions& options)
      : path_(std::move(path)), lines_(lines), lexer_(lines), options_(options) {}

  BvhMotion read() {
    motion_.source = path_;
    readHierarchy();
    readMotion();
    return std::move(motion_);
  }

 private:
  [[noreturn]] void fail(int line, int column, const std::string& reason) const {
    throw InputError(path_, line, column, reason);
  }
  [[noreturn]] void fail(const Token& token, const std::string& reason) const {
    fail(token.line, token.column, reason);
  }

  // Line of the last non-blank line of the file (0 for an empty file).
  int lastLine() const {
    for (std::size_t i = lines_.size(); i > 0; --i)
      if (!isBlankLine(lines_[i - 1])) return static_cast<int>(i);
    return 0;
  }

  const std::string& jointName(int joint) const {
    return motion_.joints[static_cast<std::size_t>(joint)].name;
  }

  std::string blockLabel(const OpenBlock& block) const {
    const BvhJoint& j = motion_.joints[static_cast<std::size_t>(block.joint)];
    return std::string(j.end_site ? "End Site of " + detail::quoted(jointName(j.parent))
                                  : (j.parent < 0 ? "ROOT " : "JOINT ") + detail::quoted(j.name)) +
           " (line " + std::to_string(j.line) + ")";
  }

  // After the ROOT/JOINT keyword or "End Site": the name (none for an End Site) and the
  // opening brace, on this line or the next.
  void openBlock(const Token& keyword, bool end_site, std::vector<OpenBlock>& open) {
    std::vector<Token> words = lexer_.restOfLine();
    bool brace = false;
    if (!words.empty() && words.back().text == "{") {
      brace = true;
      words.pop_back();
    }
    BvhJoint joint;
    joint.line = keyword.line;
    joint.end_site = end_site;
    joint.parent = open.empty() ? -1 : open.back().joint;
    if (end_site) {
      if (words.empty() || words.front().text != "Site")
        fail(keyword, "expected \"End Site\"");
      if (words.size() > 1)
        fail(words[1], "unexpected " + detail::quoted(words[1].text) + " after End Site");
      joint.name = jointName(joint.parent) + "_end";
    } else {
      if (words.empty())
        fail(keyword, std::string(keyword.text) + " without a name");
      for (const Token& w : words) {
        if (w.text == "{" || w.text == "}")
          fail(w, "unexpected " + detail::quoted(w.text) + " in the name of a " +
                      std::string(keyword.text));
        if (!joint.name.empty()) joint.name += ' ';
        joint.name += w.text;
      }
      const auto seen = names_.emplace(joint.name, joint.line);
      if (!seen.second)
        fail(words.front(), "joint name " + detail::quoted(joint.name) + " already used at line " +
                                std::to_string(seen.first->second));
    }
    if (!brace) {
      Token next;
      if (!lexer_.next(next))
        fail(lastLine(), 0,
             "unbalanced braces: the file ends where \"{\" should open " +
                 std::string(keyword.text) +
                 (end_site ? " Site" : " " + detail::quoted(joint.name)));
      if (next.text != "{")
        fail(next, "unbalanced braces: expected \"{\" to open " + std::string(keyword.text) +
                       (end_site ? " Site" : " " + detail::quoted(joint.name)) + ", found " +
                       detail::quoted(next.text));
    }
    motion_.joints.push_back(std::move(joint));
    open.push_back(OpenBlock{static_cast<int>(motion_.joints.size()) - 1});
  }

  void readOffset(const Token& keyword, OpenBlock& block) {
    if (block.has_offset) fail(keyword, "second OFFSET in " + blockLabel(block));
    block.has_offset = true;
    const std::vector<Token> words = lexer_.restOfLine();
    if (words.size() != 3)
      fail(keyword, "OFFSET needs 3 numbers on its line, found " + std::to_string(words.size()) +
                        " words");
    BvhJoint& joint = motion_.joints[static_cast<std::size_t>(block.joint)];
    for (int i = 0; i < 3; ++i) {
      const Token& w = words[static_cast<std::size_t>(i)];
      double value = 0.0;
      const NumberStatus status = detail::parseDouble(w.text, value);
      if (status != NumberStatus::kOk)
        fail(w, "OFFSET value " + detail::quoted(w.text) + ": " + detail::describe(status));
      joint.offset[i] = value * options_.length_scale;
    }
  }

  void readChannels(const Token& keyword, OpenBlock& block) {
    if (block.has_channels) fail(keyword, "second CHANNELS in " + blockLabel(block));
    block.has_channels = true;
    const std::vector<Token> words = lexer_.restOfLine();
    if (words.empty()) fail(keyword, "CHANNELS without a count");
    long long count = 0;
    if (!parseCount(words[0].text, 6, count))
      fail(words[0], "CHANNELS count " + detail::quoted(words[0].text) + " is not an integer in 0..6");
    const std::size_t names = words.size() - 1;
    if (names != static_cast<std::size_t>(count))
      fail(keyword, "CHANNELS declares " + std::to_string(count) + " channels but " +
                        std::to_string(names) + " channel names follow on its line");
    BvhJoint& joint = motion_.joints[static_cast<std::size_t>(block.joint)];
    joint.first_channel = channel_count_;
    for (std::size_t i = 1; i < words.size(); ++i) {
      BvhChannel channel{};
      if (!parseChannel(words[i].text, channel))
        fail(words[i], "unknown channel " + detail::quoted(words[i].text) +
                           " (expected Xposition, Yposition, Zposition, Xrotation, Yrotation or "
                           "Zrotation)");
      for (BvhChannel c : joint.channels)
        if (c == channel)
          fail(words[i], std::string("channel ") + bvhChannelName(c) + " listed twice");
      joint.channels.push_back(channel);
    }
    channel_count_ += static_cast<int>(count);
  }

  void closeBlock(const Token& brace, std::vector<OpenBlock>& open) {
    const OpenBlock& block = open.back();
    if (!block.has_offset) fail(brace, blockLabel(block) + " has no OFFSET");
    open.pop_back();
  }

  void readHierarchy() {
    Token token;
    if (!lexer_.next(token)) fail(0, 0, "missing HIERARCHY: the file is empty");
    if (token.text != "HIERARCHY")
      fail(token, "missing HIERARCHY: the file starts with " + detail::quoted(token.text));
    std::vector<OpenBlock> open;
    while (true) {
      if (!lexer_.next(token)) {
        if (!open.empty())
          fail(lastLine(), 0,
               "unbalanced braces: the file ends inside " + blockLabel(open.back()) + ", " +
                   std::to_string(open.size()) + " \"}\" missing");
        fail(lastLine(), 0, "missing MOTION: the file ends after the hierarchy");
      }
      const std::string_view word = token.text;
      if (open.empty()) {
        if (word == "ROOT") {
          openBlock(token, false, open);
        } else if (word == "MOTION") {
          break;
        } else if (word == "}") {
          fail(token, "unbalanced braces: \"}\" without a matching \"{\"");
        } else {
          fail(token, "expected ROOT or MOTION, found " + detail::quoted(word));
        }
        continue;
      }
      OpenBlock& block = open.back();
      const bool end_site = motion_.joints[static_cast<std::size_t>(block.joint)].end_site;
      if (word == "}") {
        closeBlock(token, open);
      } else if (word == "OFFSET") {
        readOffset(token, block);
      } else if (word == "CHANNELS" && !end_site) {
        readChannels(token, block);
      } else if (word == "JOINT" && !end_site) {
        openBlock(token, false, open);
      } else if (word == "End" && !end_site) {
        openBlock(token, true, open);
      } else if (word == "{") {
        fail(token, "unbalanced braces: unexpected \"{\" in " + blockLabel(block));
      } else if (word == "MOTION") {
        fail(token, "unbalanced braces: MOTION inside " + blockLabel(block) + ", " +
                        std::to_string(open.size()) + " \"}\" missing");
      } else {
        fail(token, "unexpected " + detail::quoted(word) + " in " + blockLabel(block) +
                        (end_site ? " (expected OFFSET or \"}\")"
                                  : " (expected OFFSET, CHANNELS, JOINT, End Site or \"}\")"));
      }
    }
    if (motion_.joints.empty()) fail(token, "no ROOT before MOTION");
    if (channel_count_ == 0) fail(token, "the hierarchy has no channels");
    const std::vector<Token> rest = lexer_.restOfLine();
    if (!rest.empty())
      fail(rest.front(), "unexpected " + detail::quoted(rest.front().text) + " after MOTION");
  }

  // One "Frames:" / "Frame Time:" header line: the label words, then one value word.
  Token readLabelled(const std::vector<std::string_view>& label, const Token& after,
                     const char* what) {
    Token token;
    if (!lexer_.next(token))
      fail(after.line, 0, std::string("missing \"") + what + "\" after line " +
                              std::to_string(after.line));
    std::vector<Token> words = lexer_.restOfLine();
    words.insert(words.begin(), token);
    for (std::size_t i = 0; i < label.size(); ++i)
      if (i >= words.size() || words[i].text != label[i])
        fail(token, std::string("expected \"") + what + "\", found " + detail::quoted(token.text));
    if (words.size() != label.size() + 1)
      fail(token, std::string("\"") + what + "\" needs one value on its line, found " +
                      std::to_string(words.size() - label.size()));
    return words.back();
  }

  void readMotion() {
    const Token motion_token{"MOTION", static_cast<int>(lexer_.lineIndex()) + 1, 0};
    const Token count_word = readLabelled({"Frames:"}, motion_token, "Frames:");
    long long declared = 0;
    if (!parseCount(count_word.text, std::numeric_limits<int>::max(), declared))
      fail(count_word, "\"Frames:\" value " + detail::quoted(count_word.text) +
                           " is not a non-negative integer");
    const Token time_word = readLabelled({"Frame", "Time:"}, count_word, "Frame Time:");
    double frame_time = 0.0;
    const NumberStatus status = detail::parseDouble(time_word.text, frame_time);
    if (status != NumberStatus::kOk)
      fail(time_word,
           "\"Frame Time:\" value " + detail::quoted(time_word.text) + ": " + detail::describe(status));
    if (!(frame_time > 0.0))
      fail(time_word, "\"Frame Time:\" must be > 0 s, got " + std::string(time_word.text));
    motion_.frame_time_s = frame_time;

    const int channels = channel_count_;
    const std::size_t first_line = lexer_.lineIndex() + 1;
    const std::size_t frames = static_cast<std::size_t>(declared);
    // Never allocate more rows than there are lines left (a wrong "Frames:" is reported
    // below as a truncated motion, not as an allocation failure).
    const std::size_t available = lines_.size() > first_line ? lines_.size() - first_line : 0;
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> values(
        static_cast<Eigen::Index>(std::min(frames, available)), channels);

    const int frames_line = count_word.line;
    std::size_t li = first_line;
    for (std::size_t k = 0; k < frames; ++k, ++li) {
      // A blank line with only blank lines after it ends the file; one followed by more
      // text is a frame line without values (reported by readFrameLine).
      const bool ended = [&] {
        for (std::size_t i = li; i < lines_.size(); ++i)
          if (!isBlankLine(lines_[i])) return false;
        return true;
      }();
      if (ended)
        fail(lastLine(), 0,
             "truncated motion: the file ends after " + std::to_string(k) + " of the " +
                 std::to_string(frames) + " frames declared by \"Frames:\" at line " +
                 std::to_string(frames_line));
      readFrameLine(lines_[li], static_cast<int>(li) + 1, channels,
                    values.row(static_cast<Eigen::Index>(k)).data());
    }
    for (; li < lines_.size(); ++li)
      if (!isBlankLine(lines_[li]))
        fail(static_cast<int>(li) + 1, 0,
             "more frame lines than the " + std::to_string(frames) +
                 " declared by \"Frames:\" at line " + std::to_string(frames_line));

    if (options_.length_scale != 1.0)
      for (const BvhJoint& joint : motion_.joints)
        for (std::size_t c = 0; c < joint.channels.size(); ++c)
          if (isBvhPositionChannel(joint.channels[c]))
            values.col(joint.first_channel + static_cast<Eigen::Index>(c)) *= options_.length_scale;

    int skip = 0;
    if (values.rows() >= 1 && options_.skip_first_frame) {
      skip = 1;
    } else if (values.rows() >= 2 && options_.detect_t_pose) {
      if (rotationRms(values.row(0)) <= kBvhRestPoseRmsDeg &&
          largestRotationStep(values.row(0), values.row(1)) >= kBvhRestPoseJumpDeg)
        skip = 1 + blendFrames(values, frame_time);
    }
    motion_.skipped_frames = skip;
    motion_.frames = values.bottomRows(values.rows() - skip);
  }

  // Root-mean-square of the rotation channels of one frame, degrees.
  template <typename Row>
  double rotationRms(const Row& row) const {
    double sum = 0.0;
    int n = 0;
    for (const BvhJoint& joint : motion_.joints)
      for (std::size_t c = 0; c < joint.channels.size(); ++c)
        if (!isBvhPositionChannel(joint.channels[c])) {
          const double a = row(joint.first_channel + static_cast<Eigen::Index>(c));
          sum += a * a;
          ++n;
        }
    return n > 0 ? std::sqrt(sum / n) : 0.0;
  }

  // Frames after a rest pose (frame 0) that a conversion blends from it into the motion:
  // from frame 1 on, each frame whose step to the next (largestRotationStep) exceeds
  // kBvhBlendStepFactor × the clip's median step, within kBvhBlendMaxS of frame 1. At
  // least two frames stay.
  template <typename Values>
  int blendFrames(const Values& values, double frame_time) const {
    const Eigen::Index n = values.rows();
    if (n < 4) return 0;
    std::vector<double> steps(static_cast<std::size_t>(n - 1));
    for (Eigen::Index k = 0; k + 1 < n; ++k)
      steps[static_cast<std::size_t>(k)] = largestRotationStep(values.row(k), values.row(k + 1));
    std::vector<double> sorted(steps.begin() + 1, steps.end());
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    const double threshold = kBvhBlendStepFactor * sorted[sorted.size() / 2];
    const Eigen::Index cap = static_cast<Eigen::Index>(
        std::min(static_cast<double>(n - 3), std::floor(kBvhBlendMaxS / frame_time + 1e-9)));
    Eigen::Index blend = 0;
    while (blend < cap && steps[static_cast<std::size_t>(1 + blend)] > threshold) ++blend;
    return static_cast<int>(blend);
  }

  // Largest change of a rotation channel from frame a to frame b, degrees, the shorter
  // way round (a step from 179 to −179 is 2).
  template <typename Row>
  double largestRotationStep(const Row& a, const Row& b) const {
    double largest = 0.0;
    for (const BvhJoint& joint : motion_.joints)
      for (std::size_t c = 0; c < joint.channels.size(); ++c)
        if (!isBvhPositionChannel(joint.channels[c])) {
          const Eigen::Index i = joint.first_channel + static_cast<Eigen::Index>(c);
          largest = std::max(largest, std::abs(std::remainder(b(i) - a(i), 360.0)));
        }
    return largest;
  }

  void readFrameLine(std::string_view line, int line_number, int channels, double* out) const {
    int found = 0;
    int bad = -1;
    NumberStatus bad_status = NumberStatus::kOk;
    std::string_view bad_text;
    std::size_t pos = 0;
    while (true) {
      while (pos < line.size() && isSpace(line[pos])) ++pos;
      if (pos >= line.size()) break;
      const std::size_t begin = pos;
      while (pos < line.size() && !isSpace(line[pos])) ++pos;
      if (found < channels && bad < 0) {
        const std::string_view text = line.substr(begin, pos - begin);
        const NumberStatus status = detail::parseDouble(text, out[found]);
        if (status != NumberStatus::kOk) {
          bad = found;
          bad_status = status;
          bad_text = text;
        }
      }
      ++found;
    }
    if (found != channels)
      fail(line_number, 0,
           "frame line has the wrong number of values: expected " + std::to_string(channels) +
               ", found " + std::to_string(found));
    if (bad >= 0)
      fail(line_number, bad + 1,
           "value " + std::to_string(bad + 1) + " " + detail::quoted(bad_text) + ": " +
               detail::describe(bad_status));
  }

  std::string path_;
  const std::vector<std::string_view>& lines_;
  Lexer lexer_;
  const BvhReadOptions& options_;
  BvhMotion motion_;
  int channel_count_ = 0;
  std::unordered_map<std::string, int> names_;  // joint name → line
};

}  // namespace

const char* bvhChannelName(BvhChannel channel) {
  switch (channel) {
    case BvhChannel::kXposition: return "Xposition";
    case BvhChannel::kYposition: return "Yposition";
    case BvhChannel::kZposition: return "Zposition";
    case BvhChannel::kXrotation: return "Xrotation";
    case BvhChannel::kYrotation: return "Yrotation";
    case BvhChannel::kZrotation: return "Zrotation";
  }
  return "?";
}

bool isBvhPositionChannel(BvhChannel channel) {
  return channel == BvhChannel::kXposition || channel == BvhChannel::kYposition ||
         channel == BvhChannel::kZposition;
}

bool BvhJoint::hasPositionChannels() const {
  for (BvhChannel c : channels)
    if (isBvhPositionChannel(c)) return true;
  return false;
}

double BvhMotion::durationS() const {
  return frames.rows() >= 2 ? static_cast<double>(frames.rows() - 1) * frame_time_s : 0.0;
}

BvhMotion bvhWindow(const BvhMotion& bvh, int first_frame, double start_s, double end_s) {
  const int n = bvh.frameCount() - first_frame;
  const double duration_s = n >= 2 ? (n - 1) * bvh.frame_time_s : 0.0;
  char window[160];
  std::snprintf(window, sizeof window, "window %g to %g s of %s: ", start_s, end_s, bvh.source.c_str());
  if (first_frame < 0 || n <= 0)
    throw std::invalid_argument(std::string(window) + "frame " + std::to_string(first_frame) +
                                " is not one of its " + std::to_string(bvh.frameCount()) + " frames");
  if (!std::isfinite(start_s) || start_s < 0.0 || std::isnan(end_s) || end_s <= start_s)
    throw std::invalid_argument(std::string(window) + "the start must be >= 0 and before the end");
  // Frame k is at k × frame_time_s; the tolerance keeps a time written with the frames' own
  // rounding (e.g. 0.0083333 × 120) on its frame.
  constexpr double kTimeTolerance = 0.01;  // frames
  const int first = static_cast<int>(std::ceil(start_s / bvh.frame_time_s - kTimeTolerance));
  const int last = std::isinf(end_s) ? n - 1
                                     : std::min(n - 1, static_cast<int>(std::floor(end_s / bvh.frame_time_s + kTimeTolerance)));
  if (first >= n || last - first < 1) {
    char reason[160];
    std::snprintf(reason, sizeof reason, "it holds fewer than two frames (the clip lasts %.6g s from frame %d)",
                  duration_s, first_frame);
    throw std::invalid_argument(std::string(window) + reason);
  }
  BvhMotion out;
  out.source = bvh.source;
  out.joints = bvh.joints;
  out.frame_time_s = bvh.frame_time_s;
  out.frames = bvh.frames.middleRows(first_frame + first, last - first + 1);
  out.skipped_frames = bvh.skipped_frames + first_frame + first;
  return out;
}

int BvhMotion::findJoint(const std::string& name) const {
  for (std::size_t j = 0; j < joints.size(); ++j)
    if (joints[j].name == name) return static_cast<int>(j);
  return -1;
}

void BvhReadOptions::validate() const {
  if (!(std::isfinite(length_scale) && length_scale > 0.0))
    throw std::invalid_argument("BvhReadOptions::length_scale must be finite and > 0");
}

BvhMotion readBvh(const std::string& path, const BvhReadOptions& options) {
  options.validate();
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const int err = errno;
    throw InputError(path, 0,
                     std::string("cannot open file") +
                         (err != 0 ? ": " + std::string(std::strerror(err)) : ""));
  }
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path, 0, "read error");
  const std::vector<std::string_view> lines = splitLines(text);
  return Reader(path, lines, options).read();
}

void bvhForwardKinematics(const BvhMotion& motion, int frame,
                          std::vector<Eigen::Isometry3d>& X_world) {
  if (frame < 0 || frame >= motion.frameCount())
    throw std::out_of_range("bvhForwardKinematics: frame " + std::to_string(frame) +
                            " not in [0, " +
                            std::to_string(motion.frameCount()) + ")");
  const std::size_t n = motion.joints.size();
  if (X_world.size() != n) X_world.resize(n);
  const auto row = motion.frames.row(frame);
  for (std::size_t j = 0; j < n; ++j) {
    const BvhJoint& joint = motion.joints[j];
    Eigen::Vector3d t = joint.offset;
    Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
    if (joint.hasPositionChannels()) t.setZero();
    for (std::size_t c = 0; c < joint.channels.size(); ++c) {
      const BvhChannel channel = joint.channels[c];
      const double value = row(joint.first_channel + static_cast<Eigen::Index>(c));
      const int axis = axisOf(channel);
      if (isBvhPositionChannel(channel)) {
        t[axis] = value;
      } else {
        R = R * Eigen::AngleAxisd(value * kRadPerDeg, Eigen::Vector3d::Unit(axis))
                    .toRotationMatrix();
      }
    }
    Eigen::Isometry3d local = Eigen::Isometry3d::Identity();
    local.linear() = R;
    local.translation() = t;
    X_world[j] = joint.parent < 0 ? local : X_world[static_cast<std::size_t>(joint.parent)] * local;
  }
}

}  // namespace dynfilter::io
