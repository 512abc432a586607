#include "tools/train/distributed_leaves.h"

#include <cstring>

#include "tools/common/error.h"
#include "tools/train/tree_trainer.h"

namespace dp::train {

void sum_leaf_pixel_counts(TrainedTree& tree, Communicator& comm) {
  comm.sum(tree.leaf_pixel_counts.data(), tree.leaf_pixel_counts.size());
}

void fit_part_distributions_distributed(const std::vector<TrainingPixel>& pixels, const LeafRanges& ranges,
                                        int part_count, TrainedTree& tree, Communicator& comm) {
  if (tree.leaf_pixel_counts.size() != ranges.size())
    tools::fail("distributed part distributions: " + std::to_string(ranges.size()) + " leaf ranges for " +
                std::to_string(tree.leaf_pixel_counts.size()) + " leaves");
  std::vector<uint32_t> counts(ranges.size() * part_count, 0);
  for (size_t l = 0; l < ranges.size(); ++l)
    for (uint32_t i = ranges[l].first; i < ranges[l].second; ++i)
      if (pixels[i].label < part_count) ++counts[l * part_count + pixels[i].label];
  comm.sum(counts.data(), counts.size());
  tree.part_probabilities.assign(ranges.size() * part_count, 0.0f);
  for (size_t l = 0; l < ranges.size(); ++l) {
    const uint64_t n = tree.leaf_pixel_counts[l];
    if (n == 0) continue;
    for (int c = 0; c < part_count; ++c)
      tree.part_probabilities[l * part_count + c] = static_cast<float>(double(counts[l * part_count + c]) / double(n));
  }
}

namespace {

template <typename T>
void put(std::vector<uint8_t>& out, const T& v) {
  const size_t at = out.size();
  out.resize(at + sizeof v);
  std::memcpy(out.data() + at, &v, sizeof v);
}
template <typename T>
T take(const std::vector<uint8_t>& in, size_t& at, int rank) {
  if (at + sizeof(T) > in.size())
    tools::fail("distributed leaf votes: the message of rank " + std::to_string(rank) + " is truncated");
  T v;
  std::memcpy(&v, in.data() + at, sizeof v);
  at += sizeof v;
  return v;
}

}  // namespace

void fit_votes_distributed(const TrainingSet& set, const std::vector<TrainingPixel>& pixels, const LeafRanges& ranges,
                           const LeafParams& params, int tree_index, TrainedTree& tree, Communicator& comm,
                           size_t first_leaf, const LeavesDoneFn& leaves_done) {
  const int joints = static_cast<int>(set.joint_names.size());
  check_leaf_params(params, joints);
  if (!set.has_joints || joints == 0) tools::fail("offset joint regression leaves need joints in every frame");
  const size_t leaves = ranges.size(), ranks = size_t(comm.size()), me = size_t(comm.rank());
  const uint64_t capacity = uint64_t(params.reservoir);
  // Where this rank's pixels of each leaf start in the leaf's global order.
  std::vector<uint32_t> per_rank(leaves * ranks, 0);
  for (size_t l = 0; l < leaves; ++l) per_rank[l * ranks + me] = ranges[l].second - ranges[l].first;
  comm.sum(per_rank.data(), per_rank.size());

  // Per (leaf, joint): the slots this rank wrote last, with the offsets written.
  struct Write {
    uint32_t slot;
    std::array<float, 3> offset;
  };
  std::vector<std::vector<Write>> writes(leaves * joints);
  parallel_for(leaves, params.threads, [&](size_t l, int) {
    uint64_t before = 0;
    for (size_t r = 0; r < me; ++r) before += per_rank[l * ranks + r];
    std::vector<int64_t> last(std::min<uint64_t>(capacity, before + (ranges[l].second - ranges[l].first)), -1);
    for (int j = 0; j < joints; ++j) {
      Rng rng = Rng::keyed(params.seed, 4, uint64_t(tree_index), l, uint64_t(j));
      uint64_t seen = 0;
      for (; seen < before;) {  // the earlier ranks' pixels: the same draws, nothing kept
        ++seen;
        if (seen > capacity) rng.below(seen);
      }
      std::fill(last.begin(), last.end(), -1);
      for (uint32_t i = ranges[l].first; i < ranges[l].second; ++i) {
        ++seen;
        if (seen <= capacity) {
          last[seen - 1] = i;
        } else {
          const uint64_t s = rng.below(seen);
          if (s < capacity) last[s] = i;
        }
      }
      std::vector<Write>& w = writes[l * joints + j];
      for (size_t s = 0; s < last.size(); ++s)
        if (last[s] >= 0) {
          const TrainingPixel& p = pixels[size_t(last[s])];
          w.push_back({static_cast<uint32_t>(s), joint_offset(set.images[p.image], p, j)});
        }
    }
  });
  std::vector<uint8_t> message;
  for (const std::vector<Write>& w : writes) {
    put(message, static_cast<uint32_t>(w.size()));
    for (const Write& x : w) {
      put(message, x.slot);
      put(message, x.offset);
    }
  }
  writes.clear();
  const std::vector<std::vector<uint8_t>> all = comm.gather(message);
  prepare_votes(tree, leaves, joints, params.votes_per_joint, comm.rank() == 0 ? first_leaf : 0);
  if (comm.rank() != 0) return;

  std::vector<std::vector<std::array<float, 3>>> reservoirs(leaves * joints);
  std::vector<size_t> cursor(ranks, 0);
  for (size_t l = 0; l < leaves; ++l) {
    uint64_t total = 0;
    for (size_t r = 0; r < ranks; ++r) total += per_rank[l * ranks + r];
    for (int j = 0; j < joints; ++j) {
      std::vector<std::array<float, 3>>& res = reservoirs[l * joints + j];
      res.assign(std::min<uint64_t>(capacity, total), {0, 0, 0});
      for (size_t r = 0; r < ranks; ++r) {
        const uint32_t n = take<uint32_t>(all[r], cursor[r], int(r));
        for (uint32_t k = 0; k < n; ++k) {
          const uint32_t slot = take<uint32_t>(all[r], cursor[r], int(r));
          const auto offset = take<std::array<float, 3>>(all[r], cursor[r], int(r));
          if (slot >= res.size())
            tools::fail("distributed leaf votes: rank " + std::to_string(r) + " wrote slot " + std::to_string(slot) +
                        " of a reservoir of " + std::to_string(res.size()));
          res[slot] = offset;
        }
      }
    }
  }
  for_leaf_blocks(first_leaf, leaves, params, [&](size_t l) {
    for (int j = 0; j < joints; ++j)
      fill_leaf_votes(reservoirs[l * joints + j], params, j, &tree.votes[(l * joints + j) * params.votes_per_joint]);
  }, leaves_done);
}

}  // namespace dp::train
