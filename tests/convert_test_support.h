// Shared by the converter's tests (tests/convert_*_test.cc): a random trained forest (our 31 parts
// and 16 joints, random features, nodes split with a given probability down to a depth), a temporary
// directory.
#pragma once
#include <stdlib.h>

#include <algorithm>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "tests/cli_test_support.h"
#include "tools/common/body_model.h"
#include "tools/train/forest_file.h"

namespace dp {

// A random trained forest: nodes split with probability `split_p` down to `depth`, so leaves end at
// every level (the blob must pad them).
inline train::TrainedForest random_trained_forest(uint32_t seed, const std::string& method, int trees, int depth,
                                           double split_p, int k_votes = 2) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> off(-120, 120), thr(-300, 300);
  train::TrainedForest f;
  f.method = method;
  f.reference_focal_px = 525.0f;
  f.depth = depth;
  f.part_names.assign(tools::kPartNames.begin(), tools::kPartNames.end());
  f.joint_names.assign(tools::kJointNames.begin(), tools::kJointNames.end());
  f.has_part_distributions = method == "bpc";
  f.has_votes = method == "ojr";
  f.votes_per_joint = f.has_votes ? k_votes : 0;
  for (int t = 0; t < trees; ++t) {
    train::TrainedTree tree;
    std::vector<uint32_t> frontier = {0};
    std::vector<uint32_t> all;
    std::vector<bool> split;
    while (!frontier.empty()) {  // breadth first keeps heap indices increasing
      std::vector<uint32_t> next;
      for (uint32_t h : frontier) {
        const bool s = train::heap_level(h) < depth && (h == 0 || unit(rng) < split_p);
        all.push_back(h);
        split.push_back(s);
        if (s) {
          next.push_back(2 * h + 1);
          next.push_back(2 * h + 2);
        }
      }
      frontier = next;
    }
    std::vector<size_t> order(all.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return all[a] < all[b]; });
    int32_t leaves = 0;
    for (size_t i : order) {
      train::TrainedNode n;
      n.heap_index = all[i];
      if (split[i]) {
        n.du1 = int16_t(off(rng));
        n.dv1 = int16_t(off(rng));
        n.du2 = int16_t(off(rng));
        n.dv2 = int16_t(off(rng));
        n.threshold_mm = float(thr(rng));
      } else {
        n.leaf = leaves++;
      }
      tree.nodes.push_back(n);
    }
    tree.leaf_pixel_counts.assign(size_t(leaves), 10);
    for (int32_t l = 0; l < leaves; ++l) {
      if (f.has_part_distributions) {
        std::vector<double> raw(tools::kPartCount);
        double sum = 0;
        for (double& r : raw) sum += (r = unit(rng) < 0.6 ? 0.0 : unit(rng));
        if (sum == 0) raw[0] = sum = 1;
        for (double r : raw) tree.part_probabilities.push_back(float(r / sum));
      }
      if (f.has_votes)
        for (int j = 0; j < tools::kJointCount; ++j)
          for (int k = 0; k < k_votes; ++k) {
            const bool none = unit(rng) < 0.1;
            tree.votes.push_back(train::LeafVote{float(unit(rng) * 5 - 2.5), float(unit(rng) * 1.2 - 0.6),
                                                 float(unit(rng) * 0.8 - 0.4), none ? 0.0f : float(unit(rng) * 300)});
          }
    }
    f.trees.push_back(std::move(tree));
  }
  train::link_and_validate(f, "random forest");
  return f;
}

struct TempDir {
  std::string path;
  TempDir() {
    char tmpl[] = "/tmp/dp_convert_test_XXXXXX";
    path = mkdtemp(tmpl);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
};

using testsupport::run_cli;  // `depthpose convert ...` in-process: run_cli({"convert", ...})

}  // namespace dp
