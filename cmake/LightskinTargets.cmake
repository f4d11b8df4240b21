# Helpers that give every lightskin target the same warnings, sanitizers and layout.

set(LIGHTSKIN_WARNING_FLAGS -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast
    -Wcast-align -Woverloaded-virtual -Wconversion -Wsign-conversion
    -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough)
# GCC 12 at -O3 reports -Wrestrict inside libstdc++'s std::string operator+ (GCC bug 105651,
# fixed in GCC 13): a false positive in the standard library, not in our code.
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
  list(APPEND LIGHTSKIN_WARNING_FLAGS -Wno-restrict)
endif()
if(LIGHTSKIN_WARNINGS_AS_ERRORS)
  list(APPEND LIGHTSKIN_WARNING_FLAGS -Werror)
endif()

# The linker: GNU ld took 5.8 s of CPU to link one test program of the ASan build, lld 1.2 s (gold 2.0 s), and
# each build links ~130 programs (docs/TESTING.md, "Build and CI times").
if(LIGHTSKIN_LINKER)
  include(CheckLinkerFlag)
  string(MAKE_C_IDENTIFIER "LIGHTSKIN_LINKER_${LIGHTSKIN_LINKER}_WORKS" linker_works)
  check_linker_flag(CXX -fuse-ld=${LIGHTSKIN_LINKER} ${linker_works})
  if(NOT ${linker_works})
    message(FATAL_ERROR "the compiler cannot link with -fuse-ld=${LIGHTSKIN_LINKER}: install it "
      "(scripts/install_dependencies.sh) or configure with -DLIGHTSKIN_LINKER= for the compiler's default linker")
  endif()
  add_link_options(-fuse-ld=${LIGHTSKIN_LINKER})
endif()

# Sanitizer builds (scripts/sanitize.sh; docs/TESTING.md). Every finding is fatal: UBSan does not recover
# (-fno-sanitize-recover=all), so a test with undefined behaviour fails instead of printing and passing.
if((LIGHTSKIN_SANITIZE OR LIGHTSKIN_SANITIZE_THREAD) AND LIGHTSKIN_FUZZ)
  message(FATAL_ERROR "LIGHTSKIN_FUZZ is a build of its own (it already has ASan+UBSan)")
endif()
if(LIGHTSKIN_SANITIZE AND LIGHTSKIN_SANITIZE_THREAD)
  message(FATAL_ERROR "LIGHTSKIN_SANITIZE (ASan+UBSan) and LIGHTSKIN_SANITIZE_THREAD (TSan) need separate builds")
