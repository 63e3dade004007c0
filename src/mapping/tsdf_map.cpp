#include "amhmvs_mapping/mapping/tsdf_map.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/marching_cubes.h"
#include "amhmvs_mapping/mapping/voxel_map.h"  // validateRigidPose

namespace amhmvs {
namespace {

constexpr int kB = TsdfMap::kBlockVoxels;
constexpr int kBlockSize = kB * kB * kB;
// Block coordinates in [-2^16, 2^16) (+-10 km at 2 cm voxels), so that a
// voxel coordinate fits 20 bits of a mesh vertex's edge key.
constexpr int64_t kKeyBias = int64_t{1} << 16;
constexpr int64_t kVoxelBias = kKeyBias * TsdfMap::kBlockVoxels;

bool blockInRange(const Eigen::Vector3i& b) {
  return (b.array() >= -kKeyBias).all() && (b.array() < kKeyBias).all();
}
uint64_t blockKey(const Eigen::Vector3i& b) {
  return (static_cast<uint64_t>(b.x() + kKeyBias) << 42) | (static_cast<uint64_t>(b.y() + kKeyBias) << 21) |
         static_cast<uint64_t>(b.z() + kKeyBias);
}
Eigen::Vector3i blockOfKey(uint64_t key) {
  const uint64_t mask = (uint64_t{1} << 21) - 1;
  return Eigen::Vector3i(static_cast<int>(static_cast<int64_t>((key >> 42) & mask) - kKeyBias),
                         static_cast<int>(static_cast<int64_t>((key >> 21) & mask) - kKeyBias),
                         static_cast<int>(static_cast<int64_t>(key & mask) - kKeyBias));
}
int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
int voxelSlot(int x, int y, int z) { return x + kB * (y + kB * z); }

}  // namespace

std::string TsdfMapOptions::validate() const {
  std::ostringstream problems;
  if (!(voxel_size > 0) || !std::isfinite(voxel_size)) problems << "voxel_size must be > 0 (is " << voxel_size << ")\n";
  if (!(band_voxels > 1) || !std::isfinite(band_voxels))
    problems << "band_voxels must be > 1 (is " << band_voxels << ")\n";
  if (max_image_width < 8) problems << "max_image_width must be >= 8 (is " << max_image_width << ")\n";
  if (!(min_weight > 0) || !std::isfinite(min_weight)) problems << "min_weight must be > 0 (is " << min_weight << ")\n";
  if (max_blocks < 1) problems << "max_blocks must be >= 1\n";
  if (reposable_keyframes < 1) problems << "reposable_keyframes must be >= 1\n";
  return problems.str();
}

std::string SurfaceDepth::validate() const {
  const std::string camera_problem = camera.validate();
  if (!camera_problem.empty()) return "camera: " + camera_problem;
  if (!depth.sameSize(camera.width, camera.height) || depth.channels != 1)
    return "depth must be one channel of the camera's size";
  if (!weight.empty()) {
    if (!weight.sameSize(camera.width, camera.height) || weight.channels != 1)
      return "weight must be empty or one channel of the camera's size";
    for (float w : weight.data) {
      if (!(w >= 0) || !std::isfinite(w)) return "weights must be finite and >= 0";
    }
  }
  if (!colour.empty() && (!colour.sameSize(camera.width, camera.height) || (colour.channels != 1 && colour.channels != 3)))
    return "colour must be empty or 1 or 3 channels of the camera's size";
  return "";
}

SurfaceDepth subsampledSurfaceDepth(const SurfaceDepth& depth, int max_width) {
  const int step = std::max(1, (depth.camera.width + max_width - 1) / max_width);
  if (step == 1) return depth;
  SurfaceDepth out;
  out.camera = depth.camera;
  out.camera.width = (depth.camera.width - 1) / step + 1;
  out.camera.height = (depth.camera.height - 1) / step + 1;
  out.camera.fx /= step;
  out.camera.fy /= step;
  out.camera.cx /= step;
  out.camera.cy /= step;
  const auto pick = [&](const auto& image, auto* result) {
    if (image.empty()) return;
    result->width = out.camera.width;
    result->height = out.camera.height;
    result->channels = image.channels;
    result->data.resize(result->pixelCount() * image.channels);
    for (int y = 0; y < result->height; ++y)
      for (int x = 0; x < result->width; ++x)
        for (int c = 0; c < image.channels; ++c) result->at(x, y, c) = image.at(step * x, step * y, c);
  };
  pick(depth.depth, &out.depth);
  pick(depth.weight, &out.weight);
  pick(depth.colour, &out.colour);
  return out;
}

TsdfMap::TsdfMap(const TsdfMapOptions& options) : options_(options) {
  const std::string problems = options.validate();
  if (!problems.empty()) throw InputError("surface map options:\n" + problems);
}

const TsdfMap::Block* TsdfMap::block(uint64_t key) const {
  const auto found = blocks_.find(key);
  return found == blocks_.end() ? nullptr : found->second.get();
}

const TsdfVoxel* TsdfMap::voxel(const Eigen::Vector3i& index) const {
  const Eigen::Vector3i b(floorDiv(index.x(), kB), floorDiv(index.y(), kB), floorDiv(index.z(), kB));
  if (!blockInRange(b)) return nullptr;
  const Block* found = block(blockKey(b));
  if (!found) return nullptr;
  const Eigen::Vector3i local = index - kB * b;
  return &found->voxels[voxelSlot(local.x(), local.y(), local.z())];
}

size_t TsdfMap::memoryBytes() const {
  size_t bytes = blocks_.size() * (sizeof(Block) + 32) + frozen_.size() * 32;
  for (const auto& entry : keyframes_) {
    const SurfaceDepth& d = *entry.second.depth;
    bytes += d.depth.data.size() * 4 + d.weight.data.size() * 4 + d.colour.data.size() + entry.second.blocks.size() * 8;
  }
  for (const auto& entry : meshes_) {
    bytes += entry.second.vertices.size() * (2 * sizeof(Eigen::Vector3f) + 11) + entry.second.triangles.size() * 12;
  }
  return bytes;
}

// The blocks within the band of each pixel's depth: the ray sampled from
// depth - band to depth + band at most half a block apart.
std::vector<uint64_t> TsdfMap::touchedBlocks(const Eigen::Isometry3d& camera_to_world,
                                             const SurfaceDepth& depth) const {
  const double band = options_.band_voxels * options_.voxel_size;
  const double block_size = kB * options_.voxel_size;
  const int steps = std::max(2, static_cast<int>(std::ceil(2 * band / (0.5 * block_size))));
  std::vector<uint64_t> keys;
  const PinholeCamera& camera = depth.camera;
  // Neighbouring pixels mostly reach the same blocks: each step along the
  // ray skips the key it pushed last, so that the sort sees few repeats.
  std::vector<uint64_t> last(steps + 1, ~uint64_t{0});
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const float d = depth.depth.at(x, y);
      if (!(d > 0) || !std::isfinite(d)) continue;
      if (!depth.weight.empty() && !(depth.weight.at(x, y) > 0)) continue;
      for (int s = 0; s <= steps; ++s) {
        const double z = d - band + 2 * band * s / steps;
        if (!(z > 0)) continue;
        const Eigen::Vector3d world = camera_to_world * camera.backproject(x, y, z);
        const Eigen::Vector3d scaled = world / block_size + Eigen::Vector3d::Constant(0.5 / kB);
        if (!(scaled.array().abs() < kKeyBias - 1).all()) continue;  // also drops non-finite values
        const uint64_t key = blockKey(Eigen::Vector3i(static_cast<int>(std::floor(scaled.x())),
                                                      static_cast<int>(std::floor(scaled.y())),
                                                      static_cast<int>(std::floor(scaled.z()))));
        if (key == last[s]) continue;
        last[s] = key;
        keys.push_back(key);
      }
    }
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return keys;
}

