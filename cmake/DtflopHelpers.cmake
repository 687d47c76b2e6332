# Helpers shared by every folder of dtflop.

# Warnings for our own targets.
function(dtflop_warnings target)
  # -Wno-missing-field-initializers: designated initializers leave the other fields at their defaults.
  target_compile_options(${target} PRIVATE
    "$<$<COMPILE_LANGUAGE:CXX>:-Wall;-Wextra;-Wpedantic;-Wshadow;-Wconversion;-Wno-sign-conversion;-Wno-missing-field-initializers>")
endfunction()

# dtflop_library(name SOURCES a.cpp b.cu ... DEPS lib... [CUDA_SOURCES x.cu ...])
# CUDA_SOURCES are compiled only when the CUDA language is enabled; the target then gets
# DTFLOP_HAVE_CUDA=1 and links the CUDA runtime.
function(dtflop_library name)
  cmake_parse_arguments(A "" "" "SOURCES;CUDA_SOURCES;DEPS;PUBLIC_DEPS" ${ARGN})
  set(srcs ${A_SOURCES})
  if(DTFLOP_HAVE_CUDA)
    list(APPEND srcs ${A_CUDA_SOURCES})
  endif()
  add_library(${name} STATIC ${srcs})
  # Unity batches are for the C++ sources (DTFLOP_UNITY_BUILD): each .cu file is compiled alone.
  set(cu_srcs ${srcs})
  list(FILTER cu_srcs INCLUDE REGEX "\\.cu$")
  if(cu_srcs)
    set_source_files_properties(${cu_srcs} TARGET_DIRECTORY ${name} PROPERTIES SKIP_UNITY_BUILD_INCLUSION ON)
  endif()
  set_property(GLOBAL APPEND PROPERTY DTFLOP_LIBRARIES ${name})
  # Headers are included as "model/profile.hpp": from the source tree, or from
  # <prefix>/include/dtflop once installed (cmake/DtflopInstall.cmake).
  target_include_directories(${name} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>
                                            $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/dtflop>)
  target_link_libraries(${name} PUBLIC ${A_PUBLIC_DEPS} PRIVATE ${A_DEPS})
  dtflop_warnings(${name})
  if(DTFLOP_HAVE_CUDA AND A_CUDA_SOURCES)
    target_compile_definitions(${name} PUBLIC DTFLOP_HAVE_CUDA=1)
    target_link_libraries(${name} PUBLIC CUDA::cudart)
    set_target_properties(${name} PROPERTIES CUDA_SEPARABLE_COMPILATION OFF
                                             POSITION_INDEPENDENT_CODE ON)
    target_compile_options(${name} PRIVATE
      $<$<COMPILE_LANGUAGE:CUDA>:--expt-relaxed-constexpr -lineinfo -Xptxas=-warn-spills>)
  endif()
endfunction()

# dtflop_test(name SOURCES a.cpp ... DEPS lib... [GPU] [SERIAL] [OPTIMISED | OPTIMISED_ONLY] [COST s])
# One line adds a GoogleTest executable, linked with our shared main (tests/support).
# Tests are labelled `unit` or `gpu`; gpu tests skip themselves (GTEST_SKIP) without a device.
# The tests' own sources are compiled at -O1 in an optimised build: what they test is compiled
# with the build's flags in the libraries, and at -O3 the test sources alone took a third of a
# clean Release build (-O1 compiles them in about half the time). They share one precompiled
# header (dtflop_test_pch, tests/CMakeLists.txt).
include(GoogleTest)
function(dtflop_test_flags target)
  dtflop_warnings(${target})
  target_compile_options(${target} PRIVATE "$<$<AND:$<COMPILE_LANGUAGE:CXX>,$<CONFIG:Release,RelWithDebInfo>>:-O1>")
endfunction()

# SERIAL: the tests run with no other test beside them (ctest RUN_SERIAL), for tests that measure
# every CPU of the machine at once (another test's load would be what they measure).
# COST: about how many seconds each of its tests runs (ctest COST), for a test far longer than the
# others: ctest -j starts the costliest first, so that where it has no timings of its own yet (a
# clean clone, CI) the long test runs beside the short ones, not after them.
# Which trees build a test (DTFLOP_TESTS, CMakeLists.txt; scripts/test.sh says why):
#   a unit test                 all, sanitized
#   OPTIMISED (a unit test)     all, sanitized, optimised: what it asserts in an optimised build
#                               the sanitized tree does not (the calibration fits on the full
#                               sample set: tests/calibrate/synthetic.hpp)
#   OPTIMISED_ONLY (unit)       all, optimised: never run under the sanitizers (the main job end
#                               to end)
#   GPU                         all, optimised: the sanitized trees have no CUDA
# A test a tree leaves out is still defined there, outside `all` and with no ctest tests, so that
# a folder's add_dependencies() and target_*() lines need no condition (and it can be built by
# name); ctest runs only what the tree builds.
function(dtflop_test name)
  cmake_parse_arguments(A "GPU;SERIAL;OPTIMISED;OPTIMISED_ONLY" "COST" "SOURCES;DEPS" ${ARGN})
  if(A_GPU OR A_OPTIMISED_ONLY)
    set(trees all optimised)
  elseif(A_OPTIMISED)
    set(trees all optimised sanitized)
  else()
    set(trees all sanitized)
  endif()
  if(DTFLOP_TESTS IN_LIST trees)
    add_executable(${name} ${A_SOURCES})
  else()
    add_executable(${name} EXCLUDE_FROM_ALL ${A_SOURCES})
  endif()
  target_link_libraries(${name} PRIVATE dtflop_test_main ${A_DEPS})
  dtflop_test_flags(${name})
  target_precompile_headers(${name} REUSE_FROM dtflop_test_pch)
  if(NOT DTFLOP_TESTS IN_LIST trees)
    return()
  endif()
  if(A_GPU)
    set(label gpu)
  else()
    set(label unit)
  endif()
  set(serial FALSE)
  if(A_SERIAL)
    set(serial TRUE)
  endif()
  set(cost)
  if(A_COST)
    set(cost COST ${A_COST})
  endif()
  gtest_discover_tests(${name} PROPERTIES LABELS ${label} RUN_SERIAL ${serial} ${cost} DISCOVERY_TIMEOUT 60)
endfunction()
