// generate_parts: writes vmsim's sample parts, one folder each with toolpath.apt (APT/CL, mm) and
// part.yaml (tool, stock, analytic design surface, feeds). The output is deterministic: the same
// bytes on every run, so the generated files are checked in and a test regenerates and compares.
//
//   <build>/samples/generate_parts samples/parts
//
// The parts follow the test parts of the second paper (Section 4, test parts 1-3) and the test
// paths of the first paper (Fig. 2, test paths 1 and 2); samples/parts/README.md describes them.
// Frame: workpiece frame W, origin at the centre of the rotary table top, z up, millimetres.
// A CL point is the tool tip; the tool axis (i,j,k) is the unit vector from the tip to the spindle.

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using Eigen::Vector3d;

constexpr double kPi = std::numbers::pi;
constexpr double kDegree = kPi / 180.0;

// ---------------------------------------------------------------------------------------------
// Tool paths and their APT text

struct ClPoint {
  Vector3d tip_W_mm = Vector3d::Zero();   //!< tool tip in W [mm]
  Vector3d axis_W = Vector3d::UnitZ();    //!< unit tool axis, tip towards spindle
};

struct Move {
  bool rapid = false;  //!< positioning move (APT RAPID before the GOTO)
  ClPoint cl;
};

struct ToolPath {
  std::string partno;
  double cutter_diameter_mm = 10.0;
  double cutter_corner_radius_mm = 5.0;
  bool five_axis = false;  //!< MULTAX: GOTO carries x,y,z,i,j,k
  double feed_mm_per_min = 10000.0;
  ClPoint from;
  std::vector<Move> moves;

  void rapid(const ClPoint& cl) { moves.push_back({true, cl}); }
  void feed(const ClPoint& cl) { moves.push_back({false, cl}); }
};

struct PartFiles {
  std::string name;
  std::string apt;
  std::string yaml;
  std::string summary;  //!< one line for the terminal
  std::string stock_stl;  //!< binary STL bytes of a near-net stock (stock.stl), or empty
};

/// Fixed notation with 6 decimals, without a negative zero.
std::string fixed6(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.6f", value);
  std::string text(buffer);
  if (text == "-0.000000") text = "0.000000";
  return text;
}

/// A YAML number: 12 significant digits (far below the 1e-6 mm of the APT files), without a
/// negative zero, so that 7.499999999999999 reads 7.5.
std::string num(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.12g", value);
  std::string text(buffer);
  if (text == "-0") text = "0";
  return text;
}

std::string vec(const Vector3d& v) {
  return "[" + num(v.x()) + ", " + num(v.y()) + ", " + num(v.z()) + "]";
}

