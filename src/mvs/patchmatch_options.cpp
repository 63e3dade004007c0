#include "amhmvs_mapping/mvs/patchmatch_options.h"

#include <cmath>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mvs/matching_cost.h"

namespace amhmvs {
namespace {

template <typename Enum>
OptionInfo choice(const char* name, Enum PatchMatchOptions::*member, const char* first,
                  const char* second, const char* help) {
  return {name, help,
          [=](const PatchMatchOptions& o) {
            return std::string(static_cast<int>(o.*member) == 0 ? first : second);
          },
          [=](PatchMatchOptions& o, const std::string& text) {
            if (text == first) {
              o.*member = static_cast<Enum>(0);
            } else if (text == second) {
              o.*member = static_cast<Enum>(1);
            } else {
              throw InputError(std::string("option ") + name + ": '" + text + "' is not one of " +
                               first + ", " + second);
            }
          }};
}

}  // namespace

const std::vector<OptionInfo>& patchMatchOptionTable() {
  using O = PatchMatchOptions;
  static const std::vector<OptionInfo> table = {
      numberField("iterations", &O::num_iterations, "PatchMatch iterations (paper: 6)"),
      numberField("seed", &O::random_seed, "random seed; equal seeds give equal depth maps"),
      numberField("window_radius", &O::window_radius, "matching window radius in pixels (paper: 5, 11x11)"),
      numberField("window_step", &O::window_step, "window sampling step, 2 = every other row and column"),
      numberField("sigma_color", &O::sigma_color, "bilateral weight sigma_I on intensities 0..255 (paper: 3)"),
      numberField("sigma_spatial", &O::sigma_spatial, "bilateral weight sigma_x in pixels (paper: 30)"),
      choice("propagation", &O::propagation, "asymmetric", "symmetric",
             "checkerboard propagation: asymmetric (paper) or symmetric (ablation \\ACP)"),
      choice("view_selection", &O::view_selection, "joint", "topk",
             "view selection: joint multi-hypothesis (paper) or heuristic top-K (ablation \\MHJ)"),
      numberField("tau_mc_init", &O::tau_mc_init, "eq. 9 initial good-cost threshold (paper: 0.8)"),
      numberField("tau_alpha", &O::tau_alpha, "eq. 9 threshold decay alpha (paper: 90)"),
      numberField("tau_up", &O::tau_up, "bad-cost threshold (paper: 1.2)"),
      numberField("n1", &O::n1, "a good view has more than n1 good costs (paper: 2)"),
      numberField("n2", &O::n2, "a good view has fewer than n2 bad costs (paper: 3)"),
      numberField("beta", &O::beta, "eq. 10 confidence width (paper: 0.3)"),
      numberField("top_k", &O::top_k, "at most k weighted views per pixel (paper: 4)"),
      numberField("best_view_boost", &O::best_view_boost, "eq. 13 factor for last iteration's best view (paper: 2)"),
      numberField("previous_selection_weight", &O::previous_selection_weight,
            "eq. 12 weight of a view selected in the last iteration only (paper: 0.2)"),
      numberField("heuristic_k", &O::heuristic_k, "K of the top-K aggregation (ablation, empty-set fallback)"),
      numberField("bisection_only_iterations", &O::bisection_only_iterations,
            "first iterations with bisection refinement only (paper: 3)"),
      numberField("bisection_steps", &O::bisection_steps, "bisection samples per pixel and pass"),
      numberField("perturbation", &O::perturbation, "relative depth / normal perturbation of the COLMAP-style refinement"),
      numberField("max_normal_angle", &O::max_normal_angle_deg, "steepest accepted plane to the viewing ray, degrees"),
      numberField("geometric_weight", &O::geometric_weight,
                  "geometric pass: cost per pixel of forward-backward reprojection error (not in the paper)"),
      numberField("geometric_max_error", &O::geometric_max_error,
                  "geometric pass: reprojection error cap in pixels (not in the paper)"),
      numberField("multiscale", &O::multiscale_levels,
                  "coarse-to-fine scales, each half the next; 1: single scale, the paper (not in the paper)"),
      numberField("multiscale_iterations", &O::multiscale_iterations,
                  "iterations at each finer scale, from the coarser scale's planes (not in the paper)"),
      switchField("planar_prior", &O::planar_prior,
                  "a second pass with a prior from the first one's triangulated confident pixels, for weakly "
                  "textured planes (not in the paper)"),
      numberField("planar_prior_iterations", &O::planar_prior_iterations,
                  "planar prior: iterations of local refinement in the second pass"),
      numberField("planar_prior_weight", &O::planar_prior_weight,
                  "planar prior: the most it adds to a hypothesis's cost (lambda; matching costs are 0..2)"),
      numberField("planar_prior_max_cost", &O::planar_prior_max_cost,
                  "planar prior: a pixel of the first pass supports it when its cost is at most this"),
      numberField("planar_prior_cell", &O::planar_prior_cell,
                  "planar prior: one support point (the lowest cost) per cell of this many pixels square"),
      numberField("planar_prior_depth_sigma", &O::planar_prior_depth_sigma,
                  "planar prior: width of its depth term, relative to the depth"),
      numberField("planar_prior_normal_sigma", &O::planar_prior_normal_sigma_deg,
                  "planar prior: width of its normal term, degrees"),
      numberField("planar_prior_max_vertex_angle", &O::planar_prior_max_vertex_angle_deg,
                  "planar prior: a triangle is used when its plane is within this angle of its corners' normals, "
                  "degrees"),
      numberField("planar_prior_max_gradient", &O::planar_prior_max_gradient,
                  "planar prior: only at pixels whose mean grey-level gradient over 5x5 pixels is below this "
                  "(weak texture; grey levels per pixel)"),
      numberField("median_filter", &O::median_filter_size, "median filter size on depth (paper: 4; 0 or 1: off)"),
  };
  return table;
}

std::string PatchMatchOptions::validate() const {
  std::ostringstream why;
  auto require = [&](bool ok, const char* text) {
    if (!ok) why << text << "\n";
  };
  require(num_iterations >= 1 && num_iterations <= 100, "iterations must be in 1..100");
  require(window_radius >= 1 && window_radius <= 15, "window_radius must be in 1..15");
  require(window_step >= 1 && window_step <= window_radius, "window_step must be in 1..window_radius");
  require(window_step >= 1 && (2 * window_radius) % window_step == 0,
          "window_step must divide 2 * window_radius, so that the window is centred on the pixel");
  const int per_axis = 2 * window_radius / std::max(window_step, 1) + 1;
  require(per_axis * per_axis <= mvs::kMaxWindowSamples,
          "window has too many samples: (2 * window_radius / window_step + 1)^2 must be <= 64");
  require(std::isfinite(sigma_color) && sigma_color > 0, "sigma_color must be positive");
  require(std::isfinite(sigma_spatial) && sigma_spatial > 0, "sigma_spatial must be positive");
  require(std::isfinite(tau_mc_init) && tau_mc_init > 0 && tau_mc_init <= 2, "tau_mc_init must be in (0, 2]");
  require(std::isfinite(tau_alpha) && tau_alpha > 0, "tau_alpha must be positive");
  require(std::isfinite(tau_up) && tau_up >= 0 && tau_up <= 2, "tau_up must be in [0, 2]");
  require(n1 >= 0 && n1 < 8, "n1 must be in 0..7 (there are 8 hypotheses)");
  require(n2 >= 1 && n2 <= 9, "n2 must be in 1..9");
  require(std::isfinite(beta) && beta > 0, "beta must be positive");
  require(top_k >= 1 && top_k <= kMaxSourceViews, "top_k must be in 1..32");
  require(std::isfinite(best_view_boost) && best_view_boost >= 1, "best_view_boost must be >= 1");
  require(std::isfinite(previous_selection_weight) && previous_selection_weight >= 0 &&
              previous_selection_weight <= 1,
          "previous_selection_weight must be in [0, 1]");
  require(heuristic_k >= 1 && heuristic_k <= kMaxSourceViews, "heuristic_k must be in 1..32");
  require(bisection_only_iterations >= 0, "bisection_only_iterations must be >= 0");
  require(bisection_steps >= 0 && bisection_steps <= 8, "bisection_steps must be in 0..8");
  require(std::isfinite(perturbation) && perturbation > 0 && perturbation < 1,
          "perturbation must be in (0, 1)");
  require(std::isfinite(max_normal_angle_deg) && max_normal_angle_deg > 0 &&
              max_normal_angle_deg < 90,
          "max_normal_angle must be in (0, 90) degrees");
  require(std::isfinite(geometric_weight) && geometric_weight >= 0 && geometric_weight <= 10,
          "geometric_weight must be in [0, 10]");
  require(std::isfinite(geometric_max_error) && geometric_max_error > 0 && geometric_max_error <= 100,
          "geometric_max_error must be in (0, 100] pixels");
  require(first_iteration >= 0 && first_iteration <= 100, "first_iteration must be in 0..100");
  require(multiscale_levels >= 1 && multiscale_levels <= 6, "multiscale must be in 1..6");
  require(multiscale_iterations >= 1 && multiscale_iterations <= 100, "multiscale_iterations must be in 1..100");
  require(planar_prior_iterations >= 1 && planar_prior_iterations <= 100,
          "planar_prior_iterations must be in 1..100");
  require(std::isfinite(planar_prior_weight) && planar_prior_weight >= 0 && planar_prior_weight <= 2,
          "planar_prior_weight must be in [0, 2]");
  require(std::isfinite(planar_prior_max_cost) && planar_prior_max_cost > 0 && planar_prior_max_cost <= 2,
          "planar_prior_max_cost must be in (0, 2]");
  require(planar_prior_cell >= 2 && planar_prior_cell <= 256, "planar_prior_cell must be in 2..256 pixels");
  require(std::isfinite(planar_prior_depth_sigma) && planar_prior_depth_sigma > 0 && planar_prior_depth_sigma <= 1,
          "planar_prior_depth_sigma must be in (0, 1]");
  require(std::isfinite(planar_prior_normal_sigma_deg) && planar_prior_normal_sigma_deg > 0 &&
              planar_prior_normal_sigma_deg <= 90,
          "planar_prior_normal_sigma must be in (0, 90] degrees");
  require(std::isfinite(planar_prior_max_vertex_angle_deg) && planar_prior_max_vertex_angle_deg > 0 &&
              planar_prior_max_vertex_angle_deg <= 90,
          "planar_prior_max_vertex_angle must be in (0, 90] degrees");
  require(std::isfinite(planar_prior_max_gradient) && planar_prior_max_gradient > 0,
          "planar_prior_max_gradient must be positive");
  require(median_filter_size >= 0 && median_filter_size <= 8, "median_filter must be in 0..8");
  return why.str();
}

std::string describe(const PatchMatchOptions& options) {
  std::ostringstream out;
  for (const OptionInfo& info : patchMatchOptionTable()) {
    out << "  --" << info.name << " " << info.get(options) << "\n      " << info.help << "\n";
  }
  return out.str();
}

}  // namespace amhmvs
