#include "toolpath_detail.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <algorithm>
#include <limits>
#include <numbers>
#include <filesystem>
#include <fstream>
#include <system_error>
#include <sstream>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::toolpath::detail {

std::string read_text_file(const std::string& path) {
  // read_file refuses what is not a regular file (a FIFO would block) and sizes it first.
  return read_file(path, kMaxFileBytes);
}

std::string_view without_byte_order_mark(std::string_view text) { return strip_utf8_bom(text); }

void require_utf8_text(std::string_view text, const std::string& file) {
  int line = 1;
  std::size_t line_start = 0;
  std::size_t i = 0;
  const auto fail = [&](std::size_t at, const std::string& what) {
    char hex[8];
    std::snprintf(hex, sizeof hex, "0x%02X", static_cast<unsigned>(static_cast<unsigned char>(text[at])));
    throw InputError(located_message(file, line, static_cast<int>(at - line_start) + 1,
                                     "byte " + std::string(hex) + " " + what +
                                         ": a tool path must be UTF-8 (or ASCII) text"));
  };
  const auto byte = [&](std::size_t at) { return static_cast<unsigned char>(text[at]); };
  while (i < text.size()) {
    const unsigned char lead = byte(i);
    if (lead == '\n') {
      ++line;
      line_start = ++i;
      continue;
    }
    if (lead == 0) fail(i, "(NUL, a binary file?)");
    if (lead < 0x80) {
      ++i;
      continue;
    }
    // The ranges of RFC 3629 (no overlong forms, no surrogates, nothing beyond U+10FFFF).
    std::size_t length = 0;
    unsigned char second_min = 0x80;
    unsigned char second_max = 0xBF;
    if (lead >= 0xC2 && lead <= 0xDF) {
      length = 2;
    } else if (lead >= 0xE0 && lead <= 0xEF) {
      length = 3;
      if (lead == 0xE0) second_min = 0xA0;
      if (lead == 0xED) second_max = 0x9F;
    } else if (lead >= 0xF0 && lead <= 0xF4) {
      length = 4;
      if (lead == 0xF0) second_min = 0x90;
      if (lead == 0xF4) second_max = 0x8F;
    } else {
      fail(i, "is not UTF-8");
    }
    for (std::size_t k = 1; k < length; ++k) {
      if (i + k >= text.size()) fail(i, "starts a UTF-8 sequence that the file cuts short");
      const unsigned char c = byte(i + k);
      const unsigned char low = k == 1 ? second_min : 0x80;
      const unsigned char high = k == 1 ? second_max : 0xBF;
      if (c < low || c > high) {
        char next_hex[8];
        std::snprintf(next_hex, sizeof next_hex, "0x%02X", static_cast<unsigned>(c));
        fail(i, "is not UTF-8 (not followed by a continuation byte: " + std::string(next_hex) +
                    " comes next)");
      }
    }
    i += length;
  }
}

std::optional<double> parse_decimal(std::string_view text, std::string* problem) {
  const auto refuse = [&](const char* why) -> std::optional<double> {
    if (problem) *problem = why;
    return std::nullopt;
  };
  // Checked by hand first: std::from_chars would also accept "inf", "nan" and hex-like forms.
  std::size_t i = 0;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
  std::size_t digits = 0;
  // The decimal order of magnitude of the first non-zero digit, for out-of-range numbers.
  long order = 0;
  bool nonzero_seen = false;
  while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) {
    if (nonzero_seen) ++order;
    if (text[i] != '0') nonzero_seen = true;
    ++i, ++digits;
  }
  if (i < text.size() && text[i] == '.') {
    ++i;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) {
      if (!nonzero_seen) --order;
      if (text[i] != '0') nonzero_seen = true;
      ++i, ++digits;
    }
  }
  if (digits == 0) return refuse("malformed number");
  long exponent = 0;
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    bool negative = false;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) negative = text[i++] == '-';
    std::size_t exponent_digits = 0;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) {
      if (exponent < 100'000'000) exponent = 10 * exponent + (text[i] - '0');
      ++i, ++exponent_digits;
    }
    if (exponent_digits == 0) return refuse("malformed number");
    if (negative) exponent = -exponent;
  }
  if (i != text.size()) return refuse("malformed number");
  std::string_view body = text;
  if (body.front() == '+') body.remove_prefix(1);
  double value = 0.0;
  const auto [end, error] = std::from_chars(body.data(), body.data() + body.size(), value);
  if (error == std::errc::result_out_of_range ||
      (error == std::errc() && (!std::isfinite(value) || (value == 0.0 && nonzero_seen)))) {
    return refuse(order + exponent > 0 ? "number too large (beyond the range of a double)"
                                       : "number too small (below the range of a double)");
  }
  if (error != std::errc() || end != body.data() + body.size()) {
    return refuse("malformed number");
  }
  if (value != 0.0 && std::abs(value) < std::numeric_limits<double>::min()) {
    return refuse("number too small (a subnormal double, below 2.2e-308)");
  }
  return value;
}