// The shortest decimal text of a value given to a few digits (-5, 0.25, 500).
std::string num_short(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

std::string range(double low, double high) { return "[" + num(low) + ", " + num(high) + "]"; }

std::string cl_numbers(const ClPoint& cl, bool with_axis) {
  std::string text = fixed6(cl.tip_W_mm.x()) + "," + fixed6(cl.tip_W_mm.y()) + "," +
                     fixed6(cl.tip_W_mm.z());
  if (with_axis) {
    text += "," + fixed6(cl.axis_W.x()) + "," + fixed6(cl.axis_W.y()) + "," +
            fixed6(cl.axis_W.z());
  }
  return text;
}

std::string apt_text(const ToolPath& path) {
  std::string text;
  text += "PARTNO/" + path.partno + "\n";
  text += "UNITS/MM\n";
  text += "CUTTER/" + fixed6(path.cutter_diameter_mm) + "," +
          fixed6(path.cutter_corner_radius_mm) + "\n";
  if (path.five_axis) text += "MULTAX\n";
  text += "FEDRAT/MMPM," + fixed6(path.feed_mm_per_min) + "\n";
  text += "FROM/" + cl_numbers(path.from, true) + "\n";
  for (const Move& move : path.moves) {
    if (move.rapid) text += "RAPID\n";
    text += "GOTO/" + cl_numbers(move.cl, path.five_axis) + "\n";
  }
  text += "FINI\n";
  return text;
}

std::size_t goto_count(const ToolPath& path) { return path.moves.size(); }

/// Length of the cutting (non-rapid) moves of the tip [mm].
double cutting_length_mm(const ToolPath& path) {
  double length = 0.0;
  for (std::size_t i = 1; i < path.moves.size(); ++i) {
    if (!path.moves[i].rapid) {
      length += (path.moves[i].cl.tip_W_mm - path.moves[i - 1].cl.tip_W_mm).norm();
    }
  }
  return length;
}

/// Parameters t in [0, 1] of points of the curve c equally spaced in arc length, at most
/// max_step_mm apart, both ends included (as a CAM system discretises a smooth curve).
std::vector<double> equal_arc_parameters(const std::function<Vector3d(double)>& curve,
                                         double max_step_mm) {
  constexpr int kFine = 200000;
  std::vector<double> s(kFine + 1, 0.0);
  Vector3d previous = curve(0.0);
  for (int i = 1; i <= kFine; ++i) {
    const Vector3d p = curve(static_cast<double>(i) / kFine);
    s[static_cast<std::size_t>(i)] = s[static_cast<std::size_t>(i - 1)] + (p - previous).norm();
    previous = p;
  }
  const double total = s.back();
  const int n = static_cast<int>(std::ceil(total / max_step_mm - 1e-9));
  std::vector<double> t{0.0};
  std::size_t i = 0;
  for (int k = 1; k < n; ++k) {
    const double target = total * k / n;
    while (s[i + 1] < target) ++i;
    const double fraction = (target - s[i]) / (s[i + 1] - s[i]);
    t.push_back((static_cast<double>(i) + fraction) / kFine);
  }
  t.push_back(1.0);
  return t;
}

/// Curve parameters at N equal steps (N = ceil(length / max_step)), both ends included.
std::vector<double> equal_steps(double length_mm, double max_step_mm) {
  const int n = std::max(1, static_cast<int>(std::ceil(length_mm / max_step_mm - 1e-9)));
  std::vector<double> t;
  for (int k = 0; k <= n; ++k) t.push_back(static_cast<double>(k) / n);
  return t;
}

const char* const kRegenerate =
    "# Regenerate (from the source tree): <build>/samples/generate_parts samples/parts\n";
const char* const kMachine = "machine: ../../machines/mikron_ucp710.yaml\n";

std::string feeds_yaml(double production, double reference) {
  return "feeds: {production_mm_per_min: " + num(production) +
         ", reference_mm_per_min: " + num(reference) + "}\n";
}

std::string stock_yaml(const Vector3d& min_mm, const Vector3d& max_mm) {
  return "stock: {box: {min_mm: " + vec(min_mm) + ", max_mm: " + vec(max_mm) + "}}\n";
}

std::string summary(const std::string& name, const ToolPath& path, const std::string& extra) {
  std::ostringstream out;
  out << name << ": " << goto_count(path) << " GOTOs, cutting length "
      << fixed6(cutting_length_mm(path)) << " mm" << extra;
  return out.str();
}

// ---------------------------------------------------------------------------------------------
// Part 1: two planes joined in tangency by a concave cylinder (second paper, test part 1)

// `width_mm` other than 10: the same profile swept over that width in y (a die-sized part for
// the scaling benchmark, bench/scaling.py), passes 0.25 mm apart over the whole width.
PartFiles part1_tangency(double width_mm = 10.0) {
  // Profile in the XZ plane, extruded along y: plane z = 20 for x <= 0, a concave cylinder
  // (axis along y through x = 0, z = 35, radius 15) from x = 0 to the tangency with the plane
  // inclined 30 degrees, which rises from x = 7.5 mm.
  const bool die = width_mm != 10.0;
  const double z_floor = 20.0;
  const double fillet_radius = 15.0;
  const double slope = 30.0 * kDegree;
  const double ball_radius = 5.0;
  const double x_start = -46.0;  // contact point at the start of a pass (tool clear of the stock)
  const double x_end = 42.0;     // contact point at the end (tool above the stock top)
  const double y_first = -0.5 * width_mm;
  const double stepover = 0.25;
  const int passes = static_cast<int>(std::lround(width_mm / stepover)) + 1;  // part 1: 41, y = -5 ... 5
  const double point_step = 0.2;
  const double z_safe = 50.0;

  const Vector3d axis_point(0.0, 0.0, z_floor + fillet_radius);  // y is free
  const Vector3d tangency2 = axis_point + fillet_radius * Vector3d(std::sin(slope), 0.0,
                                                                   -std::cos(slope));
  const Vector3d incline_normal(-std::sin(slope), 0.0, std::cos(slope));
  const Vector3d incline_direction(std::cos(slope), 0.0, std::sin(slope));
  const double incline_length = (x_end - tangency2.x()) / std::cos(slope);

  // The ball centre path in one XZ plane (y = 0), three pieces, each with equal steps.
  std::vector<Vector3d> centres;
  for (double t : equal_steps(-x_start, point_step)) {
    centres.emplace_back(x_start * (1.0 - t), 0.0, z_floor + ball_radius);
  }
  const double offset_radius = fillet_radius - ball_radius;
  for (double t : equal_steps(offset_radius * slope, point_step)) {
    if (t == 0.0) continue;
    const double angle = slope * t;
    centres.push_back(axis_point +
                      offset_radius * Vector3d(std::sin(angle), 0.0, -std::cos(angle)));
  }
  for (double t : equal_steps(incline_length, point_step)) {
    if (t == 0.0) continue;
    centres.push_back(tangency2 + incline_length * t * incline_direction +
                      ball_radius * incline_normal);
  }

  ToolPath path;
  path.partno = die ? "DIE_PART1" : "PART1_TANGENCY";
  path.cutter_diameter_mm = 2.0 * ball_radius;
  path.cutter_corner_radius_mm = ball_radius;
  path.from.tip_W_mm = Vector3d(0.0, 0.0, 100.0);
  for (int k = 0; k < passes; ++k) {
    const Vector3d shift(0.0, y_first + stepover * k, -ball_radius);
    const Vector3d first = centres.front() + shift;
    const Vector3d last = centres.back() + shift;
    path.rapid({Vector3d(first.x(), first.y(), z_safe), Vector3d::UnitZ()});
    for (const Vector3d& centre : centres) path.feed({centre + shift, Vector3d::UnitZ()});
    path.rapid({Vector3d(last.x(), last.y(), z_safe), Vector3d::UnitZ()});
  }

  const double y_last = y_first + stepover * (passes - 1);
  const std::string name = die ? "die_part1_" + num_short(width_mm) + "mm" : "part1_tangency";
  std::string yaml;
  if (die) {
    yaml += "# Die-sized part 1 for the scaling benchmark (bench/scaling.py): sample part 1's profile\n"
            "# swept over " + num_short(width_mm) + " mm in y, one-way XZ passes 0.25 mm apart, ball-end D10.\n"
            "# Regenerate: <build>/samples/generate_parts --die-width-mm " + num_short(width_mm) + " <folder>\n";
  } else {
    yaml += "# Sample part 1 (second paper, Section 4, test part 1, Fig. 6 and "
            R"(Fig. 8): two planes joined
# in tangency by a concave cylinder, finished by a ball-end mill D10 in one-way parallel XZ
# passes 0.25 mm apart, 3-axis. The tangency lines x = 0 and x = 7.5 mm are where the
# 10 m/min pass leaves a mark (about 0.02 mm deep in the paper); 0.1 m/min is the reference.
)";
    yaml += kRegenerate;
  }
  yaml += "name: " + name + "\n";
  yaml += "description: \"Plane z = 20 mm (x <= 0), concave cylinder R15 (axis along y at x = 0, "
          "z = 35), plane inclined 30 deg (x >= 7.5). " + std::to_string(passes) +
          " one-way passes in XZ planes y = " + num_short(y_first) + ".." + num_short(y_last) + " mm "
          "every 0.25 mm, each from contact x = -46 to 42 mm, tip points every 0.2 mm or less, "
          "feed plunge outside the stock, rapid retract to z = 50 and rapid return.\"\n";
  yaml += kMachine;
  yaml += "toolpath: toolpath.apt\n";
  yaml += "tool: {type: ball, diameter_mm: 10, corner_radius_mm: 5, length_mm: 60}\n";
  yaml += stock_yaml(Vector3d(-40.0, y_first, 0.0), Vector3d(40.0, y_last, 40.0));
  yaml += "design:\n";
  yaml += "  surfaces:\n";
  yaml += "    - {type: plane, point_mm: " + vec(Vector3d(0.0, 0.0, z_floor)) +
          ", normal: [0, 0, 1], x_range_mm: " + range(x_start, 0.0) +
          ", y_range_mm: " + range(y_first, y_last) + "}\n";
  yaml += "    - {type: cylinder, axis_point_mm: " + vec(axis_point) +
          ", axis_direction: [0, 1, 0], radius_mm: " + num(fillet_radius) +
          ", material: outside, x_range_mm: " + range(0.0, tangency2.x()) +
          ", y_range_mm: " + range(y_first, y_last) + "}\n";
  yaml += "    - {type: plane, point_mm: " + vec(tangency2) + ", normal: " + vec(incline_normal) +
          ", x_range_mm: " + range(tangency2.x(), x_end) +
          ", y_range_mm: " + range(y_first, y_last) + "}\n";
  yaml += "strategy: {kind: parallel_planes, plane: xz, direction: one_way, stepover_mm: " +
          num(stepover) + ", passes: " + std::to_string(passes) +
          ", point_step_max_mm: " + num(point_step) + ", safe_z_mm: " + num(z_safe) + "}\n";
  yaml += feeds_yaml(10000.0, 100.0);

  return {name, apt_text(path), yaml, summary(name, path, ""), ""};
}

