// APT/CL reader: the subset documented in vmsim/toolpath/toolpath.hpp ("APT/CL subset").
#include <array>
#include <cctype>
#include <cmath>
#include <exception>
#include <new>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "toolpath_detail.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

using detail::kMetresPerMillimetre;
using detail::kMillimetresPerInch;
using detail::kSecondsPerMinute;

/// Where a character of a logical record came from.
struct Position {
  int line = 0;
  int column = 0;
};

/// One comma-separated value after the slash, trimmed, with the position of its first character.
struct Token {
  std::string text;  ///< as written
  std::string upper;
  Position at;
};

/// One logical record: a physical line with its `$` continuations joined.
struct Record {
  std::string text;                ///< joined text, as written (for SourceBlock::text)
  std::vector<Position> position;  ///< of every character of `text`
  std::string name;                ///< upper case, e.g. "GOTO", "TOOL PATH"
  Position name_at;
  bool has_slash = false;
  std::vector<Token> args;
  std::string trailing;  ///< text after the name when there is no slash
  Position trailing_at;
};

// Records that carry free text: the rest of the line is not parsed (no `$`, no commas).
const std::set<std::string, std::less<>> kTextRecords = {"PARTNO", "PPRINT", "INSERT", "REMARK",
                                                         "TITLE"};

// Records that do not move the tool and do not change its geometry: accepted silently.
const std::set<std::string, std::less<>> kHarmlessRecords = {
    "SPINDL", "COOLNT", "LOADTL", "END",    "CLPRNT", "NOPOST",      "MACHIN",   "SELCTL",
    "TOOLNO", "TURRET", "STOP",   "OPSTOP", "DELAY",  "SEQNO",       "OPSKIP",   "AUXFUN",
    "PREFUN", "INTOL",  "OUTTOL", "TOLER",  "LINTOL", "PLABEL",      "DISPLY",   "CLEARP",
    "TLDATA", "MSYS",   "PAINT",  "AIR",    "HEAD",   "END-OF-PATH", "TOOL PATH", "OPERATION",
    "TLON",   "TLOFF",  "MODE",   "PITCH",  "SAFETY",      "TMARK",    "LEADER"};

class AptReader {
 public:
  AptReader(const std::string& file, const ReaderOptions& options)
      : file_(file), options_(options) {}

  /// The physical line being read (for errors that are not the reader's own).
  int current_line() const { return current_line_; }

  Toolpath read(std::string_view text) {
    text = detail::without_byte_order_mark(text);
    detail::require_utf8_text(text, file_);
    int& line_number = current_line_;
    std::size_t begin = 0;
    bool continuing = false;
    Record record;
    while (begin < text.size() && !finished_) {
      std::size_t end = text.find('\n', begin);
      if (end == std::string_view::npos) end = text.size();
      std::string_view line = text.substr(begin, end - begin);
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      ++line_number;
      begin = end + 1;

      if (!continuing) {
        const std::string stripped = detail::trim(line);
        if (stripped.empty() || stripped.starts_with("$$")) continue;
        if (is_text_record(stripped)) continue;
        record = Record{};
      }
      // Cut a `$$` comment, then a trailing `$` means "continued on the next line".
      std::size_t content_end = line.find("$$");
      if (content_end == std::string_view::npos) content_end = line.size();
      while (content_end > 0 && std::isspace(static_cast<unsigned char>(line[content_end - 1]))) {
        --content_end;
      }
      continuing = content_end > 0 && line[content_end - 1] == '$';
      if (continuing) --content_end;
      if (!record.text.empty()) {
        // A blank between the joined lines, so that "1.0$" + "2.0" cannot become "1.02.0".
        record.text.push_back(' ');
        record.position.push_back(record.position.back());
      }
      if (record.text.size() + content_end > detail::kMaxRecordBytes) {
        fail(Position{line_number, 0},
             "the record is longer than " + std::to_string(detail::kMaxRecordBytes) +
                 " bytes (continuations joined), the limit");
      }
      for (std::size_t i = 0; i < content_end; ++i) {
        record.text.push_back(line[i]);
        record.position.push_back(Position{line_number, static_cast<int>(i) + 1});
      }
      if (continuing) continue;
      if (detail::trim(record.text).empty()) continue;
      split(record);
      interpret(record);
    }
    if (continuing && !finished_) {
      throw InputError(located_message(file_, line_number, 0,
                                       "the file ends inside a record continued with '$'"));
    }
    detail::require_motion(path_, file_);
    return std::move(path_);
  }

