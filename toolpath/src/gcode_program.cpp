// G-code program pre-pass (gcode_program.hpp): the parameters, expressions, control flow and
// subprograms of Fanuc Custom Macro B and LinuxCNC, run into plain blocks for the block
// interpreter. The language is documented in vmsim/toolpath/toolpath.hpp ("G-code programs").
#include "gcode_program.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstddef>
#include <numbers>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "toolpath_detail.hpp"
#include "vmsim/common/errors.hpp"

namespace vmsim::toolpath::detail {

int ExpandedBlock::source_column(int text_column) const {
  if (!columns || columns->empty() || text_column <= 0) return text_column;
  const auto after = std::upper_bound(columns->begin(), columns->end(),
                                      std::pair<int, int>{text_column, INT_MAX});
  return after == columns->begin() ? columns->front().second : std::prev(after)->second;
}

namespace {

constexpr double kDegrees = 180.0 / std::numbers::pi;
/// #1..#33: the locals of a call level (Fanuc; LinuxCNC's o-call fills #1..#30).
constexpr int kLocalCount = 33;
/// #34..#999: common to all levels (Fanuc #100-#199 and #500-#999, LinuxCNC's user numbers).
/// #1000 and above are control system variables, which a simulation cannot give.
constexpr int kLastParameter = 999;
/// Fanuc #3000: writing it raises an alarm (the program stops with its message).
constexpr int kAlarmParameter = 3000;
/// A parameter number, loop or call count written as an expression must be this close to an
/// integer (LinuxCNC's own rule).
constexpr double kIntegerTolerance = 1e-4;
/// Largest program, block or loop number, call or repeat count (as the block interpreter's N O
/// words).
constexpr double kMaxLabel = 1e9;
/// LinuxCNC o-call passes at most this many arguments.
constexpr int kMaxCallArguments = 30;

// --- Values -------------------------------------------------------------------------------------

/// A parameter's value: a number, or vacant (Fanuc #0: never set). Vacant reads as 0 in
/// arithmetic; a word whose value is vacant is left out of its block.
struct Value {
  double number = 0.0;
  bool vacant = false;
  static Value of(double v) { return Value{v, false}; }
  static Value empty() { return Value{0.0, true}; }
};

/// The shortest fixed-point text that reads back as `v` (the block interpreter takes no
/// exponents).
std::string number_text(double v) {
  if (v == 0.0) return "0";  // also -0
  std::array<char, 512> buffer{};
  const auto result =
      std::to_chars(buffer.data(), buffer.data() + buffer.size(), v, std::chars_format::fixed);
  return std::string(buffer.data(), result.ptr);
}

// --- Tokens -------------------------------------------------------------------------------------

enum class Tok {
  end, number, letter, keyword, siemens, hash, name, lbracket, rbracket, plus, minus, star, power,
  slash, equals, comma, other
};

struct Token {
  Tok kind = Tok::end;
  std::size_t begin = 0;  ///< [begin, end) in the line
  std::size_t end = 0;
  std::string word;       ///< letter / keyword upper case; name lower case, blanks removed
  double number = 0.0;
  int column() const { return static_cast<int>(begin) + 1; }
};

bool is_function(std::string_view w) {
  static constexpr std::array<std::string_view, 14> kFunctions = {
      "SIN", "COS", "TAN", "ASIN", "ACOS", "ATAN", "SQRT", "ABS", "ROUND", "FIX", "FUP", "LN",
      "EXP", "EXISTS"};
  return std::find(kFunctions.begin(), kFunctions.end(), w) != kFunctions.end();
}

/// Words of two or more letters that belong to the macro language.
bool is_macro_keyword(std::string_view w) {
  static constexpr std::array<std::string_view, 30> kKeywords = {
      "MOD", "AND", "OR", "XOR", "EQ", "NE", "GT", "GE", "LT", "LE", "IF", "THEN", "GOTO", "WHILE",
      "DO", "END", "SUB", "ENDSUB", "CALL", "RETURN", "ELSEIF", "ELSE", "ENDIF", "ENDWHILE",
      "REPEAT", "ENDREPEAT", "BREAK", "CONTINUE"};
  return is_function(w) || std::find(kKeywords.begin(), kKeywords.end(), w) != kKeywords.end();
}

/// Where a line is, for messages.
struct Site {
  const std::string& file;
  int line;
  [[noreturn]] void fail(int column, const std::string& message) const {
    throw InputError(located_message(file, line, column, message));
  }
};

std::vector<Token> lex(std::string_view line, const Site& site) {
  std::vector<Token> tokens;
  std::size_t i = 0;
  const std::size_t n = line.size();
  const auto alpha = [&](std::size_t k) {
    return k < n && std::isalpha(static_cast<unsigned char>(line[k]));
  };
  const auto digit = [&](std::size_t k) {
    return k < n && std::isdigit(static_cast<unsigned char>(line[k]));
  };
  while (i < n) {
    const char c = line[i];
    if (std::isspace(static_cast<unsigned char>(c))) {
      ++i;
      continue;
    }
    if (c == '(') {
      // Comments, LinuxCNC's (debug, ...) and (print, ...) included, are not run.
      const std::size_t close = line.find(')', i);
      if (close == std::string_view::npos) {
        site.fail(static_cast<int>(i) + 1, "comment '(' is not closed on its line");
      }
      i = close + 1;
      continue;
    }
    if (c == ';') break;
    Token t;
    t.begin = i;
    if (digit(i) || (c == '.' && digit(i + 1))) {
      while (digit(i)) ++i;
      if (i < n && line[i] == '.') ++i;
      while (digit(i)) ++i;
      t.kind = Tok::number;
      t.end = i;
      std::string problem;
      const auto value = parse_decimal(line.substr(t.begin, i - t.begin), &problem);
      if (!value) {
        site.fail(t.column(), "'" + std::string(line.substr(t.begin, i - t.begin)) + "': " +
                                  problem);
      }
      t.number = *value;
    } else if (alpha(i)) {
      std::size_t j = i;
      while (alpha(j)) ++j;
      const std::string run = to_upper(line.substr(i, j - i));
      if (run.size() == 1) {
        t.kind = Tok::letter;
        t.word = run;
        i = j;
      } else if (is_macro_keyword(run)) {
        t.kind = Tok::keyword;
        t.word = run;
        i = j;
      } else if (is_function(std::string_view(run).substr(1))) {
        // LinuxCNC reads a function as a word's value without brackets: "XSIN[30]".
        t.kind = Tok::letter;
        t.word = run.substr(0, 1);
        i = i + 1;
      } else {
        // Another keyword (Siemens TRAORI, CYCLE81): handed to the block interpreter as written.
        while (j < n && (std::isalnum(static_cast<unsigned char>(line[j])) || line[j] == '_')) ++j;
        t.kind = Tok::siemens;
        i = j;
      }
      t.end = i;
    } else {
      ++i;
      switch (c) {
        case '#': t.kind = Tok::hash; break;
        case '[': t.kind = Tok::lbracket; break;
        case ']': t.kind = Tok::rbracket; break;
        case '+': t.kind = Tok::plus; break;
        case '-': t.kind = Tok::minus; break;
        case '/': t.kind = Tok::slash; break;
        case '=': t.kind = Tok::equals; break;
        case ',': t.kind = Tok::comma; break;
        case '*':
          t.kind = Tok::star;
          if (i < n && line[i] == '*') {
            t.kind = Tok::power;
            ++i;
          }
          break;
        case '<': {
          const bool after_hash_or_o =
              !tokens.empty() && (tokens.back().kind == Tok::hash ||
                                  (tokens.back().kind == Tok::letter && tokens.back().word == "O"));
          if (!after_hash_or_o) {
            t.kind = Tok::other;
            break;
          }
          const std::size_t close = line.find('>', i);
          if (close == std::string_view::npos) {
            site.fail(t.column(), "'<': the name is not closed with '>' on its line");
          }
          // LinuxCNC: names ignore case and blanks.
          for (std::size_t k = i; k < close; ++k) {
            if (!std::isspace(static_cast<unsigned char>(line[k]))) {
              t.word += static_cast<char>(std::tolower(static_cast<unsigned char>(line[k])));
            }
          }
          if (t.word.empty()) site.fail(t.column(), "'<>': an empty name");
          t.kind = Tok::name;
          i = close + 1;
          break;
        }
        default:
          t.kind = Tok::other;
          // One whole UTF-8 character, for the message.
          while (i < n && (static_cast<unsigned char>(line[i]) & 0xC0) == 0x80) ++i;
          break;
      }
      t.end = i;
    }
    tokens.push_back(std::move(t));
  }
  Token end;
  end.kind = Tok::end;
  end.begin = end.end = n;
  tokens.push_back(end);
  return tokens;
}

/// Character classes of the fast path (is_plain): most characters of a plain block (digits,
/// blanks, '.', '-') need one table look-up.
enum CharClass : unsigned char { kPlainChar, kLetterChar, kMacroChar, kCommentChar, kEndChar };

constexpr std::array<unsigned char, 256> char_classes() {
  std::array<unsigned char, 256> classes{};
  for (int c = 'A'; c <= 'Z'; ++c) classes[static_cast<std::size_t>(c)] = kLetterChar;
  for (int c = 'a'; c <= 'z'; ++c) classes[static_cast<std::size_t>(c)] = kLetterChar;
  for (const char c : {'#', '[', '<', 'O', 'o'}) {
    classes[static_cast<unsigned char>(c)] = kMacroChar;
  }
  classes[static_cast<unsigned char>('(')] = kCommentChar;
  classes[static_cast<unsigned char>(';')] = kEndChar;
  return classes;
}
constexpr std::array<unsigned char, 256> kCharClasses = char_classes();

/// True when the line has nothing for the macro language: no '#', '[', '<', O word, keyword of
/// two or more letters, M98/M99 or G65/G66/G67 (comments skipped). Such a line goes to the block
/// interpreter unchanged.
bool is_plain(std::string_view line) {
  const std::size_t n = line.size();
  const auto class_of = [&](std::size_t k) {
    return kCharClasses[static_cast<unsigned char>(line[k])];
  };
  for (std::size_t i = 0; i < n; ++i) {
    switch (class_of(i)) {
      case kPlainChar: continue;
      case kMacroChar: return false;
      case kEndChar: return true;
      case kCommentChar: {
        const std::size_t close = line.find(')', i);
        if (close == std::string_view::npos) return true;  // the interpreter reports it
        i = close;
        continue;
      }
      default: break;
    }
    // A letter: a keyword has two or more; M98 M99 G65-G67 call subprograms.
    if (i + 1 < n && class_of(i + 1) != kPlainChar) {
      if (class_of(i + 1) != kCommentChar && class_of(i + 1) != kEndChar) return false;
    }
    const char upper = static_cast<char>(line[i] & ~0x20);
    if (upper != 'M' && upper != 'G') continue;
    std::size_t k = i + 1;
    while (k < n && (line[k] == ' ' || line[k] == '\t')) ++k;
    while (k < n && line[k] == '0') ++k;
    if (k + 1 < n && std::isdigit(static_cast<unsigned char>(line[k])) &&
        std::isdigit(static_cast<unsigned char>(line[k + 1])) &&
        (k + 2 >= n || !std::isdigit(static_cast<unsigned char>(line[k + 2])))) {
      const int code = (line[k] - '0') * 10 + (line[k + 1] - '0');
      if (upper == 'M' && (code == 98 || code == 99)) return false;
      if (upper == 'G' && code >= 65 && code <= 67) return false;
    }
  }
  return true;
}

// --- The program's structure --------------------------------------------------------------------

/// What a line holds for the control flow (found once, the first time a jump needs it).
struct LineInfo {
  long program_number = -1;  ///< Fanuc O number starting a program
  int program = 0;           ///< how many Fanuc O lines up to here (the program it belongs to)
  int do_id = 0;             ///< Fanuc WHILE [..] DO m / DO m
  int end_id = 0;            ///< Fanuc END m
  bool m99 = false;          ///< M99 (end of a Fanuc subprogram)
  bool m_end = false;        ///< M2 / M30 (end of the main program)
  int o_word = -1;           ///< LinuxCNC o-word: index into Source::o_words
};

/// A LinuxCNC o-word label: numbers compare by value (o0100 is o100).
std::string label_of(const Token& t) {
  if (t.kind == Tok::name) return "<" + t.word + ">";
  return number_text(t.number);
}

/// A LinuxCNC o-word of the index.
struct OWord {
  std::string label;    ///< "100", "<name>"
  std::string keyword;  ///< lower case: "sub", "if", ...
};

/// A file of the program and the index of its structure (made at the first jump).
struct Source {
  std::string file;          ///< for messages and SourceBlock::file
  std::string text_storage;  ///< the text of a subprogram file read here
  std::string_view text;
  bool indexed = false;
  bool numbered = false;
  std::vector<std::size_t> starts;  ///< the offset of each line
  std::vector<LineInfo> info;
  std::unordered_map<long, std::vector<std::size_t>> n_lines;
  std::unordered_map<long, std::size_t> programs;
  std::vector<OWord> o_words;
  std::unordered_map<std::string, std::vector<std::size_t>> o_lines;
  std::unordered_map<std::string, std::size_t> subs;
  /// The tokens of each line run so far, once the program jumps (a loop lexes its lines once).
  std::unordered_map<std::size_t, std::vector<Token>> token_cache;
};

/// The local a macro call's argument word sets (Fanuc argument specification I: A -> #1,
/// B -> #2, C -> #3, I J K -> #4 #5 #6, D E F -> #7 #8 #9, H -> #11, M -> #13, Q-Z -> #17-#26);
/// 0 for a letter that is no argument (G L N O P).
int argument_local(char letter) {
  static constexpr std::array<int, 26> kLocalOfLetter = {
      // A  B  C  D  E  F  G  H   I  J  K  L  M   N  O  P  Q   R   S   T   U   V   W   X   Y   Z
      1, 2, 3, 7, 8, 9, 0, 11, 4, 5, 6, 0, 13, 0, 0, 0, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26};
  if (letter < 'A' || letter > 'Z') return 0;
  return kLocalOfLetter[static_cast<std::size_t>(letter - 'A')];
}

struct Locals {
  std::array<Value, kLocalCount + 1> numbered;  ///< [0] unused
  std::unordered_map<std::string, Value> named;
  Locals() { numbered.fill(Value::empty()); }
};

enum class FrameKind { main, m98, g65, o_sub };

/// One level of the call stack.
struct Frame {
  FrameKind kind = FrameKind::main;
  std::size_t locals = 0;       ///< index into the locals (M98 shares its caller's)
  std::size_t body = 0;         ///< first line of the called body
  std::size_t body_source = 0;  ///< its file (index into Program::sources_)
  std::size_t return_to = 0;    ///< line after the call
  std::size_t return_source = 0;
  long repeats_left = 1;        ///< M98 L / G65 L
  std::string name;             ///< "O1000", "o<name>", for messages
  int call_line = 0;            ///< 1-based line of the call, for messages
  Locals arguments;             ///< G65: the locals each repetition starts from
  bool modal_body = false;      ///< a macro a G66 modal call started
  std::unordered_map<std::size_t, long> repeat_counts;  ///< LinuxCNC repeat loops, by line
};

/// A parameter to write: numbered or named.
struct Target {
  int number = -1;
  std::string name;
  int column = 0;
  std::string text;
};

/// A word of the block handed on.
struct OutWord {
  char letter = '\0';
  std::optional<double> value;  ///< nullopt: a Siemens keyword / form handed on as written
  std::string text;
  int column = 0;
};

class Program {
 public:
  Program(std::string_view text, const std::string& file, const ReaderOptions& options,
          const std::function<bool(const ExpandedBlock&)>& emit)
      : options_(options), emit_(emit) {
    auto main = std::make_unique<Source>();
    main->file = file;
    main->text = text;
    sources_.push_back(std::move(main));
  }