// Every voxel of the contribution's blocks, projected into its depth image
// (nearest pixel). Each block is written by one thread.
void TsdfMap::integrate(const Contribution& contribution, float sign) {
  const SurfaceDepth& depth = *contribution.depth;
  const PinholeCamera& camera = depth.camera;
  const Eigen::Isometry3d world_to_camera = contribution.camera_to_world.inverse();
  const Eigen::Matrix3f rotation = world_to_camera.linear().cast<float>();
  const float band = static_cast<float>(options_.band_voxels * options_.voxel_size);
  const double voxel_size = options_.voxel_size;
  const float fx = static_cast<float>(camera.fx), fy = static_cast<float>(camera.fy);
  const float cx = static_cast<float>(camera.cx), cy = static_cast<float>(camera.cy);
  std::vector<Block*> targets;
  std::vector<Eigen::Vector3i> origins;
  for (uint64_t key : contribution.blocks) {
    const auto found = blocks_.find(key);
    if (found == blocks_.end()) continue;  // dropped over budget
    targets.push_back(found->second.get());
    origins.push_back(kB * blockOfKey(key));
  }
  const int count = static_cast<int>(targets.size());
#pragma omp parallel for schedule(dynamic, 16)
  for (int i = 0; i < count; ++i) {
    // The block's first voxel in the camera, in double (world coordinates can
    // be large), then float steps within the block.
    const Eigen::Vector3f origin = (world_to_camera * (origins[i].cast<double>() * voxel_size)).cast<float>();
    const Eigen::Matrix3f step = rotation * static_cast<float>(voxel_size);
    Block* block = targets[i];
    for (int z = 0; z < kB; ++z) {
      for (int y = 0; y < kB; ++y) {
        for (int x = 0; x < kB; ++x) {
          const Eigen::Vector3f p = origin + step * Eigen::Vector3f(x, y, z);
          if (!(p.z() > 0)) continue;
          const float inverse_z = 1.0f / p.z();
          const int u = static_cast<int>(std::floor(fx * p.x() * inverse_z + cx + 0.5f));
          const int v = static_cast<int>(std::floor(fy * p.y() * inverse_z + cy + 0.5f));
          if (u < 0 || v < 0 || u >= camera.width || v >= camera.height) continue;
          float distance;
          if (!truncatedDistance(depth.depth.at(u, v), p.z(), band, &distance)) continue;
          const float weight = depth.weight.empty() ? 1.0f : depth.weight.at(u, v);
          if (!(weight > 0)) continue;
          float rgb[3] = {200, 200, 200};
          if (!depth.colour.empty()) {
            for (int c = 0; c < 3; ++c) rgb[c] = depth.colour.at(u, v, depth.colour.channels == 3 ? c : 0);
          }
          accumulateSample(distance, weight, rgb, sign, &block->voxels[voxelSlot(x, y, z)]);
        }
      }
    }
  }
}

