# AMHMVS_FUZZERS (core-only build, clang): the libFuzzer targets of test/fuzz,
# one per reader, plus the nodelet's message conversions when Debian's ROS
# message headers and serialization libraries are installed (no catkin needed).
# The core is then compiled with coverage for libFuzzer (fuzzer-no-link);
# scripts/run_fuzzers.sh builds and runs them.
option(AMHMVS_FUZZERS "Build the libFuzzer targets of test/fuzz (clang only)" OFF)
if(NOT AMHMVS_FUZZERS)
  return()
endif()
if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
  message(FATAL_ERROR "AMHMVS_FUZZERS needs clang (libFuzzer), not ${CMAKE_CXX_COMPILER_ID}")
endif()
# Before the core's targets exist, so that they get the coverage instrumentation.
add_compile_options(-fsanitize=fuzzer-no-link)

function(amhmvs_add_fuzzer name source)
  add_executable(${name} ${CMAKE_CURRENT_SOURCE_DIR}/test/fuzz/${source})
  target_link_libraries(${name} amhmvs_mapping ${ARGN})
  target_link_options(${name} PRIVATE -fsanitize=fuzzer)
  list(APPEND AMHMVS_FUZZER_TARGETS ${name})
  set(AMHMVS_FUZZER_TARGETS ${AMHMVS_FUZZER_TARGETS} PARENT_SCOPE)
endfunction()

# Called after the core library is defined.
macro(amhmvs_define_fuzzers)
  amhmvs_add_fuzzer(fuzz_pfm fuzz_pfm.cpp)
  amhmvs_add_fuzzer(fuzz_image_header fuzz_image_header.cpp)
  amhmvs_add_fuzzer(fuzz_mvsnet_cam fuzz_mvsnet_cam.cpp)
  amhmvs_add_fuzzer(fuzz_mvsnet_pair fuzz_mvsnet_pair.cpp)
  amhmvs_add_fuzzer(fuzz_ply fuzz_ply.cpp)
  amhmvs_add_fuzzer(fuzz_colmap_text fuzz_colmap.cpp)
  target_compile_definitions(fuzz_colmap_text PRIVATE AMHMVS_FUZZ_COLMAP_BINARY=0)
  amhmvs_add_fuzzer(fuzz_colmap_binary fuzz_colmap.cpp)
  target_compile_definitions(fuzz_colmap_binary PRIVATE AMHMVS_FUZZ_COLMAP_BINARY=1)
  # The ROS message conversions: headers and libraries from Debian's ROS packages.
  find_path(AMHMVS_ROS_MSG_INCLUDE sensor_msgs/Image.h)
  find_library(AMHMVS_ROSTIME rostime)
  find_library(AMHMVS_ROS_SERIALIZATION roscpp_serialization)
  find_library(AMHMVS_CPP_COMMON cpp_common)
  find_library(AMHMVS_CV_BRIDGE cv_bridge)
  find_package(OpenCV QUIET COMPONENTS core imgproc)
  if(AMHMVS_ROS_MSG_INCLUDE AND AMHMVS_ROSTIME AND AMHMVS_ROS_SERIALIZATION AND AMHMVS_CPP_COMMON
     AND AMHMVS_CV_BRIDGE AND OpenCV_FOUND)
    amhmvs_add_fuzzer(fuzz_ros_conversions fuzz_ros_conversions.cpp ${AMHMVS_CV_BRIDGE} ${OpenCV_LIBS}
                      ${AMHMVS_ROSTIME} ${AMHMVS_ROS_SERIALIZATION} ${AMHMVS_CPP_COMMON})
    target_sources(fuzz_ros_conversions PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src/ros/ros_conversions.cpp)
    target_include_directories(fuzz_ros_conversions SYSTEM PRIVATE ${OpenCV_INCLUDE_DIRS})
  else()
    message(STATUS "amhmvs: no ROS message headers/libraries: fuzz_ros_conversions not built")
  endif()
  add_custom_target(fuzzers DEPENDS ${AMHMVS_FUZZER_TARGETS})
  message(STATUS "amhmvs: fuzzers ${AMHMVS_FUZZER_TARGETS}")
endmacro()
