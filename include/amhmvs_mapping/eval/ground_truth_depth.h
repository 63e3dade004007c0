// Ground-truth depth of a recorded frame in the colour camera that the
// mapping processed: read from the recording's depth file (PFM metres or
// 16-bit PNG/PGM with a unit), then resampled (depth registered to the
// colour image) or reprojected (a depth camera of its own, e.g. the Kinect
// of 7-Scenes).
#pragma once

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/eval/cloud_metrics.h"
#include "amhmvs_mapping/io/posed_sequence.h"

namespace amhmvs {

// The depth file in metres (NaN where 0, invalid_value or not finite) with
// its camera: `color_camera` (any resolution) when registered, else the
// source's depth camera. Throws InputError naming the file.
DepthMapView readGroundTruthDepth(const GroundTruthDepthSource& source, const PinholeCamera& color_camera);

// The true surface of a frame in the world: its ground-truth depth (as read
// by readGroundTruthDepth) placed at the frame's true pose where the
// recording has one apart from the tracker's (PosedFrame::true_camera:
// amhmvs_synthetic --realism, registered depth; a tracker's trajectory read
// over a sequence, the depth camera moved with the colour camera), else at
// the recorded pose (7-Scenes: the KinectFusion poses are the ground truth). A map placed with
// a tracker's poses is judged against this surface, not against the truth
// moved by the tracker's error.
DepthMapView trueSurfaceView(const DepthMapView& truth, const PosedFrame& frame);

// Nearest-sample resampling of a 1-channel image to width x height (pixel
// centres scaled).
ImageF resampleNearest(const ImageF& image, int width, int height);

// Forward warp of a z-depth map into another camera: every valid pixel is
// back-projected and splatted to the nearest pixel of `to`, the nearest depth
// winning (z-buffer); pixels nothing lands on stay NaN.
ImageF reprojectDepth(const DepthMapView& from, const PinholeCamera& to);

// Ground truth read with readGroundTruthDepth as z-depth in `camera` (the
// colour camera at the processed resolution): resampled when registered,
// else reprojected.
ImageF groundTruthDepthIn(const DepthMapView& truth, bool registered, const PinholeCamera& camera);
// The same, reading the source.
ImageF groundTruthDepthIn(const GroundTruthDepthSource& source, const PinholeCamera& camera);

}  // namespace amhmvs
