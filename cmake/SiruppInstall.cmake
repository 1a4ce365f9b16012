# What `cmake --install` (and so the Debian package, cmake/SiruppPackage.cmake) puts where, in
# Debian's layout (docs/install.md):
#   <prefix>/bin                          the programs (they find each other beside themselves)
#   <prefix>/share/sirupp                 models, environments, plans, lab layouts, grading suites
#                                         (config/), the panel's and the class server's pages,
#                                         the controller header, notebooks, examples, the LCM types
#   <prefix>/include/sirupp/controller.h  the controller header where a compiler finds it (and
#                                         student_planner.h, the planner header)
#   <prefix>/lib/python3/dist-packages    the Python module, for Debian's /usr/bin/python3
# Installed programs find the shipped files in <prefix>/share/sirupp by their own place
# (runtime/data_path.hpp), so the same build runs from the build tree and installed.
# Tests, benchmarks and the examples' programs are not installed.

set(SIRUPP_INSTALL_DATADIR ${CMAKE_INSTALL_DATADIR}/sirupp)
set(SIRUPP_INSTALL_DOCDIR ${CMAKE_INSTALL_DATADIR}/doc/sirupp)  # the package's name, not the project's
set(SIRUPP_INSTALL_PYTHONDIR lib/python3/dist-packages CACHE STRING
    "Where the Python module goes, relative to the prefix (Debian's python3 reads /usr/lib/python3/dist-packages)")

# ---- Programs ------------------------------------------------------------------------------------
set(sirupp_installed_programs
  sirupp sirupp-sim sirupp-control sirupp-controller-host sirupp-logger sirupp-viewer sirupp-panel
  sirupp-hardware sirupp-picservo-emu sirupp-sandbox-exec sirupp-planner-host)
if(SIRUPP_PYTHON_MODULE)
  list(APPEND sirupp_installed_programs sirupp-python-controller-host)
endif()
if(TARGET sirupp-rig-job)  # a rig as a cluster job (class/rig_job.hpp)
  list(APPEND sirupp_installed_programs sirupp-rig-job)
endif()
if(TARGET sirupp-notebook-bridge)  # a student's rig bus into their notebook sandbox (hub/)
  list(APPEND sirupp_installed_programs sirupp-notebook-bridge)
endif()
install(TARGETS ${sirupp_installed_programs} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# `cmake --build build --target sirupp_programs`: the programs alone, without the tests, benchmarks,
# examples and the Python module (what scripts/demo.sh builds: the demo runs nothing else). Nor
# sirupp-python-controller-host, which is built from the Python module's objects (about a minute
# of CPU the demo does not use).
set(sirupp_demo_programs ${sirupp_installed_programs})
list(REMOVE_ITEM sirupp_demo_programs sirupp-python-controller-host)
add_custom_target(sirupp_programs)
add_dependencies(sirupp_programs ${sirupp_demo_programs})

# ---- Shipped files (read-only data) ------------------------------------------------------------
install(DIRECTORY config DESTINATION ${SIRUPP_INSTALL_DATADIR})
install(DIRECTORY panel/web DESTINATION ${SIRUPP_INSTALL_DATADIR}/panel)
install(DIRECTORY class/web DESTINATION ${SIRUPP_INSTALL_DATADIR}/class)
# The notebooks hub's authenticator and spawner (hub/), read by `sirupp class notebooks`.
install(DIRECTORY hub/sirupp_hub DESTINATION ${SIRUPP_INSTALL_DATADIR}/hub FILES_MATCHING PATTERN "*.py"
        PATTERN "__pycache__" EXCLUDE)  # what running the tests from the tree leaves
# The header twice: in the data folder, where `sirupp grade`, `sirupp controller build` and the
# class server look it up (ResolveDataPath), and in <prefix>/include for a student's own g++.
install(FILES include/sirupp/controller.h include/sirupp/student_planner.h
        DESTINATION ${SIRUPP_INSTALL_DATADIR}/include/sirupp)
install(DIRECTORY notebooks DESTINATION ${SIRUPP_INSTALL_DATADIR} FILES_MATCHING
        PATTERN "*.ipynb" PATTERN "README.md")
# The examples as sources to read and copy (their CMakeLists.txt builds them in this tree only).
install(DIRECTORY examples DESTINATION ${SIRUPP_INSTALL_DATADIR}
        PATTERN "CMakeLists.txt" EXCLUDE PATTERN "__pycache__" EXCLUDE)
# The message definitions: for lcm-gen, when a student writes a process controller in another
# language (docs/student-controllers.md).
install(DIRECTORY lcmtypes DESTINATION ${SIRUPP_INSTALL_DATADIR} FILES_MATCHING
        PATTERN "*.lcm" PATTERN "README.md" PATTERN "java" EXCLUDE)
if(SIRUPP_BUILD_JAVA)
  # `sirupp spy` looks for java/sirupp_lcmtypes.jar beside the build's programs, then here.
  install(FILES ${CMAKE_BINARY_DIR}/java/sirupp_lcmtypes.jar
          DESTINATION ${SIRUPP_INSTALL_DATADIR}/java)
endif()
install(FILES scripts/sirupp-completion.bash DESTINATION ${CMAKE_INSTALL_DATADIR}/bash-completion/completions
        RENAME sirupp)

# ---- The Python module ---------------------------------------------------------------------------
if(SIRUPP_PYTHON_MODULE)
  install(TARGETS sirupp_python_module LIBRARY DESTINATION ${SIRUPP_INSTALL_PYTHONDIR}/sirupp)
  install(DIRECTORY python/sirupp/ DESTINATION ${SIRUPP_INSTALL_PYTHONDIR}/sirupp
          FILES_MATCHING PATTERN "*.py" PATTERN "__pycache__" EXCLUDE)
  # The build tree's _paths.py names build/bin and the source tree; the installed one finds the
  # prefix from its own place (<prefix>/<SIRUPP_INSTALL_PYTHONDIR>/sirupp/_paths.py), so a staged
  # install works like the real one.
  file(RELATIVE_PATH sirupp_python_to_prefix
       /prefix/${SIRUPP_INSTALL_PYTHONDIR}/sirupp /prefix)
  file(WRITE ${CMAKE_BINARY_DIR}/packaging/_paths.py
"# Installed by cmake/SiruppInstall.cmake: the programs and shipped files of the prefix this module
# is installed under.
import os

_PREFIX = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                        '${sirupp_python_to_prefix}'))
BIN_DIR = os.path.join(_PREFIX, '${CMAKE_INSTALL_BINDIR}')
SOURCE_DIR = os.path.join(_PREFIX, '${SIRUPP_INSTALL_DATADIR}')
VERSION = '${PROJECT_VERSION}'
")
  install(FILES ${CMAKE_BINARY_DIR}/packaging/_paths.py
          DESTINATION ${SIRUPP_INSTALL_PYTHONDIR}/sirupp)
  install(FILES ${CMAKE_BINARY_DIR}/python/${SIRUPP_PYTHON_DIST_INFO}/METADATA
          DESTINATION ${SIRUPP_INSTALL_PYTHONDIR}/${SIRUPP_PYTHON_DIST_INFO})
endif()

# ---- Documentation -------------------------------------------------------------------------------
install(FILES README.md DESTINATION ${SIRUPP_INSTALL_DOCDIR})
install(DIRECTORY docs/ DESTINATION ${SIRUPP_INSTALL_DOCDIR}/docs)
