# The ROS-free libraries, one per layer, each linking only the layers below it:
#
#   amhmvs_core        src/core: camera model, images, option tables
#   amhmvs_io          src/io: file formats, posed sequences (OpenCV codecs when found)
#   amhmvs_mvs         src/mvs + cuda/cuda_backend.cu: the AMHMVS estimator, CPU and CUDA backends
#   amhmvs_mapping     src/mapping + src/pose_refinement + cuda/cuda_fusion.cu, cuda_depth_filter.cu: keyframes,
#                      fusion, the map, MappingPipeline (what the nodelet links)
#   amhmvs_simulation  src/simulation: synthetic scenes (tools and tests only; static)
#   amhmvs_eval        src/eval: accuracy against ground truth (tools and tests only; static)
#
# They need Eigen and the C++ standard library; OpenMP, OpenCV and Ceres are optional.
#
# Options:
#   AMHMVS_WITH_CUDA            build the CUDA backends when nvcc is found (ON)
#   AMHMVS_CUDA_ARCHITECTURES   GPU targets; default Turing..Hopper machine code
#                               plus Hopper PTX for newer GPUs

option(AMHMVS_WITH_CUDA "Build the CUDA backend when a CUDA compiler is found" ON)
set(AMHMVS_CUDA_ARCHITECTURES "75-real;80-real;86-real;89-real;90"
    CACHE STRING "CUDA architectures (CMake syntax; '90' adds sm_90 code and PTX)")

find_package(Eigen3 REQUIRED NO_MODULE)
find_package(OpenMP)
find_package(Threads REQUIRED)

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

# Headers most C++ files of every layer include, parsed once per target
# (not for the CUDA files: nvcc takes no precompiled header).
set(AMHMVS_PRECOMPILED_HEADERS)
foreach(header Eigen/Core Eigen/Geometry functional map memory string vector)
  list(APPEND AMHMVS_PRECOMPILED_HEADERS "$<$<COMPILE_LANGUAGE:CXX>:<${header}>>")
endforeach()