endif()
if(LIGHTSKIN_SANITIZE)
  set(LIGHTSKIN_SANITIZER_FLAGS -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_compile_options(${LIGHTSKIN_SANITIZER_FLAGS})
  add_link_options(${LIGHTSKIN_SANITIZER_FLAGS})
  # Eigen assumes malloc is not 16-byte aligned when it sees __SANITIZE_ADDRESS__ and then offsets its
  # aligned blocks by hand, while Debian's PCL (built without ASan) frees them with plain free(): a vector
  # that PCL grows through our (interposed, non-inlined Debug) Eigen allocator ends in an ASan bad-free in
  # ~IntegralImageNormalEstimation. ASan's malloc is 16-byte aligned on x86-64 (Eigen asserts this in
  # aligned_malloc), so declare it and keep one Eigen allocator ABI in the process.
  add_compile_definitions(EIGEN_MALLOC_ALREADY_ALIGNED=1)
  set(LIGHTSKIN_TEST_ENVIRONMENT
    "LSAN_OPTIONS=suppressions=${CMAKE_CURRENT_LIST_DIR}/sanitizers/lsan.supp:print_suppressions=0"
    "UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1")
elseif(LIGHTSKIN_FUZZ)
  # fuzz/ (scripts/fuzz.sh): our code instrumented for libFuzzer's coverage and checked by
  # ASan+UBSan; only the fuzz targets link the libFuzzer driver (-fsanitize=fuzzer, fuzz/CMakeLists.txt).
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "LIGHTSKIN_FUZZ needs clang (libFuzzer): CC=clang-15 CXX=clang++-15")
  endif()
  set(LIGHTSKIN_SANITIZER_FLAGS -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_compile_options(-fsanitize=fuzzer-no-link ${LIGHTSKIN_SANITIZER_FLAGS})
  add_link_options(${LIGHTSKIN_SANITIZER_FLAGS})
  add_compile_definitions(EIGEN_MALLOC_ALREADY_ALIGNED=1) # as for LIGHTSKIN_SANITIZE, above
  set(LIGHTSKIN_TEST_ENVIRONMENT "")
elseif(LIGHTSKIN_SANITIZE_THREAD)
  set(LIGHTSKIN_SANITIZER_FLAGS -fsanitize=thread -fno-omit-frame-pointer)
  add_compile_options(${LIGHTSKIN_SANITIZER_FLAGS})
  add_link_options(${LIGHTSKIN_SANITIZER_FLAGS})
  set(LIGHTSKIN_TEST_ENVIRONMENT
    "TSAN_OPTIONS=suppressions=${CMAKE_CURRENT_LIST_DIR}/sanitizers/tsan.supp:halt_on_error=1:second_deadlock_stack=1:history_size=7")
  # GL tests (history_size=7: see tsan.supp), two options for Mesa's llvmpipe (uninstrumented):
  # - detect_deadlocks=0: it holds more than 64 of its own mutexes at once on the GL thread, the hard limit
  #   of TSan's deadlock detector (a CHECK failure ends the process); our GL code takes no lock.
  # - ignore_noninstrumented_modules=1: its rasteriser threads write the framebuffer with memcpy and the GL
  #   thread reads it back with memcpy, both seen through TSan's interceptor while Mesa's own futex-based
  #   fences are not: reported as races inside Mesa. The option ignores interceptor calls made from
  #   uninstrumented libraries (Mesa, libtbb, OpenCV); every access our code makes is still checked.
  #   (called_from_lib:swrast_dri.so would name Mesa alone, but TSan aborts when that library is unloaded,
  #   which eglTerminate does.)
  set(LIGHTSKIN_GL_TEST_ENVIRONMENT "${LIGHTSKIN_TEST_ENVIRONMENT}:detect_deadlocks=0:ignore_noninstrumented_modules=1")
else()
  set(LIGHTSKIN_TEST_ENVIRONMENT "")
endif()

# Release builds keep assertions: a wrong result from a graphics pipeline is worse than an abort.
string(REPLACE "-DNDEBUG" "" CMAKE_CXX_FLAGS_RELWITHDEBINFO "${CMAKE_CXX_FLAGS_RELWITHDEBINFO}")
string(REPLACE "-DNDEBUG" "" CMAKE_CXX_FLAGS_RELEASE "${CMAKE_CXX_FLAGS_RELEASE}")
# RelWithDebInfo (the main job's and CI's build) keeps function names and line tables (-g1: backtraces,
# sanitizer and profiler reports with file:line) but not variables and types: full -g costs the
# nlohmann::json-heavy files ~1.3x the CPU time (render/src/Scene.cpp: 9.1 s against 7.2 s) and makes
# the links slower, and the main job is compile-bound (docs/TESTING.md, "Build and CI times").
# -DLIGHTSKIN_FULL_DEBUG_INFO=ON (or the Debug build) for a debugger session.
if(NOT LIGHTSKIN_FULL_DEBUG_INFO)
  foreach(lang C CXX)
    string(REGEX REPLACE "(^| )-g( |$)" "\\1-g1\\2" CMAKE_${lang}_FLAGS_RELWITHDEBINFO "${CMAKE_${lang}_FLAGS_RELWITHDEBINFO}")
  endforeach()
endif()

# Applies lightskin's own warning set to a target. Third-party headers are included as SYSTEM
# by the imported targets, so their warnings never fail our build.
function(lightskin_target_warnings target)
  target_compile_options(${target} PRIVATE ${LIGHTSKIN_WARNING_FLAGS})
endfunction()

# lightskin_add_module(<name> SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
# Creates the library target lightskin_<name> with alias lightskin::<name>, public headers in
# <name>/include, private code in <name>/src.
function(lightskin_add_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(lightskin_${name} ${ARG_SOURCES})
  add_library(lightskin::${name} ALIAS lightskin_${name})
  set_target_properties(lightskin_${name} PROPERTIES EXPORT_NAME ${name} OUTPUT_NAME lightskin_${name})
  target_include_directories(lightskin_${name}
    PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include> $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>
    PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(lightskin_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  lightskin_target_warnings(lightskin_${name})
  set_property(GLOBAL APPEND PROPERTY LIGHTSKIN_MODULES lightskin_${name})
  if(EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/include)
    install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  endif()
endfunction()
