#pragma once
// The virtual PIC-SERVOs of the sequencer: servo::ServoBank (servo/servo_bank.hpp), which
// sirupp-sim also runs beside the physics. The names the control library has always used.

#include "servo/servo_bank.hpp"

namespace sirupp::control {

using JointDrive = servo::JointDrive;
using PicServo = servo::PicServo;
using ServoGains = servo::ServoGains;
using JointMove = servo::JointMove;
using ServoBank = servo::ServoBank;
using servo::GainsFromModel;

}  // namespace sirupp::control