// ---------------------------------------------------------------------------------------------
// Part 2: flank milling of an inside vertical corner (second paper, test part 2)

PartFiles part2_corner() {
  // Walls y = 20 (x <= 20) and x = 20 (y <= 20), material beyond them; a flat end mill D10
  // runs along both walls at a distance of its radius in one pass, tip at z = 20: 10 mm deep in
  // a stock 30 mm high. The corner of the path (15, 15) is a sharp G1 corner.
  const double tool_radius = 5.0;
  const double wall = 20.0;
  const double z_cut = 20.0;
  const double z_top = 30.0;
  const double z_safe = 50.0;
  const double outside = -50.0;  // start and end of the pass: tool clear of the stock (-40)
  const double c = wall - tool_radius;

  ToolPath path;
  path.partno = "PART2_CORNER";
  path.cutter_diameter_mm = 2.0 * tool_radius;
  path.cutter_corner_radius_mm = 0.0;
  path.from.tip_W_mm = Vector3d(0.0, 0.0, 100.0);
  path.rapid({Vector3d(outside, c, z_safe), Vector3d::UnitZ()});
  path.feed({Vector3d(outside, c, z_cut), Vector3d::UnitZ()});
  path.feed({Vector3d(c, c, z_cut), Vector3d::UnitZ()});
  path.feed({Vector3d(c, outside, z_cut), Vector3d::UnitZ()});
  path.rapid({Vector3d(c, outside, z_safe), Vector3d::UnitZ()});

  std::string yaml;
  yaml += "# Sample part 2 (second paper, Section 4, test part 2, Fig. 7 and "
          R"(Fig. 8): flank milling of an
# inside vertical corner by a flat end mill D10, 3-axis, one G1 pass with a sharp 90 deg corner,
# 10 mm deep. The paper machined the 10 mm deep reference at low feed, then the same path
# 5 mm higher at high feed; here the same path runs at both feeds (feeds below). The mark at
# the corner was about 0.03 mm at high feed and 0.005 mm at low feed.
)";
  yaml += kRegenerate;
  yaml += "name: part2_corner\n";
  yaml += "description: \"Walls y = 20 mm (for x <= 20) and x = 20 mm "
          "(for y <= 20) meeting at 90 deg "
          "at (20, 20), material beyond them. Tool centre line y = 15 from x = -50 to the corner "
          "(15, 15), then x = 15 down to y = -50, tip at z = 20 in a stock 30 mm high. The tool "
          "also cuts an L-shaped slot floor z = 20 mm; the island x < 10, y < 10 is left "
          "untouched.\"\n";
  yaml += kMachine;
  yaml += "toolpath: toolpath.apt\n";
  yaml += "tool: {type: flat, diameter_mm: 10, corner_radius_mm: 0, length_mm: 60}\n";
  yaml += stock_yaml(Vector3d(-40.0, -40.0, 0.0), Vector3d(40.0, 40.0, z_top));
  yaml += "design:\n";
  yaml += "  surfaces:\n";
  yaml += "    - {type: plane, point_mm: " + vec(Vector3d(0.0, wall, 0.0)) +
          ", normal: [0, -1, 0], x_range_mm: " + range(-40.0, wall) +
          ", z_range_mm: " + range(z_cut, z_top) + "}\n";
  yaml += "    - {type: plane, point_mm: " + vec(Vector3d(wall, 0.0, 0.0)) +
          ", normal: [-1, 0, 0], y_range_mm: " + range(-40.0, wall) +
          ", z_range_mm: " + range(z_cut, z_top) + "}\n";
  yaml += "    - {type: plane, point_mm: " + vec(Vector3d(0.0, 0.0, z_cut)) +
          ", normal: [0, 0, 1], x_range_mm: " + range(-40.0, wall) +
          ", y_range_mm: " + range(-40.0, wall) + ", role: floor}\n";
  yaml += "  corner_mm: " + vec(Vector3d(wall, wall, z_cut)) + "\n";
  yaml += "strategy: {kind: flank_pass, passes: 1, depth_mm: " + num(z_top - z_cut) +
          ", safe_z_mm: " + num(z_safe) + "}\n";
  yaml += feeds_yaml(10000.0, 100.0);

  return {"part2_corner", apt_text(path), yaml, summary("part2_corner", path, ""), ""};
}

// ---------------------------------------------------------------------------------------------
// Near-net stock: a closed triangle mesh written as binary STL

struct Mesh {
  std::vector<Eigen::Vector3f> vertices_mm;    //!< float, as STL stores them (shared exactly)
  std::vector<std::array<int, 3>> triangles;   //!< outward normals by the right-hand rule
};

/// Triangles between two rings of vertex indices (each ring ordered by increasing azimuth,
/// ring `a` nearer the z axis than ring `b`), the azimuths of both walked together (exact
/// integer comparison of i / n_a with j / n_b). `up`: normals towards +z (the cap), else -z (the
/// base). A ring of one vertex (pole, centre of the base) gives a fan.
void ring_strip(Mesh& mesh, const std::vector<int>& a, const std::vector<int>& b, bool up) {
  const std::size_t na = a.size();
  const std::size_t nb = b.size();
  std::size_t i = na == 1 ? 1 : 0;  // a single vertex: a fan, ring a has nothing to walk
  std::size_t j = 0;
  auto add = [&](int p, int q, int r) {
    mesh.triangles.push_back(up ? std::array<int, 3>{p, q, r} : std::array<int, 3>{p, r, q});
  };
  while (i < na || j < nb) {
    const bool advance_a = i < na && (j == nb || (i + 1) * nb <= (j + 1) * na);
    if (advance_a) {
      add(a[i], b[j % nb], a[(i + 1) % na]);
      ++i;
    } else {
      add(a[i % na], b[j], b[(j + 1) % nb]);
      ++j;
    }
  }
}