TsdfMapUpdate TsdfMap::addKeyframe(int64_t id, const Eigen::Isometry3d& camera_to_world,
                                   Shared<SurfaceDepth> depth) {
  const std::string pose_problem = validateRigidPose(camera_to_world);
  if (!pose_problem.empty()) throw InputError("surface map, keyframe " + std::to_string(id) + ": " + pose_problem);
  const std::string problem = depth->validate();
  if (!problem.empty()) throw InputError("surface map, keyframe " + std::to_string(id) + ": " + problem);
  TsdfMapUpdate update;
  if (isFrozen(id)) {
    update.refused_frozen = true;
    return update;
  }
  if (contains(id)) remove(id);
  Contribution contribution;
  contribution.camera_to_world = camera_to_world;
  contribution.depth = depth->camera.width > options_.max_image_width
                           ? Shared<SurfaceDepth>(subsampledSurfaceDepth(*depth, options_.max_image_width))
                           : std::move(depth);
  insert(id, std::move(contribution), &update);
  return update;
}

void TsdfMap::insert(int64_t id, Contribution contribution, TsdfMapUpdate* update) {
  contribution.blocks = touchedBlocks(contribution.camera_to_world, *contribution.depth);
  const auto newBlocks = [&] {
    size_t count = 0;
    for (uint64_t key : contribution.blocks) count += blocks_.count(key) == 0;
    return count;
  };
  while (!order_.empty() && keyframes_.size() + 1 > options_.reposable_keyframes) freezeOldest(update);
  size_t needed = newBlocks();
  while (!order_.empty() && blocks_.size() + needed > options_.max_blocks) {
    const int64_t oldest = order_.begin()->second;
    remove(oldest);
    update->evicted_keyframes.push_back(oldest);
    ++total_evicted_keyframes_;
    needed = newBlocks();
  }
  // What still does not fit is dropped, in key order.
  std::vector<uint64_t> kept;
  for (uint64_t key : contribution.blocks) {
    auto found = blocks_.find(key);
    if (found == blocks_.end()) {
      if (blocks_.size() >= options_.max_blocks) {
        ++update->dropped_blocks;
        continue;
      }
      found = blocks_.emplace(key, std::make_unique<Block>()).first;
      ++update->new_blocks;
    }
    ++found->second->keyframes;
    kept.push_back(key);
    changed_.insert(key);
  }
  total_dropped_blocks_ += update->dropped_blocks;
  contribution.blocks = std::move(kept);
  update->blocks = contribution.blocks.size();
  contribution.sequence = next_sequence_++;
  integrate(contribution, +1);
  order_[contribution.sequence] = id;
  keyframes_[id] = std::move(contribution);
}

