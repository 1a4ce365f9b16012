#pragma once
// Pure translation between our value structs and the LCM message types: no network, no clocks, no
// state. One pair per type in lcmtypes/ (tests/test_translate_pairs.cpp fails for a type without
// one, and round-trips each).
//  - ToMessage never fails and fills every count field from its array, so a message it builds
//    always encodes (the count-versus-array risk of core/bus.hpp is gone for its callers).
//  - XFromMessage(message, channel) checks what arrived once: counts against arrays, finiteness,
//    ranges, enum values (and for a model its physical validity). On the first problem it throws
//    MessageError "channel CHANNEL: field[i]: value is not allowed; expected ...", so a bad message
//    is refused whole and never reaches the arm. Checks that need the receiver's own state (the
//    model's joint count or limits, the mode) stay with the receiver.
// The value structs are in core/arm_state.hpp, core/robot_model.hpp, core/environment.hpp and
// core/messages.hpp.

#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/arm_ticks_t.hpp>
#include <sirupp/board_status_t.hpp>
#include <sirupp/channel_stats_t.hpp>
#include <sirupp/command_reply_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/estop_t.hpp>
#include <sirupp/hardware_command_t.hpp>
#include <sirupp/hardware_status_t.hpp>
#include <sirupp/heartbeat_t.hpp>
#include <sirupp/image_metadata_t.hpp>
#include <sirupp/image_t.hpp>
#include <sirupp/joint_model_t.hpp>
#include <sirupp/joint_target_t.hpp>
#include <sirupp/link_model_t.hpp>
#include <sirupp/logger_command_t.hpp>
#include <sirupp/logger_pass_t.hpp>
#include <sirupp/named_pose_t.hpp>
#include <sirupp/plan_command_t.hpp>
#include <sirupp/pose_target_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/servo_move_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <sirupp/shape_t.hpp>
#include <sirupp/sim_command_t.hpp>
#include <sirupp/sim_reset_t.hpp>
#include <sirupp/sim_status_t.hpp>
#include <sirupp/viewer_camera_t.hpp>
#include <string>

#include "core/arm_state.hpp"
#include "core/environment.hpp"
#include "core/messages.hpp"
#include "core/robot_model.hpp"