  void run() {
    locals_.emplace_back();
    frames_.push_back(Frame{});
    std::size_t line = 0;
    std::size_t offset = 0;
    while (true) {
      if (offset >= src().text.size() || (src().indexed && line >= src().starts.size())) {
        if (frames_.size() > 1) {
          const Frame& frame = frames_.back();
          Site{sources_[frame.return_source]->file, frame.call_line}.fail(
              0, "the file ends inside subprogram " + frame.name + " called here (no " +
                     (frame.kind == FrameKind::o_sub ? "endsub" : "M99") + ")");
        }
        return;
      }
      std::size_t end = src().text.find('\n', offset);
      if (end == std::string_view::npos) end = src().text.size();
      std::string_view raw = src().text.substr(offset, end - offset);
      if (!raw.empty() && raw.back() == '\r') raw.remove_suffix(1);
      line_ = line;
      jump_.reset();
      jump_source_ = source_;
      // Counted from the first jump on: a program that runs straight through (however long)
      // runs each block once, only a jump can run for ever.
      if (jumped_ && ++executed_ > options_.max_executed_blocks) {
        site().fail(0, "more than " + std::to_string(options_.max_executed_blocks) +
                           " blocks run (ReaderOptions::max_executed_blocks): a loop that does "
                           "not end?");
      }
      if (!execute(raw)) return;
      if (jump_) {
        jumped_ = true;
        source_ = jump_source_;
        ensure_index();
        line = *jump_;
        offset = line < src().starts.size() ? src().starts[line] : src().text.size();
      } else {
        ++line;
        offset = end + 1;
      }
    }
  }

 private:
  Source& src() { return *sources_[source_]; }
  const Source& src() const { return *sources_[source_]; }
  Site site() const { return Site{src().file, static_cast<int>(line_) + 1}; }
  [[noreturn]] void fail(const Token& t, const std::string& what, std::string_view raw) const {
    const std::string text(raw.substr(t.begin, t.end - t.begin));
    site().fail(t.column(), "'" + (t.kind == Tok::end ? std::string("end of block") : text) +
                                "': " + what);
  }

  bool hand_on(std::string_view raw, std::string_view text,
               const std::vector<std::pair<int, int>>* columns) {
    ExpandedBlock block;
    block.line = static_cast<int>(line_) + 1;
    block.source = raw;
    block.text = text;
    block.columns = columns;
    block.file = source_ == 0 ? nullptr : &src().file;
    return emit_(block);
  }