void TsdfMap::remove(int64_t id) {
  const auto found = keyframes_.find(id);
  const Contribution& contribution = found->second;
  integrate(contribution, -1);
  for (uint64_t key : contribution.blocks) {
    const auto block = blocks_.find(key);
    changed_.insert(key);
    if (--block->second->keyframes == 0) {
      blocks_.erase(block);  // its sums restart from exact zeros
    } else {
      pruneIfForeverEmpty(block);
    }
  }
  order_.erase(contribution.sequence);
  keyframes_.erase(found);
}

void TsdfMap::freezeOldest(TsdfMapUpdate* update) {
  // Its sums stay, and so does its count in each block it touched: those
  // blocks are never erased.
  const auto oldest = order_.begin();
  const int64_t id = oldest->second;
  for (uint64_t key : keyframes_.at(id).blocks) {
    const auto block = blocks_.find(key);
    ++block->second->frozen;
    update->pruned_blocks += pruneIfForeverEmpty(block);
  }
  keyframes_.erase(id);
  order_.erase(oldest);
  frozen_.insert(id);
  update->frozen_keyframes.push_back(id);
}

bool TsdfMap::pruneIfForeverEmpty(std::unordered_map<uint64_t, std::unique_ptr<Block>>::iterator block) {
  const Block& b = *block->second;
  if (b.keyframes != b.frozen) return false;
  // No observed voxel: no cell that reads one of them has a surface, so the
  // mesh is the same without the block.
  for (const TsdfVoxel& voxel : b.voxels)
    if (voxel.weight >= options_.min_weight) return false;
  changed_.insert(block->first);
  blocks_.erase(block);
  return true;
}

namespace {
std::string notReposable(int64_t id, bool frozen) {
  return "surface map: keyframe " + std::to_string(id) +
         (frozen ? " is frozen (older than the newest reposable_keyframes)" : " is not in the map");
}
}  // namespace

void TsdfMap::removeKeyframe(int64_t id) {
  if (!contains(id)) throw InputError(notReposable(id, isFrozen(id)));
  remove(id);
}

TsdfMapUpdate TsdfMap::updatePose(int64_t id, const Eigen::Isometry3d& camera_to_world) {
  if (!contains(id)) throw InputError(notReposable(id, isFrozen(id)));
  const std::string pose_problem = validateRigidPose(camera_to_world);
  if (!pose_problem.empty()) throw InputError("surface map, keyframe " + std::to_string(id) + ": " + pose_problem);
  Contribution moved;
  moved.camera_to_world = camera_to_world;
  moved.depth = keyframes_.at(id).depth;
  remove(id);
  TsdfMapUpdate update;
  insert(id, std::move(moved), &update);
  return update;
}