std::string format_number(double value) {
  char buffer[32];
  const auto [end, error] = std::to_chars(buffer, buffer + sizeof buffer, value);
  if (error != std::errc()) return std::to_string(value);
  return std::string(buffer, end);
}

std::string to_upper(std::string_view text) {
  std::string upper(text);
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return upper;
}

std::string trim(std::string_view text) {
  std::size_t begin = 0;
  std::size_t end = text.size();
  while (begin < end && std::isspace(static_cast<unsigned char>(text[begin]))) ++begin;
  while (end > begin && std::isspace(static_cast<unsigned char>(text[end - 1]))) --end;
  return std::string(text.substr(begin, end - begin));
}

std::optional<double> spindle_tool_length_mm(const ReaderOptions& options, int tool_number) {
  if (tool_number >= 0) {
    if (const auto it = options.tool_length_mm.find(tool_number); it != options.tool_length_mm.end()) return it->second;
  }
  return options.default_tool_length_mm;
}

Eigen::Vector3d spindle_tip_W_m(const ReaderOptions& options, const AxisWordPose& pose,
                                const std::optional<double>& spindle_mm) {
  if (!spindle_mm || !options.default_tool_length_mm || *spindle_mm == *options.default_tool_length_mm) {
    return pose.tip_W_m;
  }
  const double longer_by_m = (*spindle_mm - *options.default_tool_length_mm) * 1e-3;
  return pose.tip_W_m - longer_by_m * pose.axis_W.normalized();
}

Eigen::Vector3d unit_tool_axis(const Eigen::Vector3d& v, const std::string& file, int line,
                               int column, const std::string& word) {
  // Scaled by the largest component first, so that huge or tiny components neither overflow
  // nor underflow the norm.
  const double largest = v.cwiseAbs().maxCoeff();
  if (!std::isfinite(largest) || largest == 0.0) {
    throw InputError(located_message(file, line, column,
                                     "zero tool axis vector in '" + word +
                                         "': the tool axis needs a direction"));
  }
  if (largest > 1e-100 && largest < 1e100) return v / v.norm();
  const Eigen::Vector3d scaled = v / largest;
  return scaled / scaled.norm();
}

bool same_rotary_words(const PathPoint& a, const PathPoint& b) {
  for (std::size_t k = 0; k < a.rotary_words_deg.size(); ++k) {
    const double x = a.rotary_words_deg[k];
    const double y = b.rotary_words_deg[k];
    if (std::isnan(x) != std::isnan(y)) return false;
    if (!std::isnan(x) && x != y) return false;
  }
  return true;
}

void append_point(Toolpath& path, const PathPoint& point, const ReaderOptions& options,
                  const std::string& file, int line) {
  if (!path.points.empty()) {
    PathPoint& last = path.points.back();
    // The same tip with a tool of another length is another machine position (G43 H2 Z50
    // after T2 M6 lifts the spindle by the difference).
    const bool same_length = last.tool_length_m == point.tool_length_m ||
                             (std::isnan(last.tool_length_m) && std::isnan(point.tool_length_m));
    if (last.tip_W_m == point.tip_W_m && last.axis_W == point.axis_W &&
        same_rotary_words(last, point) && same_length) {
      last.dwell_s += point.dwell_s;  // a dwell where the tool already is still holds it
      return;
    }
  }
  if (path.points.size() >= options.max_path_points) {
    throw InputError(located_message(
        file, line, 0,
        "the tool path expands to more than " + std::to_string(options.max_path_points) +
            " points by this block, the limit (ReaderOptions::max_path_points; about 1 kB of memory "
            "per point along the chain)"));
  }
  path.points.push_back(point);
}

