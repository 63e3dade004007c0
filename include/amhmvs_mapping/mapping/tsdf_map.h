// The surface map: a truncated signed distance field integrated from the
// keyframes' published depth (weighted by its confidence) in voxel-hashed
// blocks, and the triangle mesh of its zero level (marching cubes), extracted
// again only where it changed.
//
//   TsdfMap map(options);
//   map.addKeyframe(id, camera_to_world, depth);  // depth: published depth, confidence, colour
//   map.updatePose(id, new_camera_to_world);      // loop closure: exact
//   map.updateMesh();                             // changed blocks only
//   TriangleMesh mesh = map.mesh();               // world frame
//
// Voxel (i, j, k) has its centre at (i, j, k) x voxel_size, world frame; a
// block holds 8^3 voxels. Each keyframe's (subsampled) depth is kept with the
// blocks it touched, so removing it subtracts what it added (tsdf_voxel.h)
// and re-posing is remove + add. A block whose last keyframe left is erased.
//
// Memory bound: only the newest reposable_keyframes keep their depth; before
// a keyframe is added, the oldest are frozen (their sums stay in the blocks;
// the keyframe can no longer be moved, removed or replaced). A block that
// only frozen keyframes touched and where no voxel reaches min_weight (the
// outliers of noisy depth, scattered through space) is erased: the mesh is
// the same without it, and a place revisited for hours does not fill the
// memory with such blocks. Beyond max_blocks, the oldest keyframes that keep their depth
// (never the one being added) are removed; blocks that still do not fit are
// dropped (counted). Depth beyond 2^16 blocks of the origin on an axis
// (10 km at 2 cm voxels) is skipped.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/core/shared.h"
#include "amhmvs_mapping/io/point_cloud_io.h"
#include "amhmvs_mapping/mapping/tsdf_voxel.h"

namespace amhmvs {

struct TsdfMapOptions {
  // The online mapper keeps a surface map beside the voxel map (its
  // published depth integrated; needs confidence.enabled).
  bool enabled = true;
  double voxel_size = 0.02;      // metres
  double band_voxels = 4;        // truncation band, in voxels (> 1)
  // Depth images wider than this are subsampled (every n-th pixel) before
  // they are integrated and kept: a 2 cm voxel at 2-4 m spans 1-2 pixels of
  // a 320-pixel-wide image with a 60 degree field of view.
  int max_image_width = 320;
  // A voxel with less weight (sum of confidences: about the keyframes whose
  // published depth reached it) counts as unobserved: no surface passes
  // through its cells. On redkitchen (docs/accuracy.md, "Surface map") 2
  // covers as much of the Kinect surface as the voxel map; 4 is more
  // accurate than it and covers two thirds as much.
  double min_weight = 2;
  size_t max_blocks = 40000;     // 8^3 voxels of 32 bytes: 16 KiB a block
  // Keyframes whose depth is kept so that a loop closure can move them (~0.6
  // MiB each at 320x240); beyond, the oldest are frozen.
  size_t reposable_keyframes = 600;

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

// What a keyframe gives the surface map.
struct SurfaceDepth {
  PinholeCamera camera;  // intrinsics and size; the pose is given to the map
  ImageF depth;          // z-depth, metres; NaN or <= 0 where none
  ImageF weight;         // >= 0 (the calibrated confidence); empty: 1
  ImageU8 colour;        // RGB (3 channels) or grey (1); empty: grey 200

  // Empty when usable: a valid camera, depth of its size, weight and colour
  // empty or of its size, finite non-negative weights.
  std::string validate() const;
};

struct TsdfMapUpdate {
  size_t blocks = 0;                      // blocks the keyframe touched
  size_t new_blocks = 0;                  // of those, allocated for it
  size_t dropped_blocks = 0;              // did not fit max_blocks
  std::vector<int64_t> evicted_keyframes;  // removed to make room, oldest first
  std::vector<int64_t> frozen_keyframes;   // their depth released (reposable_keyframes), oldest first
  size_t pruned_blocks = 0;                // erased: only frozen keyframes in them, no voxel at min_weight
  bool refused_frozen = false;             // the id was frozen: nothing was integrated
};

class TsdfMap {
 public:
  static constexpr int kBlockVoxels = 8;  // per edge

  // Throws InputError when the options are invalid.
  explicit TsdfMap(const TsdfMapOptions& options = TsdfMapOptions());