/// A dome: the half sphere z >= 0 of radius radius_mm centred at the origin, closed by the disc
/// z = 0. Rings of constant polar angle on the cap, each with as many vertices as keep its
/// edges within cap_edge_mm; rings of constant radius on the flat base, coarser (base_edge_mm);
/// the two meet at the equator ring.
Mesh dome_mesh(double radius_mm, double cap_edge_mm, double base_edge_mm) {
  Mesh mesh;
  const auto ring_size = [](double ring_radius_mm, double edge_mm) {
    return std::max(3, static_cast<int>(std::ceil(2.0 * kPi * ring_radius_mm / edge_mm)));
  };
  const auto add_ring = [&](int count, double ring_radius_mm, double z_mm) {
    std::vector<int> ring;
    for (int j = 0; j < count; ++j) {
      const double azimuth = 2.0 * kPi * j / count;
      ring.push_back(static_cast<int>(mesh.vertices_mm.size()));
      mesh.vertices_mm.emplace_back(static_cast<float>(ring_radius_mm * std::cos(azimuth)),
                                    static_cast<float>(ring_radius_mm * std::sin(azimuth)),
                                    static_cast<float>(z_mm));
    }
    return ring;
  };
  const int cap_rings = static_cast<int>(std::ceil(0.5 * kPi * radius_mm / cap_edge_mm));
  mesh.vertices_mm.emplace_back(0.0f, 0.0f, static_cast<float>(radius_mm));  // the pole
  std::vector<int> previous{0};
  for (int k = 1; k <= cap_rings; ++k) {
    const double polar = 0.5 * kPi * k / cap_rings;
    const double ring_radius = k == cap_rings ? radius_mm : radius_mm * std::sin(polar);
    const double z = k == cap_rings ? 0.0 : radius_mm * std::cos(polar);
    std::vector<int> ring = add_ring(ring_size(ring_radius, cap_edge_mm), ring_radius, z);
    ring_strip(mesh, previous, ring, true);
    previous = std::move(ring);
  }
  const std::vector<int> equator = previous;
  const int base_rings = static_cast<int>(std::ceil(radius_mm / base_edge_mm));
  mesh.vertices_mm.emplace_back(0.0f, 0.0f, 0.0f);  // the centre of the base
  previous = {static_cast<int>(mesh.vertices_mm.size()) - 1};
  for (int k = 1; k <= base_rings; ++k) {
    const double ring_radius = radius_mm * k / base_rings;
    std::vector<int> ring =
        k == base_rings ? equator : add_ring(ring_size(ring_radius, base_edge_mm), ring_radius, 0.0);
    ring_strip(mesh, previous, ring, false);
    previous = std::move(ring);
  }
  return mesh;
}

void append_le32(std::string& bytes, std::uint32_t value) {
  for (int shift = 0; shift < 32; shift += 8) bytes.push_back(static_cast<char>((value >> shift) & 0xffu));
}

void append_float(std::string& bytes, float value) {
  append_le32(bytes, std::bit_cast<std::uint32_t>(value));
}

/// Binary STL (little-endian, mm): an 80-byte header, the triangle count, then per triangle the
/// unit normal, the three corners and a zero attribute word.
std::string binary_stl(const Mesh& mesh, const std::string& header) {
  std::string bytes = header.substr(0, 80);
  bytes.resize(80, ' ');
  append_le32(bytes, static_cast<std::uint32_t>(mesh.triangles.size()));
  for (const auto& triangle : mesh.triangles) {
    const Eigen::Vector3f& p = mesh.vertices_mm[static_cast<std::size_t>(triangle[0])];
    const Eigen::Vector3f& q = mesh.vertices_mm[static_cast<std::size_t>(triangle[1])];
    const Eigen::Vector3f& r = mesh.vertices_mm[static_cast<std::size_t>(triangle[2])];
    const Eigen::Vector3f normal = (q - p).cross(r - p).normalized();
    for (const Eigen::Vector3f* v : {&normal, &p, &q, &r}) {
      for (int c = 0; c < 3; ++c) append_float(bytes, (*v)[c]);
    }
    bytes.push_back('\0');
    bytes.push_back('\0');
  }
  return bytes;
}

// ---------------------------------------------------------------------------------------------
// Part 3: 5-axis spiral on a dome, tool normal to the surface (second paper, test part 3)

PartFiles part3_five_axis() {
  // Sphere of radius 40 centred at the table centre (a dome 40 mm high); the tool follows a
  // spiral from 20 to 60 degrees from the pole in 10 turns, ball-end D10 normal to the sphere:
  // the tool axis tilts from 20 to 60 degrees (A) while it turns through 3600 degrees (C).
  const double sphere_radius = 40.0;
  const Vector3d centre = Vector3d::Zero();
  const double polar_first = 20.0 * kDegree;
  const double polar_last = 60.0 * kDegree;
  const double turns = 10.0;
  const double point_step = 0.5;
  const double retract = 20.0;
  const double clearance = 80.0;  // along the normal, where the tool axis turns
  // Start at azimuth 180 deg: from A = C = 0 the inverse kinematics then takes the branch with
  // A < 0 (the Mikron's A travels -120..+30 deg), which holds the whole 20..60 deg tilt; from
  // azimuth 0 it took A > 0 and had to flip branch (A to -A, C by 180 deg) on the spot at 30 deg.
  const double azimuth_first = -0.5 * kPi;
  // Near-net stock: the dome offset by a finishing allowance (the full 80 x 80 x 40 mm box made
  // the tilted tool and its shank sweep through uncut material all along the spiral: a collision
  // on a machine, and minutes of removal). Cap facets at most 0.8 mm long stay within a few um
  // of the offset sphere, far below the allowance (tests/samples checks it).
  const double allowance = 0.3;
  const double stock_max_edge = 0.8;
  const double stock_base_edge = 8.0;  // the flat base needs no fine facets

  const auto normal = [&](double t) {
    const double polar = polar_first + (polar_last - polar_first) * t;
    const double azimuth = azimuth_first + 2.0 * kPi * turns * t;
    return Vector3d(std::sin(polar) * std::cos(azimuth), std::sin(polar) * std::sin(azimuth),
                    std::cos(polar));
  };
  const auto contact = [&](double t) -> Vector3d { return centre + sphere_radius * normal(t); };

  ToolPath path;
  path.partno = "PART3_FIVE_AXIS";
  path.five_axis = true;
  path.from.tip_W_mm = Vector3d(0.0, 0.0, 100.0);
  const std::vector<double> ts = equal_arc_parameters(contact, point_step);
  // Ball-end normal to the surface: the tip is the contact point.
  // The tool turns from +z to the start orientation far above the dome: rapids move the axes
  // jointly, so the tip does not go straight in W while A and C turn (from FROM straight to the
  // approach point it would sweep through the dome), then it comes down the normal.
  path.rapid({contact(0.0) + clearance * normal(0.0), normal(0.0)});
  path.rapid({contact(0.0) + retract * normal(0.0), normal(0.0)});
  for (double t : ts) path.feed({contact(t), normal(t)});
  path.rapid({contact(1.0) + retract * normal(1.0), normal(1.0)});

  std::string yaml;
  yaml += "# Sample part 3 (second paper, Section 4, test part 3): a smooth "
          R"(5-axis path with large A and
# C motions, ball-end D10 normal to a dome: the tilt goes from 20 to 60 deg while the tool axis
# turns through 10 revolutions. The paper found rotary follow-up deviations of about 0.001 deg
# and no visible marks, the rotary axes being slow.
)";
  yaml += kRegenerate;
  yaml += "name: part3_five_axis\n";
  yaml += "description: \"Sphere R40 centred at the origin of W (dome "
          "40 mm high). Spiral on it from "
          "20 to 60 deg from the pole in 10 turns (pitch about 2.8 mm), polar angle linear in the "
          "azimuth, tip points every 0.5 mm or less, tool axis along the sphere normal (the tip is "
          "the contact point). Rapid to 80 mm above the start point along the normal (the tool axis "
          "turns there), rapid approach and retract 20 mm along the axis.\"\n";
  yaml += kMachine;
  yaml += "toolpath: toolpath.apt\n";
  // The removal sweeps only the ball (cutting_length_mm = D): normal to the convex dome, the
  // shank stays outside the offset sphere, and a longer body only costs orientation sub-steps.
  yaml += "tool: {type: ball, diameter_mm: 10, corner_radius_mm: 5, length_mm: 60, cutting_length_mm: 10}\n";
  yaml += "# Stock: the dome offset by the allowance, closed by the disc z = 0 (cap facets at most " +
          num(stock_max_edge) + " mm).\n";
  yaml += "stock: {stl: stock.stl, allowance_mm: " + num(allowance) + "}\n";
  yaml += "design:\n";
  yaml += "  surfaces:\n";
  yaml += "    - {type: sphere, center_mm: " + vec(centre) + ", radius_mm: " + num(sphere_radius) +
          ", material: inside, z_range_mm: " + range(0.0, sphere_radius) + "}\n";
  yaml += "strategy: {kind: spiral, polar_deg: [20, 60], turns: " + num(turns) +
          ", point_step_max_mm: " + num(point_step) + ", tool_axis: surface_normal}\n";
  yaml += feeds_yaml(10000.0, 100.0);

  const Mesh stock = dome_mesh(sphere_radius + allowance, stock_max_edge, stock_base_edge);
  return {"part3_five_axis", apt_text(path), yaml,
          summary("part3_five_axis", path,
                  ", stock.stl " + std::to_string(stock.triangles.size()) + " triangles"),
          binary_stl(stock, "vmsim sample part3_five_axis: near-net stock, dome R" +
                                num(sphere_radius + allowance) + " mm + disc z = 0, mm")};
}

