# Pose refinement before stereo (mapping/pose_refinement.h): the real
# implementation needs OpenCV features2d + calib3d and Ceres; without them
# (the core-only build of the GPU machine, AMHMVS_CORE_WITHOUT_OPENCV) a
# stub says so at run time. Part of the mapping library:
# included by amhmvs_libraries.cmake after that target exists.
#
# Options:
#   AMHMVS_WITH_POSE_REFINEMENT  build it when its libraries are found (ON)

option(AMHMVS_WITH_POSE_REFINEMENT "Build the pose refinement when OpenCV features2d and Ceres are found" ON)
set(AMHMVS_HAVE_POSE_REFINEMENT OFF)
set(amhmvs_pose_why "")
if(NOT AMHMVS_WITH_POSE_REFINEMENT)
  set(amhmvs_pose_why " (AMHMVS_WITH_POSE_REFINEMENT=OFF)")
elseif(AMHMVS_CORE_WITHOUT_OPENCV)
  set(amhmvs_pose_why " (AMHMVS_CORE_WITHOUT_OPENCV)")
else()
  # Its own lookup: the io layer's OpenCV_LIBS (image codecs) are linked already.
  find_package(OpenCV QUIET COMPONENTS core features2d calib3d)
  find_package(Ceres QUIET)
  if(OpenCV_FOUND AND Ceres_FOUND)
    set(AMHMVS_HAVE_POSE_REFINEMENT ON)
  else()
    set(amhmvs_pose_why " (needs OpenCV features2d/calib3d: ${OpenCV_FOUND}, Ceres: ${Ceres_FOUND})")
  endif()
endif()
message(STATUS "amhmvs: pose refinement ${AMHMVS_HAVE_POSE_REFINEMENT}${amhmvs_pose_why}")

if(AMHMVS_HAVE_POSE_REFINEMENT)
  target_sources(amhmvs_mapping PRIVATE
    src/pose_refinement/feature_matching.cpp
    src/pose_refinement/star_bundle_adjustment.cpp
    src/pose_refinement/pose_refiner.cpp
    src/pose_refinement/keyframe_pose_graph.cpp
    src/pose_refinement/keyframe_bundle_adjustment.cpp)
  target_include_directories(amhmvs_mapping SYSTEM PRIVATE ${OpenCV_INCLUDE_DIRS})
  target_link_libraries(amhmvs_mapping PRIVATE ${OpenCV_LIBS} Ceres::ceres)
  target_compile_definitions(amhmvs_mapping PUBLIC AMHMVS_WITH_POSE_REFINEMENT)
else()
  target_sources(amhmvs_mapping PRIVATE src/pose_refinement/pose_refiner_unavailable.cpp
    src/pose_refinement/keyframe_pose_graph_unavailable.cpp
    src/pose_refinement/keyframe_bundle_adjustment_unavailable.cpp)
endif()
