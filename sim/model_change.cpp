#include "sim/model_change.hpp"

#include <cmath>
#include <stdexcept>

#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "sim/arm_world.hpp"

namespace sirupp::sim {
namespace {
constexpr const char* kChangedMark = " (changed: ";
}  // namespace

std::string ModelChange::Describe() const {
  std::string text;
  const auto add = [&text](const std::string& part) { text += (text.empty() ? "" : ", ") + part; };
  if (payload_kg != 0) add("payload " + core::FormatNumber(payload_kg) + " kg at the tool point");
  if (friction_scale != 1) add("friction x" + core::FormatNumber(friction_scale));
  if (gravity_off) add("gravity off");
  return text.empty() ? "none" : text;
}

void ApplyModelChange(core::RobotModel& model, const ModelChange& change) {
  if (!std::isfinite(change.payload_kg) || change.payload_kg < 0) {
    throw std::invalid_argument("payload " + core::FormatNumber(change.payload_kg) +
                                " kg: allowed a finite number >= 0");
  }
  if (!std::isfinite(change.friction_scale) || change.friction_scale < 0) {
    throw std::invalid_argument("friction scale " + core::FormatNumber(change.friction_scale) +
                                ": allowed a finite number >= 0");
  }
  if (change.empty()) return;
  if (change.payload_kg > 0 && model.links.size() > 1) {
    // A point mass at the tool point, merged into the last link (parallel-axis theorem).
    core::Link& link = model.links.back();
    const Eigen::Vector3d at = model.tool.position_m;
    const double total = link.mass_kg + change.payload_kg;
    const Eigen::Vector3d com = (link.mass_kg * link.com_m + change.payload_kg * at) / total;
    const auto shift = [](double mass, const Eigen::Vector3d& d) -> Eigen::Matrix3d {
      return mass * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
    };
    link.inertia_kg_m2 = link.inertia_kg_m2 + shift(link.mass_kg, link.com_m - com) +
                         shift(change.payload_kg, at - com);
    link.com_m = com;
    link.mass_kg = total;
  }
  for (core::Joint& joint : model.joints) {
    joint.friction.static_effort *= change.friction_scale;
    joint.friction.coulomb_positive *= change.friction_scale;
    joint.friction.coulomb_negative *= change.friction_scale;
    joint.friction.viscous *= change.friction_scale;
  }
  if (change.gravity_off) model.gravity_m_s2 = Eigen::Vector3d::Zero();
  model.description += kChangedMark + change.Describe() + ")";
}

bool HasModelChange(const core::RobotModel& model) {
  return model.description.find(kChangedMark) != std::string::npos;
}

const core::RobotModel& LoadModelText(ArmWorld& world, const std::string& text,
                                      const std::string& name) {
  const core::RobotModel model = core::ParseRobotModel(text, name);  // name:line on a bad file
  if (HasModelChange(world.model())) {
    throw std::invalid_argument("the running arm was changed at start (" +
                                world.model().description +
                                "): a loaded model would drop that; restart sirupp-sim instead");
  }
  try {
    world.ReplaceModel(model);
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(name + ": " + error.what());
  }
  return world.model();
}

}  // namespace sirupp::sim
