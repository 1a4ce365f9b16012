# The Debian package `sirupp` (scripts/package.sh; docs/install.md), made by CPack's DEB generator
# from what cmake/SiruppInstall.cmake installs, plus the parts only the package has: the class
# server's systemd unit, the maintainer scripts (the service user, /var/lib/sirupp, byte-compiled
# Python) and Debian's copyright and changelog files (packaging/).
#
# The package is made from an ordinary build tree (no second build with other options): the
# programs find their files from where they are installed (runtime/data_path.hpp), so only the
# packaging prefix differs (/usr).

set(SIRUPP_DEB_NAME sirupp)
set(SIRUPP_DEB_DOCDIR ${SIRUPP_INSTALL_DOCDIR})

# Only in the package (component "debian", left out of a plain `cmake --install`): the unit names
# /usr/bin/sirupp and the service user the maintainer scripts make.
install(FILES packaging/sirupp-class@.service DESTINATION lib/systemd/system
        COMPONENT debian EXCLUDE_FROM_ALL)
# The notebooks hub beside a class server (docs/notebooks.md), as sirupp, not Debian's root unit.
install(FILES packaging/sirupp-notebooks@.service DESTINATION lib/systemd/system
        COMPONENT debian EXCLUDE_FROM_ALL)
install(FILES packaging/copyright DESTINATION ${SIRUPP_DEB_DOCDIR} COMPONENT debian EXCLUDE_FROM_ALL)
# A native package: its changelog is changelog.gz, compressed with no time stamp in it (gzip -n)
# so that the package is reproducible.
set(sirupp_changelog ${CMAKE_BINARY_DIR}/packaging/changelog.gz)
configure_file(packaging/changelog.in ${CMAKE_BINARY_DIR}/packaging/changelog @ONLY)
find_program(SIRUPP_GZIP gzip)
if(SIRUPP_GZIP)
  execute_process(COMMAND ${SIRUPP_GZIP} -9 -n -f ${CMAKE_BINARY_DIR}/packaging/changelog
                  RESULT_VARIABLE sirupp_gzip_result)
  if(sirupp_gzip_result EQUAL 0)
    install(FILES ${sirupp_changelog} DESTINATION ${SIRUPP_DEB_DOCDIR}
            COMPONENT debian EXCLUDE_FROM_ALL)
  endif()
endif()

# A manual page per program, from its --help (the programs as built; cmake/SiruppManPages.cmake).
install(CODE "execute_process(COMMAND \"${CMAKE_COMMAND}\"
    -DSIRUPP_BIN_DIR=${CMAKE_BINARY_DIR}/bin
    \"-DSIRUPP_PROGRAMS=${sirupp_installed_programs}\"
    \"-DSIRUPP_MAN_DIR=\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_MANDIR}/man1\"
    -DSIRUPP_VERSION=${PROJECT_VERSION}
    -P ${PROJECT_SOURCE_DIR}/cmake/SiruppManPages.cmake
  RESULT_VARIABLE sirupp_man_result)
  if(NOT sirupp_man_result EQUAL 0)
    message(FATAL_ERROR \"manual pages: cmake/SiruppManPages.cmake failed\")
  endif()"
  COMPONENT debian EXCLUDE_FROM_ALL)

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME ${SIRUPP_DEB_NAME})
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_VENDOR "SIRUPP-LCM")
set(CPACK_PACKAGE_CONTACT "SIRUPP-LCM maintainers <maintainers@users.noreply.h-seed-0c5a80a8.example>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "robot-arm simulator, lab system and class server for robotics courses")
set(CPACK_PACKAGE_DESCRIPTION
"SIRUPP-LCM turns any serial arm described by Denavit-Hartenberg parameters
into a virtual robot in the ODE physics engine, driven like the real PUMA 260
by PIC-SERVO-style trapezoidal profiles and PID, as separate processes talking
LCM: physics, virtual servos, the bridge to the real arm, logger, off-screen
viewer, the lab panel in the browser, grading of students' controllers in a
sandbox, and a class server giving every student a private rig in the browser.
.
This package holds the programs (sirupp, sirupp-sim, ...), the models, plans,
grading suites, web pages, notebooks and examples in /usr/share/sirupp, the
controller header, the Python module for /usr/bin/python3, and a systemd
template unit running a class server under the sirupp system user.")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
set(CPACK_COMPONENTS_ALL Unspecified debian)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_GROUPING ALL_COMPONENTS_IN_ONE)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_NAME ${SIRUPP_DEB_NAME})
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# Besides the libraries (shlibdeps): the programs the package runs and the pages' libraries.
# bubblewrap: the sandbox of students' code; g++: builds their controllers; python3 3.11 (the
# module is built for its ABI) with numpy; libjs-three and libjs-dygraphs: the panel's page;
# adduser: the service user.
set(CPACK_DEBIAN_PACKAGE_DEPENDS
    "adduser, bubblewrap, g++, python3 (>= 3.11~), python3 (<< 3.12), python3-numpy, libjs-three, libjs-dygraphs")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS
    "python3-matplotlib, jupyter-notebook, python3-ipykernel")
# jupyterhub (with its proxy): the class's notebooks hub (sirupp-notebooks@.service).
set(CPACK_DEBIAN_PACKAGE_SUGGESTS
    "liblcm-bin, liblcm-dev, liblcm-java, libjchart2d-java, default-jre, apache2 | nginx, jupyterhub, iproute2")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/packaging/postinst ${PROJECT_SOURCE_DIR}/packaging/prerm
    ${PROJECT_SOURCE_DIR}/packaging/postrm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_DEBIAN_COMPRESSION_TYPE xz)
set(CPACK_THREADS 0)  # xz on every core
include(CPack)
