#include "toolpath_detail.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include "vmsim/common/errors.hpp"

namespace vmsim::planner::detail {

std::string read_text_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(located_message(path, 0, 0, "cannot open the tool path file"));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(located_message(path, 0, 0, "cannot read the tool path file"));
  return text.str();
}

std::optional<double> parse_decimal(std::string_view text) {
  // Checked by hand first: std::from_chars would also accept "inf", "nan" and hex-like forms.
  std::size_t i = 0;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
  std::size_t digits = 0;
  while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) ++i, ++digits;
  if (i < text.size() && text[i] == '.') {
    ++i;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) ++i, ++digits;
  }
  if (digits == 0) return std::nullopt;
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
    std::size_t exponent_digits = 0;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) {
      ++i, ++exponent_digits;
    }
    if (exponent_digits == 0) return std::nullopt;
  }
  if (i != text.size()) return std::nullopt;
  std::string_view body = text;
  if (body.front() == '+') body.remove_prefix(1);
  double value = 0.0;
  const auto [end, error] = std::from_chars(body.data(), body.data() + body.size(), value);
  if (error != std::errc() || end != body.data() + body.size() || !std::isfinite(value)) {
    return std::nullopt;
  }
  return value;
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

Eigen::Vector3d unit_tool_axis(const Eigen::Vector3d& v, const std::string& file, int line,
                               int column, const std::string& word) {
  const double norm = v.norm();
  if (!std::isfinite(norm) || norm == 0.0) {
    throw InputError(located_message(file, line, column,
                                     "zero tool axis vector in '" + word +
                                         "': the tool axis needs a direction"));
  }
  return v / norm;
}

void append_point(Toolpath& path, const PathPoint& point) {
  if (!path.points.empty()) {
    const PathPoint& last = path.points.back();
    if (last.tip_W_m == point.tip_W_m && last.axis_W == point.axis_W) return;
  }
  path.points.push_back(point);
}

void require_motion(const Toolpath& path, const std::string& file) {
  if (path.points.empty()) {
    throw InputError(located_message(file, 0, 0,
                                     "no motion: the tool path programs no tool position"));
  }
}

}  // namespace vmsim::planner::detail
