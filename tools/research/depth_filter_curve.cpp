// The temporal depth filter's curve on a recorded sequence: completeness and
// accuracy of a keyframe's depth against the number of frames the filter has
// seen, beside the pipeline's raw and published depth of the same keyframes.
//
//   depth_filter_curve SEQUENCE_DIR OUT.csv [--every K] [--frames N] [amhmvs_map options]
//
// Runs the mapping pipeline offline (as amhmvs_map does, the same options),
// then for every K-th keyframe with a depth map starts a KeyframeDepthFilter
// from its raw depth and normals and feeds it the sequence's frames nearest
// to it in time (+1, -1, +2, -2, ... up to N), at the processed size and the
// poses the pipeline used. Against the ground-truth depth (missing = wrong):
// rows of (keyframe, source, frames, published %, published within 5 % of all
// truth pixels, published within 5 %). Built with -DAMHMVS_BUILD_RESEARCH=ON.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/eval/ground_truth_depth.h"
#include "amhmvs_mapping/mapping/depth_filter.h"
#include "amhmvs_mapping/mapping/mapping_parameters.h"
#include "amhmvs_mapping/mapping/mapping_pipeline.h"
#include "keyframe_picker.h"
#include "map_options.h"

namespace amhmvs {
namespace {

struct Counts {
  double published = 0, good = 0, truth = 0;
  std::vector<float> signed_errors;
};

Counts score(const ImageF& depth, const ImageF& truth) {
  Counts c;
  for (size_t i = 0; i < truth.data.size(); ++i) {
    if (!std::isfinite(truth.data[i]) || truth.data[i] <= 0) continue;
    ++c.truth;
    if (!std::isfinite(depth.data[i])) continue;
    ++c.published;
    c.signed_errors.push_back(depth.data[i] / truth.data[i] - 1);
    if (std::abs(depth.data[i] / truth.data[i] - 1) <= 0.05) ++c.good;
  }
  return c;
}

struct Sum {
  Counts all;
  void add(const Counts& c) {
    all.published += c.published;
    all.good += c.good;
    all.truth += c.truth;
    all.signed_errors.insert(all.signed_errors.end(), c.signed_errors.begin(), c.signed_errors.end());
  }
};

int run(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: depth_filter_curve SEQUENCE_DIR OUT.csv [--every K] [--frames N] [amhmvs_map options]\n";
    return 2;
  }
  int every = 4, max_frames = 16, stride = 1;
  bool forward = false;  // only the frames after the keyframe (as online)
  std::vector<std::string> rest;
  DepthFilterOptions filter_options;
  const std::map<std::string, double*> filter_flags = {
      {"--initial_sigma", &filter_options.initial_sigma}, {"--pixel_sigma", &filter_options.pixel_sigma},
      {"--max_cost", &filter_options.max_cost}, {"--converged_sigma", &filter_options.converged_sigma},
      {"--search_sigmas", &filter_options.search_sigmas}};
  for (int i = 3; i < argc; ++i) {
    const std::string arg = argv[i];
    if (filter_flags.count(arg) && i + 1 < argc) {
      *filter_flags.at(arg) = std::stod(argv[++i]);
    } else if (arg == "--search_samples" && i + 1 < argc) {
      filter_options.search_samples = std::stoi(argv[++i]);
    } else if (arg == "--every" && i + 1 < argc) {
      every = std::stoi(argv[++i]);
    } else if (arg == "--forward") {
      forward = true;
    } else if (arg == "--stride" && i + 1 < argc) {
      stride = std::stoi(argv[++i]);
    } else if (arg == "--frames" && i + 1 < argc) {
      max_frames = std::stoi(argv[++i]);
    } else {
      rest.push_back(arg);
    }
  }
  MapToolOptions options = parseMapToolArguments(rest);
  options.max_image_size = effectiveMaxImageSize(options.max_image_size, Backend::kCpu);
  const PosedSequence sequence = readPosedSequence(argv[1], options.sequence);
  PickedKeyframes picked = pickKeyframes(sequence.frames, options.frames);
  options.pipeline.queue_size = resolvedQueueSize(options, picked.indices.size());
  MappingPipeline pipeline(options.pipeline, MappingPipeline::Log());
  std::map<int64_t, size_t> frame_of_id;
  std::map<int64_t, KeyframeResult> first;  // the first depth map of each keyframe
  std::map<int64_t, ImageF> published;
  for (size_t index : picked.indices) {
    Keyframe keyframe = makeKeyframe(sequence.frames[index], options, picked.takeDecoded(index));
    frame_of_id[keyframe.id] = index;
    pipeline.push(std::move(keyframe));
    pipeline.runUntilIdle([&](const PipelineOutput& output) {
      const KeyframeResult& result = output.result;
      if (result.has_depth && !result.refined && !first.count(result.id)) first[result.id] = result;
      for (const FusedKeyframe& fused : result.fused)
        if (!fused.published.depth.empty()) published[fused.id] = fused.published.depth;
    });
  }
  std::ofstream csv(argv[2]);
  csv << "keyframe,frame,kind,frames,published_pct,good_of_truth_pct,good_of_published_pct\n";
  std::map<std::string, Sum> sums;
  int done = 0;
  for (const auto& [id, result] : first) {
    if (done++ % every != 0) continue;
    const size_t index = frame_of_id.at(id);
    const Keyframe keyframe = makeKeyframe(sequence.frames[index], options);
    const PinholeCamera camera = result.camera;
    const ImageF truth = groundTruthDepthIn(sequence.frames[index].ground_truth, camera);
    const auto row = [&](const std::string& kind, int frames, const ImageF& depth) {
      const Counts c = score(depth, truth);
      sums[kind + "," + std::to_string(frames)].add(c);
      csv << id << "," << index << "," << kind << "," << frames << "," << 100 * c.published / c.truth << ","
          << 100 * c.good / c.truth << "," << (c.published > 0 ? 100 * c.good / c.published : 0) << "\n";
    };
    row("raw", 0, result.depth->depth);
    if (published.count(id)) row("published", 0, published.at(id));
    KeyframeDepthFilter filter(camera, toGray(keyframe.image), *result.depth, filter_options);
    row("filter", 0, filter.depth());
    int frames = 0;
    for (int step = 1; frames < max_frames && step < 200; ++step) {
      for (const int sign : {1, -1}) {
        if (forward && sign < 0) continue;
        const long other = static_cast<long>(index) + sign * step * stride;
        if (other < 0 || other >= static_cast<long>(sequence.frames.size()) || frames >= max_frames) continue;
        Keyframe frame = makeKeyframe(sequence.frames[other], options);
        filter.update(frame.camera, toGray(frame.image));
        ++frames;
        if ((frames & (frames - 1)) == 0) {
          const ImageF filtered = filter.depth();
          row("filter", frames, filtered);
          if (published.count(id)) {
            ImageF both = published.at(id);
            for (size_t i = 0; i < both.data.size(); ++i)
              if (std::isfinite(filtered.data[i])) both.data[i] = filtered.data[i];
            row("union", frames, both);
          }
          const ImageF mean = filter.mean(), sigma = filter.sigma(), inliers = filter.inlierProbability();
          for (const double max_sigma : {0.03, 0.05, 1.0}) {
            ImageF kept = mean;
            for (size_t i = 0; i < kept.data.size(); ++i)
              if (!(sigma.data[i] <= max_sigma * mean.data[i] && inliers.data[i] >= 0.6f))
                kept.data[i] = std::numeric_limits<float>::quiet_NaN();
            row("sigma" + std::to_string(static_cast<int>(100 * max_sigma)), frames, kept);
          }
        }
      }
    }
    std::fprintf(stderr, "keyframe %lld (frame %zu) done\n", static_cast<long long>(id), index);
  }
  std::printf("kind,frames,published_pct,good_of_truth_pct,good_of_published_pct,signed_error_p25_p50_p75_pct\n");
  for (auto& [key, sum] : sums) {
    std::vector<float>& e = sum.all.signed_errors;
    std::sort(e.begin(), e.end());
    const auto at = [&e](double q) { return e.empty() ? 0.0 : 100.0 * e[static_cast<size_t>(q * (e.size() - 1))]; };
    std::printf("%s,%.1f,%.1f,%.1f,%.1f/%.1f/%.1f\n", key.c_str(), 100 * sum.all.published / sum.all.truth,
                100 * sum.all.good / sum.all.truth, 100 * sum.all.good / std::max(1.0, sum.all.published), at(0.25),
                at(0.5), at(0.75));
  }
  return 0;
}

}  // namespace
}  // namespace amhmvs

int main(int argc, char** argv) {
  try {
    return amhmvs::run(argc, argv);
  } catch (const std::exception& error) {
    std::cerr << "depth_filter_curve: " << error.what() << "\n";
    return 1;
  }
}
