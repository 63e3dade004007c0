#include "amhmvs_mapping/mapping/depth_confidence.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "fusion_driver.h"

namespace amhmvs {

std::string ConfidenceOptions::validate() const {
  std::ostringstream why;
  if (!(min_probability >= 0 && min_probability <= 1))
    why << "min_probability must be in [0, 1] (got " << min_probability << ")\n";
  return why.str();
}

namespace {

fusion::ViewData viewData(const FusionView& view) {
  return fusion::viewData(view, view.depth.data, view.normal.data, view.cost.data, view.color.data, nullptr);
}

}  // namespace

AgreementCounts countAgreement(const FusionView& reference, const std::vector<FusionView>& views,
                               const FusionOptions& checks) {
  fusion::agreementViews(reference, views, checks);  // validation only
  fusion::Checks pixel_checks = fusion::checks(checks);
  pixel_checks.skip_used = false;  // every view counts, whatever was fused before
  const fusion::ViewData ref_data = viewData(reference);
  std::vector<fusion::ViewData> sources;
  for (const FusionView& view : views) sources.push_back(viewData(view));
  const int width = reference.camera.width, height = reference.camera.height;
  AgreementCounts counts{ImageU8(width, height), ImageU8(width, height)};
  const int count = static_cast<int>(sources.size());
#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      int seen = 0, agreeing = 0;
      if (!fusion::countAgreement(ref_data, sources.data(), count, pixel_checks, x, y, &seen, &agreeing)) continue;
      counts.seen.at(x, y) = static_cast<uint8_t>(std::min(seen, 255));
      counts.agreeing.at(x, y) = static_cast<uint8_t>(std::min(agreeing, 255));
    }
  }
  return counts;
}

ImageF calibratedConfidence(const AgreementCounts& counts, const ImageViewF& depth, const ImageViewF& cost,
                            const ConfidenceCalibration& calibration) {
  const int width = depth.width, height = depth.height;
  if (!counts.seen.sameSize(width, height) || !counts.agreeing.sameSize(width, height) ||
      (!cost.empty() && !cost.sameSize(width, height))) {
    throw InputError("confidence: agreement counts, depth and cost maps differ in size");
  }
  ImageF confidence(width, height, 1, 0.0f);
  const confidence::TableView table = calibration.view();
  // Per pixel, on all cores (640x480 single-threaded: milliseconds of the
  // online pipeline's keyframe budget).
  const long pixels = static_cast<long>(depth.pixelCount());
#pragma omp parallel for schedule(static)
  for (long i = 0; i < pixels; ++i) {
    confidence.data[i] = confidence::pixelConfidence(table, counts.seen.data[i], counts.agreeing.data[i],
                                                     depth.data[i], cost.empty() ? 0.0f : cost.data[i]);
  }
  return confidence;
}

ImageF maskDepth(const ImageViewF& depth, const ImageViewF& confidence, float min_probability) {
  if (!confidence.sameSize(depth.width, depth.height)) throw InputError("confidence: depth and confidence differ in size");
  ImageF masked(depth.width, depth.height);
  const long pixels = static_cast<long>(depth.pixelCount());
#pragma omp parallel for schedule(static)
  for (long i = 0; i < pixels; ++i) {
    masked.data[i] = confidence::publishedDepth(depth.data[i], confidence.data[i], min_probability);
  }
  return masked;
}

PublishedDepth publishDepth(const FusionView& reference, const std::vector<FusionView>& views,
                            const ConfidenceOptions& options, const ConfidenceCalibration& calibration,
                            const AgreementFunction& count) {
  PublishedDepth published;
  published.counts = count ? count(reference, views, calibration.checks)
                           : countAgreement(reference, views, calibration.checks);
  published.confidence = calibratedConfidence(published.counts, reference.depth, reference.cost, calibration);
  published.depth = maskDepth(reference.depth, published.confidence, options.min_probability);
  published.min_probability = options.min_probability;
  return published;
}

}  // namespace amhmvs