  /// Runs one line; false when the program ends.
  bool execute(std::string_view raw) {
    std::size_t first = 0;
    while (first < raw.size() && std::isspace(static_cast<unsigned char>(raw[first]))) ++first;
    // Block delete and '%' lines go to the interpreter as they are (it warns / skips them).
    // Under G66.1 a plain block is a macro call, not a block to hand on.
    const bool plain = is_plain(raw) && !each_block_call_active();
    if (first == raw.size() || raw[first] == '/' || raw[first] == '%' || plain) {
      if (!hand_on(raw, raw, nullptr)) return false;
      if (raw[first] != '/' && raw[first] != '%') modal_call_after(raw, raw);
      return true;
    }
    tokens_ = &tokens_of(raw);
    raw_ = raw;
    k_ = 0;
    return statement();
  }

  /// The tokens of the line running (`raw`, at line_).
  const std::vector<Token>& tokens_of(std::string_view raw) {
    if (!src().indexed) {
      line_tokens_ = lex(raw, site());
      return line_tokens_;
    }
    const auto found = src().token_cache.find(line_);
    if (found != src().token_cache.end()) return found->second;
    return src().token_cache.emplace(line_, lex(raw, site())).first->second;
  }

  // --- Token access ---------------------------------------------------------------------------

  const Token& peek(std::size_t ahead = 0) const {
    return (*tokens_)[std::min(k_ + ahead, tokens_->size() - 1)];
  }
  const Token& take() {
    const Token& t = (*tokens_)[k_];
    if (k_ + 1 < tokens_->size()) ++k_;
    return t;
  }
  bool at_keyword(std::string_view w) const {
    return peek().kind == Tok::keyword && peek().word == w;
  }
  const Token& expect(Tok kind, const char* what) {
    if (peek().kind != kind) fail(peek(), std::string("expected ") + what, raw_);
    return take();
  }
  std::string span(std::size_t from_token, std::size_t to_token) const {
    const std::size_t b = (*tokens_)[from_token].begin;
    const std::size_t e = (*tokens_)[to_token > from_token ? to_token - 1 : from_token].end;
    return std::string(raw_.substr(b, e - b));
  }
  [[noreturn]] void fail_span(std::size_t from_token, const std::string& what) const {
    site().fail((*tokens_)[from_token].column(), "'" + span(from_token, k_) + "': " + what);
  }

  // --- Parameters -----------------------------------------------------------------------------

  Locals& locals() { return locals_[frames_.back().locals]; }

  /// The parameter after a '#': a number, a name, [expression] or another #.
  Target target() {
    const std::size_t start = k_ - 1;  // the '#'
    Target t;
    t.column = (*tokens_)[start].column();
    const Token& next = peek();
    if (next.kind == Tok::name) {
      t.name = take().word;
    } else {
      double number = 0.0;
      if (next.kind == Tok::number) {
        number = take().number;
      } else if (next.kind == Tok::lbracket || next.kind == Tok::hash) {
        const Value v = primary();
        if (v.vacant) fail_span(start, "the parameter number is vacant");
        number = v.number;
      } else {
        fail((*tokens_)[start], "a parameter needs a number, [expression] or <name> after '#'",
             raw_);
      }
      if (std::abs(number - std::round(number)) > kIntegerTolerance || number < 0.0) {
        fail_span(start, "a parameter number must be a non-negative integer, got " +
                             number_text(number));
      }
      t.number = number > kMaxLabel ? INT_MAX : static_cast<int>(std::lround(number));
    }
    t.text = span(start, k_);
    return t;
  }

  Value read(const Target& t, bool for_exists = false) {
    if (!t.name.empty()) {
      const bool global = t.name[0] == '_';
      auto& names = global ? globals_named_ : locals().named;
      const auto found = names.find(t.name);
      if (found != names.end()) return found->second;
      if (for_exists) return Value::empty();
      site().fail(t.column, "'" + t.text + "': the parameter is not defined (a named parameter "
                                           "must be set before it is read)");
    }
    if (t.number == 0) return Value::empty();
    if (t.number <= kLocalCount) return locals().numbered[static_cast<std::size_t>(t.number)];
    if (t.number <= kLastParameter) {
      const auto found = globals_.find(t.number);
      return found == globals_.end() ? Value::empty() : found->second;
    }
    site().fail(t.column, "'" + t.text + "': parameters #1-#999 are simulated; #1000 and above "
                                         "are control system variables, which are not");
  }

  void write(const Target& t, const Value& v, const std::string& comment) {
    if (!t.name.empty()) {
      (t.name[0] == '_' ? globals_named_ : locals().named)[t.name] = v;
      return;
    }
    if (t.number == 0) site().fail(t.column, "'" + t.text + "': #0 is always vacant (read only)");
    if (t.number <= kLocalCount) {
      locals().numbered[static_cast<std::size_t>(t.number)] = v;
    } else if (t.number <= kLastParameter) {
      globals_[t.number] = v;
    } else if (t.number == kAlarmParameter) {
      site().fail(t.column, "'" + t.text + "': the program raises alarm " +
                                (v.vacant ? std::string("#0") : number_text(v.number)) +
                                (comment.empty() ? "" : " " + comment) +
                                " (Fanuc #3000: the control stops here)");
    } else {
      site().fail(t.column, "'" + t.text + "': parameters #1-#999 are simulated; #1000 and "
                                           "above are control system variables, which are not");
    }
  }

  // --- Expressions (LinuxCNC precedence: ** ; * / MOD ; + - ; EQ NE GT GE LT LE ; AND OR XOR) --

  Value expression() {
    Value left = relational();
    while (at_keyword("AND") || at_keyword("OR") || at_keyword("XOR")) {
      const std::string op = take().word;
      const Value right = relational();
      const bool a = left.number != 0.0, b = right.number != 0.0;
      left = Value::of(op == "AND" ? (a && b) : op == "OR" ? (a || b) : (a != b));
    }
    return left;
  }

  Value relational() {
    Value left = additive();
    while (at_keyword("EQ") || at_keyword("NE") || at_keyword("GT") || at_keyword("GE") ||
           at_keyword("LT") || at_keyword("LE")) {
      const std::string op = take().word;
      const Value right = additive();
      bool result = false;
      if (op == "EQ" || op == "NE") {
        // Fanuc: vacant equals only vacant (#1 EQ #0 tests for a missing argument).
        const bool equal = (left.vacant || right.vacant) ? (left.vacant == right.vacant)
                                                         : left.number == right.number;
        result = op == "EQ" ? equal : !equal;
      } else if (op == "GT") {
        result = left.number > right.number;
      } else if (op == "GE") {
        result = left.number >= right.number;
      } else if (op == "LT") {
        result = left.number < right.number;
      } else {
        result = left.number <= right.number;
      }
      left = Value::of(result ? 1.0 : 0.0);
    }
    return left;
  }

  Value additive() {
    const std::size_t start = k_;
    Value left = multiplicative();
    while (peek().kind == Tok::plus || peek().kind == Tok::minus) {
      const bool plus = take().kind == Tok::plus;
      const Value right = multiplicative();
      left = finite(start, plus ? left.number + right.number : left.number - right.number);
    }
    return left;
  }

  Value multiplicative() {
    const std::size_t start = k_;
    Value left = power();
    while (peek().kind == Tok::star || peek().kind == Tok::slash || at_keyword("MOD")) {
      const Tok op = peek().kind;
      take();
      const Value right = power();
      if (op == Tok::star) {
        left = finite(start, left.number * right.number);
      } else if (right.number == 0.0) {
        fail_span(start, op == Tok::slash ? "division by zero" : "MOD by zero");
      } else if (op == Tok::slash) {
        left = finite(start, left.number / right.number);
      } else {
        // LinuxCNC: the remainder takes the sign of neither operand: 0 <= r < |b|.
        double r = std::fmod(left.number, right.number);
        if (r < 0.0) r += std::abs(right.number);
        left = Value::of(r);
      }
    }
    return left;
  }

  Value power() {
    const std::size_t start = k_;
    Value left = unary();
    while (peek().kind == Tok::power) {
      take();
      const Value right = unary();
      if (left.number < 0.0 && right.number != std::round(right.number)) {
        fail_span(start, "a negative number to a fractional power");
      }
      if (left.number == 0.0 && right.number < 0.0) fail_span(start, "zero to a negative power");
      left = finite(start, std::pow(left.number, right.number));
    }
    return left;
  }

  Value unary() {
    if (peek().kind == Tok::minus) {
      take();
      Value v = unary();
      v.number = -v.number;  // a vacant value stays vacant
      return v;
    }
    if (peek().kind == Tok::plus) {
      take();
      return unary();
    }
    return primary();
  }

  /// A number, a parameter, [expression] or a function.
  Value primary() {
    const Token& t = peek();
    switch (t.kind) {
      case Tok::number: take(); return Value::of(t.number);
      case Tok::hash: take(); return read(target());
      case Tok::lbracket: {
        take();
        const Value v = expression();
        expect(Tok::rbracket, "']'");
        return v;
      }
      case Tok::keyword:
        if (is_function(t.word)) return function();
        break;
      default: break;
    }
    fail(t, "expected a number, a parameter '#', '[' or a function", raw_);
  }

