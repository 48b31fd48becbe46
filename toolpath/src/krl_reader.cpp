// KUKA KRL reader: the subset documented in vmsim/toolpath/toolpath.hpp ("KUKA KRL subset").
// Robot CAM posts write a flat program: frames ($BASE, $TOOL), path parameters ($VEL.CP,
// $APO.CDIS) and one motion per line (PTP, LIN, CIRC with an E6POS target); the teach pendant's
// inline forms add position variables declared in the companion .dat file.
#include <Eigen/Geometry>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
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
constexpr double kRadPerDeg = std::numbers::pi / 180.0;

/// An aggregate as written: {[TYPE:] NAME value, ...}, component names upper case.
struct Aggregate {
  std::string type;  ///< E6POS, POS, FRAME, E6AXIS, AXIS or "" (no type given)
  std::map<std::string, double, std::less<>> values;
  int column = 0;  ///< of the '{'
};

bool is_joint_aggregate(const Aggregate& a) {
  if (a.type == "E6AXIS" || a.type == "AXIS") return true;
  return a.type.empty() && a.values.count("A1") > 0;
}

/// KUKA's orientation: A about z, then B about the new y, then C about the new x (ZYX Euler).
Eigen::Matrix3d kuka_rotation(double a_deg, double b_deg, double c_deg) {
  return (Eigen::AngleAxisd(a_deg * kRadPerDeg, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(b_deg * kRadPerDeg, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(c_deg * kRadPerDeg, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

/// X Y Z [mm] A B C [deg] of a frame (the inverse of kuka_rotation; at B = +-90 deg, C = 0).
std::array<double, 6> kuka_components(const Eigen::Isometry3d& frame_mm) {
  const Eigen::Matrix3d& R = frame_mm.linear();
  const double b = std::atan2(-R(2, 0), std::hypot(R(0, 0), R(1, 0)));
  double a = 0.0, c = 0.0;
  if (std::hypot(R(0, 0), R(1, 0)) > 1e-12) {
    a = std::atan2(R(1, 0), R(0, 0));
    c = std::atan2(R(2, 1), R(2, 2));
  } else {
    a = std::atan2(-R(0, 1), R(1, 1));
  }
  const Eigen::Vector3d p = frame_mm.translation();
  return {p.x(), p.y(), p.z(), a / kRadPerDeg, b / kRadPerDeg, c / kRadPerDeg};
}

class KrlReader {
 public:
  KrlReader(const std::string& file, const ReaderOptions& options) : file_(file), options_(options) {
    const Eigen::Matrix4d& X = options_.krl_world_in_W;
    X_W_world_.matrix() = X;
    X_W_world_.translation() *= 1.0 / kMetresPerMillimetre;  // the reader works in mm
  }

  int current_line() const { return current_line_; }

  /// Declarations (and BASE_DATA / TOOL_DATA) of the companion .dat file, read before the program.
  void read_data(std::string_view text, const std::string& dat_file) {
    const std::string saved = file_;
    file_ = dat_file;
    in_data_ = true;
    read_lines(text);
    in_data_ = false;
    file_ = saved;
    current_line_ = 0;
  }

  Toolpath read(std::string_view text) {
    read_lines(text);
    detail::require_motion(path_, file_);
    return std::move(path_);
  }

 private:
  void read_lines(std::string_view text) {
    text = detail::without_byte_order_mark(text);
    detail::require_utf8_text(text, file_);
    std::size_t begin = 0;
    current_line_ = 0;
    while (begin < text.size() && !finished_) {
      std::size_t end = text.find('\n', begin);
      if (end == std::string_view::npos) end = text.size();
      std::string_view line = text.substr(begin, end - begin);
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      ++current_line_;
      begin = end + 1;
      // ';' starts a comment (folds ;FOLD ... ;ENDFOLD are comments too), outside strings.
      bool in_string = false;
      std::size_t cut = line.size();
      for (std::size_t i = 0; i < line.size(); ++i) {
        if (line[i] == '"' || line[i] == '\'') in_string = !in_string;
        if (line[i] == ';' && !in_string) {
          cut = i;
          break;
        }
      }
      line_ = std::string(line.substr(0, cut));
      std::size_t first = 0;
      while (first < line_.size() && std::isspace(static_cast<unsigned char>(line_[first]))) ++first;
      if (first == line_.size() || line_[first] == '&') continue;  // &ACCESS, &REL: editor attributes
      statement(first);
    }
  }

  [[noreturn]] void fail(std::size_t index, const std::string& message) const {
    throw InputError(located_message(file_, current_line_, static_cast<int>(index) + 1, message));
  }

  void warn(const std::string& message) {
    ++warning_count_;
    if (warning_count_ < 1000) path_.warnings.push_back(ReaderWarning{file_, current_line_, message});
  }

  // --- lexing helpers on line_ ---
  void skip_blanks(std::size_t& i) const {
    while (i < line_.size() && std::isspace(static_cast<unsigned char>(line_[i]))) ++i;
  }
  /// An identifier ($VEL.CP, BASE_DATA, LIN, C_DIS, #BASE), upper case; empty when none.
  std::string word(std::size_t& i) const {
    const std::size_t start = i;
    while (i < line_.size()) {
      const char c = line_[i];
      if (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '$' || c == '#' ||
          (c == '.' && i > start)) {
        ++i;
      } else {
        break;
      }
    }
    return detail::to_upper(std::string_view(line_).substr(start, i - start));
  }
  double number(std::size_t& i, const std::string& what) const {
    skip_blanks(i);
    const std::size_t start = i;
    if (i < line_.size() && (line_[i] == '+' || line_[i] == '-')) ++i;
    while (i < line_.size() && (std::isalnum(static_cast<unsigned char>(line_[i])) || line_[i] == '.' ||
                                ((line_[i] == '+' || line_[i] == '-') && i > start &&
                                 (line_[i - 1] == 'e' || line_[i - 1] == 'E')))) {
      ++i;
    }
    const std::string text = line_.substr(start, i - start);
    std::string problem;
    const std::optional<double> value = detail::parse_decimal(text, &problem);
    if (!value) fail(start, (text.empty() ? std::string("a number is needed") : problem + " '" + text + "'") + " in " + what);
    return *value;
  }
  void expect(std::size_t& i, char c, const std::string& what) const {
    skip_blanks(i);
    if (i >= line_.size() || line_[i] != c) {
      fail(i, std::string("'") + c + "' expected in " + what);
    }
    ++i;
  }
  /// [index] after BASE_DATA / TOOL_DATA.
  int index(std::size_t& i, const std::string& what) {
    expect(i, '[', what);
    const std::size_t at = i;
    const double n = number(i, what);
    if (n != std::floor(n) || n < 1 || n > 1000) fail(at, "the index of " + what + " must be 1 .. 1000");
    expect(i, ']', what);
    return static_cast<int>(n);
  }

  Aggregate aggregate(std::size_t& i, const std::string& what) {
    skip_blanks(i);
    Aggregate a;
    a.column = static_cast<int>(i) + 1;
    expect(i, '{', what);
    // Optional type: "E6POS:".
    {
      std::size_t j = i;
      skip_blanks(j);
      const std::string type = word(j);
      skip_blanks(j);
      if (!type.empty() && j < line_.size() && line_[j] == ':') {
        a.type = type;
        i = j + 1;
      }
    }
    while (true) {
      skip_blanks(i);
      if (i < line_.size() && line_[i] == '}') {
        ++i;
        break;
      }
      const std::size_t at = i;
      const std::string name = word(i);
      if (name.empty()) fail(at, "a component name (X Y Z A B C, A1 .. A6) expected in " + what);
      skip_blanks(i);
      if (i < line_.size() && (line_[i] == '\'' || line_[i] == '"')) {  // S 'B110': status bits
        const char quote = line_[i];
        const std::size_t close = line_.find(quote, i + 1);
        if (close == std::string::npos) fail(i, "unterminated string in " + what);
        i = close + 1;
      } else {
        const double value = number(i, name + " of " + what);
        if (a.values.count(name)) fail(at, "component " + name + " twice in " + what);
        a.values[name] = value;
      }
      skip_blanks(i);
      if (i < line_.size() && line_[i] == ',') {
        ++i;
        continue;
      }
      expect(i, '}', what);
      break;
    }
    for (const auto& [name, value] : a.values) {
      const bool length = name == "X" || name == "Y" || name == "Z";
      const bool angle = name == "A" || name == "B" || name == "C" ||
                         (name.size() == 2 && (name[0] == 'A' || name[0] == 'E') &&
                          name[1] >= '1' && name[1] <= '6');
      if (name == "S" || name == "T") continue;
      if (!length && !angle) fail(static_cast<std::size_t>(a.column - 1), "unknown component '" + name + "' in " + what);
      const double limit = length ? detail::kMaxCoordinateMm : detail::kMaxRotaryDeg;
      if (std::abs(value) > limit) {
        fail(static_cast<std::size_t>(a.column - 1), name + " " + detail::format_number(value) + " in " + what +
                                                         " is outside [-" + detail::format_number(limit) + ", " +
                                                         detail::format_number(limit) + "]");
      }
    }
    return a;
  }

  /// A frame from an aggregate, missing components from `base` (KUKA: an aggregate that leaves
  /// components out keeps those of the current value).
  Eigen::Isometry3d frame(const Aggregate& a, const std::array<double, 6>& base) const {
    static const char* const kNames[6] = {"X", "Y", "Z", "A", "B", "C"};
    std::array<double, 6> v = base;
    for (int k = 0; k < 6; ++k) {
      const auto it = a.values.find(kNames[k]);
      if (it != a.values.end()) v[static_cast<std::size_t>(k)] = it->second;
    }
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.linear() = kuka_rotation(v[3], v[4], v[5]);
    X.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
    return X;
  }

  /// The value named or written at i: an aggregate, a declared variable, BASE_DATA[n] /
  /// TOOL_DATA[n].
  Aggregate value(std::size_t& i, const std::string& what) {
    skip_blanks(i);
    if (i < line_.size() && line_[i] == '{') return aggregate(i, what);
    const std::size_t at = i;
    const std::string name = word(i);
    if (name == "BASE_DATA" || name == "TOOL_DATA") {
      const int n = index(i, name);
      auto& table = name == "BASE_DATA" ? base_data_ : tool_data_;
      const auto it = table.find(n);
      if (it == table.end()) {
        fail(at, name + "[" + std::to_string(n) + "] is not set in the program or its .dat file (the "
                 "controller's $config.dat holds it): write " + name + "[" + std::to_string(n) +
                 "] = {X .., Y .., Z .., A .., B .., C ..} before, or the frame itself");
      }
      return it->second;
    }
    if (name.empty()) fail(at, "a position ({X .., ...}) or a variable expected in " + what);
    const auto it = variables_.find(name);
    if (it == variables_.end()) fail(at, "'" + name + "' is not a declared position (DECL E6POS/POS/FRAME/E6AXIS)");
    skip_blanks(i);
    if (i < line_.size() && line_[i] == ':') fail(i, "the geometric operator ':' is not supported");
    return it->second;
  }

  void end_of_statement(std::size_t i, const std::string& what) const {
    skip_blanks(i);
    if (i < line_.size()) fail(i, "unexpected '" + line_.substr(i) + "' after " + what);
  }

  // --- statements ---
  void statement(std::size_t i) {
    const std::size_t start = i;
    std::string head = word(i);
    if (head == "GLOBAL") {
      skip_blanks(i);
      head = word(i);
    }
    if (head.empty()) fail(start, "unexpected '" + line_.substr(start) + "'");
    if (head == "DEF" || head == "DEFDAT" || head == "DEFFCT" || head == "EXT" || head == "EXTFCT") {
      if (head == "DEF" && !in_data_) {
        ++def_depth_;
        if (def_depth_ > 1) finished_ = true;  // a second DEF: a local subprogram, not run
      }
      return;
    }
    if (head == "END") {
      if (!in_data_) finished_ = true;  // the main program's end; local subprograms follow
      return;
    }
    if (head == "ENDDAT" || head == "ENDFCT") return;
    if (head == "DECL") return declaration(i);
    if (head == "PTP" || head == "LIN" || head == "CIRC") {
      if (in_data_) fail(start, head + " in a .dat file");
      return motion(head, i, start);
    }
    static const std::set<std::string, std::less<>> kUnsupportedMotions = {
        "PTP_REL", "LIN_REL", "CIRC_REL", "SPLINE", "SPL", "SLIN", "SCIRC", "SPTP", "PTP_SPLINE"};
    if (kUnsupportedMotions.count(head)) {
      fail(start, head + " is not supported (PTP, LIN and CIRC with absolute targets are)");
    }
    static const std::set<std::string, std::less<>> kControlFlow = {
        "IF", "ELSE", "ENDIF", "FOR", "ENDFOR", "WHILE", "ENDWHILE", "LOOP", "ENDLOOP", "REPEAT",
        "UNTIL", "GOTO", "SWITCH", "CASE", "DEFAULT", "ENDSWITCH", "EXIT", "RETURN"};
    if (kControlFlow.count(head)) {
      fail(start, head + ": control flow is not supported (a robot CAM post writes the motions "
                         "one after the other)");
    }
    if (head == "BAS") return bas_call(i, start);
    if (head == "WAIT" || head == "HALT" || head == "INTERRUPT" || head == "TRIGGER" || head == "CONTINUE" ||
        head == "PULSE" || head == "ANOUT" || head == "ANIN") {
      return;  // I/O and synchronisation: no motion
    }
    skip_blanks(i);
    std::size_t subscript_index = 0;
    int subscript = 0;
    if (i < line_.size() && line_[i] == '[') {
      subscript_index = i;
      if (head == "BASE_DATA" || head == "TOOL_DATA") subscript = index(i, head);
      else {
        const std::size_t close = line_.find(']', i);
        if (close == std::string::npos) fail(i, "']' expected");
        i = close + 1;
      }
      skip_blanks(i);
    }
    (void)subscript_index;
    if (i < line_.size() && line_[i] == '=') {
      ++i;
      return assignment(head, subscript, i, start);
    }
    if (i < line_.size() && line_[i] == '(') {
      if (!in_data_) warn("call '" + detail::trim(line_.substr(start)) + "' is not simulated");
      return;
    }
    if (!in_data_) warn("statement '" + detail::trim(line_.substr(start)) + "' is not simulated");
  }

  void declaration(std::size_t i) {
    skip_blanks(i);
    std::string type = word(i);
    if (type == "GLOBAL") {
      skip_blanks(i);
      type = word(i);
    }
    const bool position = type == "E6POS" || type == "POS" || type == "FRAME" || type == "E6AXIS" || type == "AXIS";
    if (!position) return;  // INT, REAL, FDAT, PDAT, LDAT ...: nothing the path needs
    skip_blanks(i);
    const std::size_t at = i;
    const std::string name = word(i);
    if (name.empty()) fail(at, "a variable name expected after DECL " + type);
    skip_blanks(i);
    if (i >= line_.size()) return;  // declared, not initialised
    if (line_[i] == '[') return;  // arrays of positions: not used by posts' programs
    expect(i, '=', "DECL " + type + " " + name);
    Aggregate a = aggregate(i, name);
    if (a.type.empty()) a.type = type;
    variables_[name] = a;
  }

  void assignment(const std::string& target, int subscript, std::size_t i, std::size_t start) {
    if (target == "$VEL.CP") {
      const std::size_t at = i;
      const double v = number(i, target);
      const double mm_per_min = v * 60.0 / kMetresPerMillimetre;
      if (!(mm_per_min >= detail::kMinFeedMmPerMin && mm_per_min <= detail::kMaxFeedMmPerMin)) {
        fail(at, "$VEL.CP " + detail::format_number(v) + " m/s is outside the feeds accepted (1e-3 .. 1e6 mm/min)");
      }
      feed_m_per_s_ = v;
      return end_of_statement(i, target);
    }
    if (target == "$APO.CDIS") {
      const std::size_t at = i;
      const double d = number(i, target);
      if (!(d >= 0.0 && d <= detail::kMaxToleranceMm)) {
        fail(at, "$APO.CDIS " + detail::format_number(d) + " mm is outside [0, 1000] mm");
      }
      cdis_mm_ = d;
      return end_of_statement(i, target);
    }
    if (target == "$BASE" || target == "$TOOL") {
      const Aggregate a = value(i, target);
      if (is_joint_aggregate(a)) fail(static_cast<std::size_t>(a.column - 1), target + " needs a frame");
      const Eigen::Isometry3d X = frame(a, {0, 0, 0, 0, 0, 0});
      if (target == "$BASE") set_base(X);
      else tool_ = X;
      return end_of_statement(i, target);
    }
    if (target == "BASE_DATA" || target == "TOOL_DATA") {
      const Aggregate a = value(i, target);
      (target == "BASE_DATA" ? base_data_ : tool_data_)[subscript] = a;
      return end_of_statement(i, target);
    }
    const auto declared = variables_.find(target);
    if (declared != variables_.end() && !target.starts_with("$")) {
      Aggregate a = value(i, target);
      a.type = declared->second.type;
      declared->second = a;
      return end_of_statement(i, target);
    }
    // Other system variables ($ACC.CP, $ORI_TYPE, $ADVANCE, $OUT[n], $APO.CVEL ...) and
    // variables of other types change nothing on the path.
    (void)start;
  }

  /// BAS(#BASE, n) / BAS(#TOOL, n): the frames from BASE_DATA / TOOL_DATA (KUKA's BAS.SRC);
  /// BAS(#VEL_CP, v) / BAS(#CP_PARAMS, v): $VEL.CP = v m/s; other BAS calls change nothing on
  /// the path.
  void bas_call(std::size_t i, std::size_t start) {
    if (in_data_) return;
    expect(i, '(', "BAS");
    skip_blanks(i);
    const std::string what = word(i);
    skip_blanks(i);
    if (i < line_.size() && line_[i] == ',') ++i;
    if (what == "#BASE" || what == "#TOOL") {
      const std::size_t at = i;
      const double n = number(i, "BAS(" + what + ")");
      const auto& table = what == "#BASE" ? base_data_ : tool_data_;
      const auto it = table.find(static_cast<int>(n));
      const std::string name = (what == "#BASE" ? "BASE_DATA[" : "TOOL_DATA[") + detail::format_number(n) + "]";
      if (n == 0 && what == "#BASE") {
        set_base(Eigen::Isometry3d::Identity());
      } else if (it == table.end()) {
        fail(at, name + " is not set in the program or its .dat file (the controller's $config.dat "
                        "holds it): write " + name + " = {X .., Y .., Z .., A .., B .., C ..} before");
      } else if (what == "#BASE") {
        set_base(frame(it->second, {0, 0, 0, 0, 0, 0}));
      } else {
        tool_ = frame(it->second, {0, 0, 0, 0, 0, 0});
      }
    } else if (what == "#VEL_CP" || what == "#CP_PARAMS") {
      const std::size_t at = i;
      const double v = number(i, "BAS(" + what + ")");
      if (!(v > 0.0 && v * 6e4 <= detail::kMaxFeedMmPerMin)) fail(at, "BAS(" + what + ") needs a velocity in m/s");
      feed_m_per_s_ = v;
    } else {
      (void)start;
    }
  }

  void set_base(const Eigen::Isometry3d& base_mm) {
    base_ = base_mm;
  }

  /// The TCP frame of the previous motion in the current base, as components (for aggregates
  /// that leave components out).
  std::array<double, 6> current_in_base() const {
    if (!X_world_tcp_) return {0, 0, 0, 0, 0, 0};
    return kuka_components(base_.inverse() * *X_world_tcp_);
  }

  PathPoint point_of(const Eigen::Isometry3d& X_world_tcp) const {
    const Eigen::Isometry3d X_W_tcp = X_W_world_ * X_world_tcp;
    PathPoint p;
    p.tip_W_m = X_W_tcp.translation() * kMetresPerMillimetre;
    // KUKA's tool direction is the TCP frame's x axis ($TOOL_DIRECTION #X), pointing from the
    // spindle into the work; the canonical axis points from the tip to the spindle.
    p.axis_W = -X_W_tcp.linear().col(0).normalized();
    p.tool_number = -1;
    return p;
  }

  Eigen::Isometry3d target_frame(const Aggregate& a, std::size_t at, const std::string& what) {
    if (is_joint_aggregate(a)) fail(at, what + " needs a Cartesian position (E6POS, POS or FRAME)");
    const bool complete = a.values.count("X") && a.values.count("Y") && a.values.count("Z") &&
                          a.values.count("A") && a.values.count("B") && a.values.count("C");
    if (!complete && !X_world_tcp_) {
      fail(at, what + " leaves components out before the position is known (the first motion must "
                      "give X Y Z A B C)");
    }
    return base_ * frame(a, current_in_base());
  }

  void motion(const std::string& kind, std::size_t i, std::size_t start) {
    skip_blanks(i);
    const std::size_t target_at = i;
    Aggregate aux;
    std::size_t aux_at = 0;
    if (kind == "CIRC") {
      aux_at = i;
      aux = value(i, "CIRC's auxiliary point");
      skip_blanks(i);
      expect(i, ',', "CIRC (auxiliary point, end point)");
      skip_blanks(i);
    }
    const std::size_t end_at = i;
    const Aggregate target = value(i, kind + "'s target");
    // Approximation: C_DIS blends within $APO.CDIS; C_VEL / C_ORI (and C_PTP) blend by a
    // criterion that is not a distance (the part file decides); none: exact stop.
    double corner = 0.0;
    while (true) {
      skip_blanks(i);
      if (i >= line_.size()) break;
      const std::size_t at = i;
      const std::string w = word(i);
      if (w == "C_DIS") {
        corner = cdis_mm_ * kMetresPerMillimetre;
      } else if (w == "C_VEL" || w == "C_ORI" || w == "C_PTP") {
        corner = PathPoint::kNotProgrammed;
      } else if (w == "CA") {
        fail(at, "CIRC with a circular angle CA is not supported");
      } else {
        fail(at, "unexpected '" + line_.substr(at) + "' after " + kind + " (C_DIS, C_VEL or C_ORI expected)");
      }
    }
    SourceBlock block;
    block.file = file_;
    block.line = current_line_;
    block.text = detail::trim(line_.substr(start));
    if (kind == "PTP") {
      PathPoint point;
      if (is_joint_aggregate(target)) {
        if (!options_.robot_joints_to_pose) {
          fail(target_at, "PTP with axis values needs the machine (ReaderOptions::robot_joints_to_pose)");
        }
        std::vector<double> joints(6, 0.0);
        for (int k = 0; k < 6; ++k) {
          const std::string name = "A" + std::to_string(k + 1);
          const auto it = target.values.find(name);
          if (it != target.values.end()) {
            joints[static_cast<std::size_t>(k)] = it->second;
          } else if (joints_deg_) {
            joints[static_cast<std::size_t>(k)] = (*joints_deg_)[static_cast<std::size_t>(k)];
          } else {
            fail(target_at, "PTP leaves " + name + " out before the axis positions are known");
          }
        }
        joints_deg_ = joints;
        const AxisWordPose pose = options_.robot_joints_to_pose(joints);
        point.tip_W_m = pose.tip_W_m;
        point.axis_W = pose.axis_W;
        // The TCP frame in $WORLD (its roll about the tool axis is not known: any will do, the
        // canonical path has none).
        const Eigen::Isometry3d X_world_W = X_W_world_.inverse();
        Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
        const Eigen::Vector3d x = -(X_world_W.linear() * pose.axis_W).normalized();
        const Eigen::Vector3d helper = std::abs(x.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
        const Eigen::Vector3d y = helper.cross(x).normalized();
        X.linear().col(0) = x;
        X.linear().col(1) = y;
        X.linear().col(2) = x.cross(y);
        X.translation() = X_world_W * (pose.tip_W_m / kMetresPerMillimetre);
        X_world_tcp_ = X;
      } else {
        const Eigen::Isometry3d X = target_frame(target, end_at, "PTP");
        point = point_of(X);
        X_world_tcp_ = X;
        joints_deg_.reset();
      }
      path_.blocks.push_back(block);
      point.kind = MotionKind::rapid;
      point.block = static_cast<int>(path_.blocks.size()) - 1;
      point.corner_tolerance_m = corner;
      detail::append_point(path_, point, options_, file_, current_line_);
      return;
    }
    if (!feed_m_per_s_) {
      fail(start, kind + " before any $VEL.CP: the feed rate of this cutting move is unknown");
    }
    const Eigen::Isometry3d X_end = target_frame(target, end_at, kind);
    path_.blocks.push_back(block);
    const int block_index = static_cast<int>(path_.blocks.size()) - 1;
    joints_deg_.reset();
    if (kind == "LIN") {
      PathPoint point = point_of(X_end);
      point.kind = MotionKind::linear;
      point.feed_m_per_s = *feed_m_per_s_;
      point.block = block_index;
      point.corner_tolerance_m = corner;
      detail::append_point(path_, point, options_, file_, current_line_);
      X_world_tcp_ = X_end;
      return;
    }
    // CIRC: the circle through the start, the auxiliary and the end point; the orientation
    // goes from the start's to the end's in proportion to the angle turned ($ORI_TYPE #VAR,
    // the auxiliary point's orientation is not used, as on the control).
    if (!X_world_tcp_) fail(start, "CIRC as the first motion: its start is not known");
    const Eigen::Isometry3d X_aux = target_frame(aux, aux_at, "CIRC's auxiliary point");
    const Eigen::Vector3d p0 = X_world_tcp_->translation(), p1 = X_aux.translation(), p2 = X_end.translation();
    const Eigen::Vector3d u = p1 - p0, v = p2 - p0;
    const Eigen::Vector3d n = u.cross(v);
    const double scale = std::max({u.norm(), v.norm(), 1e-9});
    if (n.norm() < 1e-9 * scale * scale) {
      fail(aux_at, "CIRC: the start, auxiliary and end points lie on one line (no circle)");
    }
    // Circumcentre: c = p0 + (|u|^2 v x n ... ) standard formula.
    const Eigen::Vector3d centre =
        p0 + (u.squaredNorm() * v.cross(n) + v.squaredNorm() * n.cross(u)) / (2.0 * n.squaredNorm());
    const double radius = (p0 - centre).norm();
    const Eigen::Vector3d e1 = (p0 - centre).normalized();
    const Eigen::Vector3d normal = n.normalized();
    const Eigen::Vector3d e2 = normal.cross(e1);
    const auto angle_of = [&](const Eigen::Vector3d& p) {
      double a = std::atan2((p - centre).dot(e2), (p - centre).dot(e1));
      if (a < 0) a += 2.0 * std::numbers::pi;
      return a;
    };
    const double sweep = angle_of(p2);  // the aux point lies between (normal from u x v)
    const double tolerance_mm = options_.arc_chord_tolerance_m / kMetresPerMillimetre;
    const double step = radius > tolerance_mm ? 2.0 * std::acos(1.0 - tolerance_mm / radius) : sweep;
    const double count = std::ceil(sweep / std::max(step, 1e-12));
    if (!(count <= static_cast<double>(options_.max_points_per_block))) {
      detail::require_room_for_points(path_, options_.max_points_per_block + 1, options_, file_, current_line_,
                                      static_cast<int>(start) + 1, "the CIRC (radius " + detail::format_number(radius) + " mm)");
    }
    const auto segments = static_cast<std::size_t>(std::max(1.0, count));
    detail::require_room_for_points(path_, segments, options_, file_, current_line_, static_cast<int>(start) + 1,
                                    "the CIRC (radius " + detail::format_number(radius) + " mm)");
    const Eigen::Quaterniond q0(X_world_tcp_->linear()), q2(X_end.linear());
    for (std::size_t k = 1; k <= segments; ++k) {
      const double f = static_cast<double>(k) / static_cast<double>(segments);
      Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
      X.linear() = q0.slerp(f, q2).toRotationMatrix();
      X.translation() = k == segments ? p2 : Eigen::Vector3d(centre + radius * (std::cos(f * sweep) * e1 + std::sin(f * sweep) * e2));
      PathPoint point = point_of(X);
      point.kind = MotionKind::arc;
      point.feed_m_per_s = *feed_m_per_s_;
      point.block = block_index;
      // Points inside the arc are no corners of the program.
      point.corner_tolerance_m = k == segments ? corner : PathPoint::kNotProgrammed;
      detail::append_point(path_, point, options_, file_, current_line_);
    }
    X_world_tcp_ = X_end;
  }

  std::string file_;
  const ReaderOptions& options_;
  Toolpath path_;
  std::string line_;
  int current_line_ = 0;
  int warning_count_ = 0;
  int def_depth_ = 0;
  bool finished_ = false;
  bool in_data_ = false;
  Eigen::Isometry3d X_W_world_ = Eigen::Isometry3d::Identity();  ///< mm
  Eigen::Isometry3d base_ = Eigen::Isometry3d::Identity();       ///< $BASE in $WORLD, mm
  /// $TOOL on the flange, mm: read and checked, but it does not change the canonical path (the
  /// TCP is the tool tip; where it sits on the flange is the machine file's and the part's tool).
  Eigen::Isometry3d tool_ = Eigen::Isometry3d::Identity();
  std::optional<Eigen::Isometry3d> X_world_tcp_;                 ///< after the last motion, mm
  std::optional<std::vector<double>> joints_deg_;               ///< after a PTP with axis values
  std::optional<double> feed_m_per_s_;
  double cdis_mm_ = 0.0;
  std::map<std::string, Aggregate, std::less<>> variables_;
  std::map<int, Aggregate> base_data_, tool_data_;
};

}  // namespace

Toolpath parse_krl(const std::string& text, const std::string& file_name_for_messages,
                   const ReaderOptions& options, const std::string& dat_text, const std::string& dat_file) {
  KrlReader reader(file_name_for_messages, options);
  if (!dat_text.empty()) {
    struct DataReader {
      KrlReader& r;
      const std::string& file;
      int current_line() const { return r.current_line(); }
      Toolpath read(const std::string& text) {
        r.read_data(text, file);
        return {};
      }
    } data{reader, dat_file};
    detail::read_with_located_errors(data, dat_text, dat_file);
  }
  return detail::read_with_located_errors(reader, text, file_name_for_messages);
}

Toolpath read_krl(const std::string& path, const ReaderOptions& options) {
  std::filesystem::path dat = std::filesystem::path(path);
  std::string dat_text, dat_file;
  for (const char* extension : {".dat", ".DAT"}) {
    dat.replace_extension(extension);
    std::error_code error;
    if (std::filesystem::is_regular_file(dat, error)) {
      dat_file = dat.string();
      dat_text = detail::read_text_file(dat_file);
      break;
    }
  }
  return parse_krl(detail::read_text_file(path), path, options, dat_text, dat_file);
}

}  // namespace vmsim::toolpath
