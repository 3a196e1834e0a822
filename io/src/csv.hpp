#pragma once
// Private helpers of dynfilter::io: CSV splitting and exact number text, column names
// shared by the reference reader and the filtered-motion writer.

#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace dynfilter::io::detail {

inline constexpr std::array<const char*, 3> kBasePositionColumns{"base_x", "base_y", "base_z"};
inline constexpr std::array<const char*, 4> kBaseQuaternionColumns{"base_qw", "base_qx",
                                                                   "base_qy", "base_qz"};
inline constexpr std::array<const char*, 6> kBaseVelocityColumns{
    "base_vx", "base_vy", "base_vz", "base_wx", "base_wy", "base_wz"};
inline constexpr std::array<const char*, 6> kBaseAccelerationColumns{
    "base_ax", "base_ay", "base_az", "base_alphax", "base_alphay", "base_alphaz"};
inline constexpr const char* kTimeColumn = "time";
inline constexpr const char* kVelocitySuffix = ".v";
inline constexpr const char* kAccelerationSuffix = ".a";
inline constexpr const char* kTorqueSuffix = ".tau";

/// Spaces and tabs removed at both ends.
std::string_view trim(std::string_view s);

/// Splits one CSV line (no line terminator) into @p fields; @p count receives the number of
/// fields. @p fields is reused across calls (only grows) so that steady-state reading does
/// not allocate. Unquoted fields are trimmed; a field may be enclosed in double quotes
/// (surrounding spaces allowed) with "" standing for one quote and commas kept.
/// Returns false, with @p bad_field the 0-based field, on a malformed quoted field.
bool splitCsvLine(std::string_view line, std::vector<std::string>& fields, std::size_t& count,
                  std::size_t& bad_field);

enum class NumberStatus { kOk, kNotANumber, kNotFinite, kOutOfRange };
/// Parses a whole field as a decimal floating-point number (optional sign, digits, point,
/// exponent; "inf"/"nan" are recognised and reported as kNotFinite). Locale-independent,
/// correctly rounded.
NumberStatus parseDouble(std::string_view text, double& value);
/// What was wrong with a field that is not kOk ("not a number", ...), for error messages.
const char* describe(NumberStatus status);
/// @p s in double quotes, for error messages.
std::string quoted(std::string_view s);

/// Appends the shortest text that reads back as exactly @p x (std::to_chars); non-finite
/// values as "nan", "inf", "-inf".
void appendDouble(std::string& out, double x);
void appendInteger(std::string& out, long long x);
/// Appends @p text as a CSV field, quoted when it contains a comma, quote, line break,
/// leading/trailing blank or a leading '#'.
void appendCsvField(std::string& out, std::string_view text);

}  // namespace dynfilter::io::detail
