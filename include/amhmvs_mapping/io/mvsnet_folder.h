// MVSNet "dense folder" input (the format of the public AMHMVS-family code):
//   images/%08d.<ext>   one image per view (any readImage extension)
//   cams/%08d_cam.txt   "extrinsic" + 4x4 world-to-camera, "intrinsic" + 3x3 K,
//                       then "depth_min depth_interval [depth_num [depth_max]]"
//   pair.txt            view count, then per view: "ref_id" and
//                       "n id score id score ..." (best source first)
#pragma once

#include <map>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/io/scene.h"

namespace amhmvs {

// Reads one cam file. The camera's width and height are left at 0 (the file
// has no image size). When depth_max is absent it is depth_min +
// depth_interval * (depth_num - 1), depth_num defaulting to 192. Throws
// InputError naming the file and line for malformed numbers, a bottom row
// other than 0 0 0 1, a K with skew or a last row other than 0 0 1, and a
// depth range that is not finite with 0 < min < max.
void readMvsnetCam(const std::string& path, PinholeCamera* camera, double* depth_min,
                   double* depth_max);

// Reads pair.txt: reference view id -> sources in file order. Checks the
// syntax, finite scores, self-pairs and repeated ids; not that ids exist.
std::map<int, std::vector<SourceCandidate>> readMvsnetPair(const std::string& path);

// Reads a whole dense folder. One view per cam file, sorted by id; image sizes
// come from the image headers (no decoding for PNG/JPEG/BMP/PGM/PPM). A
// missing pair.txt leaves Scene::sources empty. Throws InputError naming the
// file for: a missing folder, no cam files, two images or cam files with one
// id, a cam without an image, an invalid camera or depth range, and pair.txt
// ids that name no view.
Scene readMvsnetDenseFolder(const std::string& dir);

// Writes a cam file in the same format, numbers with 9 significant digits:
// depth_interval = (depth_max - depth_min) / 191, depth_num = 192, then
// depth_max. Throws InputError for an invalid camera or depth range.
void writeMvsnetCam(const std::string& path, const PinholeCamera& camera, double depth_min,
                    double depth_max);

}  // namespace amhmvs
