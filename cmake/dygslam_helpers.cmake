# dygslam_add_library(NAME SRCS a.cc b.cc DEPS x y)
function(dygslam_add_library name)
  cmake_parse_arguments(ARG "" "" "SRCS;DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SRCS})
  target_link_libraries(${name} PUBLIC ${ARG_DEPS})
  target_include_directories(${name} PUBLIC ${CMAKE_SOURCE_DIR})
  set_target_properties(${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
endfunction()

# dygslam_add_test(MODULE NAME [RUN_SERIAL] SRCS a_test.cc DEPS lib)
# RUN_SERIAL: no other test runs beside it (tests of the camera's pace).
# Test names in ctest are "<module>/<Suite>.<Case>".
function(dygslam_add_test)
  if(NOT DYGSLAM_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "RUN_SERIAL" "MODULE;NAME;TIMEOUT" "SRCS;DEPS;LABELS" ${ARGN})
  set(target ${ARG_MODULE}_${ARG_NAME})
  add_executable(${target} ${ARG_SRCS})
  target_link_libraries(${target} PRIVATE ${ARG_DEPS} dygslam_test_support GTest::gtest GTest::gtest_main)
  target_compile_definitions(${target} PRIVATE DYGSLAM_TEST_SOURCE_DIR="${CMAKE_SOURCE_DIR}")
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  gtest_discover_tests(${target}
    TEST_PREFIX "${ARG_MODULE}/"
    DISCOVERY_TIMEOUT 60
    PROPERTIES TIMEOUT ${ARG_TIMEOUT} LABELS "${ARG_MODULE};${ARG_LABELS}"
      # GTEST_SKIP exits 0: without this ctest would count a skipped test as passed.
      SKIP_REGULAR_EXPRESSION "\\[  SKIPPED \\]"
      RUN_SERIAL ${ARG_RUN_SERIAL}
      ENVIRONMENT "DYGSLAM_SOURCE_DIR=${CMAKE_SOURCE_DIR}\\;DYGSLAM_BINARY_DIR=${CMAKE_BINARY_DIR}\\;DYGSLAM_DEFAULT_DATA_DIR=${DYGSLAM_DEFAULT_DATA_DIR}\\;DYGSLAM_DEFAULT_MODELS_DIR=${DYGSLAM_DEFAULT_MODELS_DIR}")
endfunction()
