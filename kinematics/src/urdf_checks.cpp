// Checks of a URDF's text made before urdfdom reads it. urdfdom silently drops a block whose
// numbers it cannot read (a `<mass value="nan"/>` leaves a massless link), recurses once per
// nesting level of the XML (100 000 levels overflow the stack), and a joint graph with a cycle
// makes the chain walk loop for ever: each is refused here with the file, line and element.
#include <tinyxml.h>

#include <Eigen/Core>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <sstream>

#include "machine_loader_internal.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/kinematics/yaml_input.hpp"

namespace vmsim::kinematics {
namespace {

constexpr double kPi = std::numbers::pi;
// Plausibility bounds: beyond them a URDF value is a slip of unit or a typo, not a robot.
constexpr double kDistanceLimit_m = 1000.0;
constexpr double kAngleLimit_rad = 1000.0;
constexpr double kMassLimit_kg = 1e6;
constexpr double kLinearLimit_m = 1000.0;                  // as a machine file's travel
constexpr double kRotaryLimit_rad = 1000.0 * 2.0 * kPi;   // 1000 turns

// Reports at an element: "file:line:column: <mass> of link 'arm': message".
class ElementReporter {
 public:
  ElementReporter(const std::string& file, const TiXmlElement& element)
      : file_(file), element_(element) {}

  std::string where() const {
    std::string context = "<" + element_.ValueStr() + ">";
    for (const TiXmlNode* up = element_.Parent(); up != nullptr; up = up->Parent()) {
      const TiXmlElement* owner = up->ToElement();
      if (owner == nullptr) continue;
      if (owner->ValueStr() == "link" || owner->ValueStr() == "joint") {
        const char* name = owner->Attribute("name");
        context += " of " + owner->ValueStr() + " '" + (name ? name : "?") + "'";
        break;
      }
    }
    if (element_.ValueStr() == "link" || element_.ValueStr() == "joint") {
      const char* name = element_.Attribute("name");
      if (name) context += " '" + std::string(name) + "'";
    }
    return located_message(file_, element_.Row(), element_.Column(), context);
  }

  [[noreturn]] void fail(const std::string& message) const {
    throw InputError(where() + ": " + message);
  }

  /// The numbers of attribute `name` (exactly `count`); nullopt-like empty vector when absent.
  std::vector<double> numbers(const char* name, std::size_t count, bool required) const {
    const char* text = element_.Attribute(name);
    if (text == nullptr) {
      if (required) fail("attribute " + std::string(name) + " is missing");
      return {};
    }
    std::istringstream words{std::string(text)};
    std::vector<double> values;
    std::string word;
    while (words >> word) {
      const NumberText number = parse_number_text(word);
      if (!number.ok) {
        fail(std::string(name) + "=\"" + text + "\": '" + word + "' " + number.problem);
      }
      values.push_back(number.value);
    }
    if (values.size() != count) {
      fail(std::string(name) + "=\"" + text + "\": expected " + std::to_string(count) +
           (count == 1 ? " number" : " numbers") + ", got " + std::to_string(values.size()));
    }
    return values;
  }

  std::string text(const char* name) const {
    const char* value = element_.Attribute(name);
    return value ? value : "";
  }

