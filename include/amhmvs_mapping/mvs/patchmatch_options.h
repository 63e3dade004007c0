// Options of the AMHMVS PatchMatch depth estimator.
//
// Every parameter of the paper (Xu & Tao, "Multi-View Stereo with Asymmetric
// Checkerboard Propagation and Multi-Hypothesis Joint View Selection", section
// 3 and 4) is a named option with the paper's default. `validate()` returns the
// problems as readable text.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace amhmvs {

// Maximum number of source views per depth map: view sets are 32-bit masks.
constexpr int kMaxSourceViews = 32;

enum class PropagationScheme {
  kAsymmetric,  // paper section 3.1: 4 near V regions (7) + 4 far lines (11)
  kSymmetric,   // ablation "\ACP": Gipuma's fixed checkerboard neighbours
};

enum class ViewSelectionScheme {
  kMultiHypothesisJoint,  // paper section 3.2, eqs. 8-14
  kHeuristicTopK,         // ablation "\MHJ": mean of each hypothesis's K best costs
};

struct PatchMatchOptions {
  // --- Schedule (section 4) ---
  int num_iterations = 6;
  uint32_t random_seed = 0;

  // --- Matching cost (eq. 15) ---
  int window_radius = 5;       // 11x11 window
  int window_step = 2;         // "skipping": every other row and column
  float sigma_color = 3.0f;    // sigma_I, on intensities 0..255
  float sigma_spatial = 30.0f; // sigma_x, in pixels (the public code uses 5)

  // --- Propagation (section 3.1) ---
  PropagationScheme propagation = PropagationScheme::kAsymmetric;

  // --- Multi-hypothesis joint view selection (eqs. 9-14) ---
  ViewSelectionScheme view_selection = ViewSelectionScheme::kMultiHypothesisJoint;
  float tau_mc_init = 0.8f;   // eq. 9: good-cost threshold at t = 0
  float tau_alpha = 90.0f;    // eq. 9: tau_mc(t) = tau_mc_init * exp(-t^2 / alpha)
  float tau_up = 1.2f;        // bad-cost threshold
  int n1 = 2;                 // a good view has more than n1 costs below tau_mc(t)
  int n2 = 3;                 // ... and fewer than n2 costs above tau_up
  float beta = 0.3f;          // eq. 10: confidence exp(-m^2 / (2 beta^2))
  int top_k = 4;              // keep at most k most important views
  float best_view_boost = 2.0f;        // eq. 13: weight factor of last iteration's best view
  float previous_selection_weight = 0.2f;  // eq. 12: weight of a view selected last time only
  int heuristic_k = 3;        // K of the heuristic top-K ablation and of the empty-set fallback

  // --- Refinement (section 3.3) ---
  int bisection_only_iterations = 3;   // first iterations: bisection refinement only
  int bisection_steps = 1;             // bisection candidates per pixel and pass
  float perturbation = 0.02f;          // COLMAP-style: relative depth / normal perturbation
  float max_normal_angle_deg = 80.0f;  // hypotheses steeper than this to the ray are rejected

  // --- Geometric consistency (not in the paper; geometric_consistency.h) ---
  // Used when a problem carries the source views' depth maps.
  float geometric_weight = 0.2f;     // lambda: cost per pixel of reprojection error
  float geometric_max_error = 3.0f;  // tau: reprojection errors are capped here, pixels
  // Number of the first iteration (not a table option): a pass that starts
  // from a prior depth map (the geometric pass) starts at 3, with the late
  // iterations' local refinement and view-selection thresholds.
  int first_iteration = 0;

  // --- Coarse-to-fine (not in the paper; coarse_to_fine.h) ---
  // A low-texture aid: estimate at multiscale_levels scales, each half the
  // size of the next, each finer one starting from the coarser one's planes
  // for multiscale_iterations iterations of local refinement. 1: single scale
  // (the paper).
  int multiscale_levels = 1;
  int multiscale_iterations = 2;

  // --- Planar prior (not in the paper; planar_prior.h) ---
  // A second pass from the first estimate, with a prior from the triangulated
  // confident pixels that holds weakly textured planes.
  bool planar_prior = false;
  int planar_prior_iterations = 1;          // iterations of the second pass (local refinement; 2 lose on redkitchen)
  float planar_prior_weight = 0.3f;         // lambda: the most the prior adds to a hypothesis's cost
  float planar_prior_max_cost = 0.3f;       // a support point's matching cost, at most
  int planar_prior_cell = 8;                // one support point per cell of this many pixels square
  float planar_prior_depth_sigma = 0.02f;   // sigma_d, relative depth
  float planar_prior_normal_sigma_deg = 10.0f;      // sigma_n
  float planar_prior_max_vertex_angle_deg = 30.0f;  // a triangle's plane against its corners' normals, at most
  // Weakly textured pixels only (core/texture.h): where the image has texture
  // the matching cost is sharper than a triangle's plane is right.
  float planar_prior_max_gradient = 3.0f;

  // --- Post-processing ---
  int median_filter_size = 4;  // paper: 4x4 median on depth; 0 or 1 disables

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

// One line per option: name, value, meaning; for --help and logs.
std::string describe(const PatchMatchOptions& options);

}  // namespace amhmvs

#include "amhmvs_mapping/core/option_field.h"

namespace amhmvs {

// One documented option of the estimator (OptionField: name, meaning,
// accessors by text).
using OptionInfo = OptionField<PatchMatchOptions>;
const std::vector<OptionInfo>& patchMatchOptionTable();

}  // namespace amhmvs
