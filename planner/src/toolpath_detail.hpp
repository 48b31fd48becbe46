#pragma once
// Private helpers shared by the APT/CL and G-code readers (not installed, not part of the API).
#include <Eigen/Core>
#include <optional>
#include <string>
#include <string_view>

#include "vmsim/planner/toolpath.hpp"

namespace vmsim::planner::detail {

inline constexpr double kMetresPerMillimetre = 1e-3;
inline constexpr double kMillimetresPerInch = 25.4;
inline constexpr double kSecondsPerMinute = 60.0;

/// The whole file as text; throws InputError naming the file when it cannot be read.
std::string read_text_file(const std::string& path);

/// A decimal number written as [+|-]digits[.digits][e[+|-]digits], the whole of `text`
/// (no surrounding blanks); nullopt if malformed or not finite.
std::optional<double> parse_decimal(std::string_view text);

std::string to_upper(std::string_view text);
std::string trim(std::string_view text);

/// `v` scaled to unit length; throws InputError at file:line:column naming `word` when `v` is
/// zero or not finite.
Eigen::Vector3d unit_tool_axis(const Eigen::Vector3d& v, const std::string& file, int line,
                               int column, const std::string& word);

/// Appends `point` unless it repeats the previous point's tip and axis exactly (a zero-length
/// motion, which would give the planner nothing to move along).
void append_point(Toolpath& path, const PathPoint& point);

/// Throws InputError naming the file when the path has no point.
void require_motion(const Toolpath& path, const std::string& file);

}  // namespace vmsim::planner::detail
