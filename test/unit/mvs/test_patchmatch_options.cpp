// PatchMatchOptions (defaults, validate(), the option table) and
// DepthProblem::validate() with the estimator's refusal of bad input.
#include "amhmvs_mapping/mvs/patchmatch_options.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

const OptionInfo& option(const std::string& name) {
  for (const OptionInfo& info : patchMatchOptionTable()) {
    if (info.name == name) return info;
  }
  ADD_FAILURE() << "no option " << name;
  static const OptionInfo none{};
  return none;
}

int lineCount(const std::string& text) {
  int n = 0;
  for (char c : text) n += c == '\n';
  return n;
}

TEST(PatchMatchOptions, DefaultsAreThePapersValues) {
  const PatchMatchOptions o;
  EXPECT_EQ(o.num_iterations, 6);
  EXPECT_EQ(o.sigma_color, 3.0f);
  EXPECT_EQ(o.sigma_spatial, 30.0f);
  EXPECT_EQ(o.tau_mc_init, 0.8f);
  EXPECT_EQ(o.tau_alpha, 90.0f);
  EXPECT_EQ(o.beta, 0.3f);
  EXPECT_EQ(o.n1, 2);
  EXPECT_EQ(o.n2, 3);
  EXPECT_EQ(o.tau_up, 1.2f);
  EXPECT_EQ(o.top_k, 4);
  EXPECT_EQ(o.window_radius, 5);
  EXPECT_EQ(o.window_step, 2);
  EXPECT_EQ(o.median_filter_size, 4);
  EXPECT_EQ(o.bisection_only_iterations, 3);
  EXPECT_EQ(o.best_view_boost, 2.0f);
  EXPECT_EQ(o.previous_selection_weight, 0.2f);
  EXPECT_EQ(o.propagation, PropagationScheme::kAsymmetric);
  EXPECT_EQ(o.view_selection, ViewSelectionScheme::kMultiHypothesisJoint);
}

TEST(PatchMatchOptions, DefaultsAreValid) { EXPECT_EQ(PatchMatchOptions().validate(), ""); }

TEST(PatchMatchOptions, ValidateNamesEachBadValue) {
  struct Case {
    std::function<void(PatchMatchOptions&)> change;
    std::string needle;
  };
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<Case> cases = {
      {[](PatchMatchOptions& o) { o.num_iterations = -1; }, "iterations"},
      {[](PatchMatchOptions& o) { o.num_iterations = 0; }, "iterations"},
      {[](PatchMatchOptions& o) { o.beta = 0; }, "beta"},
      {[nan](PatchMatchOptions& o) { o.beta = nan; }, "beta"},
      {[](PatchMatchOptions& o) { o.window_radius = 6, o.window_step = 1; }, "samples"},  // 13^2
      {[](PatchMatchOptions& o) { o.window_radius = 15; }, "samples"},  // 16^2
      {[](PatchMatchOptions& o) { o.window_radius = 0; }, "window_radius"},
      {[](PatchMatchOptions& o) { o.window_step = 0; }, "window_step"},
      {[](PatchMatchOptions& o) { o.window_step = 6; }, "window_step"},
      {[](PatchMatchOptions& o) { o.sigma_color = 0; }, "sigma_color"},
      {[nan](PatchMatchOptions& o) { o.sigma_spatial = nan; }, "sigma_spatial"},
      {[](PatchMatchOptions& o) { o.tau_mc_init = 0; }, "tau_mc_init"},
      {[](PatchMatchOptions& o) { o.tau_alpha = -90; }, "tau_alpha"},
      {[](PatchMatchOptions& o) { o.tau_up = 2.5f; }, "tau_up"},
      {[](PatchMatchOptions& o) { o.n1 = 8; }, "n1"},
      {[](PatchMatchOptions& o) { o.n2 = 0; }, "n2"},
      {[](PatchMatchOptions& o) { o.top_k = 0; }, "top_k"},
      {[](PatchMatchOptions& o) { o.top_k = 33; }, "top_k"},
      {[](PatchMatchOptions& o) { o.best_view_boost = 0.5f; }, "best_view_boost"},
      {[](PatchMatchOptions& o) { o.previous_selection_weight = 1.5f; },
       "previous_selection_weight"},
      {[](PatchMatchOptions& o) { o.heuristic_k = 0; }, "heuristic_k"},
      {[](PatchMatchOptions& o) { o.bisection_only_iterations = -1; }, "bisection_only_iterations"},
      {[](PatchMatchOptions& o) { o.bisection_steps = 9; }, "bisection_steps"},
      {[](PatchMatchOptions& o) { o.perturbation = 0; }, "perturbation"},
      {[](PatchMatchOptions& o) { o.max_normal_angle_deg = 90; }, "max_normal_angle"},
      {[](PatchMatchOptions& o) { o.median_filter_size = 9; }, "median_filter"},
      {[](PatchMatchOptions& o) { o.multiscale_levels = 0; }, "multiscale must be in 1..6"},
      {[](PatchMatchOptions& o) { o.multiscale_levels = 7; }, "multiscale must be in 1..6"},
      {[](PatchMatchOptions& o) { o.multiscale_iterations = 0; }, "multiscale_iterations"},
  };
  for (const Case& c : cases) {
    PatchMatchOptions o;
    c.change(o);
    const std::string why = o.validate();
    EXPECT_NE(why.find(c.needle), std::string::npos) << "expected '" << c.needle << "' in: " << why;
    EXPECT_GE(lineCount(why), 1) << c.needle;
  }
}

