#pragma once
/// @file
/// A set of a model's bodies by index, of fixed size (no allocation): which bodies a
/// reference has in stance, which the preview lifts soon.

#include <bitset>
#include <cstddef>

namespace dynfilter {

/// Bodies a BodySet can hold: indices 0 … kMaxSetBodies − 1. The balance layer refuses a
/// model with more bodies.
inline constexpr int kMaxSetBodies = 256;

/// Body b is in the set when bit b is set.
using BodySet = std::bitset<kMaxSetBodies>;

/// Whether @p set holds body @p body (false outside 0 … kMaxSetBodies − 1).
inline bool holds(const BodySet& set, int body) {
  return body >= 0 && body < kMaxSetBodies && set[static_cast<std::size_t>(body)];
}

}  // namespace dynfilter
