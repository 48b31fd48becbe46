#pragma once
// Private helpers shared by the APT/CL and G-code readers (not installed, not part of the API).
#include <Eigen/Core>
#include <cstddef>
#include <exception>
#include <new>
#include <optional>
#include <string>
#include <string_view>

#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath::detail {

inline constexpr double kMetresPerMillimetre = 1e-3;
inline constexpr double kMillimetresPerInch = 25.4;
inline constexpr double kSecondsPerMinute = 60.0;

// What the readers accept (toolpath.hpp, common rules "Numbers" and "Size"). Far beyond any machine,
// chosen so that sums, squares and tessellations of accepted numbers stay finite and small.
/// Largest coordinate, arc centre offset or radius [mm] (1 km).
inline constexpr double kMaxCoordinateMm = 1e6;
/// Largest rotary axis word [deg] (about 2 800 turns).
inline constexpr double kMaxRotaryDeg = 1e6;
/// Feed per minute [mm/min]: 1 um/min to 1 km/min.
inline constexpr double kMinFeedMmPerMin = 1e-3;
inline constexpr double kMaxFeedMmPerMin = 1e6;
/// G93 inverse-time feed [1/min]: a motion of 1000 min to one of 6 ms.
inline constexpr double kMinInverseTimePerMin = 1e-3;
inline constexpr double kMaxInverseTimePerMin = 1e4;
/// Cutter diameter [mm].
inline constexpr double kMinCutterDiameterMm = 1e-3;
inline constexpr double kMaxCutterDiameterMm = 1e4;
/// Spindle speed [rev/min] (APT SPINDL, G-code S).
inline constexpr double kMaxSpindleRevPerMin = 1e6;
/// Machining tolerances (APT INTOL OUTTOL TOLER LINTOL) [mm].
inline constexpr double kMaxToleranceMm = 1e3;
/// Integer-like words that are ignored (N O T H D, M codes) and G-code numbers.
inline constexpr double kMaxIgnoredWordValue = 1e9;

/// Largest tool path file [bytes] (1 GiB): a path of ReaderOptions::max_path_points takes
/// about 150 MB of text.
inline constexpr std::size_t kMaxFileBytes = std::size_t{1} << 30;
/// Largest G-code block [words]: each address may appear once, so a real block has a few dozen.
inline constexpr std::size_t kMaxWordsPerBlock = 64;
/// Largest APT record, continuations joined [bytes]: its values cost about 25 times their text.
inline constexpr std::size_t kMaxRecordBytes = std::size_t{4} << 20;

/// The whole file as text (common read_file: a regular file of at most kMaxFileBytes, else an
/// InputError naming the file).
std::string read_text_file(const std::string& path);

/// `text` without a leading UTF-8 byte-order mark (EF BB BF), which editors on Windows write and
/// which would otherwise be part of the first word.
std::string_view without_byte_order_mark(std::string_view text);

/// Throws InputError at file:line:column naming the byte (hex) where `text` is not UTF-8 or holds
/// a NUL byte (a binary file): the text of blocks goes into messages and JSON reports.
void require_utf8_text(std::string_view text, const std::string& file);

/// A decimal number written as [+|-]digits[.digits][e[+|-]digits], the whole of `text`
/// (no surrounding blanks); nullopt if malformed, out of the range of a double (1e400) or
/// subnormal (4.9e-324), with the reason in *problem when given.
std::optional<double> parse_decimal(std::string_view text, std::string* problem = nullptr);

/// Formats a number read from a file for a message: shortest form that reads back exactly.
std::string format_number(double value);

std::string to_upper(std::string_view text);
std::string trim(std::string_view text);

/// `v` scaled to unit length; throws InputError at file:line:column naming `word` when `v` is
/// zero or not finite.
Eigen::Vector3d unit_tool_axis(const Eigen::Vector3d& v, const std::string& file, int line,
                               int column, const std::string& word);

/// The length [mm] of the tool with T number `tool_number` (-1: none selected) from the spindle
/// gauge point to its tip: options.tool_length_mm[tool_number], else default_tool_length_mm;
/// nullopt when neither is given (a reading without tool data).
std::optional<double> spindle_tool_length_mm(const ReaderOptions& options, int tool_number);

/// The tip in W [m] of the tool in the spindle (`spindle_mm` long) at the machine position whose
/// pose ReaderOptions::axis_words_to_pose gave as `pose`. The callback places the caller's tool,
/// default_tool_length_mm long; the tool in the spindle has its tip (default - spindle) further
/// along the tool axis (tip = gauge point - length x axis). Unchanged where either length is
/// unknown or they are equal.
Eigen::Vector3d spindle_tip_W_m(const ReaderOptions& options, const AxisWordPose& pose,
                                const std::optional<double>& spindle_mm);

