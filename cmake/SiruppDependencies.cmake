# Finds the Debian 12 packages installed by scripts/install-deps.sh. LCM 1.3.1 ships no CMake config and
# its lcm.pc needs glib's .pc, so LCM is found by hand (the C/C++ headers do not need glib).
find_package(Threads REQUIRED)
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(yaml-cpp REQUIRED)

find_path(LCM_INCLUDE_DIR lcm/lcm-cpp.hpp)
find_library(LCM_LIBRARY lcm)
find_program(LCM_GEN_EXECUTABLE lcm-gen)
if(NOT LCM_INCLUDE_DIR OR NOT LCM_LIBRARY OR NOT LCM_GEN_EXECUTABLE)
  message(FATAL_ERROR "LCM not found (need liblcm-dev and liblcm-bin): run scripts/install-deps.sh")
endif()
add_library(sirupp_lcm_external INTERFACE)
target_include_directories(sirupp_lcm_external SYSTEM INTERFACE ${LCM_INCLUDE_DIR})
target_link_libraries(sirupp_lcm_external INTERFACE ${LCM_LIBRARY} Threads::Threads)

if(SIRUPP_BUILD_JAVA)
  find_package(Java 1.8 COMPONENTS Development)
  find_file(LCM_JAR lcm.jar PATHS /usr/share/java /usr/local/share/java)
  if(NOT Java_FOUND OR NOT LCM_JAR)
    message(FATAL_ERROR "Java types jar needs a JDK and lcm.jar (default-jdk-headless, liblcm-java): "
                        "run scripts/install-deps.sh, or configure with -DSIRUPP_BUILD_JAVA=OFF")
  endif()
  include(UseJava)
endif()

if(SIRUPP_BUILD_TESTS)
  find_package(GTest REQUIRED)
  include(GoogleTest)
endif()

# ODE 0.16 (libode-dev): Debian builds it in double precision; ode/precision.h selects dDOUBLE.
find_path(ODE_INCLUDE_DIR ode/ode.h)
find_library(ODE_LIBRARY ode)
if(NOT ODE_INCLUDE_DIR OR NOT ODE_LIBRARY)
  message(FATAL_ERROR "ODE not found (need libode-dev): run scripts/install-deps.sh")
endif()
add_library(sirupp_ode_external INTERFACE)
target_include_directories(sirupp_ode_external SYSTEM INTERFACE ${ODE_INCLUDE_DIR})
target_link_libraries(sirupp_ode_external INTERFACE ${ODE_LIBRARY})

# OMPL 1.5 (libompl-dev): the planners of planning/. Its omplConfig.cmake names boost libraries
# that libompl-dev does not install and its ompl.pc has a NOTFOUND link directory, so the library
# is found by name and linked alone (docs/planning.md); its headers (and Boost's) as SYSTEM.
find_path(OMPL_INCLUDE_DIR ompl/config.h PATH_SUFFIXES ompl-1.5 ompl)
find_library(OMPL_LIBRARY ompl)
if(NOT OMPL_INCLUDE_DIR OR NOT OMPL_LIBRARY)
  message(FATAL_ERROR "OMPL not found (need libompl-dev): run scripts/install-deps.sh")
endif()
add_library(sirupp_ompl_external INTERFACE)
target_include_directories(sirupp_ompl_external SYSTEM INTERFACE ${OMPL_INCLUDE_DIR})
target_link_libraries(sirupp_ompl_external INTERFACE ${OMPL_LIBRARY})

# nlohmann::json (nlohmann-json3-dev, header-only) for the commands' --json output.
find_package(nlohmann_json 3 REQUIRED)

# CLI11 (libcli11-dev 2.1, header-only): the command line of every process and `sirupp` command
# (runtime/args.hpp). Its CLI11Config.cmake defines CLI11::CLI11.
find_package(CLI11 2.1 REQUIRED)
add_library(sirupp_cli11_external INTERFACE)
target_link_libraries(sirupp_cli11_external INTERFACE CLI11::CLI11)

