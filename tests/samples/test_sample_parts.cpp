// Tests of the sample parts in samples/parts: the generator reproduces the checked-in files byte
// for byte, and the checked-in tool paths agree with the analytic design surfaces written in the
// part.yaml beside them. The APT files are read by a few lines here, independent of the generator
// and of the planner's reader.

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <iostream>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

namespace {

using Eigen::Vector3d;
namespace fs = std::filesystem;

constexpr double kDegree = std::numbers::pi / 180.0;
const fs::path kPartsDir = fs::path(VMSIM_SOURCE_DIR) / "samples" / "parts";
const std::vector<std::string> kParts = {"part1_tangency", "part2_corner", "part3_five_axis",
                                         "path1_yz", "path2_blade", "mould_cavity"};

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// ---------------------------------------------------------------------------------------------
// A minimal APT/CL reader for the subset the generator writes.

struct AptMove {
  bool rapid = false;
  Vector3d tip_mm = Vector3d::Zero();
  Vector3d axis = Vector3d::UnitZ();
  int line = 0;
};

struct Apt {
  std::vector<std::string> lines;
  double cutter_diameter_mm = 0.0;
  double cutter_corner_radius_mm = 0.0;
  bool multax = false;
  double feed_mm_per_min = 0.0;
  std::vector<AptMove> moves;  // FROM is not included
};

std::vector<double> numbers_after_slash(const std::string& line) {
  std::vector<double> values;
  std::stringstream rest(line.substr(line.find('/') + 1));
  std::string item;
  while (std::getline(rest, item, ',')) {
    if (item == "MMPM") continue;
    values.push_back(std::stod(item));
  }
  return values;
}

Apt read_apt(const fs::path& path) {
  Apt apt;
  std::ifstream in(path);
  std::string line;
  bool rapid_next = false;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    apt.lines.push_back(line);
    if (line.rfind("CUTTER/", 0) == 0) {
      const auto v = numbers_after_slash(line);
      apt.cutter_diameter_mm = v.at(0);
      apt.cutter_corner_radius_mm = v.at(1);
    } else if (line == "MULTAX") {
      apt.multax = true;
    } else if (line.rfind("FEDRAT/", 0) == 0) {
      apt.feed_mm_per_min = numbers_after_slash(line).at(0);
    } else if (line == "RAPID") {
      rapid_next = true;
    } else if (line.rfind("GOTO/", 0) == 0) {
      const auto v = numbers_after_slash(line);
      AptMove move;
      move.rapid = rapid_next;
      move.line = number;
      move.tip_mm = Vector3d(v.at(0), v.at(1), v.at(2));
      if (v.size() == 6) move.axis = Vector3d(v[3], v[4], v[5]);
      EXPECT_EQ(v.size(), apt.multax ? 6u : 3u) << path << ":" << number;
      apt.moves.push_back(move);
      rapid_next = false;
    }
  }
  return apt;
}

/// The runs of consecutive cutting (non-rapid) moves: the passes.
std::vector<std::vector<AptMove>> passes(const Apt& apt) {
  std::vector<std::vector<AptMove>> result;
  bool in_pass = false;
  for (const AptMove& move : apt.moves) {
    if (move.rapid) {
      in_pass = false;
      continue;
    }
    if (!in_pass) result.emplace_back();
    in_pass = true;
    result.back().push_back(move);
  }
  return result;
}

Vector3d vec3(const YAML::Node& node) {
  return {node[0].as<double>(), node[1].as<double>(), node[2].as<double>()};
}

bool in_range(const YAML::Node& surface, const char* key, double value, double kSlack = 1e-9) {
  if (!surface[key]) return true;
  return value >= surface[key][0].as<double>() - kSlack &&
         value <= surface[key][1].as<double>() + kSlack;
}

bool foot_in_ranges(const YAML::Node& surface, const Vector3d& foot) {
  return in_range(surface, "x_range_mm", foot.x()) && in_range(surface, "y_range_mm", foot.y()) &&
         in_range(surface, "z_range_mm", foot.z());
}

struct Foot {
  bool inside = false;  //!< the foot point lies on the bounded patch
  double distance_mm = std::numeric_limits<double>::infinity();
  Vector3d normal = Vector3d::Zero();  //!< unit surface normal at the foot, towards the point
  Vector3d point = Vector3d::Zero();   //!< the foot point
};