 private:
  const std::string& file_;
  const TiXmlElement& element_;
};

std::string number_text(double value) { return format_number(value); }

void check_origin(const ElementReporter& at, std::vector<std::string>& warnings) {
  for (double value : at.numbers("xyz", 3, false)) {
    if (std::abs(value) > kDistanceLimit_m) {
      at.fail("xyz holds " + number_text(value) + " m: not a plausible distance (at most 1 km)");
    }
  }
  for (double value : at.numbers("rpy", 3, false)) {
    if (std::abs(value) > kAngleLimit_rad) {
      at.fail("rpy holds " + number_text(value) + " rad: not a plausible angle");
    }
    if (std::abs(value) > 2.0 * kPi + 1e-9) {
      warnings.push_back(at.where() + ": rpy holds " + number_text(value) +
                         ", more than a turn: URDF angles are in radians (degrees written?)");
    }
  }
}

void check_inertia(const ElementReporter& at) {
  const double ixx = at.numbers("ixx", 1, true)[0];
  const double iyy = at.numbers("iyy", 1, true)[0];
  const double izz = at.numbers("izz", 1, true)[0];
  const double ixy = at.numbers("ixy", 1, true)[0];
  const double ixz = at.numbers("ixz", 1, true)[0];
  const double iyz = at.numbers("iyz", 1, true)[0];
  Eigen::Matrix3d inertia;
  inertia << ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz;
  const std::string problem = inertia_tensor_problem(inertia);
  if (!problem.empty()) at.fail(problem);
}

void check_limit(const ElementReporter& at, const std::string& joint_type) {
  const std::vector<double> lower = at.numbers("lower", 1, false);
  const std::vector<double> upper = at.numbers("upper", 1, false);
  for (const char* name : {"effort", "velocity"}) {
    const std::vector<double> value = at.numbers(name, 1, false);
    if (!value.empty() && value[0] < 0.0) {
      at.fail(std::string(name) + "=\"" + at.text(name) + "\" must be >= 0");
    }
  }
  const bool linear = joint_type == "prismatic";
  const double bound = linear ? kLinearLimit_m : kRotaryLimit_rad;
  for (const auto* value : {&lower, &upper}) {
    if (!value->empty() && std::abs(value->front()) > bound) {
      at.fail((value == &lower ? "lower" : "upper") + std::string("=\"") +
              at.text(value == &lower ? "lower" : "upper") + "\" is not a plausible joint limit (" +
              (linear ? "at most 1 km each way" : "at most 1000 turns each way, in rad") + ")");
    }
  }
  if (!lower.empty() && !upper.empty() && lower[0] > upper[0]) {
    at.fail("lower=\"" + at.text("lower") + "\" is above upper=\"" + at.text("upper") + "\"");
  }
}

void check_element(const std::string& file, const TiXmlElement& element,
                   std::vector<std::string>& warnings) {
  const ElementReporter at(file, element);
  const std::string& name = element.ValueStr();
  if (name == "origin") {
    check_origin(at, warnings);
  } else if (name == "mass") {
    const double mass_kg = at.numbers("value", 1, true)[0];
    if (!(mass_kg > 0.0)) at.fail("value=\"" + at.text("value") + "\": a mass must be > 0 kg");
    if (mass_kg > kMassLimit_kg) {
      at.fail("value=\"" + at.text("value") + "\" kg is not a plausible link mass");
    }
  } else if (name == "inertia") {
    check_inertia(at);
  } else if (name == "inertial") {
    if (element.FirstChildElement("mass") == nullptr) at.fail("an <inertial> needs a <mass>");
  } else if (name == "axis") {
    const std::vector<double> xyz = at.numbers("xyz", 3, true);
    if (!(Eigen::Vector3d(xyz[0], xyz[1], xyz[2]).norm() > 1e-9)) {
      at.fail("xyz=\"" + at.text("xyz") + "\": the axis must not be the zero vector");
    }
  } else if (name == "limit") {
    const TiXmlElement* joint = element.Parent() ? element.Parent()->ToElement() : nullptr;
    const char* type = joint ? joint->Attribute("type") : nullptr;
    check_limit(at, type ? type : "");
  } else if (name == "dynamics") {
    at.numbers("damping", 1, false);
    at.numbers("friction", 1, false);
  }
}

struct JointEdge {
  std::string joint;
  std::string parent;
  int line = 0;
};

// Each link has at most one parent joint, and following parents never comes back: a tree.
void check_joint_graph(const std::string& file, const TiXmlElement& robot) {
  std::map<std::string, JointEdge> parent_of;  // child link -> its joint
  for (const TiXmlElement* joint = robot.FirstChildElement("joint"); joint != nullptr;
       joint = joint->NextSiblingElement("joint")) {
    const ElementReporter at(file, *joint);
    const TiXmlElement* parent = joint->FirstChildElement("parent");
    const TiXmlElement* child = joint->FirstChildElement("child");
    if (!parent || !parent->Attribute("link") || !child || !child->Attribute("link")) {
      at.fail("a joint needs <parent link=\"...\"/> and <child link=\"...\"/>");
    }
    const std::string child_link = child->Attribute("link");
    const JointEdge edge{at.text("name"), parent->Attribute("link"), joint->Row()};
    if (edge.parent == child_link) at.fail("link '" + child_link + "' is its own parent");
    const auto [earlier, inserted] = parent_of.emplace(child_link, edge);
    if (!inserted) {
      at.fail("link '" + child_link + "' already has a parent, joint '" + earlier->second.joint +
              "' on line " + std::to_string(earlier->second.line) +
              ": a URDF is a tree, each link has one parent");
    }
  }
  // Walk up from every link; a link met twice on one walk closes a cycle. Links whose walk
  // already ended at a root are not walked again: linear in the number of joints.
  std::set<std::string> reaches_root;
  for (const auto& [start, unused] : parent_of) {
    (void)unused;
    std::vector<std::string> walk;
    std::set<std::string> on_walk;
    std::string link = start;
    while (!reaches_root.count(link)) {
      if (!on_walk.insert(link).second) {
        const JointEdge& edge = parent_of.at(link);
        std::string cycle;
        for (auto it = std::find(walk.begin(), walk.end(), link); it != walk.end(); ++it) {
          cycle += *it + " -> ";
        }
        throw InputError(located_message(file, edge.line, 0,
                                         "<joint> '" + edge.joint + "': the joints form a cycle (" +
                                             cycle + link +
                                             ", child to parent): a URDF is a tree"));
      }
      walk.push_back(link);
      const auto up = parent_of.find(link);
      if (up == parent_of.end()) break;  // a root
      link = up->second.parent;
    }
    reaches_root.insert(walk.begin(), walk.end());
  }
}

}  // namespace

void check_xml_nesting(std::string_view text, const std::string& file, int max_depth) {
  // One pass over the text, no recursion: the XML parsers after it recurse once per level.
  int depth = 0;
  int line = 1;
  std::size_t i = 0;
  const auto skip_past = [&](std::string_view end) {
    const std::size_t found = text.find(end, i);
    const std::size_t stop = found == std::string_view::npos ? text.size() : found + end.size();
    for (; i < stop; ++i) line += text[i] == '\n';
  };
  while (i < text.size()) {
    if (text[i] == '\n') ++line;
    if (text[i] != '<') {
      ++i;
      continue;
    }
    const std::string_view rest = text.substr(i);
    if (rest.starts_with("<!--")) {
      skip_past("-->");
    } else if (rest.starts_with("<![CDATA[")) {
      skip_past("]]>");
    } else if (rest.starts_with("<?")) {
      skip_past("?>");
    } else if (rest.starts_with("<!")) {
      // A declaration (DOCTYPE); its internal subset [...] may hold '>'.
      int brackets = 0;
      for (; i < text.size(); ++i) {
        line += text[i] == '\n';
        if (text[i] == '[') ++brackets;
        if (text[i] == ']') --brackets;
        if (text[i] == '>' && brackets <= 0) break;
      }
      ++i;
    } else if (rest.starts_with("</")) {
      --depth;
      skip_past(">");
    } else {
      // A start tag: to its '>', outside quoted attribute values.
      const int tag_line = line;
      char quote = 0;
      char previous = 0;
      for (++i; i < text.size(); ++i) {
        const char c = text[i];
        line += c == '\n';
        if (quote != 0) {
          if (c == quote) quote = 0;
        } else if (c == '"' || c == '\'') {
          quote = c;
        } else if (c == '>') {
          break;
        }
        if (!std::isspace(static_cast<unsigned char>(c))) previous = c;
      }
      ++i;
      if (previous != '/' && ++depth > max_depth) {
        throw InputError(located_message(
            file, tag_line, 0,
            "the XML elements nest more than " + std::to_string(max_depth) +
                " deep; no URDF needs that (refused before parsing: the parser would overflow)"));
      }
    }
  }
}

std::vector<std::string> check_urdf_text(std::string_view text, const std::string& file) {
  check_xml_nesting(text, file, kUrdfNestingLimit);
  TiXmlDocument document;
  document.SetTabSize(1);
  document.Parse(std::string(text).c_str(), nullptr, TIXML_ENCODING_UTF8);
  if (document.Error()) {
    throw InputError(located_message(file, document.ErrorRow(), document.ErrorCol(),
                                     std::string("not well-formed XML: ") + document.ErrorDesc()));
  }
  const TiXmlElement* robot = document.RootElement();
  if (robot == nullptr || robot->ValueStr() != "robot") {
    throw InputError(located_message(file, robot ? robot->Row() : 0, robot ? robot->Column() : 0,
                                     "a URDF's root element is <robot>"));
  }
  std::vector<std::string> warnings;
  // Every element, depth first; the nesting is bounded above, an explicit stack anyway.
  std::vector<const TiXmlElement*> pending{robot};
  while (!pending.empty()) {
    const TiXmlElement* element = pending.back();
    pending.pop_back();
    check_element(file, *element, warnings);
    // Children pushed last first, so that the first bad element in the file is reported.
    std::vector<const TiXmlElement*> children;
    for (const TiXmlElement* child = element->FirstChildElement(); child != nullptr;
         child = child->NextSiblingElement()) {
      children.push_back(child);
    }
    pending.insert(pending.end(), children.rbegin(), children.rend());
  }
  check_joint_graph(file, *robot);
  return warnings;
}

}  // namespace vmsim::kinematics
