// Handcrafted blobs and frames whose answers are known analytically. Used by the tests and by
// `depthpose demo` (what `make run` falls back to when no shipped model exists).
#pragma once
#include <cstdint>
#include <vector>

#include "forest_blob/blob_writer.h"
#include "runtime/depthpose.h"

namespace dp::tools {

struct SyntheticFrame {
  int width = 0, height = 0;
  CameraIntrinsics intrinsics{};
  std::vector<uint16_t> depth_mm;  // width × height, stride = width
  DepthFrame view() const {
    return DepthFrame{depth_mm.data(), width, height, width, intrinsics, nullptr};
  }
};

// Kinect-v1-like intrinsics for a width × height image (fx = fy = 525 · width / 640).
CameraIntrinsics kinect_intrinsics(int width, int height);

// A disc of constant depth on an empty (0) background.
SyntheticFrame make_disc_frame(int width, int height, float centre_u, float centre_v, float radius_px,
                               uint16_t depth_mm);
// A plane z = z0 + gu·(u − cx) + gv·(v − cy) (mm), everywhere valid.
SyntheticFrame make_plane_frame(int width, int height, float z0_mm, float gu_mm_per_px, float gv_mm_per_px);

// Depth-`depth` BPC forest of `trees` trees whose every leaf puts all mass on `part`; joint j uses
// part mask (1 << part) and push-back `push_back_mm`.
blob::BlobContents single_part_bpc(int part_count, int part, int joint_count, int16_t push_back_mm, int depth = 1,
                                   int trees = 1);
// OJR forest whose single leaf votes offset (dx, dy, dz) mm with weight 1 for every joint.
blob::BlobContents single_vote_ojr(int joint_count, int16_t dx_mm, int16_t dy_mm, int16_t dz_mm);
// A random complete forest (random offsets within ±max_offset, thresholds within ±thresh_range)
// with `leaf_count` random BPC leaves; for kernel equivalence tests and benchmarks.
blob::BlobContents random_bpc_forest(uint64_t seed, int trees, int depth, int part_count, int max_offset,
                                     int thresh_range);
// A random unbalanced forest of sparse trees grown breadth-first: the leftmost node of every level
// splits (so the deepest leaf is at `depth`), any other node above `depth` with probability
// split_per_mille/1000, until a tree holds max_nodes_per_tree nodes (≥ 2·depth + 1); offsets and
// thresholds as random_bpc_forest, each leaf its own random BPC record. For deep-tree tests and the
// blob-size measurement.
blob::BlobContents random_sparse_bpc_forest(uint64_t seed, int trees, int depth, int part_count, int max_offset,
                                            int thresh_range, int split_per_mille, uint32_t max_nodes_per_tree);

}  // namespace dp::tools