  Value function() {
    const std::size_t start = k_;
    const std::string name = take().word;
    if (name == "EXISTS") {
      expect(Tok::lbracket, "'[' after EXISTS");
      expect(Tok::hash, "a parameter '#<name>' in EXISTS");
      const Target t = target();
      if (t.name.empty()) fail_span(start, "EXISTS takes a named parameter #<name>");
      expect(Tok::rbracket, "']'");
      return Value::of(read(t, true).vacant ? 0.0 : 1.0);
    }
    expect(Tok::lbracket, ("'[' after " + name).c_str());
    const double a = expression().number;
    if (name == "ATAN") {
      // Two arguments, as Fanuc and LinuxCNC write them: ATAN[y]/[x]; newer Fanuc: ATAN[y,x].
      std::optional<double> x;
      if (peek().kind == Tok::comma) {
        take();
        x = expression().number;
        expect(Tok::rbracket, "']'");
      } else {
        expect(Tok::rbracket, "']'");
        if (peek().kind == Tok::slash && peek(1).kind == Tok::lbracket) {
          take();
          take();
          x = expression().number;
          expect(Tok::rbracket, "']'");
        }
      }
      return Value::of(x ? std::atan2(a, *x) * kDegrees : std::atan(a) * kDegrees);
    }
    expect(Tok::rbracket, "']'");
    const auto domain = [&](bool ok, const char* what) {
      if (!ok) fail_span(start, std::string(what) + ", got " + number_text(a));
    };
    if (name == "SIN") return Value::of(std::sin(a / kDegrees));
    if (name == "COS") return Value::of(std::cos(a / kDegrees));
    if (name == "TAN") return finite(start, std::tan(a / kDegrees));
    if (name == "ASIN" || name == "ACOS") {
      domain(a >= -1.0 && a <= 1.0, "the argument must be within [-1, 1]");
      return Value::of((name == "ASIN" ? std::asin(a) : std::acos(a)) * kDegrees);
    }
    if (name == "SQRT") {
      domain(a >= 0.0, "the square root of a negative number");
      return Value::of(std::sqrt(a));
    }
    if (name == "ABS") return Value::of(std::abs(a));
    if (name == "ROUND") return Value::of(std::round(a));
    // Fanuc: FIX drops the fraction, FUP raises it to the next integer away from zero
    // (LinuxCNC rounds down and up: the same for positive numbers).
    if (name == "FIX") return Value::of(std::trunc(a));
    if (name == "FUP") return Value::of(a >= 0.0 ? std::ceil(a) : std::floor(a));
    if (name == "LN") {
      domain(a > 0.0, "the logarithm of a number that is not positive");
      return Value::of(std::log(a));
    }
    return finite(start, std::exp(a));  // EXP
  }

  Value finite(std::size_t start, double v) const {
    if (!std::isfinite(v)) fail_span(start, "the result is too large for a number");
    return Value::of(v);
  }

  /// An integer from an expression (a label, a loop or call count).
  long integer(const Value& v, std::size_t start, const char* what) const {
    if (v.vacant) fail_span(start, std::string(what) + " is vacant");
    if (std::abs(v.number - std::round(v.number)) > kIntegerTolerance ||
        std::abs(v.number) > kMaxLabel) {
      fail_span(start, std::string(what) + " must be an integer within +-1e9, got " +
                           number_text(v.number));
    }
    return std::lround(v.number);
  }

  // --- Statements -----------------------------------------------------------------------------

  /// A word's value: a number as written, or #, [expression], a function, each with a sign.
  /// Vacant: nullopt in *value (the word is left out).
  void word_value(OutWord& word, const Token& letter) {
    bool negative = false;
    std::string sign;
    if (peek().kind == Tok::minus || peek().kind == Tok::plus) {
      negative = take().kind == Tok::minus;
      sign = negative ? "-" : "+";
    }
    if (peek().kind == Tok::number) {
      const Token& number = take();
      word.value = negative ? -number.number : number.number;
      word.text += sign + std::string(raw_.substr(number.begin, number.end - number.begin));
      return;
    }
    if (peek().kind == Tok::end || peek().kind == Tok::letter) {
      fail(letter, "the address has no value", raw_);
    }
    Value v = primary();
    if (negative) v.number = -v.number;
    if (v.vacant) {
      word.value.reset();
      word.text.clear();
      return;
    }
    // Fanuc rounds a macro value given to an integer address (not G: G43.4 is a code).
    const char a = word.letter;
    if (a == 'M' || a == 'T' || a == 'H' || a == 'D' || a == 'N' || a == 'L' || a == 'O') {
      v.number = std::round(v.number);
    }
    word.value = v.number;
    word.text += number_text(v.number);
  }

  bool statement() {
    std::vector<OutWord> words;
    std::vector<std::pair<Target, Value>> sets;
    std::string comment;  // for #3000 alarms: the comment of the block
    {
      const std::size_t open = raw_.find('(');
      const std::size_t close = open == std::string_view::npos ? open : raw_.find(')', open);
      if (close != std::string_view::npos) {
        comment = std::string(raw_.substr(open, close - open + 1));
      }
    }
    std::optional<long> goto_n;
    int goto_column = 0;
    std::size_t goto_token = 0;

    // N first, then an O word: a Fanuc program number or a LinuxCNC o-word.
    if (peek().kind == Tok::letter && peek().word == "N" && peek(1).kind == Tok::number) {
      const Token& n = take();
      const Token& number = take();
      words.push_back(OutWord{'N', number.number,
                              std::string(raw_.substr(n.begin, number.end - n.begin)),
                              n.column()});
    }
    // An N before an O line numbers nothing that moves: not handed on.
    if (peek().kind == Tok::letter && peek().word == "O") return o_line();

    while (peek().kind != Tok::end) {
      const Token& t = peek();
      if (t.kind == Tok::hash) {
        take();
        Target target_parameter = target();
        expect(Tok::equals, "'=' (a parameter assignment)");
        const Value v = expression();
        // LinuxCNC: the values set on a line take effect after the whole line is read.
        sets.emplace_back(std::move(target_parameter), v);
        continue;
      }
      if (t.kind == Tok::letter) {
        const Token& letter = take();
        OutWord word;
        word.letter = letter.word[0];
        word.column = letter.column();
        word.text = letter.word;
        if (peek().kind == Tok::equals) {
          take();  // Siemens X=10
        } else if (peek().kind == Tok::number && peek(1).kind == Tok::equals) {
          // Siemens extended address A3=0.5: handed on with its '='.
          const Token& index = take();
          take();
          word.text += std::string(raw_.substr(index.begin, index.end - index.begin)) + "=";
          word_value(word, letter);
          if (word.value) {
            word.letter = '\0';  // not a one-letter address
            words.push_back(std::move(word));
          }
          continue;
        }
        word_value(word, letter);
        if (word.value) words.push_back(std::move(word));
        continue;
      }
      if (t.kind == Tok::siemens) {
        take();
        words.push_back(OutWord{'\0', std::nullopt,
                                std::string(raw_.substr(t.begin, t.end - t.begin)), t.column()});
        continue;
      }
      if (t.kind == Tok::keyword && t.word == "IF") {
        take();
        const std::size_t start = k_;
        expect(Tok::lbracket, "'[' (IF [condition])");
        k_ = start;
        const Value condition = primary();
        if (at_keyword("GOTO")) {
          goto_token = k_;
          take();
          const std::size_t label_start = k_;
          const Value label = unary();
          if (condition.number != 0.0) {
            goto_n = integer(label, label_start, "the GOTO block number");
            goto_column = (*tokens_)[goto_token].column();
          }
          if (peek().kind != Tok::end) fail(peek(), "nothing may follow IF [..] GOTO n", raw_);
          break;
        }
        if (at_keyword("THEN")) {
          take();
          if (condition.number == 0.0) {
            k_ = tokens_->size() - 1;  // the rest of the block is not run
            break;
          }
          continue;
        }
        fail(peek(), "expected GOTO or THEN after IF [condition]", raw_);
      }
      if (t.kind == Tok::keyword && t.word == "GOTO") {
        goto_token = k_;
        take();
        const std::size_t label_start = k_;
        goto_n = integer(unary(), label_start, "the GOTO block number");
        goto_column = (*tokens_)[goto_token].column();
        continue;
      }
      if (t.kind == Tok::keyword && (t.word == "WHILE" || t.word == "DO" || t.word == "END")) {
        return fanuc_loop(words, sets);
      }
      fail(t, t.kind == Tok::keyword ? "not expected here" : "unexpected character", raw_);
    }

    // Calls and returns: M98 P L, M99, G65 P L (arguments), G66 / G66.1 / G67 modal calls.
    const OutWord* m98 = nullptr;
    const OutWord* m99 = nullptr;
    const OutWord* g65 = nullptr;
    const OutWord* g66 = nullptr;
    const OutWord* g66_1 = nullptr;
    const OutWord* g67 = nullptr;
    for (const OutWord& w : words) {
      if (!w.value) continue;
      if (w.letter == 'M' && *w.value == 98.0) m98 = &w;
      if (w.letter == 'M' && *w.value == 99.0) m99 = &w;
      if (w.letter == 'G' && *w.value == 65.0) g65 = &w;
      if (w.letter == 'G' && *w.value == 66.0) g66 = &w;
      if (w.letter == 'G' && *w.value == 67.0) g67 = &w;
      if (w.letter == 'G' && *w.value == 66.1) g66_1 = &w;
    }
    for (const auto& [t, v] : sets) write(t, v, comment);
    const OutWord* call_word = g65 ? g65 : g66 ? g66 : g66_1;
    if (g65 && g66) site().fail(g66->column, "'" + g66->text + "': G65 and G66 in one block");
    if ((g65 || g66) && g66_1) {
      site().fail(g66_1->column, "'" + g66_1->text + "': not in one block with " +
                                     call_word->text);
    }
    if (call_word && (m98 || m99 || g67 || goto_n)) {
      const OutWord* other = m98 ? m98 : m99 ? m99 : g67;
      site().fail(other ? other->column : goto_column,
                  "'" + (other ? other->text : std::string("GOTO")) + "': not in one block with " +
                      call_word->text);
    }
    if (g65) return g65_call(words, *g65);
    if (g66) {
      set_modal_call(words, *g66, false);
      return true;
    }
    if (g66_1) {
      // The G66.1 block calls the macro too, with its own arguments.
      set_modal_call(words, *g66_1, true);
      const ModalCall& modal = modal_calls_.back();
      check_modal_call_depth(modal, g66_1->column, g66_1->text);
      call_macro(modal.call, line_ + 1, source_, true);
      return true;
    }
    // Under G66.1 a block with words other than N calls the macro (its words the arguments)
    // instead of running; G67 cancels, M98 / M99 still call and return.
    if (each_block_call_active() && !g67 && !m98 && !m99) {
      std::vector<const OutWord*> arguments;
      for (const OutWord& w : words) {
        if (w.letter != 'N') arguments.push_back(&w);
      }
      if (!arguments.empty()) return each_block_call(arguments, goto_n, goto_column);
    }

    std::vector<OutWord> kept;
    const OutWord* p_word = nullptr;
    const OutWord* l_word = nullptr;
    if (g67 && !modal_calls_.empty()) modal_calls_.pop_back();
    for (const OutWord& w : words) {
      if (&w == m98 || &w == m99 || &w == g67) continue;
      if ((m98 || m99) && w.letter == 'P') {
        p_word = &w;
        continue;
      }
      if (m98 && w.letter == 'L') {
        l_word = &w;
        continue;
      }
      kept.push_back(w);
    }
    if (!hand_on_words(kept)) return false;
    if (m98) return m98_call(*m98, p_word, l_word);
    if (m99) {
      if (p_word) {
        site().fail(p_word->column, "'" + p_word->text + "': M99 P (return to a block number) "
                                                         "is not supported");
      }
      return sub_return(*m99);
    }
    if (goto_n) jump_to_n(*goto_n, goto_column);
    if (!kept.empty()) modal_call_after(raw_, text_buffer_);
    return true;
  }