size_t TsdfMap::updateMesh() const {
  // A cell reads the voxels of its block and of the blocks at +1 on each
  // axis: a change re-extracts the block and the ones at -1.
  std::vector<uint64_t> visit;
  for (uint64_t key : changed_) {
    const Eigen::Vector3i b = blockOfKey(key);
    for (int n = 0; n < 8; ++n) {
      const Eigen::Vector3i neighbour = b - Eigen::Vector3i(n & 1, (n >> 1) & 1, (n >> 2) & 1);
      if (blockInRange(neighbour)) visit.push_back(blockKey(neighbour));
    }
  }
  changed_.clear();
  std::sort(visit.begin(), visit.end());
  visit.erase(std::unique(visit.begin(), visit.end()), visit.end());
  std::vector<BlockMesh> extracted(visit.size());
  const int count = static_cast<int>(visit.size());
#pragma omp parallel for schedule(dynamic, 8)
  for (int i = 0; i < count; ++i) extractBlock(visit[i], &extracted[i]);
  for (size_t i = 0; i < visit.size(); ++i) {
    if (extracted[i].triangles.empty()) {
      meshes_.erase(visit[i]);
    } else {
      meshes_[visit[i]] = std::move(extracted[i]);
    }
  }
  return visit.size();
}

void TsdfMap::extractBlock(uint64_t key, BlockMesh* mesh) const {
  const Block* home = block(key);
  if (!home) return;
  const Eigen::Vector3i b = blockOfKey(key);
  // The block and its neighbours at +1 (null where not allocated).
  const Block* near[8];
  for (int n = 0; n < 8; ++n) {
    const Eigen::Vector3i other = b + Eigen::Vector3i(n & 1, (n >> 1) & 1, (n >> 2) & 1);
    near[n] = blockInRange(other) ? block(blockKey(other)) : nullptr;
  }
  // The 9^3 corners its cells read, gathered once: the voxel where observed
  // (weight >= min_weight), else null, and its distance.
  constexpr int kC = kB + 1;
  const TsdfVoxel* corner_voxel[kC * kC * kC];
  float corner_value[kC * kC * kC];
  const auto cornerIndex = [](int x, int y, int z) { return x + kC * (y + kC * z); };
  bool any_negative = false, any_positive = false;
  for (int z = 0; z < kC; ++z)
    for (int y = 0; y < kC; ++y)
      for (int x = 0; x < kC; ++x) {
        const Block* source = near[(x >= kB) | ((y >= kB) << 1) | ((z >= kB) << 2)];
        const TsdfVoxel* voxel = source ? &source->voxels[voxelSlot(x % kB, y % kB, z % kB)] : nullptr;
        if (voxel && !(voxel->weight >= options_.min_weight)) voxel = nullptr;
        const int i = cornerIndex(x, y, z);
        corner_voxel[i] = voxel;
        corner_value[i] = voxel ? voxel->distance() : 0.0f;
        any_negative = any_negative || (voxel && corner_value[i] < 0);
        any_positive = any_positive || (voxel && corner_value[i] >= 0);
      }
  if (!any_negative || !any_positive) return;  // no surface in reach
  CellEdge edges[kCellEdges];
  int corner_offset[kCellCorners];
  for (int e = 0; e < kCellEdges; ++e) edges[e] = cellEdge(e);
  for (int c = 0; c < kCellCorners; ++c) corner_offset[c] = cornerIndex(c & 1, (c >> 1) & 1, (c >> 2) & 1);
  const Eigen::Vector3f origin = ((kB * b).cast<double>() * options_.voxel_size).cast<float>();
  const float voxel_size = static_cast<float>(options_.voxel_size);
  // Vertex of each crossed edge, by (start corner, axis).
  int32_t vertex_of_edge[kC * kC * kC * 3];
  std::fill(std::begin(vertex_of_edge), std::end(vertex_of_edge), -1);
  for (int z = 0; z < kB; ++z) {
    for (int y = 0; y < kB; ++y) {
      for (int x = 0; x < kB; ++x) {
        const int base = cornerIndex(x, y, z);
        float value[kCellCorners];
        int case_index = 0;
        bool observed = true;
        for (int c = 0; c < kCellCorners && observed; ++c) {
          observed = corner_voxel[base + corner_offset[c]] != nullptr;
          value[c] = corner_value[base + corner_offset[c]];
          case_index |= (value[c] < 0) << c;
        }
        if (!observed || case_index == 0 || case_index == 255) continue;
        // A jump from +1 to -1 across one voxel is a depth edge (occlusion), not a surface.
        bool depth_edge = false;
        for (const CellEdge& edge : edges) {
          const float a = value[edge.corner[0]], v1 = value[edge.corner[1]];
          depth_edge = depth_edge || ((a < 0) != (v1 < 0) && std::abs(a) >= 1 && std::abs(v1) >= 1);
        }
        if (depth_edge) continue;
        const CellCase& cell = cellCase(case_index);
        for (int t = 0; t < cell.triangle_count; ++t) {
          std::array<uint32_t, 3> triangle;
          for (int k = 0; k < 3; ++k) {
            const CellEdge& edge = edges[cell.triangles[t][k]];
            const int c0 = edge.corner[0];
            const int sx = x + (c0 & 1), sy = y + ((c0 >> 1) & 1), sz = z + ((c0 >> 2) & 1);
            int32_t& slot = vertex_of_edge[3 * cornerIndex(sx, sy, sz) + edge.axis];
            if (slot < 0) {
              const float f = crossingFraction(value[c0], value[edge.corner[1]]);
              Eigen::Vector3f position = origin + voxel_size * Eigen::Vector3f(sx, sy, sz);
              position[edge.axis] += f * voxel_size;
              const TsdfVoxel& a = *corner_voxel[base + corner_offset[c0]];
              const TsdfVoxel& v1 = *corner_voxel[base + corner_offset[edge.corner[1]]];
              std::array<uint8_t, 3> rgb;
              for (int ch = 0; ch < 3; ++ch) {
                const float colour =
                    (1 - f) * static_cast<float>(a.rgb_sum[ch] / a.weight) + f * static_cast<float>(v1.rgb_sum[ch] / v1.weight);
                rgb[ch] = static_cast<uint8_t>(std::clamp(std::lround(colour), 0l, 255l));
              }
              slot = static_cast<int32_t>(mesh->vertices.size());
              mesh->vertices.push_back(position);
              mesh->normals.push_back(Eigen::Vector3f::Zero());
              mesh->colors.push_back(rgb);
              const Eigen::Vector3i start = kB * b + Eigen::Vector3i(sx, sy, sz);
              mesh->edges.push_back((static_cast<uint64_t>(start.x() + kVoxelBias) << 42) |
                                    (static_cast<uint64_t>(start.y() + kVoxelBias) << 22) |
                                    (static_cast<uint64_t>(start.z() + kVoxelBias) << 2) |
                                    static_cast<uint64_t>(edge.axis));
            }
            triangle[k] = static_cast<uint32_t>(slot);
          }
          const Eigen::Vector3f face = (mesh->vertices[triangle[1]] - mesh->vertices[triangle[0]])
                                           .cross(mesh->vertices[triangle[2]] - mesh->vertices[triangle[0]]);
          for (uint32_t vertex : triangle) mesh->normals[vertex] += face;  // area-weighted
          mesh->triangles.push_back(triangle);
        }
      }
    }
  }
  for (Eigen::Vector3f& normal : mesh->normals) {
    const float length = normal.norm();
    normal = length > 0 ? Eigen::Vector3f(normal / length) : Eigen::Vector3f::Zero();
  }
}

