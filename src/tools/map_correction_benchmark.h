// amhmvs_benchmark's table of the map corrections for real trackers (issue
// 12): rolling-shutter rectification of a keyframe image and the keyframe
// pose graph's solve, the CPU work they add per keyframe.
#pragma once

#include <string>

namespace amhmvs {

// Markdown: rectifyRollingShutter of an RGB image at 320x240 and 640x480,
// and solveKeyframePoseGraph over 10 and 50 keyframes with 3 refined pairs
// each, median of `runs` after a warm-up.
std::string mapCorrectionTable(int runs);

}  // namespace amhmvs