  bool hand_on_words(const std::vector<OutWord>& words) {
    if (words.empty()) return true;
    text_buffer_.clear();
    columns_.clear();
    for (const OutWord& w : words) {
      if (!text_buffer_.empty()) text_buffer_ += ' ';
      columns_.emplace_back(static_cast<int>(text_buffer_.size()) + 1, w.column);
      text_buffer_ += w.text;
    }
    return hand_on(raw_, text_buffer_, &columns_);
  }

  // --- Fanuc loops: WHILE [c] DO m / DO m / END m ---------------------------------------------

  bool fanuc_loop(const std::vector<OutWord>& words,
                  const std::vector<std::pair<Target, Value>>& sets) {
    if (!words.empty() && !(words.size() == 1 && words[0].letter == 'N')) {
      site().fail(words.back().column, "'" + words.back().text +
                                           "': a WHILE / DO / END block takes no other word");
    }
    if (!sets.empty()) fail(peek(), "a WHILE / DO / END block takes no assignment", raw_);
    const Token& keyword = take();
    std::optional<double> condition;
    if (keyword.word == "WHILE") {
      const std::size_t start = k_;
      expect(Tok::lbracket, "'[' (WHILE [condition])");
      k_ = start;
      condition = primary().number;
      if (!at_keyword("DO")) fail(peek(), "expected DO m after WHILE [condition]", raw_);
      take();
    }
    const std::size_t id_start = k_;
    const long id = integer(unary(), id_start, "the loop number");
    if (peek().kind != Tok::end) fail(peek(), "unexpected after the loop number", raw_);
    ensure_index();
    if (keyword.word == "END") {
      // Back to the WHILE (or DO) of the same number before this block, which tests again.
      for (std::size_t i = line_; i-- > frame_begin();) {
        if (src().info[i].do_id == id) {
          jump_ = i;
          return true;
        }
        if (src().info[i].end_id == id) break;
      }
      fail(keyword, "END " + std::to_string(id) + " without its WHILE [..] DO " +
                        std::to_string(id) + " before it", raw_);
    }
    const std::size_t end = matching_end(id, keyword);
    if (condition && *condition == 0.0) jump_ = end + 1;
    return true;
  }

  std::size_t matching_end(long id, const Token& keyword) {
    for (std::size_t i = line_ + 1; i < src().info.size(); ++i) {
      if (src().info[i].end_id == id) return i;
      if (src().info[i].program_number >= 0 || src().info[i].do_id == id) break;
    }
    fail(keyword, "DO " + std::to_string(id) + " without its END " + std::to_string(id) +
                      " after it", raw_);
  }

  /// First line of the current program (for the search of block numbers and loops).
  std::size_t frame_begin() const {
    const Frame& frame = frames_.back();
    return frame.kind == FrameKind::main ? 0 : frame.body;
  }

  /// GOTO n: the block N n of the current program, searched forward from here, then from the
  /// program's start (as the control does).
  void jump_to_n(long n, int column) {
    ensure_index();
    ensure_block_numbers();
    const auto found = src().n_lines.find(n);
    std::optional<std::size_t> before, after;
    if (found != src().n_lines.end()) {
      for (const std::size_t i : found->second) {
        if (i < frame_begin() || !in_current_program(i)) continue;
        if (i > line_ && !after) after = i;
        if (i <= line_ && !before) before = i;
      }
    }
    if (!after && !before) {
      site().fail(column, "'GOTO': no block N" + std::to_string(n) + " in this program");
    }
    jump_ = after ? *after : *before;
  }

  /// True when line i belongs to the program (Fanuc O block to O block) the frame runs.
  bool in_current_program(std::size_t i) const {
    return src().info[i].program == src().info[line_].program;
  }

  // --- Calls ----------------------------------------------------------------------------------

  /// A line of one of the files.
  struct Place {
    std::size_t source = 0;
    std::size_t line = 0;
  };

  /// The first line of the body of Fanuc program `number`: in this file, in a subprogram file
  /// read before, or in a file of the subprogram folder (O1234.nc, o1234.nc, 1234.nc,
  /// O0012.nc for O12), which may hold the O line or the body alone.
  std::optional<Place> program_body(long number) {
    ensure_index();
    const auto in = [&](std::size_t k) -> std::optional<Place> {
      const auto found = sources_[k]->programs.find(number);
      if (found == sources_[k]->programs.end()) return std::nullopt;
      return Place{k, found->second + 1};
    };
    if (auto place = in(source_)) return place;
    for (std::size_t k = 0; k < sources_.size(); ++k) {
      if (auto place = in(k)) return place;
    }
    const std::string n = std::to_string(number);
    std::vector<std::string> names = {"O" + n + ".nc", "o" + n + ".nc", n + ".nc", "O" + n + ".NC"};
    if (n.size() < 4) names.push_back("O" + std::string(4 - n.size(), '0') + n + ".nc");
    for (const std::string& name : names) {
      if (const auto k = subprogram_file(name)) {
        if (auto place = in(*k)) return place;
        return Place{*k, 0};
      }
    }
    return std::nullopt;
  }

  /// The subroutine `label` (LinuxCNC o<name> sub): in this file, in one read before, or in
  /// <name>.ngc of the subprogram folder.
  std::optional<Place> subroutine_body(const std::string& label) {
    const auto in = [&](std::size_t k) -> std::optional<Place> {
      const auto found = sources_[k]->subs.find(label);
      if (found == sources_[k]->subs.end()) return std::nullopt;
      return Place{k, found->second + 1};
    };
    if (auto place = in(source_)) return place;
    for (std::size_t k = 0; k < sources_.size(); ++k) {
      if (auto place = in(k)) return place;
    }
    if (label.size() > 2 && label.front() == '<') {
      if (const auto k = subprogram_file(label.substr(1, label.size() - 2) + ".ngc")) return in(*k);
    }
    return std::nullopt;
  }

  /// Reads and indexes the file `name` of ReaderOptions::subprogram_folder (once); nullopt where
  /// there is no folder or no such file.
  std::optional<std::size_t> subprogram_file(const std::string& name) {
    if (options_.subprogram_folder.empty()) return std::nullopt;
    const std::string path = (std::filesystem::path(options_.subprogram_folder) / name).string();
    for (std::size_t k = 1; k < sources_.size(); ++k) {
      if (sources_[k]->file == path) return k;
    }
    std::error_code error;
    if (!std::filesystem::is_regular_file(path, error)) return std::nullopt;
    auto source = std::make_unique<Source>();
    source->file = path;
    source->text_storage = read_text_file(path);
    source->text = without_byte_order_mark(source->text_storage);
    require_utf8_text(source->text, path);
    sources_.push_back(std::move(source));
    const std::size_t running = source_;
    source_ = sources_.size() - 1;
    ensure_index();
    source_ = running;
    return sources_.size() - 1;
  }

