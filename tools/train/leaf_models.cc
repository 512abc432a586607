#include "tools/train/leaf_models.h"

#include <algorithm>
#include <cmath>

#include "tools/common/error.h"
#include "tools/train/tree_trainer.h"

namespace dp::train {

std::vector<Mode> mean_shift_modes(const std::vector<std::array<float, 3>>& points, float bandwidth_m) {
  std::vector<Mode> modes;
  if (points.empty()) return modes;
  const double inv_b2 = 1.0 / (double(bandwidth_m) * bandwidth_m);
  const double tolerance2 = 1e-8 * bandwidth_m * bandwidth_m;
  const double merge2 = 0.25 * bandwidth_m * bandwidth_m;
  for (const auto& start : points) {
    double m[3] = {start[0], start[1], start[2]};
    for (int iteration = 0; iteration < 100; ++iteration) {
      double num[3] = {0, 0, 0}, den = 0;
      for (const auto& p : points) {
        const double dx = p[0] - m[0], dy = p[1] - m[1], dz = p[2] - m[2];
        const double w = std::exp(-(dx * dx + dy * dy + dz * dz) * inv_b2);
        num[0] += w * p[0];
        num[1] += w * p[1];
        num[2] += w * p[2];
        den += w;
      }
      const double n[3] = {num[0] / den, num[1] / den, num[2] / den};
      const double shift2 = (n[0] - m[0]) * (n[0] - m[0]) + (n[1] - m[1]) * (n[1] - m[1]) + (n[2] - m[2]) * (n[2] - m[2]);
      m[0] = n[0];
      m[1] = n[1];
      m[2] = n[2];
      if (shift2 < tolerance2) break;
    }
    bool merged = false;
    for (Mode& mode : modes) {
      const double dx = mode.position[0] - m[0], dy = mode.position[1] - m[1], dz = mode.position[2] - m[2];
      if (dx * dx + dy * dy + dz * dz < merge2) {
        ++mode.weight;
        merged = true;
        break;
      }
    }
    if (!merged) modes.push_back({{float(m[0]), float(m[1]), float(m[2])}, 1});
  }
  std::stable_sort(modes.begin(), modes.end(), [](const Mode& a, const Mode& b) { return a.weight > b.weight; });
  return modes;
}

std::vector<LeafVote> select_votes(const std::vector<Mode>& modes, float max_length_m, int k) {
  std::vector<LeafVote> votes;
  for (const Mode& m : modes) {
    if (int(votes.size()) == k) break;
    const float length = std::sqrt(m.position[0] * m.position[0] + m.position[1] * m.position[1] +
                                   m.position[2] * m.position[2]);
    if (max_length_m > 0 && length > max_length_m) continue;
    votes.push_back({m.position[0], m.position[1], m.position[2], float(m.weight)});
  }
  votes.resize(k);
  return votes;
}

void fit_part_distributions(const std::vector<TrainingPixel>& pixels, const LeafRanges& ranges, int part_count,
                            TrainedTree& tree) {
  tree.part_probabilities.assign(ranges.size() * part_count, 0.0f);
  for (size_t l = 0; l < ranges.size(); ++l) {
    std::vector<uint64_t> counts(part_count, 0);
    for (uint32_t i = ranges[l].first; i < ranges[l].second; ++i)
      if (pixels[i].label < part_count) ++counts[pixels[i].label];
    const uint64_t n = ranges[l].second - ranges[l].first;
    if (n == 0) continue;
    for (int c = 0; c < part_count; ++c)
      tree.part_probabilities[l * part_count + c] = static_cast<float>(double(counts[c]) / double(n));
  }
}

void fit_votes(const TrainingSet& set, const std::vector<TrainingPixel>& pixels, const LeafRanges& ranges,
               const LeafParams& params, int tree_index, TrainedTree& tree) {
  const int joints = static_cast<int>(set.joint_names.size());
  if (!set.has_joints || joints == 0) tools::fail("offset joint regression leaves need joints in every frame");
  if (params.reservoir < 1) tools::fail("--nres must be ≥ 1");
  if (!(params.bandwidth_m > 0)) tools::fail("--bandwidth must be > 0");
  if (params.votes_per_joint < 1 || params.votes_per_joint > 64) tools::fail("--votes-per-leaf must be 1..64");
  if (params.vote_length_m.size() > 1 && params.vote_length_m.size() != size_t(joints))
    tools::fail("--vote-length wants one value or " + std::to_string(joints) + " (one per joint)");
  const int k = params.votes_per_joint;
  tree.votes.assign(ranges.size() * joints * k, LeafVote{});
  parallel_for(ranges.size(), params.threads, [&](size_t l, int) {
    std::vector<ReservoirSampler<std::array<float, 3>>> reservoirs(joints, ReservoirSampler<std::array<float, 3>>(params.reservoir));
    std::vector<Rng> rngs;
    for (int j = 0; j < joints; ++j) rngs.push_back(Rng::keyed(params.seed, 4, uint64_t(tree_index), l, uint64_t(j)));
    for (uint32_t i = ranges[l].first; i < ranges[l].second; ++i) {
      const TrainingPixel& p = pixels[i];
      const TrainingImage& im = set.images[p.image];
      const std::array<float, 3> x = pixel_point(im, p.u, p.v, p.depth_mm);
      for (int j = 0; j < joints; ++j)
        reservoirs[j].offer({im.joints[3 * j] - x[0], im.joints[3 * j + 1] - x[1], im.joints[3 * j + 2] - x[2]}, rngs[j]);
    }
    for (int j = 0; j < joints; ++j) {
      const float lambda = params.vote_length_m.empty() ? 0.0f
                           : params.vote_length_m.size() == 1 ? params.vote_length_m[0]
                                                              : params.vote_length_m[j];
      const std::vector<LeafVote> v = select_votes(mean_shift_modes(reservoirs[j].items(), params.bandwidth_m), lambda, k);
      std::copy(v.begin(), v.end(), tree.votes.begin() + (l * joints + j) * k);
    }
  });
}

LeafRanges group_by_leaf(const TrainingSet& set, TrainedTree& tree, std::vector<TrainingPixel>& pixels, int threads) {
  std::vector<int32_t> leaf_of(pixels.size());
  const size_t chunk = 4096;
  parallel_for((pixels.size() + chunk - 1) / chunk, threads, [&](size_t c, int) {
    for (size_t i = c * chunk; i < std::min(pixels.size(), (c + 1) * chunk); ++i) {
      const TrainingPixel& p = pixels[i];
      const TrainingImage& im = set.images[p.image];
      leaf_of[i] = tree.nodes[leaf_node_for_pixel(tree, im.probe.data(), im.width, im.height, p.u, p.v, im.focal_factor)].leaf;
    }
  });
  const size_t leaves = tree.leaf_count() ? tree.leaf_count() : 0;
  std::vector<uint32_t> start(leaves + 1, 0);
  for (int32_t l : leaf_of) ++start[l + 1];
  for (size_t l = 0; l < leaves; ++l) start[l + 1] += start[l];
  LeafRanges ranges(leaves);
  for (size_t l = 0; l < leaves; ++l) ranges[l] = {start[l], start[l + 1]};
  std::vector<TrainingPixel> sorted(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) sorted[start[leaf_of[i]]++] = pixels[i];
  pixels.swap(sorted);
  for (size_t l = 0; l < leaves; ++l) tree.leaf_pixel_counts[l] = ranges[l].second - ranges[l].first;
  return ranges;
}

}  // namespace dp::train