void require_room_for_points(const Toolpath& path, std::size_t more, const ReaderOptions& options,
                             const std::string& file, int line, int column,
                             const std::string& what) {
  if (more > options.max_points_per_block) {
    throw InputError(located_message(
        file, line, column,
        what + " expands to " + std::to_string(more) + " points, more than the limit of " +
            std::to_string(options.max_points_per_block) + " points per block (ReaderOptions::max_points_per_block)"));
  }
  if (path.points.size() + more > options.max_path_points) {
    throw InputError(located_message(
        file, line, column,
        what + " expands to " + std::to_string(more) + " points, which brings the tool path to " +
            std::to_string(path.points.size() + more) + " points, more than the limit of " +
            std::to_string(options.max_path_points) +
            " points (ReaderOptions::max_path_points; about 1 kB of memory per point along the "
            "chain)"));
  }
}

void require_motion(const Toolpath& path, const std::string& file) {
  if (path.points.empty()) {
    throw InputError(located_message(file, 0, 0,
                                     "no motion: the tool path programs no tool position"));
  }
}

Eigen::Vector2d arc_centre_from_radius(const Eigen::Vector2d& s, const Eigen::Vector2d& e,
                                       double radius_mm, bool ccw, double* short_by_mm) {
  const double r = std::abs(radius_mm);
  const double d = (e - s).norm();
  double h2 = r * r - 0.25 * d * d;
  if (short_by_mm) *short_by_mm = h2 < 0.0 ? 0.5 * d - r : 0.0;
  if (h2 < 0.0) h2 = 0.0;
  const Eigen::Vector2d chord = (e - s) / d;
  const Eigen::Vector2d left(-chord.y(), chord.x());
  // A counter-clockwise arc of at most 180 deg has its centre left of the chord; a negative
  // radius asks for the arc of more than 180 deg, whose centre is on the other side.
  const double side = (ccw ? 1.0 : -1.0) * (radius_mm > 0.0 ? 1.0 : -1.0);
  return 0.5 * (s + e) + side * std::sqrt(h2) * left;
}

Eigen::Vector2d centre_on_bisector(const Eigen::Vector2d& s, const Eigen::Vector2d& e,
                                   const Eigen::Vector2d& c) {
  const Eigen::Vector2d chord = (e - s).normalized();
  const Eigen::Vector2d normal(-chord.y(), chord.x());
  const Eigen::Vector2d middle = 0.5 * (s + e);
  return middle + (c - middle).dot(normal) * normal;
}

double arc_sweep_rad(const Eigen::Vector2d& s, const Eigen::Vector2d& e, const Eigen::Vector2d& c,
                     bool ccw, bool full_circle) {
  constexpr double two_pi = 2.0 * std::numbers::pi;
  if (full_circle) return ccw ? two_pi : -two_pi;
  const double a0 = std::atan2(s.y() - c.y(), s.x() - c.x());
  const double a1 = std::atan2(e.y() - c.y(), e.x() - c.x());
  double sweep = a1 - a0;
  if (ccw) {
    while (sweep <= 0.0) sweep += two_pi;
    while (sweep > two_pi) sweep -= two_pi;
  } else {
    while (sweep >= 0.0) sweep -= two_pi;
    while (sweep < -two_pi) sweep += two_pi;
  }
  return sweep;
}

double arc_chord_count(double radius_mm, double sweep_rad, double chord_tolerance_mm) {
  // Chord error of a chord of angle delta on radius r: r (1 - cos(delta / 2)).
  double max_delta = std::numbers::pi / 2.0;
  if (chord_tolerance_mm < radius_mm) {
    max_delta = std::min(max_delta, 2.0 * std::acos(1.0 - chord_tolerance_mm / radius_mm));
  }
  return std::max(1.0, std::ceil(std::abs(sweep_rad) / max_delta));
}

Eigen::Vector3d SpaceArc::at(double t) const {
  const double angle = t * sweep_rad;
  return centre + radius * (std::cos(angle) * u + std::sin(angle) * v) + t * lift;
}

Eigen::Vector3d SpaceArc::tangent(double t) const {
  const double angle = t * sweep_rad;
  const Eigen::Vector3d d =
      radius * sweep_rad * (-std::sin(angle) * u + std::cos(angle) * v) + lift;
  return d.normalized();
}

}  // namespace vmsim::toolpath::detail