  void push_frame(Frame frame) {
    if (frames_.size() > options_.max_call_depth) {
      site().fail(0, "calls nested more than " + std::to_string(options_.max_call_depth) +
                      " deep (ReaderOptions::max_call_depth): a subprogram that calls itself?");
    }
    frames_.push_back(std::move(frame));
  }

  bool m98_call(const OutWord& m98, const OutWord* p_word, const OutWord* l_word) {
    if (!p_word) site().fail(m98.column, "'" + m98.text + "': M98 needs P (the program number)");
    const auto whole = [&](const OutWord& w) {
      const double v = *w.value;
      if (v < 0.0 || v > kMaxLabel || v != std::round(v)) {
        site().fail(w.column, "'" + w.text + "': must be a non-negative integer");
      }
      return static_cast<long>(v);
    };
    long number = whole(*p_word);
    long repeats = l_word ? whole(*l_word) : 1;
    auto target = program_body(number);
    if (!target && !l_word && number >= 10000) {
      // Fanuc's packed form: P kkkk nnnn = program nnnn, k times.
      repeats = number / 10000;
      number %= 10000;
      target = program_body(number);
    }
    if (!target) {
      site().fail(m98.column, "'" + m98.text + "': no subprogram O" + std::to_string(number) +
                                  " in " + src().file + " (" + p_word->text + ")");
    }
    if (repeats == 0) return true;
    Frame frame;
    frame.kind = FrameKind::m98;
    frame.locals = frames_.back().locals;  // M98 runs on its caller's locals
    frame.body = target->line;
    frame.body_source = target->source;
    frame.return_to = line_ + 1;
    frame.return_source = source_;
    frame.repeats_left = repeats;
    frame.name = "O" + std::to_string(number);
    frame.call_line = static_cast<int>(line_) + 1;
    push_frame(std::move(frame));
    jump_ = target->line;
    jump_source_ = target->source;
    return true;
  }

  /// A macro call's program, count and arguments (G65 / G66 P<program> [L<count>] A B C ...).
  struct MacroCall {
    Place body;
    long number = 0;
    long repeats = 1;
    Locals arguments;
  };

  /// The words of a G65 / G66 block: P the program, L the count, arguments A B C I J K D E F H
  /// M Q R S T U V W X Y Z into the locals of the macro (Fanuc argument specification I).
  MacroCall macro_call_of(const std::vector<OutWord>& words, const OutWord& call) {
    const std::string name = call.text;
    const OutWord* p_word = nullptr;
    MacroCall result;
    for (const OutWord& w : words) {
      if (&w == &call || w.letter == 'N') continue;
      if (w.letter == 'P') {
        p_word = &w;
      } else if (w.letter == 'L') {
        if (*w.value < 0.0 || *w.value > kMaxLabel || *w.value != std::round(*w.value)) {
          site().fail(w.column, "'" + w.text + "': the call count must be a non-negative integer");
        }
        result.repeats = std::lround(*w.value);
      } else if (const int local = argument_local(w.letter); local != 0) {
        result.arguments.numbered[static_cast<std::size_t>(local)] = Value::of(*w.value);
      } else {
        site().fail(w.column, "'" + w.text + "': not a " + name +
                                  " argument (A-F H-K M Q-Z) nor P / L");
      }
    }
    if (!p_word) site().fail(call.column, "'" + name + "': " + name + " needs P (the program number)");
    if (*p_word->value < 0.0 || *p_word->value > kMaxLabel ||
        *p_word->value != std::round(*p_word->value)) {
      site().fail(p_word->column, "'" + p_word->text + "': must be a non-negative integer");
    }
    result.number = std::lround(*p_word->value);
    const auto target = program_body(result.number);
    if (!target) {
      site().fail(call.column, "'" + name + "': no macro program O" +
                                   std::to_string(result.number) + " in " + src().file + " (" +
                                   p_word->text + ")");
    }
    result.body = *target;
    return result;
  }

  /// Calls the macro `call` from this line; it returns to `return_to` of `return_source`.
  void call_macro(MacroCall call, std::size_t return_to, std::size_t return_source,
                  bool modal_body) {
    if (call.repeats == 0) return;
    Frame frame;
    frame.kind = FrameKind::g65;
    frame.body = call.body.line;
    frame.body_source = call.body.source;
    frame.return_to = return_to;
    frame.return_source = return_source;
    frame.repeats_left = call.repeats;
    frame.name = "O" + std::to_string(call.number);
    frame.call_line = static_cast<int>(line_) + 1;
    frame.arguments = call.arguments;
    frame.modal_body = modal_body;
    locals_.push_back(std::move(call.arguments));
    frame.locals = locals_.size() - 1;
    push_frame(std::move(frame));
    if (modal_body) ++modal_bodies_running_;
    jump_ = call.body.line;
    jump_source_ = call.body.source;
  }

  bool g65_call(const std::vector<OutWord>& words, const OutWord& g65) {
    call_macro(macro_call_of(words, g65), line_ + 1, source_, false);
    return true;
  }

  // --- G66 / G67: modal macro calls -----------------------------------------------------------

  /// A G66 in force: its macro is called after every move block of the level that gave it;
  /// a G66.1 in force: every block of that level with words calls it instead of running.
  struct ModalCall {
    MacroCall call;
    bool each_block = false;  ///< G66.1
    std::string g66_text;  ///< "G66 P9010" / "G66.1 P9010", for messages
    int g66_line = 0;
    /// The modal-call macros running when G66 was given: the blocks of a macro this call
    /// started do not call it again (Fanuc: a modal call is not made from its own macro).
    std::size_t bodies_running = 0;
  };

  void set_modal_call(const std::vector<OutWord>& words, const OutWord& g66, bool each_block) {
    ModalCall modal;
    modal.call = macro_call_of(words, g66);
    modal.each_block = each_block;
    for (const OutWord& w : words) {
      if (w.letter == 'P') modal.g66_text = g66.text + " " + w.text;
    }
    modal.g66_line = static_cast<int>(line_) + 1;
    modal.bodies_running = modal_bodies_running_;
    modal_calls_.push_back(std::move(modal));
  }

  /// After a block handed on (`text`: its plain words; `raw`: the line as written): under G66,
  /// a block that moves an axis calls the macro, which returns to where the block would have
  /// gone (the next line, or its GOTO's target).
  void modal_call_after(std::string_view raw, std::string_view text) {
    if (modal_calls_.empty()) return;
    const ModalCall& modal = modal_calls_.back();
    if (modal.bodies_running != modal_bodies_running_ || modal.each_block) return;
    const std::optional<int> move_column = move_word_column(text);
    if (!move_column) return;
    if (frames_.size() > options_.max_call_depth) {
      int column = *move_column;
      if (text.data() != raw.data()) {
        for (const auto& [text_column, source_column] : columns_) {
          if (text_column <= *move_column) column = source_column;
        }
      }
      const std::string_view from_word = text.substr(static_cast<std::size_t>(*move_column - 1));
      const std::size_t word_end = from_word.find_first_of(
          " \t(;ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz", 1);
      check_modal_call_depth(modal, column, std::string(from_word.substr(0, word_end)));
    }
    const std::size_t return_to = jump_ ? *jump_ : line_ + 1;
    const std::size_t return_source = jump_ ? jump_source_ : source_;
    call_macro(modal.call, return_to, return_source, true);
  }

  /// A located error when the call `modal` makes from this block (`word` at `column`) would nest
  /// calls deeper than ReaderOptions::max_call_depth.
  void check_modal_call_depth(const ModalCall& modal, int column, const std::string& word) {
    if (frames_.size() <= options_.max_call_depth) return;
    site().fail(column, "'" + word + "': the modal call " + modal.g66_text + " (line " +
                            std::to_string(modal.g66_line) + ") nests calls more than " +
                            std::to_string(options_.max_call_depth) +
                            " deep (ReaderOptions::max_call_depth)");
  }

  /// True when a G66.1 is in force for the blocks running (not those of its own macro).
  bool each_block_call_active() const {
    return !modal_calls_.empty() && modal_calls_.back().each_block &&
           modal_calls_.back().bodies_running == modal_bodies_running_;
  }

  /// A block under G66.1: the macro runs instead of the block, its words the arguments (as
  /// G65's); it returns to where the block would have gone (the next line or the GOTO's target).
  bool each_block_call(const std::vector<const OutWord*>& words, std::optional<long> goto_n,
                       int goto_column) {
    const ModalCall& modal = modal_calls_.back();
    MacroCall call = modal.call;
    call.arguments = Locals{};
    for (const OutWord* w : words) {
      const int local = argument_local(w->letter);
      if (local == 0 || !w->value) {
        site().fail(w->column, "'" + w->text + "': not a macro argument (A-F H-K M Q-Z): under " +
                                   modal.g66_text + " (line " + std::to_string(modal.g66_line) +
                                   ") this block calls the macro, its words the arguments");
      }
      call.arguments.numbered[static_cast<std::size_t>(local)] = Value::of(*w->value);
    }
    check_modal_call_depth(modal, words.front()->column, words.front()->text);
    if (goto_n) jump_to_n(*goto_n, goto_column);
    const std::size_t return_to = jump_ ? *jump_ : line_ + 1;
    const std::size_t return_source = jump_ ? jump_source_ : source_;
    call_macro(std::move(call), return_to, return_source, true);
    return true;
  }