// ---------------------------------------------------------------------------------------------
// Path 1: a path in the yz plane with a changing tool orientation (first paper, test path 1)

PartFiles path1_yz() {
  // Surface z = 42.5 + 6 sin(2 pi (y + 10) / 80), extruded along x; one pass along x = 0 from
  // y = -10 to 82, ball-end normal to the surface: the axis tilts in the yz plane
  // within +-25.2 deg.
  const double z0 = 42.5;
  // 6 mm keeps the tilt within +-25.2 deg: the Mikron sample's A travel ends at +30 deg, and a
  // path that needs both +-30.5 deg would force a flip of the IKT branch (A sign, C + 180).
  const double amplitude = 6.0;
  const double wavelength = 80.0;
  const double y_phase = -10.0;
  const double y_first = -10.0;
  const double y_last = 82.0;
  const double point_step = 0.2;
  const double retract = 20.0;
  const double k = 2.0 * kPi / wavelength;

  const auto y_of = [&](double t) { return y_first + (y_last - y_first) * t; };
  const auto contact = [&](double t) -> Vector3d {
    const double y = y_of(t);
    return {0.0, y, z0 + amplitude * std::sin(k * (y - y_phase))};
  };
  const auto normal = [&](double t) -> Vector3d {
    const double slope = amplitude * k * std::cos(k * (y_of(t) - y_phase));
    return Vector3d(0.0, -slope, 1.0).normalized();
  };

  ToolPath path;
  path.partno = "PATH1_YZ";
  path.five_axis = true;
  path.from.tip_W_mm = Vector3d(0.0, 0.0, 100.0);
  path.rapid({contact(0.0) + retract * normal(0.0), normal(0.0)});
  for (double t : equal_arc_parameters(contact, point_step)) path.feed({contact(t), normal(t)});
  path.rapid({contact(1.0) + retract * normal(1.0), normal(1.0)});

  std::string yaml;
  yaml += "# Sample path 1 (first paper, Fig. 2, test path 1): a path in the yz "
          R"(plane, about 0.1 m long,
# with a smoothly changing tool orientation in that plane (tilt within +-25.2 deg), ball-end
# D10 normal to a wavy surface: only Y, Z and A move. The paper compares its kinematic and
# torque-limited feedrate profiles (Fig. 3) on it.
)";
  yaml += kRegenerate;
  yaml += "name: path1_yz\n";
  yaml += "description: \"Surface z = 42.5 + 6 sin(2 pi (y + 10) / "
          "80) mm, extruded along x. One pass "
          "at x = 0 from y = -10 to 82 mm, tip points every 0.2 mm or "
          "less in arc length, tool axis "
          "along the surface normal (the tip is the contact point), rapid approach and retract "
          "20 mm along the axis.\"\n";
  yaml += kMachine;
  yaml += "toolpath: toolpath.apt\n";
  yaml += "tool: {type: ball, diameter_mm: 10, corner_radius_mm: 5, length_mm: 60}\n";
  yaml += stock_yaml(Vector3d(-10.0, -15.0, 0.0), Vector3d(10.0, 87.0, 50.0));
  yaml += "design:\n";
  yaml += "  surfaces:\n";
  yaml += "    - {type: sine_height_y, z0_mm: " + num(z0) + ", amplitude_mm: " + num(amplitude) +
          ", wavelength_mm: " + num(wavelength) + ", y_phase_mm: " + num(y_phase) +
          ", x_range_mm: " + range(-10.0, 10.0) + ", y_range_mm: " + range(-15.0, 87.0) + "}\n";
  yaml += "strategy: {kind: single_pass, x_mm: 0, y_range_mm: " + range(y_first, y_last) +
          ", point_step_max_mm: " + num(point_step) + ", tool_axis: surface_normal}\n";
  yaml += feeds_yaml(10000.0, 100.0);

  return {"path1_yz", apt_text(path), yaml, summary("path1_yz", path, ""), ""};
}

// ---------------------------------------------------------------------------------------------
// Path 2: a blade-like surface, near the singularity of the IKT (first paper, test path 2)