TEST(PatchMatchOptions, ValidateListsEveryProblem) {
  PatchMatchOptions o;
  o.beta = 0;
  o.num_iterations = -3;
  o.top_k = 0;
  const std::string why = o.validate();
  EXPECT_EQ(lineCount(why), 3) << why;
  for (const char* name : {"beta", "iterations", "top_k"}) {
    EXPECT_NE(why.find(name), std::string::npos) << name << " in: " << why;
  }
}

TEST(PatchMatchOptions, EstimatorRefusesInvalidOptions) {
  PatchMatchOptions o;
  o.beta = -1;
  try {
    DepthEstimator estimator(o, Backend::kCpu);
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("beta"), std::string::npos) << e.what();
  }
}

TEST(PatchMatchOptionTable, NamesAreUniqueAndCoverTheOptions) {
  std::set<std::string> names;
  for (const OptionInfo& info : patchMatchOptionTable()) {
    EXPECT_TRUE(names.insert(info.name).second) << "duplicate " << info.name;
    EXPECT_FALSE(info.help.empty()) << info.name;
    ASSERT_TRUE(info.get && info.set) << info.name;
  }
  for (const char* name :
       {"iterations", "seed", "window_radius", "window_step", "sigma_color", "sigma_spatial",
        "propagation", "view_selection", "tau_mc_init", "tau_alpha", "tau_up", "n1", "n2", "beta",
        "top_k", "best_view_boost", "previous_selection_weight", "heuristic_k",
        "bisection_only_iterations", "bisection_steps", "perturbation", "max_normal_angle",
        "median_filter", "multiscale", "multiscale_iterations"}) {
    EXPECT_EQ(names.count(name), 1u) << name;
  }
}

TEST(PatchMatchOptionTable, GetShowsTheDefaults) {
  const PatchMatchOptions o;
  const std::map<std::string, std::string> expected = {
      {"iterations", "6"},   {"sigma_color", "3"},  {"sigma_spatial", "30"},
      {"tau_mc_init", "0.8"}, {"tau_alpha", "90"},  {"tau_up", "1.2"},
      {"n1", "2"},           {"n2", "3"},           {"beta", "0.3"},
      {"top_k", "4"},        {"window_radius", "5"}, {"window_step", "2"},
      {"median_filter", "4"}, {"bisection_only_iterations", "3"},
      {"propagation", "asymmetric"}, {"view_selection", "joint"}, {"multiscale", "1"}};
  for (const auto& [name, text] : expected) EXPECT_EQ(option(name).get(o), text) << name;
}

TEST(PatchMatchOptionTable, EverySetRoundTripsThroughGetAndTouchesOnlyItsOption) {
  const PatchMatchOptions defaults;
  const std::vector<OptionInfo>& table = patchMatchOptionTable();
  for (const OptionInfo& info : table) {
    // A value unlike every default: 7 for numbers, the other word for choices.
    std::string text = "7";
    if (info.name == "propagation") text = "symmetric";
    if (info.name == "view_selection") text = "topk";
    if (info.name == "planar_prior") text = "true";  // a switch
    ASSERT_NE(info.get(defaults), text) << info.name;
    PatchMatchOptions o;
    info.set(o, text);
    EXPECT_EQ(info.get(o), text) << info.name;
    for (const OptionInfo& other : table) {
      if (other.name != info.name) {
        EXPECT_EQ(other.get(o), other.get(defaults)) << "setting " << info.name << " changed "
                                                     << other.name;
      }
    }
    // And get() text written back gives the same options.
    PatchMatchOptions copy;
    info.set(copy, info.get(o));
    EXPECT_EQ(describe(copy), describe(o)) << info.name;
  }
}