  /// The 1-based column of the first axis word (X Y Z A B C U V W) of a block that moves (not
  /// a G4 dwell, G10 / G52 / G92 setting); nullopt where the block moves nothing.
  static std::optional<int> move_word_column(std::string_view text) {
    std::optional<int> axis_column;
    std::size_t i = 0;
    const std::size_t n = text.size();
    while (i < n) {
      const char c = text[i];
      if (c == '(') {
        const std::size_t close = text.find(')', i);
        if (close == std::string_view::npos) break;
        i = close + 1;
        continue;
      }
      if (c == ';') break;
      const char upper = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      // An address: a letter not inside a keyword, followed (blanks allowed) by a number.
      const bool address = std::isalpha(static_cast<unsigned char>(c)) &&
                           (i == 0 || !std::isalpha(static_cast<unsigned char>(text[i - 1])));
      std::size_t k = i + 1;
      while (k < n && (text[k] == ' ' || text[k] == '\t')) ++k;
      const bool numbered = k < n && (std::isdigit(static_cast<unsigned char>(text[k])) ||
                                      text[k] == '-' || text[k] == '+' || text[k] == '.' ||
                                      text[k] == '=');  // Siemens X=10
      if (address && numbered) {
        if (upper == 'G') {
          const double code = std::strtod(std::string(text.substr(k, 12)).c_str(), nullptr);
          if (code == 4.0 || code == 10.0 || code == 52.0 || code == 92.0 || code == 92.1) {
            return std::nullopt;
          }
        }
        if (!axis_column && std::string_view("XYZABCUVW").find(upper) != std::string_view::npos) {
          axis_column = static_cast<int>(i) + 1;
        }
      }
      ++i;
    }
    return axis_column;
  }

  /// M99: the end of a subprogram (again while repetitions are left); in the main program, the
  /// end of the program.
  bool sub_return(const OutWord& m99) {
    Frame& frame = frames_.back();
    if (frame.kind == FrameKind::main) return false;
    if (frame.kind == FrameKind::o_sub) {
      site().fail(m99.column, "'" + m99.text + "': M99 inside the o-word subroutine " +
                                  frame.name + " (end it with endsub)");
    }
    if (--frame.repeats_left > 0) {
      if (frame.kind == FrameKind::g65) locals_[frame.locals] = frame.arguments;
      jump_ = frame.body;
      jump_source_ = frame.body_source;
      return true;
    }
    pop_frame();
    return true;
  }

  void pop_frame() {
    const Frame& frame = frames_.back();
    jump_ = frame.return_to;
    jump_source_ = frame.return_source;
    if (frame.kind != FrameKind::m98) locals_.pop_back();
    if (frame.modal_body) --modal_bodies_running_;
    frames_.pop_back();
  }

  // --- O lines: Fanuc program numbers and LinuxCNC o-words ------------------------------------

  bool o_line() {
    const Token& o = take();
    const Token& label_token = peek();
    if (label_token.kind != Tok::number && label_token.kind != Tok::name) {
      fail(o, "O needs a program number or a label <name>", raw_);
    }
    take();
    if (peek().kind == Tok::keyword) return o_word(o, label_of(label_token));
    if (label_token.kind == Tok::name) {
      fail(peek(), "expected an o-word keyword (sub, call, if, ...)", raw_);
    }
    // A Fanuc program number. The main flow steps over a subprogram (one that ends with M99),
    // unless no program of the file ends with M2 / M30: then this one is the main program (a
    // program that loops with M99).
    if (peek().kind != Tok::end) {
      fail(peek(), "an O (program number) block takes nothing else", raw_);
    }
    ensure_index();
    if (frames_.back().kind != FrameKind::main) {
      site().fail(o.column(), "'O" + number_text(label_token.number) + "': subprogram " +
                                  frames_.back().name + " runs into the next program (no M99)");
    }
    const bool a_main_program_ends = std::any_of(src().info.begin(), src().info.end(),
                                                 [](const LineInfo& info) { return info.m_end; });
    for (std::size_t i = line_ + 1; a_main_program_ends && i < src().info.size(); ++i) {
      if (src().info[i].program_number >= 0 || src().info[i].m_end) break;
      if (src().info[i].m99) {
        jump_ = i + 1;
        return true;
      }
    }
    return true;
  }

  /// The o-word entries of `label` after (forward) or before this line.
  std::optional<std::size_t> find_o(const std::string& label,
                                    std::initializer_list<std::string_view> keywords,
                                    bool forward) const {
    const auto found = src().o_lines.find(label);
    if (found == src().o_lines.end()) return std::nullopt;
    const std::vector<std::size_t>& lines = found->second;
    const auto matches = [&](std::size_t i) {
      return std::find(keywords.begin(), keywords.end(), o_keyword(i)) != keywords.end();
    };
    if (forward) {
      for (auto it = std::upper_bound(lines.begin(), lines.end(), line_); it != lines.end(); ++it) {
        if (matches(*it)) return *it;
      }
    } else {
      auto it = std::lower_bound(lines.begin(), lines.end(), line_);
      while (it != lines.begin()) {
        --it;
        if (matches(*it)) return *it;
      }
    }
    return std::nullopt;
  }

  std::size_t need_o(const Token& o, const std::string& label,
                     std::initializer_list<std::string_view> keywords, bool forward,
                     const std::string& what) const {
    const auto line = find_o(label, keywords, forward);
    if (!line) fail(o, "o" + label + " " + what, raw_);
    return *line;
  }

  /// A condition in brackets after an o-word keyword.
  bool o_condition() {
    const std::size_t start = k_;
    expect(Tok::lbracket, "'[' (a condition in brackets)");
    k_ = start;
    return primary().number != 0.0;
  }

  void o_end_of_line() {
    if (peek().kind != Tok::end) fail(peek(), "unexpected after the o-word", raw_);
  }

  bool o_word(const Token& o, const std::string& label) {
    ensure_index();
    const Token& keyword_token = take();
    const std::string keyword = to_lower(keyword_token.word);
    Frame& frame = frames_.back();
    if (keyword == "sub") {
      // The main flow steps over a definition.
      o_end_of_line();
      jump_ = need_o(o, label, {"endsub"}, true, "sub without its endsub") + 1;
      return true;
    }
    if (keyword == "endsub" || keyword == "return") {
      std::optional<Value> value;
      if (peek().kind == Tok::lbracket) value = primary();
      o_end_of_line();
      if (frame.kind != FrameKind::o_sub) {
        fail(keyword_token, keyword + " outside a called o-word subroutine", raw_);
      }
      // LinuxCNC: a returned value is in #<_value>.
      if (value) globals_named_["_value"] = *value;
      pop_frame();
      return true;
    }
    if (keyword == "call") {
      Locals arguments;
      int count = 0;
      while (peek().kind == Tok::lbracket) {
        const Value v = primary();
        if (++count > kMaxCallArguments) {
          fail(peek(), "more than " + std::to_string(kMaxCallArguments) + " call arguments", raw_);
        }
        arguments.numbered[static_cast<std::size_t>(count)] = v;
      }
      o_end_of_line();
      const auto found = subroutine_body(label);
      if (!found) fail(o, "no subroutine o" + label + " sub in " + src().file, raw_);
      Frame callee;
      callee.kind = FrameKind::o_sub;
      callee.body = found->line;
      callee.body_source = found->source;
      callee.return_to = line_ + 1;
      callee.return_source = source_;
      callee.name = "o" + label;
      callee.call_line = static_cast<int>(line_) + 1;
      locals_.push_back(std::move(arguments));
      callee.locals = locals_.size() - 1;
      push_frame(std::move(callee));
      jump_ = found->line;
      jump_source_ = found->source;
      return true;
    }
    if (keyword == "if") {
      bool taken = o_condition();
      o_end_of_line();
      // Down the chain elseif / else / endif until a branch is taken.
      std::size_t at = line_;
      while (!taken) {
        const std::size_t saved_line = line_;
        line_ = at;
        const auto next = find_o(label, {"elseif", "else", "endif"}, true);
        line_ = saved_line;
        if (!next) fail(o, "o" + label + " if without its endif", raw_);
        at = *next;
        if (o_keyword(at) != "elseif") break;
        taken = condition_of_line(at);
      }
      jump_ = at + 1;
      return true;
    }
    if (keyword == "elseif" || keyword == "else") {
      // Reached at the end of the branch taken: on to the endif.
      jump_ = need_o(o, label, {"endif"}, true, keyword + " without its endif") + 1;
      return true;
    }
    if (keyword == "endif" || keyword == "do") {
      o_end_of_line();
      return true;
    }
    if (keyword == "while") {
      const bool condition = o_condition();
      o_end_of_line();
      const auto next = find_o(label, {"endwhile", "do", "while", "sub", "endsub"}, true);
      if (next && o_keyword(*next) == "endwhile") {
        if (!condition) jump_ = *next + 1;
        return true;
      }
      // The test at the end of a do loop.
      const std::size_t start = need_o(o, label, {"do"}, false, "while without its endwhile or do");
      if (condition) jump_ = start + 1;
      return true;
    }
    if (keyword == "endwhile") {
      o_end_of_line();
      jump_ = need_o(o, label, {"while"}, false, "endwhile without its while");
      return true;
    }
    if (keyword == "repeat") {
      const std::size_t start = k_;
      const long count = integer(primary(), start, "the repeat count");
      o_end_of_line();
      const std::size_t end = need_o(o, label, {"endrepeat"}, true, "repeat without its endrepeat");
      if (count <= 0) {
        jump_ = end + 1;
      } else {
        frame.repeat_counts[line_] = count;
      }
      return true;
    }
    if (keyword == "endrepeat") {
      o_end_of_line();
      const std::size_t start = need_o(o, label, {"repeat"}, false, "endrepeat without its repeat");
      long& left = frame.repeat_counts[start];
      if (--left > 0) jump_ = start + 1;
      return true;
    }
    if (keyword == "break" || keyword == "continue") {
      o_end_of_line();
      // The loop of this label around this line: while .. endwhile, do .. while, repeat ..
      // endrepeat.
      const std::size_t opening =
          need_o(o, label, {"while", "do", "repeat"}, false, keyword + " outside its loop");
      const std::string& kind = o_keyword(opening);
      const std::size_t closing = need_o(
          o, label, {kind == "while" ? "endwhile" : kind == "do" ? "while" : "endrepeat"}, true,
          keyword + " outside its loop");
      if (keyword == "break") {
        if (kind == "repeat") frame.repeat_counts.erase(opening);
        jump_ = closing + 1;
      } else {
        jump_ = kind == "while" ? opening : closing;
      }
      return true;
    }
    fail(keyword_token, "not an o-word keyword", raw_);
  }

