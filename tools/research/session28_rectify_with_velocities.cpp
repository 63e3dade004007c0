// Session 28: the images of an MVSNet realism folder rectified for the
// rolling shutter as the pipeline does with --rolling_shutter_velocity=1
// (mapping/rolling_shutter.h, the turn rate of velocities.txt), written as
// grey PNGs to OUT/images/ (make OUT/images first; link cams/, cams_gt/,
// depth_gt/ and velocities.txt beside them). `session26_coarse_features.py
// export OUT FILE` then gives the features of the rectified images to
// session26_adjust_keyframes.cpp (VELOCITIES=OUT/velocities.txt READOUT=0.025).
// Build against the dev build's core:
//   g++ -O2 -std=c++17 -Iinclude -I/usr/include/eigen3 tools/research/session28_rectify_with_velocities.cpp \
//       -Lbuild_cpu/devel/lib -lamhmvs_core -o /tmp/rectify_with_velocities
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>

#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/mvsnet_folder.h"
#include "amhmvs_mapping/mapping/rolling_shutter.h"

int main(int argc, char** argv) {
  using namespace amhmvs;
  if (argc != 4) {
    std::cerr << "usage: rectify_with_velocities DATA OUT READOUT_S\n";
    return 2;
  }
  const std::string data = argv[1], out = argv[2];
  const double readout_s = std::atof(argv[3]);
  for (const auto& [id, velocity] : readMvsnetVelocities(data + "/velocities.txt")) {
    char name[16];
    std::snprintf(name, sizeof name, "%08d", id);
    PinholeCamera camera;
    double depth_min = 0, depth_max = 0;
    readMvsnetCam(data + "/cams/" + name + "_cam.txt", &camera, &depth_min, &depth_max);
    const ImageU8 image = toGray(readImage(data + "/images/" + name + ".png"));
    camera.width = image.width;
    camera.height = image.height;
    writePng(out + "/images/" + name + ".png", rectifyRollingShutter(image, camera, velocity.angular, readout_s));
  }
  return 0;
}
