# Warning flags for our own targets (generated and third-party headers are included as SYSTEM).
set(SIRUPP_WARNING_FLAGS
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Woverloaded-virtual -Wcast-align
  -Wnull-dereference -Wformat=2 -Wimplicit-fallthrough -Wmissing-declarations -Wundef
  # lcm-gen's decode() reads the fingerprint through a helper that may fail; GCC 12 cannot see that the
  # early return guards the later read once the header is inlined (a false positive, not silenced by
  # SYSTEM includes). -Wuninitialized stays on.
  -Wno-maybe-uninitialized)
if(SIRUPP_WERROR)
  list(APPEND SIRUPP_WARNING_FLAGS -Werror)
endif()

function(sirupp_set_warnings target)
  target_compile_options(${target} PRIVATE ${SIRUPP_WARNING_FLAGS})
endfunction()
