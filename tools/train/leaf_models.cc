#include "tools/train/leaf_models.h"

#include <algorithm>
#include <cmath>

#include "tools/common/error.h"
#include "tools/train/tree_trainer.h"

namespace dp::train {

std::vector<Mode> mean_shift_modes(const std::vector<std::array<float, 3>>& points, float bandwidth_m) {
  std::vector<Mode> modes;
  if (points.empty()) return modes;
  const size_t n = points.size();
  // Structure of arrays in float for a vectorizable inner loop; points farther than 3b weigh
  // < e^-9 ≈ 1.2e-4 of a coincident one and are left out (their exp is never computed).
  std::vector<float> xs(n), ys(n), zs(n), w(n);
  for (size_t i = 0; i < n; ++i) {
    xs[i] = points[i][0];
    ys[i] = points[i][1];
    zs[i] = points[i][2];
  }
  const float inv_b2 = 1.0f / (bandwidth_m * bandwidth_m);
  const float cutoff = 9.0f;
  const float tolerance2 = 1e-6f * bandwidth_m * bandwidth_m;  // stop when the shift < b/1000
  const float merge2 = 0.25f * bandwidth_m * bandwidth_m;       // modes closer than b/2 are one
  const float arrived2 = 0.01f * bandwidth_m * bandwidth_m;     // within b/10 of a found mode
  auto near_mode = [&](const float* m, float limit2) -> Mode* {
    for (Mode& mode : modes) {
      const float dx = mode.position[0] - m[0], dy = mode.position[1] - m[1], dz = mode.position[2] - m[2];
      if (dx * dx + dy * dy + dz * dz < limit2) return &mode;
    }
    return nullptr;
  };
  for (size_t s = 0; s < n; ++s) {
    float m[3] = {xs[s], ys[s], zs[s]};
    for (int iteration = 0; iteration < 100; ++iteration) {
      // A path that reaches a found mode's peak ends there: it would converge to the same point.
      if (iteration > 0 && near_mode(m, arrived2)) break;
      for (size_t i = 0; i < n; ++i) {
        const float dx = xs[i] - m[0], dy = ys[i] - m[1], dz = zs[i] - m[2];
        const float q = (dx * dx + dy * dy + dz * dz) * inv_b2;
        w[i] = q < cutoff ? q : -1.0f;
      }
      double num[3] = {0, 0, 0}, den = 0;
      for (size_t i = 0; i < n; ++i) {
        if (w[i] < 0) continue;
        const double k = std::exp(-w[i]);  // float exp
        num[0] += k * xs[i];
        num[1] += k * ys[i];
        num[2] += k * zs[i];
        den += k;
      }
      const float next[3] = {float(num[0] / den), float(num[1] / den), float(num[2] / den)};
      const float shift2 = (next[0] - m[0]) * (next[0] - m[0]) + (next[1] - m[1]) * (next[1] - m[1]) +
                           (next[2] - m[2]) * (next[2] - m[2]);
      m[0] = next[0];
      m[1] = next[1];
      m[2] = next[2];
      if (shift2 < tolerance2) break;
    }
    if (Mode* mode = near_mode(m, merge2))
      ++mode->weight;
    else
      modes.push_back({{m[0], m[1], m[2]}, 1});
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

void check_leaf_params(const LeafParams& params, int joints) {
  if (params.reservoir < 1) tools::fail("--nres must be ≥ 1");
  if (!(params.bandwidth_m > 0)) tools::fail("--bandwidth must be > 0");
  if (params.votes_per_joint < 1 || params.votes_per_joint > 64) tools::fail("--votes-per-leaf must be 1..64");
  if (params.vote_length_m.size() > 1 && params.vote_length_m.size() != size_t(joints))
    tools::fail("--vote-length wants one value or " + std::to_string(joints) + " (one per joint), got " +
                std::to_string(params.vote_length_m.size()));
}

void prepare_votes(TrainedTree& tree, size_t leaves, int joints, int k, size_t first_leaf) {
  const size_t vote_count = leaves * size_t(joints) * size_t(k);
  if (first_leaf == 0)
    tree.votes.assign(vote_count, LeafVote{});
  else if (first_leaf > leaves || tree.votes.size() != vote_count)
    tools::fail("resuming leaf votes at leaf " + std::to_string(first_leaf) + " of " + std::to_string(leaves) + " with " +
                std::to_string(tree.votes.size()) + " votes (expected " + std::to_string(vote_count) + ")");
}

void for_leaf_blocks(size_t first_leaf, size_t leaves, const LeafParams& params, const std::function<void(size_t)>& fit,
                     const LeavesDoneFn& leaves_done) {
  const size_t block = std::max<size_t>(1, params.leaf_block);
  for (size_t begin = first_leaf; begin < leaves; begin += block) {
    const size_t end = std::min(leaves, begin + block);
    parallel_for(end - begin, params.threads, [&](size_t i, int) { fit(begin + i); });
    if (leaves_done) leaves_done(end);
  }
}

void fit_votes(const TrainingSet& set, const std::vector<TrainingPixel>& pixels, const LeafRanges& ranges,
               const LeafParams& params, int tree_index, TrainedTree& tree, size_t first_leaf,
               const LeavesDoneFn& leaves_done) {
  const int joints = static_cast<int>(set.joint_names.size());
  check_leaf_params(params, joints);
  if (!set.has_joints || joints == 0) tools::fail("offset joint regression leaves need joints in every frame");
  const int k = params.votes_per_joint;
  prepare_votes(tree, ranges.size(), joints, k, first_leaf);
  for_leaf_blocks(first_leaf, ranges.size(), params, [&](size_t l) {
    std::vector<ReservoirSampler<std::array<float, 3>>> reservoirs(joints, ReservoirSampler<std::array<float, 3>>(params.reservoir));
    std::vector<Rng> rngs;
    for (int j = 0; j < joints; ++j) rngs.push_back(Rng::keyed(params.seed, 4, uint64_t(tree_index), l, uint64_t(j)));
    for (uint32_t i = ranges[l].first; i < ranges[l].second; ++i) {
      const TrainingPixel& p = pixels[i];
      for (int j = 0; j < joints; ++j) reservoirs[j].offer(joint_offset(set.images[p.image], p, j), rngs[j]);
    }
    for (int j = 0; j < joints; ++j) fill_leaf_votes(reservoirs[j].items(), params, j, &tree.votes[(l * joints + j) * k]);
  }, leaves_done);
}

void fill_leaf_votes(const std::vector<std::array<float, 3>>& reservoir, const LeafParams& params, int joint,
                     LeafVote* out) {
  const float lambda = params.vote_length_m.empty() ? 0.0f
                       : params.vote_length_m.size() == 1 ? params.vote_length_m[0]
                                                          : params.vote_length_m[joint];
  const std::vector<LeafVote> v =
      select_votes(mean_shift_modes(reservoir, params.bandwidth_m), lambda, params.votes_per_joint);
  std::copy(v.begin(), v.end(), out);
}

std::array<float, 3> joint_offset(const TrainingImage& image, const TrainingPixel& p, int joint) {
  const std::array<float, 3> x = pixel_point(image, p.u, p.v, p.depth_mm);
  return {image.joints[3 * joint] - x[0], image.joints[3 * joint + 1] - x[1], image.joints[3 * joint + 2] - x[2]};
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
