// sirupp: the command-line front of SIRUPP-LCM. All logic lives in tools/cli.cpp.
#include <exception>
#include <iostream>

#include "tools/cli.hpp"

int main(int argc, char** argv) {
  try {
    return sirupp::tools::RunCli(std::vector<std::string>(argv + 1, argv + argc), std::cout,
                                 std::cerr);
  } catch (const std::exception& error) {
    std::cerr << "sirupp: " << error.what() << "\n";
    return 1;
  }
}
