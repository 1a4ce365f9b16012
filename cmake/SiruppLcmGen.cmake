# sirupp_lcm_types(TARGET <name> PACKAGE <pkg> FILES <a.lcm> ... [JAR <jar-target>]
#                  [JAVA_SOURCES <b.java> ...])
#
# Runs lcm-gen at build time on each .lcm file (one type per file, named like the file) and makes:
#   <name>          an INTERFACE library whose include directory holds <pkg>/<type>.hpp (C++11 API)
#   <jar-target>    (optional) build/java/<name>.jar, the compiled Java classes, for lcm-spy,
#                   with JAVA_SOURCES (hand-written classes, e.g. lcm-spy plugins) compiled in too
# Written for LCM 1.3.1 (no lcmConfig.cmake); works the same with newer lcm-gen.
function(sirupp_lcm_types)
  cmake_parse_arguments(ARG "" "TARGET;PACKAGE;JAR" "FILES;JAVA_SOURCES" ${ARGN})
  set(cpp_dir ${CMAKE_CURRENT_BINARY_DIR}/cpp)
  set(java_dir ${CMAKE_CURRENT_BINARY_DIR}/java)
  set(hpp_outputs)
  set(java_outputs)
  foreach(lcm_file IN LISTS ARG_FILES)
    get_filename_component(abs ${lcm_file} ABSOLUTE)
    get_filename_component(type ${lcm_file} NAME_WE)
    set(hpp ${cpp_dir}/${ARG_PACKAGE}/${type}.hpp)
    set(java ${java_dir}/${ARG_PACKAGE}/${type}.java)
    set(outputs ${hpp})
    set(java_flags)
    if(ARG_JAR)
      list(APPEND outputs ${java})
      set(java_flags --java --jpath ${java_dir})
      list(APPEND java_outputs ${java})
    endif()
    add_custom_command(
      OUTPUT ${outputs}
      COMMAND ${LCM_GEN_EXECUTABLE} --cpp --cpp-std c++11 --cpp-hpath ${cpp_dir} ${java_flags} ${abs}
      # lcm-gen 1.3.1 checks string lengths against the bytes left but not array counts: a message
      # with a valid fingerprint and num_joints = 2^31-1 would make decode allocate and zero-fill
      # gigabytes first. Every element takes at least one byte, so a count above the bytes left is
      # refused (decode returns -1) before the resize.
      COMMAND sed -i -E
        "s/^( *)(this->[A-Za-z0-9_]+)\\.resize\\((this->[A-Za-z0-9_]+)\\);/\\1if (\\3 < 0 || \\3 > maxlen - pos) return -1;\\n\\1\\2.resize(\\3);/"
        ${hpp}
      DEPENDS ${abs} ${CMAKE_CURRENT_FUNCTION_LIST_FILE}
      COMMENT "lcm-gen ${type}"
      VERBATIM)
    list(APPEND hpp_outputs ${hpp})
  endforeach()

  add_custom_target(${ARG_TARGET}_gen DEPENDS ${hpp_outputs} ${java_outputs})
  add_library(${ARG_TARGET} INTERFACE)
  add_dependencies(${ARG_TARGET} ${ARG_TARGET}_gen)
  target_include_directories(${ARG_TARGET} SYSTEM INTERFACE ${cpp_dir})
  target_link_libraries(${ARG_TARGET} INTERFACE sirupp_lcm_external)

  if(ARG_JAR)
    add_jar(${ARG_JAR}
      SOURCES ${java_outputs} ${ARG_JAVA_SOURCES}
      INCLUDE_JARS ${LCM_JAR}
      OUTPUT_NAME ${ARG_TARGET}
      OUTPUT_DIR ${CMAKE_BINARY_DIR}/java)
    add_dependencies(${ARG_JAR} ${ARG_TARGET}_gen)
  endif()
endfunction()