/// Foot of the perpendicular from p on a plane, cylinder or sphere patch of a part.yaml.
Foot foot_on(const YAML::Node& surface, const Vector3d& p) {
  const std::string type = surface["type"].as<std::string>();
  Foot result;
  Vector3d foot;
  if (type == "plane") {
    const Vector3d n = vec3(surface["normal"]).normalized();
    const double signed_distance = (p - vec3(surface["point_mm"])).dot(n);
    foot = p - signed_distance * n;
    result.distance_mm = std::abs(signed_distance);
    result.normal = signed_distance >= 0.0 ? n : Vector3d(-n);
  } else if (type == "cylinder") {
    const Vector3d a = vec3(surface["axis_direction"]).normalized();
    const Vector3d q = vec3(surface["axis_point_mm"]);
    const Vector3d radial = (p - q) - (p - q).dot(a) * a;
    const double r = surface["radius_mm"].as<double>();
    foot = p - radial + r * radial.normalized();
    result.distance_mm = std::abs(radial.norm() - r);
    result.normal = radial.norm() > r ? radial.normalized() : Vector3d(-radial.normalized());
  } else if (type == "sphere") {
    const Vector3d c = vec3(surface["center_mm"]);
    const double r = surface["radius_mm"].as<double>();
    foot = c + r * (p - c).normalized();
    result.distance_mm = std::abs((p - c).norm() - r);
    result.normal = (p - c).norm() > r ? (p - c).normalized() : Vector3d(-(p - c).normalized());
  } else {
    ADD_FAILURE() << "unexpected surface type " << type;
    return result;
  }
  result.inside = foot_in_ranges(surface, foot);
  result.point = foot;
  return result;
}

/// The nearest foot point over the patches whose foot lies inside them.
Foot nearest_foot(const YAML::Node& surfaces, const Vector3d& p) {
  Foot best;
  for (const YAML::Node& surface : surfaces) {
    const Foot foot = foot_on(surface, p);
    if (foot.inside && foot.distance_mm < best.distance_mm) best = foot;
  }
  return best;
}

double angle_between(const Vector3d& a, const Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

struct Part {
  YAML::Node yaml;
  Apt apt;
};

Part load(const std::string& name) {
  return {YAML::LoadFile((kPartsDir / name / "part.yaml").string()),
          read_apt(kPartsDir / name / "toolpath.apt")};
}

// ---------------------------------------------------------------------------------------------

TEST(SampleParts, GeneratorReproducesCheckedInFilesByteForByte) {
  const fs::path out = fs::temp_directory_path() /
                       ("vmsim_test_samples_" + std::to_string(::getpid()));
  fs::remove_all(out);
  const std::string command =
      std::string("\"") + VMSIM_GENERATE_PARTS + "\" \"" + out.string() + "\" > /dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  int expected_files = 0;
  for (const std::string& name : kParts) {
    for (const char* file : {"toolpath.apt", "part.yaml", "stock.stl"}) {
      if (std::string(file) == "stock.stl" && !fs::exists(kPartsDir / name / file)) continue;
      ++expected_files;
      const std::string generated = read_text(out / name / file);
      const std::string checked_in = read_text(kPartsDir / name / file);
      EXPECT_FALSE(generated.empty()) << name << "/" << file;
      EXPECT_TRUE(generated == checked_in)
          << name << "/" << file << " differs from the checked-in file: regenerate with "
          << "<build>/samples/generate_parts samples/parts";
    }
  }
  // Nothing else is written (no temporary file left behind).
  int files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(out)) files += entry.is_regular_file();
  EXPECT_EQ(files, expected_files);
  fs::remove_all(out);
}

// The die's part file is checked in, its 33 MB tool path is not (samples/parts/README.md): the
// generator writes the same part file, and a tool path of 2 001 passes.
TEST(SampleParts, DiePartFileIsTheGeneratorsOwn) {
  const fs::path out = fs::temp_directory_path() / ("vmsim_test_die_" + std::to_string(::getpid()));
  fs::remove_all(out);
  const std::string command =
      std::string("\"") + VMSIM_GENERATE_PARTS + "\" --die-width-mm 500 \"" + out.string() + "\" > /dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  EXPECT_TRUE(read_text(out / "die_part1_500mm" / "part.yaml") ==
              read_text(kPartsDir / "die_part1_500mm" / "part.yaml"))
      << "regenerate with <build>/samples/generate_parts --die-width-mm 500 samples/parts";
  std::ifstream apt(out / "die_part1_500mm" / "toolpath.apt");
  int rapids = 0;
  for (std::string line; std::getline(apt, line);) rapids += line == "RAPID";
  EXPECT_EQ(rapids, 2 * 2001);  // each pass: the rapid to its start and the retract
  fs::remove_all(out);
}

