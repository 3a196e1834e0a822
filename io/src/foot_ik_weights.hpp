#pragma once
// IK weights of the feet's targets (PoseIk), shared by the clean-up and followTerrain: the
// feet are met to a fraction of a millimetre while the rest of the body gives way.

namespace dynfilter::io {

inline constexpr double kFootPositionWeight = 1e3;      // 1/m
inline constexpr double kFootOrientationWeight = 10.0;  // 1/rad

}  // namespace dynfilter::io
