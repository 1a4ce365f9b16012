# -DSIRUPP_SANITIZER=asan  -> AddressSanitizer + UndefinedBehaviorSanitizer
# -DSIRUPP_SANITIZER=tsan  -> ThreadSanitizer
# Applied to every target in the tree, so the libraries, mains and tests are all instrumented.
if(SIRUPP_SANITIZER STREQUAL "asan")
  set(_san_flags -fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer)
elseif(SIRUPP_SANITIZER STREQUAL "tsan")
  set(_san_flags -fsanitize=thread -fno-omit-frame-pointer)
elseif(NOT SIRUPP_SANITIZER STREQUAL "")
  message(FATAL_ERROR "SIRUPP_SANITIZER='${SIRUPP_SANITIZER}': allowed values are '', 'asan', 'tsan'")
endif()
# -O1 in place of the build type's -O2: the sanitizers' own advice for readable reports, and a
# sanitizer build compiles in well under half the time (measured on core/model_loader.cpp with
# ASan + UBSan: 105 s at -O2 -g, 42 s at -O1 -g1), which CI pays on every run.
if(DEFINED _san_flags)
  add_compile_options(${_san_flags} -O1)
  if(SIRUPP_SANITIZER STREQUAL "asan")
    # Eigen stops trusting glibc's 16-byte aligned malloc under AddressSanitizer
    # (Eigen/src/Core/util/Memory.h: `! defined(__SANITIZE_ADDRESS__)`) and then allocates with
    # its own offset scheme; OMPL, built by Debian without ASan, trusts malloc. Eigen's templates
    # have one definition in the process, so a JacobiSVD buffer allocated by our copy was freed
    # by OMPL's (ProjectionMatrix::ComputeRandom): "attempting free on address which was not
    # malloc()-ed" in every planner test. The same rule as OMPL's on both sides ends it; ASan's
    # malloc returns 16-byte aligned blocks, and Eigen's own assert checks that it does.
    add_compile_definitions(EIGEN_MALLOC_ALREADY_ALIGNED=1)
  endif()
  add_link_options(${_san_flags})
  message(STATUS "sirupp: sanitizer build (${SIRUPP_SANITIZER})")
endif()