# cpp-httplib (libcpp-httplib-dev) for sirupp-panel's HTTP server and event stream. Debian builds it
# as a library with OpenSSL, zlib and Brotli support: its pkg-config flags must be used as they are,
# since they change the layout of httplib::Request.
find_package(PkgConfig REQUIRED)
pkg_check_modules(CPPHTTPLIB IMPORTED_TARGET cpp-httplib)
if(NOT CPPHTTPLIB_FOUND)
  message(FATAL_ERROR "cpp-httplib not found (need libcpp-httplib-dev): run scripts/install-deps.sh")
endif()
add_library(sirupp_httplib_external INTERFACE)
target_link_libraries(sirupp_httplib_external INTERFACE PkgConfig::CPPHTTPLIB)

# TinyXML-2 (libtinyxml2-dev) for environment files; its CMake config defines tinyxml2::tinyxml2.
find_package(tinyxml2 REQUIRED)

# OpenCV 4 (libopencv-core-dev, -imgproc-dev, -imgcodecs-dev): the report's PNG plots. Debian ships
# OpenCVConfig.cmake only with the full libopencv-dev, so the three modules are found by hand.
if(NOT TARGET sirupp_opencv_external)
  find_path(OpenCV_CORE_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4)
  find_library(OpenCV_CORE_LIBRARY opencv_core)
  find_library(OpenCV_IMGPROC_LIBRARY opencv_imgproc)
  find_library(OpenCV_IMGCODECS_LIBRARY opencv_imgcodecs)
  if(NOT OpenCV_CORE_INCLUDE_DIR OR NOT OpenCV_CORE_LIBRARY OR NOT OpenCV_IMGPROC_LIBRARY
     OR NOT OpenCV_IMGCODECS_LIBRARY)
    message(FATAL_ERROR "OpenCV not found (need libopencv-core-dev, libopencv-imgproc-dev, "
                        "libopencv-imgcodecs-dev): run scripts/install-deps.sh")
  endif()
  add_library(sirupp_opencv_external INTERFACE)
  target_include_directories(sirupp_opencv_external SYSTEM INTERFACE ${OpenCV_CORE_INCLUDE_DIR})
  target_link_libraries(sirupp_opencv_external INTERFACE ${OpenCV_IMGCODECS_LIBRARY}
                        ${OpenCV_IMGPROC_LIBRARY} ${OpenCV_CORE_LIBRARY})
endif()

# MuJoCo (libmujoco-dev, `scripts/install-deps.sh --peers`) is a peer only, never a dependency:
# bench/ compares against it and tests/ use it as an oracle for the MJCF export; both build and
# run without it (the tests then skip, saying why).
find_package(mujoco QUIET)
if(mujoco_FOUND AND TARGET mujoco::mujoco)
  # Debian's mujoco config lists /usr/include/libqhull_r/ among its include directories although
  # MuJoCo's public headers never use qhull; CMake refuses an imported target whose include path
  # is missing, so keep only the directories that exist.
  get_target_property(sirupp_mujoco_includes mujoco::mujoco INTERFACE_INCLUDE_DIRECTORIES)
  set(sirupp_mujoco_existing "")
  foreach(dir IN LISTS sirupp_mujoco_includes)
    if(EXISTS "${dir}")
      list(APPEND sirupp_mujoco_existing "${dir}")
    endif()
  endforeach()
  set_target_properties(mujoco::mujoco PROPERTIES INTERFACE_INCLUDE_DIRECTORIES
                                                  "${sirupp_mujoco_existing}")
  message(STATUS "sirupp: MuJoCo ${mujoco_VERSION} found (benchmark peer, MJCF export oracle)")
else()
  message(STATUS "sirupp: MuJoCo not found (libmujoco-dev): bench_mujoco_check not built, "
                 "MJCF export tests skip")
endif()