# amhmvs_add_layer(NAME [STATIC] SOURCES ... DEPENDS ...): one layer's library.
# Its private headers (src/<layer>/*.h) are included as "<layer>/name.h" by
# the CUDA files of cuda/, which are compiled into the layer they implement.
function(amhmvs_add_layer name)
  cmake_parse_arguments(layer "STATIC" "" "SOURCES;DEPENDS" ${ARGN})
  set(kind)
  if(layer_STATIC)
    set(kind STATIC)
  endif()
  add_library(amhmvs_${name} ${kind} ${layer_SOURCES})
  target_include_directories(amhmvs_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_include_directories(amhmvs_${name} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(amhmvs_${name} PUBLIC ${layer_DEPENDS})
  target_compile_features(amhmvs_${name} PUBLIC cxx_std_17)
  set_target_properties(amhmvs_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  # A shared layer must not lean on symbols of a layer above it (the
  # sanitizers' runtime is only linked into programs).
  get_target_property(type amhmvs_${name} TYPE)
  if(type STREQUAL SHARED_LIBRARY AND NOT AMHMVS_SANITIZERS)
    target_link_options(amhmvs_${name} PRIVATE LINKER:--no-undefined)
  endif()
  target_precompile_headers(amhmvs_${name} PRIVATE ${AMHMVS_PRECOMPILED_HEADERS})
  target_compile_options(amhmvs_${name} PRIVATE
    $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra>
    $<$<COMPILE_LANGUAGE:CUDA>:--expt-relaxed-constexpr -diag-suppress=20012 -lineinfo>)
endfunction()

# Every .cpp of a layer's folder, less the named files.
function(amhmvs_layer_sources var folder)
  file(GLOB sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/src/${folder}/*.cpp)
  foreach(excluded ${ARGN})
    list(REMOVE_ITEM sources ${CMAKE_CURRENT_SOURCE_DIR}/src/${folder}/${excluded})
  endforeach()
  set(${var} ${sources} PARENT_SCOPE)
endfunction()

# --- core ---
amhmvs_layer_sources(core_sources core)
amhmvs_add_layer(core SOURCES ${core_sources} DEPENDS Eigen3::Eigen Threads::Threads)
if(OpenMP_CXX_FOUND)
  target_link_libraries(amhmvs_core PUBLIC OpenMP::OpenMP_CXX)
endif()

# --- io (OpenCV's codecs for PNG/JPEG when found) ---
amhmvs_layer_sources(io_sources io image_io_opencv.cpp)
find_package(OpenCV QUIET COMPONENTS core imgcodecs)
set(AMHMVS_IO_WITH_OPENCV OFF)
if(OpenCV_FOUND AND NOT AMHMVS_CORE_WITHOUT_OPENCV)
  set(AMHMVS_IO_WITH_OPENCV ON)
  list(APPEND io_sources ${CMAKE_CURRENT_SOURCE_DIR}/src/io/image_io_opencv.cpp)
endif()
amhmvs_add_layer(io SOURCES ${io_sources} DEPENDS amhmvs_core)
if(AMHMVS_IO_WITH_OPENCV)
  target_compile_definitions(amhmvs_io PUBLIC AMHMVS_WITH_OPENCV)
  target_include_directories(amhmvs_io SYSTEM PRIVATE ${OpenCV_INCLUDE_DIRS})
  target_link_libraries(amhmvs_io PRIVATE ${OpenCV_LIBS})
endif()

# A layer's sources with its CUDA files (cuda/CU.cu for each CU named), or
# without nvcc their stubs (src/FOLDER/CU_unavailable.cpp) that say at run time
# there is none.
function(amhmvs_layer_sources_with_cuda var folder)
  set(stubs)
  foreach(cu ${ARGN})
    list(APPEND stubs ${cu}_unavailable.cpp)
  endforeach()
  amhmvs_layer_sources(sources ${folder} ${stubs})
  foreach(cu ${ARGN})
    if(AMHMVS_HAVE_CUDA)
      list(APPEND sources ${CMAKE_CURRENT_SOURCE_DIR}/cuda/${cu}.cu)
    else()
      list(APPEND sources ${CMAKE_CURRENT_SOURCE_DIR}/src/${folder}/${cu}_unavailable.cpp)
    endif()
  endforeach()
  set(${var} ${sources} PARENT_SCOPE)
endfunction()

# --- mvs (the estimator and its CUDA backend) ---
amhmvs_layer_sources_with_cuda(mvs_sources mvs cuda_backend)
amhmvs_add_layer(mvs SOURCES ${mvs_sources} DEPENDS amhmvs_io)
if(AMHMVS_HAVE_CUDA)
  target_link_libraries(amhmvs_mvs PUBLIC CUDA::cudart)
  target_compile_definitions(amhmvs_mvs PUBLIC AMHMVS_WITH_CUDA)
endif()

# --- mapping (with fusion on the GPU, and the pose refinement or its stub) ---
amhmvs_layer_sources_with_cuda(mapping_sources mapping cuda_fusion cuda_depth_filter)
amhmvs_add_layer(mapping SOURCES ${mapping_sources} DEPENDS amhmvs_mvs)
include(${CMAKE_CURRENT_LIST_DIR}/amhmvs_pose_refinement.cmake)

# --- simulation and eval: for the tools and tests, not the nodelet. Static,
# so that an install or a staged tree holds no more libraries. ---
amhmvs_layer_sources(simulation_sources simulation)
amhmvs_add_layer(simulation STATIC SOURCES ${simulation_sources} DEPENDS amhmvs_mvs)
amhmvs_layer_sources(eval_sources eval)
amhmvs_add_layer(eval STATIC SOURCES ${eval_sources} DEPENDS amhmvs_mapping)
