#pragma once
/// @file
/// Writing the filter's per-tick output to CSV, atomically.
///
/// Two files (UTF-8, LF, comma-separated, one header line, no comments, numbers in the
/// shortest form that reads back bit-exactly, i.e. std::to_chars; non-finite as nan/inf):
///
/// `<path>`, one row per tick written, columns in this order:
/// - `time` (s), `status` (FilterStatusBits, unsigned integer: with rows at a lower rate
///   than the ticks, e.g. one per reference frame, the union of the statuses of the ticks
///   since the previous row, so that no re-seed between rows is hidden);
/// - q: `base_x, base_y, base_z` (m, world), `base_qw, base_qx, base_qy, base_qz`
///   (quaternion of R_WB) — floating base only — then one column per joint named as the
///   joint (rad or m);
/// - v: `base_vx, base_vy, base_vz` (m/s, base frame), `base_wx, base_wy, base_wz`
///   (rad/s, base frame), `<joint>.v`;
/// - v̇: `base_ax, base_ay, base_az` (m/s²), `base_alphax, base_alphay, base_alphaz`
///   (rad/s²), `<joint>.a` — the derivative of v, base part in the base frame;
/// - `<joint>.tau` (N m or N);
/// - the tracking error qʳᵉᶠ ⊖ q (dim nv): `err.base_x, err.base_y, err.base_z` (m),
///   `err.base_rx, err.base_ry, err.base_rz` (rad), `err.<joint>`;
/// - the task-point error `task_err.x, task_err.y, task_err.z` (m),
///   `task_err.rx, task_err.ry, task_err.rz` (rad);
/// - `eq12_residual`, `base_residual_n` (N, N m), `max_penetration_m` (m),
///   `num_contacts`, `solve_time_s`, `tick_time_s` (s).
///
/// `<dir>/<stem>.contacts.csv` next to it (stem: the file name of `<path>` without its
/// last extension), long format, one row per valid contact per tick:
/// `time` (s), `index` (0-based within the tick), `body` (link name), `object` (−1 for
/// the ground, else the box index in Environment::boxes), `kind` (point|edge|face),
/// `px, py, pz` (contact frame origin, m, world), `nx, ny, nz` (surface normal, world),
/// `fx, fy, fz` (N, world), `mx, my, mz` (N m about p, world), `normal_force_n` (N),
/// `cop_x, cop_y` (centre of pressure in the anchor frame's xy, m).
///
/// The main file is a valid reference motion file (readReferenceMotion with
/// ReferenceReadOptions::allow_extra_columns) that reads back q, v and v̇ bit-exactly.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "dynfilter/core/filter_output.hpp"
#include "dynfilter/core/model_info.hpp"
#include "dynfilter/io/input_error.hpp"

namespace dynfilter::io {

/// Streams FilterOutput rows to temporary files `<path>.tmp.*` and
/// `<contacts path>.tmp.*` in the same directories; commit() renames them into place
/// (contacts file first, then the main file, each with an atomic rename after fsync).
/// Destroying the writer without commit() removes the temporaries, so a half-written
/// file never appears at either final path. Existing files at the final paths are
/// replaced only by commit().
///
/// I/O failures throw InputError naming the file (line 0).
class FilteredMotionWriter {
 public:
  /// Body names for the contacts file are info.body_names.
  FilteredMotionWriter(std::string path, const ModelInfo& info);
  /// @param body_names names of the body indices in ContactOutput::body
  FilteredMotionWriter(std::string path, const ModelInfo& info,
                       std::vector<std::string> body_names);
  ~FilteredMotionWriter();
  FilteredMotionWriter(FilteredMotionWriter&&) noexcept;
  FilteredMotionWriter& operator=(FilteredMotionWriter&&) noexcept;
  FilteredMotionWriter(const FilteredMotionWriter&) = delete;
  FilteredMotionWriter& operator=(const FilteredMotionWriter&) = delete;

  /// Appends one tick.
  /// @param out q dim nq, v and vdot and tracking_error dim nv, tau_J dim nj,
  ///            0 ≤ num_contacts ≤ contacts.size(), contact bodies valid indices into the
  ///            body names.
  /// @throws std::invalid_argument on wrong sizes or indices (nothing written);
  ///         std::logic_error after commit(); InputError on a write failure.
  void append(const FilterOutput& out);
  /// The same, with @p row_status written as the status (e.g. io::OfflineTick::row_status,
  /// the union of the statuses of the ticks since the previous row).
  void append(const FilterOutput& out, std::uint32_t row_status);

  /// Flushes, syncs and renames both files into place. Afterwards the writer is spent.
  /// @throws InputError on failure (the temporaries are then removed);
  ///         std::logic_error when called twice.
  void commit();

  /// The final path of the main file.
  const std::string& path() const;
  /// The final path of the contacts file.
  const std::string& contactsPath() const;
  /// Rows appended so far (ticks).
  std::size_t rows() const;

  /// `<dir>/<stem>.contacts.csv` for a main file at @p path.
  static std::string contactsPathFor(const std::string& path);
  /// Header of the main file for @p info, in column order.
  static std::vector<std::string> mainColumns(const ModelInfo& info);
  /// Header of the contacts file, in column order.
  static std::vector<std::string> contactColumns();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dynfilter::io