PartFiles path2_blade() {
  // Height field z = z0 + (hxx x^2 + 2 hxy x y + hyy y^2) / 2: curved both ways and twisted
  // (hxy), normal +z only at the origin. The pass follows y = y0 + c x^2 in plan; passing
  // y0 = 1.5 mm from the origin, the tool axis comes within about 1.06 deg of +z (the C axis of
  // a table-table machine): C must turn through about 150 deg within about 8 mm of path.
  const double z0 = 30.0;
  const double hxx = -0.008;
  const double hxy = 0.015;
  const double hyy = -0.002;
  const double y0 = 1.5;
  const double c = 0.002;
  const double s_singular = 40.0;  // arc length at which the tilt is smallest [mm]
  const double length_after = 50.0;
  const double point_step = 0.2;
  const double retract = 20.0;

  const auto height = [&](double x, double y) {
    return z0 + 0.5 * (hxx * x * x + 2.0 * hxy * x * y + hyy * y * y);
  };
  const auto on_path = [&](double x) -> Vector3d {
    const double y = y0 + c * x * x;
    return {x, y, height(x, y)};
  };
  const auto normal_at = [&](const Vector3d& p) -> Vector3d {
    const double fx = hxx * p.x() + hxy * p.y();
    const double fy = hxy * p.x() + hyy * p.y();
    return Vector3d(-fx, -fy, 1.0).normalized();
  };
  const auto tilt = [&](double x) { return std::acos(normal_at(on_path(x)).z()); };
  const auto arc = [&](double x_a, double x_b) {  // arc length along the path [mm]
    constexpr int kSteps = 20000;
    double length = 0.0;
    for (int i = 0; i < kSteps; ++i) {
      const double xa = x_a + (x_b - x_a) * i / kSteps;
      const double xb = x_a + (x_b - x_a) * (i + 1) / kSteps;
      length += (on_path(xb) - on_path(xa)).norm();
    }
    return length;
  };

  // The x of the smallest tilt (golden section), then the start x so that it is at s = 40 mm,
  // and the end x 50 mm further along.
  double lo = -20.0;
  double hi = 20.0;
  const double golden = (std::sqrt(5.0) - 1.0) / 2.0;
  for (int i = 0; i < 200; ++i) {
    const double a = hi - golden * (hi - lo);
    const double b = lo + golden * (hi - lo);
    if (tilt(a) < tilt(b)) hi = b; else lo = a;
  }
  const double x_singular = 0.5 * (lo + hi);
  const auto solve_x = [&](double x_from, double wanted, double direction) {
    double near = 0.0;
    double far = 100.0;
    for (int i = 0; i < 100; ++i) {
      const double mid = 0.5 * (near + far);
      const double length = direction > 0.0 ? arc(x_from, x_from + mid) : arc(x_from - mid, x_from);
      if (length < wanted) near = mid; else far = mid;
    }
    return x_from + direction * 0.5 * (near + far);
  };
  const double x_first = solve_x(x_singular, s_singular, -1.0);
  const double x_last = solve_x(x_singular, length_after, +1.0);

  const auto contact = [&](double t) { return on_path(x_first + (x_last - x_first) * t); };

  ToolPath path;
  path.partno = "PATH2_BLADE";
  path.five_axis = true;
  path.from.tip_W_mm = Vector3d(0.0, 0.0, 100.0);
  const Vector3d start = contact(0.0);
  const Vector3d end = contact(1.0);
  path.rapid({start + retract * normal_at(start), normal_at(start)});
  for (double t : equal_arc_parameters(contact, point_step)) {
    const Vector3d p = contact(t);
    path.feed({p, normal_at(p)});
  }
  path.rapid({end + retract * normal_at(end), normal_at(end)});

  const double min_tilt_deg = tilt(x_singular) / kDegree;
  char extra[160];
  std::snprintf(extra, sizeof extra, ", x from %.6f to %.6f, smallest tilt %.6f deg at x = %.6f",
                x_first, x_last, min_tilt_deg, x_singular);

  std::string yaml;
  yaml += "# Sample path 2 (like the first paper's test path 2, Fig. 2): a "
          R"(5-axis ball-end pass on a
# blade-like surface (curved both ways and twisted), tool normal to the surface, passing close
# to the singularity of the table-table inverse kinematics: the tool axis comes within about
# 1.06 deg of +z (the C axis) at s = 40 mm; the axis swings by about 150 deg about z from
# s = 36 to 44 mm, which asks the C axis for a fast rotation.
)";
  yaml += kRegenerate;
  yaml += "name: path2_blade\n";
  yaml += "description: \"Height field z = z0 + (hxx x^2 + 2 hxy x y + hyy y^2) / 2 (curved and "
          "twisted), z0 = " + num(z0) + " mm, hxx = " + num(hxx) + ", hxy = " + num(hxy) +
          ", hyy = " + num(hyy) + " per mm. One pass along y = " + num(y0) +
          " + " + num(c) + " x^2 in plan, 90 mm long, the smallest tilt from +z at arc length "
          "s = 40 mm from the first cutting point; tip points every 0.2 mm or less, tool axis "
          "along the surface normal (the tip is the contact point), rapid approach and retract "
          "20 mm along the axis.\"\n";
  yaml += kMachine;
  yaml += "toolpath: toolpath.apt\n";
  yaml += "tool: {type: ball, diameter_mm: 10, corner_radius_mm: 5, length_mm: 60}\n";
  yaml += stock_yaml(Vector3d(-50.0, -20.0, 0.0), Vector3d(50.0, 20.0, 32.0));
  yaml += "design:\n";
  yaml += "  surfaces:\n";
  yaml += "    - {type: quadratic_height, z0_mm: " + num(z0) + ", hxx_per_mm: " + num(hxx) +
          ", hxy_per_mm: " + num(hxy) + ", hyy_per_mm: " + num(hyy) +
          ", x_range_mm: " + range(-55.0, 55.0) + ", y_range_mm: " + range(-20.0, 20.0) + "}\n";
  yaml += "strategy: {kind: single_pass, plan_curve: {y0_mm: " + num(y0) + ", c_per_mm: " + num(c) +
          "}, x_range_mm: " + range(x_first, x_last) + ", near_singularity_s_mm: " +
          num(s_singular) + ", point_step_max_mm: " + num(point_step) +
          ", tool_axis: surface_normal}\n";
  yaml += feeds_yaml(10000.0, 100.0);

  return {"path2_blade", apt_text(path), yaml, summary("path2_blade", path, extra), ""};
}

// ---------------------------------------------------------------------------------------------
// Mould: a cavity with draft walls, fillets and a free-form floor, raster finished (issue 22)