TEST(SampleParts, EveryPartIsWellFormed) {
  for (const std::string& name : kParts) {
    SCOPED_TRACE(name);
    const Part part = load(name);
    const YAML::Node& y = part.yaml;
    EXPECT_EQ(y["name"].as<std::string>(), name);
    EXPECT_TRUE(y["description"].IsScalar());
    EXPECT_EQ(y["machine"].as<std::string>(), "../../machines/mikron_ucp710.yaml");
    EXPECT_EQ(y["toolpath"].as<std::string>(), "toolpath.apt");
    EXPECT_GT(y["feeds"]["production_mm_per_min"].as<double>(),
              y["feeds"]["reference_mm_per_min"].as<double>());
    if (y["stock"]["stl"]) {  // a near-net stock beside the part file (checked below for part 3)
      EXPECT_TRUE(fs::is_regular_file(kPartsDir / name / y["stock"]["stl"].as<std::string>()));
      EXPECT_GT(y["stock"]["allowance_mm"].as<double>(), 0.0);
    } else {
      const Vector3d low = vec3(y["stock"]["box"]["min_mm"]);
      const Vector3d high = vec3(y["stock"]["box"]["max_mm"]);
      EXPECT_TRUE((low.array() < high.array()).all());
      EXPECT_GE(low.z(), 0.0);
    }
    ASSERT_TRUE(y["design"]["surfaces"].IsSequence());

    // The APT header and the tool agree with part.yaml.
    const Apt& apt = part.apt;
    ASSERT_GE(apt.lines.size(), 8u);
    EXPECT_EQ(apt.lines[0].rfind("PARTNO/", 0), 0u);
    EXPECT_EQ(apt.lines[1], "UNITS/MM");
    EXPECT_EQ(apt.lines.back(), "FINI");
    EXPECT_DOUBLE_EQ(apt.cutter_diameter_mm, y["tool"]["diameter_mm"].as<double>());
    EXPECT_DOUBLE_EQ(apt.cutter_corner_radius_mm, y["tool"]["corner_radius_mm"].as<double>());
    EXPECT_DOUBLE_EQ(apt.feed_mm_per_min, y["feeds"]["production_mm_per_min"].as<double>());
    const std::string type = y["tool"]["type"].as<std::string>();
    EXPECT_TRUE(type == "ball" || type == "flat" || type == "bull");
    EXPECT_GT(apt.moves.size(), 2u);
    EXPECT_LE(apt.moves.size(), 25000u);
    EXPECT_TRUE(apt.moves.front().rapid);
    for (const AptMove& move : apt.moves) {
      EXPECT_NEAR(move.axis.norm(), 1.0, 2e-6) << "line " << move.line;
      EXPECT_GE(move.tip_mm.z(), 0.0) << "line " << move.line;
      EXPECT_LE(move.tip_mm.head<2>().cwiseAbs().maxCoeff(), 100.0) << "line " << move.line;
    }
  }
}

TEST(SampleParts, Part1BallCentresAtTheRadiusFromThePlanesAndCylinderOnPasses025Apart) {
  const Part part = load("part1_tangency");
  const double radius = part.yaml["tool"]["corner_radius_mm"].as<double>();
  ASSERT_EQ(radius, 5.0);
  EXPECT_FALSE(part.apt.multax);
  const YAML::Node surfaces = part.yaml["design"]["surfaces"];
  ASSERT_EQ(surfaces.size(), 3u);

  const auto runs = passes(part.apt);
  ASSERT_EQ(runs.size(), 41u);
  std::map<std::string, int> contact_patches;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const auto& run = runs[k];
    // The first move of a pass is the plunge to its first point; every point is on the surface.
    for (std::size_t i = 0; i < run.size(); ++i) {
      const AptMove& m = run[i];
      EXPECT_EQ(m.axis, Vector3d::UnitZ());
      const Vector3d centre = m.tip_mm + radius * m.axis;
      const Foot foot = nearest_foot(surfaces, centre);
      ASSERT_TRUE(foot.inside) << "line " << m.line;
      EXPECT_NEAR(foot.distance_mm, radius, 1e-6) << "line " << m.line;
      // No patch is nearer than the radius (no gouge).
      for (const YAML::Node& surface : surfaces) {
        const Foot other = foot_on(surface, centre);
        if (other.inside) {
          EXPECT_GE(other.distance_mm, radius - 1e-6) << "line " << m.line;
        }
      }
      EXPECT_DOUBLE_EQ(m.tip_mm.y(), run.front().tip_mm.y()) << "a pass stays in its XZ plane";
      if (i > 0) {
        const double step = (m.tip_mm - run[i - 1].tip_mm).norm();
        EXPECT_GT(m.tip_mm.x(), run[i - 1].tip_mm.x()) << "one-way pass, line " << m.line;
        EXPECT_LE(step, 0.2 + 1e-5) << "line " << m.line;
        EXPECT_GE(step, 0.1) << "line " << m.line;
      }
    }
    EXPECT_DOUBLE_EQ(run.front().tip_mm.x(), -46.0);
    EXPECT_DOUBLE_EQ(run.back().tip_mm.x(), runs[0].back().tip_mm.x());
    if (k > 0) {
      EXPECT_NEAR(run.front().tip_mm.y() - runs[k - 1].front().tip_mm.y(), 0.25, 1e-9);
    }
  }
  EXPECT_DOUBLE_EQ(runs.front().front().tip_mm.y(), -5.0);
  EXPECT_DOUBLE_EQ(runs.back().front().tip_mm.y(), 5.0);

  // The passes cross both tangency lines: points on each of the three patches.
  for (const AptMove& m : runs[0]) {
    const Vector3d centre = m.tip_mm + radius * m.axis;
    for (std::size_t s = 0; s < surfaces.size(); ++s) {
      const Foot foot = foot_on(surfaces[s], centre);
      if (foot.inside && std::abs(foot.distance_mm - radius) < 1e-6) {
        ++contact_patches[std::to_string(s)];
      }
    }
  }
  EXPECT_EQ(contact_patches.size(), 3u);
  EXPECT_GE(contact_patches["1"], 20) << "points on the cylinder";
}

