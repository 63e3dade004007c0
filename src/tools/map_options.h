// The command line of amhmvs_map: which frames of a recorded sequence become
// keyframes, the pipeline's options, what is written.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "amhmvs_mapping/io/posed_sequence.h"
#include "amhmvs_mapping/mapping/keyframe_picker.h"
#include "amhmvs_mapping/mapping/mapping_pipeline.h"

namespace amhmvs {

struct FrameSelection {
  size_t start = 0;   // first frame (index into the sequence)
  size_t count = 0;   // frames looked at after start (after stride); 0 = all
  size_t stride = 1;  // every stride-th frame
  // Motion, pure-rotation and blur tests (mapping/keyframe_picker.h).
  KeyframePickerOptions picking;
};

struct MapToolOptions {
  PipelineOptions pipeline;   // from MappingParameters; its queue_size is set by resolvedQueueSize()
  size_t queue_size = 0;      // --queue_size; 0 = the default of the mode
  PosedSequenceOptions sequence;
  FrameSelection frames;
  int max_image_size = -1;    // longest side of the processed images; 0 = as recorded, -1 = auto (run() resolves it)
  double depth_min = 0, depth_max = 0;  // > 0: the depth range of every keyframe
  double realtime_rate = 0;   // > 0: replay at this multiple of the recording's rate
  bool write_depth = true;
  bool write_previews = false;
  bool write_clouds = true;
  bool write_confidence = false;  // confidence/NNNNNN.pfm of each fused keyframe (with mapper.confidence)
  size_t writer_queue = 32;   // results waiting for the writer thread
  bool quiet = false;
};

// Parses the options after SEQUENCE_DIR OUTPUT_DIR; throws InputError for
// unknown options, bad values and invalid combinations.
MapToolOptions parseMapToolArguments(const std::vector<std::string>& arguments);
std::string mapToolUsage();

// Offline (no --realtime): every keyframe waits, so the queue holds them all;
// realtime: the pipeline's default (4) unless --queue_size was given.
size_t resolvedQueueSize(const MapToolOptions& options, size_t keyframes);

}  // namespace amhmvs
