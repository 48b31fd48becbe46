// Heidenhain TNC conversational (Klartext) reader: the subset and the model of the control
// documented in vmsim/toolpath/heidenhain_reader.hpp.
#include "vmsim/toolpath/heidenhain_reader.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "canned_cycles.hpp"
#include "toolpath_detail.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/cutter_compensation.hpp"

namespace vmsim::toolpath {
namespace {

using detail::kMetresPerMillimetre;
using detail::kSecondsPerMinute;

constexpr double kDegPerRad = 180.0 / std::numbers::pi;
constexpr double kSplitRotaryTurnDeg = 180.0;
constexpr double kRotaryStepDeg = 90.0;
constexpr int kMaxWarnings = 1000;
constexpr int kMaxQParameter = 1999;
/// Directions and collinearity [mm]: below this a line has no direction in the plane.
constexpr double kTinyMm = 1e-9;

/// One blank-separated token of a block, as written.
struct Token {
  std::string text;   ///< as written
  std::string upper;  ///< upper case
  int column = 0;     ///< 1-based
};

/// A word of a motion or definition block: an address and its value ("X+10", "IX-5", "DR+",
/// "FMAX", "X+Q1").
struct Word {
  std::string address;  ///< upper case, without the incremental I ("X" for "IX+5")
  bool incremental = false;
  std::optional<double> value;  ///< nullopt for "FMAX", "R0" has 0
  int sign_only = 0;            ///< "DR+" / "DR-": +1 / -1
  const Token* token = nullptr;
};

using Vec3 = Eigen::Vector3d;
using Vec2 = Eigen::Vector2d;
using RotaryDeg = std::array<std::optional<double>, 3>;

Eigen::Matrix3d rotation_x(double deg) {
  return Eigen::AngleAxisd(deg / kDegPerRad, Vec3::UnitX()).toRotationMatrix();
}
Eigen::Matrix3d rotation_y(double deg) {
  return Eigen::AngleAxisd(deg / kDegPerRad, Vec3::UnitY()).toRotationMatrix();
}
Eigen::Matrix3d rotation_z(double deg) {
  return Eigen::AngleAxisd(deg / kDegPerRad, Vec3::UnitZ()).toRotationMatrix();
}

/// The in-plane axes (u, v) and the normal w of an arc plane, right-handed: DR+ turns u to v.
using PlaneAxes = std::array<int, 3>;
constexpr PlaneAxes kPlaneXY{0, 1, 2}, kPlaneZX{2, 0, 1}, kPlaneYZ{1, 2, 0};

class HeidenhainReader {
 public:
  HeidenhainReader(const std::string& file, const ReaderOptions& options)
      : file_(file), options_(options) {}

  int current_line() const { return line_; }

  Toolpath read(std::string_view text) {
    if (!(options_.arc_chord_tolerance_m >= 1e-12) ||
        !std::isfinite(options_.arc_chord_tolerance_m)) {
      throw InputError("ReaderOptions::arc_chord_tolerance_m must be at least 1e-12 m and "
                       "finite, got " + detail::format_number(options_.arc_chord_tolerance_m));
    }
    const auto it = options_.work_offsets_mm.find(options_.initial_work_offset);
    if (it != options_.work_offsets_mm.end()) {
      preset_machine_mm_ = it->second;
      preset_W_mm_ = options_.machine_axes_W * it->second + options_.machine_zero_W_mm;
    } else if (!options_.work_offsets_mm.empty() || options_.initial_work_offset != "G54") {
      throw InputError("ReaderOptions::initial_work_offset " + options_.initial_work_offset +
                       " is not in the work offset table (the TNC's preset)");
    }
    text = detail::without_byte_order_mark(text);
    detail::require_utf8_text(text, file_);
    auto main_program = std::make_unique<Program>();
    main_program->file = file_;
    split_lines(*main_program, text);
    programs_.push_back(std::move(main_program));
    index_labels(*programs_.back());
    frames_.push_back(Frame{});
    run();
    close_cycle_definition();
    if (pending_approach_) {
      line_ = pending_approach_->line;
      fail(pending_approach_->column, "APPR at the end of the program: no contour element follows it");
    }
    if (compensation_side_ && !pending_corner_) {
      warn("radius compensation RL / RR is still on at the end of the program (no R0): its last "
           "element ends at its offset end");
      (void)end_compensation(0);
    }
    if (pending_corner_) {
      line_ = pending_corner_->line;
      fail(pending_corner_->column, std::string(pending_corner_->chamfer ? "CHF" : "RND") +
                                        " at the end of the program: no element follows it");
    }
    detail::require_motion(path_, file_);
    return std::move(path_);
  }

 private:
  // --- Messages -------------------------------------------------------------------------------

  [[noreturn]] void fail(int column, const std::string& message) const {
    throw InputError(located_message(file_, line_, column, message));
  }
  [[noreturn]] void fail(const Token& token, const std::string& message) const {
    fail(token.column, "'" + token.text + "': " + message);
  }
  [[noreturn]] void fail(const Word& word, const std::string& message) const {
    fail(*word.token, message);
  }
  /// A dwell [s] at the current position: held on the last point made (a dwell before any
  /// motion holds nothing).
  void dwell_here(double seconds) {
    if (compensator_) {
      warn("dwell under radius compensation (RL / RR): not timed");
      return;
    }
    if (!path_.points.empty() && seconds > 0.0) path_.points.back().dwell_s += seconds;
  }
  void warn(const std::string& message) {
    ++warning_count_;
    if (warning_count_ < kMaxWarnings) {
      path_.warnings.push_back(ReaderWarning{file_, line_, message});
    } else if (warning_count_ == kMaxWarnings) {
      path_.warnings.push_back(ReaderWarning{
          file_, line_,
          "more than " + std::to_string(kMaxWarnings) + " warnings: the rest are not listed"});
    }
  }
  void require_within(const Token& token, double value, double min, double max,
                      const std::string& what, const std::string& unit) const {
    if (!(value >= min && value <= max)) {
      fail(token, what + " " + detail::format_number(value) + (unit.empty() ? "" : " " + unit) +
                      " is outside [" + detail::format_number(min) + ", " +
                      detail::format_number(max) + "]" + (unit.empty() ? "" : " " + unit));
    }
  }

  // --- Tokens and numbers ---------------------------------------------------------------------