 private:
  static bool is_text_record(const std::string& stripped) {
    std::size_t end = 0;
    while (end < stripped.size() && std::isalpha(static_cast<unsigned char>(stripped[end]))) {
      ++end;
    }
    if (end < stripped.size() && stripped[end] != '/' &&
        !std::isspace(static_cast<unsigned char>(stripped[end]))) {
      return false;
    }
    return kTextRecords.count(detail::to_upper(stripped.substr(0, end))) > 0;
  }

  void split(Record& record) const {
    const std::string& s = record.text;
    std::size_t first = 0;
    while (first < s.size() && std::isspace(static_cast<unsigned char>(s[first]))) ++first;
    record.name_at = record.position[first];
    const std::size_t slash = s.find('/');
    if (slash == std::string::npos) {
      std::size_t name_end = first;
      while (name_end < s.size() && !std::isspace(static_cast<unsigned char>(s[name_end]))) {
        ++name_end;
      }
      record.name = detail::to_upper(s.substr(first, name_end - first));
      std::size_t rest = name_end;
      while (rest < s.size() && std::isspace(static_cast<unsigned char>(s[rest]))) ++rest;
      record.trailing = detail::trim(s.substr(rest));
      if (rest < s.size()) record.trailing_at = record.position[rest];
      return;
    }
    record.has_slash = true;
    record.name = detail::to_upper(detail::trim(s.substr(first, slash - first)));
    if (detail::trim(s.substr(slash + 1)).empty()) return;  // "RAPID/" : no value
    std::size_t start = slash + 1;
    while (true) {
      std::size_t comma = s.find(',', start);
      if (comma == std::string::npos) comma = s.size();
      std::size_t b = start;
      while (b < comma && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
      std::size_t e = comma;
      while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
      Token token;
      token.text = s.substr(b, e - b);
      token.upper = detail::to_upper(token.text);
      // An empty value is placed at its comma (or at the end of the record).
      token.at = record.position[std::min(b, s.size() - 1)];
      if (b == s.size()) token.at.column += 1;
      record.args.push_back(std::move(token));
      if (comma == s.size()) break;
      start = comma + 1;
    }
  }

  [[noreturn]] void fail(const Position& at, const std::string& message) const {
    throw InputError(located_message(file_, at.line, at.column, message));
  }

  void warn(const Record& record, const std::string& message) {
    // A file of millions of unknown records would otherwise give millions of warnings.
    ++warning_count_;
    if (warning_count_ < kMaxWarnings) {
      path_.warnings.push_back(ReaderWarning{file_, record.name_at.line, message});
    } else if (warning_count_ == kMaxWarnings) {
      path_.warnings.push_back(ReaderWarning{
          file_, record.name_at.line,
          "more than " + std::to_string(kMaxWarnings) + " warnings: the rest are not listed"});
    }
  }

  double number(const Record& record, const Token& token) const {
    if (token.text.empty()) {
      fail(token.at, "empty value in " + record.name + ": a number is needed");
    }
    std::string problem;
    const std::optional<double> value = detail::parse_decimal(token.text, &problem);
    if (!value) {
      fail(token.at, problem + " '" + token.text + "' in " + record.name);
    }
    return *value;
  }

  /// A number that must lie in [min, max] (in the unit `unit` after multiplying by `scale`).
  double number_within(const Record& record, const Token& token, double scale, double min,
                       double max, const std::string& what, const std::string& unit) const {
    const double value = number(record, token) * scale;
    if (!(value >= min && value <= max)) {
      fail(token.at, what + " '" + token.text + "' in " + record.name + " is outside [" +
                         detail::format_number(min) + ", " + detail::format_number(max) + "] " +
                         unit);
    }
    return value;
  }

  static bool looks_numeric(const Token& token) {
    if (token.text.empty()) return false;
    const char c = token.text[0];
    return std::isdigit(static_cast<unsigned char>(c)) || c == '+' || c == '-' || c == '.';
  }

  /// SPINDL and the tolerance records are otherwise ignored, but their numbers are checked:
  /// a spindle speed of 1e400 or a tolerance of 4.9e-324 is a broken file.
  void check_ignored_numbers(const Record& record) const {
    const bool spindle = record.name == "SPINDL";
    const bool tolerance = record.name == "INTOL" || record.name == "OUTTOL" ||
                           record.name == "TOLER" || record.name == "LINTOL";
    if (!spindle && !tolerance) return;
    for (const Token& token : record.args) {
      if (!looks_numeric(token)) continue;
      if (spindle) {
        number_within(record, token, 1.0, -detail::kMaxSpindleRevPerMin,
                      detail::kMaxSpindleRevPerMin, "spindle speed", "rev/min");
      } else {
        number_within(record, token, mm_per_unit_, -detail::kMaxToleranceMm,
                      detail::kMaxToleranceMm, "tolerance", "mm");
      }
    }
  }

  /// A coordinate in the UNITS unit, returned in mm.
  double coordinate_mm(const Record& record, const Token& token) const {
    return number_within(record, token, mm_per_unit_, -detail::kMaxCoordinateMm,
                         detail::kMaxCoordinateMm, "coordinate", "mm");
  }

  [[noreturn]] void fail_count(const Record& record, const std::string& expected) const {
    fail(record.name_at, record.name + " needs " + expected + ", got " +
                             std::to_string(record.args.size()) + " value(s) in '" +
                             detail::trim(record.text) + "'");
  }

  void require_no_args(const Record& record) const {
    if (!record.args.empty()) {
      fail(record.args.front().at, record.name + " takes no value, got '" +
                                       record.args.front().text + "'");
    }
  }

  void interpret(const Record& record) {
    const std::string& name = record.name;
    if (!record.has_slash && !record.trailing.empty()) {
      if (name == "GOTO" || name == "FROM" || name == "FEDRAT" || name == "UNITS" ||
          name == "CUTTER" || name == "TLAXIS" || name == "MULTAX" || name == "RAPID") {
        fail(record.trailing_at,
             "expected '/' after " + name + ", found '" + record.trailing + "'");
      }
      if (kHarmlessRecords.count(name) == 0) {
        warn(record, "unknown APT record '" + detail::trim(record.text) + "' ignored");
      }
      return;
    }
    if (name == "GOTO") {
      goto_record(record, false);
    } else if (name == "FROM") {
      goto_record(record, true);
    } else if (name == "RAPID") {
      require_no_args(record);
      rapid_next_ = true;
    } else if (name == "FEDRAT") {
      fedrat(record);
    } else if (name == "UNITS") {
      if (record.args.size() != 1) fail_count(record, "one of MM, INCHES");
      const Token& unit = record.args[0];
      if (unit.upper == "MM" || unit.upper == "MILLIMETERS") {
        mm_per_unit_ = 1.0;
      } else if (unit.upper == "INCHES" || unit.upper == "INCH") {
        mm_per_unit_ = kMillimetresPerInch;
      } else {
        fail(unit.at, "unknown unit '" + unit.text + "' in UNITS: use MM or INCHES");
      }
    } else if (name == "CUTTER") {
      cutter(record);
    } else if (name == "LOADTL" && !record.args.empty()) {
      loadtl(record);
    } else if (name == "MULTAX") {
      if (record.args.empty()) {
        multax_ = Multax::on;
      } else if (record.args.size() == 1 && record.args[0].upper == "ON") {
        multax_ = Multax::on;
      } else if (record.args.size() == 1 && record.args[0].upper == "OFF") {
        multax_ = Multax::off;
      } else {
        fail(record.args[0].at, "MULTAX takes ON or OFF, got '" + record.args[0].text + "'");
      }
    } else if (name == "TLAXIS") {
      if (record.args.size() != 3) fail_count(record, "3 numbers i,j,k");
      const Eigen::Vector3d v(number(record, record.args[0]), number(record, record.args[1]),
                              number(record, record.args[2]));
      axis_W_ = detail::unit_tool_axis(v, file_, record.name_at.line, record.name_at.column,
                                       detail::trim(record.text));
    } else if (name == "FINI") {
      finished_ = true;
    } else if (name == "CUTCOM") {
      if (record.args.size() != 1 || record.args[0].upper != "OFF") {
        fail(record.name_at, "cutter compensation '" + detail::trim(record.text) +
                                 "' is not supported: output tool tip (CL) points");
      }
    } else if (name == "CYCLE") {
      if (record.args.size() != 1 || record.args[0].upper != "OFF") {
        fail(record.name_at, "canned cycle '" + detail::trim(record.text) +
                                 "' is not supported: output the cycle as GOTO points");
      }
    } else if (name == "CIRCLE" || name == "MOVARC") {
      fail(record.name_at, "circular motion '" + detail::trim(record.text) +
                               "' is not supported: output the arc as GOTO points");
    } else if (kHarmlessRecords.count(name) == 0) {
      warn(record, "unknown APT record '" + detail::trim(record.text) + "' ignored");
    } else {
      check_ignored_numbers(record);
    }
  }

  void fedrat(const Record& record) {
    // FEDRAT/f, FEDRAT/MMPM,f, FEDRAT/f,MMPM, FEDRAT/IPM,f, FEDRAT/f,IPM
    std::optional<double> value;
    std::optional<double> mm_per_unit;
    Position value_at = record.name_at;
    std::string value_text;
    if (record.args.empty() || record.args.size() > 2) {
      fail_count(record, "a feed rate f or f,MMPM or f,IPM");
    }
    for (const Token& token : record.args) {
      if (token.upper == "MMPM") {
        mm_per_unit = 1.0;
      } else if (token.upper == "IPM") {
        mm_per_unit = kMillimetresPerInch;
      } else if (token.upper == "MMPR" || token.upper == "IPR") {
        fail(token.at, "feed per revolution '" + token.text +
                           "' is not supported: use a feed per minute (MMPM or IPM)");
      } else if (value) {
        fail(token.at, "FEDRAT takes one feed rate, found a second value '" + token.text + "'");
      } else if (!token.text.empty() && std::isalpha(static_cast<unsigned char>(token.text[0]))) {
        fail(token.at, "unknown feed unit '" + token.text + "' in FEDRAT: use MMPM or IPM");
      } else {
        value = number(record, token);
        value_at = token.at;
        value_text = token.text;
      }
    }
    if (!value) fail(record.name_at, "FEDRAT without a feed rate value");
    if (!(*value > 0.0)) {
      fail(value_at, "feed rate must be positive, got '" + value_text + "'");
    }
    const double feed_mm_per_min = *value * mm_per_unit.value_or(mm_per_unit_);
    if (!(feed_mm_per_min >= detail::kMinFeedMmPerMin &&
          feed_mm_per_min <= detail::kMaxFeedMmPerMin)) {
      fail(value_at, "feed rate '" + value_text + "' (" +
                         detail::format_number(feed_mm_per_min) + " mm/min) is outside [" +
                         detail::format_number(detail::kMinFeedMmPerMin) + ", " +
                         detail::format_number(detail::kMaxFeedMmPerMin) + "] mm/min");
    }
    feed_m_per_s_ = feed_mm_per_min * kMetresPerMillimetre / kSecondsPerMinute;
  }

  // LOADTL/n[,...]: tool n is in the spindle for the motions that follow
  // (PathPoint::tool_number); further modifiers (LENGTH, ...) are ignored.
  void loadtl(const Record& record) {
    const Token& token = record.args.front();
    const double value = number(record, token);
    if (!(value >= 0.0 && value <= 1e9 && value == std::floor(value))) {
      fail(token.at, "tool number '" + token.text + "' is not a whole number 0 .. 1e9");
    }
    tool_number_ = static_cast<int>(value);
  }

  void cutter(const Record& record) {
    // CUTTER/d[,r[,e,f,a,b,h]]: only the diameter d and corner radius r shape the tool here.
    if (record.args.empty() || record.args.size() > 7) {
      fail_count(record, "1 to 7 numbers d[,r,e,f,a,b,h]");
    }
    std::vector<double> values;
    for (const Token& token : record.args) values.push_back(number(record, token));
    if (!(values[0] > 0.0)) {
      fail(record.args[0].at,
           "cutter diameter must be positive, got '" + record.args[0].text + "'");
    }
    const double diameter_m =
        number_within(record, record.args[0], mm_per_unit_, detail::kMinCutterDiameterMm,
                      detail::kMaxCutterDiameterMm, "cutter diameter", "mm") *
        kMetresPerMillimetre;
    const double radius_m =
        values.size() > 1 ? values[1] * mm_per_unit_ * kMetresPerMillimetre : 0.0;
    if (!(radius_m >= 0.0 && radius_m <= 0.5 * diameter_m)) {
      fail(record.args[1].at, "cutter corner radius '" + record.args[1].text +
                                  "' must lie between 0 and half the diameter");
    }
    path_.cutter_diameter_m = diameter_m;
    path_.cutter_corner_radius_m = radius_m;
  }

  void goto_record(const Record& record, bool from) {
    const std::size_t n = record.args.size();
    std::size_t stride = 0;
    if (from) {
      if (n != 3 && n != 6) fail_count(record, "3 numbers x,y,z or 6 numbers x,y,z,i,j,k");
      stride = n;
    } else if (multax_ == Multax::on) {
      if (n == 0 || n % 6 != 0) fail_count(record, "6 numbers x,y,z,i,j,k (MULTAX is on)");
      stride = 6;
    } else if (multax_ == Multax::off) {
      if (n == 0 || n % 3 != 0) fail_count(record, "3 numbers x,y,z (MULTAX is off)");
      stride = 3;
    } else {
      if (n != 3 && n != 6) fail_count(record, "3 numbers x,y,z or 6 numbers x,y,z,i,j,k");
      stride = n;
    }
    // Coordinates (x,y,z) in mm, tool axis components as written.
    std::vector<double> values;
    for (std::size_t k = 0; k < n; ++k) {
      values.push_back(k % stride < 3 ? coordinate_mm(record, record.args[k])
                                      : number(record, record.args[k]));
    }
    detail::require_room_for_points(path_, n / stride, options_, file_, record.name_at.line,
                                    record.name_at.column, record.name);

    const bool rapid = from || rapid_next_;
    rapid_next_ = false;
    if (!rapid && !feed_m_per_s_) {
      fail(record.name_at, "GOTO before any FEDRAT: the feed rate of this cutting move is unknown");
    }
    if (from && !path_.points.empty()) {
      warn(record, "FROM after the first motion: taken as a rapid move");
    }
    SourceBlock block;
    block.file = file_;
    block.line = record.name_at.line;
    block.text = detail::trim(record.text);
    path_.blocks.push_back(std::move(block));
    const int block_index = static_cast<int>(path_.blocks.size()) - 1;

    for (std::size_t first = 0; first < n; first += stride) {
      PathPoint point;
      point.tip_W_m = Eigen::Vector3d(values[first], values[first + 1], values[first + 2]) *
                      kMetresPerMillimetre;
      if (stride == 6) {
        const Eigen::Vector3d v(values[first + 3], values[first + 4], values[first + 5]);
        const Position& at = record.args[first + 3].at;
        axis_W_ = detail::unit_tool_axis(v, file_, at.line, at.column,
                                         record.args[first + 3].text + "," +
                                             record.args[first + 4].text + "," +
                                             record.args[first + 5].text);
      }
      point.axis_W = axis_W_;
      point.kind = rapid ? MotionKind::rapid : MotionKind::linear;
      point.feed_m_per_s = rapid ? 0.0 : *feed_m_per_s_;
      point.tool_number = tool_number_;
      // CL points are tips: the length only places the axes (LOADTL's tool from the table).
      if (const auto mm = detail::spindle_tool_length_mm(options_, tool_number_)) point.tool_length_m = *mm * 1e-3;
      point.block = block_index;
      detail::append_point(path_, point, options_, file_, record.name_at.line);
    }
  }

  enum class Multax { unset, off, on };
  static constexpr int kMaxWarnings = 1000;

  const std::string& file_;
  const ReaderOptions& options_;
  Toolpath path_;
  double mm_per_unit_ = 1.0;
  std::optional<double> feed_m_per_s_;
  int tool_number_ = -1;  ///< LOADTL; -1: none loaded (the part file's tool)
  Eigen::Vector3d axis_W_ = Eigen::Vector3d::UnitZ();
  Multax multax_ = Multax::unset;
  bool rapid_next_ = false;
  bool finished_ = false;
  int current_line_ = 0;
  int warning_count_ = 0;
};

}  // namespace

Toolpath parse_apt(const std::string& text, const std::string& file_name_for_messages,
                   const ReaderOptions& options) {
  AptReader reader(file_name_for_messages, options);
  return detail::read_with_located_errors(reader, text, file_name_for_messages);
}

Toolpath read_apt(const std::string& path, const ReaderOptions& options) {
  return parse_apt(detail::read_text_file(path), path, options);
}

}  // namespace vmsim::toolpath