PartFiles mould_cavity() {
  // A cavity across the block (a runner- or channel-type mould cavity, open at both y ends),
  // profile in XZ extruded along y, symmetric about x = 0. From the centre outwards:
  // a free-form (parabolic) floor z = 12 - 0.005 x^2, a concave fillet R6, a wall with 10 deg
  // draft whose sharp edge with the land would be at (30, 30), a convex round R2, the land
  // z = 30 (1 mm under the stock top). Every piece is tangent to the next, so a ball-end D10
  // (radius 5 < 6) touches one point at a time and its centre path is the profile offset by 5.
  // The fillet's arc passes through its lowest point (the floor slopes down towards the wall), so
  // its z range starts there. Zig-zag raster: passes along x at y = -15 ... 15 every 0.5 mm, the stepover a short feed
  // move outside the stock. At 10 m/min every pass crosses ten curvature changes (land-round,
  // round-wall, wall-fillet, fillet-floor, both sides) and turns round twice: a mould's many
  // tangency zones and corners.
  const double ball_radius = 5.0;
  const double z_land = 30.0;
  const double z_stock_top = 31.0;
  const double edge_x = 30.0;  // the wall's sharp edge with the land, before the round [mm]
  const double draft = 10.0 * kDegree;
  const double round_radius = 2.0;
  const double fillet_radius = 6.0;
  const double floor_z0 = 12.0;
  const double floor_hxx = -0.01;  // per mm: z = z0 + hxx x^2 / 2 (a bulge, convex)
  const double x_outside = 46.0;   // contact x at the ends of a pass (ball clear of x = 40)
  const double stock_half_x = 40.0;
  const double y_first = -15.0;
  const double y_last = 15.0;
  const double stepover = 0.5;
  const double point_step = 0.2;
  const double z_safe = 50.0;
  const int passes = static_cast<int>(std::lround((y_last - y_first) / stepover)) + 1;

  // Right half (x >= 0); the left half is its mirror image in x = 0.
  const Vector3d edge(edge_x, 0.0, z_land);
  const Vector3d wall_normal(-std::cos(draft), 0.0, std::sin(draft));  // out of the material
  const auto floor_height = [&](double x) { return floor_z0 + 0.5 * floor_hxx * x * x; };
  const auto floor_normal = [&](double x) {
    return Vector3d(-floor_hxx * x, 0.0, 1.0).normalized();
  };
  const auto floor_point = [&](double x) { return Vector3d(x, 0.0, floor_height(x)); };
  // Round: centre 2 mm under the land and 2 mm inside the wall.
  const Vector3d round_centre(edge_x + round_radius * (1.0 - std::sin(draft)) / std::cos(draft),
                              0.0, z_land - round_radius);
  const Vector3d round_to_wall = round_centre + round_radius * wall_normal;  // tangency point
  // Fillet: centre 6 mm off the floor along its normal and 6 mm off the wall (bisection on the
  // floor's tangency x; the distance to the wall grows with x).
  const auto fillet_centre_at = [&](double x) {
    return Vector3d(floor_point(x) + fillet_radius * floor_normal(x));
  };
  double low = 0.0;
  double high = edge_x;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (low + high);
    const double to_wall = (fillet_centre_at(mid) - edge).dot(wall_normal);
    if (to_wall > fillet_radius) low = mid; else high = mid;
  }
  const double floor_end_x = 0.5 * (low + high);
  const Vector3d fillet_centre = fillet_centre_at(floor_end_x);
  const Vector3d fillet_to_wall = fillet_centre - fillet_radius * wall_normal;  // tangency point

  // The ball-centre path of the right half from x = 0 outwards, tip points at most point_step
  // apart on curved pieces; straight pieces (wall, land) are single moves, as CAM writes them.
  std::vector<Vector3d> centres;
  const auto floor_centre = [&](double t) {
    const double x = floor_end_x * t;
    return Vector3d(floor_point(x) + ball_radius * floor_normal(x));
  };
  for (double t : equal_arc_parameters(floor_centre, point_step)) centres.push_back(floor_centre(t));
  const auto arc = [&](const Vector3d& centre, double radius, const Vector3d& from,
                       const Vector3d& to) {  // unit directions in XZ, the short way round
    const double a0 = std::atan2(from.z(), from.x());
    double a1 = std::atan2(to.z(), to.x());
    if (a1 - a0 > kPi) a1 -= 2.0 * kPi;
    if (a0 - a1 > kPi) a1 += 2.0 * kPi;
    for (double t : equal_steps(std::abs(a1 - a0) * radius, point_step)) {
      if (t == 0.0) continue;
      const double a = a0 + (a1 - a0) * t;
      centres.push_back(centre + radius * Vector3d(std::cos(a), 0.0, std::sin(a)));
    }
  };
  // Fillet (concave): the ball centre on the circle of radius 6 - 5 about the fillet's axis.
  arc(fillet_centre, fillet_radius - ball_radius, Vector3d(-floor_normal(floor_end_x)),
      Vector3d(-wall_normal));
  // Wall: one straight move up to the round's tangency.
  centres.push_back(round_to_wall + ball_radius * wall_normal);
  // Round (convex): the centre on the circle of radius 2 + 5 about the round's axis.
  arc(round_centre, round_radius + ball_radius, wall_normal, Vector3d::UnitZ());
  // Land: one straight move out of the stock.
  centres.emplace_back(x_outside, 0.0, z_land + ball_radius);

  // A whole pass from x = -46 to 46: the mirror image of the right half reversed, then it.
  std::vector<Vector3d> pass;
  for (auto it = centres.rbegin(); it != centres.rend(); ++it) {
    pass.emplace_back(-it->x(), 0.0, it->z());
  }
  pass.insert(pass.end(), centres.begin() + 1, centres.end());  // x = 0 once

  ToolPath path;
  path.partno = "MOULD_CAVITY";
  path.cutter_diameter_mm = 2.0 * ball_radius;
  path.cutter_corner_radius_mm = ball_radius;
  path.from.tip_W_mm = Vector3d(0.0, 0.0, 100.0);
  const Vector3d to_tip(0.0, 0.0, -ball_radius);
  for (int k = 0; k < passes; ++k) {
    const Vector3d shift(0.0, y_first + stepover * k, 0.0);
    const bool forward = k % 2 == 0;  // zig-zag: odd passes run from +x to -x
    const auto centre_at = [&](std::size_t i) {
      return Vector3d(pass[forward ? i : pass.size() - 1 - i] + shift + to_tip);
    };
    if (k == 0) {
      const Vector3d first = centre_at(0);
      path.rapid({Vector3d(first.x(), first.y(), z_safe), Vector3d::UnitZ()});
    }
    // k > 0: the first point is the stepover, a feed move in y outside the stock.
    for (std::size_t i = 0; i < pass.size(); ++i) path.feed({centre_at(i), Vector3d::UnitZ()});
  }
  const Vector3d last = path.moves.back().cl.tip_W_mm;
  path.rapid({Vector3d(last.x(), last.y(), z_safe), Vector3d::UnitZ()});

  const std::string y_range = range(y_first, y_last);
  std::string yaml;
  yaml += R"(# Mould-like sample part (issue 22: a report for a large part with thousands of raw marks): a