  std::vector<Token> tokens_of(std::string_view line) const {
    std::vector<Token> tokens;
    std::size_t i = 0;
    while (i < line.size()) {
      const char c = line[i];
      if (c == ';') break;
      if (std::isspace(static_cast<unsigned char>(c))) {
        ++i;
        continue;
      }
      const std::size_t start = i;
      if (c == '"') {
        const std::size_t close = line.find('"', i + 1);
        if (close == std::string_view::npos) fail(static_cast<int>(i) + 1, "'\"' is not closed on its line");
        i = close + 1;
      } else {
        while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i])) &&
               line[i] != ';') {
          ++i;
        }
      }
      if (tokens.size() == detail::kMaxWordsPerBlock) {
        fail(static_cast<int>(start) + 1, "more than " + std::to_string(detail::kMaxWordsPerBlock) +
                                              " words in one block");
      }
      Token token;
      token.text = std::string(line.substr(start, i - start));
      token.upper = detail::to_upper(token.text);
      token.column = static_cast<int>(start) + 1;
      tokens.push_back(std::move(token));
    }
    return tokens;
  }

  /// A Q parameter name ("Q12", "QL3", "QR0") at the start of `text`: its key and length.
  static std::optional<std::pair<std::string, std::size_t>> q_name(std::string_view text) {
    if (text.empty() || text[0] != 'Q') return std::nullopt;
    std::size_t i = 1;
    if (i < text.size() && (text[i] == 'L' || text[i] == 'R')) ++i;
    const std::size_t digits_start = i;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) ++i;
    if (i == digits_start || i - digits_start > 6) return std::nullopt;
    return std::make_pair(std::string(text.substr(0, i)), i);
  }

  double q_value(const std::string& name, const Token& token) const {
    const auto [prefix, number] = split_q(name);
    if (number > kMaxQParameter) {
      fail(token, name + " is beyond the Q parameters (0 .. " + std::to_string(kMaxQParameter) + ")");
    }
    const auto it = q_.find(name);
    if (it == q_.end()) {
      if (prefix == "Q" && number >= 120 && number <= 122) {
        fail(token, name + " holds an axis angle the control computes for PLANE STAY (its "
                           "kinematics): not simulated; position the rotary axes with numbers "
                           "or use PLANE ... TURN");
      }
      fail(token, name + " is read before the program sets it (a value left by another program "
                         "is not simulated)");
    }
    return it->second;
  }
  static std::pair<std::string, long> split_q(const std::string& name) {
    std::size_t i = 1;
    if (i < name.size() && (name[i] == 'L' || name[i] == 'R')) ++i;
    return {name.substr(0, i), std::stol(name.substr(i))};
  }

  /// A value as written in a word: a number, or a Q parameter with an optional sign.
  std::optional<double> value_of(std::string_view text, const Token& token) const {
    std::size_t i = 0;
    double sign = 1.0;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) {
      sign = text[i] == '-' ? -1.0 : 1.0;
      ++i;
    }
    if (i < text.size() && (text[i] == 'Q' || text[i] == 'q')) {
      const std::string rest = detail::to_upper(text.substr(i));
      const auto name = q_name(rest);
      if (!name || name->second != rest.size()) fail(token, "malformed Q parameter");
      return sign * q_value(name->first, token);
    }
    std::string problem;
    const std::optional<double> value = detail::parse_decimal(text, &problem);
    if (!value) fail(token, text.empty() ? "the address has no value" : problem);
    return value;
  }

  /// The words of a block after its keyword(s).
  std::vector<Word> words_of(const std::vector<Token>& tokens, std::size_t first) const {
    std::vector<Word> words;
    for (std::size_t k = first; k < tokens.size(); ++k) {
      const Token& token = tokens[k];
      const std::string& u = token.upper;
      std::size_t i = 0;
      while (i < u.size() && std::isalpha(static_cast<unsigned char>(u[i]))) ++i;
      Word word;
      word.token = &token;
      std::string letters = u.substr(0, i);
      std::string value = token.text.substr(i);
      // "FQ5", "XQ1": an address followed directly by a Q parameter.
      if (letters.size() >= 2 && value.size() > 0 &&
          std::isdigit(static_cast<unsigned char>(value[0]))) {
        for (const char* q : {"QL", "QR", "Q"}) {
          const std::string qs(q);
          if (letters.size() > qs.size() && letters.compare(letters.size() - qs.size(), qs.size(), qs) == 0) {
            value = letters.substr(letters.size() - qs.size()) + value;
            letters = letters.substr(0, letters.size() - qs.size());
            break;
          }
        }
      }
      if (letters == "DR" && value.size() >= 2 && value[0] == '2' && (value[1] == '+' || value[1] == '-')) {
        letters = "DR2";  // TOOL CALL's DR2 (the corner radius allowance)
        value = value.substr(1);
      }
      if (letters.size() == 2 && letters[0] == 'I' && std::string("XYZABC").find(letters[1]) != std::string::npos) {
        word.incremental = true;
        letters = letters.substr(1);
      }
      word.address = letters;
      if (value == "+" || value == "-") {
        word.sign_only = value == "+" ? 1 : -1;
      } else if (!value.empty()) {
        word.value = value_of(value, token);
      }
      words.push_back(std::move(word));
    }
    return words;
  }

  // --- Q parameter formulas -------------------------------------------------------------------

  /// Evaluates a formula (`Q1 = ...` right-hand side) starting at `text[at]`; columns for
  /// messages are 1-based in the line.
  class Formula {
   public:
    Formula(const HeidenhainReader& reader, std::string_view line, std::size_t at)
        : reader_(reader), line_(line), i_(at) {}
    double evaluate() {
      const double value = expression();
      skip();
      if (i_ < line_.size() && line_[i_] != ';') error("unexpected '" + std::string(1, line_[i_]) + "'");
      return value;
    }

   private:
    [[noreturn]] void error(const std::string& what) const {
      reader_.fail(static_cast<int>(i_) + 1, "in the formula '" + detail::trim(line_) + "': " + what);
    }
    void skip() {
      while (i_ < line_.size() && std::isspace(static_cast<unsigned char>(line_[i_]))) ++i_;
    }
    bool take(char c) {
      skip();
      if (i_ < line_.size() && line_[i_] == c) {
        ++i_;
        return true;
      }
      return false;
    }
    double checked(double v) const {
      if (!std::isfinite(v)) error("the result is not a finite number");
      return v;
    }
    double expression() {
      double value = term();
      while (true) {
        if (take('+')) {
          value = checked(value + term());
        } else if (take('-')) {
          value = checked(value - term());
        } else {
          return value;
        }
      }
    }
    double term() {
      double value = power();
      while (true) {
        if (take('*')) {
          value = checked(value * power());
        } else if (take('/')) {
          const std::size_t at = i_;
          const double divisor = power();
          if (divisor == 0.0) {
            i_ = at;
            error("division by zero");
          }
          value = checked(value / divisor);
        } else {
          return value;
        }
      }
    }
    double power() {
      const double base = unary();
      if (take('^')) return checked(std::pow(base, power()));
      return base;
    }
    double unary() {
      if (take('+')) return unary();
      if (take('-')) return -unary();
      return primary();
    }
    double primary() {
      skip();
      if (i_ >= line_.size()) error("the formula ends early");
      const char c = line_[i_];
      if (c == '(') {
        ++i_;
        const double value = expression();
        if (!take(')')) error("')' expected");
        return value;
      }
      if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') {
        const std::size_t start = i_;
        while (i_ < line_.size() &&
               (std::isdigit(static_cast<unsigned char>(line_[i_])) || line_[i_] == '.')) {
          ++i_;
        }
        std::string problem;
        const auto value = detail::parse_decimal(line_.substr(start, i_ - start), &problem);
        if (!value) {
          i_ = start;
          error(problem);
        }
        return *value;
      }
      if (!std::isalpha(static_cast<unsigned char>(c))) error("unexpected '" + std::string(1, c) + "'");
      const std::size_t start = i_;
      while (i_ < line_.size() && std::isalnum(static_cast<unsigned char>(line_[i_]))) ++i_;
      const std::string name = detail::to_upper(line_.substr(start, i_ - start));
      if (const auto q = q_name(name); q && q->second == name.size()) {
        Token token{std::string(line_.substr(start, i_ - start)), name, static_cast<int>(start) + 1};
        return reader_.q_value(q->first, token);
      }
      if (name == "PI") return std::numbers::pi;
      const double x = unary();
      const auto domain = [&](bool ok) {
        if (!ok) {
          i_ = start;
          error(name + " of " + detail::format_number(x) + " is not defined");
        }
      };
      if (name == "SIN") return std::sin(x / kDegPerRad);
      if (name == "COS") return std::cos(x / kDegPerRad);
      if (name == "TAN") return checked(std::tan(x / kDegPerRad));
      if (name == "ASIN") return domain(x >= -1.0 && x <= 1.0), std::asin(x) * kDegPerRad;
      if (name == "ACOS") return domain(x >= -1.0 && x <= 1.0), std::acos(x) * kDegPerRad;
      if (name == "ATAN") return std::atan(x) * kDegPerRad;
      if (name == "SQRT") return domain(x >= 0.0), std::sqrt(x);
      if (name == "SQ") return checked(x * x);
      if (name == "ABS") return std::abs(x);
      if (name == "INT") return std::trunc(x);
      if (name == "FRAC") return x - std::trunc(x);
      if (name == "NEG") return -x;
      if (name == "SGN") return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0);
      if (name == "LN") return domain(x > 0.0), std::log(x);
      if (name == "LOG") return domain(x > 0.0), std::log10(x);
      if (name == "EXP") return checked(std::exp(x));
      i_ = start;
      error("unknown function " + name);
    }
    const HeidenhainReader& reader_;
    std::string_view line_;
    std::size_t i_;
  };

  /// `Q1 = formula` (the target token starts the block) and `FN n: Q1 = ...`.
  void q_assignment(std::string_view line, const Token& target, std::size_t equals_at,
                    std::optional<int> fn) {
    const auto name = q_name(target.upper);
    if (!name || name->second != target.upper.size()) fail(target, "malformed Q parameter");
    if (split_q(name->first).second > kMaxQParameter) {
      fail(target, "beyond the Q parameters (0 .. " + std::to_string(kMaxQParameter) + ")");
    }
    std::string rhs(line.substr(equals_at + 1));
    if (const std::size_t semicolon = rhs.find(';'); semicolon != std::string::npos) rhs.resize(semicolon);
    // FN forms as formulas: DIV is '/', LEN and ANG take two operands.
    std::string formula = rhs;
    if (fn) {
      std::string upper = detail::to_upper(rhs);
      const auto replace_word = [&](const std::string& word, const std::string& by) {
        const std::size_t at = upper.find(word);
        if (at == std::string::npos) return false;
        formula.replace(at, word.size(), by);
        upper.replace(at, word.size(), by);
        return true;
      };
      switch (*fn) {
        case 0: case 1: case 2: case 3: case 5: case 6: case 7: break;
        case 4:
          if (!replace_word("DIV", "/")) fail(target, "FN 4 needs 'DIV'");
          break;
        case 8: {  // a LEN b = sqrt(a^2 + b^2)
          const std::size_t at = upper.find("LEN");
          if (at == std::string::npos) fail(target, "FN 8 needs 'LEN'");
          formula = "SQRT((" + rhs.substr(0, at) + ")^2+(" + rhs.substr(at + 3) + ")^2)";
          break;
        }
        case 13: {  // a ANG b = atan2(b, a) in degrees
          const std::size_t at = upper.find("ANG");
          if (at == std::string::npos) fail(target, "FN 13 needs 'ANG'");
          const double x = Formula(*this, rhs.substr(0, at), 0).evaluate();
          const double y = Formula(*this, rhs.substr(at + 3), 0).evaluate();
          q_[name->first] = std::atan2(y, x) * kDegPerRad;
          return;
        }
        default: break;
      }
    }
    // Columns of messages: the formula's own text where it was not rewritten.
    if (formula == rhs) {
      q_[name->first] = Formula(*this, line, equals_at + 1).evaluate();
    } else {
      q_[name->first] = Formula(*this, formula, 0).evaluate();
    }
  }

  // --- Programs, labels and calls ------------------------------------------------------------
  //
  // The program runs as the TNC runs it: block after block from a program counter, LBL n marks
  // a place, CALL LBL n jumps there. CALL LBL n REP k with the label before it and no LBL 0
  // between them is a program section repeat (the section runs k more times, its counter kept
  // by the CALL block); else the label starts a subprogram that runs to LBL 0 and returns (REP
  // k: k more runs; a subprogram calling itself nests until ReaderOptions::max_call_depth).
  // CALL PGM runs another file to its END PGM. Q parameters are shared (QL too: not local here).

  struct Program {
    std::string file;
    std::string storage;  ///< a called program's text (the main program's is the caller's)
    std::vector<std::string_view> lines;
    std::map<std::string, std::size_t> labels;  ///< label -> its line index
    std::vector<std::size_t> subprogram_ends;   ///< the lines of LBL 0
  };

  struct Frame {
    enum class Kind { main, label, program } kind = Kind::main;
    std::size_t program = 0;
    std::size_t pc = 0;
    std::size_t label_pc = 0;  ///< a subprogram's first line (LBL n)
    long repeats_left = 0;
    std::string label;
    int call_line = 0;         ///< for messages
    double mm_per_unit = 1.0;  ///< the caller's unit (CALL PGM restores it)
  };

  static void split_lines(Program& program, std::string_view text) {
    std::size_t start = 0;
    while (start <= text.size()) {
      std::size_t end = text.find('\n', start);
      if (end == std::string_view::npos) end = text.size();
      std::string_view line = text.substr(start, end - start);
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      program.lines.push_back(line);
      start = end + 1;
    }
    if (!program.lines.empty() && program.lines.back().empty()) program.lines.pop_back();
  }

  /// "LBL 5", "LBL "NAME"": the label's key (numbers without leading zeros, names upper case).
  std::string label_key(const Token& token) const {
    std::string text = token.upper;
    if (text.size() >= 2 && text.front() == '"' && text.back() == '"') text = text.substr(1, text.size() - 2);
    if (text.empty()) fail(token, "expected the label's number or name");
    if (std::all_of(text.begin(), text.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
      if (text.size() > 6) fail(token, "the label number is beyond 999999");
      return std::to_string(std::stol(text));
    }
    return text;
  }

  /// The LBL blocks of a program (before it runs: a CALL LBL may jump forward).
  void index_labels(Program& program) {
    const int saved_line = line_;
    const std::string saved_file = file_;
    file_ = program.file;
    for (std::size_t i = 0; i < program.lines.size(); ++i) {
      const std::string_view line = program.lines[i];
      // Cheap test first: most lines have no LBL.
      bool maybe = false;
      for (std::size_t k = 0; k + 2 < line.size() && !maybe; ++k) {
        maybe = std::toupper(static_cast<unsigned char>(line[k])) == 'L' &&
                std::toupper(static_cast<unsigned char>(line[k + 1])) == 'B' &&
                std::toupper(static_cast<unsigned char>(line[k + 2])) == 'L';
      }
      if (!maybe) continue;
      line_ = static_cast<int>(i) + 1;
      const std::vector<Token> tokens = tokens_of(line);
      std::size_t first = 0;
      if (!tokens.empty() && std::all_of(tokens[0].text.begin(), tokens[0].text.end(),
                                         [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
        first = 1;
      }
      if (first >= tokens.size() || tokens[first].upper != "LBL") continue;
      if (first + 1 >= tokens.size()) fail(tokens[first], "LBL needs its number or name");
      const std::string key = label_key(tokens[first + 1]);
      if (key == "0") {
        program.subprogram_ends.push_back(i);
        continue;
      }
      if (!program.labels.emplace(key, i).second) {
        fail(tokens[first + 1], "label " + key + " is defined twice (first at line " +
                                    std::to_string(program.labels.at(key) + 1) + ")");
      }
    }
    line_ = saved_line;
    file_ = saved_file;
  }

  void run() {
    while (!frames_.empty() && !ended_) {
      const Frame& frame = frames_.back();
      const Program& program = *programs_[frame.program];
      if (frame.pc >= program.lines.size()) {
        if (frame.kind == Frame::Kind::main) break;
        if (frame.kind == Frame::Kind::label) {
          fail(0, "the subprogram LBL " + frame.label + " (called at line " + std::to_string(frame.call_line) +
                      ") runs to the end of the file without LBL 0");
        }
        return_from_program();  // a called program without END PGM
        continue;
      }
      const std::size_t pc = frame.pc;
      frames_.back().pc = pc + 1;
      file_ = program.file;
      line_ = static_cast<int>(pc) + 1;
      if (jumped_ && ++executed_blocks_ > options_.max_executed_blocks) {
        fail(0, "more than " + std::to_string(options_.max_executed_blocks) +
                    " blocks run (ReaderOptions::max_executed_blocks): a repeat or call that never ends?");
      }
      block(program.lines[pc]);
    }
  }

  /// END PGM: the end of the program, or of a program called by CALL PGM.
  void end_of_program() {
    std::size_t k = frames_.size();
    while (k > 0 && frames_[k - 1].kind == Frame::Kind::label) --k;
    if (k == 0 || frames_[k - 1].kind == Frame::Kind::main) {
      ended_ = true;
      return;
    }
    frames_.resize(k);
    return_from_program();
  }

  void return_from_program() {
    mm_per_unit_ = frames_.back().mm_per_unit;
    frames_.pop_back();
    if (!frames_.empty()) file_ = programs_[frames_.back().program]->file;
  }

  void require_call_depth(const Token& token) const {
    if (frames_.size() > options_.max_call_depth) {
      fail(token, "calls nested more than " + std::to_string(options_.max_call_depth) +
                      " deep (ReaderOptions::max_call_depth): a subprogram that calls itself?");
    }
  }

  /// LBL n (a place; LBL 0 ends a subprogram), CALL LBL n [REP k], CALL PGM name.
  void label_block(const std::vector<Token>& tokens, std::size_t first) {
    const Token& head = tokens[first];
    if (head.upper == "LBL") {
      if (first + 1 >= tokens.size()) fail(head, "LBL needs its number or name");
      if (label_key(tokens[first + 1]) != "0") return;
      // LBL 0: the end of a subprogram; reached without a call it is passed.
      if (frames_.back().kind != Frame::Kind::label) return;
      Frame& frame = frames_.back();
      if (frame.repeats_left > 0) {
        --frame.repeats_left;
        frame.pc = frame.label_pc + 1;
        return;
      }
      frames_.pop_back();
      return;
    }
    // CALL
    if (first + 2 >= tokens.size()) fail(head, "expected CALL LBL <label> or CALL PGM <name>");
    const Token& what = tokens[first + 1];
    if (what.upper == "PGM") {
      call_program(tokens[first + 2]);
      return;
    }
    if (what.upper != "LBL") fail(what, "expected CALL LBL <label> or CALL PGM <name>");
    const Token& label_token = tokens[first + 2];
    const std::string key = label_key(label_token);
    if (key == "0") fail(label_token, "LBL 0 ends a subprogram: it cannot be called");
    long repeats = 0;
    const bool has_rep = first + 3 < tokens.size();
    for (std::size_t k = first + 3; k < tokens.size(); ++k) {
      const std::string& u = tokens[k].upper;
      if (u.rfind("REP", 0) != 0) fail(tokens[k], "expected REP <count> after CALL LBL");
      std::string count = u.substr(3);
      if (count.empty() && k + 1 < tokens.size()) count = tokens[++k].upper;
      if (const std::size_t slash = count.find('/'); slash != std::string::npos) count = count.substr(0, slash);
      if (count.empty() || count.size() > 5 ||
          !std::all_of(count.begin(), count.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
        fail(tokens[k], "REP needs a whole number of repeats (0 .. 65534)");
      }
      repeats = std::stol(count);
      if (repeats > 65534) fail(tokens[k], "REP " + count + " is beyond 65534 repeats");
    }
    Frame& caller = frames_.back();
    const Program& program = *programs_[caller.program];
    const auto it = program.labels.find(key);
    if (it == program.labels.end()) fail(label_token, "label " + key + " is not defined in " + program.file);
    const std::size_t label_pc = it->second;
    const std::size_t call_pc = caller.pc - 1;
    jumped_ = true;
    const bool section = has_rep && label_pc < call_pc &&
                         std::none_of(program.subprogram_ends.begin(), program.subprogram_ends.end(),
                                      [&](std::size_t end) { return end > label_pc && end < call_pc; });
    if (section) {
      // The repeat counter belongs to the CALL block: set when it is first reached.
      const auto counter_key = std::make_pair(caller.program, call_pc);
      auto counter = section_repeats_.find(counter_key);
      if (counter == section_repeats_.end()) counter = section_repeats_.emplace(counter_key, repeats).first;
      if (counter->second > 0) {
        --counter->second;
        caller.pc = label_pc + 1;
      } else {
        section_repeats_.erase(counter);
      }
      return;
    }
    Frame frame;
    frame.kind = Frame::Kind::label;
    frame.program = caller.program;
    frame.pc = label_pc + 1;
    frame.label_pc = label_pc;
    frame.repeats_left = repeats;
    frame.label = key;
    frame.call_line = line_;
    frame.mm_per_unit = mm_per_unit_;
    frames_.push_back(frame);
    require_call_depth(label_token);
  }

  /// CALL PGM name: the file `name` (with .h where it has no extension) in
  /// ReaderOptions::subprogram_folder (read_heidenhain: the program's folder).
  void call_program(const Token& name_token) {
    std::string name = name_token.text;
    if (name.size() >= 2 && name.front() == '"' && name.back() == '"') name = name.substr(1, name.size() - 2);
    if (const std::size_t cut = name.find_last_of("\\/:"); cut != std::string::npos) name = name.substr(cut + 1);
    if (name.empty()) fail(name_token, "CALL PGM needs the program's name");
    if (name.find('.') == std::string::npos) name += ".h";
    if (options_.subprogram_folder.empty()) {
      fail(name_token, "CALL PGM " + name + ": no folder to look for it in (ReaderOptions::subprogram_folder)");
    }
    std::optional<std::string> path;
    std::string lower = name, upper = detail::to_upper(name);
    std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    for (const std::string& candidate : {name, lower, upper}) {
      const std::string p = (std::filesystem::path(options_.subprogram_folder) / candidate).string();
      std::error_code error;
      if (std::filesystem::is_regular_file(p, error)) {
        path = p;
        break;
      }
    }
    if (!path) fail(name_token, "CALL PGM: " + name + " is not in " + options_.subprogram_folder);
    std::size_t index = 0;
    if (const auto it = program_index_.find(*path); it != program_index_.end()) {
      index = it->second;
    } else {
      auto program = std::make_unique<Program>();
      program->file = *path;
      program->storage = detail::read_text_file(*path);
      const std::string_view text = detail::without_byte_order_mark(program->storage);
      detail::require_utf8_text(text, *path);
      split_lines(*program, text);
      index_labels(*program);
      programs_.push_back(std::move(program));
      index = programs_.size() - 1;
      program_index_.emplace(*path, index);
    }
    jumped_ = true;
    Frame frame;
    frame.kind = Frame::Kind::program;
    frame.program = index;
    frame.call_line = line_;
    frame.mm_per_unit = mm_per_unit_;
    frames_.push_back(frame);
    require_call_depth(name_token);
  }

  // --- Blocks ---------------------------------------------------------------------------------

  void block(std::string_view line) {
    line_text_ = detail::trim(line);
    std::vector<Token> tokens = tokens_of(line);
    if (tokens.empty()) return;
    std::size_t first = 0;
    block_number_ = -1;
    if (std::all_of(tokens[0].text.begin(), tokens[0].text.end(),
                    [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
      require_within(tokens[0], std::stod(tokens[0].text.substr(0, 12)), 0.0,
                     detail::kMaxIgnoredWordValue, "block number", "");
      block_number_ = std::stol(tokens[0].text);
      first = 1;
    }
    if (first >= tokens.size()) return;
    const Token& head = tokens[first];
    if (head.text[0] == '*') return;  // structure block ("* - ROUGHING")
    if (head.text[0] == '/') {
      warn("block skipped: block delete '/' is taken as switched on");
      return;
    }
    const std::string& k = head.upper;
    if (defining_pattern_) {
      if (k == "~") return;  // a continuation mark alone on its line
      if (pattern_element_name(k)) {
        pattern_elements(line, static_cast<std::size_t>(head.column) - 1);
        return;
      }
      defining_pattern_ = false;
    }
    if (defining_cycle_ && !q_name(k)) close_cycle_definition();
    const auto next_is = [&](std::size_t at, const char* word) {
      return at < tokens.size() && tokens[at].upper == word;
    };

    if (k == "BEGIN" || k == "END") {
      if (!next_is(first + 1, "PGM")) fail(head, "expected " + k + " PGM");
      for (std::size_t t = first + 2; t < tokens.size(); ++t) {
        if (tokens[t].upper == "MM") mm_per_unit_ = 1.0;
        if (tokens[t].upper == "INCH") mm_per_unit_ = detail::kMillimetresPerInch;
      }
      if (k == "END") end_of_program();
      return;
    }
    if (k == "BLK") {
      if (!next_is(first + 1, "FORM")) fail(head, "expected BLK FORM");
      blank_form(tokens, first + 2, head);
      return;
    }
    if (k == "TOOL") {
      if (next_is(first + 1, "DEF")) return;
      if (!next_is(first + 1, "CALL")) fail(head, "expected TOOL CALL or TOOL DEF");
      tool_call(tokens, first + 2);
      return;
    }
    if (k == "CYCL") {
      cycle(tokens, first);
      return;
    }
    if (k == "PATTERN") {
      if (!next_is(first + 1, "DEF")) fail(head, "expected PATTERN DEF");
      pattern_.clear();
      defining_pattern_ = true;
      pattern_elements(line, static_cast<std::size_t>(tokens[first + 1].column) + 2);
      return;
    }
    if (k == "PLANE") {
      plane(tokens, first + 1, head);
      return;
    }
    if (k == "TRANS") {
      if (!next_is(first + 1, "DATUM")) fail(head, "only TRANS DATUM is supported");
      if (next_is(first + 2, "RESET")) {
        set_datum_shift({}, head, true);
        return;
      }
      if (!next_is(first + 2, "AXIS")) fail(head, "expected TRANS DATUM AXIS or TRANS DATUM RESET");
      set_datum_shift(words_of(tokens, first + 3), head, false);
      return;
    }
    if (k == "FUNCTION") {
      function(tokens, first + 1, head);
      return;
    }
    if (k == "STOP") return;
    if (k == "FN") {
      fn_block(line, tokens, first);
      return;
    }
    if (const auto q = q_name(k); q && (q->second == k.size() || k[q->second] == '=')) {
      const std::size_t equals = line.find('=', static_cast<std::size_t>(head.column - 1));
      if (equals == std::string_view::npos) fail(head, "expected 'Q.. = formula'");
      Token target = head;
      target.upper = q->first;
      target.text = head.text.substr(0, q->second);
      if (defining_cycle_) {  // a parameter of the cycle just defined
        Token value_token = head;
        value_token.column = static_cast<int>(equals) + 2;
        value_token.text = std::string(line.substr(equals + 1));
        if (const std::size_t semicolon = value_token.text.find(';'); semicolon != std::string::npos) value_token.text.resize(semicolon);
        value_token.text = detail::trim(value_token.text);
        value_token.upper = detail::to_upper(value_token.text);
        cycle_parameter(q->first, value_token.text, line, equals + 1, value_token, target);
        return;
      }
      q_assignment(line, target, equals, std::nullopt);
      return;
    }
    if (k == "L" || k == "LN" || k == "C" || k == "CR" || k == "CT" || k == "CC" || k == "RND" ||
        k == "CHF") {
      motion_block(k, head, tokens, first + 1);
      return;
    }
    if (k[0] == 'M' && k.size() > 1 && std::isdigit(static_cast<unsigned char>(k[1]))) {
      motion_block("M", head, tokens, first);  // M functions alone
      return;
    }
    if (k == "LP" || k == "CP") fail(head, "polar coordinates are not supported: output X Y Z");
    if (k == "APPR" || k == "DEP") {
      approach_block(k == "APPR", head, tokens, first + 1);
      return;
    }
    if (k.rfind("FL", 0) == 0 || k.rfind("FC", 0) == 0 || k.rfind("FPOL", 0) == 0) {
      fail(head, "FK free contour programming is not supported");
    }
    if (k == "LBL" || k == "CALL") {
      label_block(tokens, first);
      return;
    }
    fail(head, "unsupported block (it may change the geometry)");
  }

  void fn_block(std::string_view line, const std::vector<Token>& tokens, std::size_t first) {
    const Token& head = tokens[first];
    if (first + 1 >= tokens.size()) fail(head, "FN needs its number");
    std::string number = tokens[first + 1].upper;
    std::size_t target_index = first + 2;
    if (!number.empty() && number.back() == ':') number.pop_back();
    if (number.empty() || !std::all_of(number.begin(), number.end(), [](char c) {
          return std::isdigit(static_cast<unsigned char>(c));
        }) || number.size() > 3) {
      fail(tokens[first + 1], "expected the FN number (FN 0: ...)");
    }
    const int fn = std::stoi(number);
    if (fn >= 9 && fn <= 12) fail(head, "conditional jumps (FN 9 .. 12) are not supported");
    if (!((fn >= 0 && fn <= 8) || fn == 13)) {
      fail(head, "FN " + number + " is not supported (FN 0 .. 8 and 13 assign Q parameters)");
    }
    if (target_index < tokens.size() && tokens[target_index].upper == ":") ++target_index;
    if (target_index >= tokens.size()) fail(head, "FN without its Q parameter");
    const Token& target_token = tokens[target_index];
    const auto q = q_name(target_token.upper);
    if (!q) fail(target_token, "expected a Q parameter");
    const std::size_t equals = line.find('=', static_cast<std::size_t>(target_token.column - 1));
    if (equals == std::string_view::npos) fail(target_token, "expected 'Q.. = ...'");
    Token target = target_token;
    target.upper = q->first;
    target.text = target_token.text.substr(0, q->second);
    std::string rhs_upper = detail::to_upper(line.substr(equals + 1));
    // FN 5 .. 7: a function of one operand, written "SQRT Q2", "SIN+30".
    if (fn == 5 || fn == 6 || fn == 7) {
      const char* names[] = {"SQRT", "SIN", "COS"};
      const std::string function = names[fn - 5];
      const std::size_t at = rhs_upper.find(function);
      if (at == std::string::npos) fail(target, "FN " + number + " needs '" + function + "'");
      const std::string operand(line.substr(equals + 1 + at + function.size()));
      const std::string rewritten = function + "(" + operand.substr(0, operand.find(';')) + ")";
      q_[q->first] = Formula(*this, rewritten, 0).evaluate();
      return;
    }
    q_assignment(line, target, equals, fn);
  }

  // --- BLK FORM, TOOL CALL, FUNCTION ----------------------------------------------------------

  void blank_form(const std::vector<Token>& tokens, std::size_t at, const Token& head) {
    if (at >= tokens.size()) fail(head, "BLK FORM needs 0.1 or 0.2 and its point");
    const std::string& kind = tokens[at].upper;
    if (kind == "CYLINDER" || kind == "ROTATION" || kind == "FILE") {
      warn("BLK FORM " + tokens[at].text + " is not read: no stock from the program");
      return;
    }
    if (kind != "0.1" && kind != "0.2") fail(tokens[at], "expected BLK FORM 0.1 or 0.2");
    std::size_t first_word = at + 1;
    if (kind == "0.1" && first_word < tokens.size() &&
        (tokens[first_word].upper == "X" || tokens[first_word].upper == "Y" ||
         tokens[first_word].upper == "Z")) {
      if (tokens[first_word].upper != "Z") fail(tokens[first_word], "tool axis X / Y is not supported");
      ++first_word;
    }
    Vec3 p = Vec3::Zero();
    std::array<bool, 3> given{};
    for (const Word& word : words_of(tokens, first_word)) {
      const int axis = linear_axis(word.address);
      if (axis < 0 || !word.value) fail(word, "expected X Y Z of the blank's corner");
      if (word.incremental && kind == "0.1") fail(word, "BLK FORM 0.1 is absolute");
      const double v = *word.value * mm_per_unit_;
      require_within(*word.token, v, -detail::kMaxCoordinateMm, detail::kMaxCoordinateMm, "length", "mm");
      if (word.incremental) {
        if (!blank_min_mm_) fail(word, "incremental BLK FORM 0.2 without 0.1 before it");
        p[axis] = (*blank_min_mm_)[axis] + v;
      } else {
        p[axis] = v;
      }
      given[static_cast<std::size_t>(axis)] = true;
    }
    if (!(given[0] && given[1] && given[2])) fail(head, "BLK FORM " + kind + " needs X, Y and Z");
    if (kind == "0.1") {
      blank_min_mm_ = p;
      return;
    }
    if (!blank_min_mm_) fail(head, "BLK FORM 0.2 without BLK FORM 0.1 before it");
    for (int k = 0; k < 3; ++k) {
      if (!(p[k] > (*blank_min_mm_)[k])) {
        fail(head, std::string("BLK FORM: the MAX point's ") + "XYZ"[k] +
                       " is not above the MIN point's (" + detail::format_number(p[k]) + " <= " +
                       detail::format_number((*blank_min_mm_)[k]) + " mm)");
      }
    }
    BoxW box;
    box.min_W_m = (preset_W_mm_ + *blank_min_mm_) * kMetresPerMillimetre;
    box.max_W_m = (preset_W_mm_ + p) * kMetresPerMillimetre;
    path_.stock_box = box;
  }

  void tool_call(const std::vector<Token>& tokens, std::size_t at) {
    require_no_pending_corner(tokens[at - 1]);
    require_no_compensation(tokens[at - 2], "a TOOL CALL");
    std::optional<int> tool;
    std::size_t k = at;
    if (k < tokens.size() && tokens[k].text[0] == '"') {
      warn("tool " + tokens[k].text + " called by name: its number is not known (the part's tool)");
      tool = -1;
      ++k;
    } else if (k < tokens.size() && std::isdigit(static_cast<unsigned char>(tokens[k].text[0]))) {
      std::string problem;
      const auto number = detail::parse_decimal(tokens[k].text, &problem);
      if (!number) fail(tokens[k], problem);
      require_within(tokens[k], *number, 0.0, detail::kMaxIgnoredWordValue, "tool number", "");
      if (*number != std::round(*number)) fail(tokens[k], "the tool number must be whole");
      tool = static_cast<int>(std::lround(*number));
      ++k;
    }
    if (k < tokens.size() && (tokens[k].upper == "X" || tokens[k].upper == "Y")) {
      fail(tokens[k], "tool axis " + tokens[k].text + " is not supported (tool axis Z)");
    }
    if (k < tokens.size() && tokens[k].upper == "Z") ++k;
    std::optional<double> dl, dr;
    for (const Word& word : words_of(tokens, k)) {
      const std::string& a = word.address;
      if (!word.value) fail(word, "expected a value");
      if (a == "S") {
        require_within(*word.token, *word.value, 0.0, detail::kMaxSpindleRevPerMin, "spindle speed", "rev/min");
      } else if (a == "F") {
        auto_feed_m_per_s_ = feed_from(word);
      } else if (a == "DL" || a == "DR" || a == "DR2") {
        const double v = *word.value * mm_per_unit_;
        require_within(*word.token, v, -detail::kMaxToleranceMm, detail::kMaxToleranceMm, "allowance", "mm");
        if (a == "DL") dl = v;
        if (a == "DR") dr = v;
      } else {
        fail(word, "unsupported word in TOOL CALL");
      }
    }
    if (tool) {
      // A new tool: its allowances are those of this call (0 where not given).
      tool_number_ = *tool;
      dl_mm_ = dl.value_or(0.0);
      dr_mm_ = dr.value_or(0.0);
      tool_length_mm_ = 0.0;
      if (*tool >= 0) {
        if (const auto it = options_.tool_length_mm.find(*tool); it != options_.tool_length_mm.end()) {
          tool_length_mm_ = it->second;
        } else if (options_.default_tool_length_mm) {
          tool_length_mm_ = *options_.default_tool_length_mm;
        }
        // Else no tool data (a reading without a machine): length 0, the gauge point is the tip;
        // it cancels out of the pose (machine Z = q + L, tip = gauge - L).
      } else if (options_.default_tool_length_mm) {
        tool_length_mm_ = *options_.default_tool_length_mm;
      }
      // The axes do not move at a tool change in the program's terms: the next motion starts
      // from the position known before (the machine compensates the new length there).
    } else {
      if (dl) dl_mm_ = *dl;
      if (dr) dr_mm_ = *dr;
    }
  }

  void function(const std::vector<Token>& tokens, std::size_t at, const Token& head) {
    const auto is = [&](std::size_t i, const char* w) { return i < tokens.size() && tokens[i].upper == w; };
    if (is(at, "MODE")) return;  // FUNCTION MODE MILL
    if (is(at, "RESET") && is(at + 1, "TCPM")) {
      tcpm_ = false;
      return;
    }
    if (is(at, "TCPM")) {
      require_no_compensation(head, "FUNCTION TCPM");
      for (std::size_t i = at + 1; i < tokens.size(); ++i) {
        if (tokens[i].upper == "SPAT") {
          fail(tokens[i], "AXIS SPAT (rotary words as spatial angles) is not supported: AXIS POS");
        }
      }
      tcpm_ = true;
      return;
    }
    fail(head, "unsupported FUNCTION");
  }

  // --- Cycles: 7 datum shift, 32 tolerance, 9 dwell -------------------------------------------

  void cycle(const std::vector<Token>& tokens, std::size_t first) {
    const Token& head = tokens[first];
    const auto is = [&](std::size_t i, const char* w) { return i < tokens.size() && tokens[i].upper == w; };
    if (is(first + 1, "CALL")) {
      cycle_call(tokens, first + 2, head);
      return;
    }
    if (!is(first + 1, "DEF") || first + 2 >= tokens.size()) fail(head, "expected CYCL DEF <number>");
    const Token& number_token = tokens[first + 2];
    const std::string& number = number_token.upper;
    const std::size_t dot = number.find('.');
    const std::string cycle_number = number.substr(0, dot);
    const std::string sub = dot == std::string::npos ? "" : number.substr(dot + 1);
    if (cycle_number == "7") {
      if (sub == "0" || sub.empty()) {
        in_datum_cycle_ = true;
        return;
      }
      if (!in_datum_cycle_) fail(number_token, "CYCL DEF 7." + sub + " without CYCL DEF 7.0");
      set_datum_shift(words_of(tokens, first + 3), number_token, false);
      return;
    }
    in_datum_cycle_ = false;
    if (cycle_number == "32") {
      if (sub == "0" || sub.empty()) {
        tolerance_cycle_ = true;
        return;
      }
      if (!tolerance_cycle_) fail(number_token, "CYCL DEF 32." + sub + " without CYCL DEF 32.0");
      if (sub == "1") {
        corner_tolerance_m_ = PathPoint::kNotProgrammed;  // 32.1 without T: the machine's
        for (const Word& word : words_of(tokens, first + 3)) {
          if (word.address != "T" || !word.value) fail(word, "expected T<tolerance>");
          const double t_mm = *word.value * mm_per_unit_;
          require_within(*word.token, t_mm, 0.0, detail::kMaxToleranceMm, "tolerance", "mm");
          corner_tolerance_m_ = t_mm * kMetresPerMillimetre;
        }
      }
      return;  // 32.2 HSC-MODE / TA: accepted, not emulated
    }
    if (cycle_number == "9") {
      // CYCL DEF 9.0 DWELL TIME / CYCL DEF 9.1 DWELL <seconds>: the tool waits where it is.
      if (sub == "0" || sub.empty()) return;
      if (sub != "1") fail(number_token, "cycle 9 has sub-blocks 9.0 and 9.1 only");
      std::optional<double> seconds;
      for (std::size_t k = first + 3; k < tokens.size(); ++k) {
        if (tokens[k].upper == "DWELL" || tokens[k].upper == "V.ZEIT") continue;
        if (tokens[k].upper.rfind(';', 0) == 0) break;
        seconds = value_of(tokens[k].text, tokens[k]);
        if (!seconds) fail(tokens[k], "expected the dwell time in seconds");
        require_within(tokens[k], *seconds, 0.0, detail::kMaxIgnoredWordValue, "dwell", "s");
        break;
      }
      if (!seconds) fail(number_token, "CYCL DEF 9.1 needs the dwell time (DWELL <seconds>)");
      dwell_here(*seconds);
      return;
    }
    if (cycle_number == "200" || cycle_number == "201" || cycle_number == "203" || cycle_number == "205") {
      if (!sub.empty()) fail(number_token, "cycle " + cycle_number + " has no sub-blocks");
      MachiningCycle definition;
      definition.number = std::stoi(cycle_number);
      definition.line = line_;
      definition.column = number_token.column;
      definition.file = file_;
      definition.text = line_text_;
      cycle_definition_ = definition;
      defining_cycle_ = true;
      // Parameters on the CYCL DEF line itself ("CYCL DEF 200 DRILLING Q200=2 Q201=-10 ...").
      for (std::size_t k = first + 3; k < tokens.size(); ++k) {
        const Token& t = tokens[k];
        const std::size_t equals = t.upper.find('=');
        const auto q = q_name(t.upper);
        if (!q || equals != q->second) continue;  // the cycle's name, "~"
        Token value_token = t;
        value_token.text = t.text.substr(equals + 1);
        value_token.upper = t.upper.substr(equals + 1);
        value_token.column = t.column + static_cast<int>(equals) + 1;
        // The token where it stands in the line, for the formula's columns.
        const std::string placed = std::string(static_cast<std::size_t>(t.column - 1), ' ') + t.text;
        cycle_parameter(q->first, value_token.text, placed, static_cast<std::size_t>(t.column) + equals, value_token, t);
      }
      return;
    }
    if (cycle_number == "19") {
      fail(number_token, "cycle 19 (working plane by axis angles) is not supported: use PLANE SPATIAL");
    }
    if (cycle_number == "204" || cycle_number == "202" || cycle_number == "207" ||
        cycle_number == "208" || cycle_number == "220" || cycle_number == "221") {
      fail(number_token, "cycle " + cycle_number + " is not read (read: 200 DRILLING, 201 REAMING, 203 "
                         "UNIVERSAL DRILLING, 205 UNIVERSAL PECKING; output the others as L blocks)");
    }
    fail(number_token, "cycle " + cycle_number + " is not supported (read: 7, 9, 32, 200, 201, 203, 205; output it as L blocks)");
  }

  // --- Machining cycles 200, 201, 203 ---------------------------------------------------------
  //
  // CYCL DEF 2xx defines the cycle; its parameters follow as "Q200=+2 ;SET-UP CLEARANCE" lines
  // (the TNC 640 writes "~" at the ends: inside the comment) and are also set as Q parameters,
  // as on the control. CYCL CALL, CYCL CALL POS, M99 (this block) and M89 (every following
  // positioning block, until M99) run it at the tool's X Y. Moves in the program's coordinates
  // with the tool axis Z (in a tilted plane: its Z), as the TNC 640 manual describes them:
  //  200 DRILLING: FMAX to the set-up clearance Q200 above the surface Q203; strokes of Q202 at
  //      Q206, after each FMAX out to the set-up clearance and FMAX back to Q200 above the depth
  //      reached; at the depth Q201, FMAX out to the set-up clearance;
  //  201 REAMING: Q206 to the depth, out at Q208 (0: at Q206);
  //  203 UNIVERSAL DRILLING: strokes of Q202, each Q212 shorter than the last but not shorter
  //      than Q205; after each Q213 chip breaks (a retract of Q256 at Q208) one retract at Q208 to
  //      the set-up clearance and FMAX back to Q200 above the depth reached; out at Q208;
  //  all: then FMAX to the 2nd set-up clearance Q204 above the surface where it is higher.
  // Dwells: Q211 (200, 201, 203, 205) at the depth, held on the point that reaches it; Q210
  // (200, 203) at the set-up clearance after each full retract out of the hole (chip removal),
  // before the tool goes back in.

  struct MachiningCycle {
    int number = 0;
    std::map<int, double> q;  ///< parameter number -> value (feeds in mm/min as written, lengths in program units)
    std::map<int, bool> rapid_feed;  ///< a feed given as FMAX
    int line = 0, column = 0;
    std::string file, text;
    bool checked = false;
  };

  /// One "Qnnn=value" of the cycle being defined (value: a number, a formula, FAUTO, FMAX).
  /// `value` is the text after '='; the formula is read from `source` at `value_start` (its line,
  /// for the columns of messages).
  void cycle_parameter(const std::string& name, std::string value, std::string_view source, std::size_t value_start,
                       const Token& value_token, const Token& name_token) {
    if (const std::size_t semicolon = value.find(';'); semicolon != std::string::npos) value.resize(semicolon);
    value = detail::trim(value);
    const auto [prefix, number] = split_q(name);
    if (prefix != "Q") fail(name_token, "a cycle parameter is a Q parameter (not QL / QR)");
    const std::string upper = detail::to_upper(value);
    double v = 0.0;
    if (upper == "FAUTO") {
      if (!auto_feed_m_per_s_) fail(value_token, "FAUTO without a feed in TOOL CALL");
      v = *auto_feed_m_per_s_ / kMetresPerMillimetre * kSecondsPerMinute / (mm_per_unit_ == 1.0 ? 1.0 : mm_per_unit_ / 10.0);
    } else if (upper == "FMAX") {
      cycle_definition_->rapid_feed[static_cast<int>(number)] = true;
      v = 0.0;
    } else {
      if (value.empty()) fail(value_token, name + " has no value");
      v = Formula(*this, source, value_start).evaluate();
    }
    q_[name] = v;
    cycle_definition_->q[static_cast<int>(number)] = v;
  }

  /// The end of a cycle definition (the first block that is not one of its parameters): its
  /// parameters checked, errors at the CYCL DEF block.
  void close_cycle_definition() {
    if (!defining_cycle_) return;
    defining_cycle_ = false;
    MachiningCycle& c = *cycle_definition_;
    const int saved_line = line_;
    const std::string saved_file = file_;
    line_ = c.line;
    file_ = c.file;
    const auto where = [&](const std::string& message) { fail(c.column, "cycle " + std::to_string(c.number) + ": " + message); };
    std::vector<int> required = {200, 201, 206, 203, 204};
    if (c.number == 200) required.push_back(202);
    if (c.number == 201) required.push_back(208);
    if (c.number == 203) {
      for (int n : {202, 212, 213, 205, 208}) required.push_back(n);
      if (c.q.count(213) && c.q.at(213) > 0.0) required.push_back(256);
    }
    if (c.number == 205) {
      for (int n : {202, 212, 205, 258, 259, 257, 208}) required.push_back(n);
      if (c.q.count(257) && c.q.at(257) > 0.0) required.push_back(256);
      if (c.q.count(379) && c.q.at(379) > 0.0) required.push_back(253);
    }
    for (int n : required) {
      if (!c.q.count(n)) where("Q" + std::to_string(n) + " is missing (" + cycle_parameter_name(n) + ")");
    }
    const auto length = [&](int n) { return c.q.at(n) * mm_per_unit_; };
    for (int n : {200, 201, 202, 203, 204, 205, 212, 256, 257, 258, 259, 379}) {
      if (c.q.count(n) && !(std::abs(length(n)) <= detail::kMaxCoordinateMm)) {
        where("Q" + std::to_string(n) + " = " + detail::format_number(c.q.at(n)) + " is outside +-1e6 mm");
      }
    }
    if (!(length(201) < 0.0)) {
      where("Q201 (depth) = " + detail::format_number(c.q.at(201)) +
            ": only a negative depth (drilling towards -Z) is read");
    }
    if (length(200) < 0.0) where("Q200 (set-up clearance) must not be negative");
    if (c.q.count(202) && !(length(202) > 0.0)) where("Q202 (plunging depth) must be positive");
    if (c.rapid_feed.count(206)) where("Q206 (feed rate for plunging) FMAX: give a feed");
    for (int n : {206, 208, 253}) {
      if (!c.q.count(n) || c.rapid_feed.count(n)) continue;
      if (n == 253 && !(c.q.count(379) && c.q.at(379) > 0.0)) continue;  // not used
      const double v = c.q.at(n);
      if (n == 208 && v == 0.0) continue;  // retract at Q206
      const double mm_per_min = v * (mm_per_unit_ == 1.0 ? 1.0 : mm_per_unit_ / 10.0);
      if (!(mm_per_min >= detail::kMinFeedMmPerMin && mm_per_min <= detail::kMaxFeedMmPerMin)) {
        where("Q" + std::to_string(n) + " (" + cycle_parameter_name(n) + ") " + detail::format_number(mm_per_min) +
              " mm/min is outside [" + detail::format_number(detail::kMinFeedMmPerMin) + ", " +
              detail::format_number(detail::kMaxFeedMmPerMin) + "] mm/min");
      }
    }
    if (c.q.count(213) && !(c.q.at(213) >= 0.0 && c.q.at(213) <= 99999.0 && c.q.at(213) == std::trunc(c.q.at(213)))) {
      where("Q213 (number of chip breaks) must be a whole number 0 .. 99999");
    }
    if (c.q.count(256) && !(length(256) > 0.0)) where("Q256 (retraction for chip breaking) must be positive");
    if (c.number == 205) {
      if (length(205) < 0.0) where("Q205 (minimum plunging depth) must not be negative");
      if (length(212) < 0.0) where("Q212 (decrement) must not be negative");
      if (length(257) < 0.0) where("Q257 (depth for chip breaking) must not be negative");
      for (int n : {258, 259}) {
        if (length(n) < 0.0) where("Q" + std::to_string(n) + " (" + cycle_parameter_name(n) + ") must not be negative");
      }
      if (c.q.count(379) && length(379) < 0.0) where("Q379 (deepened starting point) must not be negative");
      if (c.q.count(379) && !(length(379) < -length(201))) {
        where("Q379 (deepened starting point) = " + detail::format_number(c.q.at(379)) + " is not above the depth Q201");
      }
    }
    if (c.q.count(395) && c.q.at(395) != 0.0) {
      where("Q395 = 1 (depth to the full diameter) needs the tool's point angle: not read (Q395 = 0, depth to the tip)");
    }
    c.checked = true;
    line_ = saved_line;
    file_ = saved_file;
  }

  static std::string cycle_parameter_name(int n) {
    switch (n) {
      case 200: return "set-up clearance";
      case 201: return "depth";
      case 202: return "plunging depth";
      case 203: return "surface coordinate";
      case 204: return "2nd set-up clearance";
      case 205: return "minimum plunging depth";
      case 206: return "feed rate for plunging";
      case 208: return "retraction feed rate";
      case 212: return "decrement";
      case 213: return "number of chip breaks before retracting";
      case 256: return "retraction for chip breaking";
      case 253: return "feed rate for pre-positioning";
      case 257: return "depth for chip breaking";
      case 258: return "upper advanced stop distance";
      case 259: return "lower advanced stop distance";
      case 379: return "deepened starting point";
      default: return "parameter";
    }
  }

  double cycle_feed_m_per_s(const MachiningCycle& c, int n) const {
    return c.q.at(n) * (mm_per_unit_ == 1.0 ? 1.0 : mm_per_unit_ / 10.0) * kMetresPerMillimetre / kSecondsPerMinute;
  }

  /// CYCL CALL [POS X Y Z [FMAX | F]] [M..]
  void cycle_call(const std::vector<Token>& tokens, std::size_t at, const Token& head) {
    std::optional<Vec3> position;
    bool rapid = true;
    std::optional<double> feed;
    if (at < tokens.size() && tokens[at].upper == "PAT") {
      cycle_call_pattern(tokens, at + 1, head, tokens[at]);
      return;
    }
    if (at < tokens.size() && tokens[at].upper == "POS") {
      std::array<const Word*, 3> xyz{};
      const std::vector<Word> words = words_of(tokens, at + 1);
      for (const Word& word : words) {
        if (const int k = linear_axis(word.address); k >= 0) {
          if (!word.value) fail(word, "expected a value");
          if (xyz[static_cast<std::size_t>(k)]) fail(word, "the address appears twice in one block");
          xyz[static_cast<std::size_t>(k)] = &word;
        } else if (word.address == "FMAX") {
          rapid = true;
        } else if (word.address == "F") {
          feed = feed_from(word);
          rapid = false;
        } else if (word.address == "M" || word.address == "R") {
          // R0 (no compensation, as the TNC moves there), M functions: nothing.
        } else {
          fail(word, "unsupported word in CYCL CALL POS");
        }
      }
      if (!xyz[0] || !xyz[1] || !xyz[2]) fail(head, "CYCL CALL POS needs X, Y and Z");
      if (!pos_[0] || !pos_[1] || !pos_[2]) fail(head, "CYCL CALL POS before the tool's position is known: position it first");
      Vec3 p;
      for (int k = 0; k < 3; ++k) {
        const Word* w = xyz[static_cast<std::size_t>(k)];
        const double v = *w->value * mm_per_unit_;
        require_within(*w->token, v, -detail::kMaxCoordinateMm, detail::kMaxCoordinateMm, "position", "mm");
        p[k] = w->incremental ? *pos_[static_cast<std::size_t>(k)] + v : v;
      }
      position = p;
    } else {
      for (std::size_t k = at; k < tokens.size(); ++k) {
        if (tokens[k].upper.rfind("M", 0) != 0 && tokens[k].upper != "~") fail(tokens[k], "unsupported word in CYCL CALL");
      }
    }
    run_cycle(head, position, rapid, feed);
  }

  /// Runs the cycle defined last at the tool's X Y (or CYCL CALL POS's X Y, its Z shifting the
  /// surface: the TNC's positioning logic, in the plane first where the tool is above the
  /// surface, else up to the 2nd set-up clearance first).
  void run_cycle(const Token& head, std::optional<Vec3> call_position, bool position_rapid,
                 std::optional<double> position_feed, std::optional<double> travel_height_mm = std::nullopt) {
    if (!cycle_definition_) fail(head, "cycle call without a machining cycle defined (CYCL DEF 200, 201, 203, 205)");
    close_cycle_definition();
    require_no_pending_corner(head);
    require_no_compensation(head, "a cycle call");
    if (pending_approach_) fail(head, "a cycle call right after APPR");
    if (!pos_[0] || !pos_[1] || !pos_[2] || !started_) {
      fail(head, "cycle call before the tool's position is known: position it first (L X.. Y.. Z..)");
    }
    const MachiningCycle& c = *cycle_definition_;
    const double unit = mm_per_unit_;
    const double shift_mm = call_position ? call_position->z() : 0.0;
    const double surface = c.q.at(203) * unit + shift_mm;
    const double clearance = surface + c.q.at(200) * unit;
    const double second = surface + std::max(c.q.at(204), c.q.at(200)) * unit;
    const double bottom = surface + c.q.at(201) * unit;
    const double cutting = cycle_feed_m_per_s(c, 206);
    const double retract = c.q.count(208) && c.q.at(208) != 0.0 && !c.rapid_feed.count(208) ? cycle_feed_m_per_s(c, 208) : cutting;
    const bool retract_rapid = c.rapid_feed.count(208) > 0;

    struct Step {
      bool rapid;
      Vec3 p_mm;
      double feed_m_per_s;
      double dwell_s = 0.0;
    };
    std::vector<Step> steps;
    Vec3 p(*pos_[0], *pos_[1], *pos_[2]);
    const auto add = [&](bool rapid, const Vec3& to, double feed_m_per_s) {
      if ((to - p).norm() <= kTinyMm) return;
      steps.push_back({rapid, to, feed_m_per_s, 0.0});
      p = to;
    };
    const auto at_level = [&](double z) { return Vec3(p.x(), p.y(), z); };
    if (call_position && travel_height_mm) {
      // CYCL CALL PAT: between the points at the higher of the tool's Z at the call and the
      // 2nd set-up clearance.
      const double height = std::max(*travel_height_mm, second);
      if (p.z() < height) add(true, at_level(height), 0.0);
    } else if (call_position) {
      if (p.z() < surface) add(true, at_level(second), 0.0);  // below the surface: up first
    }
    if (call_position) {
      add(position_rapid, Vec3(call_position->x(), call_position->y(), p.z()), position_feed.value_or(cutting));
    }
    add(true, at_level(clearance), 0.0);
    // 205: a deepened starting point Q379 below the surface, reached at Q253 (FMAX: rapid) to Q200
    // above it; the strokes count from there.
    double start_level = surface;
    if (c.number == 205 && c.q.count(379) && c.q.at(379) > 0.0) {
      start_level = surface - c.q.at(379) * unit;
      const bool pre_rapid = c.rapid_feed.count(253) > 0;
      add(pre_rapid, at_level(start_level + c.q.at(200) * unit), pre_rapid ? 0.0 : cycle_feed_m_per_s(c, 253));
    }
    detail::PeckDrilling peck;
    peck.reference_mm = start_level;
    peck.bottom_mm = bottom;
    peck.retract_to_mm = clearance;
    peck.reapproach_clearance_mm = c.q.at(200) * unit;
    peck.first_stroke_mm = c.number == 201 ? surface - bottom : c.q.at(202) * unit;
    if (c.number == 203) {
      peck.stroke_decrement_mm = c.q.at(212) * unit;
      peck.minimum_stroke_mm = c.q.at(205) * unit;
      peck.chip_breaks_per_retract = static_cast<int>(c.q.at(213));
      if (c.q.count(256)) peck.chip_break_mm = c.q.at(256) * unit;
      peck.chip_break_rapid = retract_rapid;
      peck.retract_rapid = retract_rapid;
    }
    if (c.number == 205) {
      // Full retracts in rapid, the rapid back stopping Q258 (first) .. Q259 (last) above the
      // depth reached; chip breaks every Q257 (a retract of Q256 at Q208).
      peck.stroke_decrement_mm = c.q.at(212) * unit;
      peck.minimum_stroke_mm = c.q.at(205) * unit;
      peck.chip_breaks_per_retract = 0;
      peck.reapproach_clearance_mm = c.q.at(258) * unit;
      peck.reapproach_clearance_last_mm = c.q.at(259) * unit;
      peck.chip_break_every_mm = c.q.at(257) * unit;
      if (c.q.count(256)) peck.chip_break_mm = c.q.at(256) * unit;
      peck.chip_break_rapid = retract_rapid;
      peck.retract_rapid = true;
    }
    // Points before they are made: a tiny plunging depth would make millions.
    const std::size_t cap = options_.max_points_per_block + 1;
    const std::size_t strokes = detail::peck_stroke_count(peck, cap);
    double estimate = 3.0 * static_cast<double>(strokes) + 7.0;
    if (peck.chip_break_every_mm > 0.0) estimate += 2.0 * (peck.reference_mm - peck.bottom_mm) / peck.chip_break_every_mm;
    if (strokes >= cap || !(estimate <= static_cast<double>(options_.max_points_per_block))) {
      fail(head, "cycle " + std::to_string(c.number) + " expands to more than " +
                     std::to_string(options_.max_points_per_block) +
                     " points (ReaderOptions::max_points_per_block): the plunging depth is too small");
    }
    detail::require_room_for_points(path_, static_cast<std::size_t>(estimate), options_, file_, line_, head.column,
                                    "cycle " + std::to_string(c.number));
    for (const detail::CycleMove& m : detail::peck_moves(p, peck)) {
      add(m.rapid, m.p_mm, m.feed == detail::CycleFeed::retract ? retract : cutting);
    }
    const double bottom_dwell_s = c.q.count(211) ? c.q.at(211) : 0.0;
    const double top_dwell_s = (c.number == 200 || c.number == 203) && c.q.count(210) ? c.q.at(210) : 0.0;
    for (std::size_t k = 0; k < steps.size(); ++k) {
      Step& step = steps[k];
      if (!step.rapid && step.p_mm.z() == bottom) step.dwell_s = bottom_dwell_s;
      const bool back_in = k > 0 && k + 1 < steps.size() && steps[k - 1].p_mm.z() < clearance &&
                           steps[k + 1].p_mm.z() < clearance;
      if (step.p_mm.z() == clearance && back_in) step.dwell_s = top_dwell_s;
    }
    // Out of the hole: 200 in rapid, 201 / 203 at the retraction feed; then the 2nd set-up clearance.
    add(c.number == 200 || retract_rapid, at_level(clearance), retract);
    add(true, at_level(second), 0.0);

    const int block = add_source_block();
    for (const Step& step : steps) {
      PathPoint point = new_point(step.rapid ? MotionKind::rapid : MotionKind::linear, block);
      if (!step.rapid) point.feed_m_per_s = step.feed_m_per_s;
      point.corner_tolerance_m = 0.0;  // the control stops at each level of a cycle
      point.dwell_s = step.dwell_s;
      set_pose(point, step.p_mm, rotary_deg_, axis_W_);
      detail::append_point(path_, point, options_, file_, line_);
    }
    for (int k = 0; k < 3; ++k) pos_[static_cast<std::size_t>(k)] = p[k];
    last_.reset();
  }

  // --- PATTERN DEF and CYCL CALL PAT -------------------------------------------------------------
  //
  // PATTERN DEF, then its elements on the same line or the lines that follow (the TNC 640 writes
  // one per line, "~" at the ends), each "NAMEn (words)", in the program's coordinates:
  //  POSn (X Y [Z])                    one point (IX / IY: from the point before);
  //  ROWn (X Y D NUM [ROT] [Z])         NUM points from (X, Y), D apart, along the direction ROT [deg];
  //  PATn (X Y DX DY NUMX NUMY [ROT] [ROTX] [ROTY] [Z])  NUMY rows of NUMX points from (X, Y): the
  //      rows along the main axis turned by ROTX, the columns along the minor axis turned by ROTY,
  //      the whole turned by ROT about (X, Y); row after row, each from its first point;
  //  CIRCn (X Y D START STEP NUM [Z])   NUM points on the circle of diameter D about (X, Y), from
  //      START [deg] in steps of STEP; PITCHCIRCn the same with STEP = 360 / NUM (full circle).
  // Z is the workpiece surface at the points: it adds to the cycle's Q203 (as CYCL CALL POS's Z).
  // CYCL CALL PAT [F | FMAX] runs the cycle defined last at each point in the order defined,
  // moving between them at the higher of the tool's Z at the call and the 2nd set-up clearance.

  struct PatternPoint {
    Vec3 p_mm;  ///< X Y of the hole, Z the surface shift [mm]
  };

  static bool pattern_element_name(std::string_view upper) {
    for (std::string_view name : {"PITCHCIRC", "POS", "ROW", "PAT", "CIRC", "FRAME"}) {
      if (upper.size() > name.size() && upper.substr(0, name.size()) == name &&
          (std::isdigit(static_cast<unsigned char>(upper[name.size()])) || upper[name.size()] == '(')) {
        return true;
      }
    }
    return false;
  }

  /// The pattern elements in `line` from `from` (0-based).
  void pattern_elements(std::string_view line, std::size_t from) {
    std::size_t i = from;
    const auto column = [](std::size_t at) { return static_cast<int>(at) + 1; };
    while (i < line.size()) {
      const char c = line[i];
      if (c == ';') return;
      if (std::isspace(static_cast<unsigned char>(c)) || c == '~') {
        ++i;
        continue;
      }
      const std::size_t name_start = i;
      while (i < line.size() && std::isalpha(static_cast<unsigned char>(line[i]))) ++i;
      const std::string name = detail::to_upper(std::string(line.substr(name_start, i - name_start)));
      while (i < line.size() && std::isdigit(static_cast<unsigned char>(line[i]))) ++i;
      const std::string element_text(line.substr(name_start, i - name_start));
      while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
      if (name.empty() || !pattern_element_name(name + "(")) {
        fail(column(name_start), "'" + (element_text.empty() ? std::string(1, c) : element_text) +
                                     "': expected a pattern element POS, ROW, PAT, CIRC or PITCHCIRC");
      }
      if (i >= line.size() || line[i] != '(') fail(column(i), "'" + element_text + "': expected '(' after the element's name");
      const std::size_t close = line.find(')', i);
      if (close == std::string_view::npos) fail(column(i), "'" + element_text + "': '(' is not closed on its line");
      if (name == "FRAME") fail(column(name_start), "'" + element_text + "': FRAME (a pattern frame) is not read");
      pattern_element(name, element_text, line, i + 1, close, column(name_start));
      i = close + 1;
    }
  }

  /// One element "NAME (words)": its words between `begin` and `end` of `line`.
  void pattern_element(const std::string& name, const std::string& element_text, std::string_view line,
                       std::size_t begin, std::size_t end, int element_column) {
    struct Value {
      double v = 0.0;
      bool incremental = false;
      int column = 0;
    };
    std::map<std::string, Value> words;
    std::size_t i = begin;
    while (i < end) {
      if (std::isspace(static_cast<unsigned char>(line[i]))) {
        ++i;
        continue;
      }
      const std::size_t start = i;
      while (i < end && std::isalpha(static_cast<unsigned char>(line[i]))) ++i;
      std::string address = detail::to_upper(std::string(line.substr(start, i - start)));
      const std::size_t value_start = i;
      while (i < end && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
      const std::string word(line.substr(start, i - start));
      const std::string value(line.substr(value_start, i - value_start));
      Value parsed;
      parsed.column = static_cast<int>(start) + 1;
      if (address == "IX" || address == "IY") {
        parsed.incremental = true;
        address = address.substr(1);
      }
      static const std::vector<std::string> known = {"X", "Y", "Z", "D", "NUM", "ROT", "DX", "DY", "NUMX",
                                                     "NUMY", "ROTX", "ROTY", "START", "STEP"};
      if (std::find(known.begin(), known.end(), address) == known.end()) {
        fail(parsed.column, "'" + word + "': unsupported word in the pattern element " + element_text);
      }
      char* parse_end = nullptr;
      parsed.v = value.empty() ? 0.0 : std::strtod(value.c_str(), &parse_end);
      if (value.empty() || parse_end != value.c_str() + value.size() || !std::isfinite(parsed.v)) {
        fail(parsed.column, "'" + word + "': expected a number");
      }
      if (words.count(address)) fail(parsed.column, "'" + word + "': the address appears twice in one element");
      words[address] = parsed;
    }
    const auto need = [&](const char* address) -> const Value& {
      const auto it = words.find(address);
      if (it == words.end()) fail(element_column, "'" + element_text + "': " + address + " is missing");
      return it->second;
    };
    const auto optional = [&](const char* address) { return words.count(address) ? words.at(address).v : 0.0; };
    const auto length = [&](const Value& value, const char* what) {
      const double mm = value.v * mm_per_unit_;
      if (!(std::abs(mm) <= detail::kMaxCoordinateMm)) {
        fail(value.column, std::string(what) + " " + detail::format_number(mm) + " mm is outside +-1e6 mm");
      }
      return mm;
    };
    const auto count = [&](const char* address) {
      const Value& value = need(address);
      if (!(value.v >= 1.0 && value.v <= kMaxPatternPoints && value.v == std::trunc(value.v))) {
        fail(value.column, std::string(address) + " = " + detail::format_number(value.v) +
                               ": expected a whole number 1 .. " + std::to_string(static_cast<int>(kMaxPatternPoints)));
      }
      return static_cast<int>(value.v);
    };
    const double z_mm = words.count("Z") ? length(words.at("Z"), "Z") : 0.0;
    const double rad = std::numbers::pi / 180.0;
    std::vector<Vec3> points;
    if (name == "POS") {
      const Value& x = need("X");
      const Value& y = need("Y");
      const Vec3 previous = pattern_.empty() ? Vec3::Zero() : pattern_.back().p_mm;
      if ((x.incremental || y.incremental) && pattern_.empty()) {
        fail(element_column, "'" + element_text + "': IX / IY need a point before them in the pattern");
      }
      points.emplace_back((x.incremental ? previous.x() : 0.0) + length(x, "X"),
                          (y.incremental ? previous.y() : 0.0) + length(y, "Y"), z_mm);
    } else {
      for (const auto& [address, value] : words) {
        if (value.incremental) fail(value.column, "incremental IX / IY only in POS");
      }
      const Eigen::Vector2d origin(length(need("X"), "X"), length(need("Y"), "Y"));
      const auto turn = [&](double deg) { return Eigen::Vector2d(std::cos(deg * rad), std::sin(deg * rad)); };
      if (name == "ROW") {
        const double spacing_mm = length(need("D"), "D");
        const int n = count("NUM");
        const Eigen::Vector2d along = turn(optional("ROT"));
        for (int k = 0; k < n; ++k) {
          const Eigen::Vector2d q = origin + k * spacing_mm * along;
          points.emplace_back(q.x(), q.y(), z_mm);
        }
      } else if (name == "PAT") {
        const double dx_mm = length(need("DX"), "DX");
        const double dy_mm = length(need("DY"), "DY");
        const int nx = count("NUMX");
        const int ny = count("NUMY");
        if (static_cast<double>(nx) * ny > kMaxPatternPoints) {
          fail(element_column, "'" + element_text + "': more than " + std::to_string(static_cast<int>(kMaxPatternPoints)) + " points");
        }
        const Eigen::Vector2d main_axis = turn(optional("ROTX"));
        const Eigen::Vector2d minor_axis = turn(90.0 + optional("ROTY"));
        const double rot = optional("ROT") * rad;
        Eigen::Matrix2d R;
        R << std::cos(rot), -std::sin(rot), std::sin(rot), std::cos(rot);
        for (int j = 0; j < ny; ++j) {
          for (int k = 0; k < nx; ++k) {
            const Eigen::Vector2d q = origin + R * (k * dx_mm * main_axis + j * dy_mm * minor_axis);
            points.emplace_back(q.x(), q.y(), z_mm);
          }
        }
      } else {  // CIRC, PITCHCIRC
        const double diameter_mm = length(need("D"), "D");
        if (!(diameter_mm > 0.0)) fail(need("D").column, "D (the circle's diameter) must be positive");
        const int n = count("NUM");
        const double start_deg = need("START").v;
        const double step_deg = name == "CIRC" ? need("STEP").v : 360.0 / n;
        for (int k = 0; k < n; ++k) {
          const Eigen::Vector2d q = origin + 0.5 * diameter_mm * turn(start_deg + k * step_deg);
          points.emplace_back(q.x(), q.y(), z_mm);
        }
      }
    }
    if (pattern_.size() + points.size() > static_cast<std::size_t>(kMaxPatternPoints)) {
      fail(element_column, "'" + element_text + "': the pattern has more than " +
                               std::to_string(static_cast<int>(kMaxPatternPoints)) + " points");
    }
    for (const Vec3& q : points) pattern_.push_back({q});
  }

  /// CYCL CALL PAT [F | FMAX] [M..]
  void cycle_call_pattern(const std::vector<Token>& tokens, std::size_t at, const Token& head, const Token& pat) {
    bool rapid = true;
    std::optional<double> feed;
    for (const Word& word : words_of(tokens, at)) {
      if (word.address == "FMAX") {
        rapid = true;
      } else if (word.address == "F") {
        feed = feed_from(word);
        rapid = false;
      } else if (word.address != "M" && word.token->upper != "~") {
        fail(word, "unsupported word in CYCL CALL PAT");
      }
    }
    if (pattern_.empty()) fail(pat, "CYCL CALL PAT without a PATTERN DEF (or one without points) before it");
    if (!pos_[2]) fail(head, "CYCL CALL PAT before the tool's position is known: position it first");
    const double height_mm = *pos_[2];
    for (const PatternPoint& point : pattern_) run_cycle(head, point.p_mm, rapid, feed, height_mm);
  }

  // --- Frames ---------------------------------------------------------------------------------

  /// Program coordinates [mm] to preset coordinates: q = d0 + R (d1 + p).
  Vec3 to_preset(const Vec3& p) const { return shift_before_mm_ + plane_R_ * (shift_after_mm_ + p); }
  Vec3 from_preset(const Vec3& q) const {
    return plane_R_.transpose() * (q - shift_before_mm_) - shift_after_mm_;
  }
  bool tilted() const { return plane_active_; }
  bool tcp_like() const { return tcpm_ || plane_active_; }

  /// Runs `change` on the frame and keeps the tool where it is: the known program position is
  /// expressed in the new frame.
  template <class Change>
  void change_frame(Change change) {
    const bool all_known = pos_[0] && pos_[1] && pos_[2];
    std::optional<Vec3> q;
    if (all_known) q = to_preset(Vec3(*pos_[0], *pos_[1], *pos_[2]));
    const Vec3 d_before = shift_before_mm_ + plane_R_ * shift_after_mm_;
    change();
    if (q) {
      const Vec3 p = from_preset(*q);
      for (int k = 0; k < 3; ++k) pos_[static_cast<std::size_t>(k)] = p[k];
    } else {
      // Some axes unknown (only possible untilted): shift the known ones.
      const Vec3 d_after = shift_before_mm_ + plane_R_ * shift_after_mm_;
      for (int k = 0; k < 3; ++k) {
        if (pos_[static_cast<std::size_t>(k)]) *pos_[static_cast<std::size_t>(k)] -= d_after[k] - d_before[k];
      }
    }
  }

  void set_datum_shift(const std::vector<Word>& words, const Token& head, bool reset) {
    require_no_pending_corner(head);
    require_no_compensation(head, "a datum shift");
    Vec3 shift = tilted() ? shift_after_mm_ : shift_before_mm_;
    if (reset) shift.setZero();
    for (const Word& word : words) {
      const int axis = linear_axis(word.address);
      if (axis < 0) fail(word, "a datum shift of X, Y or Z only (rotary axes are not supported)");
      if (!word.value) fail(word, "expected a value");
      const double v = *word.value * mm_per_unit_;
      require_within(*word.token, v, -detail::kMaxCoordinateMm, detail::kMaxCoordinateMm, "datum shift", "mm");
      shift[axis] = word.incremental ? shift[axis] + v : v;
    }
    change_frame([&] { (tilted() ? shift_after_mm_ : shift_before_mm_) = shift; });
  }

  void plane(const std::vector<Token>& tokens, std::size_t at, const Token& head) {
    require_no_pending_corner(head);
    require_no_compensation(head, "a PLANE function");
    if (at >= tokens.size()) fail(head, "PLANE needs its kind (SPATIAL, VECTOR, EULER, RELATIV, RESET)");
    const Token& kind_token = tokens[at];
    const std::string& kind = kind_token.upper;
    if (kind == "PROJECTED" || kind == "POINTS" || kind == "AXIAL") {
      fail(kind_token, "PLANE " + kind + " is not supported (SPATIAL, VECTOR, EULER, RELATIV, RESET)");
    }
    if (kind != "SPATIAL" && kind != "VECTOR" && kind != "EULER" && kind != "RELATIV" && kind != "RESET") {
      fail(kind_token, "unknown PLANE function");
    }
    std::map<std::string, const Word*> values;
    enum class Positioning { none, turn, stay } positioning = Positioning::none;
    const Token* positioning_token = nullptr;
    std::optional<double> feed_m_per_s;
    bool rapid = true;
    std::optional<double> retract_mm;
    const std::vector<Word> words = words_of(tokens, at + 1);
    for (std::size_t i = 0; i < words.size(); ++i) {
      const Word& word = words[i];
      const std::string& a = word.address;
      if (!word.value && !word.sign_only) {
        if (a == "TURN" || a == "MOVE") {
          positioning = Positioning::turn;
          positioning_token = word.token;
        } else if (a == "STAY") {
          positioning = Positioning::stay;
          positioning_token = word.token;
        } else if (a == "FMAX") {
          rapid = true;
        } else if (a == "MB") {
          if (i + 1 < words.size() && words[i + 1].address == "MAX" && !words[i + 1].value) {
            warn("PLANE ... MB MAX (retract to the travel limit before tilting) is skipped: the "
                 "travel is the machine's; program the retract (L Z.. M91)");
            ++i;
          } else if (i + 1 < words.size() && words[i + 1].address.empty()) {
            fail(*words[i + 1].token, "unexpected");
          } else {
            fail(word, "MB needs MAX or a distance (MB50)");
          }
        } else if (a == "TABLE" || a == "COORD" || a == "ROT") {
          // TABLE ROT / COORD ROT: the control's choice of solution, not emulated.
        } else {
          fail(word, "unexpected word in PLANE");
        }
        continue;
      }
      if (a == "SEQ") continue;  // SEQ+ / SEQ-: the solution's choice, not emulated
      if (a == "MB") {
        const double v = *word.value * mm_per_unit_;
        require_within(*word.token, v, 0.0, detail::kMaxCoordinateMm, "retract", "mm");
        retract_mm = v;
        continue;
      }
      if (a == "DIST" || a == "ABST") continue;  // MOVE's distance: the turn is about the tip
      if (a == "F") {
        feed_m_per_s = feed_from(word);
        rapid = false;
        continue;
      }
      if (!word.value) fail(word, "expected a value");
      if (values.count(a)) fail(word, "the address appears twice in one block");
      values[a] = &word;
      require_within(*word.token, *word.value, -detail::kMaxCoordinateMm, detail::kMaxCoordinateMm, "value", "");
    }
    const auto need = [&](std::initializer_list<const char*> names) {
      for (const auto& [name, word] : values) {
        bool known = false;
        for (const char* n : names) known = known || name == n;
        if (!known) fail(*word, "not a word of PLANE " + kind);
      }
      std::vector<double> result;
      for (const char* n : names) {
        const auto it = values.find(n);
        if (it == values.end()) fail(kind_token, "PLANE " + kind + " needs " + n);
        result.push_back(*it->second->value);
      }
      return result;
    };
    bool active = true;
    Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
    if (kind == "SPATIAL") {
      const auto v = need({"SPA", "SPB", "SPC"});
      R = rotation_z(v[2]) * rotation_y(v[1]) * rotation_x(v[0]);
    } else if (kind == "EULER") {
      const auto v = need({"EULPR", "EULNU", "EULROT"});
      R = rotation_z(v[0]) * rotation_x(v[1]) * rotation_z(v[2]);
    } else if (kind == "VECTOR") {
      const auto v = need({"BX", "BY", "BZ", "NX", "NY", "NZ"});
      const Vec3 b(v[0], v[1], v[2]);
      const Vec3 n(v[3], v[4], v[5]);
      if (!(n.norm() > 1e-9)) fail(kind_token, "PLANE VECTOR: the normal vector N is zero");
      const Vec3 z = n.normalized();
      const Vec3 x_raw = b - b.dot(z) * z;
      if (!(x_raw.norm() > 1e-9 * std::max(1.0, b.norm()))) {
        fail(kind_token, "PLANE VECTOR: the base vector B is zero or parallel to the normal N");
      }
      const Vec3 x = x_raw.normalized();
      R.col(0) = x;
      R.col(1) = z.cross(x);
      R.col(2) = z;
    } else if (kind == "RELATIV") {
      if (values.size() != 1) fail(kind_token, "PLANE RELATIV needs one of SPA, SPB, SPC");
      const auto& [name, word] = *values.begin();
      Eigen::Matrix3d step;
      if (name == "SPA") {
        step = rotation_x(*word->value);
      } else if (name == "SPB") {
        step = rotation_y(*word->value);
      } else if (name == "SPC") {
        step = rotation_z(*word->value);
      } else {
        fail(*word, "not a word of PLANE RELATIV (SPA, SPB or SPC)");
      }
      R = plane_R_ * step;  // about the axes of the plane in force
    } else {
      need({});
      active = false;
    }
    if (positioning == Positioning::none) {
      fail(kind_token, "PLANE needs its positioning: TURN, MOVE or STAY");
    }
    // The frame: a new plane turns about the datum in force outside planes; a shift made inside
    // the old plane goes with it.
    const Vec3 old_axis = axis_W_;
    change_frame([&] {
      plane_active_ = active;
      plane_R_ = R;
      shift_after_mm_.setZero();
    });
    if (positioning != Positioning::turn) return;
    // TURN / MOVE: the tool turns about its tip onto the plane's axis.
    if (!(pos_[0] && pos_[1] && pos_[2])) {
      fail(*positioning_token, "PLANE TURN / MOVE before the tool's position is known");
    }
    const int block = add_source_block();
    const Vec3 p(*pos_[0], *pos_[1], *pos_[2]);
    // The tip in W before the turn (as the previous point has it).
    const Vec3 tip_W_mm = path_.points.empty() ? tip_W_mm_of(p, old_axis)
                                               : Vec3(path_.points.back().tip_W_m / kMetresPerMillimetre);
    Vec3 tip = tip_W_mm;
    if (retract_mm && *retract_mm > 0.0) {
      tip += *retract_mm * old_axis;
      PathPoint point = new_point(MotionKind::rapid, block);
      point.tip_W_m = tip * kMetresPerMillimetre;
      point.axis_W = old_axis;
      point.rotary_words_deg = rotary_words_deg(rotary_deg_);
      detail::append_point(path_, point, options_, file_, line_);
    }
    axis_W_ = plane_R_ * Vec3::UnitZ();
    rotary_deg_ = {};  // the chain's choice from here; PLANE RESET TURN: the basic position
    rotary_unknown_ = active;
    PathPoint point = new_point(rapid ? MotionKind::rapid : MotionKind::linear, block);
    if (!rapid) point.feed_m_per_s = *feed_m_per_s;
    point.tip_W_m = tip * kMetresPerMillimetre;
    point.axis_W = axis_W_;
    detail::append_point(path_, point, options_, file_, line_);
    // The program position of the (possibly retracted) tip in the new frame.
    const Vec3 q = tip - preset_W_mm_ - dl_mm_ * axis_W_;
    const Vec3 np = from_preset(q);
    for (int k = 0; k < 3; ++k) pos_[static_cast<std::size_t>(k)] = np[k];
    last_ = {};
  }

  // --- Motion blocks --------------------------------------------------------------------------

  static int linear_axis(const std::string& a) {
    if (a == "X") return 0;
    if (a == "Y") return 1;
    if (a == "Z") return 2;
    return -1;
  }
  static int rotary_axis(const std::string& a) {
    if (a == "A") return 0;
    if (a == "B") return 1;
    if (a == "C") return 2;
    return -1;
  }

  double feed_from(const Word& word) const {
    if (!word.value) fail(word, "expected a feed rate");
    // Inch programs give F in 0.1 inch/min.
    const double mm_per_min = *word.value * (mm_per_unit_ == 1.0 ? 1.0 : mm_per_unit_ / 10.0);
    if (!(mm_per_min > 0.0)) fail(word, "the feed rate must be positive");
    require_within(*word.token, mm_per_min, detail::kMinFeedMmPerMin, detail::kMaxFeedMmPerMin,
                   "feed rate", "mm/min");
    return mm_per_min * kMetresPerMillimetre / kSecondsPerMinute;
  }

  struct PendingCorner {
    bool chamfer = false;
    double size_mm = 0.0;
    std::optional<double> feed_m_per_s;
    int line = 0;
    int column = 0;
    int block = -1;
  };

  /// The last contour element, for CT, RND and CHF.
  struct LastElement {
    bool line = false;  ///< a straight line (else an arc)
    Vec3 start = Vec3::Zero(), end = Vec3::Zero();  ///< program coordinates [mm]
    Vec2 tangent = Vec2::Zero();  ///< unit direction at the end in the plane X/Y; zero: none
    std::size_t point_index = 0;  ///< its last point (the corner), for RND / CHF
    bool point_made = false;
    bool in_plane = false;  ///< a line that does not move in Z
    RotaryDeg rotary;
  };

  void require_no_pending_corner(const Token& token) const {
    if (pending_corner_) {
      fail(token, std::string(pending_corner_->chamfer ? "CHF" : "RND") +
                      " must be followed by the straight line it ends at");
    }
  }

  void motion_block(const std::string& kind, const Token& head, const std::vector<Token>& tokens,
                    std::size_t first) {
    const std::vector<Word> words = words_of(tokens, first);
    std::array<const Word*, 3> xyz{}, abc{}, normal{}, vector{};
    const Word* f_word = nullptr;
    bool fmax = false, fauto = false;
    const Word* dr_word = nullptr;
    const Word* r_word = nullptr;
    const Word* size_word = nullptr;  // CHF's length (a bare number)
    const Word* compensation_word = nullptr;  // RL, RR or R0
    bool m91 = false, m92 = false, m128 = false, m129 = false, end_program = false;
    bool cycle_call_here = false, modal_cycle_on = false;  // M99, M89
    const auto once = [&](const Word*& slot, const Word& word) {
      if (slot) fail(word, "the address appears twice in one block");
      slot = &word;
    };
    for (const Word& word : words) {
      const std::string& a = word.address;
      if (a.empty()) {
        if (kind == "CHF" && !size_word && word.value) {
          size_word = &word;
          continue;
        }
        fail(word, "expected a word");
      }
      if (const int k = linear_axis(a); k >= 0) {
        if (!word.value) fail(word, "expected a value");
        once(xyz[static_cast<std::size_t>(k)], word);
        continue;
      }
      if (const int k = rotary_axis(a); k >= 0) {
        if (!word.value) fail(word, "expected a value");
        once(abc[static_cast<std::size_t>(k)], word);
        continue;
      }
      if (a == "NX" || a == "NY" || a == "NZ" || a == "TX" || a == "TY" || a == "TZ") {
        if (kind != "LN") fail(word, "the surface normal and tool vector belong to LN");
        if (!word.value) fail(word, "expected a value");
        once((a[0] == 'N' ? normal : vector)[static_cast<std::size_t>(a[1] - 'X')], word);
        continue;
      }
      if (a == "F") {
        once(f_word, word);
        continue;
      }
      if (a == "FMAX") {
        fmax = true;
        continue;
      }
      if (a == "FAUTO") {
        fauto = true;
        continue;
      }
      if (a == "FU" || a == "FZ") fail(word, "feed per revolution / per tooth is not supported");
      if (a == "R") {
        if (kind == "CR" || kind == "RND") {
          if (!word.value) fail(word, "expected the radius");
          once(r_word, word);
          continue;
        }
        if (word.value && *word.value == 0.0) {  // R0: radius compensation off
          once(compensation_word, word);
          continue;
        }
        fail(word, "paraxial radius compensation R+ / R- is not supported");
      }
      if (a == "RL" || a == "RR") {
        if (word.value || word.sign_only) fail(word, "expected RL or RR alone");
        once(compensation_word, word);
        continue;
      }
      if (a == "DR") {
        if (kind != "C" && kind != "CR") fail(word, "DR (direction) belongs to C and CR");
        if (!word.sign_only) fail(word, "expected DR+ or DR-");
        once(dr_word, word);
        continue;
      }
      if (a == "M") {
        if (!word.value) fail(word, "expected the M function's number");
        require_within(*word.token, *word.value, 0.0, detail::kMaxIgnoredWordValue, "M function", "");
        const long m = std::lround(*word.value);
        if (m == 91) m91 = true;
        if (m == 92) m92 = true;
        if (m == 128) m128 = true;
        if (m == 129) m129 = true;
        if (m == 2 || m == 30) end_program = true;
        if (m == 140) fail(word, "M140 (retract along the tool axis) is not supported: program the retract");
        if (m == 98) fail(word, "M98 is not a TNC function (CALL LBL / CALL PGM call subprograms)");
        if (m == 99) cycle_call_here = true;
        if (m == 89) modal_cycle_on = true;
        continue;
      }
      fail(word, "unsupported word in " + kind);
    }
    if (m91 && m92) fail(head, "both M91 and M92 in one block");
    for (const Word* w : {xyz[0], xyz[1], xyz[2]}) {
      if (w) require_within(*w->token, *w->value * mm_per_unit_, -detail::kMaxCoordinateMm, detail::kMaxCoordinateMm, "length", "mm");
    }
    for (const Word* w : {abc[0], abc[1], abc[2]}) {
      if (w) require_within(*w->token, *w->value, -detail::kMaxRotaryDeg, detail::kMaxRotaryDeg, "rotary axis word", "deg");
    }
    if (r_word) {
      require_within(*r_word->token, *r_word->value * mm_per_unit_, -detail::kMaxCoordinateMm, detail::kMaxCoordinateMm, "radius", "mm");
    }
    // Feed: F modal (and from the block on), FMAX this block only, FAUTO the TOOL CALL's.
    std::optional<double> block_feed;
    if (f_word) {
      block_feed = feed_from(*f_word);
      if (kind != "RND" && kind != "CHF") feed_m_per_s_ = block_feed;
    }
    if (fauto) {
      if (!auto_feed_m_per_s_) fail(head, "FAUTO without a feed in TOOL CALL");
      block_feed = auto_feed_m_per_s_;
    }
    if (compensation_word && kind != "L" && kind != "C" && kind != "CR" && kind != "CT") {
      fail(*compensation_word, "RL / RR / R0 belong to L, C, CR and CT");
    }
    if (m128) {
      if (compensation_side_) fail(head, "M128 under radius compensation is not supported: cancel it (R0) first");
      tcpm_ = true;
    }

    if (kind == "CC") {
      pole(xyz, head);
    } else if (kind == "RND" || kind == "CHF") {
      corner(kind == "CHF", kind == "CHF" ? size_word : r_word, block_feed, head);
    } else if (kind != "M") {
      const Word* any = nullptr;
      for (const Word* w : {xyz[0], xyz[1], xyz[2], abc[0], abc[1], abc[2]}) {
        if (w && (!any || w->token->column < any->token->column)) any = w;
      }
      if (compensation_word && !any && kind == "L" &&
          (compensation_word->address != "R" || compensation_side_)) {
        fail(*compensation_word, "RL / RR / R0 on a block without a point to move to");
      }
      if (any || kind != "L") {
        if (fmax && (kind != "L" && kind != "LN")) fail(head, "FMAX on an arc: give a feed");
        const bool rapid = fmax;
        std::optional<double> feed = rapid ? std::nullopt : (block_feed ? block_feed : feed_m_per_s_);
        if (!rapid && !feed) fail(head, "feed motion before any F: the feed is unknown");
        Motion motion{kind, &head, xyz, abc, normal, vector, dr_word, r_word, compensation_word,
                      rapid, feed, m91 || m92, m92};
        move(motion);
      }
    }
    if (m129) tcpm_ = false;
    // Cycle calls at the block's end: M99 once (and ends M89), M89 from here on after every
    // positioning block.
    const bool positioned = (kind == "L" || kind == "LN") && (xyz[0] || xyz[1] || xyz[2]);
    if (modal_cycle_on) modal_cycle_call_ = true;
    if (cycle_call_here || (modal_cycle_call_ && positioned)) run_cycle(head, std::nullopt, true, std::nullopt);
    if (cycle_call_here) modal_cycle_call_ = false;
    if (end_program) ended_ = true;
  }

  struct Motion {
    std::string kind;
    const Token* head;
    std::array<const Word*, 3> xyz, abc, normal, vector;
    const Word* dr;
    const Word* r;
    const Word* compensation;  ///< RL, RR or R0 (nullptr: the mode in force)
    bool rapid;
    std::optional<double> feed_m_per_s;
    bool machine;  ///< M91 / M92
    bool m92;
  };

  /// CC: the circle centre, in the plane of the axes it names.
  void pole(const std::array<const Word*, 3>& xyz, const Token& head) {
    const bool x = xyz[0], y = xyz[1], z = xyz[2];
    if (x && y && z) fail(head, "CC names two axes of the circle's plane, not three");
    PlaneAxes plane = kPlaneXY;
    if (z && x) plane = kPlaneZX;
    if (z && y) plane = kPlaneYZ;
    if (z && !x && !y) fail(*xyz[2]->token, "CC with Z alone: name the plane's two axes");
    Vec3 c = Vec3::Zero();
    for (int k = 0; k < 3; ++k) {
      const Word* w = xyz[static_cast<std::size_t>(k)];
      const auto& p = pos_[static_cast<std::size_t>(k)];
      if (w && !w->incremental) {
        c[k] = *w->value * mm_per_unit_;
      } else {
        if (!p && (k == plane[0] || k == plane[1])) {
          fail(w ? *w->token : head, std::string("CC: the position of ") + "XYZ"[k] +
                                         " is not known (the centre takes it from the tool)");
        }
        c[k] = p.value_or(0.0) + (w ? *w->value * mm_per_unit_ : 0.0);
      }
    }
    pole_mm_ = c;
    pole_plane_ = plane;
  }

  void corner(bool chamfer, const Word* size, std::optional<double> feed, const Token& head) {
    if (!size) fail(head, chamfer ? "CHF needs its length (CHF 2)" : "RND needs its radius (RND R5)");
    const double v = *size->value * mm_per_unit_;
    if (!(v > 0.0)) fail(*size, chamfer ? "the chamfer length must be positive" : "the radius must be positive");
    require_no_pending_corner(head);
    const bool line_before = compensation_side_ ? held_.has_value() && !held_->element.arc
                                                : last_ && last_->point_made &&
                                                      last_->point_index + 1 == path_.points.size();
    if (!last_ || !last_->line || !line_before) {
      fail(head, std::string(chamfer ? "CHF" : "RND") + " must follow a straight line (L) that ends at the corner");
    }
    PendingCorner pending;
    pending.chamfer = chamfer;
    pending.size_mm = v;
    pending.feed_m_per_s = feed ? feed : feed_m_per_s_;
    if (!pending.feed_m_per_s) fail(head, "feed motion before any F: the feed is unknown");
    pending.line = line_;
    pending.column = head.column;
    pending.block = add_source_block();
    pending_corner_ = pending;
  }

  // --- Radius compensation RL / RR / R0 (cutter_compensation.hpp) -----------------------------
  //
  // As in the 840D reader: every L / C / CR / CT under RL / RR goes, in program coordinates, to
  // the compensator, whose moves come one element late and are posed point by point. The block
  // with RL / RR is the approach: it ends on the first contour element's offset start, normal to
  // it (EntryRule::normal_to_next, as NORM). Each element is held back one more block here so that
  // an RND / CHF after a line can still cut that line back to its tangent point.

  void require_no_compensation(const Token& token, const std::string& what) const {
    if (compensation_side_) {
      fail(token, what + " under radius compensation RL / RR is not supported: cancel it (R0) first");
    }
  }

  /// The radius [mm] of the tool of the last TOOL CALL: ReaderOptions::cutter_radius_mm by its
  /// number (default_cutter_radius_mm for a tool called by name or one not in the table), plus
  /// TOOL CALL's DR (the radius allowance).
  double cutter_radius_of(const Word& word) const {
    double radius_mm = 0.0;
    const auto it = tool_number_ >= 0 ? options_.cutter_radius_mm.find(tool_number_) : options_.cutter_radius_mm.end();
    if (it != options_.cutter_radius_mm.end()) {
      radius_mm = it->second;
    } else if (options_.default_cutter_radius_mm) {
      radius_mm = *options_.default_cutter_radius_mm;
    } else {
      std::string known;
      for (const auto& [n, r] : options_.cutter_radius_mm) known += (known.empty() ? "T" : ", T") + std::to_string(n);
      fail(word, "RL / RR need the tool radius: none for " +
                     (tool_number_ >= 0 ? "T" + std::to_string(tool_number_) : std::string("the tool (no TOOL CALL with a number)")) +
                     " (the tool table has " + (known.empty() ? std::string("none") : known) +
                     "; the part file's tools: diameter_mm)");
    }
    if (!(radius_mm >= 0.0 && radius_mm <= 0.5 * detail::kMaxCutterDiameterMm)) {
      fail(word, "the tool radius " + detail::format_number(radius_mm) + " mm is not within [0, " +
                     detail::format_number(0.5 * detail::kMaxCutterDiameterMm) + "] mm");
    }
    const double compensated_mm = radius_mm + dr_mm_;
    if (!(compensated_mm > 0.0)) {
      fail(word, "the tool radius " + detail::format_number(radius_mm) + " mm with TOOL CALL's DR " +
                     detail::format_number(dr_mm_) + " mm is " + detail::format_number(compensated_mm) +
                     " mm: RL / RR need a positive radius");
    }
    return compensated_mm;
  }

  void start_compensation(const Word& word, const Motion& m, const Vec3& start) {
    const CompensationSide side = word.address == "RL" ? CompensationSide::left : CompensationSide::right;
    if (compensation_side_) {
      if (*compensation_side_ == side) return;  // repeated on a later block
      fail(word, std::string("radius compensation ") + (side == CompensationSide::left ? "RR" : "RL") +
                     " is on: cancel it (R0) before changing its side");
    }
    if (tcp_like()) {
      fail(word, "radius compensation RL / RR under M128 / FUNCTION TCPM or in a tilted working plane "
                 "(PLANE) is not supported");
    }
    if (m.kind != "L") {
      fail(word, "RL / RR on " + m.kind + ": the block that starts radius compensation (the approach) "
                 "must be a straight line L");
    }
    if (pending_corner_) {
      fail(*m.head, std::string(pending_corner_->chamfer ? "CHF" : "RND") + " before the block with RL / RR");
    }
    const double radius_mm = cutter_radius_of(word);
    compensation_radius_mm_ = radius_mm;
    compensation_side_ = side;
    compensator_.emplace(side, radius_mm, Vec2(start.x(), start.y()), start.z(), EntryRule::normal_to_next);
  }

  /// R0 (or the end of the program): the last element ends at its offset end. Returns where the
  /// tool is [program mm].
  Vec3 end_compensation(int column) {
    flush_held();
    emit_compensated(compensation_call(line_, column, line_text_, [&] { return compensator_->finish(); }));
    const Vec3 tool(compensator_->tool_mm().x(), compensator_->tool_mm().y(), compensator_->tool_w_mm());
    compensator_.reset();
    compensation_side_.reset();
    return tool;
  }

  template <typename Call>
  std::vector<CompensatedMove> compensation_call(int line, int column, const std::string& text, Call call) const {
    try {
      return call();
    } catch (const CompensationError& error) {
      throw InputError(located_message(file_, line, column, "'" + text + "': " + error.what()));
    }
  }

  void compensated_move(const Motion& m, Vec3 start, const Vec3& end) {
    const Token& head = *m.head;
    const bool arc = m.kind != "L";
    PathPoint point = new_point(m.rapid ? MotionKind::rapid : (arc ? MotionKind::arc : MotionKind::linear), -1);
    if (!m.rapid) point.feed_m_per_s = *m.feed_m_per_s;
    if (pending_corner_) {
      if (arc) {
        fail(head, std::string(pending_corner_->chamfer ? "CHF" : "RND") +
                       " between a line and an arc is not supported: only between two straight lines");
      }
      start = compensated_corner(start, end, head);
    }
    point.block = add_source_block();
    PlaneElement element;
    element.start = start.head<2>();
    element.end = end.head<2>();
    element.start_w_mm = start.z();
    element.end_w_mm = end.z();
    if (arc) {
      const ArcSpec spec = arc_spec(m, start, end);
      if (spec.plane != kPlaneXY) {
        fail(head, "an arc outside the working plane X/Y under radius compensation is not supported");
      }
      const ArcFit fit = fit_arc(start, end, spec.centre, spec.ccw, spec.full, spec.plane, head.column);
      element.arc = true;
      element.centre = fit.centre;
      element.sweep_rad = fit.sweep_rad;
    }
    add_compensated(element, point, line_, head.column, line_text_);
  }

  /// RND / CHF under compensation: the held line now ends at the first tangent point, the
  /// rounding arc or chamfer follows as an element of its own; returns the second tangent point.
  Vec3 compensated_corner(const Vec3& corner, const Vec3& end, const Token& head) {
    const PendingCorner pending = *pending_corner_;
    pending_corner_.reset();
    const CornerGeometry geometry = corner_geometry(pending, corner, end, head);
    held_->element.end = geometry.p1.head<2>();
    PlaneElement element;
    element.start = geometry.p1.head<2>();
    element.end = geometry.p2.head<2>();
    element.start_w_mm = element.end_w_mm = corner.z();
    if (!pending.chamfer) {
      element.arc = true;
      element.centre = geometry.centre;
      element.sweep_rad = detail::arc_sweep_rad(element.start, element.end, element.centre, geometry.ccw, false);
    }
    PathPoint point = new_point(pending.chamfer ? MotionKind::linear : MotionKind::arc, pending.block);
    point.feed_m_per_s = *pending.feed_m_per_s;
    add_compensated(element, point, pending.line, pending.column, pending.chamfer ? "CHF" : "RND");
    return geometry.p2;
  }

  /// Holds an element (its PathPoint the template of its moves) after handing on the one held.
  void add_compensated(PlaneElement element, const PathPoint& point, int line, int column, const std::string& text) {
    const int tag = next_compensation_tag_++;
    compensated_sources_[tag] = point;
    element.tag = tag;
    flush_held();
    if (element.arc || (element.end - element.start).norm() > kTinyMm) {
      held_ = HeldElement{element, line, column, text};
      return;
    }
    // A move along Z only: made where the contour is when the next element says where that is.
    emit_compensated(compensation_call(line, column, text, [&] {
      return compensator_->add_normal_move(element.end_w_mm, tag);
    }));
  }

  void flush_held() {
    if (!held_) return;
    const HeldElement held = *held_;
    held_.reset();
    emit_compensated(compensation_call(held.line, held.column, held.text,
                                       [&] { return compensator_->add(held.element); }));
  }

  void emit_compensated(const std::vector<CompensatedMove>& moves) {
    for (const CompensatedMove& move : moves) {
      const auto source = compensated_sources_.find(move.tag);
      if (source == compensated_sources_.end()) continue;
      PathPoint point = source->second;
      const std::size_t first = path_.points.size();
      if (!move.arc) {
        set_pose(point, Vec3(move.end.x(), move.end.y(), move.end_w_mm), rotary_deg_, axis_W_);
        detail::append_point(path_, point, options_, file_, line_);
      } else {
        if (point.kind != MotionKind::rapid) point.kind = MotionKind::arc;
        const double radius = (move.start - move.centre).norm();
        const double chord_mm = options_.arc_chord_tolerance_m / kMetresPerMillimetre;
        const double count = detail::arc_chord_count(radius, move.sweep_rad, chord_mm);
        const std::string what = "the compensated arc (radius " + detail::format_number(radius) + " mm)";
        if (!(count <= static_cast<double>(options_.max_points_per_block))) {
          fail(0, what + " expands to " + detail::format_number(count) + " points, more than the limit of " +
                      std::to_string(options_.max_points_per_block) +
                      " points per block (ReaderOptions::max_points_per_block)");
        }
        const long segments = std::max(1L, static_cast<long>(count));
        detail::require_room_for_points(path_, static_cast<std::size_t>(segments), options_, file_, line_, 0, what);
        for (const Eigen::Vector3d& p : arc_chord_ends_mm(move, segments)) {
          set_pose(point, p, rotary_deg_, axis_W_);
          detail::append_point(path_, point, options_, file_, line_);
        }
      }
      // Points inside a move are no corners; a corner arc has none of its own (tangent both ways).
      for (std::size_t i = first; i < path_.points.size(); ++i) {
        if (path_.points[i].corner_tolerance_m == 0.0 && (move.corner || i + 1 < path_.points.size())) {
          path_.points[i].corner_tolerance_m = PathPoint::kNotProgrammed;
        }
      }
      if (!move.corner) compensated_sources_.erase(source);
    }
  }

  // --- APPR / DEP (TNC 640 user's manual, "Approaching and departing a contour") ------------
  //
  // PS: where the tool is before APPR (without compensation); PH: the auxiliary point; PA: the
  // first contour point (the APPR block's X Y); PE: the last contour point; PN: DEP's end point.
  // t: the contour's unit tangent at PA (PE); n: its normal to the compensation side (left of t
  // for RL). The tool centre, tool radius r, moves:
  //  APPR LT: PS -> PH + r n, PH = PA - LEN t (on the contour's extension), then along t to PA + r n.
  //  APPR LN: PS -> PA + (LEN + r) n (the manual: PH is LEN plus the tool radius from PA), then
  //           along -n to PA + r n.
  //  APPR CT: PS -> PH on an arc of radius |R| tangent to the contour at PA, swept CCA; the
  //           direction: RL with R > 0 (RR with R < 0) counter-clockwise, else clockwise; the arc
  //           is travelled compensated (tool centre r to the compensation side of it).
  //  APPR LCT: an arc of radius R > 0 tangent to the contour at PA, its centre PA + R n (turning
  //           as CT with R > 0); the tool centre on radius R - r, entered on the line from PS
  //           that touches that circle (PH: where it touches).
  //  DEP LT / LN / CT / LCT: the mirror (DEP LCT: the arc, then its tangent to X Y, PN) from PE + r n (the compensated contour's end), compensation
  //           off at PN.
  // A Z in APPR: to PH in the plane, then to that depth, then on to PA. A Z in DEP: to PN in the
  // plane, then to that height.

  static Vec2 left_of(const Vec2& t) { return Vec2(-t.y(), t.x()); }

  void approach_block(bool approach, const Token& head, const std::vector<Token>& tokens, std::size_t first) {
    const std::string what = approach ? "APPR" : "DEP";
    if (first >= tokens.size()) fail(head, what + " needs its form: LT, LN, CT or LCT");
    const Token& form_token = tokens[first];
    // PLT, PLN, PCT, PLCT: the same forms with the point in polar coordinates PR PA about CC.
    const bool polar = form_token.upper.size() > 2 && form_token.upper[0] == 'P';
    const std::string form = polar ? form_token.upper.substr(1) : form_token.upper;
    if (form != "LT" && form != "LN" && form != "CT" && form != "LCT") {
      fail(form_token, what + " " + form_token.upper + " is not read: the forms read are LT, LN, CT and LCT "
                       "(Cartesian) and PLT, PLN, PCT and PLCT (polar)");
    }
    const std::vector<Word> words = words_of(tokens, first + 1);
    std::array<const Word*, 3> xyz{};
    const Word *len = nullptr, *cca = nullptr, *radius = nullptr, *side = nullptr, *f_word = nullptr;
    const Word *polar_radius = nullptr, *polar_angle = nullptr;
    const auto once = [&](const Word*& slot, const Word& word) {
      if (slot) fail(word, "the address appears twice in one block");
      if (!word.value && &slot != &side) fail(word, "expected a value");
      slot = &word;
    };
    for (const Word& word : words) {
      const std::string& a = word.address;
      if (const int k = linear_axis(a); k >= 0) {
        once(xyz[static_cast<std::size_t>(k)], word);
      } else if (polar && (a == "PR" || a == "PA")) {
        once(a == "PR" ? polar_radius : polar_angle, word);
      } else if (polar && (a == "IPR" || a == "IPA")) {
        fail(word, "incremental polar coordinates are not read: PR PA about CC");
      } else if (a == "LEN") {
        once(len, word);
      } else if (a == "CCA") {
        once(cca, word);
      } else if (a == "R") {
        once(radius, word);
      } else if (a == "RL" || a == "RR") {
        if (word.value || word.sign_only) fail(word, "expected RL or RR alone");
        once(side, word);
      } else if (a == "F") {
        once(f_word, word);
      } else if (a == "M") {
        if (!word.value) fail(word, "expected the M function's number");
      } else {
        fail(word, "unsupported word in " + what + " " + form);
      }
    }
    for (const Word* w : {xyz[0], xyz[1], xyz[2]}) {
      if (w) require_within(*w->token, *w->value * mm_per_unit_, -detail::kMaxCoordinateMm, detail::kMaxCoordinateMm, "length", "mm");
    }
    // Polar: the point PR PA about the pole CC becomes X Y.
    Word polar_x, polar_y;
    if (polar) {
      if (xyz[0] || xyz[1]) fail(*(xyz[0] ? xyz[0] : xyz[1]), what + " " + form_token.upper + " takes PR PA, not X Y");
      const bool needs_point = approach || form == "LCT";
      if (needs_point || polar_radius || polar_angle) {
        if (!polar_radius || !polar_angle) fail(form_token, what + " " + form_token.upper + " needs the polar radius PR and angle PA");
        if (!pole_mm_ || pole_plane_ != kPlaneXY) fail(form_token, "polar coordinates without a pole CC in the plane X/Y before them");
        const double pr_mm = *polar_radius->value * mm_per_unit_;
        require_within(*polar_radius->token, pr_mm, 0.0, detail::kMaxCoordinateMm, "polar radius", "mm");
        require_within(*polar_angle->token, *polar_angle->value, -detail::kMaxRotaryDeg, detail::kMaxRotaryDeg, "polar angle", "deg");
        const double angle = *polar_angle->value / kDegPerRad;
        polar_x.address = "X";
        polar_x.value = (pole_mm_->x() + pr_mm * std::cos(angle)) / mm_per_unit_;
        polar_x.token = polar_radius->token;
        polar_y = polar_x;
        polar_y.address = "Y";
        polar_y.value = (pole_mm_->y() + pr_mm * std::sin(angle)) / mm_per_unit_;
        xyz[0] = &polar_x;
        xyz[1] = &polar_y;
      }
    }
    const bool arc_form = form == "CT";
    if (form == "LCT") {
      if (!radius) fail(form_token, what + " LCT needs the radius R");
      if (!(*radius->value > 0.0)) fail(*radius, "R in " + what + " LCT must be positive");
      require_within(*radius->token, *radius->value * mm_per_unit_, 0.0, detail::kMaxCoordinateMm, "radius", "mm");
      if (len) fail(*len, "LEN belongs to LT and LN");
      if (cca) fail(*cca, "CCA belongs to CT");
    } else if (arc_form) {
      if (!cca) fail(form_token, what + " CT needs the centre angle CCA");
      if (!radius) fail(form_token, what + " CT needs the radius R");
      if (!(*cca->value > 0.0 && *cca->value <= 360.0)) fail(*cca, "CCA must be within (0, 360] deg");
      if (*radius->value == 0.0) fail(*radius, "R0 in " + what + " CT: the arc needs a radius");
      require_within(*radius->token, *radius->value * mm_per_unit_, -detail::kMaxCoordinateMm, detail::kMaxCoordinateMm, "radius", "mm");
      if (len) fail(*len, "LEN belongs to LT and LN");
    } else {
      if (!len) fail(form_token, what + " " + form + " needs the length LEN");
      if (!(*len->value > 0.0)) fail(*len, "LEN must be positive");
      require_within(*len->token, *len->value * mm_per_unit_, 0.0, detail::kMaxCoordinateMm, "LEN", "mm");
      if (cca) fail(*cca, "CCA belongs to CT");
      if (radius) fail(*radius, "R belongs to CT (and LCT) here; RL / RR name the compensation side");
    }
    std::optional<double> block_feed;
    if (f_word) {
      block_feed = feed_from(*f_word);
      feed_m_per_s_ = block_feed;
    }
    const std::optional<double> feed = block_feed ? block_feed : feed_m_per_s_;
    if (!feed) fail(head, "feed motion before any F: the feed is unknown");
    require_no_pending_corner(head);

    if (approach) {
      if (!side) fail(form_token, "APPR " + form + " needs the radius compensation RL or RR");
      if (compensation_side_) fail(head, "APPR under radius compensation: cancel it (R0) first");
      if (pending_approach_) fail(head, "APPR after APPR: a contour element must follow APPR");
      if (tcp_like()) fail(head, "APPR under M128 / FUNCTION TCPM or in a tilted working plane is not supported");
      if (!xyz[0] || !xyz[1]) fail(form_token, "APPR needs the first contour point's X and Y");
      if (!pos_[0] || !pos_[1] || !pos_[2] || !started_) {
        fail(head, "APPR before the start point PS is known: position the tool first (L X.. Y.. Z.. R0)");
      }
      PendingApproach pending;
      pending.form = form;
      pending.start_mm = Vec3(*pos_[0], *pos_[1], *pos_[2]);
      for (int k = 0; k < 3; ++k) {
        const Word* w = xyz[static_cast<std::size_t>(k)];
        const double v = w ? *w->value * mm_per_unit_ : 0.0;
        pending.contour_mm[k] = !w ? pending.start_mm[k] : (w->incremental ? pending.start_mm[k] + v : v);
      }
      if (len) pending.length_mm = *len->value * mm_per_unit_;
      if (radius) pending.radius_mm = *radius->value * mm_per_unit_;
      if (cca) pending.sweep_deg = *cca->value;
      pending.side = side->address == "RL" ? CompensationSide::left : CompensationSide::right;
      pending.tool_radius_mm = cutter_radius_of(*side);
      // To PH at the feed (or rapid) of the motion before APPR.
      pending.to_auxiliary_rapid = !path_.points.empty() && path_.points.back().kind == MotionKind::rapid;
      pending.to_auxiliary_feed_m_per_s = path_.points.empty() ? feed : std::optional<double>(path_.points.back().feed_m_per_s);
      pending.feed_m_per_s = feed;
      pending.line = line_;
      pending.column = head.column;
      pending.text = line_text_;
      pending.block = add_source_block();
      for (int k = 0; k < 3; ++k) pos_[static_cast<std::size_t>(k)] = pending.contour_mm[k];
      pending_approach_ = pending;
      return;
    }

    // DEP: leaves the compensated contour at PE.
    if (side) fail(*side, "RL / RR in DEP: DEP ends the radius compensation");
    if (!compensation_side_) fail(head, "DEP without radius compensation RL / RR in force");
    if (pending_approach_) fail(head, "DEP right after APPR: no contour element between them");
    if (form != "LCT" && (xyz[0] || xyz[1])) {
      fail(*(xyz[0] ? xyz[0] : xyz[1]), "DEP " + form + " takes no X / Y (only Z, the height after PN)");
    }
    if (form == "LCT" && (!xyz[0] || !xyz[1])) fail(form_token, "DEP LCT needs the end point PN's X and Y");
    if (!last_ || last_->tangent.norm() < 0.5) {
      fail(head, "DEP: the last contour element has no direction in the plane X/Y");
    }
    const Vec2 t = last_->tangent.normalized();
    const double s = *compensation_side_ == CompensationSide::left ? 1.0 : -1.0;
    const double r = compensation_radius_mm_;
    const Vec3 contour_end(*pos_[0], *pos_[1], *pos_[2]);  // PE
    const Vec3 tool = end_compensation(head.column);        // PE + r n
    PathPoint point = new_point(MotionKind::linear, add_source_block());
    point.feed_m_per_s = *feed;
    const Vec2 n = s * left_of(t);
    CompensatedMove move;
    move.start = tool.head<2>();
    move.start_w_mm = move.end_w_mm = tool.z();
    if (form == "LT") {
      move.end = contour_end.head<2>() + (*len->value * mm_per_unit_) * t + r * n;
    } else if (form == "LN") {
      move.end = contour_end.head<2>() + (*len->value * mm_per_unit_ + r) * n;
    } else if (form == "LCT") {
      // An arc of radius R tangent to the contour at PE, turning to the compensation side, then
      // the tangent from it to PN (X Y: the tool centre's end).
      Vec2 pn;
      for (int k = 0; k < 2; ++k) {
        const double v = *xyz[static_cast<std::size_t>(k)]->value * mm_per_unit_;
        pn[k] = xyz[static_cast<std::size_t>(k)]->incremental ? contour_end[k] + v : v;
      }
      const double arc_radius = *radius->value * mm_per_unit_;
      const bool ccw = s > 0.0;
      const Vec2 centre = contour_end.head<2>() + arc_radius * n;
      const double rho = arc_radius - r;
      if (!(rho > 1e-9)) fail(*radius, "the arc radius " + detail::format_number(arc_radius) + " mm is not larger than the tool radius " + detail::format_number(r) + " mm on the arc's inside");
      // Leaving the circle (centre C, radius rho) along a tangent towards PN.
      const Vec2 ph = tangent_point(centre, rho, pn, !ccw, *radius);
      move.arc = true;
      move.centre = centre;
      move.end = ph;
      move.sweep_rad = detail::arc_sweep_rad(move.start, ph, centre, ccw, false);
      emit_tool_centre(move, point);
      move = CompensatedMove{};
      move.start = ph;
      move.end = pn;
      move.start_w_mm = move.end_w_mm = tool.z();
    } else {
      const double arc_radius = *radius->value * mm_per_unit_;
      const bool ccw = s * arc_radius > 0.0;
      const Vec2 centre = contour_end.head<2>() + (ccw ? 1.0 : -1.0) * std::abs(arc_radius) * left_of(t);
      const double sweep = (ccw ? 1.0 : -1.0) * *cca->value * std::numbers::pi / 180.0;
      const double factor = tool_arc_factor(ccw, s, r, arc_radius, *radius);
      const Vec2 rel = contour_end.head<2>() - centre;
      const Vec2 contour_pn = centre + Eigen::Rotation2Dd(sweep) * rel;
      move.arc = true;
      move.centre = centre;
      move.sweep_rad = sweep;
      move.end = centre + factor * (contour_pn - centre);
    }
    emit_tool_centre(move, point);
    Vec3 end(move.end.x(), move.end.y(), tool.z());
    if (xyz[2]) {
      const double v = *xyz[2]->value * mm_per_unit_;
      CompensatedMove lift;
      lift.start = lift.end = move.end;
      lift.start_w_mm = tool.z();
      lift.end_w_mm = end.z() = xyz[2]->incremental ? tool.z() + v : v;
      emit_tool_centre(lift, point);
    }
    for (int k = 0; k < 3; ++k) pos_[static_cast<std::size_t>(k)] = end[k];
    last_.reset();
  }

  /// Where a line through `point` touches the circle (centre, radius_mm) so that a motion
  /// arriving on it goes on counter-clockwise (arriving_ccw) or clockwise; a motion leaving a
  /// counter-clockwise arc for the point is the clockwise arrival's point reversed.
  Vec2 tangent_point(const Vec2& centre, double radius_mm, const Vec2& point, bool arriving_ccw, const Word& word) const {
    const Vec2 d = point - centre;
    const double distance = d.norm();
    if (!(distance > radius_mm + 1e-9)) {
      fail(word, "the point " + detail::format_number(point.x()) + ", " + detail::format_number(point.y()) +
                     " is inside the tool centre's arc (radius " + detail::format_number(radius_mm) +
                     " mm): no tangent line from it");
    }
    const double alpha = std::acos(radius_mm / distance);
    return centre + radius_mm * (Eigen::Rotation2Dd(arriving_ccw ? alpha : -alpha) * (d / distance));
  }

  /// The tool centre's distance from an approach / departure arc's centre over the arc's radius
  /// |R|: the tool r to the compensation side s of an arc turning counter-clockwise or not.
  double tool_arc_factor(bool ccw, double s, double r, double arc_radius, const Word& radius_word) const {
    const double factor = 1.0 - (ccw ? 1.0 : -1.0) * s * r / std::abs(arc_radius);
    if (!(factor > 1e-9)) {
      fail(radius_word, "the arc radius " + detail::format_number(std::abs(arc_radius)) +
                            " mm is not larger than the tool radius " + detail::format_number(r) +
                            " mm on the arc's inside");
    }
    return factor;
  }

  /// APPR, made when the first contour element (start PA, end `end`) comes: the tool centre's
  /// moves to PA + r n, then radius compensation on from there.
  void realise_approach(const Motion& m, const Vec3& contour_start, const Vec3& end) {
    const PendingApproach a = *pending_approach_;
    pending_approach_.reset();
    Vec2 t;
    if (m.kind == "L") {
      t = end.head<2>() - contour_start.head<2>();
    } else {
      const ArcSpec spec = arc_spec(m, contour_start, end);
      if (spec.plane != kPlaneXY) fail(*m.head, "an arc outside the plane X/Y after APPR is not supported");
      const Vec2 radial = contour_start.head<2>() - spec.centre;
      t = spec.ccw ? left_of(radial) : Vec2(-left_of(radial));
    }
    if (t.norm() <= kTinyMm) fail(*m.head, "the first contour element after APPR does not move in the plane X/Y");
    t.normalize();
    const double s = a.side == CompensationSide::left ? 1.0 : -1.0;
    const double r = a.tool_radius_mm;
    const Vec2 n = s * left_of(t);
    const Vec2 pa = a.contour_mm.head<2>();
    const Vec2 tool_at_pa = pa + r * n;
    CompensatedMove approach;  // PH -> PA + r n
    approach.end = tool_at_pa;
    if (a.form == "LT") {
      approach.start = pa - a.length_mm * t + r * n;
    } else if (a.form == "LN") {
      approach.start = pa + (a.length_mm + r) * n;
    } else if (a.form == "LCT") {
      // An arc of radius R tangent to the contour at PA from the compensation side, entered on
      // the tangent from PS (the line PS -> PH touches the tool centre's arc).
      const bool ccw = s > 0.0;
      const Vec2 centre = pa + a.radius_mm * n;
      const double rho = a.radius_mm - r;
      if (!(rho > 1e-9)) {
        line_ = a.line;
        fail(a.column, "APPR LCT: the arc radius " + detail::format_number(a.radius_mm) +
                           " mm is not larger than the tool radius " + detail::format_number(r) + " mm on the arc's inside");
      }
      const Vec2 ps = a.start_mm.head<2>();
      if (!((ps - centre).norm() > rho + 1e-9)) {
        line_ = a.line;
        fail(a.column, "APPR LCT: the start point PS is inside the tool centre's arc (radius " +
                           detail::format_number(rho) + " mm): no tangent line from it");
      }
      const double alpha = std::acos(rho / (ps - centre).norm());
      const Vec2 ph = centre + rho * (Eigen::Rotation2Dd(ccw ? alpha : -alpha) * (ps - centre).normalized());
      approach.arc = true;
      approach.centre = centre;
      approach.start = ph;
      approach.sweep_rad = detail::arc_sweep_rad(ph, tool_at_pa, centre, ccw, false);
    } else {
      const bool ccw = s * a.radius_mm > 0.0;
      const Vec2 centre = pa + (ccw ? 1.0 : -1.0) * std::abs(a.radius_mm) * left_of(t);
      const double sweep = (ccw ? 1.0 : -1.0) * a.sweep_deg * std::numbers::pi / 180.0;
      const double factor = 1.0 - (ccw ? 1.0 : -1.0) * s * r / std::abs(a.radius_mm);
      if (!(factor > 1e-9)) {
        line_ = a.line;
        fail(a.column, "APPR CT: the arc radius " + detail::format_number(std::abs(a.radius_mm)) +
                           " mm is not larger than the tool radius " + detail::format_number(r) +
                           " mm on the arc's inside");
      }
      const Vec2 ph = centre + Eigen::Rotation2Dd(-sweep) * (pa - centre);
      approach.arc = true;
      approach.centre = centre;
      approach.sweep_rad = sweep;
      approach.start = centre + factor * (ph - centre);
    }
    PathPoint to_auxiliary = new_point(a.to_auxiliary_rapid ? MotionKind::rapid : MotionKind::linear, a.block);
    if (!a.to_auxiliary_rapid) to_auxiliary.feed_m_per_s = a.to_auxiliary_feed_m_per_s.value_or(*a.feed_m_per_s);
    CompensatedMove move;
    move.start = a.start_mm.head<2>();
    move.end = approach.start;
    move.start_w_mm = move.end_w_mm = a.start_mm.z();
    emit_tool_centre(move, to_auxiliary);
    if (std::abs(a.contour_mm.z() - a.start_mm.z()) > kTinyMm) {  // to depth at PH
      move.start = move.end;
      move.end_w_mm = a.contour_mm.z();
      PathPoint plunge = to_auxiliary;
      plunge.kind = MotionKind::linear;
      plunge.feed_m_per_s = *a.feed_m_per_s;
      emit_tool_centre(move, plunge);
    }
    PathPoint point = new_point(approach.arc ? MotionKind::arc : MotionKind::linear, a.block);
    point.feed_m_per_s = *a.feed_m_per_s;
    approach.start_w_mm = approach.end_w_mm = a.contour_mm.z();
    emit_tool_centre(approach, point);
    // Compensation on, the tool at PA + r n: the entry (to PA) ends where the contour's offset starts.
    if (pending_corner_) fail(*m.head, "RND / CHF right after APPR");
    compensation_side_ = a.side;
    compensation_radius_mm_ = r;
    compensator_.emplace(a.side, r, tool_at_pa, a.contour_mm.z(), EntryRule::normal_to_next);
    PlaneElement entry;
    entry.start = tool_at_pa;
    entry.end = pa;
    entry.start_w_mm = entry.end_w_mm = a.contour_mm.z();
    entry.tag = next_compensation_tag_++;  // no source: the entry's (zero) move is not emitted
    emit_compensated(compensation_call(a.line, a.column, a.text, [&] { return compensator_->add(entry); }));
  }

  void emit_tool_centre(CompensatedMove move, const PathPoint& point) {
    move.tag = next_compensation_tag_++;
    compensated_sources_[move.tag] = point;
    emit_compensated({move});
  }

  // --- Poses ----------------------------------------------------------------------------------

  PathPoint new_point(MotionKind kind, int block) const {
    PathPoint point;
    point.kind = kind;
    point.block = block;
    point.tool_number = tool_number_;
    if (const auto mm = detail::spindle_tool_length_mm(options_, tool_number_)) point.tool_length_m = *mm * 1e-3;
    point.corner_tolerance_m = corner_tolerance_m_;
    return point;
  }

  int add_source_block() {
    SourceBlock source;
    source.file = file_;
    source.line = line_;
    source.block_number = block_number_;
    source.text = line_text_;
    path_.blocks.push_back(std::move(source));
    return static_cast<int>(path_.blocks.size()) - 1;
  }

  static std::vector<std::pair<char, double>> rotary_words(const RotaryDeg& rotary_deg) {
    std::vector<std::pair<char, double>> words;
    for (std::size_t k = 0; k < 3; ++k) {
      if (rotary_deg[k]) words.emplace_back("ABC"[k], *rotary_deg[k]);
    }
    return words;
  }
  static std::array<double, 3> rotary_words_deg(const RotaryDeg& rotary_deg) {
    std::array<double, 3> words;
    for (std::size_t k = 0; k < 3; ++k) words[k] = rotary_deg[k].value_or(PathPoint::kNotProgrammed);
    return words;
  }

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

  /// The tip in W [mm] of program point p with the tool along `axis_W` (tool-centre-point terms).
  Vec3 tip_W_mm_of(const Vec3& p, const Vec3& axis_W) const {
    return preset_W_mm_ + to_preset(p) + dl_mm_ * axis_W;
  }

  /// The machine axes X Y Z [mm] of program point p outside M128 and planes.
  Vec3 machine_of(const Vec3& p) const {
    return preset_machine_mm_ + to_preset(p) + Vec3(0.0, 0.0, tool_length_mm_ + dl_mm_);
  }

  /// Sets the pose of `point` for program point p [mm] with rotary words `rotary` (and, in
  /// tool-centre-point terms, the axis `axis_W` unless the words give it); `shift_W_mm` moves
  /// the tip in W (LN's DR along the normal).
  void set_pose(PathPoint& point, const Vec3& p, const RotaryDeg& rotary, const Vec3& axis_W,
                const Vec3& shift_W_mm = Vec3::Zero()) const {
    point.rotary_words_deg = rotary_words_deg(rotary);
    if (!tcp_like()) {
      const Vec3 m = machine_of(p);
      if (options_.axis_words_to_pose) {
        std::vector<std::pair<char, double>> words = {{'X', m.x()}, {'Y', m.y()}, {'Z', m.z()}};
        for (const auto& w : rotary_words(rotary)) words.push_back(w);
        const AxisWordPose pose =
            located_call("axis_words_to_pose", [&] { return options_.axis_words_to_pose(words); });
        if (!pose.tip_W_m.allFinite()) {
          fail(0, "axis_words_to_pose gave a tool tip that is not finite for '" + line_text_ + "'");
        }
        point.axis_W = detail::unit_tool_axis(pose.axis_W, file_, line_, 0,
                                              line_text_ + " (through axis_words_to_pose)");
        point.tip_W_m = detail::spindle_tip_W_m(options_, {pose.tip_W_m, point.axis_W},
                                                detail::spindle_tool_length_mm(options_, tool_number_)) +
                        shift_W_mm * kMetresPerMillimetre;
        return;
      }
      const Vec3 gauge_mm = m - Vec3(0.0, 0.0, tool_length_mm_);
      point.tip_W_m = (options_.machine_axes_W * gauge_mm + options_.machine_zero_W_mm + shift_W_mm) *
                      kMetresPerMillimetre;
      point.axis_W = Vec3::UnitZ();
      return;
    }
    point.axis_W = axis_W;
    point.tip_W_m = (tip_W_mm_of(p, axis_W) + shift_W_mm) * kMetresPerMillimetre;
  }

  Vec3 tool_axis_of(const RotaryDeg& rotary, int column) const {
    const auto words = rotary_words(rotary);
    const Vec3 v = located_call("rotary_words_to_tool_axis",
                                [&] { return options_.rotary_words_to_tool_axis(words); });
    return detail::unit_tool_axis(v, file_, line_, column, line_text_ + " (through rotary_words_to_tool_axis)");
  }

  /// Where an axis never programmed is taken: at the G28 reference (the machine's home) with a
  /// set-up and outside tool-centre-point terms, else at the program's 0.
  double start_position(int k) const {
    if (!tcp_like() && !options_.work_offsets_mm.empty()) {
      const Vec3 d = preset_machine_mm_ + to_preset(Vec3::Zero()) + Vec3(0.0, 0.0, tool_length_mm_ + dl_mm_);
      return options_.g28_reference_mm[k] - d[k];
    }
    return 0.0;
  }

  void move(const Motion& m) {
    const bool arc = m.kind == "C" || m.kind == "CR" || m.kind == "CT";
    const bool any_rotary = m.abc[0] || m.abc[1] || m.abc[2];
    const bool any_vector = m.vector[0] || m.vector[1] || m.vector[2];
    const bool any_normal = m.normal[0] || m.normal[1] || m.normal[2];
    if (arc && any_rotary) fail(*m.head, "a change of tool orientation in an arc is not supported");
    if (compensation_side_ && (any_rotary || any_vector)) {
      fail(*m.head, "rotary axis words or a tool vector under radius compensation: cancel it (R0) first");
    }
    if (any_vector && !tcpm_) {
      fail(*m.head, "LN with a tool vector TX TY TZ needs M128 / FUNCTION TCPM");
    }
    if (any_rotary && any_vector) fail(*m.head, "both rotary words and a tool vector in one block");
    if (any_rotary) {
      const Word* w = m.abc[0] ? m.abc[0] : (m.abc[1] ? m.abc[1] : m.abc[2]);
      if (tcp_like() && !options_.rotary_words_to_tool_axis) {
        fail(*w, "rotary words under M128 / a tilted plane need a machine to turn them into a tool "
                 "axis (ReaderOptions::rotary_words_to_tool_axis)");
      }
      if (!tcp_like() && !options_.axis_words_to_pose) {
        fail(*w, "rotary axis words need a machine to turn the axis words into a tool pose "
                 "(ReaderOptions::axis_words_to_pose)");
      }
    }
    if (m.machine && tcp_like()) {
      fail(*m.head, "M91 / M92 under M128 or in a tilted working plane (an error on the TNC too)");
    }
    if (m.machine && arc) fail(*m.head, "M91 / M92 on an arc");

    // Machine coordinates (M91 / M92): the named axes become known in program terms.
    std::array<std::optional<double>, 3> target = pos_;
    if (m.machine) {
      // No tool length compensation: the spindle's gauge point goes to the machine position;
      // in program terms that is the machine position less machine_of(0).
      const Vec3 zero = machine_of(Vec3::Zero());
      for (int k = 0; k < 3; ++k) {
        const Word* w = m.xyz[static_cast<std::size_t>(k)];
        if (!w) continue;
        if (w->incremental) fail(*w, "incremental words with M91 / M92");
        const double machine_mm = *w->value * mm_per_unit_ + (m.m92 ? options_.g28_reference_mm[k] : 0.0);
        target[static_cast<std::size_t>(k)] = machine_mm - zero[k];
      }
    }
    const RotaryDeg start_rotary = rotary_deg_;
    RotaryDeg rotary = rotary_deg_;
    for (int k = 0; k < 3; ++k) {
      const Word* w = m.abc[static_cast<std::size_t>(k)];
      if (!w) continue;
      const double previous = rotary[static_cast<std::size_t>(k)].value_or(0.0);
      const double value = w->incremental ? previous + *w->value : *w->value;
      require_within(*w->token, value, -detail::kMaxRotaryDeg, detail::kMaxRotaryDeg, "rotary axis position", "deg");
      rotary[static_cast<std::size_t>(k)] = value;
    }
    if (any_vector) rotary = {};  // the tool vector, not the words, orients the tool
    if (m.machine && !(target[0] && target[1] && target[2])) {
      // As after G28 / G53: the named axes are known, the pose once all three are.
      pos_ = target;
      rotary_deg_ = rotary;
      if (any_rotary) rotary_unknown_ = false;
      return;
    }
    // The start: axes never programmed at their start position (with a warning).
    Vec3 start;
    for (int k = 0; k < 3; ++k) {
      auto& p = pos_[static_cast<std::size_t>(k)];
      if (!p) {
        const Word* w = m.xyz[static_cast<std::size_t>(k)];
        if (!(w && !w->incremental) && !m.machine) {
          warn(std::string("axis ") + "XYZ"[k] + " has no programmed position before this motion: taken " +
               (!tcp_like() && !options_.work_offsets_mm.empty()
                    ? "at the G28 reference point (the machine's home, where a tool change leaves it)"
                    : "as 0"));
        }
        p = start_position(k);
        if (!target[static_cast<std::size_t>(k)]) target[static_cast<std::size_t>(k)] = p;
      }
      start[k] = *p;
    }
    Vec3 end = start;
    for (int k = 0; k < 3; ++k) {
      if (m.machine) {
        end[k] = *target[static_cast<std::size_t>(k)];
        continue;
      }
      const Word* w = m.xyz[static_cast<std::size_t>(k)];
      if (!w) continue;
      const double v = *w->value * mm_per_unit_;
      end[k] = w->incremental ? start[k] + v : v;
      require_within(*w->token, end[k], -detail::kMaxCoordinateMm, detail::kMaxCoordinateMm, "position", "mm");
    }
    if (arc && !started_) fail(*m.head, "an arc as the first motion: its start point is unknown");

    // The tool axis of this motion.
    Vec3 axis = axis_W_;
    if (any_vector) {
      const Vec3 t(m.vector[0] ? *m.vector[0]->value : 0.0, m.vector[1] ? *m.vector[1]->value : 0.0,
                   m.vector[2] ? *m.vector[2]->value : 0.0);
      axis = plane_R_ * detail::unit_tool_axis(t, file_, line_, m.head->column, line_text_);
    } else if (any_rotary && tcp_like()) {
      axis = tool_axis_of(rotary, m.head->column);
    }
    if (any_rotary) rotary_unknown_ = false;
    if (!tcp_like() && rotary_unknown_ && !any_rotary && axis_W_ != Vec3::UnitZ()) {
      fail(*m.head, "the rotary axes are where PLANE ... TURN put them (the chain's choice, unknown "
                    "to the reader): position them (L A.. C..) before leaving the plane and M128");
    }
    Vec3 shift_W = Vec3::Zero();
    if (m.kind == "LN") {
      if (!any_normal) fail(*m.head, "LN needs the surface normal NX NY NZ");
      const Vec3 n(m.normal[0] ? *m.normal[0]->value : 0.0, m.normal[1] ? *m.normal[1]->value : 0.0,
                   m.normal[2] ? *m.normal[2]->value : 0.0);
      shift_W = dr_mm_ * (plane_R_ * detail::unit_tool_axis(n, file_, line_, m.head->column, line_text_));
    }

    if (pending_approach_) {
      if (m.compensation || m.machine || (m.kind != "L" && m.kind != "C" && m.kind != "CR")) {
        fail(*m.head, "the block after APPR must be the first contour element: L, C or CR without "
                      "RL / RR / R0 or M91 / M92");
      }
      realise_approach(m, start, end);
    }
    // Radius compensation: RL / RR start it on this block (the approach), R0 ends it here.
    const bool cancel = m.compensation && m.compensation->address == "R";
    if (m.compensation && !cancel) start_compensation(*m.compensation, m, start);
    if (cancel && compensation_side_) {
      if (pending_corner_) {
        fail(*m.head, std::string(pending_corner_->chamfer ? "CHF" : "RND") +
                          " before the block with R0 is not supported: R0 leaves the contour");
      }
      if (arc) fail(*m.compensation, "the block with R0 leaves the contour on a straight line L, not an arc");
      // The move to this block's point starts where the compensated contour left the tool.
      start = end_compensation(m.head->column);
    }
    if (compensation_side_) {
      if (m.machine) fail(*m.head, "M91 / M92 under radius compensation: cancel it (R0) first");
      if (m.kind == "LN") fail(*m.head, "LN under radius compensation: cancel it (R0) first");
      compensated_move(m, start, end);
      started_ = true;
      for (int k = 0; k < 3; ++k) pos_[static_cast<std::size_t>(k)] = end[k];
      last_ = moved_element(arc, start, end, rotary_deg_);
      return;
    }

    PathPoint point = new_point(m.rapid ? MotionKind::rapid : (arc ? MotionKind::arc : MotionKind::linear), -1);
    if (!m.rapid) point.feed_m_per_s = *m.feed_m_per_s;
    const std::size_t first_point = path_.points.size();

    if (pending_corner_) {
      if (m.kind != "L" || m.machine) {
        fail(*m.head, std::string(pending_corner_->chamfer ? "CHF" : "RND") +
                          " between a line and an arc, or before a positioning with M91 / M92, is "
                          "not supported: only between two straight lines");
      }
      start = round_corner(start, end, *m.head);
    }
    point.block = add_source_block();
    if (!arc) {
      line_points(point, start, end, start_rotary, rotary, axis, shift_W, *m.head);
    } else {
      arc_motion(point, m, start, end);
    }
    // The block's last point carries the mode; points inside it are no corners.
    for (std::size_t i = first_point; i + 1 < path_.points.size(); ++i) {
      if (path_.points[i].corner_tolerance_m == 0.0) path_.points[i].corner_tolerance_m = PathPoint::kNotProgrammed;
    }
    started_ = true;
    axis_W_ = tcp_like() ? axis : (path_.points.empty() ? axis_W_ : path_.points.back().axis_W);
    rotary_deg_ = rotary;
    if (any_vector) {
      // The tool vector leaves the rotary axes to the chain: unknown to the reader from here.
      rotary_deg_ = {};
      rotary_unknown_ = true;
    }
    for (int k = 0; k < 3; ++k) pos_[static_cast<std::size_t>(k)] = end[k];
    // The element, for CT / RND / CHF.
    LastElement element = moved_element(arc, start, end, rotary);
    element.point_made = path_.points.size() > first_point;
    element.point_index = path_.points.size() - 1;
    last_ = element;
  }

  /// The line or arc just moved from `start` to `end` (program coordinates [mm]), for CT / RND /
  /// CHF and the compensation: an arc's end tangent is arc_end_tangent_ (set by its motion).
  LastElement moved_element(bool arc, const Vec3& start, const Vec3& end, const RotaryDeg& rotary) const {
    LastElement element;
    element.line = !arc;
    element.start = start;
    element.end = end;
    element.rotary = rotary;
    if (!arc) {
      const Vec2 d(end.x() - start.x(), end.y() - start.y());
      element.tangent = d.norm() > kTinyMm ? Vec2(d.normalized()) : Vec2::Zero();
      element.in_plane = std::abs(end.z() - start.z()) <= kTinyMm;
    } else {
      element.tangent = arc_end_tangent_;
    }
    return element;
  }

  /// RND / CHF pending at the corner `corner` (the start of this line to `end`): moves the
  /// previous line's end point back to the first tangent point, makes the rounding arc or the
  /// chamfer, and gives the start of this line (the second tangent point).
  struct CornerGeometry {
    Vec3 p1 = Vec3::Zero(), p2 = Vec3::Zero();  ///< the tangent points on the lines before and after
    Vec2 centre = Vec2::Zero();                 ///< RND: the rounding arc's centre
    bool ccw = false;                           ///< RND: its direction
  };

  /// RND / CHF `pending` at `corner` between the line before (last_) and the line to `end`:
  /// the two tangent points and the rounding arc, in program coordinates [mm].
  CornerGeometry corner_geometry(const PendingCorner& pending, const Vec3& corner, const Vec3& end,
                                 const Token& head) const {
    const std::string name = pending.chamfer ? "CHF" : "RND";
    const LastElement& before = *last_;
    if (!before.in_plane || std::abs(end.z() - corner.z()) > kTinyMm) {
      fail(head, name + " between lines in the working plane X/Y only (this line or the one before "
                        "moves in Z)");
    }
    const Vec2 c2(corner.x(), corner.y());
    const Vec2 a(before.start.x(), before.start.y());
    const Vec2 b(end.x(), end.y());
    const double len1 = (c2 - a).norm(), len2 = (b - c2).norm();
    if (len1 <= kTinyMm || len2 <= kTinyMm) fail(head, name + " next to a line of zero length in X/Y");
    const Vec2 u1 = (c2 - a) / len1, u2 = (b - c2) / len2;
    const double cross = u1.x() * u2.y() - u1.y() * u2.x();
    const double deflection = std::atan2(std::abs(cross), u1.dot(u2));
    if (std::abs(cross) < 1e-12 && u1.dot(u2) > 0.0) fail(head, name + " between collinear lines: no corner");
    if (std::abs(cross) < 1e-12) fail(head, name + " where the contour reverses: no corner to round");
    const double t = pending.chamfer ? pending.size_mm : pending.size_mm * std::tan(0.5 * deflection);
    if (t > len1 + kTinyMm || t > len2 + kTinyMm) {
      fail(head, name + " " + detail::format_number(pending.size_mm) + " mm cuts " +
                     detail::format_number(t) + " mm off each line, more than the lines are long (" +
                     detail::format_number(len1) + " and " + detail::format_number(len2) + " mm)");
    }
    const Vec2 t1 = c2 - t * u1, t2 = c2 + t * u2;
    CornerGeometry geometry;
    geometry.p1 = Vec3(t1.x(), t1.y(), corner.z());
    geometry.p2 = Vec3(t2.x(), t2.y(), corner.z());
    geometry.ccw = cross > 0.0;
    const Vec2 n1 = geometry.ccw ? Vec2(-u1.y(), u1.x()) : Vec2(u1.y(), -u1.x());
    geometry.centre = t1 + pending.size_mm * n1;
    return geometry;
  }

  Vec3 round_corner(const Vec3& corner, const Vec3& end, const Token& head) {
    const PendingCorner pending = *pending_corner_;
    pending_corner_.reset();
    const CornerGeometry geometry = corner_geometry(pending, corner, end, head);
    const Vec3& p1 = geometry.p1;
    const Vec3& p2 = geometry.p2;
    const LastElement& before = *last_;
    // The line before now ends at the first tangent point.
    PathPoint& corner_point = path_.points[before.point_index];
    set_pose(corner_point, p1, before.rotary, corner_point.axis_W);
    const int block = pending.block;
    PathPoint point = new_point(pending.chamfer ? MotionKind::linear : MotionKind::arc, block);
    point.feed_m_per_s = *pending.feed_m_per_s;
    const int saved_line = line_;
    if (pending.chamfer) {
      set_pose(point, p2, rotary_deg_, axis_W_);
      detail::append_point(path_, point, options_, file_, line_);
    } else {
      line_ = pending.line;
      arc_points(point, p1, p2, geometry.centre, geometry.ccw, false, kPlaneXY, pending.column);
      line_ = saved_line;
    }
    return p2;
  }

  void line_points(PathPoint point, const Vec3& start, const Vec3& end, const RotaryDeg& start_rotary,
                   const RotaryDeg& rotary, const Vec3& axis, const Vec3& shift_W, const Token& head) {
    double largest_turn = 0.0;
    for (std::size_t k = 0; k < 3; ++k) {
      if (rotary[k] && start_rotary[k]) largest_turn = std::max(largest_turn, std::abs(*rotary[k] - *start_rotary[k]));
    }
    if (largest_turn < kSplitRotaryTurnDeg) {
      set_pose(point, end, rotary, axis, shift_W);
      detail::append_point(path_, point, options_, file_, line_);
      return;
    }
    const auto steps = static_cast<std::size_t>(std::ceil(largest_turn / kRotaryStepDeg));
    detail::require_room_for_points(path_, steps, options_, file_, line_, head.column,
                                    "the rotary turn of " + detail::format_number(largest_turn) +
                                        " deg (steps of " + detail::format_number(kRotaryStepDeg) + " deg)");
    PathPoint end_point = point;
    set_pose(end_point, end, rotary, axis, shift_W);  // the words as written checked first
    for (std::size_t s = 1; s < steps; ++s) {
      const double t = static_cast<double>(s) / static_cast<double>(steps);
      RotaryDeg r = rotary;
      for (std::size_t k = 0; k < 3; ++k) {
        if (rotary[k] && start_rotary[k]) r[k] = *start_rotary[k] + t * (*rotary[k] - *start_rotary[k]);
      }
      const Vec3 a = tcp_like() && options_.rotary_words_to_tool_axis && !rotary_words(r).empty()
                         ? tool_axis_of(r, head.column)
                         : axis;
      set_pose(point, start + t * (end - start), r, a, t * shift_W);
      detail::append_point(path_, point, options_, file_, line_);
    }
    detail::append_point(path_, end_point, options_, file_, line_);
  }

  double radius_tolerance_mm(double r_mm) const {
    const double absolute_mm = mm_per_unit_ == 1.0
                                   ? options_.arc_radius_tolerance_mm
                                   : options_.arc_radius_tolerance_inch * detail::kMillimetresPerInch;
    return std::max(absolute_mm, options_.arc_radius_relative_tolerance * r_mm);
  }

  /// An arc as programmed: its centre in `plane`, direction and whether it is a full circle.
  struct ArcSpec {
    Vec2 centre = Vec2::Zero();
    bool ccw = false;
    bool full = false;
    PlaneAxes plane = kPlaneXY;
  };

  void arc_motion(PathPoint point, const Motion& m, const Vec3& start, const Vec3& end) {
    const ArcSpec spec = arc_spec(m, start, end);
    arc_points(point, start, end, spec.centre, spec.ccw, spec.full, spec.plane, m.head->column);
  }

  ArcSpec arc_spec(const Motion& m, const Vec3& start, const Vec3& end) const {
    const Token& head = *m.head;
    if (m.kind == "C") {
      if (!pole_mm_) fail(head, "C without a circle centre CC before it");
      const PlaneAxes plane = pole_plane_;
      const Vec2 c((*pole_mm_)[plane[0]], (*pole_mm_)[plane[1]]);
      if (!m.dr) fail(head, "C needs its direction DR+ or DR-");
      const Vec2 s(start[plane[0]], start[plane[1]]), e(end[plane[0]], end[plane[1]]);
      const bool full = (e - s).norm() < detail::kFullCircleDistanceMm;
      return ArcSpec{c, m.dr->sign_only > 0, full, plane};
    }
    const Vec2 s(start.x(), start.y()), e(end.x(), end.y());
    if ((e - s).norm() < detail::kFullCircleDistanceMm) {
      fail(head, m.kind + " cannot be a full circle (end = start): use CC and C");
    }
    if (m.kind == "CR") {
      if (!m.r) fail(head, "CR needs its radius R");
      if (!m.dr) fail(head, "CR needs its direction DR+ or DR-");
      const double r_mm = *m.r->value * mm_per_unit_;
      if (r_mm == 0.0) fail(*m.r, "zero arc radius");
      double short_by = 0.0;
      const bool ccw = m.dr->sign_only > 0;
      const Vec2 c = detail::arc_centre_from_radius(s, e, r_mm, ccw, &short_by);
      const double tolerance = radius_tolerance_mm(0.5 * (e - s).norm());
      if (short_by > tolerance) {
        fail(*m.r, "the radius is smaller than half the distance from start to end (" +
                       detail::format_number(0.5 * (e - s).norm()) + " mm) by " +
                       detail::format_number(short_by) + " mm, more than the tolerance of " +
                       detail::format_number(tolerance) + " mm");
      }
      return ArcSpec{c, ccw, false, kPlaneXY};
    }
    // CT: tangent to the element before at its end.
    if (!last_ || last_->tangent.norm() == 0.0) {
      fail(head, "CT needs a contour element before it with a direction in the plane X/Y");
    }
    const Vec2 t = last_->tangent;
    const Vec2 n(-t.y(), t.x());
    const Vec2 d = e - s;
    const double nd = n.dot(d);
    if (std::abs(nd) <= 1e-12 * d.squaredNorm() || std::abs(nd) < 1e-12) {
      fail(head, "CT: the end point lies on the tangent (a straight line, not an arc)");
    }
    const double r_signed = d.squaredNorm() / (2.0 * nd);
    const Vec2 c = s + r_signed * n;
    return ArcSpec{c, r_signed > 0.0, false, kPlaneXY};
  }

  /// An arc fitted to its start and end: the centre (moved onto the bisector when the radii
  /// differ within the tolerance), radius, start angle and sweep (> 0 counter-clockwise).
  struct ArcFit {
    Vec2 centre = Vec2::Zero();
    double radius_mm = 0.0;
    double r_max_mm = 0.0;  ///< the larger of the start and end radii (a full circle's may differ)
    double a0_rad = 0.0;
    double sweep_rad = 0.0;
  };

  /// Checks and fits the arc from start to end [program mm] about c in `plane`; keeps its end
  /// direction in the plane X/Y for a CT after it.
  ArcFit fit_arc(const Vec3& start, const Vec3& end, Vec2 c, bool ccw, bool full_circle,
                 const PlaneAxes& plane, int column) {
    const int u = plane[0], v = plane[1];
    const Vec2 s(start[u], start[v]), e(end[u], end[v]);
    double r_start = (s - c).norm(), r_end = (e - c).norm();
    if (r_start == 0.0) fail(column, "an arc of zero radius (the centre is the start point)");
    const double tolerance = radius_tolerance_mm(std::max(r_start, r_end));
    if (std::abs(r_start - r_end) > tolerance) {
      fail(column, "'" + line_text_ + "': the arc's start and end are not at the same distance from its "
                   "centre: start radius " + detail::format_number(r_start) + " mm, end radius " +
                   detail::format_number(r_end) + " mm, more than the tolerance of " +
                   detail::format_number(tolerance) + " mm apart");
    }
    if (!full_circle && r_start != r_end) {
      c = detail::centre_on_bisector(s, e, c);
      r_start = r_end = (s - c).norm();
    }
    ArcFit fit;
    fit.r_max_mm = std::max(r_start, r_end);
    fit.centre = c;
    fit.radius_mm = r_start;
    fit.a0_rad = std::atan2(s.y() - c.y(), s.x() - c.x());
    fit.sweep_rad = detail::arc_sweep_rad(s, e, c, ccw, full_circle);
    const double a1 = fit.a0_rad + fit.sweep_rad;
    const Vec2 radial(std::cos(a1), std::sin(a1));
    const Vec2 tangent = ccw ? Vec2(-radial.y(), radial.x()) : Vec2(radial.y(), -radial.x());
    arc_end_tangent_ = plane == kPlaneXY ? tangent : Vec2::Zero();
    return fit;
  }

  /// The points of an arc from start to end [program mm] about centre c in `plane`, tessellated
  /// as G2/G3 (detail arc helpers); motion along the plane normal makes a helix.
  void arc_points(PathPoint point, const Vec3& start, const Vec3& end, Vec2 c, bool ccw,
                  bool full_circle, const PlaneAxes& plane, int column) {
    const int u = plane[0], v = plane[1], w = plane[2];
    const ArcFit fit = fit_arc(start, end, c, ccw, full_circle, plane, column);
    c = fit.centre;
    const double r_start = fit.radius_mm, a0 = fit.a0_rad, sweep = fit.sweep_rad;
    const double r_max = fit.r_max_mm;
    const double chord_mm = options_.arc_chord_tolerance_m / kMetresPerMillimetre;
    const double count = detail::arc_chord_count(r_max, sweep, chord_mm);
    const std::string what = "the arc (radius " + detail::format_number(r_max) + " mm, " +
                             detail::format_number(std::abs(sweep) * kDegPerRad) +
                             " deg, chord tolerance " + detail::format_number(chord_mm) + " mm)";
    if (!(count <= static_cast<double>(options_.max_points_per_block))) {
      fail(column, what + " expands to " + detail::format_number(count) +
                       " points, more than the limit of " + std::to_string(options_.max_points_per_block) +
                       " points per block (ReaderOptions::max_points_per_block)");
    }
    const auto segments = static_cast<long>(count);
    detail::require_room_for_points(path_, static_cast<std::size_t>(segments), options_, file_, line_, column, what);
    for (long k = 1; k <= segments; ++k) {
      Vec3 p = end;
      if (k < segments) {
        const double t = static_cast<double>(k) / static_cast<double>(segments);
        const double angle = a0 + t * sweep;
        p[u] = c.x() + r_start * std::cos(angle);
        p[v] = c.y() + r_start * std::sin(angle);
        p[w] = start[w] + t * (end[w] - start[w]);
      }
      set_pose(point, p, rotary_deg_, axis_W_);
      detail::append_point(path_, point, options_, file_, line_);
    }
  }

  std::string file_;  // the file running (CALL PGM: the called one)
  const ReaderOptions& options_;
  Toolpath path_;
  int line_ = 0;
  std::string line_text_;
  long block_number_ = -1;
  bool ended_ = false;
  bool started_ = false;
  int warning_count_ = 0;

  double mm_per_unit_ = 1.0;
  std::map<std::string, double> q_;
  std::optional<Vec3> blank_min_mm_;
  // Tool.
  int tool_number_ = -1;
  double tool_length_mm_ = 0.0;
  double dl_mm_ = 0.0, dr_mm_ = 0.0;
  std::optional<double> auto_feed_m_per_s_;
  std::optional<double> feed_m_per_s_;
  double corner_tolerance_m_ = PathPoint::kNotProgrammed;
  bool in_datum_cycle_ = false, tolerance_cycle_ = false;
  // Frames.
  Vec3 preset_machine_mm_ = Vec3::Zero();
  Vec3 preset_W_mm_ = Vec3::Zero();
  Vec3 shift_before_mm_ = Vec3::Zero(), shift_after_mm_ = Vec3::Zero();
  bool plane_active_ = false;
  Eigen::Matrix3d plane_R_ = Eigen::Matrix3d::Identity();
  bool tcpm_ = false;
  // Position and contour.
  std::array<std::optional<double>, 3> pos_;  ///< program coordinates [mm]
  RotaryDeg rotary_deg_;
  bool rotary_unknown_ = false;  ///< after PLANE TURN: the axes are the chain's choice
  Vec3 axis_W_ = Vec3::UnitZ();
  std::optional<Vec3> pole_mm_;
  PlaneAxes pole_plane_ = kPlaneXY;
  Vec2 arc_end_tangent_ = Vec2::Zero();
  std::optional<PendingCorner> pending_corner_;
  std::optional<LastElement> last_;
  // Radius compensation RL / RR.
  struct HeldElement {
    PlaneElement element;
    int line = 0;       ///< where it was programmed, for messages
    int column = 0;
    std::string text;
  };
  std::optional<CompensationSide> compensation_side_;
  std::optional<CutterCompensator> compensator_;  // from the block with RL / RR to R0
  std::optional<HeldElement> held_;               // the last element, not yet given to the compensator
  std::map<int, PathPoint> compensated_sources_;  // by element tag, until its moves are made
  int next_compensation_tag_ = 0;
  double compensation_radius_mm_ = 0.0;
  // APPR: read, made once the first contour element (the next motion) gives its tangent at PA.
  struct PendingApproach {
    std::string form;          ///< LT, LN, CT or LCT
    Vec3 contour_mm = Vec3::Zero();  ///< PA, the first contour point [program mm]
    Vec3 start_mm = Vec3::Zero();    ///< PS, where the tool centre is
    double length_mm = 0.0;    ///< LEN
    double radius_mm = 0.0;    ///< CT: R (signed); LCT: R
    double sweep_deg = 0.0;    ///< CT: CCA
    CompensationSide side = CompensationSide::left;
    double tool_radius_mm = 0.0;
    bool to_auxiliary_rapid = false;
    std::optional<double> to_auxiliary_feed_m_per_s, feed_m_per_s;
    int line = 0, column = 0, block = -1;
    std::string text;
  };
  std::optional<PendingApproach> pending_approach_;
  // Machining cycles.
  std::optional<MachiningCycle> cycle_definition_;
  bool defining_cycle_ = false;  ///< its parameter lines may follow
  bool modal_cycle_call_ = false;  ///< M89
  // PATTERN DEF: its points (program coordinates), its elements may follow on the next lines.
  static constexpr double kMaxPatternPoints = 100000.0;
  std::vector<PatternPoint> pattern_;
  bool defining_pattern_ = false;
  // Programs and calls.
  std::vector<std::unique_ptr<Program>> programs_;
  std::map<std::string, std::size_t> program_index_;  ///< CALL PGM's files by path
  std::vector<Frame> frames_;
  std::map<std::pair<std::size_t, std::size_t>, long> section_repeats_;  ///< (program, CALL line) -> repeats left
  bool jumped_ = false;  ///< blocks are counted from the first jump on
  std::size_t executed_blocks_ = 0;
};

}  // namespace

Toolpath parse_heidenhain(const std::string& text, const std::string& file_name_for_messages,
                          const ReaderOptions& options) {
  HeidenhainReader reader(file_name_for_messages, options);
  return detail::read_with_located_errors(reader, text, file_name_for_messages);
}

Toolpath read_heidenhain(const std::string& path, const ReaderOptions& options) {
  if (!options.subprogram_folder.empty()) return parse_heidenhain(detail::read_text_file(path), path, options);
  // CALL PGM looks for its file beside the program.
  ReaderOptions with_folder = options;
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  with_folder.subprogram_folder = folder.empty() ? "." : folder.string();
  return parse_heidenhain(detail::read_text_file(path), path, with_folder);
}

}  // namespace vmsim::toolpath
