// URDF import of a serial chain (urdfdom), for robots users bring in their own description.
#include <urdf_model/model.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "machine_loader_internal.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::kinematics {
namespace {

Eigen::Isometry3d to_isometry(const urdf::Pose& pose) {
  Eigen::Isometry3d result = Eigen::Isometry3d::Identity();
  result.translation() = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  result.linear() =
      Eigen::Quaterniond(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z)
          .normalized()
          .toRotationMatrix();
  return result;
}

RigidBody to_body(const urdf::InertialSharedPtr& inertial) {
  RigidBody body;
  if (!inertial) return body;
  body.mass_kg = inertial->mass;
  const Eigen::Isometry3d X_link_inertial = to_isometry(inertial->origin);
  body.com_m = X_link_inertial.translation();
  Eigen::Matrix3d inertia;
  inertia << inertial->ixx, inertial->ixy, inertial->ixz, inertial->ixy, inertial->iyy,
      inertial->iyz, inertial->ixz, inertial->iyz, inertial->izz;
  // URDF gives the tensor about the com in the inertial frame; the model wants the joint frame.
  const Eigen::Matrix3d R = X_link_inertial.linear();
  body.inertia_kg_m2 = R * inertia * R.transpose();
  return body;
}

}  // namespace

void append_urdf_chain(const UrdfChainRequest& request, MachineModel& model,
                       const std::string& context) {
  std::error_code error;  // (a name too long for the file system throws without one)
  if (!std::filesystem::exists(request.path, error)) {
    throw InputError(context + ": URDF file '" + request.path + "' does not exist" +
                     (error ? " (" + error.message() + ")" : std::string()));
  }
  // Read through read_file (regular files only, size cap) and checked by vmsim itself before
  // urdfdom sees it: urdfdom drops what it cannot read and would loop on a cycle.
  const std::string file_content = read_file(request.path);
  const std::string_view urdf_text = strip_utf8_bom(file_content);
  std::vector<std::string> warnings = check_urdf_text(urdf_text, request.path);
  model.warnings.insert(model.warnings.end(), warnings.begin(), warnings.end());
  const urdf::ModelInterfaceSharedPtr urdf_model = urdf::parseURDF(std::string(urdf_text));
  if (!urdf_model) {
    throw InputError(located_message(request.path, 0, 0, "not a valid URDF (urdfdom could not parse it)"));
  }
  if (!urdf_model->getLink(request.base_link)) {
    throw InputError(context + ": base_link '" + request.base_link + "' is not a link of " +
                     request.path);
  }
  urdf::LinkConstSharedPtr link = urdf_model->getLink(request.tip_link);
  if (!link) {
    throw InputError(context + ": tip_link '" + request.tip_link + "' is not a link of " +
                     request.path);
  }
  // Walk from the tip up to the base, then reverse.
  std::vector<urdf::LinkConstSharedPtr> links;
  while (link && link->name != request.base_link) {
    links.push_back(link);
    link = link->getParent();
  }
  if (!link) {
    throw InputError(context + ": tip_link '" + request.tip_link + "' does not descend from '" +
                     request.base_link + "' in " + request.path);
  }
  std::reverse(links.begin(), links.end());

  Chain chain;
  for (const urdf::LinkConstSharedPtr& child : links) {
    const urdf::JointSharedPtr& urdf_joint = child->parent_joint;
    Joint joint;
    joint.name = urdf_joint->name;
    joint.origin = to_isometry(urdf_joint->parent_to_joint_origin_transform);
    joint.body = to_body(child->inertial);
    switch (urdf_joint->type) {
      case urdf::Joint::FIXED:
        joint.type = JointType::fixed;
        break;
      case urdf::Joint::REVOLUTE:
      case urdf::Joint::CONTINUOUS:
        joint.type = JointType::revolute;
        break;
      case urdf::Joint::PRISMATIC:
        joint.type = JointType::prismatic;
        break;
      default:
        throw InputError(context + ": URDF joint '" + urdf_joint->name +
                         "' is neither fixed, revolute, continuous nor prismatic");
    }
    if (joint.type != JointType::fixed) {
      joint.axis_index = model.axis_index(joint.name);
      if (joint.axis_index < 0) {
        throw InputError(context + ": URDF joint '" + joint.name +
                         "' has no axis of that name in 'axes'");
      }
      Axis& axis = model.axes[static_cast<std::size_t>(joint.axis_index)];
      const bool linear = joint.type == JointType::prismatic;
      if (linear != (axis.type == AxisType::linear)) {
        throw InputError(context + ": URDF joint '" + joint.name + "' is " +
                         (linear ? "prismatic" : "revolute") + " but axis " + axis.name + " is " +
                         (axis.type == AxisType::linear ? "linear" : "rotary"));
      }
      const Eigen::Vector3d direction(urdf_joint->axis.x, urdf_joint->axis.y, urdf_joint->axis.z);
      if (direction.norm() < 1e-9) {
        throw InputError(context + ": URDF joint '" + joint.name + "' has a zero axis");
      }
      joint.direction = direction.normalized();
      if (std::isnan(axis.travel_min)) {
        if (urdf_joint->type == urdf::Joint::CONTINUOUS) {
          axis.continuous = true;
        } else if (urdf_joint->limits && urdf_joint->limits->lower < urdf_joint->limits->upper) {
          axis.travel_min = urdf_joint->limits->lower;
          axis.travel_max = urdf_joint->limits->upper;
        }
      }
    }
    chain.push_back(joint);
  }
  Joint spindle;
  spindle.name = "spindle";
  spindle.origin = request.tip_to_spindle;
  chain.push_back(spindle);
  model.tool_chain = std::move(chain);

  Joint workpiece;
  workpiece.name = "workpiece";
  workpiece.origin = request.base_to_workpiece;
  model.workpiece_chain = {workpiece};
}

}  // namespace vmsim::kinematics