TriangleMesh TsdfMap::mesh() const {
  updateMesh();
  TriangleMesh mesh;
  PointCloud& vertices = mesh.vertices;
  for (const auto& entry : meshes_) {
    const BlockMesh& block = entry.second;
    const uint32_t offset = static_cast<uint32_t>(vertices.size());
    vertices.points.insert(vertices.points.end(), block.vertices.begin(), block.vertices.end());
    vertices.normals.insert(vertices.normals.end(), block.normals.begin(), block.normals.end());
    vertices.colors.insert(vertices.colors.end(), block.colors.begin(), block.colors.end());
    for (const std::array<uint32_t, 3>& t : block.triangles) mesh.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  }
  return mesh;
}

PointCloud TsdfMap::surfaceCloud() const {
  updateMesh();
  PointCloud cloud;
  std::unordered_set<uint64_t> taken;  // a vertex on a block border is in both blocks' meshes
  for (const auto& entry : meshes_) {
    const BlockMesh& block = entry.second;
    for (size_t i = 0; i < block.vertices.size(); ++i) {
      if (!taken.insert(block.edges[i]).second) continue;
      cloud.points.push_back(block.vertices[i]);
      cloud.normals.push_back(block.normals[i]);
      cloud.colors.push_back(block.colors[i]);
    }
  }
  return cloud;
}

}  // namespace amhmvs
