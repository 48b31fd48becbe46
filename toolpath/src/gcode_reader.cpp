// ISO G-code reader: the Fanuc / Siemens subset documented in vmsim/toolpath/toolpath.hpp
// ("G-code subset").
#include <array>
#include <cctype>
#include <algorithm>
#include <cmath>
#include <exception>
#include <filesystem>
#include <new>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "gcode_program.hpp"
#include "toolpath_detail.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

using detail::kMetresPerMillimetre;
using detail::kMillimetresPerInch;
using detail::kSecondsPerMinute;

/// One word of a block: an address and a value ("X-1.5", "A3=0.5", "G43.4"), or a keyword
/// ("TRAORI").
struct Word {
  std::string address;  ///< upper case: "X", "A3", "TRAORI"
  double value = 0.0;
  bool has_value = false;
  int column = 0;       ///< 1-based column of the first character
  std::string text;     ///< as written
  char letter() const { return address.size() == 1 ? address[0] : '\0'; }
};

/// Largest start/end radius difference of an arc [mm]: the larger of this and
/// kArcRadiusRelativeTolerance times the radius.
constexpr double kArcRadiusToleranceMm = 1e-3;
constexpr double kArcRadiusRelativeTolerance = 1e-6;
/// End points closer than this [mm] in the arc plane make a full circle (I J K form).
constexpr double kFullCircleDistanceMm = 1e-9;
/// A motion that turns a rotary axis word by this much or more [deg] is split into steps of at
/// most kRotaryStepDeg: the chain follows poses, and from one pose to the next the inverse
/// kinematics takes the nearest solution, so a turn of 180 deg or more (C0 -> C360) would vanish.
constexpr double kSplitRotaryTurnDeg = 180.0;
constexpr double kRotaryStepDeg = 90.0;
constexpr int kMaxWarnings = 1000;

enum class Plane { xy, zx, yz };
enum class Tcp { off, g43_4, g43_5, traori };

/// The in-plane axes (u, v) and the plane normal w, as indices into X Y Z; (u, v, w) is
/// right-handed, so G3 (counter-clockwise) turns from u towards v.
std::array<int, 3> plane_axes(Plane plane) {
  switch (plane) {
    case Plane::xy: return {0, 1, 2};
    case Plane::zx: return {2, 0, 1};
    case Plane::yz: return {1, 2, 0};
  }
  return {0, 1, 2};
}

const char* plane_name(Plane plane) {
  switch (plane) {
    case Plane::xy: return "G17";
    case Plane::zx: return "G18";
    case Plane::yz: return "G19";
  }
  return "G17";
}

int axis_index(char letter) {
  switch (letter) {
    case 'X': case 'A': case 'I': return 0;
    case 'Y': case 'B': case 'J': return 1;
    default: return 2;
  }
}

class GcodeReader {
 public:
  GcodeReader(const std::string& file, const ReaderOptions& options)
      : file_(file), options_(options) {}

  int current_line() const { return line_; }

  Toolpath read(std::string_view text) {
    if (!(options_.arc_chord_tolerance_m >= 1e-12) ||
        !std::isfinite(options_.arc_chord_tolerance_m)) {
      throw InputError("ReaderOptions::arc_chord_tolerance_m must be at least 1e-12 m and "
                       "finite, got " + detail::format_number(options_.arc_chord_tolerance_m));
    }
    text = detail::without_byte_order_mark(text);
    detail::require_utf8_text(text, file_);
    // The program pre-pass (gcode_program.hpp) runs parameters, expressions, loops and
    // subprograms and gives the blocks in the order the control runs them; a block keeps its
    // source line (SourceBlock::text is the line as written) and the source columns of its words.
    detail::run_gcode_program(text, file_, options_, [&](const detail::ExpandedBlock& expanded) {
      line_ = expanded.line;
      line_text_ = detail::trim(expanded.source);
      expanded_ = &expanded;
      if (!expanded.file) {
        block(expanded.text);
      } else {
        // A block of a subprogram file: it and its messages name that file.
        const std::size_t blocks = path_.blocks.size(), warnings = path_.warnings.size();
        detail::with_messages_naming(file_, *expanded.file, [&] { block(expanded.text); });
        for (std::size_t i = blocks; i < path_.blocks.size(); ++i) {
          path_.blocks[i].file = *expanded.file;
        }
        for (std::size_t i = warnings; i < path_.warnings.size(); ++i) {
          path_.warnings[i].file = *expanded.file;
        }
      }
      expanded_ = nullptr;
      return !ended_;
    });
    detail::require_motion(path_, file_);
    return std::move(path_);
  }