/// Distance from p to a quadratic_height patch that depends on x only (hxy = hyy = 0: a profile
/// z = z0 + hxx x^2 / 2 extruded along y), by a dense scan of the profile's x and a golden-section
/// refinement; the foot's x is checked against x_range_mm.
Foot foot_on_x_parabola(const YAML::Node& surface, const Vector3d& p) {
  const double z0 = surface["z0_mm"].as<double>();
  const double hxx = surface["hxx_per_mm"].as<double>();
  EXPECT_EQ(surface["hxy_per_mm"].as<double>(), 0.0);
  EXPECT_EQ(surface["hyy_per_mm"].as<double>(), 0.0);
  const auto distance_at = [&](double x) { return std::hypot(p.x() - x, p.z() - (z0 + 0.5 * hxx * x * x)); };
  double best_x = p.x();
  for (double x = p.x() - 20.0; x <= p.x() + 20.0; x += 0.01) {
    if (distance_at(x) < distance_at(best_x)) best_x = x;
  }
  double low = best_x - 0.01, high = best_x + 0.01;
  const double golden = (std::sqrt(5.0) - 1.0) / 2.0;
  for (int i = 0; i < 100; ++i) {
    const double a = high - golden * (high - low), b = low + golden * (high - low);
    if (distance_at(a) < distance_at(b)) high = b; else low = a;
  }
  const double x = 0.5 * (low + high);
  Foot result;
  result.distance_mm = distance_at(x);
  result.point = Vector3d(x, p.y(), z0 + 0.5 * hxx * x * x);
  return result;
}

/// The foot on any patch of the mould; `inside` with a slack of 0.1 um on the ranges: a ball
/// centre at a tangency (APT's 6 decimals) has its foot on the patch border, and on a fillet
/// whose centre circle is 1 mm in radius the rounding is magnified six times.
Foot any_foot_on(const YAML::Node& surface, const Vector3d& p) {
  Foot foot = surface["type"].as<std::string>() == "quadratic_height" ? foot_on_x_parabola(surface, p)
                                                                       : foot_on(surface, p);
  constexpr double kSlack = 1e-4;
  foot.inside = in_range(surface, "x_range_mm", foot.point.x(), kSlack) &&
                in_range(surface, "y_range_mm", foot.point.y(), kSlack) &&
                in_range(surface, "z_range_mm", foot.point.z(), kSlack);
  return foot;
}

