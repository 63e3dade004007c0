// What the realism mode of amhmvs_synthetic did to each frame, in the units
// that matter to a mapper (pixels of image motion through the true depth):
// written next to the sequence as realism.txt and summed up on stderr.
#pragma once

#include <string>
#include <vector>

#include "amhmvs_mapping/simulation/realistic_capture.h"

namespace amhmvs {

struct FrameRealismReport {
  double gain = 1, offset = 0;
  double position_error_m = 0;      // written centre - true centre (of the middle row)
  double rotation_error_deg = 0;    // angle between the written and the true rotation
  double pose_error_px = 0;         // mean image motion from the true to the written camera
  double time_offset_px = 0;        // ... from the camera at the stamp to the one at stamp + offset
  double rolling_shutter_px = 0;    // ... between the first and the last row's camera
  double motion_blur_px = 0;        // ... from the start to the end of the exposure
};

// The report of one frame, from its true depth (`view`, as
// renderRealisticView returns it) and the written camera.
FrameRealismReport reportFrame(const RenderedView& view, const PinholeCamera& written, const CameraTrajectory& trajectory,
                               int frame, const RealismOptions& options, const FrameDisturbance& disturbance);

// Writes `path`: the options (name value, one a line, and the frame period),
// then a row per frame. Throws InputError when it cannot write.
void writeRealismReport(const std::string& path, const RealismOptions& options, double frame_period_s,
                        const std::vector<FrameRealismReport>& frames);

// One line: the means over the frames.
std::string summarizeRealism(const std::vector<FrameRealismReport>& frames);

}  // namespace amhmvs
