// Siemens Sinumerik 840D reader: the subset documented in vmsim/toolpath/toolpath.hpp
// ("Siemens 840D subset"). One pass runs the program as the control does: the language (R
// parameters, DEF variables, expressions, IF / WHILE / FOR / REPEAT / LOOP, GOTOF / GOTOB,
// L subprograms) and the blocks it reaches, in order.
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "canned_cycles.hpp"
#include "toolpath_detail.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/cutter_compensation.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

using detail::kMetresPerMillimetre;
using detail::kMillimetresPerInch;
using detail::kSecondsPerMinute;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

constexpr double kDegToRad = std::numbers::pi / 180.0;
constexpr double kFullCircleDistanceMm = 1e-9;
constexpr double kSplitRotaryTurnDeg = 180.0;
constexpr double kRotaryStepDeg = 90.0;
constexpr int kMaxWarnings = 1000;

bool is_ident_start(char c) {
  return std::isalpha(static_cast<unsigned char>(c)) || c == '_' || c == '$';
}
bool is_ident_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '$';
}

/// An affine map p -> L p + t [mm]: a frame (translation, rotation, mirror).
struct Affine {
  Mat3 L = Mat3::Identity();
  Vec3 t = Vec3::Zero();
  Vec3 apply(const Vec3& p) const { return L * p + t; }
  /// This map after `inner`: p -> this(inner(p)).
  Affine after(const Affine& inner) const { return Affine{L * inner.L, L * inner.t + t}; }
  Affine inverse() const {
    const Mat3 Li = L.inverse();
    return Affine{Li, -(Li * t)};
  }
  bool identity() const { return L == Mat3::Identity() && t == Vec3::Zero(); }
};

Mat3 rotation_about(int axis, double angle_deg) {
  return Eigen::AngleAxisd(angle_deg * kDegToRad, Vec3::Unit(axis)).toRotationMatrix();
}

enum class Plane { xy, zx, yz };
std::array<int, 3> plane_axes(Plane plane) {
  switch (plane) {
    case Plane::xy: return {0, 1, 2};
    case Plane::zx: return {2, 0, 1};
    case Plane::yz: return {1, 2, 0};
  }
  return {0, 1, 2};
}

/// A value of a word: a number (with AC / IC where written), or a string ("T="EM10"").
struct Value {
  double number = 0.0;
  enum class Dimension { modal, absolute, incremental } dimension = Dimension::modal;
  std::optional<std::string> text;
};

/// One word of a block after its expressions are evaluated.
struct Word {
  std::string address;  ///< upper case: "X", "A3", "G", "TRAORI", "CYCLE832", "R1"
  bool has_value = false;
  Value value;
  std::vector<std::optional<Value>> arguments;  ///< KEYWORD(a, , c): empty ones nullopt
  bool has_arguments = false;
  bool assignment = false;  ///< NAME=value where NAME is a variable (R1=, DEF'd names)
  int column = 0;
  std::string text;
  double number() const { return value.number; }
};

/// One program (the main program or a subprogram file): its lines, labels and the matching
/// lines of its control structures.
struct Program {
  std::string file;
  std::vector<std::string> lines;
  std::map<std::string, std::size_t> labels;  ///< LABEL: and N numbers ("N100") -> line index
  std::map<std::size_t, std::size_t> partner;  ///< IF -> ELSE/ENDIF, ELSE -> ENDIF, WHILE <-> ENDWHILE, ...
};

/// The first keyword of a line and where it starts (after an N number and a label).
struct LineHead {
  std::string keyword;
  std::size_t position = 0;  ///< index of the keyword in the line
  bool has_goto = false;     ///< the line holds GOTOF / GOTOB / GOTO (single-line IF)
};

std::string strip_comment(std::string_view line) {
  bool in_string = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    if (line[i] == '"') in_string = !in_string;
    if (!in_string && line[i] == ';') return std::string(line.substr(0, i));
  }
  return std::string(line);
}

LineHead line_head(std::string_view line) {
  LineHead head;
  std::size_t i = 0;
  const auto skip = [&] { while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i; };
  skip();
  // Block number N123 or :123.
  if (i + 1 < line.size() && (line[i] == 'N' || line[i] == 'n' || line[i] == ':') &&
      std::isdigit(static_cast<unsigned char>(line[i + 1]))) {
    ++i;
    while (i < line.size() && std::isdigit(static_cast<unsigned char>(line[i]))) ++i;
    skip();
  }
  std::size_t start = i;
  while (i < line.size() && is_ident_char(line[i])) ++i;
  if (i > start && i < line.size() && line[i] == ':' && is_ident_start(line[start])) {
    ++i;  // a label
    skip();
    start = i;
    while (i < line.size() && is_ident_char(line[i])) ++i;
  }
  head.keyword = detail::to_upper(line.substr(start, i - start));
  head.position = start;
  const std::string upper = detail::to_upper(line);
  for (const char* g : {"GOTOF", "GOTOB", "GOTO"}) {
    const std::size_t at = upper.find(g, start);
    if (at != std::string::npos && (at == 0 || !is_ident_char(upper[at - 1]))) head.has_goto = true;
  }
  return head;
}

class SiemensReader {
 public:
  SiemensReader(const std::string& file, const ReaderOptions& options)
      : file_(file), options_(options) {}

  int current_line() const { return line_; }

  Toolpath read(std::string_view text) {
    if (!(options_.arc_chord_tolerance_m >= 1e-12) || !std::isfinite(options_.arc_chord_tolerance_m)) {
      throw InputError("ReaderOptions::arc_chord_tolerance_m must be at least 1e-12 m and finite, got " +
                       detail::format_number(options_.arc_chord_tolerance_m));
    }
    offsets_mm_ = options_.work_offsets_mm;
    implicit_g54_ = offsets_mm_.empty();
    const auto initial = offset_named(options_.initial_work_offset);
    if (!initial) {
      throw InputError("ReaderOptions::initial_work_offset " + options_.initial_work_offset +
                       " is not in the work offset table (" + offset_list() + ")");
    }
    offset_ = *initial;
    text = detail::without_byte_order_mark(text);
    detail::require_utf8_text(text, file_);
    programs_.push_back(load_program(std::string(text), file_));
    run(0);
    if (compensator_) {
      warn("cutter compensation is still on at the end of the program (no G40): its last element ends at its "
           "offset end");
      end_compensation(nullptr);
    }
    detail::require_motion(path_, file_);
    return std::move(path_);
  }

 private:
  // --- Errors and warnings ---------------------------------------------------------------------

  [[noreturn]] void fail(int column, const std::string& message) const {
    throw InputError(located_message(current_file(), line_, column, message));
  }
  [[noreturn]] void fail(const Word& word, const std::string& message) const {
    fail(word.column, "'" + word.text + "': " + message);
  }
  const std::string& current_file() const {
    return calls_.empty() ? file_ : programs_[calls_.back().program].file;
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
    ++warning_count_;
    if (warning_count_ < kMaxWarnings) {
      path_.warnings.push_back(ReaderWarning{current_file(), line_, message});
    } else if (warning_count_ == kMaxWarnings) {
      path_.warnings.push_back(ReaderWarning{current_file(), line_,
                                             "more than " + std::to_string(kMaxWarnings) +
                                                 " warnings: the rest are not listed"});
    }
  }
  void require_within(const Word& word, double value, double min, double max, const std::string& what,
                      const std::string& unit) const {
    if (!(value >= min && value <= max)) {
      fail(word, what + " " + detail::format_number(value) + " " + unit + " is outside [" +
                     detail::format_number(min) + ", " + detail::format_number(max) + "] " + unit);
    }
  }

  // --- Programs and control flow -------------------------------------------------------------

  Program load_program(const std::string& text, const std::string& file) {
    Program program;
    program.file = file;
    std::size_t start = 0;
    while (start <= text.size()) {
      std::size_t end = text.find('\n', start);
      if (end == std::string::npos) end = text.size();
      std::string line = text.substr(start, end - start);
      if (!line.empty() && line.back() == '\r') line.pop_back();
      program.lines.push_back(std::move(line));
      if (end == text.size()) break;
      start = end + 1;
    }
    // Labels, block numbers and the partners of control structures.
    struct Open { std::string keyword; std::size_t line; };
    std::vector<Open> open;
    const int saved_line = line_;
    for (std::size_t i = 0; i < program.lines.size(); ++i) {
      line_ = static_cast<int>(i) + 1;
      const std::string code = strip_comment(program.lines[i]);
      std::size_t k = 0;
      while (k < code.size() && std::isspace(static_cast<unsigned char>(code[k]))) ++k;
      if (k + 1 < code.size() && (code[k] == 'N' || code[k] == 'n') &&
          std::isdigit(static_cast<unsigned char>(code[k + 1]))) {
        std::size_t e = k + 1;
        while (e < code.size() && std::isdigit(static_cast<unsigned char>(code[e]))) ++e;
        program.labels.emplace("N" + std::to_string(std::stol(code.substr(k + 1, e - k - 1))), i);
        k = e;
        while (k < code.size() && std::isspace(static_cast<unsigned char>(code[k]))) ++k;
      }
      std::size_t e = k;
      while (e < code.size() && is_ident_char(code[e])) ++e;
      if (e > k && e < code.size() && code[e] == ':' && is_ident_start(code[k])) {
        program.labels.emplace(detail::to_upper(code.substr(k, e - k)), i);
      }
      const LineHead head = line_head(code);
      const std::string& key = head.keyword;
      const auto close = [&](const char* opener, const char* closer) {
        if (open.empty() || open.back().keyword != opener) {
          throw InputError(located_message(file, line_, static_cast<int>(head.position) + 1,
                                           std::string(closer) + " without its " + opener));
        }
        program.partner[open.back().line] = i;
        program.partner[i] = open.back().line;
        open.pop_back();
      };
      if ((key == "IF" && !head.has_goto) || key == "WHILE" || key == "FOR" || key == "REPEAT" ||
          key == "LOOP") {
        open.push_back({key, i});
      } else if (key == "ELSE") {
        if (open.empty() || open.back().keyword != "IF") {
          throw InputError(located_message(file, line_, static_cast<int>(head.position) + 1, "ELSE without its IF"));
        }
        program.partner[open.back().line] = i;  // IF -> ELSE; ELSE -> ENDIF below
        open.back() = {"ELSE", i};
      } else if (key == "ENDIF") {
        if (!open.empty() && open.back().keyword == "ELSE") {
          program.partner[open.back().line] = i;
          open.pop_back();
        } else {
          close("IF", "ENDIF");
        }
      } else if (key == "ENDWHILE") {
        close("WHILE", "ENDWHILE");
      } else if (key == "ENDFOR") {
        close("FOR", "ENDFOR");
      } else if (key == "UNTIL") {
        close("REPEAT", "UNTIL");
      } else if (key == "ENDLOOP") {
        close("LOOP", "ENDLOOP");
      }
    }
    if (!open.empty()) {
      line_ = static_cast<int>(open.back().line) + 1;
      throw InputError(located_message(file, line_, 0,
                                       open.back().keyword + " without its end (" +
                                           (open.back().keyword == "IF" || open.back().keyword == "ELSE" ? "ENDIF"
                                            : open.back().keyword == "WHILE" ? "ENDWHILE"
                                            : open.back().keyword == "FOR"   ? "ENDFOR"
                                            : open.back().keyword == "REPEAT" ? "UNTIL"
                                                                             : "ENDLOOP") +
                                           ")"));
    }
    line_ = saved_line;
    return program;
  }

  struct Call {
    std::size_t program = 0;
    std::size_t pc = 0;
    long repeats_left = 0;
    std::map<std::string, double> locals;  ///< DEF variables of this program level
    std::map<std::size_t, double> for_end;  ///< FOR line -> its end value
  };

  void count_block() {
    if (!jumped_) return;
    if (++executed_blocks_ > options_.max_executed_blocks) {
      fail(0, "more than " + std::to_string(options_.max_executed_blocks) +
                  " blocks run (ReaderOptions::max_executed_blocks): a loop that never ends?");
    }
  }

  void run(std::size_t program_index) {
    calls_.push_back(Call{program_index, 0, 0, {}, {}});
    while (!calls_.empty() && !ended_) {
      Call& call = calls_.back();
      const Program& program = programs_[call.program];
      if (call.pc >= program.lines.size()) {
        // The end of a subprogram file returns (M17 / RET are the rule); the main program ends.
        if (!return_from_call()) break;
        continue;
      }
      const std::size_t pc = call.pc;
      line_ = static_cast<int>(pc) + 1;
      line_text_ = detail::trim(program.lines[pc]);
      count_block();
      call.pc = pc + 1;
      execute_line(program, pc);
    }
  }

  /// Returns true when a caller continues, false when the main program ends.
  bool return_from_call() {
    Call& call = calls_.back();
    if (call.repeats_left > 0) {
      --call.repeats_left;
      call.pc = 0;
      call.locals.clear();
      return true;
    }
    calls_.pop_back();
    return !calls_.empty();
  }

  void jump_to(const std::string& target, int direction, int column) {
    jumped_ = true;
    Call& call = calls_.back();
    const Program& program = programs_[call.program];
    const auto it = program.labels.find(detail::to_upper(target));
    if (it == program.labels.end()) fail(column, "jump target '" + target + "' is not in the program");
    const std::size_t here = call.pc - 1;
    if (direction > 0 && it->second <= here) fail(column, "GOTOF '" + target + "': the target is not after this block");
    if (direction < 0 && it->second > here) fail(column, "GOTOB '" + target + "': the target is not before this block");
    call.pc = it->second;
  }