# cavity across the block with 10 deg draft walls, R6 fillets, R2 rounds and a free-form
# (parabolic) floor, finished by a ball-end D10 in a zig-zag raster along x, 0.5 mm stepover, at
# 10 m/min on the Mikron: each pass crosses ten tangency zones and turns round twice.
)";
  yaml += kRegenerate;
  yaml += "name: mould_cavity\n";
  yaml += "description: \"Cavity across the block (open at y = -15 and 15 mm), profile in XZ "
          "extruded along y, symmetric about x = 0: floor z = 12 - 0.005 x^2 mm, concave fillets "
          "R6, walls with 10 deg draft (sharp edge with the land at x = +-30, z = 30), convex "
          "rounds R2, land z = 30 (stock top 31). " + std::to_string(passes) +
          " zig-zag passes along x at y = -15..15 mm every 0.5 mm, contact x from -46 to 46 mm, "
          "tip points every 0.2 mm or less on the curved pieces, walls and lands one move each, "
          "stepover a feed move outside the stock.\"\n";
  yaml += kMachine;
  yaml += "toolpath: toolpath.apt\n";
  yaml += "tool: {type: ball, diameter_mm: 10, corner_radius_mm: 5, length_mm: 60}\n";
  yaml += stock_yaml(Vector3d(-stock_half_x, y_first, 0.0),
                     Vector3d(stock_half_x, y_last, z_stock_top));
  yaml += "design:\n";
  yaml += "  surfaces:\n";
  for (const double side : {-1.0, 1.0}) {  // left side (x < 0), then right side
    const auto mirror = [&](const Vector3d& v) { return Vector3d(side * v.x(), v.y(), v.z()); };
    const auto x_range = [&](double a, double b) {
      return range(std::min(side * a, side * b), std::max(side * a, side * b));
    };
    yaml += "    - {type: plane, point_mm: " + vec(mirror(Vector3d(x_outside, 0.0, z_land))) +
            ", normal: [0, 0, 1], x_range_mm: " + x_range(round_centre.x(), stock_half_x) +
            ", y_range_mm: " + y_range + "}\n";
    yaml += "    - {type: cylinder, axis_point_mm: " + vec(mirror(round_centre)) +
            ", axis_direction: [0, 1, 0], radius_mm: " + num(round_radius) +
            ", material: inside, x_range_mm: " + x_range(round_to_wall.x(), round_centre.x()) +
            ", y_range_mm: " + y_range + ", z_range_mm: " + range(round_to_wall.z(), z_land) + "}\n";
    yaml += "    - {type: plane, point_mm: " + vec(mirror(edge)) +
            ", normal: " + vec(mirror(wall_normal)) +
            ", x_range_mm: " + x_range(fillet_to_wall.x(), round_to_wall.x()) +
            ", y_range_mm: " + y_range +
            ", z_range_mm: " + range(fillet_to_wall.z(), round_to_wall.z()) + "}\n";
    yaml += "    - {type: cylinder, axis_point_mm: " + vec(mirror(fillet_centre)) +
            ", axis_direction: [0, 1, 0], radius_mm: " + num(fillet_radius) +
            ", material: outside, x_range_mm: " + x_range(floor_end_x, fillet_to_wall.x()) +
            ", y_range_mm: " + y_range +
            ", z_range_mm: " + range(fillet_centre.z() - fillet_radius, fillet_to_wall.z()) + "}\n";
  }
  yaml += "    - {type: quadratic_height, z0_mm: " + num(floor_z0) + ", hxx_per_mm: " +
          num(floor_hxx) + ", hxy_per_mm: 0, hyy_per_mm: 0, x_range_mm: " +
          range(-floor_end_x, floor_end_x) + ", y_range_mm: " + y_range + "}\n";
  yaml += "strategy: {kind: parallel_planes, plane: xz, direction: zig_zag, stepover_mm: " +
          num(stepover) + ", passes: " + std::to_string(passes) +
          ", point_step_max_mm: " + num(point_step) + ", safe_z_mm: " + num(z_safe) + "}\n";
  yaml += feeds_yaml(10000.0, 100.0);
  yaml += "tolerance_um: 10                # a finishing tolerance of a mould cavity: the report's verdict\n";

  return {"mould_cavity", apt_text(path), yaml, summary("mould_cavity", path, ""), ""};
}

// ---------------------------------------------------------------------------------------------

/// Writes text to a temporary name beside path, then renames it: never a half-written file.
void write_file(const std::filesystem::path& path, const std::string& text) {
  const std::filesystem::path temporary = path.string() + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error("cannot open " + temporary.string() + " for writing");
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    if (!out) throw std::runtime_error("cannot write " + temporary.string());
  }
  std::filesystem::rename(temporary, path);
}

}  // namespace

int main(int argc, char** argv) {
  const bool die = argc == 4 && std::string(argv[1]) == "--die-width-mm";
  if ((argc != 2 && !die) || std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help") {
    std::cerr << "usage: generate_parts <output folder>   (e.g. generate_parts samples/parts)\n"
                 "Writes <output folder>/<part>/toolpath.apt and part.yaml for the sample parts\n"
                 "(and stock.stl where a part has a near-net stock).\n"
                 "       generate_parts --die-width-mm W <output folder>\n"
                 "Writes <output folder>/die_part1_<W>mm/: part 1's profile swept over W mm in y\n"
                 "(the scaling benchmark's die; 500 mm: 2 001 passes, about 900 000 GOTOs).\n";
    return argc == 2 ? 0 : 2;
  }
  try {
    const std::filesystem::path out_dir(argv[die ? 3 : 1]);
    double width_mm = 10.0;
    if (die) {
      std::size_t used = 0;
      width_mm = std::stod(argv[2], &used);
      if (used != std::string(argv[2]).size() || !(width_mm >= 1.0 && width_mm <= 2000.0)) {
        throw std::runtime_error(std::string("--die-width-mm ") + argv[2] + ": a width in mm from 1 to 2000");
      }
    }
    const std::vector<PartFiles> parts =
        die ? std::vector<PartFiles>{part1_tangency(width_mm)}
            : std::vector<PartFiles>{part1_tangency(), part2_corner(), part3_five_axis(), path1_yz(), path2_blade(),
                                     mould_cavity()};
    for (const PartFiles& part : parts) {
      const std::filesystem::path dir = out_dir / part.name;
      std::filesystem::create_directories(dir);
      write_file(dir / "toolpath.apt", part.apt);
      write_file(dir / "part.yaml", part.yaml);
      if (!part.stock_stl.empty()) write_file(dir / "stock.stl", part.stock_stl);
      std::cout << part.summary << '\n';
    }
  } catch (const std::exception& error) {
    std::cerr << "generate_parts: " << error.what() << '\n';
    return 1;
  }
  return 0;
}
