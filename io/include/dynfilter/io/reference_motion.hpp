#pragma once
/// @file
/// Reading a reference motion (the filter's input) from a CSV file, and estimating
/// velocities and accelerations that the file does not give.
///
/// The file format is specified in README.md, section "Reference motion file". In short:
/// one row per frame; columns `time` (s), `base_x, base_y, base_z` (m, world),
/// `base_qw, base_qx, base_qy, base_qz` (quaternion of R_WB), one column per joint named
/// as the joint (rad or m); optionally all velocity columns (`base_vx..base_wz` in the base
/// frame, `<joint>.v`) and all acceleration columns (`base_ax..base_alphaz`, `<joint>.a`).
/// Frames come out in the model's coordinates (see dynfilter/core/model_info.hpp).

#include <string>
#include <vector>

#include "dynfilter/core/model_info.hpp"
#include "dynfilter/core/reference_frame.hpp"
#include "dynfilter/io/input_error.hpp"

namespace dynfilter::io {

/// A reference motion as read from a file.
struct ReferenceMotion {
  std::string source;                  ///< the path it was read from
  std::vector<ReferenceFrame> frames;  ///< ≥ 2 frames, strictly increasing time_s;
                                       ///< q dim nq (unit base quaternion), v and vdot dim nv
  bool had_velocities = false;     ///< v came from the file (else estimated, see below)
  bool had_accelerations = false;  ///< vdot came from the file (else estimated)
  /// Columns of joints the model has locked (ModelInfo::locked_joint_names), and of their
  /// velocities and accelerations: in the file, not read (the joint stays where it is welded).
  std::vector<std::string> ignored_columns;
};

struct ReferenceReadOptions {
  /// Frames in the local polynomial fit that estimates missing derivatives: odd, ≥ 3.
  int smoothing_window = 7;
  /// Largest accepted |‖quat‖ − 1| of a base quaternion in the file; quaternions within
  /// it are normalised, beyond it the file is rejected.
  double quaternion_tolerance = 1e-3;
  /// Ignore columns that are not part of the format (their fields are not even parsed)
  /// instead of rejecting the file; used to read a filtered-motion file back.
  bool allow_extra_columns = false;

  /// Throws std::invalid_argument on an even or too small window or a tolerance that is
  /// not in (0, 1).
  void validate() const;
};

/// Reads a reference motion for the model described by @p info.
///
/// Velocities and accelerations missing from the file are estimated with
/// estimateDerivatives() using ReferenceReadOptions::smoothing_window.
/// @throws InputError naming file, line, column (CSV column index, 1-based) and reason on
///         any violation of the format; std::invalid_argument on invalid @p options.
ReferenceMotion readReferenceMotion(const std::string& path, const ModelInfo& info,
                                    const ReferenceReadOptions& options = {});

/// Savitzky–Golay style derivative estimation on possibly non-uniform time stamps.
///
/// For every frame k a quadratic is fitted by least squares, over the @p smoothing_window
/// frames centred on k (shifted to stay inside the motion near its ends, so one-sided
/// there; all frames when there are fewer; a line when only 2), as a function of
/// τ = t_j − t_k. Joint coordinates are fitted directly. For a floating base the
/// neighbours are first expressed relative to frame k as body twists
/// ξ_j = logSE3(X_k⁻¹ X_j) ([linear (m); angular (rad)], base frame k) and those six
/// components are fitted. The first derivative of the fit at τ = 0 is the velocity
/// v_k = [v_B (m/s); ω_B (rad/s), both in the base frame; joint rates]; the second
/// derivative is the acceleration v̇_k = d v / dt (the derivative of the base-frame
/// velocity vector, as in the model's v̇).
///
/// @param frames          ≥ 2 frames, strictly increasing time_s, q dim nq; v and vdot are
///                        resized to nv where they are written
/// @param floating_base   whether q carries the 7 base coordinates in front
/// @param smoothing_window odd, ≥ 3
/// @param fill_velocities  write v
/// @param fill_accelerations write vdot
/// @throws std::invalid_argument on bad arguments
void estimateDerivatives(std::vector<ReferenceFrame>& frames, bool floating_base,
                         int smoothing_window, bool fill_velocities, bool fill_accelerations);

/// Zero-phase low-pass of the configurations (q only): each frame becomes the Gaussian-
/// weighted mean of its neighbours within 3σ, σ = 0.1325 / @p cutoff_hz (the Gaussian's
/// −3 dB frequency is the cutoff), with the kernel renormalised where it reaches past the
/// clip's ends. Joint coordinates and the base position are averaged directly; the base
/// orientation as R_k exp(Σ w_j log(R_kᵀ R_j)). Motion capture is commonly filtered at
/// 6–10 Hz: above that its second derivative is mostly marker noise. Time stamps are
/// kept; v and v̇ are not touched (estimate them again).
/// @throws std::invalid_argument on cutoff_hz ≤ 0 or frames of different sizes.
void lowPassConfigurations(std::vector<ReferenceFrame>& frames, bool floating_base, double cutoff_hz);

}  // namespace dynfilter::io
