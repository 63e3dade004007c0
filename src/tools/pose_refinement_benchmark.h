// amhmvs_benchmark's pose refinement table (mapping/pose_refinement.h).
#pragma once

#include <string>

namespace amhmvs {

// Markdown: the time of PoseRefiner::refine on the folded planes at 320x240
// and 640x480 with 4 sources, each 12 mm / 0.5 degrees off: the first
// keyframe of a run (every image's features detected) and an online one
// (the sources' features cached, the new keyframe's detected), median of
// `runs`, with its stages.
std::string poseRefinementTable(int runs);

}  // namespace amhmvs
