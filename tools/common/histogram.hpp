#pragma once
// Fixed-bin histogram of durations (µs) for the processes' timing reports: its memory is
// allocated once, so adding a sample on a control tick allocates nothing.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace dynfilter::tools {

class Histogram {
 public:
  /// @p bins bins of @p bin_us each; larger samples land in the last bin (max() keeps them).
  Histogram(double bin_us, int bins) : bin_us_(bin_us), counts_(static_cast<std::size_t>(bins), 0) {}

  /// Adds one sample (µs); non-finite samples are ignored.
  void add(double us) {
    if (!std::isfinite(us)) return;
    const auto k = std::min(counts_.size() - 1, static_cast<std::size_t>(std::max(0.0, us / bin_us_)));
    ++counts_[k];
    ++n_;
    max_ = std::max(max_, us);
  }

  /// The @p p quantile (0..1) as the upper edge of its bin (µs); 0 when empty.
  double percentile(double p) const {
    if (n_ == 0) return 0.0;
    const auto target = static_cast<long>(std::ceil(p * static_cast<double>(n_)));
    long seen = 0;
    for (std::size_t k = 0; k < counts_.size(); ++k)
      if ((seen += counts_[k]) >= target) return std::min(max_, (static_cast<double>(k) + 1.0) * bin_us_);
    return max_;
  }
  double max() const { return max_; }
  long count() const { return n_; }

 private:
  double bin_us_;
  std::vector<long> counts_;
  long n_ = 0;
  double max_ = 0.0;
};

}  // namespace dynfilter::tools