 private:
  [[noreturn]] void fail(int column, const std::string& message) const {
    throw InputError(located_message(file_, line_, column, message));
  }
  [[noreturn]] void fail(const Word& word, const std::string& message) const {
    fail(word.column, "'" + word.text + "': " + message);
  }
  void warn(const std::string& message) {
    // A file of millions of deleted blocks would otherwise give millions of warnings.
    ++warning_count_;
    if (warning_count_ < kMaxWarnings) {
      path_.warnings.push_back(ReaderWarning{file_, line_, message});
    } else if (warning_count_ == kMaxWarnings) {
      path_.warnings.push_back(ReaderWarning{
          file_, line_,
          "more than " + std::to_string(kMaxWarnings) + " warnings: the rest are not listed"});
    }
  }

  /// Throws unless min <= value <= max; `unit` names the unit of value, min and max.
  void require_within(const Word& word, double value, double min, double max,
                      const std::string& what, const std::string& unit) const {
    if (!(value >= min && value <= max)) {
      fail(word, what + " " + detail::format_number(value) + " " + unit + " is outside [" +
                     detail::format_number(min) + ", " + detail::format_number(max) + "] " +
                     unit);
    }
  }

  // --- Words ----------------------------------------------------------------------------------

  std::vector<Word> words_of(std::string_view line, bool& block_delete) const {
    std::vector<Word> words;
    std::size_t i = 0;
    const std::size_t n = line.size();
    auto skip_blanks = [&] {
      while (i < n && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    };
    skip_blanks();
    block_delete = i < n && line[i] == '/';
    if (block_delete || (i < n && line[i] == '%')) return words;
    while (true) {
      skip_blanks();
      if (i >= n || line[i] == ';') break;
      const char c = line[i];
      const int column = expanded_ ? expanded_->source_column(static_cast<int>(i) + 1)
                                   : static_cast<int>(i) + 1;
      if (c == '(') {
        const std::size_t close = line.find(')', i);
        if (close == std::string_view::npos) fail(column, "comment '(' is not closed on its line");
        i = close + 1;
        continue;
      }
      if (!std::isalpha(static_cast<unsigned char>(c))) {
        fail(column, "unexpected character '" + std::string(1, c) + "'");
      }
      if (words.size() == detail::kMaxWordsPerBlock) {
        fail(column, "more than " + std::to_string(detail::kMaxWordsPerBlock) +
                         " words in one block");
      }
      const std::size_t start = i;
      Word word;
      word.column = column;
      ++i;
      if (i < n && std::isalpha(static_cast<unsigned char>(line[i]))) {
        // A keyword (Siemens): TRAORI, TRAFOOF, ...
        while (i < n && (std::isalnum(static_cast<unsigned char>(line[i])) || line[i] == '_')) ++i;
        word.address = detail::to_upper(line.substr(start, i - start));
        if (word.address == "TRAORI" && i < n && line[i] == '(') {
          const std::size_t close = line.find(')', i);
          if (close == std::string_view::npos) fail(column, "'TRAORI(' is not closed");
          i = close + 1;
        }
        word.text = std::string(line.substr(start, i - start));
        words.push_back(std::move(word));
        continue;
      }
      word.address = std::string(1, static_cast<char>(std::toupper(static_cast<unsigned char>(c))));
      auto read_number = [&]() -> std::string_view {
        skip_blanks();
        const std::size_t number_start = i;
        if (i < n && (line[i] == '+' || line[i] == '-')) ++i;
        while (i < n && (std::isdigit(static_cast<unsigned char>(line[i])) || line[i] == '.')) ++i;
        return line.substr(number_start, i - number_start);
      };
      skip_blanks();
      std::string_view number;
      if (i < n && line[i] == '=') {
        ++i;  // Siemens "X=10"
        number = read_number();
      } else {
        number = read_number();
        std::size_t after = i;
        while (after < n && std::isspace(static_cast<unsigned char>(line[after]))) ++after;
        if (after < n && line[after] == '=' && !number.empty() &&
            std::isdigit(static_cast<unsigned char>(number[0]))) {
          // Siemens extended address: "A3=0.5"
          word.address += std::string(number);
          i = after + 1;
          number = read_number();
        }
      }
      word.text = detail::trim(line.substr(start, i - start));
      std::string problem;
      const std::optional<double> value = detail::parse_decimal(number, &problem);
      if (!value) {
        fail(column, "'" + word.text + "': " +
                         (number.empty() ? "the address has no value" : problem));
      }
      word.value = *value;
      word.has_value = true;
      words.push_back(std::move(word));
    }
    return words;
  }

  // --- Blocks ---------------------------------------------------------------------------------

  void block(std::string_view line) {
    bool block_delete = false;
    const std::vector<Word> words = words_of(line, block_delete);
    if (block_delete) {
      warn("block skipped: block delete '/' is taken as switched on");
      return;
    }
    if (words.empty()) return;

    const Word* motion_word = nullptr;
    std::optional<int> motion;
    bool dwell = false;
    bool path_mode = false;
    std::optional<Plane> plane;
    std::optional<bool> inch, incremental, inverse_time;
    std::optional<Tcp> tcp;
    const Word* f_word = nullptr;
    const Word* p_word = nullptr;
    const Word* r_word = nullptr;
    std::array<const Word*, 3> xyz{}, abc{}, ijk{}, vec{};
    long block_number = -1;

    for (const Word& word : words) {
      const std::string& a = word.address;
      if (!word.has_value) {
        if (a == "TRAORI") {
          tcp = Tcp::traori;
        } else if (a == "TRAFOOF") {
          tcp = Tcp::off;
        } else {
          fail(word, "unsupported word");
        }
        continue;
      }
      if (a == "A3" || a == "B3" || a == "C3") {
        set_once(vec[static_cast<std::size_t>(a[0] - 'A')], word);
        continue;
      }
      switch (word.letter()) {
        case 'G': {
          require_within(word, word.value, 0.0, 1000.0, "G-code number", "");
          const double tenths = word.value * 10.0;
          if (std::abs(tenths - std::round(tenths)) > 1e-9) fail(word, "unknown G-code");
          const long code = std::lround(tenths);
          switch (code) {
            case 0: case 10: case 20: case 30:
              if (motion) fail(word, "a second motion G-code in one block");
              motion = static_cast<int>(code / 10);
              motion_word = &word;
              break;
            case 40: dwell = true; break;
            case 170: plane = Plane::xy; break;
            case 180: plane = Plane::zx; break;
            case 190: plane = Plane::yz; break;
            case 200: inch = true; break;
            case 210: inch = false; break;
            case 900: incremental = false; break;
            case 910: incremental = true; break;
            case 930: inverse_time = true; break;
            case 940: inverse_time = false; break;
            case 434: tcp = Tcp::g43_4; break;
            case 435: tcp = Tcp::g43_5; break;
            case 490: tcp = Tcp::off; break;  // also cancels tool length compensation
            // Harmless: tool length compensation (the program gives the tool tip), cancels,
            // work offsets (taken as placing the workpiece frame W), exact stop / path modes,
            // canned-cycle return levels.
            case 430: case 400: case 800: case 150: case 500: case 690: case 90: case 610:
            case 611: case 980: case 990: case 540: case 550: case 560: case 570: case 580:
            case 590:
              break;
            case 640: path_mode = true; break;
            case 410: case 420:
              fail(word, "cutter radius compensation is not supported: program the tool tip");
            case 680: case 681: fail(word, "coordinate rotation is not supported");
            case 510: case 511: fail(word, "scaling / mirroring is not supported");
            case 541: case 520: case 920: case 530:
              fail(word, "this coordinate system change is not supported");
            case 280: case 290: case 300:
              fail(word, "reference point return is not supported");
            case 160: fail(word, "polar coordinates are not supported");
            case 730: case 740: case 760: case 810: case 820: case 830: case 840: case 850:
            case 860: case 870: case 880: case 890:
              fail(word, "canned cycles are not supported: output the cycle as G0/G1 moves");
            default:
              fail(word, "unsupported G-code (it may change the geometry)");
          }
          break;
        }
        case 'M': {
          require_within(word, word.value, 0.0, detail::kMaxIgnoredWordValue, "M code", "");
          const long code = std::lround(word.value);
          if (code == 98 || code == 99) fail(word, "subprogram calls are not supported");
          if (code == 2 || code == 30) ended_ = true;
          break;
        }
        case 'N':
          require_within(word, word.value, 0.0, detail::kMaxIgnoredWordValue, "block number", "");
          block_number = std::lround(word.value);
          break;
        case 'S':
          require_within(word, word.value, 0.0, detail::kMaxSpindleRevPerMin, "spindle speed",
                         "rev/min");
          break;
        case 'O': case 'T': case 'H': case 'D':
          require_within(word, word.value, 0.0, detail::kMaxIgnoredWordValue, "value", "");
          break;
        case 'F': set_once(f_word, word); break;
        case 'P': set_once(p_word, word); break;
        case 'R': set_once(r_word, word); break;
        case 'X': case 'Y': case 'Z': set_once(xyz[axis_index(word.letter())], word); break;
        case 'A': case 'B': case 'C': set_once(abc[axis_index(word.letter())], word); break;
        case 'I': case 'J': case 'K': set_once(ijk[axis_index(word.letter())], word); break;
        default: fail(word, "unsupported word");
      }
    }

    // Modal settings first: they apply to this block's own numbers.
    if (plane) plane_ = *plane;
    if (inch) mm_per_unit_ = *inch ? kMillimetresPerInch : 1.0;
    if (incremental) incremental_ = *incremental;
    if (inverse_time) inverse_time_ = *inverse_time;
    if (tcp) tcp_ = *tcp;
    if (p_word && !dwell && !path_mode) fail(*p_word, "P is supported only with G4 or G64");
    if (p_word) {
      require_within(*p_word, p_word->value, 0.0, detail::kMaxIgnoredWordValue, "P value", "");
    }

    std::optional<double> block_inverse_time_per_s;
    if (f_word) {
      if (!(f_word->value > 0.0)) fail(*f_word, "the feed rate must be positive");
      if (inverse_time_) {
        require_within(*f_word, f_word->value, detail::kMinInverseTimePerMin,
                       detail::kMaxInverseTimePerMin, "inverse-time feed", "1/min");
        block_inverse_time_per_s = f_word->value / kSecondsPerMinute;
      } else {
        const double feed_mm_per_min = f_word->value * mm_per_unit_;
        require_within(*f_word, feed_mm_per_min, detail::kMinFeedMmPerMin,
                       detail::kMaxFeedMmPerMin, "feed rate", "mm/min");
        feed_m_per_s_ = feed_mm_per_min * kMetresPerMillimetre / kSecondsPerMinute;
      }
    }
    // Lengths and angles within the readers' limits, so that sums, squares and tessellations
    // stay finite (toolpath.hpp, "Limits").
    for (const Word* word : {xyz[0], xyz[1], xyz[2], ijk[0], ijk[1], ijk[2], r_word}) {
      if (word && !dwell) {
        require_within(*word, word->value * mm_per_unit_, -detail::kMaxCoordinateMm,
                       detail::kMaxCoordinateMm, "length", "mm");
      }
    }
    if (dwell && xyz[0]) {
      require_within(*xyz[0], xyz[0]->value, 0.0, detail::kMaxIgnoredWordValue, "dwell", "");
    }
    for (const Word* word : abc) {
      if (word) {
        require_within(*word, word->value, -detail::kMaxRotaryDeg, detail::kMaxRotaryDeg,
                       "rotary axis word", "deg");
      }
    }
    if (motion) motion_ = motion;

    const bool any_abc = abc[0] || abc[1] || abc[2];
    const bool any_ijk = ijk[0] || ijk[1] || ijk[2];
    const bool any_vec = vec[0] || vec[1] || vec[2];
    const Word* first_motion_word = first_of({xyz[0], xyz[1], xyz[2], abc[0], abc[1], abc[2],
                                              ijk[0], ijk[1], ijk[2], vec[0], vec[1], vec[2],
                                              r_word});
    if (dwell) {
      // G4 X.. / G4 P..: the X is a time, not a position.
      if (any_abc || any_ijk || any_vec || r_word || xyz[1] || xyz[2]) {
        fail(*first_motion_word, "motion word in a G4 dwell block");
      }
      return;
    }
    if (!first_motion_word) return;
    if (!motion_) fail(*first_motion_word, "axis word before any motion mode G0/G1/G2/G3");
    const bool arc = *motion_ >= 2;
    const Word& reported = motion_word ? *motion_word : *first_motion_word;

    if (any_ijk && !arc && tcp_ != Tcp::g43_5) {
      fail(*first_of({ijk[0], ijk[1], ijk[2]}),
           "I J K need G2/G3 (arc centre) or G43.5 (tool vector)");
    }
    if (r_word && !arc) fail(*r_word, "R (arc radius) needs G2/G3");
    if (any_vec && tcp_ != Tcp::traori) {
      fail(*first_of({vec[0], vec[1], vec[2]}), "tool vector words A3 B3 C3 need TRAORI");
    }
    if (arc && (any_abc || any_vec)) {
      fail(*first_of({abc[0], abc[1], abc[2], vec[0], vec[1], vec[2]}),
           "a change of tool orientation in a G2/G3 block is not supported");
    }
    if (any_abc) check_rotary_words(*first_of({abc[0], abc[1], abc[2]}));
    if (any_vec && any_abc) {
      fail(*first_of({abc[0], abc[1], abc[2]}),
           "both rotary words and a tool vector (A3 B3 C3) in one block");
    }

    // Feed of this motion.
    PathPoint point;
    point.kind = *motion_ == 0 ? MotionKind::rapid : (arc ? MotionKind::arc : MotionKind::linear);
    if (*motion_ != 0) {
      if (inverse_time_) {
        if (!block_inverse_time_per_s) {
          fail(reported, "under G93 (inverse time) every G1/G2/G3 block needs its F word");
        }
        point.inverse_time_feed_per_s = *block_inverse_time_per_s;
      } else {
        if (!feed_m_per_s_) fail(reported, "feed motion before any F word: the feed is unknown");
        point.feed_m_per_s = *feed_m_per_s_;
      }
    }

    // Target in program coordinates [mm, deg].
    const Eigen::Vector3d start_mm = known_position(xyz);
    Eigen::Vector3d target_mm = start_mm;
    for (std::size_t k = 0; k < 3; ++k) {
      if (!xyz[k]) continue;
      const double value = xyz[k]->value * mm_per_unit_;
      target_mm[static_cast<Eigen::Index>(k)] =
          incremental_ ? start_mm[static_cast<Eigen::Index>(k)] + value : value;
      require_within(*xyz[k], target_mm[static_cast<Eigen::Index>(k)], -detail::kMaxCoordinateMm,
                     detail::kMaxCoordinateMm, "position", "mm");
    }
    if (!started_ && arc) {
      fail(reported, "an arc as the first motion: its start point is unknown");
    }
    const std::array<std::optional<double>, 3> start_rotary_deg = rotary_deg_;
    for (std::size_t k = 0; k < 3; ++k) {
      if (!abc[k]) continue;
      const double previous = rotary_deg_[k].value_or(0.0);
      rotary_deg_[k] = incremental_ ? previous + abc[k]->value : abc[k]->value;
      require_within(*abc[k], *rotary_deg_[k], -detail::kMaxRotaryDeg, detail::kMaxRotaryDeg,
                     "rotary axis position", "deg");
    }
    started_ = true;

    // Tool axis for TCP modes.
    if (any_vec) {
      const Eigen::Vector3d v(vec[0] ? vec[0]->value : 0.0, vec[1] ? vec[1]->value : 0.0,
                              vec[2] ? vec[2]->value : 0.0);
      axis_W_ = detail::unit_tool_axis(v, file_, line_, first_of({vec[0], vec[1], vec[2]})->column,
                                       line_text_);
    } else if (any_ijk && !arc) {
      const Eigen::Vector3d v(ijk[0] ? ijk[0]->value : 0.0, ijk[1] ? ijk[1]->value : 0.0,
                              ijk[2] ? ijk[2]->value : 0.0);
      axis_W_ = detail::unit_tool_axis(v, file_, line_, first_of({ijk[0], ijk[1], ijk[2]})->column,
                                       line_text_);
    } else if (any_abc && (tcp_ == Tcp::g43_4 || tcp_ == Tcp::traori)) {
      axis_W_ = tool_axis_of(rotary_words(rotary_deg_), first_of({abc[0], abc[1], abc[2]})->column);
    }
    if (tcp_ == Tcp::off && !options_.axis_words_to_pose && axis_W_ != Eigen::Vector3d::UnitZ()) {
      fail(reported,
           "a motion without tool-centre-point mode after a tilted tool axis: the machine axes "
           "cannot be turned into a tool pose without a machine "
           "(ReaderOptions::axis_words_to_pose)");
    }

    SourceBlock source;
    source.file = file_;
    source.line = line_;
    source.block_number = block_number;
    source.text = line_text_;
    path_.blocks.push_back(std::move(source));
    point.block = static_cast<int>(path_.blocks.size()) - 1;

    point.rotary_words_deg = rotary_words_deg(rotary_deg_);
    if (!arc) {
      linear_points(point, start_mm, target_mm, start_rotary_deg, any_abc, reported);
    } else {
      arc_points(point, start_mm, target_mm, ijk, r_word, reported);
    }
    for (std::size_t k = 0; k < 3; ++k) position_mm_[k] = target_mm[static_cast<Eigen::Index>(k)];
  }

  void set_once(const Word*& slot, const Word& word) const {
    if (slot) fail(word, "the address appears twice in one block");
    slot = &word;
  }

  static const Word* first_of(std::initializer_list<const Word*> words) {
    const Word* first = nullptr;
    for (const Word* w : words) {
      if (w && (!first || w->column < first->column)) first = w;
    }
    return first;
  }

  void check_rotary_words(const Word& word) const {
    switch (tcp_) {
      case Tcp::g43_5:
        fail(word, "rotary words under G43.5: give the tool vector with I J K");
      case Tcp::g43_4:
      case Tcp::traori:
        if (!options_.rotary_words_to_tool_axis) {
          fail(word, std::string(tcp_ == Tcp::g43_4 ? "G43.4" : "TRAORI") +
                         " with rotary words needs a machine to turn them into a tool axis "
                         "(ReaderOptions::rotary_words_to_tool_axis)");
        }
        break;
      case Tcp::off:
        if (!options_.axis_words_to_pose) {
          fail(word,
               "rotary axis word outside tool-centre-point mode needs a machine to turn the "
               "axis words into a tool pose (ReaderOptions::axis_words_to_pose)");
        }
        break;
    }
  }

  /// The current position [mm]; an axis not programmed yet is taken as 0, with a warning
  /// unless this block gives its absolute position.
  Eigen::Vector3d known_position(const std::array<const Word*, 3>& xyz) {
    Eigen::Vector3d p;
    for (std::size_t k = 0; k < 3; ++k) {
      if (!position_mm_[k] && xyz[k] && !incremental_) position_mm_[k] = 0.0;
      if (!position_mm_[k]) {
        warn(std::string("axis ") + "XYZ"[k] +
             " has no programmed position before this motion: taken as 0");
        position_mm_[k] = 0.0;
      }
      p[static_cast<Eigen::Index>(k)] = *position_mm_[k];
    }
    return p;
  }

  using RotaryDeg = std::array<std::optional<double>, 3>;

  static std::vector<std::pair<char, double>> rotary_words(const RotaryDeg& rotary_deg) {
    std::vector<std::pair<char, double>> words;
    for (std::size_t k = 0; k < 3; ++k) {
      if (rotary_deg[k]) words.emplace_back("ABC"[k], *rotary_deg[k]);
    }
    return words;
  }

  static std::array<double, 3> rotary_words_deg(const RotaryDeg& rotary_deg) {
    std::array<double, 3> words;
    for (std::size_t k = 0; k < 3; ++k) {
      words[k] = rotary_deg[k].value_or(PathPoint::kNotProgrammed);
    }
    return words;
  }

  /// Calls a caller's word callback; its errors (a word naming no axis: InputError; a word
  /// outside the axis travel: InfeasibleError) are placed at this block.
  template <typename Call>
  auto located_call(const char* callback, Call call) const {
    const std::string where = "'" + line_text_ + "' (through " + callback + "): ";
    try {
      return call();
    } catch (const InfeasibleError& error) {
      throw InfeasibleError(located_message(file_, line_, 0, where + error.what()));
    } catch (const InputError& error) {
      throw InputError(located_message(file_, line_, 0, where + error.what()));
    }
  }

  /// The tool axis of rotary words under G43.4 / TRAORI.
  Eigen::Vector3d tool_axis_of(const std::vector<std::pair<char, double>>& words,
                               int column) const {
    const Eigen::Vector3d v = located_call(
        "rotary_words_to_tool_axis", [&] { return options_.rotary_words_to_tool_axis(words); });
    return detail::unit_tool_axis(v, file_, line_, column,
                                  line_text_ + " (through rotary_words_to_tool_axis)");
  }

  /// The tool pose of program position p_mm under the current mode.
  void set_pose(PathPoint& point, const Eigen::Vector3d& p_mm) const {
    set_pose(point, p_mm, rotary_deg_);
  }

  /// The tool pose of program position p_mm and rotary words `rotary_deg` (which give the tool
  /// axis under G43.4 / TRAORI only when `axis_from_rotary`).
  void set_pose(PathPoint& point, const Eigen::Vector3d& p_mm, const RotaryDeg& rotary_deg,
                bool axis_from_rotary = false) const {
    if (tcp_ == Tcp::off && options_.axis_words_to_pose) {
      std::vector<std::pair<char, double>> words = {{'X', p_mm.x()}, {'Y', p_mm.y()},
                                                    {'Z', p_mm.z()}};
      for (const auto& w : rotary_words(rotary_deg)) words.push_back(w);
      const AxisWordPose pose =
          located_call("axis_words_to_pose", [&] { return options_.axis_words_to_pose(words); });
      if (!pose.tip_W_m.allFinite()) {
        fail(0, "axis_words_to_pose gave a tool tip that is not finite for '" + line_text_ + "'");
      }
      point.tip_W_m = pose.tip_W_m;
      point.axis_W = detail::unit_tool_axis(pose.axis_W, file_, line_, 0,
                                            line_text_ + " (through axis_words_to_pose)");
      return;
    }
    point.tip_W_m = p_mm * kMetresPerMillimetre;
    point.axis_W = axis_from_rotary ? tool_axis_of(rotary_words(rotary_deg), 0) : axis_W_;
  }

  /// The points of a G0/G1 motion: its end point, or, when the block turns a rotary axis word
  /// by kSplitRotaryTurnDeg or more, equal steps of at most kRotaryStepDeg in axis space (as the
  /// NC interpolates the axes), each carrying its own rotary words.
  void linear_points(PathPoint point, const Eigen::Vector3d& start_mm,
                     const Eigen::Vector3d& end_mm, const RotaryDeg& start_rotary_deg,
                     bool any_abc, const Word& reported) {
    double largest_turn_deg = 0.0;
    if (any_abc) {
      for (std::size_t k = 0; k < 3; ++k) {
        // A word programmed for the first time has no known start: no turn to split.
        if (!rotary_deg_[k] || !start_rotary_deg[k]) continue;
        largest_turn_deg =
            std::max(largest_turn_deg, std::abs(*rotary_deg_[k] - *start_rotary_deg[k]));
      }
    }
    if (largest_turn_deg < kSplitRotaryTurnDeg) {
      set_pose(point, end_mm);
      detail::append_point(path_, point, options_, file_, line_);
      return;
    }
    const auto steps = static_cast<std::size_t>(std::ceil(largest_turn_deg / kRotaryStepDeg));
    detail::require_room_for_points(
        path_, steps, options_, file_, line_, reported.column,
        "the rotary turn of " + detail::format_number(largest_turn_deg) + " deg (steps of " +
            detail::format_number(kRotaryStepDeg) + " deg)");
    const bool axis_from_rotary = tcp_ == Tcp::g43_4 || tcp_ == Tcp::traori;
    // The programmed end first: a caller's check of the words (the axis travel) then names the
    // words as written; the steps between lie between the start and the end.
    PathPoint end_point = point;
    set_pose(end_point, end_mm);
    for (std::size_t k = 1; k < steps; ++k) {
      const double t = static_cast<double>(k) / static_cast<double>(steps);
      const Eigen::Vector3d p_mm = start_mm + t * (end_mm - start_mm);
      RotaryDeg rotary_deg = rotary_deg_;
      for (std::size_t j = 0; j < 3; ++j) {
        if (!rotary_deg_[j] || !start_rotary_deg[j]) continue;
        rotary_deg[j] = *start_rotary_deg[j] + t * (*rotary_deg_[j] - *start_rotary_deg[j]);
      }
      point.rotary_words_deg = rotary_words_deg(rotary_deg);
      set_pose(point, p_mm, rotary_deg, axis_from_rotary);
      detail::append_point(path_, point, options_, file_, line_);
    }
    detail::append_point(path_, end_point, options_, file_, line_);
  }

  void arc_points(PathPoint point, const Eigen::Vector3d& start_mm, const Eigen::Vector3d& end_mm,
                  const std::array<const Word*, 3>& ijk, const Word* r_word,
                  const Word& reported) {
    const auto [u, v, w] = plane_axes(plane_);
    const bool ccw = *motion_ == 3;
    for (int k = 0; k < 3; ++k) {
      if (ijk[static_cast<std::size_t>(k)] && k == w) {
        fail(*ijk[static_cast<std::size_t>(k)],
             std::string("not an arc centre word in the ") + plane_name(plane_) + " plane");
      }
    }
    const bool has_ijk = ijk[0] || ijk[1] || ijk[2];
    if (has_ijk && r_word) fail(*r_word, "an arc with both a centre (I J K) and a radius (R)");
    if (!has_ijk && !r_word) fail(reported, "an arc needs a centre (I J K) or a radius (R)");

    const Eigen::Vector2d s(start_mm[u], start_mm[v]);
    const Eigen::Vector2d e(end_mm[u], end_mm[v]);
    Eigen::Vector2d c;
    bool full_circle = false;
    if (has_ijk) {
      const auto offset = [&](int axis) {
        const Word* word = ijk[static_cast<std::size_t>(axis)];
        return word ? word->value * mm_per_unit_ : 0.0;
      };
      c = s + Eigen::Vector2d(offset(u), offset(v));
      full_circle = (e - s).norm() < kFullCircleDistanceMm;
    } else {
      const double r = std::abs(r_word->value) * mm_per_unit_;
      const double d = (e - s).norm();
      if (d < kFullCircleDistanceMm) {
        fail(*r_word, "an R-form arc cannot be a full circle (end = start): use I J K");
      }
      if (r == 0.0) fail(*r_word, "zero arc radius");
      double h2 = r * r - 0.25 * d * d;
      if (h2 < 0.0) {
        if (0.5 * d - r > std::max(kArcRadiusToleranceMm, kArcRadiusRelativeTolerance * r)) {
          fail(*r_word, "the radius is smaller than half the distance from start to end (" +
                            std::to_string(0.5 * d) + " mm)");
        }
        h2 = 0.0;
      }
      const Eigen::Vector2d chord = (e - s) / d;
      const Eigen::Vector2d left(-chord.y(), chord.x());
      // A counter-clockwise arc of at most 180 deg has its centre left of the chord;
      // a negative R asks for the arc of more than 180 deg, whose centre is on the other side.
      const double side = (ccw ? 1.0 : -1.0) * (r_word->value > 0.0 ? 1.0 : -1.0);
      c = 0.5 * (s + e) + side * std::sqrt(h2) * left;
    }
    const double r_start = (s - c).norm();
    const double r_end = (e - c).norm();
    if (r_start == 0.0) fail(reported, "an arc of zero radius (the centre is the start point)");
    const double radius_tolerance =
        std::max(kArcRadiusToleranceMm, kArcRadiusRelativeTolerance * std::max(r_start, r_end));
    if (std::abs(r_start - r_end) > radius_tolerance) {
      fail(reported, "the arc's start and end are not at the same distance from its centre "
                     "(start radius " + std::to_string(r_start) + " mm, end radius " +
                         std::to_string(r_end) + " mm)");
    }
    const double a0 = std::atan2(s.y() - c.y(), s.x() - c.x());
    const double a1 = std::atan2(e.y() - c.y(), e.x() - c.x());
    constexpr double two_pi = 2.0 * std::numbers::pi;
    double sweep = 0.0;
    if (full_circle) {
      sweep = ccw ? two_pi : -two_pi;
    } else if (ccw) {
      sweep = a1 - a0;
      while (sweep <= 0.0) sweep += two_pi;
      while (sweep > two_pi) sweep -= two_pi;
    } else {
      sweep = a1 - a0;
      while (sweep >= 0.0) sweep -= two_pi;
      while (sweep < -two_pi) sweep += two_pi;
    }

    // Chord error of a segment of angle delta on radius r: r (1 - cos(delta / 2)).
    const double r_max = std::max(r_start, r_end);
    const double tolerance_mm = options_.arc_chord_tolerance_m / kMetresPerMillimetre;
    double max_delta = std::numbers::pi / 2.0;
    if (tolerance_mm < r_max) {
      max_delta = std::min(max_delta, 2.0 * std::acos(1.0 - tolerance_mm / r_max));
    }
    const double segments_real = std::ceil(std::abs(sweep) / max_delta);
    const std::string what =
        "the arc (radius " + detail::format_number(r_max) + " mm, " +
        detail::format_number(std::abs(sweep) * 180.0 / std::numbers::pi) +
        " deg, chord tolerance " + detail::format_number(tolerance_mm) + " mm)";
    if (!(segments_real <= static_cast<double>(options_.max_points_per_block))) {
      fail(reported, what + " expands to " + detail::format_number(segments_real) +
                         " points, more than the limit of " +
                         std::to_string(options_.max_points_per_block) +
                         " points per block (ReaderOptions::max_points_per_block)");
    }
    const long segments = std::max(1L, static_cast<long>(segments_real));
    detail::require_room_for_points(path_, static_cast<std::size_t>(segments), options_, file_, line_,
                                    reported.column, what);
    if (point.inverse_time_feed_per_s > 0.0) {
      // G93: the whole arc takes 1/F; each segment takes its share.
      point.inverse_time_feed_per_s *= static_cast<double>(segments);
    }
    for (long k = 1; k <= segments; ++k) {
      Eigen::Vector3d p_mm = end_mm;
      if (k < segments) {
        const double t = static_cast<double>(k) / static_cast<double>(segments);
        const double angle = a0 + t * sweep;
        const double r = r_start + t * (r_end - r_start);
        p_mm[u] = c.x() + r * std::cos(angle);
        p_mm[v] = c.y() + r * std::sin(angle);
        p_mm[w] = start_mm[w] + t * (end_mm[w] - start_mm[w]);
      }
      set_pose(point, p_mm);
      detail::append_point(path_, point, options_, file_, line_);
    }
  }

  const std::string& file_;
  const ReaderOptions& options_;
  Toolpath path_;
  int line_ = 0;
  std::string line_text_;
  const detail::ExpandedBlock* expanded_ = nullptr;  ///< the block being read (its columns)
  bool ended_ = false;
  bool started_ = false;
  int warning_count_ = 0;

  // Modal state.
  std::optional<int> motion_;
  Plane plane_ = Plane::xy;
  double mm_per_unit_ = 1.0;
  bool incremental_ = false;
  bool inverse_time_ = false;
  Tcp tcp_ = Tcp::off;
  std::optional<double> feed_m_per_s_;
  std::array<std::optional<double>, 3> position_mm_;
  std::array<std::optional<double>, 3> rotary_deg_;
  Eigen::Vector3d axis_W_ = Eigen::Vector3d::UnitZ();
};

}  // namespace

Toolpath parse_gcode(const std::string& text, const std::string& file_name_for_messages,
                     const ReaderOptions& options) {
  GcodeReader reader(file_name_for_messages, options);
  return detail::read_with_located_errors(reader, text, file_name_for_messages);
}

Toolpath read_gcode(const std::string& path, const ReaderOptions& options) {
  if (!options.subprogram_folder.empty()) {
    return parse_gcode(detail::read_text_file(path), path, options);
  }
  // Subprograms in other files are looked for beside the program.
  ReaderOptions with_folder = options;
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  with_folder.subprogram_folder = folder.empty() ? "." : folder.string();
  return parse_gcode(detail::read_text_file(path), path, with_folder);
}

}  // namespace vmsim::toolpath
