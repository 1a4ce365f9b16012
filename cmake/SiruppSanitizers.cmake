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
  add_link_options(${_san_flags})
  message(STATUS "sirupp: sanitizer build (${SIRUPP_SANITIZER})")
endif()
