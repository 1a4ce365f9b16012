# Helpers that keep every folder's CMakeLists.txt to a few lines.

# Unity builds (docs/developing.md, "Build"): a library's sources compiled a few at a time as one
# translation unit, so the headers they share (Eigen, nlohmann/json, CLI11, cpp-httplib, the
# messages) are parsed and their templates instantiated once per batch instead of once per file.
option(SIRUPP_UNITY_BUILD "Compile each library's sources in batches (less CPU, docs/developing.md)" ON)
set(SIRUPP_UNITY_BATCH 6 CACHE STRING "Sources per unity batch (SIRUPP_UNITY_BUILD)")

# sirupp_add_library(<name> SOURCES <...> DEPS <...> [NO_UNITY])
#   A static library whose public headers live in the folder itself, included as
#   "<folder>/<header>.hpp" from the source root. Its sources are compiled in unity batches
#   (SIRUPP_UNITY_BUILD), so names in a file's anonymous namespace must not repeat in another
#   file of the folder; NO_UNITY compiles a folder file by file.
function(sirupp_add_library name)
  cmake_parse_arguments(ARG "NO_UNITY" "" "SOURCES;DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(${name} PUBLIC ${ARG_DEPS})
  sirupp_set_warnings(${name})
  if(SIRUPP_UNITY_BUILD AND NOT ARG_NO_UNITY)
    set_target_properties(${name} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE ${SIRUPP_UNITY_BATCH})
  endif()
endfunction()

# sirupp_add_executable(<name> SOURCES <...> DEPS <...>): a thin process main.
function(sirupp_add_executable name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS})
  sirupp_set_warnings(${name})
endfunction()

# sirupp_add_test(<name> [DEPS <libs...>] [SOURCES <extra...>])
#   One line per test file: builds tests/<name>.cpp with GoogleTest against the given libraries and
#   registers every TEST in it with CTest. Tests run from the source root, so paths like
#   config/robots/puma260.yaml work as written.
# SERIAL: the test's cases run alone (RUN_SERIAL), for tests that keep real-time pace with a
# thread or process of their own (the PIC-SERVO emulator) and would starve beside other tests.
function(sirupp_add_test name)
  cmake_parse_arguments(ARG "SERIAL" "" "DEPS;SOURCES" ${ARGN})
  add_executable(${name} ${name}.cpp ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main)
  sirupp_set_warnings(${name})
  set(serial FALSE)
  if(ARG_SERIAL)
    set(serial TRUE)
  endif()
  gtest_discover_tests(${name}
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    PROPERTIES ENVIRONMENT "SIRUPP_BIN_DIR=${CMAKE_BINARY_DIR}/bin" RUN_SERIAL ${serial}
    DISCOVERY_TIMEOUT 30)
endfunction()
