// A controller library built against a (pretend) newer controller.h, for
// tests/test_plugin_controller.cpp: loading it must fail naming both versions, and its factory
// must never be called (create returns null without an error text, which the test would notice).
#include <sirupp/controller.h>

extern "C" __attribute__((visibility("default"))) int sirupp_controller_abi_version() {
  return SIRUPP_CONTROLLER_ABI_VERSION + 1;
}

extern "C" __attribute__((visibility("default"))) sirupp::Controller* sirupp_controller_create(
    const char* /*args*/, char* /*error*/, std::size_t /*error_size*/) {
  return nullptr;
}

extern "C" __attribute__((visibility("default"))) void sirupp_controller_destroy(
    sirupp::Controller* controller) {
  delete controller;
}
