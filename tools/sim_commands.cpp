#include "tools/sim_commands.hpp"

#include <chrono>
#include <ostream>

#include "client/client.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "runtime/args.hpp"
#include "tools/cli.hpp"
#include "tools/rig_args.hpp"

namespace sirupp::tools {

const char* const kResetAbout =
    "  Teleports the arm in a running sirupp-sim: every joint to the given position, at rest.\n"
    "  --pose: a named pose of the model (default model config/robots/puma260.yaml); --deg:\n"
    "  revolute joints in degrees, --rad: in radians, prismatic joints in metres either way.\n"
    "  --objects: also put the environment's free objects back where their file placed them.\n"
    "  The sim refuses positions outside the joint limits (see its heartbeat or stderr).\n";

int RunReset(const std::vector<std::string>& args, std::ostream& out) {
  const runtime::Args parsed(
      args, "reset",
      WithJointFlags({runtime::ModelFlag(),
                      runtime::Flag("objects", "reset the free objects too").Switch(),
                      runtime::Flag("lcm-url", "LCM URL").Takes("URL"),
                      runtime::Flag("prefix", "channel prefix of the rig").Takes("PREFIX")}),
      kResetAbout);
  const core::RobotModel model = ModelFromArgs(parsed);
  const std::vector<double> position = PositionsFromArgs(parsed, model, "reset");
  const bool objects = parsed.Switch("objects");
  core::Bus bus = BusFromArgs(parsed);
  client::Options options;
  options.sender = "sirupp reset";
  client::Client rig(bus, options);
  rig.ResetSim(position, objects);
  PrintSent(out, bus, rig.channels().sim_reset, model, position);
  out << (objects ? ", objects reset" : "") << "\n";
  return 0;
}

}  // namespace sirupp::tools
