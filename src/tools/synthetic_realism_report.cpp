#include "synthetic_realism_report.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include <Eigen/Geometry>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/atomic_file.h"

namespace amhmvs {
namespace {

// Mean image motion between the trajectory's cameras at two times after the
// frame's stamp (0 when they are the same time).
double motionBetween(const RenderedView& view, const CameraTrajectory& trajectory, int frame, double from_s,
                     double to_s) {
  if (from_s == to_s) return 0;
  return meanImageMotion(view.depth, trajectory(frame, from_s), trajectory(frame, to_s));
}

}  // namespace

FrameRealismReport reportFrame(const RenderedView& view, const PinholeCamera& written, const CameraTrajectory& trajectory,
                               int frame, const RealismOptions& options, const FrameDisturbance& disturbance) {
  FrameRealismReport r;
  r.gain = disturbance.gain;
  r.offset = disturbance.offset;
  r.position_error_m = (written.center() - view.camera.center()).norm();
  r.rotation_error_deg = rotationAngleDeg(written.R * view.camera.R.transpose());
  r.pose_error_px = meanImageMotion(view.depth, view.camera, written);
  const double offset = options.time_offset_s, readout = options.rolling_shutter_s, exposure = options.motion_blur_s;
  r.time_offset_px = motionBetween(view, trajectory, frame, 0, offset);
  r.rolling_shutter_px = motionBetween(view, trajectory, frame, offset - readout / 2, offset + readout / 2);
  r.motion_blur_px = motionBetween(view, trajectory, frame, offset - exposure / 2, offset + exposure / 2);
  return r;
}

void writeRealismReport(const std::string& path, const RealismOptions& options, double frame_period_s,
                        const std::vector<FrameRealismReport>& frames) {
  std::ostringstream out;
  out << "# amhmvs_synthetic realism: the options, then per frame what they did. Image motion in pixels\n"
         "# through the true depth; the written pose is cams/, the true pose (middle row, mid exposure) cams_gt/.\n";
  out << "frame_period_s " << frame_period_s << "\n";
  for (const RealismOptionInfo& info : realismOptionTable()) out << info.name << " " << info.get(options) << "\n";
  out << "# frame gain offset position_error_m rotation_error_deg pose_error_px time_offset_px "
         "rolling_shutter_px motion_blur_px\n";
  char line[256];
  for (size_t i = 0; i < frames.size(); ++i) {
    const FrameRealismReport& f = frames[i];
    std::snprintf(line, sizeof(line), "%zu %.4f %.3f %.5f %.4f %.3f %.3f %.3f %.3f\n", i, f.gain, f.offset,
                  f.position_error_m, f.rotation_error_deg, f.pose_error_px, f.time_offset_px, f.rolling_shutter_px,
                  f.motion_blur_px);
    out << line;
  }
  writeFileAtomically(path, out.str(), "realism report");
}

std::string summarizeRealism(const std::vector<FrameRealismReport>& frames) {
  FrameRealismReport mean;
  mean.gain = mean.offset = 0;
  for (const FrameRealismReport& f : frames) {
    mean.position_error_m += f.position_error_m / frames.size();
    mean.rotation_error_deg += f.rotation_error_deg / frames.size();
    mean.pose_error_px += f.pose_error_px / frames.size();
    mean.time_offset_px += f.time_offset_px / frames.size();
    mean.rolling_shutter_px += f.rolling_shutter_px / frames.size();
    mean.motion_blur_px += f.motion_blur_px / frames.size();
  }
  char text[320];
  std::snprintf(text, sizeof(text),
                "realism, mean per frame: written pose %.1f mm / %.2f deg from the true one (%.2f px of image "
                "motion); timing offset %.2f px, rolling shutter %.2f px top to bottom, motion blur %.2f px",
                1000 * mean.position_error_m, mean.rotation_error_deg, mean.pose_error_px, mean.time_offset_px,
                mean.rolling_shutter_px, mean.motion_blur_px);
  return text;
}

}  // namespace amhmvs
