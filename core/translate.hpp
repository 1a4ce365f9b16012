#pragma once
// Pure translation between our value structs and the LCM message types: no network, no clocks, no
// state. ToMessage never fails. FromMessage checks what arrived (counts, finiteness, ranges, the
// model's physical validity) and throws MessageError naming the channel and the field, so a bad
// message is refused whole and never reaches the arm.

#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <string>

#include "core/arm_state.hpp"
#include "core/robot_model.hpp"

namespace sirupp::core {

sirupp::robot_model_t ToMessage(const RobotModel& model, int64_t utime, int64_t seq);
// Rebuilds the model as the sender loaded it; throws MessageError on anything FindModelProblem or
// the message's own consistency (array counts, enum values) rejects.
RobotModel RobotModelFromMessage(const sirupp::robot_model_t& message, const std::string& channel);

sirupp::arm_state_t ToMessage(const ArmState& state, int64_t seq);
// `expected_joints` < 0 accepts any joint count.
ArmState ArmStateFromMessage(const sirupp::arm_state_t& message, const std::string& channel,
                             int expected_joints);

sirupp::arm_command_t ToMessage(const ArmCommand& command, int64_t seq);
ArmCommand ArmCommandFromMessage(const sirupp::arm_command_t& message, const std::string& channel,
                                 int expected_joints);

}  // namespace sirupp::core
