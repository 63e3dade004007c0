# The core unit tests (test/unit, ROS-free) as one gtest program; shared by the
# catkin build (catkin_add_gtest) and the plain-CMake core build.
#
# amhmvs_unit_test_sources(VAR): the test sources and the tool sources they call.
# amhmvs_configure_unit_tests(TARGET): links the core and names the programs
# and folders the tests use.

function(amhmvs_unit_test_sources var)
  file(GLOB tests CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/test/unit/test_*.cpp)
  set(tools depth_job synthetic_problem keyframe_picker map_options)
  list(TRANSFORM tools PREPEND ${CMAKE_CURRENT_SOURCE_DIR}/src/tools/)
  list(TRANSFORM tools APPEND .cpp)
  set(${var} ${tests} ${tools} PARENT_SCOPE)
endfunction()

function(amhmvs_configure_unit_tests target)
  target_link_libraries(${target} amhmvs_simulation amhmvs_eval gtest_main)
  target_include_directories(${target} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src/tools
                             ${CMAKE_CURRENT_SOURCE_DIR}/test)
  target_compile_definitions(${target} PRIVATE
    AMHMVS_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}"
    AMHMVS_DEPTH_BIN="$<TARGET_FILE:amhmvs_depth>"
    AMHMVS_TOOLS_DIR="$<TARGET_FILE_DIR:amhmvs_depth>")
  add_dependencies(${target} amhmvs_depth amhmvs_synthetic ${AMHMVS_MAPPING_TOOLS} ${AMHMVS_STUDY_TOOLS})
endfunction()