// The mould: every ball centre inside the stock is the ball radius from the design surface (the
// nearest patch whose foot lies on it) and no patch is nearer (no gouge), on points and at the
// middle of the long straight moves (walls, lands); zig-zag passes 0.5 mm apart; each pass
// touches all nine patches (ten tangency zones crossed).
TEST(SampleParts, MouldBallCentresAtTheRadiusFromEveryPatchOnZigZagPasses) {
  const Part part = load("mould_cavity");
  const double radius = part.yaml["tool"]["corner_radius_mm"].as<double>();
  ASSERT_EQ(radius, 5.0);
  const YAML::Node surfaces = part.yaml["design"]["surfaces"];
  ASSERT_EQ(surfaces.size(), 9u);
  const double stock_x = vec3(part.yaml["stock"]["box"]["max_mm"]).x();
  const auto runs = passes(part.apt);
  ASSERT_EQ(runs.size(), 1u) << "one continuous zig-zag";
  const auto& run = runs[0];
  const auto check_centre = [&](const Vector3d& centre, int line, std::vector<int>* touched) {
    if (std::abs(centre.x()) > stock_x) return;  // outside the stock: turning round
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t s = 0; s < surfaces.size(); ++s) {
      const Foot foot = any_foot_on(surfaces[s], centre);
      if (!foot.inside) continue;
      EXPECT_GE(foot.distance_mm, radius - 2e-6) << "gouge at line " << line << ", patch " << s;
      nearest = std::min(nearest, foot.distance_mm);
      if (touched && std::abs(foot.distance_mm - radius) < 2e-6) (*touched)[s] += 1;
    }
    EXPECT_NEAR(nearest, radius, 2e-6) << "line " << line;
  };
  std::vector<int> touched(surfaces.size(), 0);
  std::vector<double> pass_y;
  for (std::size_t i = 0; i < run.size(); ++i) {
    const AptMove& m = run[i];
    EXPECT_EQ(m.axis, Vector3d::UnitZ());
    check_centre(m.tip_mm + radius * m.axis, m.line, &touched);
    if (i == 0) continue;
    const Vector3d step = m.tip_mm - run[i - 1].tip_mm;
    if (step.y() != 0.0) {  // a stepover: outside the stock, along y only
      EXPECT_EQ(step.x(), 0.0);
      EXPECT_EQ(step.z(), 0.0);
      EXPECT_GT(std::abs(m.tip_mm.x()), stock_x + radius);
      EXPECT_NEAR(step.y(), 0.5, 1e-9);
      pass_y.push_back(m.tip_mm.y());
    } else if (step.norm() > 1.0) {  // a straight move (wall, land): its middle too
      check_centre(0.5 * (m.tip_mm + run[i - 1].tip_mm) + radius * m.axis, m.line, nullptr);
    } else {
      EXPECT_LE(step.norm(), 0.2 + 1e-5) << "line " << m.line;
    }
  }
  EXPECT_EQ(pass_y.size() + 1, 61u);
  EXPECT_DOUBLE_EQ(run.front().tip_mm.y(), -15.0);
  EXPECT_DOUBLE_EQ(run.back().tip_mm.y(), 15.0);
  for (std::size_t s = 0; s < surfaces.size(); ++s) {
    EXPECT_GE(touched[s], 61) << "patch " << s << " is touched on every pass";
  }
}

TEST(SampleParts, Part2FlatMillTouchesBothWallsUpToTheCorner) {
  const Part part = load("part2_corner");
  const double radius = 0.5 * part.yaml["tool"]["diameter_mm"].as<double>();
  EXPECT_EQ(part.yaml["tool"]["type"].as<std::string>(), "flat");
  const YAML::Node surfaces = part.yaml["design"]["surfaces"];
  const Vector3d stock_low = vec3(part.yaml["stock"]["box"]["min_mm"]);

  const auto runs = passes(part.apt);
  ASSERT_EQ(runs.size(), 1u);
  const auto& run = runs[0];
  ASSERT_EQ(run.size(), 3u) << "plunge, then two G1 lines with one sharp corner";

  int walls = 0;
  for (const YAML::Node& surface : surfaces) {
    const Vector3d n = vec3(surface["normal"]);
    if (std::abs(n.z()) > 0.5) continue;  // the floor
    ++walls;
    const Vector3d p0 = vec3(surface["point_mm"]);
    const double z_low = surface["z_range_mm"][0].as<double>();
    const double z_high = surface["z_range_mm"][1].as<double>();
    // Along the wall: the horizontal coordinate the wall extends in.
    const int along = std::abs(n.x()) > 0.5 ? 1 : 0;
    const char* along_key = along == 0 ? "x_range_mm" : "y_range_mm";
    const double wall_end = surface[along_key][1].as<double>();
    bool touched = false;
    for (std::size_t i = 1; i < run.size(); ++i) {
      const Vector3d a = run[i - 1].tip_mm;
      const Vector3d b = run[i].tip_mm;
      EXPECT_EQ(run[i].axis, Vector3d::UnitZ());
      // No point of the path is nearer the wall than the radius where it faces the wall.
      for (const Vector3d& p : {a, b}) {
        if (p[along] <= wall_end) {
          EXPECT_GE((p - p0).dot(n), radius - 1e-9);
        }
      }
      const bool flank = std::abs((a - p0).dot(n) - radius) < 1e-9 &&
                         std::abs((b - p0).dot(n) - radius) < 1e-9 && a.z() == b.z();
      if (!flank) continue;
      touched = true;
      // The tool flank covers the wall's height, and its length from the stock edge to the
      // corner (where the tool, of radius R, stops R short of the other wall).
      EXPECT_LE(a.z(), z_low);
      EXPECT_GE(a.z() + part.yaml["tool"]["length_mm"].as<double>(), z_high);
      const double lo = std::min(a[along], b[along]);
      const double hi = std::max(a[along], b[along]);
      EXPECT_LE(lo - radius, stock_low[along]);
      EXPECT_DOUBLE_EQ(hi, wall_end - radius);
    }
    EXPECT_TRUE(touched) << "wall through " << p0.transpose();
  }
  EXPECT_EQ(walls, 2);
  // The corner point of the path touches both walls at once.
  const Vector3d corner = run[1].tip_mm;
  const Vector3d design_corner = vec3(part.yaml["design"]["corner_mm"]);
  EXPECT_DOUBLE_EQ(corner.x(), design_corner.x() - radius);
  EXPECT_DOUBLE_EQ(corner.y(), design_corner.y() - radius);
  EXPECT_NEAR(angle_between(run[1].tip_mm - run[0].tip_mm, run[2].tip_mm - run[1].tip_mm),
              90.0 * kDegree, 1e-12);
}

