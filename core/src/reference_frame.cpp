#include "dynfilter/core/reference_frame.hpp"

#include <algorithm>

#include "dynfilter/core/lie_group.hpp"

namespace dynfilter {

void interpolateReference(bool floating_base, const ReferenceFrame& a, const ReferenceFrame& b,
                          double t_s, ReferenceFrame& out) {
  const double span = b.time_s - a.time_s;
  const double s = span > 0.0 ? std::clamp((t_s - a.time_s) / span, 0.0, 1.0) : 0.0;
  out.time_s = a.time_s + s * span;
  // q = a ⊕ s (b ⊖ a); the difference goes through out.vdot as scratch (same size nv).
  differenceConfiguration(floating_base, a.q, b.q, out.vdot);
  integrateConfiguration(floating_base, a.q, out.vdot, s, out.q);
  out.v = (1.0 - s) * a.v + s * b.v;
  out.vdot = (1.0 - s) * a.vdot + s * b.vdot;
}

}  // namespace dynfilter
