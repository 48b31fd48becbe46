// ISO G-code reader: the Fanuc / Siemens subset documented in vmsim/toolpath/toolpath.hpp
// ("G-code subset").
#include <array>
#include <cctype>
#include <map>
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

#include "canned_cycles.hpp"
#include "gcode_program.hpp"
#include "toolpath_detail.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/cutter_compensation.hpp"
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

using detail::kFullCircleDistanceMm;
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
    offsets_mm_ = options_.work_offsets_mm;
    implicit_g54_ = offsets_mm_.empty();
    tool_length_mm_ = options_.tool_length_mm;
    const auto initial = offset_named(options_.initial_work_offset);
    if (!initial) {
      throw InputError("ReaderOptions::initial_work_offset " + options_.initial_work_offset +
                       " is not in the work offset table (" + offset_list() + ")");
    }
    offset_ = *initial;
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
    if (compensator_) {
      warn("cutter compensation is still on at the end of the program (no G40): its last element ends at its "
           "offset end");
      end_compensation(nullptr);
    }
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
  /// A dwell [s] at the current position: held on the last point made (a dwell before any
  /// motion holds nothing).
  void dwell_here(double seconds) {
    if (compensator_) {
      warn("dwell under cutter compensation (G41 / G42): not timed");
      return;
    }
    if (!path_.points.empty() && seconds > 0.0) path_.points.back().dwell_s += seconds;
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
    std::optional<int> motion;  // 0 1 2 3, or a canned cycle 73 74 81 .. 89
    const Word* cancel_cycle_word = nullptr;  // G80
    const Word* nonmodal_word = nullptr;      // G4 G10 G28 G30 G52 G92 G92.1
    long nonmodal = -1;                       // its code in tenths
    const Word* g53_word = nullptr;
    bool exact_stop_here = false;             // G9
    std::optional<Plane> plane;
    std::optional<bool> inch, incremental, inverse_time, arc_centre_incremental, to_initial;
    std::optional<Tcp> tcp;
    bool g43 = false;
    const Word* g43_word = nullptr;
    const Word* lookahead_word = nullptr;
    const Word* offset_word = nullptr;
    std::string offset_name;
    const Word* rotation_word = nullptr;  // G68 / G69
    const Word* path_word = nullptr;      // G61 G61.1 G64 G5.1 G05 G187
    long path_code = 0;
    const Word* f_word = nullptr;
    const Word* p_word = nullptr;
    const Word* r_word = nullptr;
    const Word* h_word = nullptr;
    const Word* t_word = nullptr;
    const Word* q_word = nullptr;
    const Word* l_word = nullptr;
    const Word* e_word = nullptr;
    const Word* m6_word = nullptr;
    const Word* d_word = nullptr;
    const Word* compensation_word = nullptr;  // G40 G41 G42 G41.1 G42.1
    long compensation_code = 0;
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
          const auto set_motion = [&](int m) {
            if (motion) fail(word, "a second motion G-code in one block");
            motion = m;
            motion_word = &word;
          };
          const auto set_nonmodal = [&] {
            if (nonmodal_word) fail(word, "a second one of G4 G10 G28 G30 G52 G92 in one block");
            nonmodal_word = &word;
            nonmodal = code;
          };
          const auto set_path = [&] {
            if (path_word) fail(word, "a second path control mode in one block");
            path_word = &word;
            path_code = code;
          };
          switch (code) {
            case 0: case 10: case 20: case 30: set_motion(static_cast<int>(code / 10)); break;
            case 730: case 740: case 760: case 810: case 820: case 830: case 840: case 850:
            case 860: case 870: case 880: case 890:
              set_motion(static_cast<int>(code / 10));
              break;
            case 800: cancel_cycle_word = &word; break;
            case 40: case 100: case 280: case 300: case 520: case 920: case 921:
              set_nonmodal();
              break;
            case 530: g53_word = &word; break;
            case 90: exact_stop_here = true; break;
            case 170: plane = Plane::xy; break;
            case 180: plane = Plane::zx; break;
            case 190: plane = Plane::yz; break;
            case 200: inch = true; break;
            case 210: inch = false; break;
            case 900: incremental = false; break;
            case 910: incremental = true; break;
            case 901: arc_centre_incremental = false; break;
            case 911: arc_centre_incremental = true; break;
            case 930: inverse_time = true; break;
            case 940: inverse_time = false; break;
            case 430: tcp = Tcp::off; g43 = true; g43_word = &word; break;
            case 434: tcp = Tcp::g43_4; break;
            case 435: tcp = Tcp::g43_5; break;
            case 490: tcp = Tcp::off; g43 = false; break;  // cancels tool length compensation too
            case 540: case 550: case 560: case 570: case 580: case 590: case 541:
              if (offset_word) fail(word, "a second work offset in one block");
              offset_word = &word;
              offset_name = code == 541 ? "G54.1" : "G" + std::to_string(code / 10);
              break;
            case 680: case 690: rotation_word = &word; break;
            case 610: case 611: case 640: case 51: case 50: case 1870: set_path(); break;
            case 980: to_initial = true; break;
            case 990: to_initial = false; break;
            case 400: case 410: case 420: case 411: case 421:
              if (compensation_word) fail(word, "a second cutter compensation G-code in one block");
              compensation_word = &word;
              compensation_code = code;
              break;
            // Harmless: polar and scaling cancels.
            case 150: case 500: break;
            case 80: lookahead_word = &word; break;  // G8 P1 / P0: look-ahead, no geometry
            case 681: fail(word, "3-D coordinate rotation is not supported");
            case 510: case 511: fail(word, "scaling / mirroring is not supported");
            case 160: fail(word, "polar coordinates are not supported");
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
          if (code == 6) m6_word = &word;
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
        case 'O':
          require_within(word, word.value, 0.0, detail::kMaxIgnoredWordValue, "value", "");
          break;
        case 'D': set_once(d_word, word);
          require_within(word, word.value, 0.0, detail::kMaxIgnoredWordValue, "value", "");
          break;
        case 'T': set_once(t_word, word);
          require_within(word, word.value, 0.0, detail::kMaxIgnoredWordValue, "value", "");
          break;
        case 'H': set_once(h_word, word);
          require_within(word, word.value, 0.0, detail::kMaxIgnoredWordValue, "value", "");
          break;
        case 'L': set_once(l_word, word);
          require_within(word, word.value, 0.0, detail::kMaxIgnoredWordValue, "value", "");
          break;
        case 'Q': set_once(q_word, word); break;
        case 'E': set_once(e_word, word); break;
        case 'F': set_once(f_word, word); break;
        case 'P': set_once(p_word, word); break;
        case 'R': set_once(r_word, word); break;
        case 'X': case 'Y': case 'Z': set_once(xyz[axis_index(word.letter())], word); break;
        case 'A': case 'B': case 'C': set_once(abc[axis_index(word.letter())], word); break;
        case 'I': case 'J': case 'K': set_once(ijk[axis_index(word.letter())], word); break;
        default: fail(word, "unsupported word");
      }
    }

    // Cutter compensation: G40 ends it before anything else of its block (the block's motion is
    // the exit move); while it is on, what would move the offset contour is refused.
    if (compensation_word && compensation_code == 400) end_compensation(compensation_word);
    if (compensation_side_) refuse_under_compensation(words, inch);

    // Modal settings first: they apply to this block's own numbers.
    if (plane) plane_ = *plane;
    if (inch) mm_per_unit_ = *inch ? kMillimetresPerInch : 1.0;
    if (incremental) incremental_ = *incremental;
    if (arc_centre_incremental) arc_centre_incremental_ = *arc_centre_incremental;
    if (inverse_time) inverse_time_ = *inverse_time;
    if (to_initial) return_to_initial_ = *to_initial;
    const bool dwell = nonmodal == 40;

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
    for (const Word* word : {xyz[0], xyz[1], xyz[2], ijk[0], ijk[1], ijk[2], r_word, q_word}) {
      if (word && !dwell) {
        require_within(*word, word->value * mm_per_unit_, -detail::kMaxCoordinateMm,
                       detail::kMaxCoordinateMm, "length", "mm");
      }
    }
    if (dwell && xyz[0]) {
      require_within(*xyz[0], xyz[0]->value, 0.0, detail::kMaxIgnoredWordValue, "dwell", "");
    }
    if (p_word) {
      require_within(*p_word, p_word->value, 0.0, detail::kMaxIgnoredWordValue, "P value", "");
    }
    if (e_word) {
      require_within(*e_word, e_word->value * mm_per_unit_, 0.0, detail::kMaxToleranceMm,
                     "tolerance", "mm");
    }
    for (const Word* word : abc) {
      if (word) {
        require_within(*word, word->value, -detail::kMaxRotaryDeg, detail::kMaxRotaryDeg,
                       "rotary axis word", "deg");
      }
    }

    // Tool change: T preselects, M6 puts the preselected tool in the spindle.
    if (t_word) next_tool_ = static_cast<int>(std::lround(t_word->value));
    if (m6_word) {
      if (!next_tool_) fail(*m6_word, "tool change M6 without a tool selected by a T word");
      tool_number_ = *next_tool_;
    }

    // Tool length compensation and tool-centre-point modes (one modal group on the control).
    if (tcp) {
      const Tcp old_tcp = tcp_;
      // Leaving tool-centre-point mode the machine axes are where the last tip put them (the
      // machine's inverse, when given); otherwise, and switching into it, the program numbers are
      // kept: the two modes' coordinates differ by the machine's kinematics.
      const auto program = program_position();
      const std::optional<Eigen::Vector3d> machine_mm =
          old_tcp != Tcp::off && *tcp == Tcp::off ? machine_axes_at_tip() : std::nullopt;
      tcp_ = *tcp;
      g43_ = g43;
      h_mm_ = 0.0;
      if (g43) h_mm_ = tool_length_of(h_word, *g43_word);
      if (machine_mm) {
        // Outside tool-centre-point mode the frame position is the machine axes.
        for (std::size_t k = 0; k < 3; ++k) position_[k] = (*machine_mm)[static_cast<Eigen::Index>(k)];
      } else if ((old_tcp == Tcp::off) != (tcp_ == Tcp::off)) {
        set_program_position(program);
      }
    } else if (h_word && tcp_ == Tcp::off && g43_) {
      h_mm_ = tool_length_of(h_word, *h_word);
    }

    if (compensation_word && compensation_code != 400) {
      start_compensation(*compensation_word, compensation_code, d_word);
    } else if (d_word) {
      set_d_number(*d_word);
    }

    if (offset_word) select_offset(*offset_word, offset_name, p_word);
    if (path_word) set_path_mode(*path_word, path_code, p_word, q_word, r_word, e_word);
    if (cancel_cycle_word) {
      // As on a Fanuc: the cycles are a modal group of their own, so G80 gives back the G0 / G1
      // in force before the cycle (Fusion 360 posts `G80` then `Z15.`).
      if (!motion && motion_ && *motion_ >= 70) motion_ = motion_before_cycle_;
      end_cycle();
    }
    if (motion) {
      if (*motion >= 70 && !(motion_ && *motion_ >= 70)) {
        end_cycle();
        motion_before_cycle_ = motion_;
      }
      motion_ = motion;
    }

    // Words that belong to something other than a motion in this block.
    const bool cycle = motion_ && *motion_ >= 70 && !nonmodal_word && !g53_word;
    const bool p_used = dwell || lookahead_word ||
                        (path_word && (path_code == 640 || path_code == 50 ||
                                       path_code == 1870)) ||
                        nonmodal == 100 || (offset_word && offset_name == "G54.1") ||
                        (cycle && (*motion_ == 82 || *motion_ == 89 || *motion_ == 74 ||
                                   *motion_ == 84 || *motion_ == 76 || *motion_ == 87 ||
                                   *motion_ == 88));
    if (p_word && !p_used) fail(*p_word, "P has no meaning in this block");
    // G64 P.. Q..: LinuxCNC's Q (collinear points folded) changes no geometry beyond P.
    if (q_word && !(path_code == 51 || path_code == 640 ||
                    (cycle && (*motion_ == 73 || *motion_ == 76 || *motion_ == 83 ||
                               *motion_ == 87)))) {
      fail(*q_word, "Q has no meaning in this block (G5.1 Q, G64 Q, G73 / G76 / G83 / G87 Q)");
    }
    if (l_word && !(nonmodal == 100 || cycle)) {
      fail(*l_word, "L has no meaning in this block (G10 L, canned cycle repeats)");
    }
    if (e_word && path_code != 1870) fail(*e_word, "E has no meaning here (G187 E)");

    if (rotation_word && (nonmodal_word || g53_word)) {
      fail(*rotation_word, "G68 / G69 with " + (nonmodal_word ? nonmodal_word : g53_word)->text +
                               " in one block: give them in separate blocks");
    }
    if (g53_word && nonmodal_word) {
      fail(*g53_word, "G53 with " + nonmodal_word->text + " in one block");
    }
    if (rotation_word) {
      const Word* angle_word = r_word;
      set_rotation(*rotation_word, xyz, angle_word);
      return;
    }
    if (nonmodal_word) {
      switch (nonmodal) {
        case 40: {
          // G4 X.. / G4 P..: the X is a time, not a position.
          const Word* other = first_of({abc[0], abc[1], abc[2], ijk[0], ijk[1], ijk[2], vec[0],
                                        vec[1], vec[2], r_word, xyz[1], xyz[2]});
          if (other) fail(*other, "motion word in a G4 dwell block");
          // Fanuc: G4 X<seconds> or G4 P<milliseconds> (LinuxCNC's P in seconds is not this
          // dialect's).
          if (xyz[0] && p_word) fail(*p_word, "G4 with both X and P");
          if (xyz[0] || p_word) dwell_here(xyz[0] ? xyz[0]->value : p_word->value * 1e-3);
          return;
        }
        case 100: set_offset_from_program(*nonmodal_word, l_word, p_word, r_word, xyz); return;
        case 520: case 920: case 921: set_local_shift(*nonmodal_word, nonmodal, xyz); return;
        default:
          reference_return(*nonmodal_word, nonmodal == 280, xyz, abc, block_number,
                           exact_stop_here);
          return;
      }
    }

    const bool any_abc = abc[0] || abc[1] || abc[2];
    const bool any_ijk = ijk[0] || ijk[1] || ijk[2];
    const bool any_vec = vec[0] || vec[1] || vec[2];
    const Word* first_motion_word = first_of({xyz[0], xyz[1], xyz[2], abc[0], abc[1], abc[2],
                                              ijk[0], ijk[1], ijk[2], vec[0], vec[1], vec[2],
                                              r_word});
    if (g53_word && !first_motion_word) fail(*g53_word, "G53 without an axis word");
    if (!first_motion_word) return;
    if (!motion_) fail(*first_motion_word, "axis word before any motion mode G0/G1/G2/G3");
    if (cycle) {
      if (compensation_side_) {
        fail(motion_word ? *motion_word : *first_motion_word,
             "canned cycles under cutter compensation are not supported: cancel it (G40) first");
      }
      exit_pending_ = false;
      if (const Word* extra = first_of({abc[0], abc[1], abc[2], vec[0], vec[1], vec[2]})) {
        fail(*extra, "rotary and tool vector words in a canned cycle block are not supported");
      }
      canned_cycle(xyz, ijk, r_word, q_word, l_word, p_word, block_number,
                   motion_word ? *motion_word : *first_motion_word);
      return;
    }
    const bool arc = *motion_ >= 2;
    const Word& reported = motion_word ? *motion_word : *first_motion_word;
    if (g53_word && (arc || *motion_ >= 70)) fail(*g53_word, "G53 needs G0 or G1");
    if (g53_word && tcp_ != Tcp::off) {
      fail(*g53_word, "G53 (machine coordinates) in tool-centre-point mode is not supported");
    }

    if (g53_word && ((!position_[0] && !xyz[0]) || (!position_[1] && !xyz[1]) ||
                     (!position_[2] && !xyz[2]))) {
      // As for G28: the named machine axes are known from here on, the pose once all are.
      for (std::size_t k = 0; k < 3; ++k) {
        if (xyz[k]) position_[k] = xyz[k]->value * mm_per_unit_;
      }
      if (const Word* rotary = first_of({abc[0], abc[1], abc[2]})) {
        fail(*rotary, "rotary words in a G53 block before the linear axes are known");
      }
      return;
    }
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
    PathPoint point = new_point(*motion_ == 0 ? MotionKind::rapid
                                              : (arc ? MotionKind::arc : MotionKind::linear));
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

    // Target: in program coordinates [mm], and in the frame the pose is made from.
    const Eigen::Vector3d start_f = known_frame_position(xyz, g53_word || !incremental_);
    const Eigen::Vector3d start_mm = from_frame(start_f);
    Eigen::Vector3d target_mm = start_mm;
    Eigen::Vector3d target_f = start_f;
    for (std::size_t k = 0; k < 3; ++k) {
      if (!xyz[k]) continue;
      const auto i = static_cast<Eigen::Index>(k);
      const double value = xyz[k]->value * mm_per_unit_;
      if (g53_word) {
        target_f[i] = value;  // machine coordinates, always absolute
      } else {
        target_mm[i] = incremental_ ? start_mm[i] + value : value;
        require_within(*xyz[k], target_mm[i], -detail::kMaxCoordinateMm,
                       detail::kMaxCoordinateMm, "position", "mm");
      }
    }
    if (!g53_word) target_f = to_frame(target_mm);
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
      // The tool vector leaves the rotary axes to the machine: the words of an earlier G43.4
      // block no longer say where they are (a later turn must not start from them).
      rotary_deg_ = {};
    } else if (any_abc && (tcp_ == Tcp::g43_4 || tcp_ == Tcp::traori)) {
      axis_W_ = tool_axis_of(rotary_words(rotary_deg_), first_of({abc[0], abc[1], abc[2]})->column);
    }
    if (tcp_ == Tcp::off && !options_.axis_words_to_pose && axis_W_ != Eigen::Vector3d::UnitZ()) {
      fail(reported,
           "a motion without tool-centre-point mode after a tilted tool axis: the machine axes "
           "cannot be turned into a tool pose without a machine "
           "(ReaderOptions::axis_words_to_pose)");
    }

    if (exit_pending_ && arc) {
      // The move after G40 leaves the offset contour (from where compensation left the tool,
      // the current position since G40): a line, as on LinuxCNC.
      fail(reported, "the move after G40 (cutter compensation off) must be a line (G0 / G1), not an arc");
    }
    std::optional<ArcGeometry> arc_geometry;
    if (arc) arc_geometry = arc_geometry_of(start_mm, target_mm, ijk, r_word, reported);
    point.block = add_source_block(block_number);
    point.rotary_words_deg = rotary_words_deg(rotary_deg_);
    if (compensating()) {
      compensated_motion(point, start_mm, target_mm, arc_geometry ? &*arc_geometry : nullptr,
                         exact_stop_here, reported);
      for (std::size_t k = 0; k < 3; ++k) position_[k] = target_f[static_cast<Eigen::Index>(k)];
      return;
    }
    if (exit_pending_ && (g53_word || (target_mm.head<2>() - start_mm.head<2>()).norm() > 1e-9)) {
      exit_pending_ = false;
    }
    const std::size_t first_point = path_.points.size();
    if (!arc) {
      linear_points(point, start_f, target_f, start_rotary_deg, any_abc, reported);
    } else {
      arc_points(point, start_mm, target_mm, *arc_geometry, reported);
    }
    finish_block_points(first_point, exact_stop_here);
    for (std::size_t k = 0; k < 3; ++k) position_[k] = target_f[static_cast<Eigen::Index>(k)];
  }

  /// A G2/G3 arc in the plane's axes (u, v) [mm]: centre, start and end radius, start angle and
  /// signed sweep (> 0 counter-clockwise).
  struct ArcGeometry {
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    double r_start = 0.0, r_end = 0.0;
    double a0 = 0.0;
    double sweep = 0.0;
  };

  // --- Cutter radius compensation (G40 G41 G42 G41.1 G42.1; cutter_compensation.hpp) -----------
  //
  // Under G41 / G42 the reader hands each motion, in program coordinates, to the compensator as
  // a plane element (X Y, with Z along) and makes the points of the moves it gives back, which
  // come one element late (the end of an element depends on the next). position_ stays the
  // programmed position, so incremental words and arcs read as programmed.

  bool compensating() const { return compensation_side_.has_value() && compensation_radius_mm_ > 0.0; }

  /// While compensation is on: words that would change the frame, the plane, the units or the
  /// tool axis of the contour being offset (LinuxCNC refuses them too).
  void refuse_under_compensation(const std::vector<Word>& words, const std::optional<bool>& inch) const {
    const std::string cancel = " under cutter compensation is not supported: cancel it (G40) first";
    for (const Word& word : words) {
      const std::string& a = word.address;
      if (!word.has_value) {
        fail(word, "tool-centre-point mode" + cancel);
      }
      if (a == "A" || a == "B" || a == "C" || a == "A3" || a == "B3" || a == "C3") {
        fail(word, "a rotary axis or tool vector word" + cancel);
      }
      if (a == "H") fail(word, "a tool length change" + cancel);
      if (a != "G") continue;
      const long code = std::lround(word.value * 10.0);
      switch (code) {
        case 180: case 190: fail(word, "a plane change" + cancel);
        case 200: case 210:
          if (inch && (*inch ? kMillimetresPerInch : 1.0) != mm_per_unit_) fail(word, "a change of units" + cancel);
          break;
        case 430: case 434: case 435: case 490: fail(word, "a tool length or tool-centre-point change" + cancel);
        case 930: fail(word, "inverse-time feed (G93)" + cancel);
        case 540: case 550: case 560: case 570: case 580: case 590: case 541:
          fail(word, "a work offset change" + cancel);
        case 680: case 690: fail(word, "a coordinate rotation change" + cancel);
        case 100: case 520: case 920: case 921: fail(word, "an offset change" + cancel);
        case 280: case 300: fail(word, "a reference point return" + cancel);
        case 530: fail(word, "a move in machine coordinates (G53)" + cancel);
        default: break;
      }
    }
  }

  /// D outside G41 / G42 (Fanuc: modal, taken by a later G41 / G42 without D).
  void set_d_number(const Word& d_word) {
    if (d_word.value != std::round(d_word.value)) fail(d_word, "D must be a whole number (a tool number)");
    const int number = static_cast<int>(std::lround(d_word.value));
    if (compensating() && number != d_number_.value_or(-1)) {
      fail(d_word, "a new D under cutter compensation is not supported: cancel it (G40) first");
    }
    d_number_ = number;
  }

  /// The cutter radius [mm] of G41 / G42: D from the tool table (ReaderOptions::cutter_radius_mm),
  /// else the D given before, else the tool in the spindle (LinuxCNC); D0 is no radius.
  double cutter_radius_of(const Word* d_word, const Word& word) {
    int number = -1;
    if (d_word) {
      set_d_number(*d_word);
      number = *d_number_;
    } else if (d_number_) {
      number = *d_number_;
    } else if (tool_number_ >= 0) {
      number = tool_number_;
    } else {
      fail(word, "G41 / G42 without D and without a tool in the spindle (T.. M6): the cutter radius is unknown");
    }
    if (number == 0) return 0.0;
    double radius_mm = 0.0;
    if (const auto it = options_.cutter_radius_mm.find(number); it != options_.cutter_radius_mm.end()) {
      radius_mm = it->second;
    } else if (options_.default_cutter_radius_mm) {
      radius_mm = *options_.default_cutter_radius_mm;
    } else {
      std::string known;
      for (const auto& [n, r] : options_.cutter_radius_mm) known += (known.empty() ? "D" : ", D") + std::to_string(n);
      fail(d_word ? *d_word : word, "no cutter radius for D" + std::to_string(number) + " (the tool table has " +
                                        (known.empty() ? std::string("none") : known) +
                                        "; the part file's tools: diameter_mm)");
    }
    if (!(radius_mm >= 0.0 && radius_mm <= 0.5 * detail::kMaxCutterDiameterMm)) {
      fail(d_word ? *d_word : word, "the cutter radius of D" + std::to_string(number) + ", " +
                                        detail::format_number(radius_mm) + " mm, is not within [0, " +
                                        detail::format_number(0.5 * detail::kMaxCutterDiameterMm) + "] mm");
    }
    return radius_mm;
  }

  void start_compensation(const Word& word, long code, const Word* d_word) {
    const CompensationSide side = code == 410 || code == 411 ? CompensationSide::left : CompensationSide::right;
    if (plane_ != Plane::xy) {
      fail(word, std::string("cutter radius compensation in the ") + plane_name(plane_) +
                     " plane is not supported (G17 only)");
    }
    if (tcp_ != Tcp::off) {
      fail(word, "cutter radius compensation under tool-centre-point mode (G43.4 / G43.5 / TRAORI) is not supported");
    }
    if (inverse_time_) fail(word, "cutter radius compensation under inverse-time feed (G93) is not supported");
    double radius_mm = 0.0;
    if (code == 411 || code == 421) {
      // LinuxCNC's dynamic compensation: D is the cutter diameter, in program units.
      if (!d_word) fail(word, "G41.1 / G42.1 need D (the cutter diameter)");
      radius_mm = 0.5 * d_word->value * mm_per_unit_;
      require_within(*d_word, 2.0 * radius_mm, 0.0, detail::kMaxCutterDiameterMm, "cutter diameter", "mm");
    } else {
      radius_mm = cutter_radius_of(d_word, word);
    }
    if (compensation_side_) {
      if (*compensation_side_ == side && radius_mm == compensation_radius_mm_) return;  // repeated
      fail(word, "cutter compensation is already on: cancel it (G40) before changing its side or radius");
    }
    compensation_side_ = side;
    compensation_radius_mm_ = radius_mm;
  }

  /// G40 (word) or the end of the program (nullptr): the last element ends at its offset end,
  /// and the position is the tool's from here on.
  void end_compensation(const Word* word) {
    if (compensator_) {
      const bool entered = compensator_->entered();
      emit_compensated(compensation_call(word, [&] { return compensator_->finish(); }), word);
      if (entered) {
        const Eigen::Vector3d programmed = from_frame(filled_frame_position());
        const Eigen::Vector3d f = to_frame(Eigen::Vector3d(compensator_->tool_mm().x(), compensator_->tool_mm().y(),
                                                           programmed.z()));
        for (std::size_t k = 0; k < 3; ++k) position_[k] = f[static_cast<Eigen::Index>(k)];
        exit_pending_ = true;
      }
      compensator_.reset();
    }
    compensation_side_.reset();
    compensation_radius_mm_ = 0.0;
  }

  template <typename Call>
  std::vector<CompensatedMove> compensation_call(const Word* word, Call call) const {
    try {
      return call();
    } catch (const CompensationError& error) {
      if (word) fail(*word, error.what());
      fail(0, error.what());
    }
  }

  /// One motion under compensation: a plane element, or a move along Z only.
  void compensated_motion(const PathPoint& point, const Eigen::Vector3d& start_mm, const Eigen::Vector3d& end_mm,
                          const ArcGeometry* arc, bool exact_stop_here, const Word& reported) {
    if (!compensator_) {
      compensator_.emplace(*compensation_side_, compensation_radius_mm_, Eigen::Vector2d(start_mm.x(), start_mm.y()),
                           start_mm.z());
      exit_pending_ = false;
    }
    const int tag = next_compensation_tag_++;
    compensated_sources_[tag] = {point, exact_stop_here};
    PlaneElement element;
    element.arc = arc != nullptr;
    element.start = start_mm.head<2>();
    element.end = end_mm.head<2>();
    if (arc) {
      element.centre = arc->centre;
      element.sweep_rad = arc->sweep;
    }
    element.start_w_mm = start_mm.z();
    element.end_w_mm = end_mm.z();
    element.tag = tag;
    const bool in_plane = arc || (element.end - element.start).norm() > 1e-9;
    emit_compensated(compensation_call(&reported, [&] {
                       return in_plane ? compensator_->add(element)
                                       : compensator_->add_normal_move(element.end_w_mm, tag);
                     }),
                     &reported);
  }

  /// The points of compensated moves (program coordinates, through the frame as any point).
  void emit_compensated(const std::vector<CompensatedMove>& moves, const Word* word) {
    for (const CompensatedMove& move : moves) {
      const auto source = compensated_sources_.find(move.tag);
      if (source == compensated_sources_.end()) continue;
      PathPoint point = source->second.point;
      const std::size_t first = path_.points.size();
      if (!move.arc) {
        set_pose(point, to_frame(Eigen::Vector3d(move.end.x(), move.end.y(), move.end_w_mm)), rotary_deg_);
        detail::append_point(path_, point, options_, file_, line_);
      } else {
        if (point.kind != MotionKind::rapid) point.kind = MotionKind::arc;
        const double radius = (move.start - move.centre).norm();
        const double tolerance_mm = options_.arc_chord_tolerance_m / kMetresPerMillimetre;
        const double segments_real = detail::arc_chord_count(radius, move.sweep_rad, tolerance_mm);
        const std::string what = "the compensated arc (radius " + detail::format_number(radius) + " mm, " +
                                 detail::format_number(std::abs(move.sweep_rad) * 180.0 / std::numbers::pi) +
                                 " deg)";
        if (!(segments_real <= static_cast<double>(options_.max_points_per_block))) {
          fail(word ? word->column : 0, what + " expands to " + detail::format_number(segments_real) +
                                            " points, more than the limit of " +
                                            std::to_string(options_.max_points_per_block) +
                                            " points per block (ReaderOptions::max_points_per_block)");
        }
        const long segments = std::max(1L, static_cast<long>(segments_real));
        detail::require_room_for_points(path_, static_cast<std::size_t>(segments), options_, file_, line_,
                                        word ? word->column : 0, what);
        for (const Eigen::Vector3d& p_mm : arc_chord_ends_mm(move, segments)) {
          set_pose(point, to_frame(p_mm), rotary_deg_);
          detail::append_point(path_, point, options_, file_, line_);
        }
      }
      if (move.corner) {
        // The roll about a corner is tangent to the elements on both sides: no corner of its own.
        for (std::size_t i = first; i < path_.points.size(); ++i) {
          if (path_.points[i].corner_tolerance_m == 0.0) path_.points[i].corner_tolerance_m = PathPoint::kNotProgrammed;
        }
      } else {
        finish_block_points(first, source->second.exact_stop);
        compensated_sources_.erase(source);
      }
    }
  }

  // --- Coordinate systems ---------------------------------------------------------------------
  //
  // The reader keeps the position in the "frame": outside tool-centre-point mode the machine
  // axis positions X Y Z [mm] (what axis_words_to_pose receives), under it the tool tip in W
  // [mm]. Program coordinates p map to it as the control does:
  //   frame = base + rotation_G68(p),
  //   base = work offset + G52 + G92 (+ the G43 tool length along Z outside TCP),
  // where the work offset is in machine axes outside TCP and its zero in W under TCP.

  static std::array<const Word*, 3> no_words() { return {}; }

  Eigen::Vector3d rotated(const Eigen::Vector3d& p, double sign) const {
    if (!rotation_) return p;
    const auto [u, v, w] = plane_axes(rotation_plane_);
    const double c = std::cos(sign * rotation_rad_);
    const double s = std::sin(sign * rotation_rad_);
    const double du = p[u] - rotation_centre_mm_.x();
    const double dv = p[v] - rotation_centre_mm_.y();
    Eigen::Vector3d q = p;
    q[u] = rotation_centre_mm_.x() + c * du - s * dv;
    q[v] = rotation_centre_mm_.y() + s * du + c * dv;
    return q;
  }
  Eigen::Vector3d frame_base() const {
    const Eigen::Vector3d offset = tcp_ == Tcp::off
                                       ? Eigen::Vector3d(offset_.machine_mm + Eigen::Vector3d(0.0, 0.0, h_mm_))
                                       : offset_.zero_W_mm;
    return offset + g52_mm_ + g92_mm_;
  }
  Eigen::Vector3d to_frame(const Eigen::Vector3d& p_mm) const {
    return frame_base() + rotated(p_mm, 1.0);
  }
  Eigen::Vector3d from_frame(const Eigen::Vector3d& f_mm) const {
    return rotated(f_mm - frame_base(), -1.0);
  }
  /// Where an axis never programmed is taken to be: with a set-up (work offsets) and outside
  /// tool-centre-point mode, at the G28 reference point (the machine's home, where a tool change
  /// leaves the axes: Mastercam posts `T1 M6` then `G0 G90 G54 X.. Y..` and only then
  /// `G43 H1 Z..`); else at the program's 0 (the meaning without a set-up).
  Eigen::Vector3d start_frame_position() const {
    if (tcp_ == Tcp::off && !options_.work_offsets_mm.empty()) return options_.g28_reference_mm;
    return to_frame(Eigen::Vector3d::Zero());
  }
  /// The frame position, an axis never programmed taken at start_frame_position().
  Eigen::Vector3d filled_frame_position() const {
    const Eigen::Vector3d zero = start_frame_position();
    Eigen::Vector3d f;
    for (std::size_t k = 0; k < 3; ++k) {
      f[static_cast<Eigen::Index>(k)] = position_[k].value_or(zero[static_cast<Eigen::Index>(k)]);
    }
    return f;
  }
  std::array<std::optional<double>, 3> program_position() const {
    const Eigen::Vector3d p = from_frame(filled_frame_position());
    std::array<std::optional<double>, 3> result;
    for (std::size_t k = 0; k < 3; ++k) {
      if (position_[k]) result[k] = p[static_cast<Eigen::Index>(k)];
    }
    return result;
  }
  void set_program_position(const std::array<std::optional<double>, 3>& p) {
    Eigen::Vector3d v;
    for (std::size_t k = 0; k < 3; ++k) v[static_cast<Eigen::Index>(k)] = p[k].value_or(0.0);
    const Eigen::Vector3d f = to_frame(v);
    for (std::size_t k = 0; k < 3; ++k) {
      position_[k].reset();
      if (p[k]) position_[k] = f[static_cast<Eigen::Index>(k)];
    }
  }

  struct ActiveOffset {
    std::string name;
    Eigen::Vector3d machine_mm = Eigen::Vector3d::Zero();
    Eigen::Vector3d zero_W_mm = Eigen::Vector3d::Zero();
  };

  std::string offset_list() const {
    std::string list;
    for (const auto& [name, value] : offsets_mm_) list += (list.empty() ? "" : ", ") + name;
    return list.empty() ? "none" : list;
  }

  /// The work offset `name`; nullopt when it is not set up.
  std::optional<ActiveOffset> offset_named(const std::string& name) const {
    const auto it = offsets_mm_.find(name);
    if (it != offsets_mm_.end()) {
      return ActiveOffset{name, it->second,
                          options_.machine_axes_W * it->second + options_.machine_zero_W_mm};
    }
    if (name == "G54" && implicit_g54_) {
      return ActiveOffset{name, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
    }
    return std::nullopt;
  }

  void select_offset(const Word& word, const std::string& name, const Word* p_word) {
    std::string key = name;
    if (name == "G54.1") {
      if (!p_word) fail(word, "G54.1 needs the number of the additional offset, P1 .. P48");
      if (!(p_word->value >= 1.0 && p_word->value <= 48.0 &&
            p_word->value == std::round(p_word->value))) {
        fail(*p_word, "G54.1 P must be a whole number 1 .. 48");
      }
      key = "G54.1 P" + std::to_string(std::lround(p_word->value));
    }
    const auto offset = offset_named(key);
    if (!offset) {
      fail(word, "work offset " + key + " is not set up (set up: " + offset_list() +
                     "; the part file's setup: work_offsets, or G10 in the program)");
    }
    offset_ = *offset;  // the machine does not move: the next motion is in the new system
  }

  void set_offset_from_program(const Word& word, const Word* l_word, const Word* p_word,
                               const Word* r_word, const std::array<const Word*, 3>& xyz) {
    if (!l_word || !p_word) fail(word, "G10 needs L (2, 20: work offsets; 1, 10: tool lengths) and P");
    const long l = std::lround(l_word->value);
    const double p = p_word->value;
    if (p != std::round(p)) fail(*p_word, "G10 P must be a whole number");
    const long n = std::lround(p);
    if (l == 1 || l == 10) {
      if (!r_word) fail(word, "G10 L" + std::to_string(l) + " needs R (the tool length)");
      if (const Word* extra = first_of({xyz[0], xyz[1], xyz[2]})) {
        fail(*extra, "G10 L" + std::to_string(l) + " sets a tool length: no axis words");
      }
      const double value = r_word->value * mm_per_unit_;
      double& length = tool_length_mm_[static_cast<int>(n)];
      length = incremental_ ? length + value : value;
      return;
    }
    if (r_word) fail(*r_word, "R has no meaning in G10 L2 / L20");
    std::string key;
    if (l == 2 && n >= 1 && n <= 6) {
      key = "G" + std::to_string(53 + n);
    } else if (l == 20 && n >= 1 && n <= 48) {
      key = "G54.1 P" + std::to_string(n);
    } else if (l == 2 || l == 20) {
      fail(*p_word, l == 2 ? "G10 L2 P must be 1 .. 6 (G54 .. G59; P0, the external offset, "
                             "is not supported)"
                           : "G10 L20 P must be 1 .. 48 (G54.1 P1 .. P48)");
    } else {
      fail(*l_word, "G10 L" + std::to_string(l) +
                        " is not supported (L2 / L20 work offsets, L1 / L10 tool lengths)");
    }
    Eigen::Vector3d value = Eigen::Vector3d::Zero();
    if (const auto it = offsets_mm_.find(key); it != offsets_mm_.end()) value = it->second;
    for (std::size_t k = 0; k < 3; ++k) {
      if (!xyz[k]) continue;
      const double v = xyz[k]->value * mm_per_unit_;
      auto& component = value[static_cast<Eigen::Index>(k)];
      component = incremental_ ? component + v : v;
    }
    offsets_mm_[key] = value;
    if (offset_.name == key) offset_ = *offset_named(key);
  }

  void set_local_shift(const Word& word, long code, const std::array<const Word*, 3>& xyz) {
    if (code == 921) {
      if (const Word* extra = first_of({xyz[0], xyz[1], xyz[2]})) {
        fail(*extra, "G92.1 cancels the G92 shift: no axis words");
      }
      g92_mm_.setZero();
      return;
    }
    if (!xyz[0] && !xyz[1] && !xyz[2]) fail(word, "needs at least one of X Y Z");
    if (code == 520) {
      // G52: the local zero in work coordinates (G52 X0 Y0 Z0 cancels); the machine stays.
      for (std::size_t k = 0; k < 3; ++k) {
        if (xyz[k]) g52_mm_[static_cast<Eigen::Index>(k)] = xyz[k]->value * mm_per_unit_;
      }
      return;
    }
    // G92: the current position becomes the given coordinates.
    const Eigen::Vector3d now = from_frame(filled_frame_position());
    Eigen::Vector3d wanted = now;
    for (std::size_t k = 0; k < 3; ++k) {
      if (xyz[k]) wanted[static_cast<Eigen::Index>(k)] = xyz[k]->value * mm_per_unit_;
    }
    g92_mm_ += rotated(now, 1.0) - rotated(wanted, 1.0);
  }

  void set_rotation(const Word& word, const std::array<const Word*, 3>& xyz, const Word*& r_word) {
    if (std::lround(word.value * 10.0) == 690) {
      if (const Word* extra = first_of({xyz[0], xyz[1], xyz[2], r_word})) {
        fail(*extra, "G69 cancels the rotation: no other words");
      }
      rotation_ = false;
      return;
    }
    const auto [u, v, w] = plane_axes(plane_);
    if (xyz[static_cast<std::size_t>(w)]) {
      fail(*xyz[static_cast<std::size_t>(w)],
           std::string("not a rotation centre word in the ") + plane_name(plane_) + " plane");
    }
    if (!r_word) fail(word, "G68 needs R (the rotation angle in deg)");
    require_within(*r_word, r_word->value, -detail::kMaxRotaryDeg, detail::kMaxRotaryDeg,
                   "rotation angle", "deg");
    // The centre in the current program coordinates; an axis not given: the current position.
    rotation_ = false;
    const Eigen::Vector3d now = from_frame(filled_frame_position());
    Eigen::Vector2d centre(now[u], now[v]);
    if (xyz[static_cast<std::size_t>(u)]) centre.x() = xyz[static_cast<std::size_t>(u)]->value * mm_per_unit_;
    if (xyz[static_cast<std::size_t>(v)]) centre.y() = xyz[static_cast<std::size_t>(v)]->value * mm_per_unit_;
    rotation_ = true;
    rotation_plane_ = plane_;
    rotation_centre_mm_ = centre;
    rotation_rad_ = r_word->value * std::numbers::pi / 180.0;
    r_word = nullptr;
  }

  /// The tool length [mm] of G43 (H, else the tool in the spindle).
  double tool_length_of(const Word* h_word, const Word& g43_word) const {
    int number = -1;
    if (h_word) {
      require_within(*h_word, h_word->value, 0.0, detail::kMaxIgnoredWordValue, "H number", "");
      number = static_cast<int>(std::lround(h_word->value));
    } else if (tool_number_ >= 0) {
      number = tool_number_;
    } else {
      fail(g43_word, "G43 without H and without a tool in the spindle (T.. M6): the tool "
                     "length is unknown");
    }
    if (number == 0) return 0.0;  // H0: no length (Fanuc)
    if (const auto it = tool_length_mm_.find(number); it != tool_length_mm_.end()) {
      return it->second;
    }
    if (options_.default_tool_length_mm) return *options_.default_tool_length_mm;
    std::string known;
    for (const auto& [n, length] : tool_length_mm_) {
      known += (known.empty() ? "H" : ", H") + std::to_string(n);
    }
    fail(h_word ? *h_word : g43_word,
         "no tool length for H" + std::to_string(number) + " (the tool table has " +
             (known.empty() ? std::string("none") : known) + "; the part file's tools)");
  }

  void set_path_mode(const Word& word, long code, const Word* p_word, const Word* q_word,
                     const Word*& r_word, const Word* e_word) {
    switch (code) {
      case 610: case 611: corner_tolerance_m_ = 0.0; return;
      case 640:
        if (p_word && !(p_word->value > 0.0)) {
          fail(*p_word, "G64 P must be positive (G61 asks for exact stops)");
        }
        // G64 without P: the control's own blending, which the part file or the command line
        // models.
        corner_tolerance_m_ = p_word ? p_word->value * mm_per_unit_ * kMetresPerMillimetre
                                     : PathPoint::kNotProgrammed;
        return;
      case 51:
        if (!q_word || (q_word->value != 0.0 && q_word->value != 1.0)) {
          fail(q_word ? *q_word : word, "G5.1 needs Q1 (AI contour control on) or Q0 (off)");
        }
        // R is a smoothing level (1 .. 10), not a length.
        r_word = nullptr;
        corner_tolerance_m_ = q_word->value == 1.0 ? options_.contouring_tolerance_m
                                                   : PathPoint::kNotProgrammed;
        return;
      case 50:
        if (!p_word || (p_word->value != 0.0 && p_word->value != 10000.0)) {
          fail(p_word ? *p_word : word,
               "G05 is supported as G05 P10000 (high-precision contour control) and G05 P0");
        }
        corner_tolerance_m_ = p_word->value == 10000.0 ? options_.contouring_tolerance_m
                                                       : PathPoint::kNotProgrammed;
        return;
      default:  // G187 [P1 .. P3] [E tolerance]
        if (p_word && !(p_word->value >= 1.0 && p_word->value <= 3.0)) {
          fail(*p_word, "G187 P must be 1, 2 or 3");
        }
        if (e_word) {
          if (!(e_word->value > 0.0)) fail(*e_word, "G187 E (the corner tolerance) must be positive");
          corner_tolerance_m_ = e_word->value * mm_per_unit_ * kMetresPerMillimetre;
        } else {
          corner_tolerance_m_ =
              p_word ? options_.contouring_tolerance_m : PathPoint::kNotProgrammed;
        }
        return;
    }
  }

  PathPoint new_point(MotionKind kind) const {
    PathPoint point;
    point.kind = kind;
    point.tool_number = tool_number_;
    point.tool_length_m = spindle_length_m();
    point.corner_tolerance_m = corner_tolerance_m_;
    return point;
  }

  int add_source_block(long block_number) {
    SourceBlock source;
    source.file = file_;
    source.line = line_;
    source.block_number = block_number;
    source.text = line_text_;
    path_.blocks.push_back(std::move(source));
    return static_cast<int>(path_.blocks.size()) - 1;
  }

  /// Points inside a block (arc chords, rotary steps) are no corners of the program: an exact
  /// stop is not asked there (NaN); the block's last point carries the mode, 0 under G9.
  void finish_block_points(std::size_t first, bool exact_stop_here) {
    if (first >= path_.points.size()) return;
    for (std::size_t i = first; i + 1 < path_.points.size(); ++i) {
      if (path_.points[i].corner_tolerance_m == 0.0) {
        path_.points[i].corner_tolerance_m = PathPoint::kNotProgrammed;
      }
    }
    if (exact_stop_here) path_.points.back().corner_tolerance_m = 0.0;
  }

  /// A rapid to frame position f where all three axes are known.
  void rapid_to_frame(const std::array<std::optional<double>, 3>& f, int& block,
                      long block_number) {
    if (!f[0] || !f[1] || !f[2]) return;
    if (block < 0) block = add_source_block(block_number);
    PathPoint point = new_point(MotionKind::rapid);
    point.block = block;
    point.rotary_words_deg = rotary_words_deg(rotary_deg_);
    set_pose(point, Eigen::Vector3d(*f[0], *f[1], *f[2]), rotary_deg_);
    detail::append_point(path_, point, options_, file_, line_);
    started_ = true;
  }

  /// G28 / G30: a rapid to the intermediate point (the axes named, in program coordinates), then
  /// the named axes (all three when none is named) to the reference point in machine
  /// coordinates. An axis whose position is not known yet skips the intermediate point; points
  /// are made once all three axes are known.
  void reference_return(const Word& word, bool g28, const std::array<const Word*, 3>& xyz,
                        const std::array<const Word*, 3>& abc, long block_number,
                        bool exact_stop_here) {
    if (tcp_ != Tcp::off) {
      fail(word, "reference point return in tool-centre-point mode: cancel it first (G49)");
    }
    exit_pending_ = false;
    // Rotary words (Mastercam's `G28 X0. Y0. A0.`): the named rotary axes go to the word's
    // value (the intermediate position) with the linear axes, then to their reference.
    RotaryDeg rotary_reference = rotary_deg_;
    for (std::size_t k = 0; k < 3; ++k) {
      if (!abc[k]) continue;
      const double previous = rotary_deg_[k].value_or(0.0);
      rotary_deg_[k] = incremental_ ? previous + abc[k]->value : abc[k]->value;
      rotary_reference[k] = options_.rotary_reference_deg[k];
    }
    const bool all = !xyz[0] && !xyz[1] && !xyz[2] && !abc[0] && !abc[1] && !abc[2];
    const Eigen::Vector3d& reference = g28 ? options_.g28_reference_mm : options_.g30_reference_mm;
    int block = -1;
    const std::size_t first_point = path_.points.size();
    std::array<std::optional<double>, 3> f = position_;
    Eigen::Vector3d p = from_frame(filled_frame_position());
    std::array<bool, 3> via{};
    for (std::size_t k = 0; k < 3; ++k) {
      if (!xyz[k]) continue;
      const double v = xyz[k]->value * mm_per_unit_;
      auto& component = p[static_cast<Eigen::Index>(k)];
      if (!incremental_) {
        component = v;
      } else if (position_[k]) {
        component += v;
      } else {
        continue;
      }
      via[k] = true;
    }
    const Eigen::Vector3d f_via = to_frame(p);
    for (std::size_t k = 0; k < 3; ++k) {
      if (via[k]) f[k] = f_via[static_cast<Eigen::Index>(k)];
    }
    rapid_to_frame(f, block, block_number);
    for (std::size_t k = 0; k < 3; ++k) {
      if (all || xyz[k]) f[k] = reference[static_cast<Eigen::Index>(k)];
    }
    rotary_deg_ = rotary_reference;
    rapid_to_frame(f, block, block_number);
    finish_block_points(first_point, exact_stop_here);
    position_ = f;
  }

  /// G80, or a cycle started anew: the hole data (R, bottom, Q) and the initial level go.
  void end_cycle() {
    cycle_initial_known_ = false;
    cycle_r_mm_.reset();
    cycle_bottom_mm_.reset();
    cycle_q_mm_.reset();
    cycle_shift_ij_mm_.reset();
    cycle_dwell_s_ = 0.0;
  }

  void canned_cycle(const std::array<const Word*, 3>& xyz, const std::array<const Word*, 3>& ijk,
                    const Word* r_word, const Word* q_word, const Word* l_word, const Word* p_word,
                    long block_number, const Word& reported) {
    const auto [u, v, w] = plane_axes(plane_);
    const int code = *motion_;
    const bool shifting = code == 76 || code == 87;
    if (const Word* extra = first_of({ijk[0], ijk[1]})) {
      // Fanuc (parameter SIJ) and Haas: I J give the G76 / G87 shift as a vector in the plane.
      if (!shifting) fail(*extra, "I J have no meaning in this canned cycle (G76 / G87 shift)");
      if (plane_ != Plane::xy) {
        fail(*extra, "a G76 / G87 shift by I J is read under G17 only: give Q (the shift along "
                     "ReaderOptions::fine_boring_shift_direction)");
      }
      if (q_word) fail(*q_word, "both Q and I J (the shift) in one block");
      Eigen::Vector2d shift_mm = Eigen::Vector2d::Zero();
      for (const int k : {0, 1}) {
        const Word* word = ijk[static_cast<std::size_t>(k)];
        if (!word) continue;
        require_within(*word, word->value, -detail::kMaxCoordinateMm, detail::kMaxCoordinateMm,
                       "shift", "");
        shift_mm[k] = word->value * mm_per_unit_;
      }
      cycle_shift_ij_mm_ = shift_mm;
      cycle_q_mm_.reset();
    } else if (q_word && shifting) {
      cycle_shift_ij_mm_.reset();
    }
    const Word* k_word = ijk[2];
    if (k_word && l_word) fail(*l_word, "both K and L (repeats) in one block");
    const Word* repeat_word = k_word ? k_word : l_word;
    long repeats = 1;
    if (repeat_word) {
      require_within(*repeat_word, repeat_word->value, 0.0, 1e6, "repeat count", "");
      if (repeat_word->value != std::round(repeat_word->value)) {
        fail(*repeat_word, "the repeat count must be a whole number");
      }
      repeats = std::lround(repeat_word->value);
    }
    if (inverse_time_) fail(reported, "canned cycles under G93 (inverse time) are not supported");
    if (!feed_m_per_s_) fail(reported, "canned cycle before any F word: the feed is unknown");
    if (tcp_ != Tcp::off && axis_W_ != Eigen::Vector3d::UnitZ()) {
      fail(reported, "canned cycles with a tilted tool axis are not supported");
    }
    // Hole data are modal while the cycle is: R, the bottom and Q stay for the next holes.
    const Word* bottom_word = xyz[static_cast<std::size_t>(w)];
    if (r_word) cycle_r_mm_ = r_word->value * mm_per_unit_;
    if (bottom_word) cycle_bottom_mm_ = bottom_word->value * mm_per_unit_;
    if (q_word) cycle_q_mm_ = std::abs(q_word->value) * mm_per_unit_;
    // P: the dwell at the bottom in ms (Fanuc), modal like the hole data.
    if (p_word) cycle_dwell_s_ = p_word->value * 1e-3;
    const std::string axis_name(1, "XYZ"[w]);
    if (!cycle_r_mm_) fail(reported, "canned cycle without its R level");
    if (!cycle_bottom_mm_) fail(reported, "canned cycle without its hole bottom (" + axis_name + ")");
    if ((code == 73 || code == 83) && !(cycle_q_mm_ && *cycle_q_mm_ > 0.0)) {
      fail(q_word ? *q_word : reported, "G" + std::to_string(code) + " needs a peck depth Q > 0");
    }
    if (!started_) fail(reported, "a canned cycle as the first motion: its start point is unknown");

    Eigen::Vector3d p = from_frame(known_frame_position(no_words(), true));
    if (!cycle_initial_known_) {
      cycle_initial_mm_ = p[w];
      cycle_initial_known_ = true;
    }
    detail::CycleHole hole;
    hole.code = code;
    hole.u = u;
    hole.v = v;
    hole.w = w;
    hole.initial_mm = cycle_initial_mm_;
    hole.r_mm = incremental_ ? cycle_initial_mm_ + *cycle_r_mm_ : *cycle_r_mm_;
    hole.bottom_mm = incremental_ ? hole.r_mm + *cycle_bottom_mm_ : *cycle_bottom_mm_;
    hole.return_to_initial = return_to_initial_;
    hole.peck_mm = cycle_q_mm_.value_or(0.0);
    hole.dwell_s = cycle_dwell_s_;
    hole.peck_clearance_mm = options_.peck_clearance_mm;
    hole.peck_retract_mm = options_.peck_retract_mm;
    if (!(options_.fine_boring_shift_direction.norm() > 0.0) ||
        !options_.fine_boring_shift_direction.allFinite()) {
      throw InputError("ReaderOptions::fine_boring_shift_direction must be a non-zero direction");
    }
    hole.shift_direction = options_.fine_boring_shift_direction.normalized();
    hole.shift_mm = 0.0;
    if (shifting && cycle_shift_ij_mm_) {
      hole.shift_mm = cycle_shift_ij_mm_->norm();
      if (hole.shift_mm > 0.0) hole.shift_direction = *cycle_shift_ij_mm_ / hole.shift_mm;
    } else if (shifting) {
      hole.shift_mm = cycle_q_mm_.value_or(0.0);
    }
    if (code == 87) {
      // Back boring cuts upwards: R is below the part, the Z point above it.
      hole.return_to_initial = true;
      if (!return_to_initial_ && !g99_back_boring_warned_) {
        warn("G87 under G99: back boring returns to the initial level (G98), as on a Fanuc, "
             "since R lies below the part");
        g99_back_boring_warned_ = true;
      }
      if (!(hole.bottom_mm > hole.r_mm)) {
        fail(bottom_word ? *bottom_word : reported,
             "G87 (back boring): the Z point " + axis_name +
                 detail::format_number(hole.bottom_mm) + " mm is not above the R level " +
                 detail::format_number(hole.r_mm) + " mm (R lies below the part)");
      }
      if (!(hole.initial_mm > hole.bottom_mm)) {
        fail(reported, "G87 (back boring): the initial level " +
                           detail::format_number(hole.initial_mm) +
                           " mm is not above the Z point " + axis_name +
                           detail::format_number(hole.bottom_mm) + " mm");
      }
    } else if (!(hole.bottom_mm < hole.r_mm)) {
      fail(bottom_word ? *bottom_word : reported,
           "the hole bottom " + axis_name + detail::format_number(hole.bottom_mm) +
               " mm is not below the R level " + detail::format_number(hole.r_mm) + " mm");
    }
    if (code == 88 && !g88_warned_) {
      warn("G88 stops at the hole bottom for a manual retract: taken as a rapid straight out to "
           "the R level, then the return (G98 / G99) as after cycle start");
      g88_warned_ = true;
    }
    // Points before they are made: a tiny Q would peck millions of times.
    const double pecks = (code == 73 || code == 83)
                             ? std::ceil((hole.r_mm - hole.bottom_mm) / hole.peck_mm)
                             : 1.0;
    const double estimate = static_cast<double>(repeats) * (3.0 * pecks + 6.0);
    const std::string what = "the canned cycle G" + std::to_string(code) + " (" +
                             detail::format_number(static_cast<double>(repeats)) + " holes)";
    if (!(estimate <= static_cast<double>(options_.max_points_per_block))) {
      fail(reported, what + " expands to about " + detail::format_number(estimate) +
                         " points, more than the limit of " +
                         std::to_string(options_.max_points_per_block) +
                         " points per block (ReaderOptions::max_points_per_block)");
    }
    detail::require_room_for_points(path_, static_cast<std::size_t>(estimate), options_, file_,
                                    line_, reported.column, what);
    const int block = add_source_block(block_number);
    for (long repeat = 0; repeat < repeats; ++repeat) {
      hole.hole_mm = p;
      for (const int k : {u, v}) {
        const Word* word = xyz[static_cast<std::size_t>(k)];
        if (!word) continue;
        const double value = word->value * mm_per_unit_;
        hole.hole_mm[k] = incremental_ ? p[k] + value : value;
        require_within(*word, hole.hole_mm[k], -detail::kMaxCoordinateMm,
                       detail::kMaxCoordinateMm, "position", "mm");
      }
      for (const detail::CycleMove& move : detail::expand_cycle(p, hole)) {
        PathPoint point = new_point(move.rapid ? MotionKind::rapid : MotionKind::linear);
        if (!move.rapid) point.feed_m_per_s = *feed_m_per_s_;
        point.corner_tolerance_m = 0.0;  // the control stops at each level of a cycle
        point.dwell_s = move.dwell_s;
        point.block = block;
        point.rotary_words_deg = rotary_words_deg(rotary_deg_);
        set_pose(point, to_frame(move.p_mm), rotary_deg_);
        detail::append_point(path_, point, options_, file_, line_);
        p = move.p_mm;
      }
    }
    const Eigen::Vector3d f = to_frame(p);
    for (std::size_t k = 0; k < 3; ++k) position_[k] = f[static_cast<Eigen::Index>(k)];
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

  /// The length of the tool in the spindle [m] (PathPoint::tool_length_m), NaN when unknown.
  double spindle_length_m() const {
    const std::optional<double> mm = detail::spindle_tool_length_mm(options_, tool_number_);
    return mm ? *mm * kMetresPerMillimetre : PathPoint::kNotProgrammed;
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

  /// The current frame position [mm]; an axis not programmed yet is taken at
  /// start_frame_position(), with a warning unless this block gives its absolute position.
  Eigen::Vector3d known_frame_position(const std::array<const Word*, 3>& xyz, bool absolute) {
    const Eigen::Vector3d zero = start_frame_position();
    const bool at_reference = tcp_ == Tcp::off && !options_.work_offsets_mm.empty();
    Eigen::Vector3d f;
    for (std::size_t k = 0; k < 3; ++k) {
      if (!position_[k]) {
        if (!(xyz[k] && absolute)) {
          warn(std::string("axis ") + "XYZ"[k] + " has no programmed position before this motion: taken " +
               (at_reference ? "at the G28 reference point (the machine's home, where a tool change leaves it)"
                             : "as 0"));
        }
        position_[k] = zero[static_cast<Eigen::Index>(k)];
      }
      f[static_cast<Eigen::Index>(k)] = *position_[k];
    }
    return f;
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

  /// Under tool-centre-point mode with the tip known: the machine's linear axes there
  /// (ReaderOptions::tip_to_axis_words), nullopt without the callback or an answer.
  std::optional<Eigen::Vector3d> machine_axes_at_tip() const {
    if (!options_.tip_to_axis_words || !position_[0] || !position_[1] || !position_[2]) return std::nullopt;
    const Eigen::Vector3d spindle_tip_W_m =
        Eigen::Vector3d(*position_[0], *position_[1], *position_[2]) * kMetresPerMillimetre;
    // The callback places the caller's tool: its tip where the gauge point of the tool in the
    // spindle puts it.
    const Eigen::Vector3d tip_W_m =
        spindle_tip_W_m + (spindle_tip_W_m - detail::spindle_tip_W_m(options_, {spindle_tip_W_m, axis_W_},
                                                                     detail::spindle_tool_length_mm(options_, tool_number_)));
    const std::vector<std::pair<char, double>> words = rotary_words(rotary_deg_);
    const std::optional<Eigen::Vector3d> machine_mm =
        located_call("tip_to_axis_words", [&] { return options_.tip_to_axis_words(tip_W_m, axis_W_, words); });
    if (machine_mm && !machine_mm->allFinite()) {
      fail(0, "tip_to_axis_words gave machine axes that are not finite for '" + line_text_ + "'");
    }
    return machine_mm;
  }

  /// The tool pose of frame position f_mm (see "Coordinate systems") and rotary words
  /// `rotary_deg` (which give the tool axis under G43.4 / TRAORI only when `axis_from_rotary`).
  void set_pose(PathPoint& point, const Eigen::Vector3d& f_mm, const RotaryDeg& rotary_deg,
                bool axis_from_rotary = false) const {
    if (tcp_ == Tcp::off && options_.axis_words_to_pose) {
      std::vector<std::pair<char, double>> words = {{'X', f_mm.x()}, {'Y', f_mm.y()},
                                                    {'Z', f_mm.z()}};
      for (const auto& w : rotary_words(rotary_deg)) words.push_back(w);
      const AxisWordPose pose =
          located_call("axis_words_to_pose", [&] { return options_.axis_words_to_pose(words); });
      if (!pose.tip_W_m.allFinite()) {
        fail(0, "axis_words_to_pose gave a tool tip that is not finite for '" + line_text_ + "'");
      }
      point.axis_W = detail::unit_tool_axis(pose.axis_W, file_, line_, 0,
                                            line_text_ + " (through axis_words_to_pose)");
      point.tip_W_m = detail::spindle_tip_W_m(options_, {pose.tip_W_m, point.axis_W},
                                              detail::spindle_tool_length_mm(options_, tool_number_));
      return;
    }
    if (tcp_ == Tcp::off) {
      // No machine: the machine axes move the spindle gauge point; the tool under G43 is as long
      // as its H says, so the tip is the gauge point less that length along +Z.
      const Eigen::Vector3d gauge_mm = f_mm - Eigen::Vector3d(0.0, 0.0, h_mm_);
      point.tip_W_m = (options_.machine_axes_W * gauge_mm + options_.machine_zero_W_mm) *
                      kMetresPerMillimetre;
      point.axis_W = axis_W_;
      return;
    }
    point.tip_W_m = f_mm * kMetresPerMillimetre;
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
      set_pose(point, end_mm, rotary_deg_);
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
    set_pose(end_point, end_mm, rotary_deg_);
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

  /// A length [mm] for a message, to the nanometre (0.02, not 0.019999999999999574).
  static std::string format_mm(double value_mm) {
    return detail::format_number(std::round(value_mm * 1e6) / 1e6);
  }

  /// The largest start/end radius difference accepted for an arc of radius r_mm [mm].
  double arc_radius_tolerance_mm(double r_mm) const {
    const double absolute_mm = mm_per_unit_ == 1.0
                                   ? options_.arc_radius_tolerance_mm
                                   : options_.arc_radius_tolerance_inch * kMillimetresPerInch;
    return std::max(absolute_mm, options_.arc_radius_relative_tolerance * r_mm);
  }
  std::string arc_tolerance_source() const {
    const std::string absolute =
        mm_per_unit_ == 1.0 ? format_mm(options_.arc_radius_tolerance_mm) + " mm"
                            : format_mm(options_.arc_radius_tolerance_inch) + " inch";
    return " (the larger of " + absolute + " and " +
           detail::format_number(options_.arc_radius_relative_tolerance * 100.0) +
           " % of the radius: ReaderOptions::arc_radius_tolerance_mm / _inch / "
           "arc_radius_relative_tolerance)";
  }

  ArcGeometry arc_geometry_of(const Eigen::Vector3d& start_mm, const Eigen::Vector3d& end_mm,
                              const std::array<const Word*, 3>& ijk, const Word* r_word,
                              const Word& reported) const {
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
      if (arc_centre_incremental_) {
        c = s + Eigen::Vector2d(offset(u), offset(v));
      } else {
        // G90.1: I J K are the centre in program coordinates.
        for (const int axis : {u, v}) {
          if (!ijk[static_cast<std::size_t>(axis)]) {
            fail(reported, std::string("under G90.1 (absolute arc centres) the arc needs both "
                                       "centre words of the ") + plane_name(plane_) + " plane");
          }
        }
        c = Eigen::Vector2d(offset(u), offset(v));
      }
      full_circle = (e - s).norm() < kFullCircleDistanceMm;
    } else {
      const double r = std::abs(r_word->value) * mm_per_unit_;
      const double d = (e - s).norm();
      if (d < kFullCircleDistanceMm) {
        fail(*r_word, "an R-form arc cannot be a full circle (end = start): use I J K");
      }
      if (r == 0.0) fail(*r_word, "zero arc radius");
      double short_by_mm = 0.0;
      c = detail::arc_centre_from_radius(s, e, r_word->value * mm_per_unit_, ccw, &short_by_mm);
      const double tolerance_mm = arc_radius_tolerance_mm(0.5 * d);
      if (short_by_mm > tolerance_mm) {
        fail(*r_word, "the radius is smaller than half the distance from start to end (" +
                          format_mm(0.5 * d) + " mm) by " + format_mm(short_by_mm) +
                          " mm, more than the tolerance of " + format_mm(tolerance_mm) + " mm" +
                          arc_tolerance_source());
      }
    }
    double r_start = (s - c).norm();
    double r_end = (e - c).norm();
    if (r_start == 0.0) fail(reported, "an arc of zero radius (the centre is the start point)");
    const double radius_tolerance = arc_radius_tolerance_mm(std::max(r_start, r_end));
    if (std::abs(r_start - r_end) > radius_tolerance) {
      fail(reported, "the arc's start and end are not at the same distance from its centre: "
                     "the radii differ by " + format_mm(std::abs(r_start - r_end)) +
                         " mm (start radius " + format_mm(r_start) +
                         " mm, end radius " + format_mm(r_end) +
                         " mm), more than the tolerance of " + format_mm(radius_tolerance) +
                         " mm" +
                         arc_tolerance_source());
    }
    if (!full_circle && r_start != r_end) {
      // Within the tolerance the control moves the centre onto the perpendicular bisector of
      // start and end (the nearest such point), so that the arc is a circle through both.
      c = detail::centre_on_bisector(s, e, c);
      r_start = (s - c).norm();
      r_end = r_start;
    }
    ArcGeometry arc;
    arc.centre = c;
    arc.r_start = r_start;
    arc.r_end = r_end;
    arc.a0 = std::atan2(s.y() - c.y(), s.x() - c.x());
    arc.sweep = detail::arc_sweep_rad(s, e, c, ccw, full_circle);
    return arc;
  }

  void arc_points(PathPoint point, const Eigen::Vector3d& start_mm, const Eigen::Vector3d& end_mm,
                  const ArcGeometry& arc, const Word& reported) {
    const auto [u, v, w] = plane_axes(plane_);
    const Eigen::Vector2d& c = arc.centre;
    const double r_start = arc.r_start, r_end = arc.r_end, a0 = arc.a0, sweep = arc.sweep;
    const double r_max = std::max(r_start, r_end);
    const double tolerance_mm = options_.arc_chord_tolerance_m / kMetresPerMillimetre;
    const double segments_real = detail::arc_chord_count(r_max, sweep, tolerance_mm);
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
      set_pose(point, to_frame(p_mm), rotary_deg_);
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
  std::optional<int> motion_;  // 0 1 2 3, or a canned cycle 73 74 81 .. 89
  std::optional<int> motion_before_cycle_;  // the G0 .. G3 a cycle interrupted (back after G80)
  bool arc_centre_incremental_ = true;  // G91.1 (else G90.1)
  bool return_to_initial_ = true;       // G98 (else G99)
  std::optional<double> cycle_r_mm_, cycle_bottom_mm_, cycle_q_mm_;
  std::optional<Eigen::Vector2d> cycle_shift_ij_mm_;  // G76 / G87 shift by I J (modal)
  double cycle_dwell_s_ = 0.0;  // P of G74 G76 G82 G84 G87 G88 G89 (modal in the cycle)
  bool g99_back_boring_warned_ = false;
  bool g88_warned_ = false;
  bool cycle_initial_known_ = false;
  double cycle_initial_mm_ = 0.0;
  // Coordinate systems.
  std::map<std::string, Eigen::Vector3d> offsets_mm_;
  bool implicit_g54_ = true;
  ActiveOffset offset_;
  Eigen::Vector3d g52_mm_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d g92_mm_ = Eigen::Vector3d::Zero();
  bool rotation_ = false;
  Plane rotation_plane_ = Plane::xy;
  Eigen::Vector2d rotation_centre_mm_ = Eigen::Vector2d::Zero();
  double rotation_rad_ = 0.0;
  bool g43_ = false;
  double h_mm_ = 0.0;  // G43 tool length in force (outside tool-centre-point mode)
  std::map<int, double> tool_length_mm_;
  // Tools and path control.
  std::optional<int> next_tool_;
  int tool_number_ = -1;
  double corner_tolerance_m_ = PathPoint::kNotProgrammed;
  Plane plane_ = Plane::xy;
  double mm_per_unit_ = 1.0;
  bool incremental_ = false;
  bool inverse_time_ = false;
  Tcp tcp_ = Tcp::off;
  std::optional<double> feed_m_per_s_;
  std::array<std::optional<double>, 3> position_;  // frame position [mm]
  std::array<std::optional<double>, 3> rotary_deg_;
  Eigen::Vector3d axis_W_ = Eigen::Vector3d::UnitZ();
  // Cutter radius compensation.
  std::optional<CompensationSide> compensation_side_;
  double compensation_radius_mm_ = 0.0;
  std::optional<int> d_number_;  // the last D (Fanuc: modal)
  std::optional<CutterCompensator> compensator_;  // from the first motion under G41 / G42
  struct CompensatedSource {
    PathPoint point;  // the block's point: kind, feed, block, modes
    bool exact_stop = false;
  };
  std::map<int, CompensatedSource> compensated_sources_;  // by element tag, until its moves are made
  int next_compensation_tag_ = 0;
  bool exit_pending_ = false;  // G40 given: the next move in the plane must be a line
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