TEST(SampleParts, Part3BallCentresAtTheRadiusFromTheDomeWithTheToolNormal) {
  const Part part = load("part3_five_axis");
  const double radius = part.yaml["tool"]["corner_radius_mm"].as<double>();
  EXPECT_TRUE(part.apt.multax);
  const YAML::Node surfaces = part.yaml["design"]["surfaces"];
  const auto runs = passes(part.apt);
  ASSERT_EQ(runs.size(), 1u);
  const auto& run = runs[0];

  double tilt_min = 180.0;
  double tilt_max = 0.0;
  double azimuth_turned = 0.0;
  for (std::size_t i = 0; i < run.size(); ++i) {
    const AptMove& m = run[i];
    const Vector3d centre = m.tip_mm + radius * m.axis.normalized();
    const Foot foot = nearest_foot(surfaces, centre);
    ASSERT_TRUE(foot.inside) << "line " << m.line;
    EXPECT_NEAR(foot.distance_mm, radius, 1e-6) << "line " << m.line;
    EXPECT_LT(angle_between(m.axis, foot.normal), 3e-6) << "line " << m.line;
    const double tilt = angle_between(m.axis, Vector3d::UnitZ()) / kDegree;
    tilt_min = std::min(tilt_min, tilt);
    tilt_max = std::max(tilt_max, tilt);
    if (i > 0) {
      const Vector3d& a = run[i - 1].axis;
      const Vector3d& b = m.axis;
      const double turn = std::atan2(a.x() * b.y() - a.y() * b.x(), a.x() * b.x() + a.y() * b.y());
      EXPECT_LT(std::abs(turn), 5.0 * kDegree) << "smooth, line " << m.line;
      azimuth_turned += turn;
      EXPECT_LE((m.tip_mm - run[i - 1].tip_mm).norm(), 0.5 + 1e-5) << "line " << m.line;
    }
  }
  EXPECT_NEAR(tilt_min, 20.0, 1e-3);
  EXPECT_NEAR(tilt_max, 60.0, 1e-3);
  EXPECT_NEAR(std::abs(azimuth_turned) / kDegree, 3600.0, 1e-3);
}