/// True when two points hold the same programmed rotary words (both unprogrammed counts as
/// the same).
bool same_rotary_words(const PathPoint& a, const PathPoint& b);

/// Appends `point` unless it repeats the previous point's tip, axis and rotary words exactly (a
/// zero-length motion, which would give the planner nothing to move along). Throws InputError
/// at file:line when the path would exceed options.max_path_points.
void append_point(Toolpath& path, const PathPoint& point, const ReaderOptions& options,
                  const std::string& file, int line);

/// Throws InputError at file:line:column when `more` further points (of one block) would exceed
/// options.max_points_per_block or, with those already in `path`, options.max_path_points.
/// `what` names the block's expansion ("the arc (radius ...)").
void require_room_for_points(const Toolpath& path, std::size_t more, const ReaderOptions& options,
                             const std::string& file, int line, int column,
                             const std::string& what);

/// A circular arc or helix in space [mm]: p(t) = centre + radius (cos(t sweep) u + sin(t sweep)
/// v) + t lift, t in [0, 1]; u, v orthonormal (u from the centre to the start, v the direction
/// of motion at the start), sweep > 0.
struct SpaceArc {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d u = Eigen::Vector3d::UnitX();
  Eigen::Vector3d v = Eigen::Vector3d::UnitY();
  Eigen::Vector3d lift = Eigen::Vector3d::Zero();
  double radius = 0.0;
  double sweep_rad = 0.0;
  Eigen::Vector3d at(double t) const;
  /// Unit direction of motion at t (the helix's lift included).
  Eigen::Vector3d tangent(double t) const;
};

/// Throws InputError naming the file when the path has no point.
void require_motion(const Toolpath& path, const std::string& file);

// --- Arcs (G2/G3; Heidenhain C, CR, CT, RND), in the arc plane's two axes [mm] ------------------

/// End points closer than this [mm] in the arc plane make a full circle (centre forms).
inline constexpr double kFullCircleDistanceMm = 1e-9;

/// The centre of the arc of radius |radius_mm| from s to e, turning counter-clockwise when
/// `ccw`: the arc of at most 180 deg for radius_mm > 0, of more for radius_mm < 0. Where |radius|
/// is smaller than half the chord the centre is the chord's middle and *short_by_mm gets how
/// much smaller (0 otherwise): the caller accepts it within its tolerance or fails. s != e.
Eigen::Vector2d arc_centre_from_radius(const Eigen::Vector2d& s, const Eigen::Vector2d& e,
                                       double radius_mm, bool ccw, double* short_by_mm);

/// The point of the perpendicular bisector of s and e nearest to c: the centre of a circle
/// through both, as a control corrects a centre whose start and end radii differ a little.
Eigen::Vector2d centre_on_bisector(const Eigen::Vector2d& s, const Eigen::Vector2d& e,
                                   const Eigen::Vector2d& c);

/// The angle swept from s to e about c [rad]: in (0, 2 pi] counter-clockwise, in [-2 pi, 0)
/// clockwise; +-2 pi for a full circle.
double arc_sweep_rad(const Eigen::Vector2d& s, const Eigen::Vector2d& e, const Eigen::Vector2d& c,
                     bool ccw, bool full_circle);

/// The number of chords (at least 1, as a double: it may be huge) that keep the chord error of
/// an arc of radius radius_mm sweeping sweep_rad within chord_tolerance_mm; chords span at most
/// 90 deg. Shared by the G-code, Siemens and Heidenhain readers.
double arc_chord_count(double radius_mm, double sweep_rad, double chord_tolerance_mm);

/// Runs `reader.read(text)`. Every failure of a reader is about its input: an exception that is
/// not already one of vmsim's located errors (an InfeasibleError comes from a caller's callback,
/// a word outside the travel) becomes an InputError at the reader's current line.
template <class Reader>
Toolpath read_with_located_errors(Reader& reader, const std::string& text, const std::string& file) {
  try {
    return reader.read(text);
  } catch (const InputError&) {
    throw;
  } catch (const InfeasibleError&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw InputError(located_message(file, reader.current_line(), 0, "out of memory reading the tool path"));
  } catch (const std::exception& error) {
    throw InputError(located_message(file, reader.current_line(), 0,
                                     std::string("cannot read the tool path: ") + error.what()));
  }
}

}  // namespace vmsim::toolpath::detail
