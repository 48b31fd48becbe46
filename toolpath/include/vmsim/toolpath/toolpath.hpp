#pragma once
// The canonical motion: what both tool path readers (APT/CL and ISO G-code) produce, and all the
// planner reads. SI units (m, s), positions and tool axes in the workpiece frame W.
//
// Both readers give the same canonical points for the same motion: a tool tip [m], a unit tool
// axis pointing from the tip to the spindle, the kind of motion, the feed [m/s] (or G93 inverse
// time [1/s]) and the source block. Common rules:
//  - Errors: bad input throws vmsim::InputError "file:line:column: 'word': what is wrong"; nothing
//    is half-returned. A file that programs no tool position at all (empty, comments only, no
//    motion record) is an error ("no motion"), not an empty path.
//  - A cutting move (APT GOTO without RAPID, G1/G2/G3) before any feed rate is an error (never a
//    silent feed of 0).
//  - A motion that ends exactly where the previous point is (same tip, same axis) adds no point.
//  - A zero tool axis vector (APT i,j,k; G43.5 I J K; Siemens A3 B3 C3) is an error; others are
//    normalised.
//  - Text: a UTF-8 byte-order mark at the start is skipped (columns count after it). The file
//    must be UTF-8 (ASCII included): a byte that is not (a Latin-1 0xE9, a cut-short sequence)
//    or a NUL is an error naming its line, column and the byte in hex.
//  - Numbers: finite, not subnormal (4.9e-324), within a double (1e400 is an error "too large",
//    1e-400 "too small"); every error quotes the value as written. Plausible ranges (in mm after
//    UNITS/G20): coordinates, arc centre offsets and radii |v| <= 1e6 mm (also the positions
//    reached incrementally); rotary words |A B C| <= 1e6 deg; feed 1e-3 .. 1e6 mm/min; G93
//    inverse time 1e-3 .. 1e4 1/min; CUTTER diameter 1e-3 .. 1e4 mm, corner radius 0 .. d/2;
//    spindle speed (APT SPINDL, G-code S) |S| <= 1e6 rev/min; APT tolerances (INTOL OUTTOL TOLER
//    LINTOL) |t| <= 1e3 mm; N O T H D M P and G4 dwell values 0 .. 1e9; G numbers 0 .. 1000.
//  - Size: a file of at most 1 GiB, a G-code block of at most 64 words, an APT record of at
//    most 4 MiB (continuations joined). Expansion: ReaderOptions::max_points_per_block (an arc's
//    tessellation, a long rotary turn's steps) and max_path_points (the whole path), checked
//    before a block's points are made; the message gives the block's points, the total and the
//    limit. A block turns an arc at most once (a full circle: no P turns count, no TURN=).
//  - Errors from the caller's callbacks (axis_words_to_pose, rotary_words_to_tool_axis) are
//    rethrown at the block, of the same type (InputError or InfeasibleError: a word outside the
//    axis travel); every other failure inside a reader becomes an InputError naming the line.
//
// APT/CL subset (read_apt):
//  - Records `NAME/v1,v2,...`, case-insensitive; a trailing `$` continues the record on the next
//    line; `$$` starts a comment (to the end of the line). PARTNO PPRINT INSERT REMARK TITLE
//    carry free text and are skipped whole.
//  - UNITS/MM | UNITS/INCHES (default mm): lengths and FEDRAT/f that follow are in that unit.
//  - FROM/x,y,z[,i,j,k]: a point of kind rapid (the start pose when first; a warning when not).
//  - GOTO/x,y,z[,i,j,k]: MULTAX/ON (or MULTAX alone): x,y,z,i,j,k, several points allowed as a
//    multiple of 6 values; MULTAX/OFF: x,y,z, several points as a multiple of 3 values, with the
//    current TLAXIS axis; MULTAX never given: 3 values (TLAXIS axis) or 6 values (own axis).
//    A given i,j,k becomes the current tool axis. The point's kind is rapid after RAPID (for the
//    next GOTO only), else linear.
//  - TLAXIS/i,j,k: the tool axis for GOTOs without i,j,k (default +Z). No motion by itself.
//  - FEDRAT/f | FEDRAT/MMPM,f | FEDRAT/f,MMPM | IPM forms: feed per minute (f alone: in the
//    UNITS unit per minute); MMPR/IPR (per revolution) is an error.
//  - CUTTER/d[,r[,e,f,a,b,h]] (APT 7-parameter form): Toolpath::cutter_diameter_m and
//    cutter_corner_radius_m (r defaults to 0; 0 <= r <= d/2).
//  - LOADTL/n[,...]: tool n (PathPoint::tool_number) for the motions that follow.
//  - FINI ends the file. CUTCOM (other than /OFF), CYCLE (other than /OFF) and CIRCLE / MOVARC
//    change the geometry and are errors. Harmless records (SPINDL COOLNT LOADTL END CLPRNT NOPOST
//    MACHIN SELCTL TOOLNO STOP OPSTOP DELAY SEQNO INTOL OUTTOL TOLER PLABEL TLDATA MSYS PAINT
//    "TOOL PATH" END-OF-PATH ...) are accepted silently; any other record is a ReaderWarning
//    naming its line.
//  - Errors: malformed number, wrong number of values, unknown UNITS/FEDRAT/MULTAX modifier, a
//    record name without its '/' (GOTO 1,2,3), the file ending inside a `$` continuation.
//
// G-code subset (read_gcode), Fanuc / Siemens dialect:
//  - Words: a letter and a decimal number (X10 is 10 mm: decimal-point programming), Siemens
//    `X=10` and extended addresses `A3=0.5`; comments `( ... )` and after `;`; `%` lines and O
//    program numbers skipped; N is kept as SourceBlock::block_number; a block starting with `/`
//    (block delete) is skipped with a warning. S T H D words and M codes are accepted and
//    ignored, except M2/M30 (end of program: the rest of the file is not read) and M98/M99
//    (error). An address twice in one block is an error.
//  - G0 G1 G2 G3 (modal; an axis word before any of them is an error), G17/G18/G19 planes
//    (arcs turn in (X,Y), (Z,X), (Y,Z); G3 is counter-clockwise seen from the plane normal +Z,
//    +Y, +X), G20/G21 inch/mm (lengths and F), G90/G91 absolute/incremental (X Y Z A B C; arc
//    centres I J K are always incremental from the start point), G93/G94 inverse-time (F in 1/min,
//    needed in every G1/G2/G3 block, stored as inverse_time_feed_per_s; an arc tessellated into
//    n segments gives each n*F) / per-minute feed, F modal under G94 and > 0.
//  - Arcs: I J K (centre offset) or R (R < 0: the arc of more than 180 deg); I J K with the end
//    point equal to the start: a full circle (R cannot program one); motion along the plane
//    normal makes a helix. Tessellated into MotionKind::arc points with chord error (in the arc
//    plane) <= ReaderOptions::arc_chord_tolerance_m; the last point is the programmed end point.
//    Start and end radii differing by more than max(1e-3 mm, 1e-6 r) is an error naming the
//    block. An arc as the very first motion (unknown start) is an error. G2/G3 cannot change the
//    tool orientation.
//  - Before the first motion, an axis not yet programmed is taken as 0, with a warning.
//  - Tool-centre-point programming (X Y Z are the tool tip in W): Fanuc G43.4 (tool axis from
//    rotary words A B C through ReaderOptions::rotary_words_to_tool_axis), G43.5 (tool vector
//    I J K on G0/G1 blocks), G49 cancels; Siemens TRAORI (tool vector A3= B3= C3=, or rotary
//    words through rotary_words_to_tool_axis), TRAFOOF cancels. In a tool vector, a component
//    left out of a block that gives another is 0; a block giving none keeps the current axis.
//    Rotary words without the callback are an error that says a machine is needed.
//  - Outside tool-centre-point mode: with ReaderOptions::axis_words_to_pose every point (arc
//    points too) is the pose of the modal machine axes X Y Z [A B C]; without it, X Y Z are the
//    tool tip and the axis is +Z (a 3-axis program); a rotary word, or a motion after a tilted
//    TCP axis, is then an error that says a machine is needed.
//  - Rotary words through a machine (axis words, or G43.4 / TRAORI A B C): each point carries the
//    words in force (PathPoint::rotary_words_deg), and a point whose words differ from the
//    previous one's is kept even where its pose is the same (C0 -> C360 is a real turn). A G0/G1
//    block that turns a word by 180 deg or more is split into equal steps of at most 90 deg in
//    axis space (as the NC interpolates the axes), since the chain follows poses and the inverse
//    kinematics takes the nearest solution from one pose to the next.
//  - Accepted and ignored: G4 dwell (with X or P), G40 G43 G49 G80 G15 G50 G69 G9 G61 G61.1
//    G64 [P] G98 G99, G54-G59 (taken as placing the workpiece frame W; offsets not applied).
//    Errors naming the word: G41/G42 cutter compensation, G68 rotation, G51 scaling, G52 G53
//    G54.1 G92 coordinate changes, G28-G30 reference returns, G16 polar, canned cycles
//    (G73 G74 G76 G81-G89), any other G-code, and words outside this list (U V W Q L E, P
//    elsewhere, Siemens keywords other than TRAORI/TRAFOOF).
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <limits>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace vmsim::toolpath {

/// One source block (a line of G-code, or an APT record with its `$` continuations). Only the
/// blocks that program a motion are listed.
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
  /// Programmed feed for the motion that ends here [m/s]; 0 for rapids and under G93.
  double feed_m_per_s = 0.0;
  /// G93 inverse-time feed [1/s] for this motion, where programmed (feed_m_per_s is then 0).
  double inverse_time_feed_per_s = 0.0;
  int block = -1;  ///< index into Toolpath::blocks of the block that programmed this motion
  /// The rotary axis words A B C [deg] in force here where the program gives machine axes
  /// (G-code axis words through ReaderOptions::axis_words_to_pose, or G43.4 / TRAORI rotary
  /// words); NaN where not programmed. Two points with the same pose but different words are
  /// different machine positions (a 360 deg turn of C), never merged.
  static constexpr double kNotProgrammed = std::numeric_limits<double>::quiet_NaN();
  std::array<double, 3> rotary_words_deg = {kNotProgrammed, kNotProgrammed, kNotProgrammed};
  /// The tool (T number, made active by M6) in the spindle for this motion; -1 where the program
  /// selects none (the part file's tool is meant).
  int tool_number = -1;
  /// What the program asks at the corner where this motion ends [m]: 0 = exact stop (G61, G9),
  /// > 0 = blending within this tolerance (G64 P, high-precision contouring G5.1 / G05 P10000 /
  /// G187 with its tolerance); NaN where the program says nothing (the part file or the command
  /// line decides).
  double corner_tolerance_m = kNotProgrammed;
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
  /// Expansion limits, checked before the points are made: the points one block may expand to
  /// (an arc's tessellation, a long rotary turn's steps), and the points of the whole path. A
  /// path point costs about 100 bytes in the reader and about 1 kB further down the chain (axis
  /// positions and their derivatives, the planner's grid, set points): 2 million points is about
  /// 2 GB, as much as a simulation on an ordinary workstation should take.
  std::size_t max_points_per_block = 1'000'000;
  std::size_t max_path_points = 2'000'000;
};

/// Reads an APT/CL file (subset above). Throws vmsim::InputError naming the file, line, column
/// and word, also when the file cannot be read or programs no motion.
Toolpath read_apt(const std::string& path, const ReaderOptions& options = {});
Toolpath parse_apt(const std::string& text, const std::string& file_name_for_messages,
                   const ReaderOptions& options = {});

/// Reads an ISO G-code file (Fanuc / Siemens dialect subset above). Throws vmsim::InputError
/// naming the file, line, column and word; also when arc_chord_tolerance_m is not positive.
Toolpath read_gcode(const std::string& path, const ReaderOptions& options = {});
Toolpath parse_gcode(const std::string& text, const std::string& file_name_for_messages,
                     const ReaderOptions& options = {});

/// Picks the reader by extension: .apt .cl .cls -> APT; .nc .ngc .gcode .mpf .tap .iso -> G-code.
Toolpath read_toolpath(const std::string& path, const ReaderOptions& options = {});

}  // namespace vmsim::toolpath
