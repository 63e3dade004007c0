# The ROS-free core library: camera model, images, file formats, the AMHMVS
# estimator with its CPU backend and (when nvcc is found) its CUDA backend.
# Needs Eigen and the C++ standard library; OpenMP, OpenCV and Ceres are optional.
#
# Options:
#   AMHMVS_WITH_CUDA            build the CUDA backend when nvcc is found (ON)
#   AMHMVS_CUDA_ARCHITECTURES   GPU targets; default Turing..Hopper machine code
#                               plus Hopper PTX for newer GPUs

option(AMHMVS_WITH_CUDA "Build the CUDA backend when a CUDA compiler is found" ON)
set(AMHMVS_CUDA_ARCHITECTURES "75-real;80-real;86-real;89-real;90"
    CACHE STRING "CUDA architectures (CMake syntax; '90' adds sm_90 code and PTX)")

find_package(Eigen3 REQUIRED NO_MODULE)
find_package(OpenMP)

set(AMHMVS_HAVE_CUDA OFF)
if(AMHMVS_WITH_CUDA)
  if(NOT DEFINED CMAKE_CUDA_COMPILER AND EXISTS /usr/local/cuda/bin/nvcc)
    set(CMAKE_CUDA_COMPILER /usr/local/cuda/bin/nvcc)
  endif()
  include(CheckLanguage)
  check_language(CUDA)
  if(CMAKE_CUDA_COMPILER)
    set(CMAKE_CUDA_ARCHITECTURES ${AMHMVS_CUDA_ARCHITECTURES})
    enable_language(CUDA)
    find_package(CUDAToolkit REQUIRED)
    set(AMHMVS_HAVE_CUDA ON)
  endif()
endif()
message(STATUS "amhmvs: CUDA backend ${AMHMVS_HAVE_CUDA} (architectures: ${AMHMVS_CUDA_ARCHITECTURES})")

set(AMHMVS_CORE_SOURCES
  src/core/camera.cpp
  src/core/fresh_memory.cpp
  src/core/image.cpp
  src/io/scene.cpp
  src/io/pfm.cpp
  src/io/image_io.cpp
  src/io/colormap.cpp
  src/io/depth_preview.cpp
  src/io/background_writer.cpp
  src/io/mvsnet_folder.cpp
  src/io/colmap_model.cpp
  src/io/point_cloud_io.cpp
  src/io/posed_sequence.cpp
  src/io/seven_scenes_sequence.cpp
  src/io/tum_rgbd_sequence.cpp
  src/io/tum_trajectory.cpp
  src/mvs/patchmatch_options.cpp
  src/mvs/propagation_pattern.cpp
  src/mvs/depth_estimator.cpp
  src/mvs/coarse_to_fine.cpp
  src/mvs/scaled_image_cache.cpp
  src/mvs/plane_map.cpp
  src/mvs/cpu_backend.cpp
  src/mvs/problem_builder.cpp
)
# The mapping core (keyframes, source selection, fusion, map): every .cpp of
# src/mapping belongs to the core.
file(GLOB AMHMVS_MAPPING_SOURCES CONFIGURE_DEPENDS src/mapping/*.cpp)
list(APPEND AMHMVS_CORE_SOURCES ${AMHMVS_MAPPING_SOURCES})
if(AMHMVS_HAVE_CUDA)
  list(APPEND AMHMVS_CORE_SOURCES cuda/cuda_backend.cu cuda/cuda_fusion.cu)
else()
  list(APPEND AMHMVS_CORE_SOURCES src/mvs/cuda_unavailable.cpp)
endif()

find_package(OpenCV QUIET COMPONENTS core imgcodecs)
if(OpenCV_FOUND AND NOT AMHMVS_CORE_WITHOUT_OPENCV)
  list(APPEND AMHMVS_CORE_SOURCES src/io/image_io_opencv.cpp)
endif()

add_library(amhmvs_core ${AMHMVS_CORE_SOURCES})
target_include_directories(amhmvs_core PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
find_package(Threads REQUIRED)
target_link_libraries(amhmvs_core PUBLIC Eigen3::Eigen Threads::Threads)
target_compile_features(amhmvs_core PUBLIC cxx_std_17)
set_target_properties(amhmvs_core PROPERTIES POSITION_INDEPENDENT_CODE ON)
target_compile_options(amhmvs_core PRIVATE
  $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra>
  $<$<COMPILE_LANGUAGE:CUDA>:--expt-relaxed-constexpr -diag-suppress=20012 -lineinfo>)
if(OpenMP_CXX_FOUND)
  target_link_libraries(amhmvs_core PUBLIC OpenMP::OpenMP_CXX)
endif()
if(AMHMVS_HAVE_CUDA)
  target_link_libraries(amhmvs_core PUBLIC CUDA::cudart)
  target_compile_definitions(amhmvs_core PUBLIC AMHMVS_WITH_CUDA)
endif()
if(OpenCV_FOUND AND NOT AMHMVS_CORE_WITHOUT_OPENCV)
  target_compile_definitions(amhmvs_core PUBLIC AMHMVS_WITH_OPENCV)
  target_include_directories(amhmvs_core SYSTEM PRIVATE ${OpenCV_INCLUDE_DIRS})
  target_link_libraries(amhmvs_core PRIVATE ${OpenCV_LIBS})
endif()
include(${CMAKE_CURRENT_LIST_DIR}/amhmvs_pose_refinement.cmake)

# Synthetic scenes with their realism mode (src/simulation) and accuracy
# against ground truth (src/eval): for the tools and tests, not the nodelet.
# Static, so that an install or a staged tree holds no more libraries.
foreach(layer simulation eval)
  file(GLOB sources CONFIGURE_DEPENDS src/${layer}/*.cpp)
  add_library(amhmvs_${layer} STATIC ${sources})
  target_link_libraries(amhmvs_${layer} PUBLIC amhmvs_core)
  set_target_properties(amhmvs_${layer} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  target_compile_options(amhmvs_${layer} PRIVATE -Wall -Wextra)
endforeach()
