// A library that says it is a SIRUPP controller (right ABI version) but exports no factory
// functions, for tests/test_plugin_controller.cpp: loading it must fail naming what is missing.
#include <sirupp/controller.h>

extern "C" __attribute__((visibility("default"))) int sirupp_controller_abi_version() {
  return SIRUPP_CONTROLLER_ABI_VERSION;
}