TEST(PatchMatchOptionTable, FractionalValuesRoundTripExactly) {
  for (const char* name : {"sigma_color", "tau_mc_init", "tau_up", "beta", "perturbation",
                           "previous_selection_weight", "max_normal_angle"}) {
    PatchMatchOptions o;
    option(name).set(o, "0.37");
    EXPECT_EQ(option(name).get(o), "0.37") << name;
  }
  PatchMatchOptions o;
  option("beta").set(o, "0.45");
  EXPECT_EQ(o.beta, 0.45f);
  option("sigma_spatial").set(o, "5");
  EXPECT_EQ(o.sigma_spatial, 5.0f);
  option("iterations").set(o, "12");
  EXPECT_EQ(o.num_iterations, 12);
  option("seed").set(o, "4000000000");
  EXPECT_EQ(o.random_seed, 4000000000u);
}

TEST(PatchMatchOptionTable, GarbageThrowsInputErrorNamingTheOption) {
  for (const OptionInfo& info : patchMatchOptionTable()) {
    for (const std::string& text : {std::string("abc"), std::string(""), std::string("5x"),
                                    std::string("1 2")}) {
      if (info.name == "planar_prior" && text.empty()) continue;  // a switch: empty text turns it on
      PatchMatchOptions o;
      try {
        info.set(o, text);
        ADD_FAILURE() << info.name << " accepted '" << text << "'";
      } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(info.name), std::string::npos) << e.what();
      }
      EXPECT_EQ(info.get(o), info.get(PatchMatchOptions())) << info.name << " changed by garbage";
    }
  }
  // Integer options refuse fractions.
  for (const char* name : {"iterations", "window_radius", "n1", "top_k", "median_filter"}) {
    PatchMatchOptions o;
    EXPECT_THROW(option(name).set(o, "2.5"), InputError) << name;
  }
}

TEST(PatchMatchOptionTable, ChoicesAcceptTheirWordsOnly) {
  PatchMatchOptions o;
  option("propagation").set(o, "symmetric");
  EXPECT_EQ(o.propagation, PropagationScheme::kSymmetric);
  option("propagation").set(o, "asymmetric");
  EXPECT_EQ(o.propagation, PropagationScheme::kAsymmetric);
  option("view_selection").set(o, "topk");
  EXPECT_EQ(o.view_selection, ViewSelectionScheme::kHeuristicTopK);
  option("view_selection").set(o, "joint");
  EXPECT_EQ(o.view_selection, ViewSelectionScheme::kMultiHypothesisJoint);
  for (const char* bad : {"Symmetric", "sym", "1"}) {
    try {
      option("propagation").set(o, bad);
      ADD_FAILURE() << "accepted " << bad;
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("propagation"), std::string::npos) << message;
      EXPECT_NE(message.find("asymmetric"), std::string::npos) << message;  // lists the choices
    }
  }
  EXPECT_THROW(option("view_selection").set(o, "heuristic"), InputError);
  EXPECT_EQ(o.propagation, PropagationScheme::kAsymmetric);
}

// --- DepthProblem::validate ----------------------------------------------------

PinholeCamera camera(double x) {
  PinholeCamera c = test::centredCamera(30, 30, 30);
  c.t = Eigen::Vector3d(-x, 0, 0);  // centre at (x, 0, 0)
  return c;
}

// Problems borrow their images: these live for the whole test program.
const ImageU8& texturedImage() {
  static const ImageU8 image = [] {
    ImageU8 textured(30, 30);
    for (int y = 0; y < 30; ++y) {
      for (int x = 0; x < 30; ++x) textured.at(x, y) = static_cast<uint8_t>((x * 37 + y * 91) % 251);
    }
    return textured;
  }();
  return image;
}

DepthProblem goodProblem() {
  DepthProblem p;
  p.reference_camera = camera(0);
  p.reference_image = texturedImage();
  p.source_cameras = {camera(0.1), camera(-0.1)};
  p.source_images = {texturedImage(), texturedImage()};
  p.depth_min = 1;
  p.depth_max = 10;
  return p;
}

// Expects validate() and estimate() (CPU) to report `needle1` and `needle2`.
void expectRefused(const DepthProblem& problem, const std::string& needle1,
                   const std::string& needle2 = "") {
  const std::string why = problem.validate();
  EXPECT_NE(why.find(needle1), std::string::npos) << "'" << needle1 << "' not in: " << why;
  EXPECT_NE(why.find(needle2), std::string::npos) << "'" << needle2 << "' not in: " << why;
  const DepthEstimator estimator(PatchMatchOptions(), Backend::kCpu);
  try {
    estimator.estimate(problem);
    ADD_FAILURE() << "estimate accepted a problem with: " << needle1;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(needle1), std::string::npos) << e.what();
  }
}

