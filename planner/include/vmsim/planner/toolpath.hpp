#pragma once
// The canonical motion: what both tool path readers (APT/CL and ISO G-code) produce, and all the
// planner reads. SI units (m, s), positions and tool axes in the workpiece frame W.
#include <Eigen/Core>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace vmsim::planner {

/// One source block (a line of G-code, or an APT record with its `$` continuations).
struct SourceBlock {
  std::string file;
  int line = 0;          ///< first line of the block, 1-based
  long block_number = -1;  ///< G-code N number, -1 where none
  std::string text;      ///< the block as written (continuations joined)
};

enum class MotionKind {
  rapid,   ///< G0 / APT RAPID: positioning, not part of the cut
  linear,  ///< G1 / APT GOTO
  arc,     ///< a point on a G2/G3 arc (tessellated; see ReaderOptions::arc_chord_tolerance_m)
};

/// One point of the tool path: the pose reached at the end of a motion.
struct PathPoint {
  Eigen::Vector3d tip_W_m = Eigen::Vector3d::Zero();        ///< tool tip (APT CL point)
  Eigen::Vector3d axis_W = Eigen::Vector3d::UnitZ();        ///< unit tool axis, tip -> spindle
  MotionKind kind = MotionKind::linear;
  /// Programmed feed for the motion that ends here [m/s]; 0 for rapids.
  double feed_m_per_s = 0.0;
  /// G93 inverse-time feed [1/s] for this motion, where programmed (feed_m_per_s is then 0).
  double inverse_time_feed_per_s = 0.0;
  int block = -1;  ///< index into Toolpath::blocks of the block that programmed this motion
};

/// A warning that names where it comes from (an unknown APT record, an ignored G-code word).
struct ReaderWarning {
  std::string file;
  int line = 0;
  std::string message;
};

struct Toolpath {
  /// The first point is the start pose (APT FROM, or the first programmed position).
  std::vector<PathPoint> points;
  std::vector<SourceBlock> blocks;
  std::vector<ReaderWarning> warnings;
  /// Tool from APT CUTTER where given: diameter and corner radius [m].
  std::optional<double> cutter_diameter_m;
  std::optional<double> cutter_corner_radius_m;
};

/// Machine axis words (G-code X Y Z A B C without tool-centre-point programming) to a pose in
/// the workpiece frame. Given by the caller that knows the machine (the direct kinematics);
/// keys are axis letters, values in mm and deg as written (after G20 inch conversion).
struct AxisWordPose {
  Eigen::Vector3d tip_W_m;
  Eigen::Vector3d axis_W;
};
using AxisWordsToPose = std::function<AxisWordPose(const std::vector<std::pair<char, double>>&)>;

/// Rotary axis words (A B C in deg, under G43.4 or TRAORI) to a unit tool axis in W.
using RotaryWordsToToolAxis =
    std::function<Eigen::Vector3d(const std::vector<std::pair<char, double>>&)>;

struct ReaderOptions {
  /// Largest distance between a G2/G3 arc and the chords it is tessellated into [m].
  double arc_chord_tolerance_m = 0.1e-6;
  /// Needed only for files that program machine axes with rotary words outside tool-centre-point
  /// mode; without it such a file is an error that says so.
  AxisWordsToPose axis_words_to_pose;
  /// Needed only for G43.4 / TRAORI blocks that give A B C rather than a tool vector.
  RotaryWordsToToolAxis rotary_words_to_tool_axis;
};

/// Reads an APT/CL file. Throws vmsim::InputError naming the file, line, column and word.
Toolpath read_apt(const std::string& path, const ReaderOptions& options = {});
Toolpath parse_apt(const std::string& text, const std::string& file_name_for_messages,
                   const ReaderOptions& options = {});

/// Reads an ISO G-code file (Fanuc / Siemens dialect subset; see the README).
Toolpath read_gcode(const std::string& path, const ReaderOptions& options = {});
Toolpath parse_gcode(const std::string& text, const std::string& file_name_for_messages,
                     const ReaderOptions& options = {});

/// Picks the reader by extension: .apt .cl .cls -> APT; .nc .ngc .gcode .mpf .tap .iso -> G-code.
Toolpath read_toolpath(const std::string& path, const ReaderOptions& options = {});

}  // namespace vmsim::planner