  void execute_line(const Program& program, std::size_t pc) {
    std::string code = strip_comment(program.lines[pc]);
    std::size_t i = 0;
    while (i < code.size() && std::isspace(static_cast<unsigned char>(code[i]))) ++i;
    if (i >= code.size()) return;
    if (code[i] == '%') return;  // %_N_NAME_MPF header
    if (code[i] == '/') {
      warn("block skipped: block delete '/' is taken as switched on");
      return;
    }
    const LineHead head = line_head(code);
    const std::string& key = head.keyword;
    Call& call = calls_.back();
    Lexer lex(code, head.position + key.size());
    const int key_column = static_cast<int>(head.position) + 1;
    if (key == "IF") {
      const double condition = expression(lex);
      if (head.has_goto) {
        const std::string jump = lex.identifier();
        const std::string target = lex.identifier_or_number();
        if (condition != 0.0) jump_to(target, jump == "GOTOF" ? 1 : jump == "GOTOB" ? -1 : 0, key_column);
        return;
      }
      jumped_ = true;
      if (condition == 0.0) {
        const std::size_t other = program.partner.at(pc);
        const bool is_else = line_head(strip_comment(program.lines[other])).keyword == "ELSE";
        call.pc = other + (is_else ? 1 : 0);
      }
      return;
    }
    if (key == "ELSE") {
      call.pc = program.partner.at(pc) + 1;
      return;
    }
    if (key == "ENDIF" || key == "REPEAT" || key == "LOOP") return;
    if (key == "WHILE") {
      jumped_ = true;
      if (expression(lex) == 0.0) call.pc = program.partner.at(pc) + 1;
      return;
    }
    if (key == "ENDWHILE" || key == "ENDLOOP") {
      call.pc = program.partner.at(pc) + (key == "ENDLOOP" ? 1 : 0);
      return;
    }
    if (key == "UNTIL") {
      if (expression(lex) == 0.0) call.pc = program.partner.at(pc) + 1;
      return;
    }
    if (key == "FOR") {
      jumped_ = true;
      const std::string name = lex.identifier();
      if (!lex.take('=')) fail(key_column, "FOR needs 'variable = start TO end'");
      const double start = expression(lex);
      if (lex.identifier() != "TO") fail(key_column, "FOR needs 'variable = start TO end'");
      const double end = expression(lex);
      assign(name, start, key_column);
      call.for_end[pc] = end;
      if (!(start <= end)) call.pc = program.partner.at(pc) + 1;
      return;
    }
    if (key == "ENDFOR") {
      const std::size_t for_line = program.partner.at(pc);
      const LineHead for_head = line_head(strip_comment(program.lines[for_line]));
      Lexer l2(strip_comment(program.lines[for_line]), for_head.position + 3);
      const std::string name = l2.identifier();
      const double value = variable(name, key_column) + 1.0;
      assign(name, value, key_column);
      if (value <= call.for_end[for_line]) call.pc = for_line + 1;
      return;
    }
    if (key == "GOTOF" || key == "GOTOB" || key == "GOTO" || key == "GOTOC") {
      const std::string target = lex.identifier_or_number();
      jump_to(target, key == "GOTOF" ? 1 : key == "GOTOB" ? -1 : 0, key_column);
      return;
    }
    if (key == "DEF") {
      define(lex, key_column);
      return;
    }
    if (key == "PROC") return;  // a subprogram's header: its parameters are not supported
    if (key == "RET") {
      if (!return_from_call()) ended_ = true;
      return;
    }
    block(code);
  }

  // --- Expressions ---------------------------------------------------------------------------

