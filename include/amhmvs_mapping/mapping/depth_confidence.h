// A calibrated per-pixel confidence of a keyframe's depth map from its
// agreement with other keyframes' depth maps, and the depth map as published:
// NaN where the confidence is below a level.
//
// For every pixel with an estimate, the keyframe's consistency views are
// asked with the fusion's own per-view test (fusion_pixel.h checkSource)
// under the calibration's checks: `seen` views see the pixel's 3D point,
// `agreeing` of them agree. The confidence is the calibration table's
// probability that the depth is within calibration.within (5 %) of the truth
// for (seen, agreeing, matching-cost bin) (confidence_calibration.h); 0 where
// the depth map has no estimate.
//
// Online (online_mapper.h), a keyframe's confidence is computed when it is
// fused, against the views it is fused against (earlier and later keyframes
// with depth maps); a refined keyframe is fused again and gets a new one.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/mapping/confidence_calibration.h"
#include "amhmvs_mapping/mapping/fusion.h"

namespace amhmvs {

struct ConfidenceOptions {
  // Compute the confidence when a keyframe is fused and publish its depth
  // map then, masked (false: depth maps are published unmasked as soon as
  // they are estimated, with 1 - cost / 2 as their confidence).
  bool enabled = true;
  // Published depth: NaN where the confidence is below this (0: nothing
  // masked). From the precision/completeness curve (README): on redkitchen
  // 90.6 % of the published pixels are within 10 % of the Kinect depth at
  // 23.3 % completeness (unmasked 55.9 % at 94.5 %); 88.6 % at 28.2 % with
  // again_with_more_views (amhmvs_map, 60 frames).
  float min_probability = 0.97f;
  // A keyframe fused with fewer consistency views than this table counts
  // (max_views, 4; the first keyframes of a run are fused once two views see
  // them, and with two views no evidence reaches 0.97, so they published
  // nothing) is fused and published again when more views see it, during
  // the next 8 depth maps, as idle work (OnlineMapper::fuseAgain: the
  // pipeline runs it when no keyframe waits); its map points are replaced.
  // Realism room (8 views, 320 px, --pose_refinement): published
  // completeness 58.8 -> 73.7 % at 99.4 % within 5 %; redkitchen (60
  // frames): 23.5 -> 28.2 % at 90.6 -> 88.6 % within 10 % (README).
  // Also with enabled false (then only its points are replaced): more views
  // confirm more of a depth map, and without it the map's coverage depended
  // on whether later keyframes were estimated before a keyframe was first
  // fused, i.e. on the machine's speed (fountain bag: 83.5 % at 0.1x vs
  // 86-87 % at 1x on 2 cores).
  bool again_with_more_views = true;

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

// Per pixel: consistency views that see the pixel's point and that agree
// (0 where the reference has no usable estimate).
struct AgreementCounts {
  ImageU8 seen, agreeing;
};

// Counts for `reference` against `views` (FusionView::source_ids are
// ignored) under `checks`, on the CPU. Throws InputError like fuseDepthMaps
// for views it cannot read. (DepthMapFuser::countAgreement: the same where
// the fuser runs, e.g. on the GPU from its resident maps.)
AgreementCounts countAgreement(const FusionView& reference, const std::vector<FusionView>& views,
                               const FusionOptions& checks);
// The counting the online mapper calls (countAgreement, or a fuser's).
using AgreementFunction =
    std::function<AgreementCounts(const FusionView&, const std::vector<FusionView>&, const FusionOptions&)>;

// The calibrated confidence of each pixel (0 where `depth` has no positive
// finite value); `cost` may be empty (then the lowest cost bin).
ImageF calibratedConfidence(const AgreementCounts& counts, const ImageViewF& depth, const ImageViewF& cost,
                            const ConfidenceCalibration& calibration);

// `depth` with NaN wherever confidence < min_probability.
ImageF maskDepth(const ImageViewF& depth, const ImageViewF& confidence, float min_probability);

// A keyframe's depth map as published, with its confidence and the counts.
struct PublishedDepth {
  ImageF depth;       // NaN where masked or without estimate
  ImageF confidence;  // calibrated probability, [0, 1]
  AgreementCounts counts;
  float min_probability = 0;
  bool empty() const { return depth.empty(); }
};

// The counts (under calibration.checks), calibratedConfidence and maskDepth
// in one; `count` defaults to countAgreement.
PublishedDepth publishDepth(const FusionView& reference, const std::vector<FusionView>& views,
                            const ConfidenceOptions& options,
                            const ConfidenceCalibration& calibration = defaultConfidenceCalibration(),
                            const AgreementFunction& count = AgreementFunction());
// The publication the online mapper calls (publishDepth, or a fuser's:
// DepthMapFuser::publishDepth runs all of it on the GPU).
using PublishFunction = std::function<PublishedDepth(const FusionView&, const std::vector<FusionView>&,
                                                     const ConfidenceOptions&, const ConfidenceCalibration&)>;

}  // namespace amhmvs