// Part 3's near-net stock (stock.stl), read here by a few lines of binary STL: closed and
// consistently oriented outwards, and everywhere between the design sphere offset by the
// allowance and that offset sphere less a small chord error (the facets lie inside the sphere
// through their corners), closed by the disc z = 0 that the dome stands on.
TEST(SampleParts, Part3StockIsAClosedDomeWithinTheAllowanceOfTheDesignSphere) {
  const Part part = load("part3_five_axis");
  const YAML::Node sphere = part.yaml["design"]["surfaces"][0];
  ASSERT_EQ(sphere["type"].as<std::string>(), "sphere");
  const Vector3d centre = vec3(sphere["center_mm"]);
  const double allowance = part.yaml["stock"]["allowance_mm"].as<double>();
  const double offset_radius = sphere["radius_mm"].as<double>() + allowance;
  const std::string bytes =
      read_text(kPartsDir / "part3_five_axis" / part.yaml["stock"]["stl"].as<std::string>());
  ASSERT_GE(bytes.size(), 84u);
  std::uint32_t count = 0;
  std::memcpy(&count, bytes.data() + 80, 4);
  ASSERT_EQ(bytes.size(), 84u + 50u * count) << "binary STL of " << count << " triangles";
  auto read_float = [&](std::size_t offset) {
    float value = 0.0f;
    std::memcpy(&value, bytes.data() + offset, 4);
    return static_cast<double>(value);
  };

  // Weld bit-equal corners; every directed edge once, its reverse once (closed, oriented).
  std::map<std::array<double, 3>, int> index;
  std::map<std::pair<int, int>, int> directed;
  std::vector<std::array<Vector3d, 3>> triangles;
  double volume = 0.0;
  for (std::uint32_t t = 0; t < count; ++t) {
    const std::size_t at = 84u + 50u * t;
    const Vector3d stored_normal(read_float(at), read_float(at + 4), read_float(at + 8));
    std::array<Vector3d, 3> corner;
    std::array<int, 3> id{};
    for (int c = 0; c < 3; ++c) {
      const std::size_t offset = at + 12u + 12u * static_cast<std::size_t>(c);
      corner[c] = Vector3d(read_float(offset), read_float(offset + 4), read_float(offset + 8));
      id[c] = index.emplace(std::array<double, 3>{corner[c].x(), corner[c].y(), corner[c].z()},
                            static_cast<int>(index.size()))
                  .first->second;
    }
    const Vector3d normal = (corner[1] - corner[0]).cross(corner[2] - corner[0]);
    ASSERT_GT(normal.norm(), 0.0) << "triangle " << t << " is degenerate";
    EXPECT_GT(normal.normalized().dot(stored_normal), 0.999) << "triangle " << t;
    for (int c = 0; c < 3; ++c) ++directed[{id[c], id[(c + 1) % 3]}];
    volume += corner[0].dot(corner[1].cross(corner[2])) / 6.0;
    triangles.push_back(corner);
  }
  for (const auto& [edge, uses] : directed) {
    ASSERT_EQ(uses, 1) << "edge " << edge.first << "-" << edge.second << " used " << uses << " times";
    ASSERT_EQ(directed.count({edge.second, edge.first}), 1u) << "open edge " << edge.first << "-" << edge.second;
  }
  const double half_ball = 2.0 / 3.0 * std::numbers::pi * std::pow(offset_radius, 3);
  EXPECT_GT(volume, 0.0) << "outward normals";
  EXPECT_NEAR(volume / half_ball, 1.0, 1e-3);

  // Points of every facet (corners, edges and inside): on the base disc, or between the offset
  // sphere less the chord error and the offset sphere; never below the design surface.
  constexpr double kChordTolerance_mm = 0.01;  // 3 % of the allowance
  constexpr double kFloat_mm = 2e-5;           // float coordinates of about 40 mm
  double chord_error = 0.0;
  double lowest_z = std::numeric_limits<double>::infinity();
  double highest_z = -lowest_z;
  for (const auto& corner : triangles) {
    const bool base = std::max({std::abs(corner[0].z()), std::abs(corner[1].z()), std::abs(corner[2].z())}) == 0.0;
    for (int i = 0; i <= 8; ++i) {
      for (int j = 0; i + j <= 8; ++j) {
        const Vector3d p = corner[0] + (corner[1] - corner[0]) * (i / 8.0) + (corner[2] - corner[0]) * (j / 8.0);
        const double r = (p - centre).norm();
        lowest_z = std::min(lowest_z, p.z());
        highest_z = std::max(highest_z, p.z());
        EXPECT_LE(r, offset_radius + kFloat_mm);
        if (!base) chord_error = std::max(chord_error, offset_radius - r);
      }
    }
  }
  EXPECT_LT(chord_error, kChordTolerance_mm) << "the facets stay within the allowance";
  EXPECT_GT(offset_radius - chord_error, offset_radius - allowance) << "the stock covers the design";
  EXPECT_EQ(lowest_z, 0.0);
  EXPECT_NEAR(highest_z, centre.z() + offset_radius, kFloat_mm);
  std::cout << "stock.stl: " << count << " triangles, chord error " << chord_error * 1e3 << " um\n";
}

