# The ROS-free unit tests: one gtest program per library, amhmvs_<layer>_tests
# from test/unit/<layer>/test_*.cpp, plus amhmvs_tools_tests for the
# command-line programs and the docs' commands (test/unit/tools). Shared by the
# catkin build (catkin_add_gtest) and the plain-CMake core build.
#
# AMHMVS_UNIT_TEST_LAYERS: the folders of test/unit, lowest layer first.
# amhmvs_add_unit_tests(catkin|ctest): defines every program (catkin_add_gtest,
# or add_executable with add_test) and the target amhmvs_unit_tests that
# builds them all, with AMHMVS_EXTRA_UNIT_TEST_PROGRAMS (defined before).

set(AMHMVS_UNIT_TEST_LAYERS core io mvs simulation mapping eval tools)

macro(amhmvs_add_unit_tests registry)
  set(amhmvs_unit_test_programs)
  foreach(layer ${AMHMVS_UNIT_TEST_LAYERS})
    file(GLOB tests CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/test/unit/${layer}/test_*.cpp)
    set(program amhmvs_${layer}_tests)
    if("${registry}" STREQUAL "catkin")
      catkin_add_gtest(${program} ${tests})
    else()
      add_executable(${program} ${tests})
      add_test(NAME ${program} COMMAND ${program})
    endif()
    target_link_libraries(${program} amhmvs_tools_common gtest_main)
    # gtest and Eigen parsed once for every program (about 1.5 s of each
    # test file's compile otherwise).
    if(amhmvs_unit_test_programs)
      list(GET amhmvs_unit_test_programs 0 first_program)
      target_precompile_headers(${program} REUSE_FROM ${first_program})
    else()
      target_precompile_headers(${program} PRIVATE ${AMHMVS_PRECOMPILED_HEADERS} <gtest/gtest.h>)
    endif()
    # test/unit: the shared test helpers; src: the layers' private headers.
    target_include_directories(${program} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test/unit
                               ${CMAKE_CURRENT_SOURCE_DIR}/test ${CMAKE_CURRENT_SOURCE_DIR}/src)
    target_compile_definitions(${program} PRIVATE
      AMHMVS_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}"
      AMHMVS_DEPTH_BIN="$<TARGET_FILE:amhmvs_depth>"
      AMHMVS_TOOLS_DIR="$<TARGET_FILE_DIR:amhmvs_depth>")
    add_dependencies(${program} amhmvs_depth amhmvs_synthetic ${AMHMVS_MAPPING_TOOLS} ${AMHMVS_STUDY_TOOLS})
    list(APPEND amhmvs_unit_test_programs ${program})
  endforeach()
  # Programs defined by the caller (AMHMVS_EXTRA_UNIT_TEST_PROGRAMS) run with them.
  list(APPEND amhmvs_unit_test_programs ${AMHMVS_EXTRA_UNIT_TEST_PROGRAMS})
  add_custom_target(amhmvs_unit_tests DEPENDS ${amhmvs_unit_test_programs})
  # Their paths, one per line, for scripts/run_tests.sh.
  list(TRANSFORM amhmvs_unit_test_programs REPLACE "(.+)" "$<TARGET_FILE:\\1>")
  list(JOIN amhmvs_unit_test_programs "\n" amhmvs_unit_test_files)
  file(GENERATE OUTPUT ${CMAKE_BINARY_DIR}/unit_test_programs.txt CONTENT "${amhmvs_unit_test_files}\n")
endmacro()