TEST(DepthProblemValidate, GoodProblemIsValidAndSolves) {
  const DepthProblem p = goodProblem();
  EXPECT_EQ(p.validate(), "");
  PatchMatchOptions o;
  o.num_iterations = 1;
  const DepthMap map = DepthEstimator(o, Backend::kCpu).estimate(p);
  EXPECT_EQ(map.backend, Backend::kCpu);
  EXPECT_EQ(map.depth.width, 30);
  EXPECT_EQ(map.depth.height, 30);
  EXPECT_EQ(map.normal.channels, 3);
}

TEST(DepthProblemValidate, NonFinitePose) {
  DepthProblem p = goodProblem();
  p.reference_camera.R(1, 2) = std::numeric_limits<double>::quiet_NaN();
  expectRefused(p, "reference view", "non-finite");
  p = goodProblem();
  p.source_cameras[1].t.x() = std::numeric_limits<double>::infinity();
  expectRefused(p, "source view 1", "non-finite");
}

TEST(DepthProblemValidate, NonRigidRotation) {
  DepthProblem p = goodProblem();
  p.source_cameras[0].R *= 1.1;
  expectRefused(p, "source view 0", "not rigid");
  p = goodProblem();
  p.reference_camera.R = Eigen::Vector3d(1, 1, -1).asDiagonal();  // a reflection
  expectRefused(p, "reference view", "not rigid");
}

TEST(DepthProblemValidate, NonPositiveFocalLength) {
  DepthProblem p = goodProblem();
  p.reference_camera.fx = 0;
  expectRefused(p, "reference view", "focal");
  p = goodProblem();
  p.source_cameras[1].fy = -30;
  expectRefused(p, "source view 1", "focal");
}

TEST(DepthProblemValidate, ImageSizeMismatch) {
  DepthProblem p = goodProblem();
  const ImageU8 wrong_size(31, 30);
  p.source_images[0] = wrong_size;
  expectRefused(p, "source view 0", "31x30");
  p = goodProblem();
  p.reference_image = ImageViewU8();
  expectRefused(p, "reference view", "0x0");
  p = goodProblem();
  p.source_images.pop_back();
  expectRefused(p, "2 source cameras but 1 source images");
}

TEST(DepthProblemValidate, SourceCount) {
  DepthProblem p = goodProblem();
  p.source_cameras.clear();
  p.source_images.clear();
  expectRefused(p, "no source views");
  p = goodProblem();
  p.source_cameras.clear();
  p.source_images.clear();
  for (int i = 0; i < 33; ++i) {
    p.source_cameras.push_back(camera(0.01 * (i + 1)));
    p.source_images.push_back(texturedImage());
  }
  expectRefused(p, "33 source views", "at most 32");
  // 32 is fine.
  p.source_cameras.pop_back();
  p.source_images.pop_back();
  EXPECT_EQ(p.validate(), "");
  // Image keys: none or one per source.
  p.source_keys.assign(32, kNoImageKey);
  EXPECT_EQ(p.validate(), "");
  p.source_keys.pop_back();
  expectRefused(p, "31 source keys for 32 source views");
}

TEST(DepthProblemValidate, DepthRange) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double ranges[][2] = {{5, 5}, {10, 1}, {nan, 10}, {1, nan}, {0, 10}, {-1, 10}};
  for (const auto& range : ranges) {
    DepthProblem p = goodProblem();
    p.depth_min = range[0];
    p.depth_max = range[1];
    expectRefused(p, "depth range");
  }
}

TEST(DepthProblemValidate, ColourImageAndNoBaseline) {
  DepthProblem p = goodProblem();
  const ImageU8 colour(30, 30, 3);
  p.reference_image = colour;
  expectRefused(p, "reference view", "1 channel");
  p = goodProblem();
  p.source_images[1] = colour;
  expectRefused(p, "source view 1", "1 channel");
  p = goodProblem();
  p.source_cameras[0] = camera(0);
  expectRefused(p, "source view 0", "baseline");
}

TEST(PatchMatchOptions, WindowMustBeCentred) {
  PatchMatchOptions o;
  o.window_radius = 4;
  o.window_step = 3;  // would sample -4, -1, 2: not centred on the pixel
  EXPECT_NE(o.validate().find("centred"), std::string::npos);
}

TEST(PatchMatchOptions, NegativeSeedIsRefused) {
  PatchMatchOptions o;
  for (const OptionInfo& info : patchMatchOptionTable()) {
    if (info.name == "seed") EXPECT_THROW(info.set(o, "-1"), InputError);
  }
}

}  // namespace
}  // namespace amhmvs