TEST(SampleParts, Path1IsInTheYzPlaneAbout100MmLongWithTheToolNormal) {
  const Part part = load("path1_yz");
  const YAML::Node s = part.yaml["design"]["surfaces"][0];
  ASSERT_EQ(s["type"].as<std::string>(), "sine_height_y");
  const double z0 = s["z0_mm"].as<double>();
  const double amplitude = s["amplitude_mm"].as<double>();
  const double k = 2.0 * std::numbers::pi / s["wavelength_mm"].as<double>();
  const double phase = s["y_phase_mm"].as<double>();
  const auto runs = passes(part.apt);
  ASSERT_EQ(runs.size(), 1u);
  const auto& run = runs[0];

  double length = 0.0;
  double tilt_min = 90.0;
  double tilt_max = -90.0;
  for (std::size_t i = 0; i < run.size(); ++i) {
    const AptMove& m = run[i];
    const double y = m.tip_mm.y();
    EXPECT_EQ(m.tip_mm.x(), 0.0);
    EXPECT_EQ(m.axis.x(), 0.0);
    EXPECT_NEAR(m.tip_mm.z(), z0 + amplitude * std::sin(k * (y - phase)), 1e-6);
    const Vector3d normal =
        Vector3d(0.0, -amplitude * k * std::cos(k * (y - phase)), 1.0).normalized();
    EXPECT_LT(angle_between(m.axis, normal), 3e-6) << "line " << m.line;
    const double tilt = std::atan2(-m.axis.y(), m.axis.z()) / kDegree;
    tilt_min = std::min(tilt_min, tilt);
    tilt_max = std::max(tilt_max, tilt);
    if (i > 0) length += (m.tip_mm - run[i - 1].tip_mm).norm();
    EXPECT_GE(m.tip_mm.y(), -20.0);
    EXPECT_LE(m.tip_mm.y(), 100.0);
    EXPECT_GE(m.tip_mm.z() + 5.0 * m.axis.z(), 30.0);
    EXPECT_LE(m.tip_mm.z() + 5.0 * m.axis.z(), 56.0);
  }
  EXPECT_NEAR(length, 100.0, 10.0);
  EXPECT_LT(tilt_max, 25.5);  // the Mikron sample's A travel ends at +30 deg
  EXPECT_GT(tilt_min, -25.5);
  EXPECT_GT(tilt_max - tilt_min, 45.0) << "the orientation changes along the path";
}

TEST(SampleParts, Path2PassesWithin2DegreesOfTheCAxisNearS40Mm) {
  const Part part = load("path2_blade");
  const YAML::Node s = part.yaml["design"]["surfaces"][0];
  ASSERT_EQ(s["type"].as<std::string>(), "quadratic_height");
  const double z0 = s["z0_mm"].as<double>();
  const double hxx = s["hxx_per_mm"].as<double>();
  const double hxy = s["hxy_per_mm"].as<double>();
  const double hyy = s["hyy_per_mm"].as<double>();
  const auto runs = passes(part.apt);
  ASSERT_EQ(runs.size(), 1u);
  const auto& run = runs[0];

  double arc = 0.0;
  double best_tilt = 180.0;
  double best_s = -1.0;
  double azimuth_30 = 0.0;
  double azimuth_50 = 0.0;
  double azimuth = 0.0;
  for (std::size_t i = 0; i < run.size(); ++i) {
    const AptMove& m = run[i];
    const double x = m.tip_mm.x();
    const double y = m.tip_mm.y();
    EXPECT_NEAR(m.tip_mm.z(), z0 + 0.5 * (hxx * x * x + 2.0 * hxy * x * y + hyy * y * y), 1e-6);
    const Vector3d normal = Vector3d(-(hxx * x + hxy * y), -(hxy * x + hyy * y), 1.0).normalized();
    EXPECT_LT(angle_between(m.axis, normal), 3e-6) << "line " << m.line;
    if (i > 0) {
      arc += (m.tip_mm - run[i - 1].tip_mm).norm();
      const Vector3d& a = run[i - 1].axis;
      const Vector3d& b = m.axis;
      azimuth += std::atan2(a.x() * b.y() - a.y() * b.x(), a.x() * b.x() + a.y() * b.y());
    }
    if (arc <= 30.0) azimuth_30 = azimuth;
    if (arc <= 50.0) azimuth_50 = azimuth;
    const double tilt = angle_between(m.axis, Vector3d::UnitZ()) / kDegree;
    if (tilt < best_tilt) {
      best_tilt = tilt;
      best_s = arc;
    }
  }
  EXPECT_LT(best_tilt, 2.0);
  EXPECT_GT(best_tilt, 0.5);
  EXPECT_NEAR(best_s, 40.0, 1.0);
  EXPECT_NEAR(arc, 90.0, 1.0);
  EXPECT_GT(std::abs(azimuth_50 - azimuth_30) / kDegree, 120.0)
      << "the axis swings round the C axis near the singularity";
}

}  // namespace
