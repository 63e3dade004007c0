// The offline depth job shared by amhmvs_depth, the benchmark and the tests:
// read an input folder, estimate the depth of reference views, write outputs.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "amhmvs_mapping/io/scene.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"
#include "amhmvs_mapping/mvs/problem_builder.h"

namespace amhmvs {

// Reads an MVSNet dense folder (images/, cams/, pair.txt) or a COLMAP
// workspace (sparse/ and images/); throws InputError otherwise.
Scene readInputFolder(const std::string& dir, int max_sources);

// The smallest non-zero --max_image_size: the default 11x11 window must fit.
constexpr int kMinMaxImageSize = 16;

struct DepthJobOptions {
  ProblemOptions problem;
  PatchMatchOptions patchmatch;
  Backend backend = Backend::kAuto;
  std::vector<int> reference_ids;  // empty: every view with sources
  float max_cost = 0;              // > 0: depth NaN where cost exceeds it
  bool quiet = false;
  // Folder of ground-truth z-depth maps NNNNNNNN.pfm (any resolution): when
  // set, accuracy is reported per view and pooled.
  std::string ground_truth_dir;
  // > 0 (--geometric): every listed view is estimated photometrically first,
  // then again for this many iterations from its own map, with the geometric
  // term against the listed source views' maps (geometric_consistency.h).
  int geometric_iterations = 0;
};

// Writes OUTPUT_DIR/<8-digit id>/ depth.pfm, normal.pfm, cost.pfm, depth.png
// and cam.txt.
// (`camera` and the depth range are the problem's).
void writeDepthOutputs(const std::string& output_dir, int view_id, const PinholeCamera& camera,
                       double depth_min, double depth_max, const DepthMap& map);

// The geometric pass's inputs of `problem` (made by SceneImageCache, whose
// source keys are view ids): the photometric maps of its sources (a source
// not in `photometric` has none) and of the reference itself as the start.
// The maps must outlive the problem.
void attachGeometricInputs(const std::map<int, DepthMap>& photometric, int reference_id, DepthProblem* problem);

// Masks pixels whose cost exceeds max_cost (depth := NaN).
void maskByCost(DepthMap* map, float max_cost);

// Asks the CUDA driver for one hardware work queue (CUDA_DEVICE_MAX_CONNECTIONS=1)
// unless the environment already names a number. A program that drives one
// stream at a time, as amhmvs_depth does, loses nothing by it and its context
// starts and ends faster. Call before the first CUDA call.
void preferOneCudaWorkQueue();

// Runs the job; `on_result` (if set) sees every depth map, and with
// geometric_iterations > 0 `on_photometric` (if set) sees each view's
// first-pass map before the geometric pass. Output files are written by a
// background thread (off the estimator's path); its first error is thrown
// before this returns. Returns the number of depth maps written.
int runDepthJob(const std::string& input_dir, const std::string& output_dir,
                const DepthJobOptions& options,
                const std::function<void(int, const DepthProblem&, const DepthMap&)>& on_result = {},
                const std::function<void(int, const DepthMap&)>& on_photometric = {});

// Parses the command line of amhmvs_depth (after INPUT_DIR OUTPUT_DIR);
// throws InputError on unknown options or bad values.
DepthJobOptions parseDepthJobArguments(const std::vector<std::string>& arguments);
std::string depthJobUsage();

}  // namespace amhmvs
