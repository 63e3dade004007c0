# The core unit tests without catkin (AMHMVS_CORE_ONLY): Debian's googletest
# sources (/usr/src/googletest, package googletest) are built with this build's
# compiler and flags, so a clang or sanitizer build instruments gtest too;
# else an installed GTest package. `ctest` or build/amhmvs_<layer>_tests runs them.

option(AMHMVS_BUILD_TESTS "Build the core unit tests (core-only build)" ON)
if(NOT AMHMVS_BUILD_TESTS)
  return()
endif()
if(EXISTS /usr/src/googletest/CMakeLists.txt)
  set(INSTALL_GTEST OFF CACHE BOOL "" FORCE)
  set(BUILD_GMOCK OFF CACHE BOOL "" FORCE)
  add_subdirectory(/usr/src/googletest ${CMAKE_BINARY_DIR}/googletest EXCLUDE_FROM_ALL)
else()
  find_package(GTest REQUIRED)
  add_library(gtest_main ALIAS GTest::gtest_main)
endif()
enable_testing()
amhmvs_add_unit_tests(ctest)