  /// The condition of the elseif at line `at` (jumped to from a condition that was false).
  bool condition_of_line(std::size_t at) {
    const std::size_t saved_line = line_;
    const std::vector<Token>* saved_tokens = tokens_;
    const std::size_t saved_k = k_;
    const std::string_view saved_raw = raw_;
    line_ = at;
    ++executed_;
    raw_ = line_text(at);
    tokens_ = &tokens_of(raw_);
    k_ = 0;
    if (peek().kind == Tok::letter && peek().word == "N") {
      take();
      take();
    }
    take();  // o
    take();  // label
    take();  // elseif
    const bool result = o_condition();
    o_end_of_line();
    line_ = saved_line;
    tokens_ = saved_tokens;
    k_ = saved_k;
    raw_ = saved_raw;
    return result;
  }

  static std::string to_lower(std::string s) {
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
  }

  // --- The index of the program's structure (once, at the first jump) -------------------------

  std::string_view line_text(std::size_t i) const {
    const std::size_t begin = src().starts[i];
    std::size_t end = src().text.find('\n', begin);
    if (end == std::string_view::npos) end = src().text.size();
    std::string_view line = src().text.substr(begin, end - begin);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    return line;
  }

  void ensure_index() {
    if (src().indexed) return;
    src().indexed = true;
    src().starts.push_back(0);
    const std::string_view text = src().text;
    for (std::size_t p = text.find('\n'); p != std::string_view::npos && p + 1 < text.size();
         p = text.find('\n', p + 1)) {
      src().starts.push_back(p + 1);
    }
    src().info.resize(src().starts.size());
    int program = 0;
    for (std::size_t i = 0; i < src().starts.size(); ++i) {
      index_line(i);
      if (src().info[i].program_number >= 0) ++program;
      src().info[i].program = program;
    }
  }

  void index_line(std::size_t i) {
    const std::string_view line = line_text(i);
    std::size_t first = 0;
    while (first < line.size() && std::isspace(static_cast<unsigned char>(line[first]))) ++first;
    if (first == line.size() || line[first] == '/' || line[first] == '%') return;
    if (is_plain(line)) {
      index_plain_line(i, line.substr(first));
      return;
    }
    std::vector<Token> tokens;
    try {
      tokens = lex(line, Site{src().file, static_cast<int>(i) + 1});
    } catch (const InputError&) {
      return;  // reported if the line runs
    }
    LineInfo& info = src().info[i];
    std::size_t k = 0;
    const auto is_letter = [&](std::size_t j, const char* w) {
      return tokens[j].kind == Tok::letter && tokens[j].word == w;
    };
    if (is_letter(k, "N") && tokens[k + 1].kind == Tok::number) k += 2;
    if (is_letter(k, "O") &&
        (tokens[k + 1].kind == Tok::number || tokens[k + 1].kind == Tok::name)) {
      if (tokens[k + 2].kind == Tok::keyword) {
        info.o_word = static_cast<int>(src().o_words.size());
        src().o_words.push_back(OWord{label_of(tokens[k + 1]), to_lower(tokens[k + 2].word)});
        const OWord& o_word = src().o_words.back();
        src().o_lines[o_word.label].push_back(i);
        if (o_word.keyword == "sub") src().subs.emplace(o_word.label, i);
      } else if (tokens[k + 1].kind == Tok::number && tokens[k + 1].number <= kMaxLabel) {
        info.program_number = std::lround(tokens[k + 1].number);
        src().programs.emplace(info.program_number, i);
      }
      return;
    }
    for (std::size_t j = k; j + 1 < tokens.size(); ++j) {
      const Token& t = tokens[j];
      const bool label = tokens[j + 1].kind == Tok::number && tokens[j + 1].number <= kMaxLabel;
      if (t.kind == Tok::keyword && t.word == "DO" && label) {
        info.do_id = static_cast<int>(tokens[j + 1].number);
      } else if (t.kind == Tok::keyword && t.word == "END" && label) {
        info.end_id = static_cast<int>(tokens[j + 1].number);
      } else if (t.kind == Tok::letter && t.word == "M" && tokens[j + 1].kind == Tok::number) {
        const double m = tokens[j + 1].number;
        if (m == 99.0) info.m99 = true;
        if (m == 2.0 || m == 30.0) info.m_end = true;
      }
    }
  }

  const std::string& o_keyword(std::size_t i) const {
    static const std::string none;
    const int o_word = src().info[i].o_word;
    return o_word < 0 ? none : src().o_words[static_cast<std::size_t>(o_word)].keyword;
  }

  /// A line without macro syntax matters to the index only by M2 / M30 (found without tokens:
  /// an O program number at the top of a long plain program indexes every line).
  void index_plain_line(std::size_t i, std::string_view line) {
    for (std::size_t k = 0; k < line.size(); ++k) {
      const char c = line[k];
      if (c == '(') {
        k = line.find(')', k);
        if (k == std::string_view::npos) return;
      } else if (c == ';') {
        return;
      } else if (c == 'M' || c == 'm') {
        std::size_t j = k + 1;
        while (j < line.size() && (line[j] == ' ' || line[j] == '\t')) ++j;
        while (j < line.size() && line[j] == '0') ++j;
        std::size_t digits = j;
        while (digits < line.size() && std::isdigit(static_cast<unsigned char>(line[digits]))) {
          ++digits;
        }
        const std::string_view code = line.substr(j, digits - j);
        if ((code == "2" || code == "30") && (digits == line.size() || line[digits] != '.')) {
          src().info[i].m_end = true;
        }
      }
    }
  }

  /// The lines of each block number N (at the start of a block), found at the first GOTO.
  void ensure_block_numbers() {
    if (src().numbered) return;
    src().numbered = true;
    for (std::size_t i = 0; i < src().starts.size(); ++i) {
      const std::string_view line = line_text(i);
      std::size_t k = 0;
      while (k < line.size() && std::isspace(static_cast<unsigned char>(line[k]))) ++k;
      if (k == line.size() || (line[k] != 'N' && line[k] != 'n')) continue;
      ++k;
      while (k < line.size() && (line[k] == ' ' || line[k] == '\t')) ++k;
      const std::size_t begin = k;
      while (k < line.size() && std::isdigit(static_cast<unsigned char>(line[k]))) ++k;
      if (k == begin || k - begin > 9) continue;
      long n = 0;
      for (std::size_t j = begin; j < k; ++j) n = 10 * n + (line[j] - '0');
      src().n_lines[n].push_back(i);
    }
  }

  const ReaderOptions& options_;
  const std::function<bool(const ExpandedBlock&)>& emit_;

  // The line running and the line to go to next (when not the following one).
  std::size_t line_ = 0;
  std::optional<std::size_t> jump_;
  std::size_t executed_ = 0;  ///< blocks run since the first jump
  bool jumped_ = false;

  // The tokens of the line running.
  const std::vector<Token>* tokens_ = nullptr;
  std::vector<Token> line_tokens_;
  std::size_t k_ = 0;
  std::string_view raw_;

  // The block handed on (reused).
  std::string text_buffer_;
  std::vector<std::pair<int, int>> columns_;

  // Parameters and calls.
  std::vector<Locals> locals_;
  std::vector<Frame> frames_;
  std::vector<ModalCall> modal_calls_;  ///< G66 / G66.1 in force (the last one given calls)
  std::size_t modal_bodies_running_ = 0;
  std::unordered_map<int, Value> globals_;
  std::unordered_map<std::string, Value> globals_named_;

  // The files: the program's, then those of subprograms found in the subprogram folder.
  std::vector<std::unique_ptr<Source>> sources_;
  std::size_t source_ = 0;  ///< the file running
  std::size_t jump_source_ = 0;  ///< the file of jump_
};

}  // namespace

void run_gcode_program(std::string_view text, const std::string& file,
                       const ReaderOptions& options,
                       const std::function<bool(const ExpandedBlock&)>& emit) {
  Program program(text, file, options, emit);
  program.run();
}

}  // namespace vmsim::toolpath::detail
