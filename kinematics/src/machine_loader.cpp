#include "vmsim/kinematics/machine_loader.hpp"

#include <yaml-cpp/yaml.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <sstream>

#include "machine_loader_internal.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/kinematics/yaml_input.hpp"

namespace vmsim::kinematics {
namespace {

constexpr double kPi = std::numbers::pi;

// Unit suffixes accepted for each quantity, with the factor to SI. A field is written as
// <quantity>_<suffix>, e.g. velocity_m_per_min; exactly one of the spellings must be present.
using UnitTable = std::vector<std::pair<std::string, double>>;

const UnitTable kLength = {{"mm", 1e-3}, {"m", 1.0}};
const UnitTable kAngle = {{"deg", kPi / 180.0}, {"rad", 1.0}};
const UnitTable kLinearVelocity = {{"m_per_min", 1.0 / 60.0}, {"mm_per_s", 1e-3}, {"m_per_s", 1.0}};
const UnitTable kRotaryVelocity = {
    {"rev_per_min", 2.0 * kPi / 60.0}, {"deg_per_s", kPi / 180.0}, {"rad_per_s", 1.0}};
const UnitTable kLinearAcceleration = {{"m_per_s2", 1.0}, {"mm_per_s2", 1e-3}};
const UnitTable kRotaryAcceleration = {
    {"rev_per_s2", 2.0 * kPi}, {"deg_per_s2", kPi / 180.0}, {"rad_per_s2", 1.0}};
const UnitTable kLinearJerk = {{"m_per_s3", 1.0}, {"mm_per_s3", 1e-3}};
const UnitTable kRotaryJerk = {
    {"rev_per_s3", 2.0 * kPi}, {"deg_per_s3", kPi / 180.0}, {"rad_per_s3", 1.0}};
const UnitTable kTime = {{"s", 1.0}, {"ms", 1e-3}, {"us", 1e-6}};
const UnitTable kPositionGain = {{"per_s", 1.0}, {"m_per_min_per_mm", 1000.0 / 60.0}};
const UnitTable kMotorSpeed = {{"rev_per_min", 2.0 * kPi / 60.0}, {"rad_per_s", 1.0}};

}  // namespace

// ---------------------------------------------------------------------------------------------
// Field access with located errors.

FieldReader::FieldReader(const YAML::Node& node, std::string file, std::string path,
                         std::string axis)
    : node_(node), file_(std::move(file)), path_(std::move(path)), axis_(std::move(axis)) {}

std::string FieldReader::where(const YAML::Node& at) const {
  const YAML::Mark mark = at.Mark();
  const int line = mark.is_null() ? 0 : mark.line + 1;
  const int column = mark.is_null() ? 0 : mark.column + 1;
  std::string context = path_.empty() ? std::string("(top level)") : path_;
  if (!axis_.empty()) context += " (axis " + axis_ + ")";
  return located_message(file_, line, column, context);
}

void FieldReader::fail(const std::string& message) const { fail_at(node_, message); }

void FieldReader::fail_at(const YAML::Node& at, const std::string& message) const {
  throw InputError(where(at) + ": " + message);
}

std::string FieldReader::child_path(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

bool FieldReader::has(const std::string& key) const {
  used_->insert(key);
  return node_.IsMap() && node_[key].IsDefined() && !node_[key].IsNull();
}


std::string FieldReader::misspelling_hint(const std::string& wanted, bool prefix) const {
  if (!node_.IsMap()) return "";
  for (const auto& entry : node_) {
    const std::string key = entry.first.as<std::string>();
    const bool close = prefix ? key.rfind(wanted + "_", 0) == 0 : edit_distance(key, wanted) <= 2;
    if (close && key != wanted) {
      return " (the map has '" + key + "' on line " + std::to_string(entry.first.Mark().line + 1) +
             (prefix ? ": not a known unit)" : ": a misspelling?)");
    }
  }
  return "";
}

FieldReader FieldReader::child(const std::string& key) const {
  used_->insert(key);
  if (!node_.IsMap() || !node_[key].IsDefined() || node_[key].IsNull()) {
    fail("missing field '" + key + "'" + misspelling_hint(key, false));
  }
  return FieldReader(node_[key], file_, child_path(key), axis_);
}

FieldReader FieldReader::element(std::size_t index) const {
  std::string path = path_ + "[" + std::to_string(index) + "]";
  return FieldReader(node_[index], file_, path, axis_);
}

std::size_t FieldReader::sequence_size() const {
  if (!node_.IsSequence()) fail("expected a list");
  return node_.size();
}

FieldReader FieldReader::for_axis(const std::string& axis_name) const {
  FieldReader reader(node_, file_, path_, axis_name);
  reader.used_ = used_;
  return reader;
}

namespace {

std::string scalar_text(const YAML::Node& node) {
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list";
  if (node.IsMap()) return "a map";
  return "nothing";
}

}  // namespace

double FieldReader::as_number() const {
  if (!node_.IsScalar()) fail("expected a number, got " + scalar_text(node_));
  const std::string& text = node_.Scalar();
  const NumberText number = parse_number_text(text);
  if (!number.ok) fail("expected a finite number, got '" + text + "', which " + number.problem);
  return number.value;
}

std::string FieldReader::as_string() const {
  if (!node_.IsScalar()) fail("expected a text value, got " + scalar_text(node_));
  return node_.Scalar();
}

bool FieldReader::as_bool() const {
  const std::string text = as_string();
  if (text == "true" || text == "yes" || text == "on") return true;
  if (text == "false" || text == "no" || text == "off") return false;
  fail("expected true or false, got '" + text + "'");
  return false;
}

std::vector<double> FieldReader::as_numbers(std::size_t expected_count) const {
  if (!node_.IsSequence()) fail("expected a list of " + std::to_string(expected_count) + " numbers");
  if (node_.size() != expected_count) {
    fail("expected " + std::to_string(expected_count) + " numbers, got " +
         std::to_string(node_.size()));
  }
  std::vector<double> values;
  for (std::size_t i = 0; i < node_.size(); ++i) values.push_back(element(i).as_number());
  return values;
}

Eigen::Vector3d FieldReader::as_vector3() const {
  const std::vector<double> v = as_numbers(3);
  return {v[0], v[1], v[2]};
}

double FieldReader::number(const std::string& key) const { return child(key).as_number(); }

double FieldReader::number_or(const std::string& key, double fallback) const {
  return has(key) ? number(key) : fallback;
}

std::string FieldReader::string(const std::string& key) const { return child(key).as_string(); }

std::string FieldReader::string_or(const std::string& key, const std::string& fallback) const {
  return has(key) ? string(key) : fallback;
}

bool FieldReader::boolean_or(const std::string& key, bool fallback) const {
  return has(key) ? child(key).as_bool() : fallback;
}

std::optional<std::pair<FieldReader, double>> FieldReader::find_with_unit(
    const std::string& quantity, const UnitTable& units) const {
  std::optional<std::pair<FieldReader, double>> found;
  std::string found_key;
  for (const auto& [suffix, factor] : units) {
    const std::string key = quantity + "_" + suffix;
    if (!has(key)) continue;
    if (found) {
      fail("both '" + found_key + "' and '" + key + "' are given: keep one");
    }
    found.emplace(child(key), factor);
    found_key = key;
  }
  return found;
}

std::string FieldReader::spellings(const std::string& quantity, const UnitTable& units) {
  std::string list;
  for (const auto& [suffix, factor] : units) {
    (void)factor;
    if (!list.empty()) list += ", ";
    list += quantity + "_" + suffix;
  }
  return list;
}

double FieldReader::quantity(const std::string& name, const UnitTable& units) const {
  auto found = find_with_unit(name, units);
  if (!found) {
    fail("missing field '" + name + "_<unit>' (one of " + spellings(name, units) + ")" +
         misspelling_hint(name, true));
  }
  return found->first.as_number() * found->second;
}

double FieldReader::quantity_or(const std::string& name, const UnitTable& units,
                                double fallback_si) const {
  auto found = find_with_unit(name, units);
  return found ? found->first.as_number() * found->second : fallback_si;
}

std::optional<std::pair<double, double>> FieldReader::range_with_unit(
    const std::string& name, const UnitTable& units) const {
  auto found = find_with_unit(name, units);
  if (!found) return std::nullopt;
  const std::vector<double> v = found->first.as_numbers(2);
  if (!(v[0] < v[1])) found->first.fail("expected [min, max] with min < max");
  return std::make_pair(v[0] * found->second, v[1] * found->second);
}

void FieldReader::reject_unknown_fields() const {
  if (!node_.IsMap()) return;
  for (const auto& entry : node_) {
    const std::string key = entry.first.as<std::string>();
    if (used_->count(key) == 0) {
      // The keys asked for are the ones this map may have: the nearest is the likely intent.
      fail_at(entry.first, "unknown field '" + key + "'" +
                               nearest_key_hint(key, std::vector<std::string>(used_->begin(),
                                                                              used_->end())));
    }
  }
}

void FieldReader::require_positive(const std::string& key, double value) const {
  if (!(value > 0.0)) fail("field '" + key + "' must be > 0, got " + format_number(value));
}

void FieldReader::require_non_negative(const std::string& key, double value) const {
  if (!(value >= 0.0)) fail("field '" + key + "' must be >= 0, got " + format_number(value));
}

std::string format_number(double value) {
  std::ostringstream out;
  out.precision(10);
  out << value;
  return out.str();
}

// ---------------------------------------------------------------------------------------------
// The machine file.

namespace {

bool is_linear(const Axis& axis) { return axis.type == AxisType::linear; }

KinematicLimits read_limits(const FieldReader& limits, const Axis& axis) {
  KinematicLimits result;
  result.velocity_max =
      limits.quantity("velocity", is_linear(axis) ? kLinearVelocity : kRotaryVelocity);
  result.acceleration_max =
      limits.quantity("acceleration", is_linear(axis) ? kLinearAcceleration : kRotaryAcceleration);
  result.jerk_max = limits.quantity("jerk", is_linear(axis) ? kLinearJerk : kRotaryJerk);
  limits.require_positive("velocity", result.velocity_max);
  limits.require_positive("acceleration", result.acceleration_max);
  limits.require_positive("jerk", result.jerk_max);
  limits.reject_unknown_fields();
  return result;
}

Drive read_drive(const FieldReader& drive, const Axis& axis) {
  Drive result;
  if (is_linear(axis)) {
    const double lead_m = drive.quantity("screw_lead", kLength);
    drive.require_positive("screw_lead", lead_m);
    // An optional belt or gear between motor and screw: motor turns per screw turn.
    const double reduction = drive.number_or("gear_ratio", 1.0);
    drive.require_positive("gear_ratio", reduction);
    result.ratio = lead_m / (2.0 * kPi * reduction);
    result.friction_viscous_A_per_joint_unit_per_s = drive.number_or("friction_viscous_A_s_per_m", 0.0);
  } else {
    const double reduction = drive.number("gear_ratio");
    drive.require_positive("gear_ratio", reduction);
    result.ratio = 1.0 / reduction;
    result.friction_viscous_A_per_joint_unit_per_s =
        drive.number_or("friction_viscous_A_s_per_rad", 0.0);
  }
  result.equivalent_inertia_kg_m2 = drive.number("equivalent_inertia_kg_m2");
  result.rotor_inertia_kg_m2 = drive.number_or("rotor_inertia_kg_m2", 0.0);
  result.torque_constant_N_m_per_A = drive.number("torque_constant_N_m_per_A");
  result.friction_dry_A = drive.number_or("friction_dry_A", 0.0);
  result.torque_max_N_m = drive.number("torque_max_N_m");
  result.torque_rate_max_N_m_per_s = drive.number("torque_rate_max_N_m_per_s");
  drive.require_positive("equivalent_inertia_kg_m2", result.equivalent_inertia_kg_m2);
  drive.require_non_negative("rotor_inertia_kg_m2", result.rotor_inertia_kg_m2);
  if (result.rotor_inertia_kg_m2 > result.equivalent_inertia_kg_m2) {
    drive.fail("rotor_inertia_kg_m2 (" + format_number(result.rotor_inertia_kg_m2) +
               ") exceeds equivalent_inertia_kg_m2 (" +
               format_number(result.equivalent_inertia_kg_m2) + ")");
  }
  drive.require_positive("torque_constant_N_m_per_A", result.torque_constant_N_m_per_A);
  drive.require_non_negative("friction_viscous", result.friction_viscous_A_per_joint_unit_per_s);
  drive.require_non_negative("friction_dry_A", result.friction_dry_A);
  drive.require_positive("torque_max_N_m", result.torque_max_N_m);
  drive.require_positive("torque_rate_max_N_m_per_s", result.torque_rate_max_N_m_per_s);
  drive.reject_unknown_fields();
  return result;
}

template <typename Enum>
Enum read_choice(const FieldReader& reader, const std::string& key,
                 const std::vector<std::pair<std::string, Enum>>& choices, Enum fallback) {
  if (!reader.has(key)) return fallback;
  const FieldReader field = reader.child(key);
  const std::string text = field.as_string();
  std::string allowed;
  for (const auto& [name, value] : choices) {
    if (name == text) return value;
    allowed += (allowed.empty() ? "" : ", ") + name;
  }
  field.fail("'" + text + "' is not one of: " + allowed);
  return fallback;
}

// A small non-negative whole number of samples (a computation dead time).
int read_delay_samples(const FieldReader& reader, const std::string& key) {
  if (!reader.has(key)) return 1;
  const double value = reader.number(key);
  if (!(value >= 0.0 && value <= 8.0 && value == std::floor(value))) {
    reader.child(key).fail("'" + key + "' must be a whole number from 0 to 8, got " +
                           format_number(value));
  }
  return static_cast<int>(value);
}

Controller read_controller(const FieldReader& controller, const Axis& axis) {
  Controller result;
  {
    const FieldReader position = controller.child("position");
    result.position_gain_kv_per_s = position.quantity("kv", kPositionGain);
    result.position_period_s = position.quantity("period", kTime);
    position.require_positive("kv", result.position_gain_kv_per_s);
    position.require_positive("period", result.position_period_s);
    result.fine_interpolation = read_choice<FineInterpolation>(
        position, "fine_interpolation",
        {{"linear", FineInterpolation::linear}, {"cubic", FineInterpolation::cubic}},
        FineInterpolation::linear);
    result.position_feedback = read_choice<PositionFeedback>(
        position, "feedback", {{"motor", PositionFeedback::motor}, {"load", PositionFeedback::load}},
        PositionFeedback::motor);
    const UnitTable resolution_units =
        is_linear(axis) ? UnitTable{{"nm", 1e-9}, {"um", 1e-6}, {"mm", 1e-3}}
                        : UnitTable{{"arcsec", kPi / 648000.0}, {"deg", kPi / 180.0}};
    result.load_encoder_resolution =
        position.quantity_or("load_encoder_resolution", resolution_units, 0.0);
    position.require_non_negative("load_encoder_resolution", result.load_encoder_resolution);
    result.position_output_delay_samples = read_delay_samples(position, "output_delay_samples");
    result.position_output_dead_time_s = position.quantity_or("output_dead_time", kTime, -1.0);
    if (result.position_output_dead_time_s != -1.0) {
      position.require_non_negative("output_dead_time", result.position_output_dead_time_s);
      if (position.has("output_delay_samples")) {
        position.fail("give the position output delay once: output_delay_samples or "
                      "output_dead_time_<unit>");
      }
      result.position_output_delay_samples = 0;
    }
    position.reject_unknown_fields();
  }
  {
    const FieldReader velocity = controller.child("velocity");
    result.velocity_type = read_choice<VelocityControllerType>(
        velocity, "type", {{"P", VelocityControllerType::P}, {"PI", VelocityControllerType::PI}},
        VelocityControllerType::PI);
    result.velocity_gain_N_m_s_per_rad = velocity.number("gain_N_m_s_per_rad");
    velocity.require_positive("gain_N_m_s_per_rad", result.velocity_gain_N_m_s_per_rad);
    if (result.velocity_type == VelocityControllerType::PI) {
      result.velocity_integral_time_s = velocity.quantity("integral_time", kTime);
      velocity.require_positive("integral_time", result.velocity_integral_time_s);
    }
    result.velocity_period_s = velocity.quantity("period", kTime);
    velocity.require_positive("period", result.velocity_period_s);
    result.velocity_filter_time_s = velocity.quantity_or("filter_time", kTime, 0.0);
    velocity.require_non_negative("filter_time", result.velocity_filter_time_s);
    result.velocity_output_delay_samples = read_delay_samples(velocity, "output_delay_samples");
    velocity.reject_unknown_fields();
  }
  {
    const FieldReader current = controller.child("current");
    result.current_model = read_choice<CurrentLoopModel>(
        current, "model",
        {{"ideal", CurrentLoopModel::ideal},
         {"first_order", CurrentLoopModel::first_order},
         {"PI", CurrentLoopModel::PI}},
        CurrentLoopModel::first_order);
    if (result.current_model == CurrentLoopModel::first_order) {
      result.current_bandwidth_hz = current.number("bandwidth_hz");
      current.require_positive("bandwidth_hz", result.current_bandwidth_hz);
    }
    if (result.current_model == CurrentLoopModel::PI) {
      result.current_gain_V_per_A = current.number("gain_V_per_A");
      result.current_integral_time_s = current.quantity("integral_time", kTime);
      current.require_positive("gain_V_per_A", result.current_gain_V_per_A);
      current.require_positive("integral_time", result.current_integral_time_s);
      result.resistance_ohm = current.number("resistance_ohm");
      result.inductance_H = current.quantity("inductance", UnitTable{{"mH", 1e-3}, {"H", 1.0}});
      result.back_emf_V_s_per_rad = current.number_or("back_emf_V_s_per_rad", 0.0);
      result.voltage_max_V = current.number_or("voltage_max_V", 0.0);
      current.require_non_negative("resistance_ohm", result.resistance_ohm);
      current.require_positive("inductance", result.inductance_H);
      current.require_non_negative("back_emf_V_s_per_rad", result.back_emf_V_s_per_rad);
      current.require_non_negative("voltage_max_V", result.voltage_max_V);
      result.current_output_delay_samples = read_delay_samples(current, "output_delay_samples");
    }
    result.current_period_s = current.quantity_or("period", kTime, result.velocity_period_s);
    current.require_positive("period", result.current_period_s);
    current.reject_unknown_fields();
  }
  if (controller.has("feedforward")) {
    const FieldReader feedforward = controller.child("feedforward");
    result.velocity_feedforward = feedforward.boolean_or("velocity", false);
    result.velocity_feedforward_weight = feedforward.number_or("velocity_weight", 1.0);
    result.torque_feedforward = feedforward.boolean_or("torque", false);
    result.torque_feedforward_weight = feedforward.number_or("torque_weight", 1.0);
    result.balancing_type = read_choice<BalancingType>(
        feedforward, "balancing",
        {{"none", BalancingType::none},
         {"dead_time", BalancingType::dead_time},
         {"first_order_lag", BalancingType::first_order_lag}},
        BalancingType::none);
    result.balancing_time_s = feedforward.quantity_or("balancing_time", kTime, 0.0);
    result.feedforward_timing = read_choice<FeedforwardTiming>(
        feedforward, "timing",
        {{"interpolated", FeedforwardTiming::interpolated},
         {"held", FeedforwardTiming::held},
         {"held_backward", FeedforwardTiming::held_backward}},
        FeedforwardTiming::interpolated);
    feedforward.require_non_negative("velocity_weight", result.velocity_feedforward_weight);
    feedforward.require_non_negative("torque_weight", result.torque_feedforward_weight);
    feedforward.require_non_negative("balancing_time", result.balancing_time_s);
    if (result.balancing_type != BalancingType::none && result.balancing_time_s <= 0.0) {
      feedforward.fail("balancing '" + feedforward.string("balancing") +
                       "' needs balancing_time_<unit> > 0");
    }
    feedforward.reject_unknown_fields();
  }
  result.delay_s = controller.quantity_or("delay", kTime, 0.0);
  // A negative delay removes computation dead time the loops' output delays put in (a model
  // that is slower than the drive); it cannot remove more than they hold.
  const double removable_s =
      result.position_output_delay_samples * result.position_period_s +
      std::max(0.0, result.position_output_dead_time_s) +
      result.velocity_output_delay_samples * result.velocity_period_s;
  if (result.delay_s < -removable_s - 1e-12) {
    controller.fail("delay " + std::to_string(result.delay_s) +
                    " s: a negative delay removes at most the loops' output delays (" +
                    std::to_string(removable_s) + " s here)");
  }
  if (controller.has("saturation")) {
    const FieldReader saturation = controller.child("saturation");
    result.current_max_A = saturation.number_or("current_A", 0.0);
    result.velocity_max_rad_per_s = saturation.quantity_or("motor_speed", kMotorSpeed, 0.0);
    saturation.require_non_negative("current_A", result.current_max_A);
    saturation.require_non_negative("motor_speed", result.velocity_max_rad_per_s);
    saturation.reject_unknown_fields();
  }
  result.encoder_counts_per_rev = controller.number_or("encoder_counts_per_rev", 0.0);
  controller.require_non_negative("encoder_counts_per_rev", result.encoder_counts_per_rev);
  controller.reject_unknown_fields();
  return result;
}

// Plausibility bounds: beyond them a value is a slip of unit or a typo, not a machine. A rotary
// axis with a stop may turn a few turns (cables); 1000 turns each way is far beyond any.
constexpr double kLinearPositionLimit_m = 1000.0;
constexpr double kLinearTravelWarning_m = 50.0;
constexpr double kRotaryPositionLimit_rad = 1000.0 * 2.0 * kPi;
constexpr double kRotaryTravelWarning_rad = 100.0 * 2.0 * kPi;
constexpr double kPeriodLimit_s = 10.0;
constexpr double kPeriodWarningAbove_s = 0.1;
constexpr double kPeriodWarningBelow_s = 1e-5;

std::string position_in_file_unit(const Axis& axis, double value_si) {
  return is_linear(axis) ? format_number(value_si * 1e3) + " mm"
                         : format_number(value_si * 180.0 / kPi) + " deg";
}

// The reader of the field <name>_<unit> that is given (the axis reader itself when none is).
FieldReader field_with_unit(const FieldReader& reader, const std::string& name,
                            const UnitTable& units) {
  for (const auto& [suffix, factor] : units) {
    (void)factor;
    if (reader.has(name + "_" + suffix)) return reader.child(name + "_" + suffix);
  }
  return reader;
}

void check_travel_plausible(const FieldReader& at, const Axis& axis, const std::string& source,
                            std::vector<std::string>& warnings) {
  if (axis.continuous) return;
  const double limit = is_linear(axis) ? kLinearPositionLimit_m : kRotaryPositionLimit_rad;
  if (!(std::abs(axis.travel_min) <= limit && std::abs(axis.travel_max) <= limit)) {
    at.fail(source + " [" + position_in_file_unit(axis, axis.travel_min) + ", " +
            position_in_file_unit(axis, axis.travel_max) + "] is not plausible: " +
            (is_linear(axis)
                 ? "a linear axis travels at most 1 km each way (was m written for mm?)"
                 : "a rotary axis with stops turns at most 1000 turns (360000 deg) each way; "
                   "an endless axis is written continuous: true"));
  }
  const double warning = is_linear(axis) ? kLinearTravelWarning_m : kRotaryTravelWarning_rad;
  if (axis.travel_max - axis.travel_min > warning) {
    warnings.push_back(at.where(at.node()) + ": " + source + " [" +
                       position_in_file_unit(axis, axis.travel_min) + ", " +
                       position_in_file_unit(axis, axis.travel_max) + "] is unusually long (" +
                       (is_linear(axis) ? "more than 50 m" : "more than 100 turns") +
                       "): check the unit");
  }
}

Axis read_axis(const FieldReader& reader, MachineKind kind, std::vector<std::string>& warnings) {
  Axis axis;
  axis.name = reader.string("name");
  if (axis.name.empty()) reader.fail("axis name is empty");
  const FieldReader named = reader.for_axis(axis.name);
  axis.type = read_choice<AxisType>(named, "type",
                                    {{"linear", AxisType::linear}, {"rotary", AxisType::rotary}},
                                    AxisType::linear);
  if (!named.has("type")) named.fail("missing field 'type' (linear or rotary)");
  const UnitTable& position_units = is_linear(axis) ? UnitTable{{"mm", 1e-3}, {"m", 1.0}} : kAngle;
  axis.continuous = named.boolean_or("continuous", false);
  if (axis.continuous && is_linear(axis)) named.fail("a linear axis cannot be continuous");
  auto travel = named.range_with_unit("travel", position_units);
  if (travel) {
    axis.travel_min = travel->first;
    axis.travel_max = travel->second;
    check_travel_plausible(field_with_unit(named, "travel", position_units), axis,
                           "travel", warnings);
  } else if (!axis.continuous) {
    // Filled from the URDF joint limits where the structure is a URDF; checked after it.
    axis.travel_min = std::numeric_limits<double>::quiet_NaN();
    axis.travel_max = std::numeric_limits<double>::quiet_NaN();
  }
  axis.home = named.quantity_or("home", position_units, 0.0);
  if (std::abs(axis.home) > (is_linear(axis) ? kLinearPositionLimit_m : kRotaryPositionLimit_rad)) {
    field_with_unit(named, "home", position_units)
        .fail("home " + position_in_file_unit(axis, axis.home) + " is not plausible (unit?)");
  }
  if (travel && !axis.continuous && (axis.home < axis.travel_min || axis.home > axis.travel_max)) {
    named.fail("home position lies outside the travel");
  }
  axis.limits = read_limits(named.child("limits"), axis);
  axis.drive = read_drive(named.child("drive"), axis);
  axis.controller = read_controller(named.child("controller"), axis);
  if (named.has("effects")) axis.effects = read_drive_effects(named.child("effects"), axis, kind);
  named.reject_unknown_fields();
  return axis;
}

Eigen::Isometry3d read_origin(const FieldReader& reader) {
  Eigen::Isometry3d origin = Eigen::Isometry3d::Identity();
  if (reader.has("origin_mm")) origin.translation() = reader.child("origin_mm").as_vector3() * 1e-3;
  if (reader.has("origin_rpy_deg")) {
    const Eigen::Vector3d rpy = reader.child("origin_rpy_deg").as_vector3() * (kPi / 180.0);
    // URDF convention: fixed-axis roll about x, then pitch about y, then yaw about z.
    origin.linear() = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                       Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                       Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
                          .toRotationMatrix();
  }
  return origin;
}

RigidBody read_body(const FieldReader& reader) {
  RigidBody body;
  body.mass_kg = reader.number("mass_kg");
  reader.require_non_negative("mass_kg", body.mass_kg);
  if (reader.has("com_mm")) body.com_m = reader.child("com_mm").as_vector3() * 1e-3;
  if (reader.has("inertia_kg_m2")) {
    const FieldReader inertia = reader.child("inertia_kg_m2");
    const double ixx = inertia.number("ixx");
    const double iyy = inertia.number("iyy");
    const double izz = inertia.number("izz");
    const double ixy = inertia.number_or("ixy", 0.0);
    const double ixz = inertia.number_or("ixz", 0.0);
    const double iyz = inertia.number_or("iyz", 0.0);
    inertia.reject_unknown_fields();
    body.inertia_kg_m2 << ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz;
  }
  reader.reject_unknown_fields();
  return body;
}

Chain read_chain(const FieldReader& reader, MachineModel& model) {
  Chain chain;
  const std::size_t count = reader.sequence_size();
  for (std::size_t i = 0; i < count; ++i) {
    const FieldReader element = reader.element(i);
    Joint joint;
    if (element.has("joint") == element.has("fixed")) {
      element.fail("each chain element has either 'joint: <axis name>' or 'fixed: <label>'");
    }
    if (element.has("joint")) {
      joint.name = element.string("joint");
      joint.axis_index = model.axis_index(joint.name);
      if (joint.axis_index < 0) {
        element.child("joint").fail("no axis named '" + joint.name + "' in 'axes'");
      }
      joint.type = model.axes[static_cast<std::size_t>(joint.axis_index)].type == AxisType::linear
                       ? JointType::prismatic
                       : JointType::revolute;
      const FieldReader direction_field = element.child("direction");
      const Eigen::Vector3d direction = direction_field.as_vector3();
      if (direction.norm() < 1e-9) direction_field.fail("direction must not be the zero vector");
      joint.direction = direction.normalized();
    } else {
      joint.name = element.string("fixed");
    }
    joint.origin = read_origin(element);
    if (element.has("body")) joint.body = read_body(element.child("body"));
    element.reject_unknown_fields();
    chain.push_back(joint);
  }
  return chain;
}

void read_structure(const FieldReader& structure, MachineModel& model,
                    const std::string& base_directory) {
  if (structure.has("urdf")) {
    UrdfChainRequest request;
    request.path = structure.string("urdf");
    if (!std::filesystem::path(request.path).is_absolute()) {
      request.path = (std::filesystem::path(base_directory) / request.path).string();
    }
    request.base_link = structure.string("base_link");
    request.tip_link = structure.string("tip_link");
    if (structure.has("spindle")) request.tip_to_spindle = read_origin(structure.child("spindle"));
    if (structure.has("workpiece")) {
      request.base_to_workpiece = read_origin(structure.child("workpiece"));
    }
    structure.reject_unknown_fields();
    append_urdf_chain(request, model, structure.where(structure.node()));
    return;
  }
  model.workpiece_chain = read_chain(structure.child("workpiece_chain"), model);
  model.tool_chain = read_chain(structure.child("tool_chain"), model);
  structure.reject_unknown_fields();
}

}  // namespace

MachineModel parse_machine(const std::string& yaml_text, const std::string& file_name_for_messages,
                           const std::string& base_directory) {
  const YAML::Node root = parse_yaml_input(yaml_text, file_name_for_messages);
  if (!root.IsMap()) throw InputError(located_message(file_name_for_messages, 0, 0,
                                                      "a machine file is a YAML map"));
  const FieldReader top(root, file_name_for_messages, "", "");
  MachineModel model;
  model.source_file = file_name_for_messages;
  model.name = top.string("name");
  model.kind = read_choice<MachineKind>(
      top, "kind", {{"machine_tool", MachineKind::machine_tool}, {"robot", MachineKind::robot}},
      MachineKind::machine_tool);
  if (!top.has("kind")) top.fail("missing field 'kind' (machine_tool or robot)");
  model.interpolation_period_s = top.quantity("interpolation_period", kTime);
  top.require_positive("interpolation_period", model.interpolation_period_s);
  {
    // NC interpolators run at 0.1 to 20 ms: seconds are a slip of unit.
    const FieldReader period = field_with_unit(top, "interpolation_period", kTime);
    const std::string period_text = format_number(model.interpolation_period_s) + " s";
    if (model.interpolation_period_s > kPeriodLimit_s) {
      period.fail("an interpolation period of " + period_text +
                  " is not plausible (NC interpolators run at 0.1 to 20 ms; ms meant?)");
    }
    if (model.interpolation_period_s > kPeriodWarningAbove_s ||
        model.interpolation_period_s < kPeriodWarningBelow_s) {
      model.warnings.push_back(period.where(period.node()) + ": an interpolation period of " +
                               period_text +
                               " is unusual (NC interpolators run at 0.1 to 20 ms): check the unit");
    }
  }
  if (top.has("gravity_m_per_s2")) model.gravity_B_m_per_s2 = top.child("gravity_m_per_s2").as_vector3();

  const FieldReader axes = top.child("axes");
  const std::size_t axis_count = axes.sequence_size();
  if (axis_count == 0) axes.fail("a machine needs at least one axis");
  std::set<std::string> names;
  std::vector<bool> travel_in_machine_file(axis_count, false);
  for (std::size_t i = 0; i < axis_count; ++i) {
    const FieldReader axis_reader = axes.element(i);
    Axis axis = read_axis(axis_reader, model.kind, model.warnings);
    travel_in_machine_file[i] = axis.continuous || !std::isnan(axis.travel_min);
    if (!names.insert(axis.name).second) axis_reader.fail("duplicate axis name '" + axis.name + "'");
    model.axes.push_back(std::move(axis));
  }
  read_structure(top.child("structure"), model, base_directory);
  for (std::size_t i = 0; i < axis_count; ++i) {
    const Axis& axis = model.axes[i];
    if (!axis.continuous && std::isnan(axis.travel_min)) {
      axes.element(i).for_axis(axis.name).fail(
          "missing field 'travel_<unit>' (travel_mm, travel_deg, ...), or continuous: true for an "
          "endless rotary axis");
    }
    if (!travel_in_machine_file[i]) {
      check_travel_plausible(axes.element(i).for_axis(axis.name), axis,
                             "the travel taken from the URDF joint limits", model.warnings);
    }
    if (!axis.continuous && (axis.home < axis.travel_min || axis.home > axis.travel_max)) {
      axes.element(i).for_axis(axis.name).fail("home position lies outside the travel");
    }
  }
  top.reject_unknown_fields();
  validate_machine(model);
  return model;
}

MachineModel load_machine(const std::string& path) {
  const std::string text = read_file(path);
  const std::string directory = std::filesystem::path(path).parent_path().string();
  return parse_machine(text, path, directory.empty() ? "." : directory);
}

// ---------------------------------------------------------------------------------------------
// Invariants.

std::string inertia_tensor_problem(const Eigen::Matrix3d& inertia) {
  if (!inertia.allFinite()) return "the inertia tensor has a value that is not finite";
  if ((inertia - inertia.transpose()).norm() > 1e-12 * (1.0 + inertia.norm())) {
    return "the inertia tensor is not symmetric";
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(inertia);
  const Eigen::Vector3d principal = solver.eigenvalues();
  const double scale = 1e-9 * (1.0 + principal.cwiseAbs().maxCoeff());
  if (principal.minCoeff() < -scale) {
    return "the inertia tensor has a negative principal moment (" +
           format_number(principal.minCoeff()) + " kg m^2)";
  }
  // Triangle inequality of principal moments: no real body violates it.
  for (int i = 0; i < 3; ++i) {
    const double others = principal.sum() - principal[i];
    if (principal[i] > others + scale) {
      return "principal moments " + format_number(principal[0]) + ", " +
             format_number(principal[1]) + ", " + format_number(principal[2]) +
             " kg m^2 violate the triangle inequality (no physical body has them)";
    }
  }
  return "";
}

namespace {

void check_body(const MachineModel& model, const Joint& joint, const std::string& chain_name) {
  const std::string where = model.source_file + ": " + chain_name + " element '" + joint.name + "'";
  const Eigen::Matrix3d& inertia = joint.body.inertia_kg_m2;
  const std::string problem = inertia_tensor_problem(inertia);
  if (!problem.empty()) throw InputError(where + ": " + problem);
  const Eigen::Vector3d principal =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(inertia).eigenvalues();
  const double scale = 1e-9 * (1.0 + principal.cwiseAbs().maxCoeff());
  if (joint.body.mass_kg == 0.0 && principal.maxCoeff() > scale) {
    throw InputError(where + ": a body without mass cannot have inertia");
  }
}

}  // namespace

void validate_machine(const MachineModel& model) {
  const std::string& file = model.source_file;
  std::vector<int> moved_by(model.axes.size(), 0);
  auto check_chain = [&](const Chain& chain, const std::string& chain_name) {
    for (const Joint& joint : chain) {
      if (joint.type != JointType::fixed) {
        if (joint.axis_index < 0 || joint.axis_index >= static_cast<int>(model.axes.size())) {
          throw InputError(file + ": " + chain_name + " joint '" + joint.name +
                           "' does not name an axis");
        }
        ++moved_by[static_cast<std::size_t>(joint.axis_index)];
        if (std::abs(joint.direction.norm() - 1.0) > 1e-9) {
          throw InputError(file + ": " + chain_name + " joint '" + joint.name +
                           "': direction is not a unit vector");
        }
      }
      const Eigen::Matrix3d rotation = joint.origin.linear();
      if ((rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-9) {
        throw InputError(file + ": " + chain_name + " element '" + joint.name +
                         "': origin rotation is not orthonormal");
      }
      check_body(model, joint, chain_name);
    }
  };
  check_chain(model.workpiece_chain, "workpiece_chain");
  check_chain(model.tool_chain, "tool_chain");
  for (std::size_t i = 0; i < model.axes.size(); ++i) {
    if (moved_by[i] != 1) {
      throw InputError(file + ": axis " + model.axes[i].name + " is moved by " +
                       std::to_string(moved_by[i]) +
                       " joints of the structure; each axis must appear exactly once");
    }
  }
  if (model.kind == MachineKind::robot && model.tool_chain.empty()) {
    throw InputError(file + ": a robot needs a tool chain");
  }
}

}  // namespace vmsim::kinematics