namespace sirupp::core {

// A receiver's own checks, the ones that need its model or state, in the From functions' words so
// that every refusal reads the same: "channel CHANNEL: FIELD: VALUE is not allowed; expected
// ALLOWED". RefuseValue throws that MessageError.
[[noreturn]] void RefuseValue(const std::string& channel, const std::string& field,
                              const std::string& value, const std::string& allowed);
// A message's joint count (`field`, e.g. "num_joints") against the receiver's model: refused unless
// count == expected_joints (the text says "expected N (the model's joints)").
void CheckJointCount(const std::string& channel, const std::string& field, size_t count,
                     int expected_joints);

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

// The parts of a robot model and an environment (`field` names the part in errors, e.g.
// "joints[2]"). Environment and environment_t are in core/environment.hpp.
sirupp::joint_model_t ToMessage(const Joint& joint);
Joint JointFromMessage(const sirupp::joint_model_t& message, const std::string& channel,
                       const std::string& field);
sirupp::link_model_t ToMessage(const Link& link);
Link LinkFromMessage(const sirupp::link_model_t& message, const std::string& channel,
                     const std::string& field);
sirupp::named_pose_t ToMessage(const NamedPose& pose);
NamedPose NamedPoseFromMessage(const sirupp::named_pose_t& message, const std::string& channel,
                               const std::string& field);
sirupp::shape_t ToMessage(const Shape& shape);
// Checks the type and the colours; sizes and pose are the receiver's (environment, model) to check.
Shape ShapeFromMessage(const sirupp::shape_t& message, const std::string& channel,
                       const std::string& field);

// Servo messages: set-points, moves, gains, joint targets.
sirupp::servo_setpoint_t ToMessage(const ServoSetpoint& setpoint);
ServoSetpoint ServoSetpointFromMessage(const sirupp::servo_setpoint_t& message,
                                       const std::string& channel);
sirupp::board_status_t ToMessage(const BoardStatus& status);
// `expected_joints` < 0 accepts any joint count (the arm's and the boards' must agree).
BoardStatus BoardStatusFromMessage(const sirupp::board_status_t& message,
                                   const std::string& channel, int expected_joints);
sirupp::arm_ticks_t ToMessage(const ArmTicks& ticks);
// Every state and set-point as on its own channel (`expected_joints` < 0: any, the same for all),
// the ticks in order (a state's tick not before the one before it).
ArmTicks ArmTicksFromMessage(const sirupp::arm_ticks_t& message, const std::string& channel,
                             int expected_joints);
sirupp::servo_move_t ToMessage(const ServoMove& move);
ServoMove ServoMoveFromMessage(const sirupp::servo_move_t& message, const std::string& channel);
sirupp::servo_gains_t ToMessage(const ServoGainsSet& gains);
// Counts and finiteness only; the chip's ranges for a model are servo::ChipGainsFromMessage's.
ServoGainsSet ServoGainsFromMessage(const sirupp::servo_gains_t& message,
                                    const std::string& channel);
sirupp::joint_target_t ToMessage(const JointTarget& target);
JointTarget JointTargetFromMessage(const sirupp::joint_target_t& message,
                                   const std::string& channel);

// Commands to the controller, the bridge, the sim and the viewer.
sirupp::pose_target_t ToMessage(const PoseTarget& target);
// The orientation must be a unit quaternion (norm 1 +- 0.001) unless position_only; speed_scale
// in (0, 1], or 0 for 1.
PoseTarget PoseTargetFromMessage(const sirupp::pose_target_t& message, const std::string& channel);
sirupp::plan_command_t ToMessage(const PlanCommand& command);
PlanCommand PlanCommandFromMessage(const sirupp::plan_command_t& message,
                                   const std::string& channel);
sirupp::hardware_command_t ToMessage(const HardwareCommand& command);
HardwareCommand HardwareCommandFromMessage(const sirupp::hardware_command_t& message,
                                           const std::string& channel);
sirupp::estop_t ToMessage(const EStop& estop);
EStop EStopFromMessage(const sirupp::estop_t& message, const std::string& channel);
sirupp::sim_command_t ToMessage(const SimCommand& command);
SimCommand SimCommandFromMessage(const sirupp::sim_command_t& message, const std::string& channel);
sirupp::logger_command_t ToMessage(const LoggerCommand& command);
LoggerCommand LoggerCommandFromMessage(const sirupp::logger_command_t& message,
                                       const std::string& channel);
sirupp::logger_pass_t ToMessage(const LoggerPass& pass);
// taken >= 0, last 0 or 1.
LoggerPass LoggerPassFromMessage(const sirupp::logger_pass_t& message, const std::string& channel);
sirupp::sim_reset_t ToMessage(const SimReset& reset);
// velocity: empty or as many as position.
SimReset SimResetFromMessage(const sirupp::sim_reset_t& message, const std::string& channel);
sirupp::viewer_camera_t ToMessage(const ViewerCamera& camera);
// distance > 0 when set_camera.
ViewerCamera ViewerCameraFromMessage(const sirupp::viewer_camera_t& message,
                                     const std::string& channel);

// Status and replies.
sirupp::controller_status_t ToMessage(const ControllerStatus& status);
ControllerStatus ControllerStatusFromMessage(const sirupp::controller_status_t& message,
                                             const std::string& channel);
sirupp::hardware_status_t ToMessage(const HardwareStatus& status);
HardwareStatus HardwareStatusFromMessage(const sirupp::hardware_status_t& message,
                                         const std::string& channel);
sirupp::sim_status_t ToMessage(const SimStatus& status);
SimStatus SimStatusFromMessage(const sirupp::sim_status_t& message, const std::string& channel);
sirupp::command_reply_t ToMessage(const CommandReply& reply);
// A refusal must say why (error not empty).
CommandReply CommandReplyFromMessage(const sirupp::command_reply_t& message,
                                     const std::string& channel);
sirupp::channel_stats_t ToMessage(const ChannelTraffic& traffic);
ChannelTraffic ChannelTrafficFromMessage(const sirupp::channel_stats_t& message,
                                         const std::string& channel, const std::string& field);
sirupp::heartbeat_t ToMessage(const HeartbeatReport& heartbeat);
HeartbeatReport HeartbeatFromMessage(const sirupp::heartbeat_t& message,
                                     const std::string& channel);

// Images as sent (viewer/image_codec.hpp decodes the pixels).
sirupp::image_metadata_t ToMessage(const ImageMetadata& metadata);
ImageMetadata ImageMetadataFromMessage(const sirupp::image_metadata_t& message,
                                       const std::string& channel, const std::string& field);
sirupp::image_t ToMessage(const Image& image);
Image ImageFromMessage(const sirupp::image_t& message, const std::string& channel);

}  // namespace sirupp::core
