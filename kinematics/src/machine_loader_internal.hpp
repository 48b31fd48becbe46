#pragma once
// Internals of the machine loader: a YAML field reader whose every error names the file, line,
// column, field path and axis; and the URDF chain import.
#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "vmsim/kinematics/machine_model.hpp"

namespace vmsim::kinematics {

std::string format_number(double value);

/// Levenshtein distance between two keys (yaml_input.cpp): how misspelt one is as the other.
std::size_t edit_distance(const std::string& a, const std::string& b);

/// Reads fields of one YAML map and remembers which were read, so that the rest can be
/// reported as unknown. Quantities are written <name>_<unit> and converted to SI.
class FieldReader {
 public:
  using UnitTable = std::vector<std::pair<std::string, double>>;

  FieldReader(const YAML::Node& node, std::string file, std::string path, std::string axis);

  bool has(const std::string& key) const;
  FieldReader child(const std::string& key) const;
  FieldReader element(std::size_t index) const;
  std::size_t sequence_size() const;
  /// The same node, with errors naming this axis.
  FieldReader for_axis(const std::string& axis_name) const;

  double as_number() const;
  std::string as_string() const;
  bool as_bool() const;
  std::vector<double> as_numbers(std::size_t expected_count) const;
  Eigen::Vector3d as_vector3() const;

  double number(const std::string& key) const;
  double number_or(const std::string& key, double fallback) const;
  std::string string(const std::string& key) const;
  std::string string_or(const std::string& key, const std::string& fallback) const;
  bool boolean_or(const std::string& key, bool fallback) const;

  /// The value of <name>_<unit> for exactly one unit of the table, in SI.
  double quantity(const std::string& name, const UnitTable& units) const;
  double quantity_or(const std::string& name, const UnitTable& units, double fallback_si) const;
  /// [min, max] of <name>_<unit>, in SI; nullopt when absent.
  std::optional<std::pair<double, double>> range_with_unit(const std::string& name,
                                                           const UnitTable& units) const;
  static std::string spellings(const std::string& quantity, const UnitTable& units);

  void require_positive(const std::string& key, double value) const;
  void require_non_negative(const std::string& key, double value) const;
  /// Every key of the map not read so far is an error.
  void reject_unknown_fields() const;

  [[noreturn]] void fail(const std::string& message) const;
  [[noreturn]] void fail_at(const YAML::Node& at, const std::string& message) const;
  std::string where(const YAML::Node& at) const;
  const YAML::Node& node() const { return node_; }

 private:
  std::optional<std::pair<FieldReader, double>> find_with_unit(const std::string& quantity,
                                                               const UnitTable& units) const;
  std::string child_path(const std::string& key) const;
  /// A key of this map that looks like `wanted` misspelt (or, with prefix, wanted_<bad unit>).
  std::string misspelling_hint(const std::string& wanted, bool prefix) const;

  YAML::Node node_;
  std::string file_;
  std::string path_;
  std::string axis_;
  /// Keys read so far; shared by the readers of the same node (see for_axis).
  std::shared_ptr<std::set<std::string>> used_ = std::make_shared<std::set<std::string>>();
};

/// Why an inertia tensor about the centre of mass [kg m^2] is no physical body's ("" when it is
/// one): not symmetric, a negative principal moment, or principal moments that violate the
/// triangle inequality.
std::string inertia_tensor_problem(const Eigen::Matrix3d& inertia_kg_m2);

/// The deepest XML nesting a URDF may have; real ones have 4 or 5 levels.
inline constexpr int kUrdfNestingLimit = 100;

/// Refuses XML whose elements nest deeper than `max_depth`, by one pass over the text without
/// recursion (XML parsers recurse per level). Throws vmsim::InputError naming the line.
void check_xml_nesting(std::string_view text, const std::string& file, int max_depth);

/// Checks a URDF's text (urdf_checks.cpp) before urdfdom reads it: the nesting, well-formed XML
/// under <robot>, every number of <origin>, <mass>, <inertia>, <axis>, <limit> and <dynamics>
/// (finite, plausible; mass > 0; inertia physical), and a joint graph that is a tree (no link
/// with two parents, no cycle). Throws vmsim::InputError naming the file, line, element and
/// value; returns warnings (each located) for values plausible but unusual.
std::vector<std::string> check_urdf_text(std::string_view text, const std::string& file);

/// Reads `axes[i].effects` (machine_loader_effects.cpp); rejects unknown fields.
DriveEffects read_drive_effects(const FieldReader& effects, const Axis& axis, MachineKind kind);

/// A serial chain imported from URDF: the joints from base_link to tip_link become the tool
/// chain (their names must be axis names of the machine file); tip_to_spindle places the spindle
/// frame S on the tip link; base_to_workpiece places W in the base.
struct UrdfChainRequest {
  std::string path;
  std::string base_link;
  std::string tip_link;
  Eigen::Isometry3d tip_to_spindle = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d base_to_workpiece = Eigen::Isometry3d::Identity();
};

/// Fills model.tool_chain and model.workpiece_chain from the URDF; axes without travel take the
/// URDF joint limits. `context` names the machine file field for messages.
void append_urdf_chain(const UrdfChainRequest& request, MachineModel& model,
                       const std::string& context);

}  // namespace vmsim::kinematics