  /// Reads a line left to right: identifiers, numbers, strings, operators.
  class Lexer {
   public:
    Lexer(std::string text, std::size_t position) : text_(std::move(text)), i_(position) {}
    void skip() { while (i_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[i_]))) ++i_; }
    bool at_end() { skip(); return i_ >= text_.size(); }
    char peek() { skip(); return i_ < text_.size() ? text_[i_] : '\0'; }
    char peek_raw() const { return i_ < text_.size() ? text_[i_] : '\0'; }
    char peek_raw(std::size_t ahead) const { return i_ + ahead < text_.size() ? text_[i_ + ahead] : '\0'; }
    bool take(char c) {
      if (peek() == c) { ++i_; return true; }
      return false;
    }
    bool take(std::string_view s) {
      skip();
      if (text_.compare(i_, s.size(), s) == 0) { i_ += s.size(); return true; }
      return false;
    }
    std::string identifier() {
      skip();
      const std::size_t start = i_;
      while (i_ < text_.size() && is_ident_char(text_[i_])) ++i_;
      return detail::to_upper(std::string_view(text_).substr(start, i_ - start));
    }
    std::string identifier_or_number() { return identifier(); }
    /// An unsigned decimal number; nullopt when none starts here.
    std::optional<std::string> number_text() {
      skip();
      const std::size_t start = i_;
      while (i_ < text_.size() && (std::isdigit(static_cast<unsigned char>(text_[i_])) || text_[i_] == '.')) ++i_;
      if (i_ < text_.size() && (text_[i_] == 'E' || text_[i_] == 'e') && i_ > start) {
        // 1.5EX3 is Siemens' exponent form; a plain E is not read (EX is).
        if (i_ + 1 < text_.size() && (text_[i_ + 1] == 'X' || text_[i_ + 1] == 'x')) {
          std::size_t j = i_ + 2;
          if (j < text_.size() && (text_[j] == '+' || text_[j] == '-')) ++j;
          const std::size_t digits = j;
          while (j < text_.size() && std::isdigit(static_cast<unsigned char>(text_[j]))) ++j;
          if (j > digits) {
            std::string mantissa = text_.substr(start, i_ - start);
            std::string exponent = text_.substr(i_ + 2, j - i_ - 2);
            i_ = j;
            return mantissa + "e" + exponent;
          }
        }
      }
      if (i_ == start) return std::nullopt;
      return text_.substr(start, i_ - start);
    }
    std::optional<std::string> string_literal() {
      skip();
      if (i_ >= text_.size() || text_[i_] != '"') return std::nullopt;
      const std::size_t close = text_.find('"', i_ + 1);
      if (close == std::string::npos) return std::nullopt;
      std::string s = text_.substr(i_ + 1, close - i_ - 1);
      i_ = close + 1;
      return s;
    }
    std::size_t position() const { return i_; }
    void set_position(std::size_t i) { i_ = i; }
    const std::string& text() const { return text_; }

   private:
    std::string text_;
    std::size_t i_ = 0;
  };

  int column_of(const Lexer& lex) const { return static_cast<int>(lex.position()) + 1; }

  double parse_number(Lexer& lex, const std::string& written) const {
    std::string problem;
    const auto value = detail::parse_decimal(written, &problem);
    if (!value) fail(column_of(lex), "'" + written + "': " + problem);
    return *value;
  }

  static bool is_word_boundary_keyword(const std::string& name) {
    return name == "AND" || name == "OR" || name == "XOR" || name == "DIV" || name == "MOD" ||
           name == "NOT" || name == "TO" || name == "GOTOF" || name == "GOTOB" || name == "GOTO" ||
           name == "B_AND" || name == "B_OR" || name == "B_XOR";
  }

  /// expression: or-level (OR XOR), then AND, comparisons, + -, * / DIV MOD, unary, primary.
  double expression(Lexer& lex) {
    double left = and_level(lex);
    while (true) {
      const std::size_t at = lex.position();
      const std::string op = peek_operator_word(lex);
      if (op == "OR") { lex.identifier(); const double r = and_level(lex); left = (left != 0.0 || r != 0.0) ? 1.0 : 0.0; }
      else if (op == "XOR") { lex.identifier(); const double r = and_level(lex); left = ((left != 0.0) != (r != 0.0)) ? 1.0 : 0.0; }
      else { lex.set_position(at); return left; }
    }
  }
  std::string peek_operator_word(Lexer& lex) {
    const std::size_t at = lex.position();
    lex.skip();
    if (!is_ident_start(lex.peek_raw())) return "";
    const std::string word = lex.identifier();
    lex.set_position(at);
    return word;
  }
  double and_level(Lexer& lex) {
    double left = comparison(lex);
    while (peek_operator_word(lex) == "AND") {
      lex.identifier();
      const double r = comparison(lex);
      left = (left != 0.0 && r != 0.0) ? 1.0 : 0.0;
    }
    return left;
  }
  double comparison(Lexer& lex) {
    double left = sum(lex);
    while (true) {
      if (lex.take("==")) left = left == sum(lex) ? 1.0 : 0.0;
      else if (lex.take("<>")) left = left != sum(lex) ? 1.0 : 0.0;
      else if (lex.take(">=")) left = left >= sum(lex) ? 1.0 : 0.0;
      else if (lex.take("<=")) left = left <= sum(lex) ? 1.0 : 0.0;
      else if (lex.take('>')) left = left > sum(lex) ? 1.0 : 0.0;
      else if (lex.take('<')) left = left < sum(lex) ? 1.0 : 0.0;
      else return left;
    }
  }
  double sum(Lexer& lex) {
    double left = product(lex);
    while (true) {
      if (lex.take('+')) left += product(lex);
      else if (lex.take('-')) left -= product(lex);
      else return left;
    }
  }
  double product(Lexer& lex) {
    double left = unary(lex);
    while (true) {
      const int column = column_of(lex);
      if (lex.take('*')) {
        left *= unary(lex);
      } else if (lex.take('/')) {
        const double r = unary(lex);
        if (r == 0.0) fail(column, "division by zero");
        left /= r;
      } else {
        const std::string op = peek_operator_word(lex);
        if (op != "DIV" && op != "MOD") return left;
        lex.identifier();
        const double r = unary(lex);
        if (r == 0.0) fail(column, op + " by zero");
        left = op == "DIV" ? std::trunc(std::trunc(left) / std::trunc(r)) : std::fmod(left, r);
      }
    }
  }
  double unary(Lexer& lex) {
    if (lex.take('-')) return -unary(lex);
    if (lex.take('+')) return unary(lex);
    if (peek_operator_word(lex) == "NOT") {
      lex.identifier();
      return unary(lex) == 0.0 ? 1.0 : 0.0;
    }
    return primary(lex);
  }
  double primary(Lexer& lex) {
    const int column = column_of(lex) + 1;
    if (lex.take('(')) {
      const double v = expression(lex);
      if (!lex.take(')')) fail(column, "')' missing in the expression");
      return v;
    }
    if (const auto number = lex.number_text()) return parse_number(lex, *number);
    lex.skip();
    if (!is_ident_start(lex.peek_raw())) {
      fail(column_of(lex), lex.at_end() ? "an expression is missing" :
                                          "unexpected '" + std::string(1, lex.peek_raw()) + "' in an expression");
    }
    const int name_column = column_of(lex);
    const std::string name = lex.identifier();
    if (lex.take('(')) return function(lex, name, name_column);
    return variable(name, name_column);
  }
  double function(Lexer& lex, const std::string& name, int column) {
    std::vector<double> args;
    if (!lex.take(')')) {
      do { args.push_back(expression(lex)); } while (lex.take(','));
      if (!lex.take(')')) fail(column, name + "(: ')' missing");
    }
    const auto need = [&](std::size_t n) {
      if (args.size() != n) fail(column, name + " takes " + std::to_string(n) + " argument(s)");
    };
    double result = 0.0;
    if (name == "SIN") { need(1); result = std::sin(args[0] * kDegToRad); }
    else if (name == "COS") { need(1); result = std::cos(args[0] * kDegToRad); }
    else if (name == "TAN") { need(1); result = std::tan(args[0] * kDegToRad); }
    else if (name == "ASIN" || name == "ACOS") {
      need(1);
      if (!(args[0] >= -1.0 && args[0] <= 1.0)) fail(column, name + " of " + detail::format_number(args[0]) + " (outside [-1, 1])");
      result = (name == "ASIN" ? std::asin(args[0]) : std::acos(args[0])) / kDegToRad;
    }
    else if (name == "ATAN2") { need(2); result = std::atan2(args[0], args[1]) / kDegToRad; }
    else if (name == "SQRT") {
      need(1);
      if (args[0] < 0.0) fail(column, "SQRT of a negative number " + detail::format_number(args[0]));
      result = std::sqrt(args[0]);
    }
    else if (name == "ABS") { need(1); result = std::abs(args[0]); }
    else if (name == "POT") { need(1); result = args[0] * args[0]; }
    else if (name == "TRUNC") { need(1); result = std::trunc(args[0]); }
    else if (name == "ROUND") { need(1); result = std::round(args[0]); }
    else if (name == "ROUNDUP") { need(1); result = std::ceil(args[0]); }
    else if (name == "LN") {
      need(1);
      if (!(args[0] > 0.0)) fail(column, "LN of " + detail::format_number(args[0]) + " (not positive)");
      result = std::log(args[0]);
    }
    else if (name == "EXP") { need(1); result = std::exp(args[0]); }
    else if (name == "MINVAL") { need(2); result = std::min(args[0], args[1]); }
    else if (name == "MAXVAL") { need(2); result = std::max(args[0], args[1]); }
    else fail(column, "unknown function " + name + "(");
    if (!std::isfinite(result)) fail(column, name + " gives a result beyond a double");
    return result;
  }

  static std::optional<std::size_t> r_parameter(const std::string& name) {
    if (name.size() < 2 || name[0] != 'R') return std::nullopt;
    for (std::size_t k = 1; k < name.size(); ++k) {
      if (!std::isdigit(static_cast<unsigned char>(name[k]))) return std::nullopt;
    }
    if (name.size() > 6) return std::nullopt;
    return static_cast<std::size_t>(std::stoul(name.substr(1)));
  }

  /// Symbolic constants posts write into cycle calls (CYCLE832's machining types).
  static std::optional<double> constant(const std::string& name) {
    static const std::map<std::string, double> constants = {
        {"TRUE", 1.0},     {"FALSE", 0.0},       {"_OFF", 0.0},          {"_FINISH", 1.0},
        {"_SEMIFIN", 2.0}, {"_ROUGH", 3.0},      {"_PRECISION", 4.0},    {"_ORI_FINISH", 11.0},
        {"_ORI_SEMIFIN", 12.0}, {"_ORI_ROUGH", 13.0}};
    const auto it = constants.find(name);
    if (it == constants.end()) return std::nullopt;
    return it->second;
  }

  double variable(const std::string& name, int column) {
    if (const auto r = r_parameter(name)) {
      const auto it = r_.find(*r);
      return it == r_.end() ? 0.0 : it->second;  // R parameters start at 0
    }
    for (auto it = calls_.rbegin(); it != calls_.rend(); ++it) {
      if (const auto v = it->locals.find(name); v != it->locals.end()) return v->second;
      break;  // DEF variables are local to their program level
    }
    if (const auto v = constant(name)) return *v;
    if (!name.empty() && name[0] == '$') {
      fail(column, "system variable " + name + " is not simulated");
    }
    fail(column, "'" + name + "' is not a variable (DEF it first) or a known constant");
  }

  void assign(const std::string& name, double value, int column) {
    if (!std::isfinite(value)) fail(column, "'" + name + "': the value is beyond a double");
    if (const auto r = r_parameter(name)) {
      r_[*r] = value;
      return;
    }
    auto& locals = calls_.back().locals;
    const auto it = locals.find(name);
    if (it == locals.end()) {
      if (!name.empty() && name[0] == '$') fail(column, "system variable " + name + " cannot be written here");
      fail(column, "'" + name + "' is not defined (DEF INT / REAL / BOOL " + name + ")");
    }
    const auto type = defined_types_.find(name);
    it->second = (type != defined_types_.end() && type->second == "INT") ? std::round(value) : value;
  }

  /// DEF INT|REAL|BOOL|CHAR|STRING[n] name[=value], name2...
  void define(Lexer& lex, int column) {
    const std::string type = lex.identifier();
    if (type == "STRING") {
      // Strings (MSG texts, tool names) carry no geometry: accepted, not kept.
      return;
    }
    if (type != "INT" && type != "REAL" && type != "BOOL" && type != "CHAR") {
      fail(column, "DEF " + type + ": only INT REAL BOOL CHAR (and STRING, not kept) variables are supported");
    }
    do {
      const int name_column = column_of(lex) + 1;
      const std::string name = lex.identifier();
      if (name.empty() || !is_ident_start(name[0])) fail(name_column, "DEF needs a variable name");
      if (lex.peek() == '[') fail(name_column, "DEF arrays are not supported");
      calls_.back().locals[name] = 0.0;
      defined_types_[name] = type;
      if (lex.take('=')) assign(name, expression(lex), name_column);
    } while (lex.take(','));
    if (!lex.at_end()) fail(column_of(lex) + 1, "unexpected text after the DEF");
  }

  // --- Words of a block ------------------------------------------------------------------------

  static bool is_known_address(const std::string& a) {
    static const char* const addresses[] = {
        "X", "Y", "Z", "A", "B", "C", "I", "J", "K", "F", "S", "T", "D", "M", "G", "H", "L", "P",
        "N", "A3", "B3", "C3", "I1", "J1", "K1", "CR", "AR", "ADIS", "ADISPOS", "RPL", "CTOL",
        "OTOL", "SPOS", "TURN", "AP", "RP", "A2", "B2", "C2", "SF", "E"};
    for (const char* address : addresses) {
      if (a == address) return true;
    }
    return false;
  }

  Value value_of(Lexer& lex) {
    Value value;
    if (const auto s = lex.string_literal()) {
      value.text = *s;
      return value;
    }
    const std::size_t at = lex.position();
    const std::string name = (lex.skip(), is_ident_start(lex.peek_raw())) ? lex.identifier() : "";
    if ((name == "AC" || name == "IC") && lex.take('(')) {
      value.number = expression(lex);
      if (!lex.take(')')) fail(column_of(lex), name + "(: ')' missing");
      value.dimension = name == "AC" ? Value::Dimension::absolute : Value::Dimension::incremental;
      return value;
    }
    lex.set_position(at);
    value.number = expression(lex);
    return value;
  }

  std::vector<Word> words_of(const std::string& code) {
    std::vector<Word> words;
    Lexer lex(code, 0);
    // A label at the start (LABEL:) is no word.
    {
      const LineHead head = line_head(code);
      std::size_t i = 0;
      while (i < code.size() && std::isspace(static_cast<unsigned char>(code[i]))) ++i;
      const std::size_t label_colon = code.find(':');
      if (label_colon != std::string::npos && label_colon < head.position) {
        // "N10 LABEL: ..." or "LABEL: ...": read the N number, skip the label.
        if (i < label_colon && (code[i] == 'N' || code[i] == 'n') && i + 1 < code.size() &&
            std::isdigit(static_cast<unsigned char>(code[i + 1]))) {
          Lexer n_lex(code, i + 1);
          Word n;
          n.address = "N";
          n.column = static_cast<int>(i) + 1;
          n.has_value = true;
          n.value.number = parse_number(n_lex, n_lex.number_text().value_or("0"));
          n.text = detail::trim(std::string_view(code).substr(i, n_lex.position() - i));
          words.push_back(std::move(n));
        }
        lex.set_position(label_colon + 1);
      }
    }
    while (!lex.at_end()) {
      if (words.size() == detail::kMaxWordsPerBlock) {
        fail(column_of(lex) + 1, "more than " + std::to_string(detail::kMaxWordsPerBlock) + " words in one block");
      }
      lex.skip();
      const std::size_t start = lex.position();
      Word word;
      word.column = static_cast<int>(start) + 1;
      if (lex.peek_raw() == ':' && std::isdigit(static_cast<unsigned char>(lex.peek_raw(1)))) {
        lex.take(':');  // main block number ":10"
        word.address = "N";
        word.has_value = true;
        word.value.number = parse_number(lex, *lex.number_text());
        word.text = code.substr(start, lex.position() - start);
        words.push_back(std::move(word));
        continue;
      }
      if (!is_ident_start(lex.peek_raw())) {
        fail(word.column, "unexpected character '" + std::string(1, lex.peek_raw()) + "'");
      }
      const char letter = static_cast<char>(std::toupper(static_cast<unsigned char>(lex.peek_raw())));
      const char next = lex.peek_raw(1);
      if (std::isalpha(static_cast<unsigned char>(letter)) &&
          (std::isdigit(static_cast<unsigned char>(next)) || next == '.' || next == '-' ||
           next == '+' || next == ' ' || next == '\t')) {
        // A letter and its number ("X10.5", "G642", "M30"), or an extended address ("A3=",
        // "R1=", "I1=") whose digits are followed by '='.
        std::size_t j = start + 1;
        while (j < code.size() && std::isdigit(static_cast<unsigned char>(code[j]))) ++j;
        std::size_t k = j;
        while (k < code.size() && std::isspace(static_cast<unsigned char>(code[k]))) ++k;
        if (j > start + 1 && k < code.size() && code[k] == '=' && (k + 1 >= code.size() || code[k + 1] != '=')) {
          word.address = detail::to_upper(code.substr(start, j - start));
          lex.set_position(k + 1);
          word.has_value = true;
          word.assignment = r_parameter(word.address).has_value() || defined_types_.count(word.address) > 0;
          word.value = value_of(lex);
          // Assignments take effect in the order of the block: R1=4 R2=R1*2 gives R2 = 8.
          if (word.assignment) assign(word.address, word.value.number, word.column);
        } else {
          word.address = std::string(1, letter);
          lex.set_position(start + 1);
          lex.skip();
          word.has_value = true;
          const bool negative = lex.take('-');
          if (!negative) lex.take('+');
          const auto number = lex.number_text();
          if (!number) fail(word.column, "'" + code.substr(start, 1) + "': the address has no value");
          word.value.number = (negative ? -1.0 : 1.0) * parse_number(lex, *number);
        }
        word.text = detail::trim(std::string_view(code).substr(start, lex.position() - start));
        words.push_back(std::move(word));
        continue;
      }
      const std::string name = lex.identifier();
      word.address = name;
      if (lex.peek() == '=' && lex.peek_raw(1) != '=') {
        lex.take('=');
        word.has_value = true;
        word.assignment = !is_known_address(name);
        word.value = value_of(lex);
        if (word.assignment) assign(name, word.value.number, word.column);
      } else if (lex.peek() == '(' && name == "MSG") {
        // MSG("text" << R1): a message, no geometry: skipped to its closing parenthesis.
        std::size_t k = code.find('(', lex.position());
        int depth = 0;
        bool in_string = false;
        for (; k < code.size(); ++k) {
          if (code[k] == '"') in_string = !in_string;
          if (in_string) continue;
          if (code[k] == '(') ++depth;
          if (code[k] == ')' && --depth == 0) break;
        }
        if (k >= code.size()) fail(word.column, "'MSG(' is not closed");
        lex.set_position(k + 1);
        word.has_arguments = true;
      } else if (lex.peek() == '(') {
        lex.take('(');
        word.has_arguments = true;
        if (!lex.take(')')) {
          while (true) {
            lex.skip();
            if (lex.peek() == ',' || lex.peek() == ')') {
              word.arguments.push_back(std::nullopt);
            } else {
              word.arguments.push_back(value_of(lex));
            }
            if (lex.take(',')) continue;
            if (lex.take(')')) break;
            fail(word.column, "'" + name + "(': ',' or ')' expected at column " + std::to_string(column_of(lex) + 1));
          }
        }
      }
      word.text = detail::trim(std::string_view(code).substr(start, lex.position() - start));
      words.push_back(std::move(word));
    }
    return words;
  }

  // --- Blocks -------------------------------------------------------------------------------

  enum class Motion { rapid, linear, cw, ccw, cip, ct };
  enum class PathMode { exact, g64, g641, g642 };

  void block(const std::string& code) {
    const std::vector<Word> words = words_of(code);
    if (words.empty()) return;

    // Cutter radius compensation: G40 ends it before anything else of its block (the block's
    // motion is the exit); while it is on, what would move the offset contour is refused.
    const Word* compensation_word = nullptr;
    for (const Word& word : words) {
      if (word.address != "G" || !word.has_value || word.assignment || word.value.text) continue;
      const double v = word.number();
      if (v != 40.0 && v != 41.0 && v != 42.0) continue;
      if (compensation_word) fail(word, "a second cutter compensation G-code in one block");
      compensation_word = &word;
    }
    if (compensation_word && compensation_word->number() == 40.0) end_compensation(compensation_word);
    if (compensation_side_) refuse_under_compensation(words);

    std::optional<Motion> motion;
    const Word* motion_word = nullptr;
    bool exact_stop_here = false, machine_coordinates = false, dwell = false;
    const Word* frame_word = nullptr;
    const Word* f_word = nullptr;
    const Word* s_word = nullptr;  // spindle speed [rev/min]; in a G4 block, revolutions
    const Word* t_word = nullptr;
    const Word* d_word = nullptr;
    const Word* l_word = nullptr;
    const Word* p_word = nullptr;
    const Word* cr_word = nullptr;
    const Word* rpl_word = nullptr;
    const Word* m6_word = nullptr;
    const Word* offset_word = nullptr;
    std::string offset_name;
    const Word* subprogram_word = nullptr;
    std::array<const Word*, 3> xyz{}, abc{}, ijk{}, vec{}, mid{};
    long block_number = -1;
    bool end_subprogram = false;
    std::vector<const Word*> cycles;
    const Word* drill_word = nullptr;  // CYCLE81 / 82 / 83
    const Word* mcall_word = nullptr;

    for (const Word& word : words) {
      const std::string& a = word.address;
      if (word.assignment) continue;  // done where it was read (words_of)
      if (word.has_arguments) {
        if (a == "CYCLE832" || a == "CYCLE800") {
          cycles.push_back(&word);
        } else if (a == "CYCLE81" || a == "CYCLE82" || a == "CYCLE83") {
          if (drill_word) fail(word, "two drilling cycles in one block");
          drill_word = &word;
        } else if (a == "MSG" || a == "WORKPIECE" || a == "FGROUP" || a == "TRAORI" || a == "SETMS" ||
                   a == "G_SET" || a == "ORIRESET") {
          if (a == "TRAORI") set_tcp(true);
          if (a == "ORIRESET") fail(word, "ORIRESET is not supported: program the tool vector or the rotary axes");
        } else {
          fail(word, "unsupported cycle or procedure call (output the cycle as G0/G1/G2/G3 moves)");
        }
        continue;
      }
      if (!word.has_value && a == "MCALL") {
        mcall_word = &word;
        continue;
      }
      if (!word.has_value) {
        keyword(word, frame_word, motion, motion_word, machine_coordinates, subprogram_word);
        continue;
      }
      if (word.value.text && a != "T") fail(word, "a text value where a number is expected");
      if (a == "A3" || a == "B3" || a == "C3") { set_once(vec[static_cast<std::size_t>(a[0] - 'A')], word); continue; }
      if (a == "I1" || a == "J1" || a == "K1") { set_once(mid[static_cast<std::size_t>(a[0] == 'I' ? 0 : a[0] == 'J' ? 1 : 2)], word); continue; }
      if (a == "CR") { set_once(cr_word, word); continue; }
      if (a == "ADIS" || a == "ADISPOS") {
        if (!(word.number() >= 0.0)) fail(word, "ADIS must be >= 0");
        if (a == "ADIS") adis_mm_ = word.number() * mm_per_unit_;
        refresh_corner_tolerance();
        continue;
      }
      if (a == "CTOL") {
        if (!(word.number() > 0.0)) fail(word, "CTOL (contour tolerance) must be positive");
        ctol_m_ = word.number() * mm_per_unit_ * kMetresPerMillimetre;
        refresh_corner_tolerance();
        continue;
      }
      if (a == "S") { set_once(s_word, word); continue; }
      if (a == "OTOL" || a == "SPOS") continue;
      if (a == "RPL") { set_once(rpl_word, word); continue; }
      if (a == "AR" || a == "TURN" || a == "AP" || a == "RP" || a == "A2" || a == "B2" || a == "C2" || a == "SF" || a == "E") {
        fail(word, a == "AR" ? "arc by opening angle (AR=) is not supported: give I J K, CR= or CIP"
                   : a == "TURN" ? "helix turns (TURN=) are not supported"
                   : (a == "AP" || a == "RP") ? "polar coordinates are not supported"
                   : "unsupported address");
      }
      if (a.size() != 1) fail(word, "unsupported address");
      switch (a[0]) {
        case 'G': g_code(word, motion, motion_word, exact_stop_here, machine_coordinates, dwell,
                         offset_word, offset_name); break;
        case 'M': {
          require_within(word, word.number(), 0.0, detail::kMaxIgnoredWordValue, "M code", "");
          const long m = std::lround(word.number());
          if (m == 2 || m == 30) ended_ = true;
          if (m == 17) end_subprogram = true;
          if (m == 6) m6_word = &word;
          break;
        }
        case 'N':
          require_within(word, word.number(), 0.0, detail::kMaxIgnoredWordValue, "block number", "");
          block_number = std::lround(word.number());
          break;
        case 'T': set_once(t_word, word); break;
        case 'D': set_once(d_word, word);
          require_within(word, word.number(), 0.0, detail::kMaxIgnoredWordValue, "D number", "");
          break;
        case 'H': break;  // auxiliary function
        case 'F': set_once(f_word, word); break;
        case 'L': set_once(l_word, word); break;
        case 'P': set_once(p_word, word); break;
        case 'X': case 'Y': case 'Z': set_once(xyz[static_cast<std::size_t>(a[0] - 'X')], word); break;
        case 'A': case 'B': case 'C': set_once(abc[static_cast<std::size_t>(a[0] - 'A')], word); break;
        case 'I': case 'J': case 'K': set_once(ijk[static_cast<std::size_t>(a[0] - 'I')], word); break;
        default: fail(word, "unsupported word");
      }
    }

    if (mcall_word && !drill_word && (subprogram_word || l_word)) {
      fail(*mcall_word, "MCALL of a subprogram is not read (MCALL CYCLE81 / 82 / 83 are)");
    }
    // Tool: T selects, M6 loads (D1 active unless the block says otherwise), D the cutting edge.
    if (t_word) {
      if (t_word->value.text) {
        next_tool_ = -1;  // a named tool: the part file's tool
        next_tool_name_ = *t_word->value.text;
      } else {
        require_within(*t_word, t_word->number(), 0.0, detail::kMaxIgnoredWordValue, "T number", "");
        next_tool_ = static_cast<int>(std::lround(t_word->number()));
      }
    }
    if (m6_word) {
      if (!next_tool_) fail(*m6_word, "tool change M6 without a tool selected by a T word");
      change_geometry([&] {
        tool_number_ = *next_tool_;
        d_ = 1;
      });
    }
    if (d_word) change_geometry([&] { d_ = static_cast<int>(std::lround(d_word->number())); });
    if (compensation_word && compensation_word->number() != 40.0) start_compensation(*compensation_word);

    if (s_word && !dwell) {  // the spindle speed, for G4 S
      require_within(*s_word, std::abs(s_word->number()), 0.0, 1e6, "spindle speed", "rev/min");
      spindle_rev_per_min_ = std::abs(s_word->number());
    }
    if (f_word && !dwell) {
      if (!(f_word->number() > 0.0)) fail(*f_word, "the feed rate must be positive");
      if (inverse_time_) {
        require_within(*f_word, f_word->number(), detail::kMinInverseTimePerMin, detail::kMaxInverseTimePerMin,
                       "inverse-time feed", "1/min");
        block_inverse_time_per_s_ = f_word->number() / kSecondsPerMinute;
      } else {
        const double feed_mm_per_min = f_word->number() * mm_per_unit_;
        require_within(*f_word, feed_mm_per_min, detail::kMinFeedMmPerMin, detail::kMaxFeedMmPerMin, "feed rate", "mm/min");
        feed_m_per_s_ = feed_mm_per_min * kMetresPerMillimetre / kSecondsPerMinute;
      }
    } else {
      block_inverse_time_per_s_.reset();
    }
    for (const Word* word : {xyz[0], xyz[1], xyz[2], ijk[0], ijk[1], ijk[2], mid[0], mid[1], mid[2], cr_word}) {
      if (word && !frame_word) {
        require_within(*word, word->number() * mm_per_unit_, -detail::kMaxCoordinateMm, detail::kMaxCoordinateMm, "length", "mm");
      }
    }
    for (const Word* word : abc) {
      if (word) require_within(*word, word->number(), -detail::kMaxRotaryDeg, detail::kMaxRotaryDeg, "rotary axis word", "deg");
    }
    if (offset_word) select_offset(*offset_word, offset_name);
    if (motion) motion_ = *motion;

    for (const Word* cycle : cycles) {
      if (cycle->address == "CYCLE832") cycle832(*cycle);
      else cycle800(*cycle);
    }
    if (frame_word) {
      if (const Word* extra = first_of({abc[0], abc[1], abc[2], ijk[0], ijk[1], ijk[2], vec[0], vec[1], vec[2], f_word})) {
        fail(*extra, "a frame instruction (" + frame_word->text + ") takes X Y Z (or RPL=) only: program the motion in a block of its own");
      }
      frame(*frame_word, xyz, rpl_word);
      return;
    }
    if (rpl_word) fail(*rpl_word, "RPL= needs ROT or AROT");
    if (subprogram_word || l_word) {
      call_subprogram(subprogram_word ? *subprogram_word : *l_word, p_word, block_number);
      return;
    }
    if (p_word) fail(*p_word, "P has no meaning here (L<n> P<repeats>)");
    if (dwell) {
      if (const Word* other = first_of({xyz[0], xyz[1], xyz[2], abc[0], abc[1], abc[2]})) {
        fail(*other, "motion word in a G4 dwell block");
      }
      // G4 F<seconds> or G4 S<spindle revolutions> (at the spindle speed programmed last).
      if (f_word && s_word) fail(*s_word, "G4 with both F (seconds) and S (revolutions)");
      if (!f_word && !s_word) fail(*dwell_word_, "G4 needs F (seconds) or S (spindle revolutions)");
      const Word& time_word = f_word ? *f_word : *s_word;
      require_within(time_word, time_word.number(), 0.0, detail::kMaxIgnoredWordValue, "dwell", "");
      if (s_word && !(spindle_rev_per_min_ > 0.0)) {
        fail(*s_word, "G4 S (a dwell in spindle revolutions) needs the spindle speed: no S before it");
      }
      dwell_here(f_word ? f_word->number() : s_word->number() * 60.0 / spindle_rev_per_min_);
      return;
    }
    if (mcall_word && !drill_word) modal_drill_.reset();  // MCALL alone ends the modal call
    motion_block(xyz, abc, ijk, vec, mid, cr_word, motion_word, block_number, exact_stop_here,
                 machine_coordinates);
    // Drilling cycles: called here (CYCLE8x in a block), or made modal by MCALL and called after
    // every following block that moves the axes, until MCALL alone.
    if (drill_word) {
      const DrillCycle cycle = drill_cycle_of(*drill_word);
      if (mcall_word) {
        modal_drill_ = cycle;
      } else {
        run_drill_cycle(cycle, block_number);
      }
    } else if (modal_drill_ && first_of({xyz[0], xyz[1], xyz[2]})) {
      run_drill_cycle(*modal_drill_, block_number);
    }
    if (end_subprogram) {
      if (!return_from_call()) ended_ = true;
    }
  }

  void keyword(const Word& word, const Word*& frame_word, std::optional<Motion>& motion,
               const Word*& motion_word, bool& machine_coordinates, const Word*& subprogram_word) {
    const std::string& a = word.address;
    const auto set_motion = [&](Motion m) {
      if (motion) fail(word, "a second motion command in one block");
      motion = m;
      motion_word = &word;
    };
    if (a == "TRAORI") { set_tcp(true); return; }
    if (a == "TRAFOOF") { set_tcp(false); return; }
    if (a == "CIP") { set_motion(Motion::cip); return; }
    if (a == "CT") { set_motion(Motion::ct); return; }
    if (a == "SOFT") { jerk_mode_ = JerkMode::soft; return; }
    if (a == "BRISK" || a == "DRIVE") { jerk_mode_ = JerkMode::brisk; return; }
    if (a == "FFWON") { feedforward_ = FeedforwardMode::on; return; }
    if (a == "FFWOF") { feedforward_ = FeedforwardMode::off; return; }
    if (a == "COMPCAD" || a == "COMPCURV" || a == "COMPON") {
      compressor_on_ = true;
      refresh_compressor();
      return;
    }
    if (a == "COMPOF") { compressor_on_ = false; refresh_compressor(); return; }
    if (a == "TRANS" || a == "ATRANS" || a == "ROT" || a == "AROT" || a == "MIRROR" || a == "AMIRROR") {
      if (frame_word) fail(word, "a second frame instruction in one block");
      frame_word = &word;
      return;
    }
    if (a == "SCALE" || a == "ASCALE") fail(word, "scaling frames are not supported");
    if (a == "SUPA") { machine_coordinates = true; return; }
    if (a == "STOPRE" || a == "ORIWKS" || a == "ORIMKS" || a == "ORIAXES" || a == "ORIVECT" ||
        a == "ORIEULER" || a == "ORIRPY" || a == "CFTCP" || a == "CFC" || a == "CFIN" ||
        a == "UPATH" || a == "SPATH" || a == "DYNNORM" || a == "DYNPOS" || a == "DYNROUGH" ||
        a == "DYNSEMIFIN" || a == "DYNFINISH" || a == "DYNPREC" || a == "DIAMOF" || a == "FNORM" ||
        a == "FLIN" || a == "FCUB" || a == "SPOF" || a == "PTP" ||
        a == "CP" || a == "ORIPLANE" || a == "ORICONCW" || a == "ORICONCCW" || a == "TOFFOF" ||
        a == "CUT2D" || a == "CUT3DC" || a == "TCOABS" || a == "SOFTA" || a == "BRISKA") {
      // Orientation references and interpolation kinds (the chain interpolates the tool axis
      // between points), feed references, dynamic response groups (machine data not modelled),
      // preprocessing stops: no geometry of their own.
      return;
    }
    if (a == "RET") {
      if (!return_from_call()) ended_ = true;
      return;
    }
    if (find_subprogram_file(a)) {
      subprogram_word = &word;
      return;
    }
    fail(word, "unsupported word");
  }

  void g_code(const Word& word, std::optional<Motion>& motion, const Word*& motion_word, bool& exact_stop_here,
              bool& machine_coordinates, bool& dwell, const Word*& offset_word, std::string& offset_name) {
    const double v = word.number();
    if (!(v >= 0.0 && v <= 1000.0) || v != std::round(v)) fail(word, "unknown G-code");
    const long code = std::lround(v);
    const auto set_motion = [&](Motion m) {
      if (motion) fail(word, "a second motion command in one block");
      motion = m;
      motion_word = &word;
    };
    switch (code) {
      case 0: set_motion(Motion::rapid); return;
      case 1: set_motion(Motion::linear); return;
      case 2: set_motion(Motion::cw); return;
      case 3: set_motion(Motion::ccw); return;
      case 4: dwell = true; dwell_word_ = &word; return;
      case 9: exact_stop_here = true; return;
      case 17: plane_ = Plane::xy; return;
      case 18: plane_ = Plane::zx; return;
      case 19: plane_ = Plane::yz; return;
      case 40: case 41: case 42: return;  // cutter compensation: block() did it
      case 53: case 153: machine_coordinates = true; return;
      case 60: path_mode_ = PathMode::exact; refresh_corner_tolerance(); return;
      case 601: case 602: case 603: return;  // exact stop windows (fine, coarse, interpolator end)
      case 64: path_mode_ = PathMode::g64; refresh_corner_tolerance(); return;
      case 641: path_mode_ = PathMode::g641; refresh_corner_tolerance(); return;
      case 642: case 643: case 644: case 645:
        path_mode_ = PathMode::g642;
        refresh_corner_tolerance();
        return;
      case 70: case 700: change_geometry([&] { mm_per_unit_ = kMillimetresPerInch; }); return;
      case 71: case 710: change_geometry([&] { mm_per_unit_ = 1.0; }); return;
      case 90: incremental_ = false; return;
      case 91: incremental_ = true; return;
      case 93: inverse_time_ = true; return;
      case 94: inverse_time_ = false; return;
      case 95: case 96: fail(word, "feed per revolution / constant cutting speed is not supported: give F in mm/min (G94)");
      case 500: case 54: case 55: case 56: case 57:
        if (offset_word) fail(word, "a second work offset in one block");
        offset_word = &word;
        offset_name = "G" + std::to_string(code);
        return;
      default:
        if (code >= 505 && code <= 599) {
          if (offset_word) fail(word, "a second work offset in one block");
          offset_word = &word;
          offset_name = "G" + std::to_string(code);
          return;
        }
        fail(word, "unsupported G-code (it may change the geometry)");
    }
  }

  // --- NC modes ------------------------------------------------------------------------------

  void refresh_corner_tolerance() {
    switch (path_mode_) {
      case PathMode::exact: corner_tolerance_m_ = 0.0; break;
      case PathMode::g64: corner_tolerance_m_ = PathPoint::kNotProgrammed; break;
      case PathMode::g641:
        // ADIS: the blend starts and ends at most this far from the corner, so it stays within
        // ADIS of the programmed path (an upper bound taken as the tolerance). ADIS=0: as G64.
        corner_tolerance_m_ = adis_mm_ > 0.0 ? adis_mm_ * kMetresPerMillimetre : PathPoint::kNotProgrammed;
        break;
      case PathMode::g642:
        corner_tolerance_m_ = !std::isnan(ctol_m_)         ? ctol_m_
                              : !std::isnan(cycle832_tol_m_) ? cycle832_tol_m_
                                                             : options_.contouring_tolerance_m;
        break;
    }
  }
  void refresh_compressor() {
    compressor_tolerance_m_ = !compressor_on_ ? 0.0
                              : !std::isnan(cycle832_tol_m_) ? cycle832_tol_m_
                              : !std::isnan(ctol_m_)         ? ctol_m_
                                                             : options_.contouring_tolerance_m;
  }

  /// CYCLE832(tolerance, machining type, orientation tolerance, ...): the high-speed settings.
  /// Any machining type but 0 (deselection): G642 within the tolerance, COMPCAD within it, SOFT
  /// and FFWON. Type 0 (or no arguments): G64, COMPOF, the tolerance forgotten.
  void cycle832(const Word& word) {
    const auto arg = [&](std::size_t k) -> std::optional<double> {
      if (k >= word.arguments.size() || !word.arguments[k]) return std::nullopt;
      if (word.arguments[k]->text) fail(word, "CYCLE832 argument " + std::to_string(k + 1) + " must be a number");
      return word.arguments[k]->number;
    };
    const double tolerance_mm = arg(0).value_or(0.0) * mm_per_unit_;
    const long type = std::lround(arg(1).value_or(0.0));
    if (!(tolerance_mm >= 0.0 && tolerance_mm <= detail::kMaxToleranceMm)) {
      fail(word, "CYCLE832 tolerance " + detail::format_number(tolerance_mm) + " mm is outside [0, " +
                     detail::format_number(detail::kMaxToleranceMm) + "] mm");
    }
    ctol_m_ = PathPoint::kNotProgrammed;
    if (type % 10 == 0 || tolerance_mm == 0.0) {
      cycle832_tol_m_ = PathPoint::kNotProgrammed;
      path_mode_ = PathMode::g64;
      compressor_on_ = false;
    } else {
      cycle832_tol_m_ = tolerance_mm * kMetresPerMillimetre;
      path_mode_ = PathMode::g642;
      compressor_on_ = true;
      jerk_mode_ = JerkMode::soft;
      feedforward_ = FeedforwardMode::on;
    }
    refresh_corner_tolerance();
    refresh_compressor();
  }

  /// CYCLE800(_FR, _TC, _ST, _MODE, _X0, _Y0, _Z0, _A, _B, _C, _X1, _Y1, _Z1, _DIR, _FR_I, _DMODE):
  /// the swivel frame of 3+2 machining, axis by axis (rotations about the frame's own axes in
  /// the order _MODE gives). The tool is aligned with the new Z.
  void cycle800(const Word& word) {
    const auto arg = [&](std::size_t k) -> double {
      if (k >= word.arguments.size() || !word.arguments[k]) return 0.0;
      if (word.arguments[k]->text) {
        if (k == 1) return 0.0;  // _TC: the swivel data set's name
        fail(word, "CYCLE800 argument " + std::to_string(k + 1) + " must be a number");
      }
      return word.arguments[k]->number;
    };
    if (word.arguments.size() > 16) fail(word, "CYCLE800 takes at most 16 arguments");
    const long st = std::lround(arg(2));
    const long mode = std::lround(arg(3));
    const Vec3 before(arg(4), arg(5), arg(6));
    const std::array<double, 3> angle = {arg(7), arg(8), arg(9)};
    const Vec3 after(arg(10), arg(11), arg(12));
    for (double a : angle) {
      if (!(std::abs(a) <= 360.0)) fail(word, "CYCLE800 angle " + detail::format_number(a) + " deg is outside [-360, 360] deg");
    }
    Mat3 R = Mat3::Identity();
    const long kind = (mode >> 6) & 3;
    if (kind != 0) {
      fail(word, "CYCLE800 _MODE " + std::to_string(mode) +
                     ": only axis-by-axis swivelling (_MODE bits 6-7 = 0, e.g. 57: X then Y then Z) "
                     "is supported (solid angle, projection angles and direct rotary axes are not)");
    }
    for (int k = 0; k < 3; ++k) {
      const long axis_code = (mode >> (2 * k)) & 3;
      if (axis_code == 0) {
        if (angle[static_cast<std::size_t>(k)] != 0.0) fail(word, "CYCLE800 _MODE " + std::to_string(mode) + " names no axis for rotation " + std::to_string(k + 1));
        continue;
      }
      R = R * rotation_about(static_cast<int>(axis_code) - 1, angle[static_cast<std::size_t>(k)]);
    }
    Affine swivel{R, Vec3::Zero()};
    // Zero before the rotation (_X0 _Y0 _Z0), then the rotation, then the zero after it.
    swivel = Affine{Mat3::Identity(), before * mm_per_unit_}.after(swivel).after(Affine{Mat3::Identity(), after * mm_per_unit_});
    change_geometry([&] {
      swivel_ = (st % 10 == 1) ? swivel_.after(swivel) : swivel;
      if (!tcp_) axis_W_ = (swivel_.L * Vec3::UnitZ()).normalized();
    });
  }

  // --- Frames, offsets, modes: the machine does not move ---------------------------------------

  /// Runs `change` (which may change the frames, offsets, tool length, units or mode) keeping the
  /// machine where it is: the frame position is kept within one mode; across a switch between
  /// machine axes and tip-in-W (TRAORI, a swivel) the program numbers are kept.
  template <class Change>
  void change_geometry(Change change) {
    const bool old_w = tip_mode();
    const auto program = program_position();
    change();
    if (old_w != tip_mode()) set_program_position(program);
  }

  void set_tcp(bool on) {
    change_geometry([&] { tcp_ = on; });
    if (!tcp_ && swivel_.identity()) {
      // Back to the machine axes: the tool axis follows the rotary words in force.
    } else if (!tcp_) {
      axis_W_ = (swivel_.L * Vec3::UnitZ()).normalized();
    }
  }

  void frame(const Word& word, const std::array<const Word*, 3>& xyz, const Word* rpl_word) {
    const std::string& a = word.address;
    const bool additive = a[0] == 'A' && a != "ATRANS" ? true : a == "ATRANS";
    Affine step;
    if (a == "TRANS" || a == "ATRANS") {
      if (rpl_word) fail(*rpl_word, "RPL= needs ROT or AROT");
      for (std::size_t k = 0; k < 3; ++k) {
        if (xyz[k]) step.t[static_cast<Eigen::Index>(k)] = xyz[k]->number() * mm_per_unit_;
      }
    } else if (a == "ROT" || a == "AROT") {
      if (rpl_word) {
        if (const Word* extra = first_of({xyz[0], xyz[1], xyz[2]})) fail(*extra, "ROT RPL= takes no axis angles");
        require_within(*rpl_word, rpl_word->number(), -360.0, 360.0, "rotation angle", "deg");
        step.L = rotation_about(plane_axes(plane_)[2], rpl_word->number());
      } else {
        // Spatial rotation, RPY as the 840D's default (MD10600 FRAME_ANGLE_INPUT_MODE = 1):
        // about Z first, then about the new Y, then about the new X.
        std::array<double, 3> angle{};
        for (std::size_t k = 0; k < 3; ++k) {
          if (!xyz[k]) continue;
          require_within(*xyz[k], xyz[k]->number(), -360.0, 360.0, "rotation angle", "deg");
          angle[k] = xyz[k]->number();
        }
        step.L = rotation_about(2, angle[2]) * rotation_about(1, angle[1]) * rotation_about(0, angle[0]);
      }
    } else {  // MIRROR / AMIRROR: the named axes change sign (the value, X0, is not used)
      if (rpl_word) fail(*rpl_word, "RPL= needs ROT or AROT");
      for (std::size_t k = 0; k < 3; ++k) {
        if (xyz[k]) step.L(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(k)) = -1.0;
      }
    }
    change_geometry([&] { program_frame_ = additive ? program_frame_.after(step) : step; });
  }

  struct ActiveOffset {
    std::string name;
    Vec3 machine_mm = Vec3::Zero();
    Vec3 zero_W_mm = Vec3::Zero();
  };
  std::string offset_list() const {
    std::string list;
    for (const auto& [name, value] : offsets_mm_) list += (list.empty() ? "" : ", ") + name;
    return list.empty() ? "none" : list;
  }
  std::optional<ActiveOffset> offset_named(const std::string& name) const {
    const auto it = offsets_mm_.find(name);
    if (it != offsets_mm_.end()) {
      return ActiveOffset{name, it->second, options_.machine_axes_W * it->second + options_.machine_zero_W_mm};
    }
    if (name == "G500") {
      // No settable frame: X Y Z are the machine axes (less the tool length).
      return ActiveOffset{name, Vec3::Zero(), options_.machine_zero_W_mm};
    }
    if (name == "G54" && implicit_g54_) return ActiveOffset{name, Vec3::Zero(), Vec3::Zero()};
    return std::nullopt;
  }
  void select_offset(const Word& word, const std::string& name) {
    const auto offset = offset_named(name);
    if (!offset) {
      fail(word, "work offset " + name + " is not set up (set up: " + offset_list() +
                     "; the part file's setup: work_offsets)");
    }
    change_geometry([&] { offset_ = *offset; });
  }

  // --- Positions ------------------------------------------------------------------------------
  //
  // The reader keeps the position in the "frame": the machine axes X Y Z [mm] outside TRAORI and
  // without a swivel (what axis_words_to_pose receives), else the tool tip in W [mm]. A program
  // point p maps to it through the programmable frame, the swivel and the settable frame:
  //   machine axes: f = offset + (0, 0, tool length under D) + P(p)
  //   tip in W:     f = work zero in W + S(P(p))

  bool tip_mode() const { return tcp_ || !swivel_.identity(); }

  double tool_length_mm() const {
    if (d_ == 0 || tool_number_ == 0) return 0.0;
    if (const auto it = options_.tool_length_mm.find(tool_number_); it != options_.tool_length_mm.end()) return it->second;
    if (options_.default_tool_length_mm) return *options_.default_tool_length_mm;
    throw InputError(located_message(current_file(), line_, 0,
                                     "no tool length for T" + std::to_string(tool_number_) + " D" + std::to_string(d_) +
                                         " (the part file's tools), needed outside TRAORI and CYCLE800"));
  }

  Affine to_frame_map() const {
    if (tip_mode()) return Affine{Mat3::Identity(), offset_.zero_W_mm}.after(swivel_).after(program_frame_);
    return Affine{Mat3::Identity(), offset_.machine_mm + Vec3(0.0, 0.0, tool_length_or_zero())}.after(program_frame_);
  }
  /// The tool length where it is known, else 0 (a program before any T / D, or without lengths;
  /// the error comes when such a position is used for a pose).
  double tool_length_or_zero() const {
    if (d_ == 0 || tool_number_ == 0) return 0.0;
    if (options_.tool_length_mm.count(tool_number_) || options_.default_tool_length_mm) return tool_length_mm();
    length_missing_ = true;
    return 0.0;
  }
  Vec3 to_frame(const Vec3& p) const { return to_frame_map().apply(p); }
  Vec3 from_frame(const Vec3& f) const { return to_frame_map().inverse().apply(f); }

  Vec3 start_frame_position() const {
    if (!tip_mode() && !options_.work_offsets_mm.empty()) return options_.g28_reference_mm;
    return to_frame(Vec3::Zero());
  }
  Vec3 filled_frame_position() const {
    const Vec3 zero = start_frame_position();
    Vec3 f;
    for (std::size_t k = 0; k < 3; ++k) f[static_cast<Eigen::Index>(k)] = position_[k].value_or(zero[static_cast<Eigen::Index>(k)]);
    return f;
  }
  std::array<std::optional<double>, 3> program_position() const {
    const Vec3 p = from_frame(filled_frame_position());
    std::array<std::optional<double>, 3> result;
    for (std::size_t k = 0; k < 3; ++k) {
      if (position_[k]) result[k] = p[static_cast<Eigen::Index>(k)];
    }
    return result;
  }
  void set_program_position(const std::array<std::optional<double>, 3>& p) {
    Vec3 v;
    for (std::size_t k = 0; k < 3; ++k) v[static_cast<Eigen::Index>(k)] = p[k].value_or(0.0);
    const Vec3 f = to_frame(v);
    for (std::size_t k = 0; k < 3; ++k) {
      position_[k].reset();
      if (p[k]) position_[k] = f[static_cast<Eigen::Index>(k)];
    }
  }
  Vec3 known_frame_position(const std::array<const Word*, 3>& xyz, bool absolute) {
    const Vec3 zero = start_frame_position();
    const bool at_reference = !tip_mode() && !options_.work_offsets_mm.empty();
    Vec3 f;
    for (std::size_t k = 0; k < 3; ++k) {
      if (!position_[k]) {
        if (!(xyz[k] && absolute)) {
          warn(std::string("axis ") + "XYZ"[k] + " has no programmed position before this motion: taken " +
               (at_reference ? "at the G28 reference point (the machine's home)" : "as 0"));
        }
        position_[k] = zero[static_cast<Eigen::Index>(k)];
      }
      f[static_cast<Eigen::Index>(k)] = *position_[k];
    }
    return f;
  }

  // --- Motion --------------------------------------------------------------------------------

  using RotaryDeg = std::array<std::optional<double>, 3>;

  bool incremental_word(const Word& word) const {
    if (word.value.dimension == Value::Dimension::absolute) return false;
    if (word.value.dimension == Value::Dimension::incremental) return true;
    return incremental_;
  }

  void motion_block(const std::array<const Word*, 3>& xyz, const std::array<const Word*, 3>& abc,
                    const std::array<const Word*, 3>& ijk, const std::array<const Word*, 3>& vec,
                    const std::array<const Word*, 3>& mid, const Word* cr_word, const Word* motion_word,
                    long block_number, bool exact_stop_here, bool machine_coordinates) {
    const Word* first = first_of({xyz[0], xyz[1], xyz[2], abc[0], abc[1], abc[2], ijk[0], ijk[1], ijk[2],
                                  vec[0], vec[1], vec[2], mid[0], mid[1], mid[2], cr_word});
    if (!first) {
      if (machine_coordinates && motion_word) fail(*motion_word, "G53 / G153 / SUPA without an axis word");
      return;
    }
    if (!motion_) fail(*first, "axis word before any motion command G0/G1/G2/G3/CIP/CT");
    const Motion motion = *motion_;
    const bool arc = motion == Motion::cw || motion == Motion::ccw || motion == Motion::cip || motion == Motion::ct;
    const Word& reported = motion_word ? *motion_word : *first;
    const bool any_abc = abc[0] || abc[1] || abc[2];
    const bool any_vec = vec[0] || vec[1] || vec[2];
    if (machine_coordinates && (arc || tip_mode())) {
      fail(reported, arc ? "G53 / G153 / SUPA need G0 or G1" : "G53 / G153 / SUPA (machine coordinates) under TRAORI or CYCLE800 is not supported");
    }
    if (!arc) {
      if (const Word* w = first_of({ijk[0], ijk[1], ijk[2], mid[0], mid[1], mid[2], cr_word})) {
        fail(*w, "arc words (I J K, I1 J1 K1, CR=) need G2/G3/CIP/CT");
      }
    }
    if (any_vec && !tcp_) fail(*first_of({vec[0], vec[1], vec[2]}), "tool vector words A3 B3 C3 need TRAORI");
    if (arc && (any_abc || any_vec)) {
      fail(*first_of({abc[0], abc[1], abc[2], vec[0], vec[1], vec[2]}), "a change of tool orientation in an arc block is not supported");
    }
    if (any_abc && any_vec) fail(*first_of({abc[0], abc[1], abc[2]}), "both rotary words and a tool vector (A3 B3 C3) in one block");
    if (any_abc) {
      const Word& w = *first_of({abc[0], abc[1], abc[2]});
      if (tcp_ && !options_.rotary_words_to_tool_axis) {
        fail(w, "TRAORI with rotary words needs a machine to turn them into a tool axis (ReaderOptions::rotary_words_to_tool_axis)");
      }
      if (!tcp_ && !swivel_.identity()) fail(w, "rotary words while a CYCLE800 swivel is active: the swivel places the rotary axes");
      if (!tcp_ && !options_.axis_words_to_pose) {
        fail(w, "rotary axis word outside TRAORI needs a machine to turn the axis words into a tool pose (ReaderOptions::axis_words_to_pose)");
      }
    }

    PathPoint point = new_point(motion == Motion::rapid ? MotionKind::rapid : arc ? MotionKind::arc : MotionKind::linear);
    if (motion != Motion::rapid) {
      if (inverse_time_) {
        if (!block_inverse_time_per_s_) fail(reported, "under G93 (inverse time) every G1/G2/G3 block needs its F word");
        point.inverse_time_feed_per_s = *block_inverse_time_per_s_;
      } else {
        if (!feed_m_per_s_) fail(reported, "feed motion before any F word: the feed is unknown");
        point.feed_m_per_s = *feed_m_per_s_;
      }
    }

    // Target in program coordinates, and the start.
    bool all_absolute = true;
    for (const Word* w : xyz) all_absolute = all_absolute && (!w || !incremental_word(*w) || machine_coordinates);
    const Vec3 start_f = known_frame_position(xyz, all_absolute);
    length_missing_ = false;
    const Vec3 start_p = from_frame(start_f);
    Vec3 target_p = start_p;
    Vec3 target_f = start_f;
    for (std::size_t k = 0; k < 3; ++k) {
      if (!xyz[k]) continue;
      const auto i = static_cast<Eigen::Index>(k);
      const double value = xyz[k]->number() * mm_per_unit_;
      if (machine_coordinates) {
        target_f[i] = value;
      } else {
        target_p[i] = incremental_word(*xyz[k]) ? start_p[i] + value : value;
        require_within(*xyz[k], target_p[i], -detail::kMaxCoordinateMm, detail::kMaxCoordinateMm, "position", "mm");
      }
    }
    if (!machine_coordinates) target_f = to_frame(target_p);
    if (!started_ && arc) fail(reported, "an arc as the first motion: its start point is unknown");
    if (length_missing_) (void)tool_length_mm();  // throws naming the tool

    const RotaryDeg start_rotary = rotary_deg_;
    for (std::size_t k = 0; k < 3; ++k) {
      if (!abc[k]) continue;
      const double previous = rotary_deg_[k].value_or(0.0);
      rotary_deg_[k] = incremental_word(*abc[k]) ? previous + abc[k]->number() : abc[k]->number();
      require_within(*abc[k], *rotary_deg_[k], -detail::kMaxRotaryDeg, detail::kMaxRotaryDeg, "rotary axis position", "deg");
    }
    started_ = true;

    if (any_vec) {
      // ORIWKS: the vector in the workpiece coordinates, turned by the frames.
      const Vec3 v(vec[0] ? vec[0]->number() : 0.0, vec[1] ? vec[1]->number() : 0.0, vec[2] ? vec[2]->number() : 0.0);
      const Vec3 v_W = swivel_.L * (program_frame_.L * v);
      axis_W_ = detail::unit_tool_axis(v_W, current_file(), line_, first_of({vec[0], vec[1], vec[2]})->column, line_text_);
    } else if (any_abc && tcp_) {
      axis_W_ = tool_axis_of(rotary_deg_, first_of({abc[0], abc[1], abc[2]})->column);
    }
    if (!tip_mode() && !options_.axis_words_to_pose && axis_W_ != Vec3::UnitZ()) {
      fail(reported, "a motion outside TRAORI after a tilted tool axis: the machine axes cannot be turned into a tool pose without a machine (ReaderOptions::axis_words_to_pose)");
    }

    point.block = add_source_block(block_number);
    point.rotary_words_deg = rotary_words_deg(rotary_deg_);
    if (compensating()) {
      compensated_motion(point, motion, start_p, target_p, ijk, mid, cr_word, exact_stop_here, reported);
      for (std::size_t k = 0; k < 3; ++k) position_[k] = target_f[static_cast<Eigen::Index>(k)];
      return;
    }
    if (exit_pending_) {
      // The move after G40 leaves the contour from where compensation left the tool: a line.
      if (arc) fail(reported, "the move after G40 (cutter compensation off) must be a line (G0 / G1), not an arc");
      if (machine_coordinates || (target_p.head<2>() - start_p.head<2>()).norm() > 1e-9) exit_pending_ = false;
    }
    const std::size_t first_point = path_.points.size();
    if (!arc) {
      linear_points(point, start_f, target_f, start_rotary, any_abc, reported);
      const Vec3 d = machine_coordinates ? Vec3(from_frame(target_f) - start_p) : Vec3(target_p - start_p);
      if (d.norm() > 0.0) last_tangent_p_ = d.normalized();
    } else {
      arc_points(point, motion, start_p, target_p, ijk, mid, cr_word, reported);
    }
    // Points inside a block (arc chords, rotary steps) are no corners of the program.
    for (std::size_t i = first_point; i + 1 < path_.points.size(); ++i) {
      if (path_.points[i].corner_tolerance_m == 0.0) path_.points[i].corner_tolerance_m = PathPoint::kNotProgrammed;
    }
    if (exact_stop_here && first_point < path_.points.size()) path_.points.back().corner_tolerance_m = 0.0;
    for (std::size_t k = 0; k < 3; ++k) position_[k] = target_f[static_cast<Eigen::Index>(k)];
  }

  // --- Drilling cycles CYCLE81 / CYCLE82 / CYCLE83 ----------------------------------------------
  //
  // As the 840D's cycle manual describes them, along the plane's drilling axis (G17: Z) at the
  // tool's position, in program coordinates (the frames map the points):
  //  CYCLE81(RTP, RFP, SDIS, DP, DPR), CYCLE82(..., DTB): G0 to RFP + SDIS, G1 to the depth
  //  (DPR > 0: RFP - DPR, it wins over DP, as on the control; else DP), G0 to RTP (the G-code
  //  G81 motion: canned_cycles.hpp). DTB: a dwell at the depth (seconds; < 0: spindle
  //  revolutions at the last S).
  //  CYCLE83(RTP, RFP, SDIS, DP, DPR, FDEP, FDPR, DAM, DTB, DTS, FRF, VARI, _AXN, _MDEP, _VRT,
  //  _DTD, _DIS1): the first stroke to FDPR below RFP (else to FDEP) at F * FRF, each next one
  //  DAM shorter but not shorter than DAM or _MDEP; VARI = 0 chip breaking: back _VRT (0: 1 mm)
  //  at F after each stroke; VARI = 1 swarf removal: G0 out to RFP + SDIS and G0 back to the
  //  anticipation distance above the depth reached (_DIS1, else 0.6 mm up to 30 mm deep holes,
  //  depth / 50 up to 7 mm beyond). G0 to RTP at the end. DAM < 0 (a degression factor) is not
  //  read. The dwell at the final depth: _DTD, else (0) DTB; DTB at the intermediate strokes'
  //  depths and DTS at the top are not timed.

  struct DrillCycle {
    int number = 81;
    double rtp_mm = 0.0, rfp_mm = 0.0, sdis_mm = 0.0, depth_mm = 0.0;  ///< along the drilling axis
    double first_depth_mm = 0.0;  ///< CYCLE83: the first stroke's end
    double decrement_mm = 0.0, minimum_stroke_mm = 0.0, feed_factor = 1.0;
    bool chip_breaking = false;
    double chip_break_mm = 1.0, anticipation_mm = 0.6;
    /// The dwell at the (final) depth as programmed: seconds, < 0 spindle revolutions.
    double bottom_dwell = 0.0;
    int line = 0, column = 0;  ///< where it was programmed
  };

  DrillCycle drill_cycle_of(const Word& word) const {
    const std::string& name = word.address;
    const auto arg = [&](std::size_t k) -> std::optional<double> {
      if (k >= word.arguments.size() || !word.arguments[k]) return std::nullopt;
      if (word.arguments[k]->text) fail(word, name + " argument " + std::to_string(k + 1) + " must be a number");
      return word.arguments[k]->number;
    };
    const std::size_t max_arguments = name == "CYCLE81" ? 5 : name == "CYCLE82" ? 6 : 17;
    if (word.arguments.size() > max_arguments) {
      fail(word, name + " takes at most " + std::to_string(max_arguments) + " arguments");
    }
    for (std::size_t k = 0; k < word.arguments.size(); ++k) {
      if (const auto v = arg(k); v && !(std::abs(*v * mm_per_unit_) <= detail::kMaxCoordinateMm)) {
        fail(word, name + " argument " + std::to_string(k + 1) + " = " + detail::format_number(*v) + " is outside +-1e6");
      }
    }
    DrillCycle c;
    c.number = std::stoi(name.substr(5));
    c.line = line_;
    c.column = word.column;
    const auto length = [&](std::size_t k, const char* what) {
      const auto v = arg(k);
      if (!v) fail(word, name + " needs " + what + " (argument " + std::to_string(k + 1) + ")");
      return *v * mm_per_unit_;
    };
    c.rtp_mm = length(0, "the retraction plane RTP");
    c.rfp_mm = length(1, "the reference plane RFP");
    c.sdis_mm = std::abs(arg(2).value_or(0.0)) * mm_per_unit_;
    const std::optional<double> dpr = arg(4);
    if (dpr && *dpr != 0.0) {
      c.depth_mm = c.rfp_mm - std::abs(*dpr) * mm_per_unit_;
    } else if (const auto dp = arg(3)) {
      c.depth_mm = *dp * mm_per_unit_;
    } else {
      fail(word, name + " needs the final drilling depth DP or DPR (arguments 4, 5)");
    }
    if (!(c.depth_mm < c.rfp_mm)) {
      fail(word, name + ": the drilling depth " + detail::format_number(c.depth_mm) +
                     " mm is not below the reference plane RFP " + detail::format_number(c.rfp_mm) + " mm");
    }
    if (!(c.rtp_mm >= c.rfp_mm)) {
      fail(word, name + ": the retraction plane RTP " + detail::format_number(c.rtp_mm) +
                     " mm is below the reference plane RFP " + detail::format_number(c.rfp_mm) + " mm");
    }
    if (c.number == 82) c.bottom_dwell = arg(5).value_or(0.0);
    if (c.number != 83) return c;
    // _DTD, else DTB.
    c.bottom_dwell = arg(15).value_or(0.0) != 0.0 ? *arg(15) : arg(8).value_or(0.0);
    const std::optional<double> fdpr = arg(6);
    if (fdpr && *fdpr != 0.0) {
      c.first_depth_mm = c.rfp_mm - std::abs(*fdpr) * mm_per_unit_;
    } else if (const auto fdep = arg(5)) {
      c.first_depth_mm = *fdep * mm_per_unit_;
    } else {
      fail(word, "CYCLE83 needs the first drilling depth FDEP or FDPR (arguments 6, 7)");
    }
    if (!(c.first_depth_mm < c.rfp_mm)) fail(word, "CYCLE83: the first drilling depth is not below the reference plane RFP");
    const double dam = arg(7).value_or(0.0);
    if (dam < 0.0) fail(word, "CYCLE83 DAM < 0 (a degression factor) is not read: give DAM as a length");
    c.decrement_mm = dam * mm_per_unit_;
    c.minimum_stroke_mm = std::max(c.decrement_mm, std::abs(arg(13).value_or(0.0)) * mm_per_unit_);
    const double frf = arg(10).value_or(0.0);
    if (!(frf >= 0.0 && frf <= 1.0)) fail(word, "CYCLE83 FRF (feed factor of the first stroke) must be within [0.001, 1]");
    c.feed_factor = frf == 0.0 ? 1.0 : std::max(frf, 0.001);
    const double vari = arg(11).value_or(0.0);
    if (vari != 0.0 && vari != 1.0) fail(word, "CYCLE83 VARI must be 0 (chip breaking) or 1 (swarf removal)");
    c.chip_breaking = vari == 0.0;
    if (const auto axis = arg(12); axis && *axis != 0.0 && *axis != static_cast<double>(plane_axes(plane_)[2] + 1)) {
      fail(word, "CYCLE83 _AXN: a drilling axis other than the plane's (G17: Z) is not read");
    }
    const double vrt = std::abs(arg(14).value_or(0.0)) * mm_per_unit_;
    c.chip_break_mm = vrt > 0.0 ? vrt : 1.0;
    const double dis1 = std::abs(arg(16).value_or(0.0)) * mm_per_unit_;
    const double hole_mm = c.rfp_mm - c.depth_mm;
    c.anticipation_mm = dis1 > 0.0 ? dis1 : (hole_mm <= 30.0 ? 0.6 : std::min(hole_mm / 50.0, 7.0));
    return c;
  }

  void run_drill_cycle(const DrillCycle& c, long block_number) {
    // A modal call runs in a later block: its errors name that block (and the MCALL's line).
    const bool here = c.line == line_;
    const std::string name = "CYCLE" + std::to_string(c.number) + (here ? "" : " (MCALL at line " + std::to_string(c.line) + ")");
    const auto fail = [&](int column, const std::string& message) { this->fail(here ? column : 0, message); };
    if (compensating()) fail(c.column, name + " under cutter compensation: cancel it (G40) first");
    if (!feed_m_per_s_) fail(c.column, name + " before any F word: the drilling feed is unknown");
    if (inverse_time_) fail(c.column, name + " under G93 (inverse time) is not read");
    if (!position_[0] || !position_[1] || !position_[2]) {
      fail(c.column, name + " before the tool's position is known: position it first");
    }
    const std::array<int, 3> axes = plane_axes(plane_);  // (no structured binding: the lambda below uses w)
    const int u = axes[0], v = axes[1], w = axes[2];
    const Vec3 start = from_frame(Vec3(*position_[0], *position_[1], *position_[2]));
    std::vector<detail::CycleMove> moves;
    if (c.number != 83) {
      detail::CycleHole hole;
      hole.code = 81;
      hole.u = u;
      hole.v = v;
      hole.w = w;
      hole.hole_mm = start;
      hole.r_mm = c.rfp_mm + c.sdis_mm;
      hole.bottom_mm = c.depth_mm;
      hole.initial_mm = c.rtp_mm;
      hole.return_to_initial = true;
      moves = detail::expand_cycle(start, hole);
    } else {
      detail::PeckDrilling peck;
      peck.w = w;
      peck.reference_mm = c.rfp_mm;
      peck.bottom_mm = c.depth_mm;
      peck.first_stroke_mm = c.rfp_mm - c.first_depth_mm;
      peck.stroke_decrement_mm = c.decrement_mm;
      peck.minimum_stroke_mm = c.minimum_stroke_mm;
      peck.chip_breaks_per_retract = c.chip_breaking ? -1 : 0;
      peck.chip_break_mm = c.chip_break_mm;
      peck.chip_break_rapid = false;
      peck.chip_break_feed = detail::CycleFeed::cutting;
      peck.retract_to_mm = c.rfp_mm + c.sdis_mm;
      peck.retract_rapid = true;
      peck.reapproach_clearance_mm = c.anticipation_mm;
      peck.first_stroke_feed = detail::CycleFeed::first_stroke;
      const std::size_t cap = options_.max_points_per_block + 1;
      const std::size_t strokes = detail::peck_stroke_count(peck, cap);
      if (strokes >= cap || !(3.0 * static_cast<double>(strokes) + 4.0 <= static_cast<double>(options_.max_points_per_block))) {
        fail(c.column, "CYCLE83 expands to more than " + std::to_string(options_.max_points_per_block) +
                           " points (ReaderOptions::max_points_per_block): the strokes are too short");
      }
      Vec3 p = start;
      const auto add = [&](bool rapid, double level) {
        if (p[w] == level) return;
        p[w] = level;
        moves.push_back({rapid, p, detail::CycleFeed::cutting});
      };
      add(true, c.rfp_mm + c.sdis_mm);
      for (const detail::CycleMove& m : detail::peck_moves(p, peck)) moves.push_back(m);
      p = moves.back().p_mm;
      add(true, c.rtp_mm);
    }
    if (c.bottom_dwell != 0.0) {
      if (c.bottom_dwell < 0.0 && !(spindle_rev_per_min_ > 0.0)) {
        fail(c.column, name + ": a dwell in spindle revolutions (DTB < 0) needs the spindle speed: no S before it");
      }
      const double seconds = c.bottom_dwell > 0.0 ? c.bottom_dwell : -c.bottom_dwell * 60.0 / spindle_rev_per_min_;
      for (auto m = moves.rbegin(); m != moves.rend(); ++m) {
        if (!m->rapid && m->p_mm[w] == c.depth_mm) {
          m->dwell_s = seconds;
          break;
        }
      }
    }
    detail::require_room_for_points(path_, moves.size(), options_, current_file(), line_, c.column, name);
    const int block = add_source_block(block_number);
    for (const detail::CycleMove& m : moves) {
      PathPoint point = new_point(m.rapid ? MotionKind::rapid : MotionKind::linear);
      if (!m.rapid) point.feed_m_per_s = *feed_m_per_s_ * (m.feed == detail::CycleFeed::first_stroke ? c.feed_factor : 1.0);
      point.corner_tolerance_m = 0.0;  // the control stops at each level of a cycle
      point.dwell_s = m.dwell_s;
      point.block = block;
      point.rotary_words_deg = rotary_words_deg(rotary_deg_);
      set_pose(point, to_frame(m.p_mm), rotary_deg_);
      detail::append_point(path_, point, options_, current_file(), line_);
    }
    if (!moves.empty()) {
      const Vec3 f = to_frame(moves.back().p_mm);
      for (std::size_t k = 0; k < 3; ++k) position_[k] = f[static_cast<Eigen::Index>(k)];
    }
  }

  // --- Cutter radius compensation (G40 G41 G42; cutter_compensation.hpp) ------------------------
  //
  // As in the G-code reader: each motion under G41 / G42 goes, in program coordinates, to the
  // compensator, whose moves come one element late and go through the frames point by point
  // (a mirror turns the offset side with the contour, as the control does). The entry is the
  // 840D's NORM: straight to the first element's offset start.

  bool compensating() const { return compensation_side_.has_value() && compensation_radius_mm_ > 0.0; }

  void refuse_under_compensation(const std::vector<Word>& words) const {
    const std::string cancel = " under cutter compensation is not supported: cancel it (G40) first";
    for (const Word& word : words) {
      const std::string& a = word.address;
      if (word.assignment) continue;
      if (word.has_arguments && (a == "CYCLE800" || a == "TRAORI")) fail(word, a + cancel);
      if (!word.has_value) {
        if (a == "TRAORI" || a == "TRAFOOF" || a == "TRANS" || a == "ATRANS" || a == "ROT" || a == "AROT" ||
            a == "MIRROR" || a == "AMIRROR" || a == "SUPA" || a == "CIP" || a == "CT") {
          fail(word, a + cancel);
        }
        continue;
      }
      if (a == "T" || a == "D" || a == "A" || a == "B" || a == "C" || a == "A3" || a == "B3" || a == "C3") {
        fail(word, "a tool, rotary axis or tool vector word" + cancel);
      }
      if (a == "M" && word.number() == 6.0) fail(word, "a tool change" + cancel);
      if (a != "G") continue;
      const long code = std::lround(word.number());
      if (code == 18 || code == 19 || code == 70 || code == 71 || code == 700 || code == 710 || code == 53 ||
          code == 153 || code == 93 || code == 500 || (code >= 54 && code <= 57) || (code >= 505 && code <= 599)) {
        fail(word, "a change of plane, units, work offset, feed mode or a machine-coordinate move" + cancel);
      }
    }
  }

  /// The radius [mm] of the active tool's cutting edge: ReaderOptions::cutter_radius_mm by T
  /// number (default_cutter_radius_mm for a named tool or one not in the table); D0: none.
  double cutter_radius_of(const Word& word) const {
    if (d_ == 0 || tool_number_ == 0) return 0.0;
    double radius_mm = 0.0;
    if (const auto it = options_.cutter_radius_mm.find(tool_number_); it != options_.cutter_radius_mm.end()) {
      radius_mm = it->second;
    } else if (options_.default_cutter_radius_mm) {
      radius_mm = *options_.default_cutter_radius_mm;
    } else {
      std::string known;
      for (const auto& [n, r] : options_.cutter_radius_mm) known += (known.empty() ? "T" : ", T") + std::to_string(n);
      fail(word, "no cutter radius for " + (tool_number_ >= 0 ? "T" + std::to_string(tool_number_) : std::string("the tool")) +
                     " D" + std::to_string(d_) + " (the tool table has " + (known.empty() ? std::string("none") : known) +
                     "; the part file's tools: diameter_mm)");
    }
    if (!(radius_mm >= 0.0 && radius_mm <= 0.5 * detail::kMaxCutterDiameterMm)) {
      fail(word, "the cutter radius " + detail::format_number(radius_mm) + " mm is not within [0, " +
                     detail::format_number(0.5 * detail::kMaxCutterDiameterMm) + "] mm");
    }
    return radius_mm;
  }

  void start_compensation(const Word& word) {
    const CompensationSide side = word.number() == 41.0 ? CompensationSide::left : CompensationSide::right;
    if (plane_ != Plane::xy) fail(word, "cutter radius compensation outside the G17 plane is not supported");
    if (tip_mode()) fail(word, "cutter radius compensation under TRAORI or a CYCLE800 swivel is not supported");
    if (inverse_time_) fail(word, "cutter radius compensation under inverse-time feed (G93) is not supported");
    const double radius_mm = cutter_radius_of(word);
    if (compensation_side_) {
      if (*compensation_side_ == side && radius_mm == compensation_radius_mm_) return;  // repeated
      fail(word, "cutter compensation is already on: cancel it (G40) before changing its side");
    }
    compensation_side_ = side;
    compensation_radius_mm_ = radius_mm;
  }

  void end_compensation(const Word* word) {
    if (compensator_) {
      const bool entered = compensator_->entered();
      emit_compensated(compensation_call(word, [&] { return compensator_->finish(); }), word);
      if (entered) {
        const Vec3 programmed = from_frame(filled_frame_position());
        const Vec3 f = to_frame(Vec3(compensator_->tool_mm().x(), compensator_->tool_mm().y(), programmed.z()));
        for (std::size_t k = 0; k < 3; ++k) position_[k] = f[static_cast<Eigen::Index>(k)];
        exit_pending_ = true;
        last_tangent_p_.reset();
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

  void compensated_motion(const PathPoint& point, Motion motion, const Vec3& start_p, const Vec3& end_p,
                          const std::array<const Word*, 3>& ijk, const std::array<const Word*, 3>& mid,
                          const Word* cr_word, bool exact_stop_here, const Word& reported) {
    if (motion == Motion::cip || motion == Motion::ct) {
      fail(reported, "CIP / CT under cutter compensation are not supported: program G2 / G3");
    }
    if (const Word* w = first_of({mid[0], mid[1], mid[2]})) fail(*w, "I1 J1 K1 (the intermediate point) need CIP");
    PlaneElement element;
    if (motion == Motion::cw || motion == Motion::ccw) {
      const detail::SpaceArc arc = plane_arc(motion == Motion::ccw, start_p, end_p, ijk, cr_word, reported);
      element.arc = true;
      element.centre = arc.centre.head<2>();
      element.sweep_rad = motion == Motion::ccw ? arc.sweep_rad : -arc.sweep_rad;
    }
    if (!compensator_) {
      compensator_.emplace(*compensation_side_, compensation_radius_mm_, Eigen::Vector2d(start_p.x(), start_p.y()),
                           start_p.z(), EntryRule::normal_to_next);
      exit_pending_ = false;
    }
    const int tag = next_compensation_tag_++;
    compensated_sources_[tag] = {point, exact_stop_here};
    element.start = start_p.head<2>();
    element.end = end_p.head<2>();
    element.start_w_mm = start_p.z();
    element.end_w_mm = end_p.z();
    element.tag = tag;
    const bool in_plane = element.arc || (element.end - element.start).norm() > 1e-9;
    emit_compensated(compensation_call(&reported, [&] {
                       return in_plane ? compensator_->add(element)
                                       : compensator_->add_normal_move(element.end_w_mm, tag);
                     }),
                     &reported);
  }

  void emit_compensated(const std::vector<CompensatedMove>& moves, const Word* word) {
    for (const CompensatedMove& move : moves) {
      const auto source = compensated_sources_.find(move.tag);
      if (source == compensated_sources_.end()) continue;
      PathPoint point = source->second.point;
      const std::size_t first = path_.points.size();
      if (!move.arc) {
        set_pose(point, to_frame(Vec3(move.end.x(), move.end.y(), move.end_w_mm)), rotary_deg_);
        detail::append_point(path_, point, options_, current_file(), line_);
      } else {
        if (point.kind != MotionKind::rapid) point.kind = MotionKind::arc;
        const double radius = (move.start - move.centre).norm();
        const double tolerance_mm = options_.arc_chord_tolerance_m / kMetresPerMillimetre;
        const double segments_real = detail::arc_chord_count(radius, move.sweep_rad, tolerance_mm);
        const std::string what = "the compensated arc (radius " + detail::format_number(radius) + " mm)";
        if (!(segments_real <= static_cast<double>(options_.max_points_per_block))) {
          fail(word ? word->column : 0, what + " expands to " + detail::format_number(segments_real) +
                                            " points, more than the limit of " +
                                            std::to_string(options_.max_points_per_block) +
                                            " points per block (ReaderOptions::max_points_per_block)");
        }
        const long segments = std::max(1L, static_cast<long>(segments_real));
        detail::require_room_for_points(path_, static_cast<std::size_t>(segments), options_, current_file(), line_,
                                        word ? word->column : 0, what);
        for (const Vec3& p : arc_chord_ends_mm(move, segments)) {
          set_pose(point, to_frame(p), rotary_deg_);
          detail::append_point(path_, point, options_, current_file(), line_);
        }
      }
      // Points inside a move are no corners; a corner arc has none of its own (tangent both ways).
      for (std::size_t i = first; i < path_.points.size(); ++i) {
        if (path_.points[i].corner_tolerance_m == 0.0 && (move.corner || i + 1 < path_.points.size())) {
          path_.points[i].corner_tolerance_m = PathPoint::kNotProgrammed;
        }
      }
      if (!move.corner) {
        if (source->second.exact_stop && first < path_.points.size()) path_.points.back().corner_tolerance_m = 0.0;
        compensated_sources_.erase(source);
      }
    }
  }

  PathPoint new_point(MotionKind kind) const {
    PathPoint point;
    point.kind = kind;
    point.tool_number = tool_number_;
    if (const auto mm = detail::spindle_tool_length_mm(options_, tool_number_)) point.tool_length_m = *mm * 1e-3;
    point.corner_tolerance_m = corner_tolerance_m_;
    point.jerk_mode = jerk_mode_;
    point.feedforward = feedforward_;
    point.compressor_tolerance_m = compressor_tolerance_m_;
    return point;
  }

  int add_source_block(long block_number) {
    SourceBlock source;
    source.file = current_file();
    source.line = line_;
    source.block_number = block_number;
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

  template <typename CallBack>
  auto located_call(const char* callback, CallBack call) const {
    const std::string where = "'" + line_text_ + "' (through " + callback + "): ";
    try {
      return call();
    } catch (const InfeasibleError& error) {
      throw InfeasibleError(located_message(current_file(), line_, 0, where + error.what()));
    } catch (const InputError& error) {
      throw InputError(located_message(current_file(), line_, 0, where + error.what()));
    }
  }

  Vec3 tool_axis_of(const RotaryDeg& rotary_deg, int column) const {
    const auto words = rotary_words(rotary_deg);
    const Vec3 v = located_call("rotary_words_to_tool_axis", [&] { return options_.rotary_words_to_tool_axis(words); });
    return detail::unit_tool_axis(v, current_file(), line_, column, line_text_ + " (through rotary_words_to_tool_axis)");
  }

  void set_pose(PathPoint& point, const Vec3& f_mm, const RotaryDeg& rotary_deg, bool axis_from_rotary = false) const {
    if (!tip_mode() && options_.axis_words_to_pose) {
      std::vector<std::pair<char, double>> words = {{'X', f_mm.x()}, {'Y', f_mm.y()}, {'Z', f_mm.z()}};
      for (const auto& w : rotary_words(rotary_deg)) words.push_back(w);
      const AxisWordPose pose = located_call("axis_words_to_pose", [&] { return options_.axis_words_to_pose(words); });
      if (!pose.tip_W_m.allFinite()) fail(0, "axis_words_to_pose gave a tool tip that is not finite for '" + line_text_ + "'");
      point.axis_W = detail::unit_tool_axis(pose.axis_W, current_file(), line_, 0, line_text_ + " (through axis_words_to_pose)");
      // The tool in the spindle (T), whatever D compensates.
      point.tip_W_m = detail::spindle_tip_W_m(options_, {pose.tip_W_m, point.axis_W},
                                              detail::spindle_tool_length_mm(options_, tool_number_));
      return;
    }
    if (!tip_mode()) {
      const Vec3 gauge_mm = f_mm - Vec3(0.0, 0.0, tool_length_or_zero());
      point.tip_W_m = (options_.machine_axes_W * gauge_mm + options_.machine_zero_W_mm) * kMetresPerMillimetre;
      point.axis_W = axis_W_;
      return;
    }
    point.tip_W_m = f_mm * kMetresPerMillimetre;
    point.axis_W = axis_from_rotary ? tool_axis_of(rotary_deg, 0) : axis_W_;
  }

  void linear_points(PathPoint point, const Vec3& start_f, const Vec3& end_f, const RotaryDeg& start_rotary,
                     bool any_abc, const Word& reported) {
    double largest_turn_deg = 0.0;
    if (any_abc) {
      for (std::size_t k = 0; k < 3; ++k) {
        if (!rotary_deg_[k] || !start_rotary[k]) continue;
        largest_turn_deg = std::max(largest_turn_deg, std::abs(*rotary_deg_[k] - *start_rotary[k]));
      }
    }
    if (largest_turn_deg < kSplitRotaryTurnDeg) {
      set_pose(point, end_f, rotary_deg_);
      detail::append_point(path_, point, options_, current_file(), line_);
      return;
    }
    // A turn of 180 deg or more: equal steps of at most 90 deg in axis space, as the NC
    // interpolates the axes (the chain follows poses and would take the short way).
    const auto steps = static_cast<std::size_t>(std::ceil(largest_turn_deg / kRotaryStepDeg));
    detail::require_room_for_points(path_, steps, options_, current_file(), line_, reported.column,
                                    "the rotary turn of " + detail::format_number(largest_turn_deg) + " deg");
    PathPoint end_point = point;
    set_pose(end_point, end_f, rotary_deg_);
    for (std::size_t k = 1; k < steps; ++k) {
      const double t = static_cast<double>(k) / static_cast<double>(steps);
      RotaryDeg rotary = rotary_deg_;
      for (std::size_t j = 0; j < 3; ++j) {
        if (rotary_deg_[j] && start_rotary[j]) rotary[j] = *start_rotary[j] + t * (*rotary_deg_[j] - *start_rotary[j]);
      }
      point.rotary_words_deg = rotary_words_deg(rotary);
      set_pose(point, start_f + t * (end_f - start_f), rotary, tcp_);
      detail::append_point(path_, point, options_, current_file(), line_);
    }
    detail::append_point(path_, end_point, options_, current_file(), line_);
  }

  double arc_radius_tolerance_mm(double r_mm) const {
    const double absolute_mm = mm_per_unit_ == 1.0 ? options_.arc_radius_tolerance_mm
                                                   : options_.arc_radius_tolerance_inch * kMillimetresPerInch;
    return std::max(absolute_mm, options_.arc_radius_relative_tolerance * r_mm);
  }
  static std::string format_mm(double value_mm) { return detail::format_number(std::round(value_mm * 1e6) / 1e6); }

  /// The arc of a G2 / G3 / CIP / CT block in program coordinates [mm], tessellated and mapped
  /// through the frames point by point (so a mirror turns G2 into G3 as on the control).
  void arc_points(PathPoint point, Motion motion, const Vec3& s, const Vec3& e,
                  const std::array<const Word*, 3>& ijk, const std::array<const Word*, 3>& mid,
                  const Word* cr_word, const Word& reported) {
    detail::SpaceArc arc;
    if (motion == Motion::cw || motion == Motion::ccw) {
      if (const Word* w = first_of({mid[0], mid[1], mid[2]})) fail(*w, "I1 J1 K1 (the intermediate point) need CIP");
      arc = plane_arc(motion == Motion::ccw, s, e, ijk, cr_word, reported);
    } else if (motion == Motion::cip) {
      if (const Word* w = first_of({ijk[0], ijk[1], ijk[2], cr_word})) fail(*w, "CIP takes the intermediate point I1= J1= K1=");
      Vec3 m = s;
      if (!mid[0] && !mid[1] && !mid[2]) fail(reported, "CIP needs the intermediate point I1= J1= K1=");
      for (std::size_t k = 0; k < 3; ++k) {
        if (!mid[k]) continue;
        const double value = mid[k]->number() * mm_per_unit_;
        m[static_cast<Eigen::Index>(k)] = incremental_word(*mid[k]) ? s[static_cast<Eigen::Index>(k)] + value : value;
      }
      arc = circle_through(s, m, e, reported);
    } else {
      if (const Word* w = first_of({ijk[0], ijk[1], ijk[2], mid[0], mid[1], mid[2], cr_word})) {
        fail(*w, "CT (tangential arc) takes the end point only");
      }
      if (!last_tangent_p_) fail(reported, "CT needs a motion before it (its start tangent)");
      arc = tangent_arc(s, *last_tangent_p_, e, reported);
    }
    const double tolerance_mm = options_.arc_chord_tolerance_m / kMetresPerMillimetre;
    const double segments_real = detail::arc_chord_count(arc.radius, arc.sweep_rad, tolerance_mm);
    const std::string what = "the arc (radius " + detail::format_number(arc.radius) + " mm, " +
                             detail::format_number(arc.sweep_rad / kDegToRad) + " deg, chord tolerance " +
                             detail::format_number(tolerance_mm) + " mm)";
    if (!(segments_real <= static_cast<double>(options_.max_points_per_block))) {
      fail(reported, what + " expands to " + detail::format_number(segments_real) + " points, more than the limit of " +
                         std::to_string(options_.max_points_per_block) + " points per block (ReaderOptions::max_points_per_block)");
    }
    const auto segments = static_cast<long>(segments_real);
    detail::require_room_for_points(path_, static_cast<std::size_t>(segments), options_, current_file(), line_, reported.column, what);
    if (point.inverse_time_feed_per_s > 0.0) point.inverse_time_feed_per_s *= static_cast<double>(segments);
    for (long k = 1; k <= segments; ++k) {
      const Vec3 p = k < segments ? arc.at(static_cast<double>(k) / static_cast<double>(segments)) : e;
      set_pose(point, to_frame(p), rotary_deg_);
      detail::append_point(path_, point, options_, current_file(), line_);
    }
    last_tangent_p_ = arc.tangent(1.0);
  }

  detail::SpaceArc plane_arc(bool ccw, const Vec3& s3, const Vec3& e3, const std::array<const Word*, 3>& ijk,
                             const Word* cr_word, const Word& reported) const {
    const auto [u, v, w] = plane_axes(plane_);
    if (ijk[static_cast<std::size_t>(w)]) {
      fail(*ijk[static_cast<std::size_t>(w)], std::string("not an arc centre word in the ") +
                                                 (plane_ == Plane::xy ? "G17" : plane_ == Plane::zx ? "G18" : "G19") + " plane");
    }
    const bool has_ijk = ijk[0] || ijk[1] || ijk[2];
    if (has_ijk && cr_word) fail(*cr_word, "an arc with both a centre (I J K) and a radius (CR=)");
    if (!has_ijk && !cr_word) fail(reported, "an arc needs a centre (I J K), a radius (CR=) or CIP / CT");
    const Eigen::Vector2d s(s3[u], s3[v]);
    const Eigen::Vector2d e(e3[u], e3[v]);
    Eigen::Vector2d c;
    bool full_circle = false;
    if (has_ijk) {
      // I J K: from the start, or absolute with I=AC(..).
      for (const int axis : {u, v}) {
        const Word* word = ijk[static_cast<std::size_t>(axis)];
        const double value = word ? word->number() * mm_per_unit_ : 0.0;
        const bool absolute = word && word->value.dimension == Value::Dimension::absolute;
        (axis == u ? c.x() : c.y()) = absolute ? value : (axis == u ? s.x() : s.y()) + value;
      }
      full_circle = (e - s).norm() < kFullCircleDistanceMm;
    } else {
      const double r = std::abs(cr_word->number()) * mm_per_unit_;
      const double d = (e - s).norm();
      if (d < kFullCircleDistanceMm) fail(*cr_word, "a CR= arc cannot be a full circle (end = start): use I J K");
      if (r == 0.0) fail(*cr_word, "zero arc radius");
      double h2 = r * r - 0.25 * d * d;
      if (h2 < 0.0) {
        const double tolerance_mm = arc_radius_tolerance_mm(0.5 * d);
        if (0.5 * d - r > tolerance_mm) {
          fail(*cr_word, "the radius is smaller than half the distance from start to end (" + format_mm(0.5 * d) +
                             " mm) by " + format_mm(0.5 * d - r) + " mm, more than the tolerance of " + format_mm(tolerance_mm) + " mm");
        }
        h2 = 0.0;
      }
      const Eigen::Vector2d chord = (e - s) / d;
      const Eigen::Vector2d left(-chord.y(), chord.x());
      // CR > 0: the arc of at most 180 deg (centre left of the chord for G3); CR < 0: more.
      const double side = (ccw ? 1.0 : -1.0) * (cr_word->number() > 0.0 ? 1.0 : -1.0);
      c = 0.5 * (s + e) + side * std::sqrt(h2) * left;
    }
    double r_start = (s - c).norm();
    const double r_end = (e - c).norm();
    if (r_start == 0.0) fail(reported, "an arc of zero radius (the centre is the start point)");
    const double radius_tolerance = arc_radius_tolerance_mm(std::max(r_start, r_end));
    if (std::abs(r_start - r_end) > radius_tolerance) {
      fail(reported, "the arc's start and end are not at the same distance from its centre: the radii differ by " +
                         format_mm(std::abs(r_start - r_end)) + " mm (start radius " + format_mm(r_start) + " mm, end radius " +
                         format_mm(r_end) + " mm), more than the tolerance of " + format_mm(radius_tolerance) + " mm");
    }
    if (!full_circle && r_start != r_end) {
      const Eigen::Vector2d chord = (e - s).normalized();
      const Eigen::Vector2d normal(-chord.y(), chord.x());
      const Eigen::Vector2d middle = 0.5 * (s + e);
      c = middle + (c - middle).dot(normal) * normal;
      r_start = (s - c).norm();
    }
    const double a0 = std::atan2(s.y() - c.y(), s.x() - c.x());
    const double a1 = std::atan2(e.y() - c.y(), e.x() - c.x());
    constexpr double two_pi = 2.0 * std::numbers::pi;
    double sweep = 0.0;  // > 0 along the direction of motion
    if (full_circle) {
      sweep = two_pi;
    } else {
      sweep = ccw ? a1 - a0 : a0 - a1;
      while (sweep <= 0.0) sweep += two_pi;
      while (sweep > two_pi) sweep -= two_pi;
    }
    detail::SpaceArc arc;
    const Vec3 U = Vec3::Unit(u), V = Vec3::Unit(v), W = Vec3::Unit(w);
    arc.centre = c.x() * U + c.y() * V + s3[w] * W;
    arc.radius = r_start;
    arc.u = (std::cos(a0) * U + std::sin(a0) * V);
    const Vec3 ccw_dir = -std::sin(a0) * U + std::cos(a0) * V;
    arc.v = ccw ? ccw_dir : Vec3(-ccw_dir);
    arc.sweep_rad = sweep;
    arc.lift = (e3[w] - s3[w]) * W;
    return arc;
  }

  /// CIP: the circle through start, intermediate point and end, from the start over the
  /// intermediate point to the end.
  detail::SpaceArc circle_through(const Vec3& s, const Vec3& m, const Vec3& e, const Word& reported) const {
    const Vec3 a = m - s, b = e - s;
    const Vec3 n = a.cross(b);
    if (n.norm() < 1e-9 * std::max(1.0, a.norm() * b.norm())) {
      fail(reported, "CIP: start, intermediate and end point lie on a line (no circle through them)");
    }
    // Centre: s + (|a|^2 (b x n) + |b|^2 (n x a)) / (2 |n|^2).
    const Vec3 c = s + (a.squaredNorm() * b.cross(n) + b.squaredNorm() * n.cross(a)) / (2.0 * n.squaredNorm());
    detail::SpaceArc arc;
    arc.centre = c;
    arc.radius = (s - c).norm();
    arc.u = (s - c) / arc.radius;
    const Vec3 normal = n.normalized();  // s -> m -> e turns counter-clockwise about n
    arc.v = normal.cross(arc.u);
    const Vec3 re = e - c;
    double sweep = std::atan2(re.dot(arc.v), re.dot(arc.u));
    if (sweep <= 0.0) sweep += 2.0 * std::numbers::pi;
    arc.sweep_rad = sweep;
    return arc;
  }

  /// CT: the arc that leaves the start along the previous motion's tangent and ends at e.
  detail::SpaceArc tangent_arc(const Vec3& s, const Vec3& t, const Vec3& e, const Word& reported) const {
    const Vec3 d = e - s;
    const Vec3 across = d - d.dot(t) * t;
    if (across.norm() < 1e-9 * std::max(1.0, d.norm())) {
      fail(reported, "CT: the end point lies on the start tangent (no arc; program a G1)");
    }
    const Vec3 m = across.normalized();
    detail::SpaceArc arc;
    arc.radius = d.squaredNorm() / (2.0 * d.dot(m));
    arc.centre = s + arc.radius * m;
    arc.u = -m;
    arc.v = t;
    // The chord makes half the central angle with the tangent.
    arc.sweep_rad = 2.0 * std::atan2(d.dot(m), d.dot(t));
    return arc;
  }

  // --- Subprograms -----------------------------------------------------------------------------

  std::optional<std::string> find_subprogram_file(const std::string& name) const {
    std::string folder = options_.subprogram_folder;
    if (folder.empty()) return std::nullopt;
    for (const std::string& candidate : {name + ".SPF", name + ".spf", detail::to_upper(name) + ".SPF",
                                         detail::to_upper(name) + ".spf", name + ".MPF", name + ".mpf"}) {
      const std::filesystem::path p = std::filesystem::path(folder) / candidate;
      std::error_code error;
      if (std::filesystem::is_regular_file(p, error)) return p.string();
    }
    return std::nullopt;
  }

  void call_subprogram(const Word& word, const Word* p_word, long) {
    const std::string name = word.address == "L" ? "L" + detail::format_number(word.number()) : word.address;
    if (word.address == "L" && (word.number() < 0.0 || word.number() != std::round(word.number()))) {
      fail(word, "L needs a whole subprogram number");
    }
    long repeats = 1;
    if (p_word) {
      if (!(p_word->number() >= 1.0 && p_word->number() <= 1e6) || p_word->number() != std::round(p_word->number())) {
        fail(*p_word, "P (the repeats) must be a whole number 1 .. 1e6");
      }
      repeats = std::lround(p_word->number());
    }
    if (calls_.size() >= options_.max_call_depth) {
      fail(word, "calls nested more than " + std::to_string(options_.max_call_depth) + " deep (ReaderOptions::max_call_depth)");
    }
    const auto path = find_subprogram_file(name);
    if (!path) {
      fail(word, "subprogram " + name + " not found (" + name + ".SPF in " +
                     (options_.subprogram_folder.empty() ? std::string("no folder: ReaderOptions::subprogram_folder") : options_.subprogram_folder) + ")");
    }
    std::size_t index = programs_.size();
    for (std::size_t k = 0; k < programs_.size(); ++k) {
      if (programs_[k].file == *path) index = k;
    }
    if (index == programs_.size()) {
      std::string text = detail::read_text_file(*path);
      const std::string_view body = detail::without_byte_order_mark(text);
      detail::require_utf8_text(body, *path);
      programs_.push_back(load_program(std::string(body), *path));
    }
    jumped_ = true;
    calls_.push_back(Call{index, 0, repeats - 1, {}, {}});
  }

  // --- Helpers ---------------------------------------------------------------------------------

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

  const std::string& file_;
  const ReaderOptions& options_;
  Toolpath path_;
  std::vector<Program> programs_;
  std::vector<Call> calls_;
  int line_ = 0;
  std::string line_text_;
  bool ended_ = false;
  bool started_ = false;
  bool jumped_ = false;
  std::size_t executed_blocks_ = 0;
  int warning_count_ = 0;
  // Language.
  std::map<std::size_t, double> r_;
  std::map<std::string, std::string> defined_types_;
  // Modal state.
  std::optional<Motion> motion_;
  Plane plane_ = Plane::xy;
  std::optional<DrillCycle> modal_drill_;  ///< MCALL CYCLE8x(...)
  double mm_per_unit_ = 1.0;
  bool incremental_ = false;
  bool inverse_time_ = false;
  std::optional<double> feed_m_per_s_;
  std::optional<double> block_inverse_time_per_s_;
  bool tcp_ = false;
  Affine program_frame_;
  Affine swivel_;
  std::map<std::string, Vec3> offsets_mm_;
  bool implicit_g54_ = true;
  ActiveOffset offset_;
  std::optional<int> next_tool_;
  std::string next_tool_name_;
  int tool_number_ = -1;
  int d_ = 0;
  mutable bool length_missing_ = false;
  std::array<std::optional<double>, 3> position_;
  RotaryDeg rotary_deg_;
  Vec3 axis_W_ = Vec3::UnitZ();
  std::optional<Vec3> last_tangent_p_;
  // Cutter radius compensation.
  std::optional<CompensationSide> compensation_side_;
  double compensation_radius_mm_ = 0.0;
  std::optional<CutterCompensator> compensator_;  // from the first motion under G41 / G42
  double spindle_rev_per_min_ = 0.0;  // the last S, for G4 S (revolutions)
  const Word* dwell_word_ = nullptr;   // the G4 of the block being read
  struct CompensatedSource {
    PathPoint point;
    bool exact_stop = false;
  };
  std::map<int, CompensatedSource> compensated_sources_;  // by element tag, until its moves are made
  int next_compensation_tag_ = 0;
  bool exit_pending_ = false;  // G40 given: the next move in the plane must be a line
  // NC modes.
  PathMode path_mode_ = PathMode::g64;  // unspecified until the program says: NaN tolerance
  double adis_mm_ = 0.0;
  double ctol_m_ = PathPoint::kNotProgrammed;
  double cycle832_tol_m_ = PathPoint::kNotProgrammed;
  bool compressor_on_ = false;
  double corner_tolerance_m_ = PathPoint::kNotProgrammed;
  JerkMode jerk_mode_ = JerkMode::unspecified;
  FeedforwardMode feedforward_ = FeedforwardMode::unspecified;
  double compressor_tolerance_m_ = PathPoint::kNotProgrammed;
};

}  // namespace

Toolpath parse_siemens(const std::string& text, const std::string& file_name_for_messages, const ReaderOptions& options) {
  SiemensReader reader(file_name_for_messages, options);
  return detail::read_with_located_errors(reader, text, file_name_for_messages);
}

Toolpath read_siemens(const std::string& path, const ReaderOptions& options) {
  if (!options.subprogram_folder.empty()) return parse_siemens(detail::read_text_file(path), path, options);
  ReaderOptions with_folder = options;
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  with_folder.subprogram_folder = folder.empty() ? "." : folder.string();
  return parse_siemens(detail::read_text_file(path), path, with_folder);
}

}  // namespace vmsim::toolpath