  // Integrates keyframe `id`'s depth at camera_to_world; an id already in the
  // map is replaced, a frozen one refused (TsdfMapUpdate::refused_frozen).
  // Throws InputError for invalid depth or a bad pose.
  // Kept as given (shared, not copied) unless it is wider than max_image_width.
  TsdfMapUpdate addKeyframe(int64_t id, const Eigen::Isometry3d& camera_to_world, Shared<SurfaceDepth> depth);
  // Throws InputError for an unknown id.
  void removeKeyframe(int64_t id);
  TsdfMapUpdate updatePose(int64_t id, const Eigen::Isometry3d& camera_to_world);

  // True for the keyframes that keep their depth (frozen ones: isFrozen).
  bool contains(int64_t id) const { return keyframes_.count(id) != 0; }
  bool isFrozen(int64_t id) const { return frozen_.count(id) != 0; }
  size_t frozenKeyframeCount() const { return frozen_.size(); }
  size_t keyframeCount() const { return keyframes_.size(); }
  size_t blockCount() const { return blocks_.size(); }
  size_t memoryBytes() const;
  size_t totalDroppedBlocks() const { return total_dropped_blocks_; }
  size_t totalEvictedKeyframes() const { return total_evicted_keyframes_; }
  const TsdfMapOptions& options() const { return options_; }

  // Extracts the mesh again in the blocks changed since the last call and in
  // the neighbours whose cells read them; returns how many blocks it visited.
  // mesh() and surfaceCloud() call it first, so that a map updated many
  // times between two reads extracts each changed block once.
  size_t updateMesh() const;
  bool meshIsCurrent() const { return changed_.empty(); }
  // The mesh, world frame, blocks in key order: vertices with unit normals
  // (area-weighted face normals) and colours. Not thread-safe with itself
  // (it may extract), like the map's updates.
  TriangleMesh mesh() const;
  // Its vertices as a cloud (normals, colours), each vertex once.
  PointCloud surfaceCloud() const;

  // A voxel, or nullptr where its block is not allocated (tests, tools).
  const TsdfVoxel* voxel(const Eigen::Vector3i& index) const;
  Eigen::Vector3d voxelCentre(const Eigen::Vector3i& index) const { return index.cast<double>() * options_.voxel_size; }

 private:
  struct Block {
    TsdfVoxel voxels[kBlockVoxels * kBlockVoxels * kBlockVoxels];
    uint32_t keyframes = 0;  // contributions that touched it
    uint32_t frozen = 0;     // of those, frozen ones
  };
  struct Contribution {
    uint64_t sequence = 0;
    Eigen::Isometry3d camera_to_world;
    Shared<SurfaceDepth> depth;    // subsampled
    std::vector<uint64_t> blocks;  // sorted keys
  };
  struct BlockMesh {
    std::vector<Eigen::Vector3f> vertices, normals;
    std::vector<std::array<uint8_t, 3>> colors;
    std::vector<std::array<uint32_t, 3>> triangles;
    std::vector<uint64_t> edges;  // each vertex's voxel edge (start voxel, axis): one key across blocks
  };

  std::vector<uint64_t> touchedBlocks(const Eigen::Isometry3d& camera_to_world, const SurfaceDepth& depth) const;
  void integrate(const Contribution& contribution, float sign);
  void insert(int64_t id, Contribution contribution, TsdfMapUpdate* update);
  void remove(int64_t id);
  void freezeOldest(TsdfMapUpdate* update);
  // Erases the block when only frozen keyframes touched it and none of its
  // voxels reaches min_weight: it holds no surface, and nothing will ever
  // take its sums out again. True when erased.
  bool pruneIfForeverEmpty(std::unordered_map<uint64_t, std::unique_ptr<Block>>::iterator block);
  void extractBlock(uint64_t key, BlockMesh* mesh) const;
  const Block* block(uint64_t key) const;

  TsdfMapOptions options_;
  std::unordered_map<uint64_t, std::unique_ptr<Block>> blocks_;
  std::unordered_map<int64_t, Contribution> keyframes_;
  std::map<uint64_t, int64_t> order_;  // sequence -> id, oldest first
  uint64_t next_sequence_ = 0;
  // Blocks changed since the last updateMesh(), and the mesh (by block key:
  // deterministic order), brought up to date when read.
  mutable std::unordered_set<uint64_t> changed_;
  mutable std::map<uint64_t, BlockMesh> meshes_;
  size_t total_dropped_blocks_ = 0;
  size_t total_evicted_keyframes_ = 0;
  std::unordered_set<int64_t> frozen_;  // ids whose sums stay in their blocks, depth released
};

// Every n-th pixel of `depth` so that it is at most max_width wide, with its
// camera scaled to match (pixel (x, y) of the result is (n x, n y)).
SurfaceDepth subsampledSurfaceDepth(const SurfaceDepth& depth, int max_width);

}  // namespace amhmvs
