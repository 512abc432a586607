#include "tools/convert/forest_convert.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>

#include "forest_blob/blob_loader.h"
#include "runtime/fixed_point.h"
#include "runtime/kernels/forest_kernel.h"
#include "tools/common/body_model.h"
#include "tools/common/error.h"

namespace dp::tools {

void bpc_joint_masks(const std::vector<std::string>& parts, std::vector<std::string>* joint_names,
                     std::vector<uint32_t>* masks, const std::string& what) {
  joint_names->clear();
  masks->clear();
  auto part_bit = [&](const std::string& name) -> uint32_t {
    for (size_t p = 0; p < parts.size(); ++p)
      if (parts[p] == name) return 1u << p;
    return 0;
  };
  for (const char* joint : kJointNames) {
    uint32_t mask = part_bit(joint);
    if (std::string(joint) == "head")
      mask |= part_bit("head_lu") | part_bit("head_ru") | part_bit("head_lw") | part_bit("head_rw");
    if (mask == 0) continue;
    joint_names->push_back(joint);
    masks->push_back(mask);
  }
  if (masks->empty()) fail(what + ": no part name matches a joint (head, neck, shoulder_l, ...): cannot map joints");
}

namespace {

// Largest-remainder Q15 rounding of one distribution; returns the worst |q/32768 − p|.
double quantize_distribution(const float* p, int parts, uint16_t* out) {
  double sum = 0;
  for (int c = 0; c < parts; ++c) sum += double(p[c]);
  int64_t target = int64_t(std::llround(sum * 32768.0));
  if (target > 32768) target = 32768;
  int64_t given = 0;
  std::vector<std::pair<double, int>> remainders;
  for (int c = 0; c < parts; ++c) {
    const double exact = double(p[c]) * 32768.0;
    const int64_t q = int64_t(std::floor(exact));
    out[c] = uint16_t(q);
    given += q;
    remainders.push_back({exact - double(q), c});
  }
  // Largest fractional parts first; ties by part index (deterministic).
  std::stable_sort(remainders.begin(), remainders.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  for (size_t k = 0; given < target && k < remainders.size(); ++k, ++given) ++out[remainders[k].second];
  double worst = 0;
  for (int c = 0; c < parts; ++c) worst = std::max(worst, std::fabs(out[c] / 32768.0 - double(p[c])));
  return worst;
}

}  // namespace

CompactionReport compact_bpc_leaves(blob::BlobContents* c, const BpcCompaction& k) {
  CompactionReport rep;
  if (c->method != blob::Method::kBpc) return rep;
  if (k.max_parts < 1 || k.max_parts > blob::kMaxParts || k.min_q15 < 1 || k.min_q15 > blob::kProbabilityOneQ15)
    fail("BPC compaction: max parts " + std::to_string(k.max_parts) + " outside 1.." + std::to_string(blob::kMaxParts) +
         " or min probability " + std::to_string(k.min_q15) + " outside 1..32768 (Q15)");
  const size_t parts = c->part_names.size();
  if (parts == 0) return rep;
  const size_t records = c->bpc_leaves.size() / parts;
  std::vector<int> order(parts);
  for (size_t r = 0; r < records; ++r) {
    uint16_t* p = &c->bpc_leaves[r * parts];
    for (size_t i = 0; i < parts; ++i) order[i] = int(i);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return p[a] > p[b]; });
    uint32_t dropped = 0;
    for (size_t rank = 0; rank < parts; ++rank) {
      uint16_t& q = p[order[rank]];
      if (q == 0 || (rank < size_t(k.max_parts) && q >= k.min_q15)) continue;
      dropped += q;
      q = 0;
      ++rep.dropped_parts;
    }
    rep.mean_dropped_mass += dropped / 32768.0;
    rep.worst_dropped_mass = std::max(rep.worst_dropped_mass, dropped / 32768.0);
  }
  if (records) rep.mean_dropped_mass /= double(records);
  return rep;
}

OjrCompactionReport compact_ojr_leaves(blob::BlobContents* c, const OjrCompaction& k) {
  OjrCompactionReport rep;
  if (c->method != blob::Method::kOjr) return rep;
  if (k.max_votes < 1 || k.max_votes > blob::kMaxVotesPerLeafJoint || k.max_length_mm > blob::kMaxVoteLengthMm ||
      !(k.min_share >= 0.0 && k.min_share <= 1.0))
    fail("OJR compaction: max votes " + std::to_string(k.max_votes) + " outside 1.." +
         std::to_string(blob::kMaxVotesPerLeafJoint) + ", max length " + std::to_string(k.max_length_mm) +
         " mm outside 0.." + std::to_string(blob::kMaxVoteLengthMm) + " or min share " + std::to_string(k.min_share) +
         " outside 0..1");
  const size_t joints = c->joint_names.size();
  if (!k.joint_max_length_mm.empty()) {
    if (k.joint_max_length_mm.size() != joints)
      fail("OJR compaction: " + std::to_string(k.joint_max_length_mm.size()) + " per-joint vote lengths for a forest of " +
           std::to_string(joints) + " joints");
    if (!k.joint_names.empty() && k.joint_names != c->joint_names) {
      std::string theirs, ours;
      for (const auto& n : k.joint_names) theirs += (theirs.empty() ? "" : ",") + n;
      for (const auto& n : c->joint_names) ours += (ours.empty() ? "" : ",") + n;
      fail("OJR compaction: the per-joint vote lengths are for joints " + theirs + ", the forest's are " + ours);
    }
    for (const uint16_t len : k.joint_max_length_mm)
      if (len > blob::kMaxVoteLengthMm)
        fail("OJR compaction: per-joint max length " + std::to_string(len) + " mm outside 0.." +
             std::to_string(blob::kMaxVoteLengthMm));
  }
  const auto cut_of = [&](size_t j) { return k.joint_max_length_mm.empty() ? k.max_length_mm : k.joint_max_length_mm[j]; };
  const size_t lanes = size_t(c->votes_per_joint);
  if (lanes == 0) return rep;
  std::vector<size_t> order(lanes);
  for (size_t g = 0; g * lanes < c->ojr_leaves.size(); ++g) {  // one (record, joint) at a time
    blob::OjrVote* v = &c->ojr_leaves[g * lanes];
    const uint16_t cut = cut_of(g % joints);
    const int64_t len2 = int64_t(cut) * cut;
    uint64_t total = 0;
    for (size_t i = 0; i < lanes; ++i) total += v[i].weight;
    for (size_t i = 0; i < lanes; ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return v[a].weight > v[b].weight; });
    int kept = 0;
    for (size_t i : order) {
      blob::OjrVote& x = v[i];
      if (x.weight == 0) continue;
      ++rep.votes_before;
      const int64_t d2 = int64_t(x.dx_mm) * x.dx_mm + int64_t(x.dy_mm) * x.dy_mm + int64_t(x.dz_mm) * x.dz_mm;
      uint64_t* reason = nullptr;
      if (cut > 0 && d2 > len2)
        reason = &rep.dropped_long;
      else if (double(x.weight) < k.min_share * double(total))
        reason = &rep.dropped_light;
      else if (kept == k.max_votes)
        reason = &rep.dropped_beyond_k;
      if (reason) {
        ++*reason;
        x = blob::OjrVote{0, 0, 0, 0};
        continue;
      }
      ++kept;
      ++rep.votes_after;
    }
  }
  for (size_t j = 0; j < joints; ++j) {
    const uint16_t cut = cut_of(j);
    uint16_t& len = c->config.joints[j].vote_length_mm;
    if (cut > 0 && (len == 0 || len > cut)) len = cut;
  }
  return rep;
}

blob::BlobContents convert_forest(const train::TrainedForest& forest, const ConvertOptions& options,
                                  const std::string& what, QuantizationReport* report) {
  QuantizationReport rep;
  const bool bpc = forest.method == "bpc";
  if (!bpc && forest.method != "ojr") fail(what + ": method '" + forest.method + "' is neither bpc nor ojr");
  if (bpc && !forest.has_part_distributions) fail(what + ": BPC forest without part distributions");
  if (!bpc && !forest.has_votes) fail(what + ": OJR forest without votes");
  if (forest.trees.empty() || forest.trees.size() > size_t(blob::kMaxTrees))
    fail(what + ": " + std::to_string(forest.trees.size()) + " trees; a blob holds 1.." + std::to_string(blob::kMaxTrees));
  if (forest.part_names.size() > size_t(blob::kMaxParts))
    fail(what + ": " + std::to_string(forest.part_names.size()) + " parts; a blob holds at most " +
         std::to_string(blob::kMaxParts));
  int depth = 1;
  for (const auto& t : forest.trees) depth = std::max(depth, t.max_leaf_level());
  if (depth > blob::kMaxDepth)
    fail(what + ": deepest leaf at level " + std::to_string(depth) + "; a blob holds depth ≤ " +
         std::to_string(blob::kMaxDepth));
  rep.blob_depth = depth;

  blob::BlobContents c;
  c.method = bpc ? blob::Method::kBpc : blob::Method::kOjr;
  c.depth = depth;
  c.reference_focal_px = forest.reference_focal_px;
  c.part_names = forest.part_names;
  c.max_width = options.max_width;
  c.max_height = options.max_height;
  std::vector<uint32_t> masks;
  if (bpc) {
    bpc_joint_masks(forest.part_names, &c.joint_names, &masks, what);
  } else {
    if (forest.joint_names.size() > size_t(blob::kMaxJoints))
      fail(what + ": " + std::to_string(forest.joint_names.size()) + " joints; a blob holds at most " +
           std::to_string(blob::kMaxJoints));
    c.joint_names = forest.joint_names;
    c.votes_per_joint = std::min(forest.votes_per_joint, blob::kMaxVotesPerLeafJoint);
  }

  uint32_t record_base = 0;
  double max_weight = 0;
  if (!bpc)
    for (const auto& t : forest.trees)
      for (const auto& v : t.votes) max_weight = std::max(max_weight, double(v.weight));
  const double weight_scale = max_weight > 0 ? 65535.0 / max_weight : 1.0;
  const int parts = int(forest.part_names.size());
  const int joints = int(forest.joint_names.size());
  const int k_in = forest.votes_per_joint;

  for (size_t ti = 0; ti < forest.trees.size(); ++ti) {
    const train::TrainedTree& tree = forest.trees[ti];
    // The trained nodes, sorted by heap index, are the blob's breadth-first order: node i is sparse node
    // m = i + 1 and the k-th split node's children are the nodes at positions 2k − 1, 2k (heap 2h+1, 2h+2).
    std::vector<blob::TreeNode> nodes;
    std::vector<uint32_t> index, left_child;
    uint32_t splits = 0;
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
      const train::TrainedNode& n = tree.nodes[i];
      const uint32_t m = uint32_t(i + 1);
      if (n.is_leaf()) {
        nodes.push_back(blob::TreeNode{0, 0, 0, 0, blob::kPadThreshold});
        index.push_back(record_base + uint32_t(n.leaf));
        left_child.push_back(m);
        ++rep.leaf_nodes;
        continue;
      }
      for (int v : {n.du1, n.dv1, n.du2, n.dv2})
        if (std::abs(v) > blob::kMaxProbeOffsetPxm)
          fail(what + ": tree " + std::to_string(ti) + " node " + std::to_string(n.heap_index) + " offset " +
               std::to_string(v) + " beyond ±" + std::to_string(blob::kMaxProbeOffsetPxm));
      const uint32_t left = 2 * ++splits;  // 1-based
      if (left > tree.nodes.size() || tree.nodes[left - 1].heap_index != 2 * n.heap_index + 1 ||
          tree.nodes[left].heap_index != 2 * n.heap_index + 2)
        fail(what + ": tree " + std::to_string(ti) + " split node " + std::to_string(n.heap_index) +
             " lacks a child (the trained tree is not a full binary tree)");
      nodes.push_back(blob::TreeNode{n.du1, n.dv1, n.du2, n.dv2, int16_t(n.threshold_mm)});
      index.push_back(0);
      left_child.push_back(left);
    }
    c.tree_nodes.push_back(std::move(nodes));
    c.tree_leaf_index.push_back(std::move(index));
    c.tree_left_child.push_back(std::move(left_child));

    for (size_t l = 0; l < tree.leaf_count(); ++l) {
      if (bpc) {
        std::vector<uint16_t> q(static_cast<size_t>(parts));
        rep.worst_probability_error =
            std::max(rep.worst_probability_error, quantize_distribution(&tree.part_probabilities[l * parts], parts, q.data()));
        c.bpc_leaves.insert(c.bpc_leaves.end(), q.begin(), q.end());
        continue;
      }
      for (int j = 0; j < joints; ++j) {
        const train::LeafVote* in = &tree.votes[(l * joints + j) * size_t(k_in)];
        std::vector<int> order(static_cast<size_t>(k_in));
        for (int k = 0; k < k_in; ++k) order[k] = k;
        std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return in[a].weight > in[b].weight; });
        for (int k = 0; k < k_in; ++k)
          if (k >= c.votes_per_joint && in[order[k]].weight > 0) ++rep.dropped_votes;
        for (int k = 0; k < c.votes_per_joint; ++k) {
          const train::LeafVote& v = in[order[k]];
          blob::OjrVote out{0, 0, 0, 0};
          if (v.weight > 0) {
            int16_t* comp[3] = {&out.dx_mm, &out.dy_mm, &out.dz_mm};
            const float metres[3] = {v.dx, v.dy, v.dz};
            for (int a = 0; a < 3; ++a) {
              const double mm = double(metres[a]) * 1000.0;
              double q = std::round(mm);
              if (std::fabs(q) > blob::kMaxVoteOffsetMm) {
                q = q > 0 ? blob::kMaxVoteOffsetMm : -blob::kMaxVoteOffsetMm;
                ++rep.clamped_vote_components;
              } else {
                rep.worst_vote_offset_error_mm = std::max(rep.worst_vote_offset_error_mm, std::fabs(q - mm));
              }
              *comp[a] = int16_t(q);
            }
            const double w = std::max(1.0, std::round(double(v.weight) * weight_scale));
            out.weight = uint16_t(std::min(65535.0, w));
            rep.worst_vote_weight_rel_error = std::max(
                rep.worst_vote_weight_rel_error, std::fabs(out.weight / weight_scale - double(v.weight)) / double(v.weight));
          }
          c.ojr_leaves.push_back(out);
        }
      }
    }
    record_base += uint32_t(tree.leaf_count());
  }
  c.config = blob::default_runtime_config(int(c.joint_names.size()));
  for (size_t j = 0; j < masks.size(); ++j) c.config.joints[j].part_mask = masks[j];
  rep.bpc_compaction = compact_bpc_leaves(&c, options.bpc);
  rep.ojr_compaction = compact_ojr_leaves(&c, options.ojr);
  if (report) *report = rep;
  return c;
}

std::vector<std::vector<uint16_t>> sample_frames(int width, int height, int count) {
  std::vector<std::vector<uint16_t>> frames;
  std::mt19937 rng(20261122u);
  for (int i = 0; i < count; ++i) {
    std::vector<uint16_t> d(size_t(width) * height, 0);
    const float cu = width * (0.3f + 0.4f * float(rng() % 1000) / 1000.0f);
    const float cv = height * (0.3f + 0.4f * float(rng() % 1000) / 1000.0f);
    const float r = height * (0.15f + 0.25f * float(rng() % 1000) / 1000.0f);
    const int base = 800 + int(rng() % 3200);
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u) {
        const float du = u - cu, dv = v - cv;
        const bool inside = i % 3 == 0 ? true : du * du + dv * dv < r * r;  // every third: a full tilted plane
        if (!inside) continue;
        int z = base + int(du * 2.0f + dv * 1.5f) + int(rng() % 7);
        if (i % 3 == 2 && rng() % 13 == 0) z = 0;  // holes
        d[size_t(v) * width + u] = uint16_t(std::clamp(z, 0, 8000));
      }
    frames.push_back(std::move(d));
  }
  return frames;
}

BudgetedBlob convert_within_budget(const train::TrainedForest& forest, const ConvertOptions& options,
                                   const PruneBudget& budget, const std::string& what) {
  if (budget.min_leaf_pixels > 0 && forest.has_votes)
    fail(what + ": --min-leaf-pixels prunes BPC forests only: OJR votes are mean-shift modes that do not merge; "
                "prune the structure before retro-fitting (depthpose train --structure F --structure-min-pixels N)");
  std::optional<train::GainPruneOrder> gain_order;
  if (budget.by_gain) {
    if (forest.has_votes)
      fail(what + ": pruning by gain is for BPC forests: OJR votes are mean-shift modes that do not merge");
    if (budget.min_leaf_pixels > 0) fail(what + ": --prune-by gain and --min-leaf-pixels exclude each other");
    if (budget.max_bytes == 0) fail(what + ": --prune-by gain needs --max-bytes");
    gain_order.emplace(forest);
  }
  // Both prunings are one knob x under which the blob never grows: the pixel threshold N, or the
  // number of splits collapsed in the gain order (leaf_count() − x leaves kept). 0 prunes nothing.
  auto build = [&](uint64_t x) {
    BudgetedBlob b;
    if (x == 0) {
      b.forest = forest;
      for (const auto& t : forest.trees) {
        b.prune.leaves_before += t.leaf_count();
        b.prune.depth_before = std::max(b.prune.depth_before, t.max_leaf_level());
      }
      b.prune.leaves_after = b.prune.leaves_before;
      b.prune.depth_after = b.prune.depth_before;
    } else if (gain_order) {
      b.max_leaves = gain_order->leaf_count() - x;
      b.forest = gain_order->prune_to(b.max_leaves, &b.prune);
    } else {
      b.min_leaf_pixels = x;
      b.forest = train::prune_forest(forest, x, &b.prune);
    }
    b.bytes = blob::write_blob(convert_forest(b.forest, options, what, &b.quantization));
    return b;
  };
  const uint64_t start = budget.min_leaf_pixels;
  const uint64_t most = gain_order ? gain_order->leaf_count() - gain_order->min_leaves()
                                   : train::prune_everything_threshold(forest);
  int conversions = 1;
  BudgetedBlob best = build(start);
  const auto fits = [&](const BudgetedBlob& b) { return budget.max_bytes == 0 || b.bytes.size() <= budget.max_bytes; };
  if (!fits(best)) {
    if (forest.has_votes)
      fail(what + ": the OJR blob is " + std::to_string(best.bytes.size()) + " bytes, above --max-bytes " +
           std::to_string(budget.max_bytes) + "; OJR votes do not merge, so prune the structure before retro-fitting " +
           "(depthpose train --structure F --structure-min-pixels N) or cut more votes (--ojr-max-length)");
    // Invariant: the blob at `low` exceeds the budget, the one at `high` fits; the smallest fitting
    // x is kept (by gain: the most leaves).
    uint64_t low = start, high = most;
    BudgetedBlob fitting = build(high);
    ++conversions;
    if (!fits(fitting))
      fail(what + ": --max-bytes " + std::to_string(budget.max_bytes) + " cannot be met: with every tree pruned to " +
           "its root the blob is still " + std::to_string(fitting.bytes.size()) + " bytes");
    while (high - low > 1) {
      const uint64_t mid = low + (high - low) / 2;
      BudgetedBlob b = build(mid);
      ++conversions;
      if (fits(b)) {
        high = mid;
        fitting = std::move(b);
      } else {
        low = mid;
      }
    }
    best = std::move(fitting);
  }
  best.conversions = conversions;
  return best;
}

LeafCheck check_leaves(const train::TrainedForest& forest, const std::vector<uint8_t>& blob_bytes,
                       const std::vector<std::vector<uint16_t>>& frames, int width, int height, float focal_px) {
  blob::LoadedBlob b;
  if (blob::load_blob(blob_bytes.data(), blob_bytes.size(), &b) != blob::BlobStatus::kOk)
    fail("check_leaves: the blob does not load");
  if (size_t(b.tree_count()) != forest.trees.size()) fail("check_leaves: the blob's tree count differs from the forest's");
  // The blob numbers records by leaf node in breadth-first order (blob_format.h): the trained node at
  // position i (sorted by heap index: sparse node i + 1) reads record tree_first_leaf[t] + (leaf nodes
  // before it).
  std::vector<std::vector<uint32_t>> record_of(forest.trees.size());
  for (size_t t = 0; t < forest.trees.size(); ++t) {
    uint32_t r = b.tree_first_leaf[t];
    for (const train::TrainedNode& n : forest.trees[t].nodes) record_of[t].push_back(n.is_leaf() ? r++ : 0);
  }
  std::vector<blob::TreeNode> nodes(b.total_nodes);
  std::vector<uint32_t> left_child(b.total_nodes), leaf_index(b.total_nodes);
  blob::expand_tree_tables(b, nodes.data(), left_child.data(), leaf_index.data());
  const int32_t focal = focal_factor_mm(focal_px, forest.reference_focal_px);
  LeafCheck check;
  for (const auto& depth : frames) {
    const std::vector<uint16_t> probe = train::make_probe_image(depth.data(), nullptr, width, height);
    std::vector<uint16_t> padded(kernels::padded_probe_elements(width, height));
    kernels::fill_probe_border(padded.data(), width, height);
    std::vector<EvaluatedPixel> pixels;
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u) {
        const uint16_t z = probe[size_t(v) * width + u];
        padded[size_t(v + 1) * (width + 2) + u + 1] = kernels::probe_element(z);
        if (z != kBackgroundDepthMm) pixels.push_back(EvaluatedPixel{uint16_t(u), uint16_t(v), z, 0});
      }
    if (pixels.empty()) continue;
    std::vector<uint32_t> ref(pixels.size()), best(pixels.size());
    for (size_t t = 0; t < forest.trees.size(); ++t) {
      kernels::ForestKernelArgs a{padded.data(), width + 2, width, height, focal, pixels.data(), int32_t(pixels.size()),
                                  nodes.data() + b.tree_first[t], nullptr, left_child.data() + b.tree_first[t],
                                  leaf_index.data() + b.tree_first[t], b.depth(), b.tree_node_count(int(t)), ref.data()};
      kernels::forest_kernel(KernelIsa::kScalar)(a);
      a.leaf_out = best.data();
      kernels::forest_kernel(KernelIsa::kBest)(a);
      const train::TrainedTree& tree = forest.trees[t];
      for (size_t i = 0; i < pixels.size(); ++i) {
        const int pos = train::leaf_node_for_pixel(tree, probe.data(), width, height, pixels[i].u, pixels[i].v, focal);
        const uint32_t expected = record_of[t][size_t(pos)];
        ++check.pixels;
        check.mismatches += (ref[i] != expected) + (best[i] != expected) > 0;
      }
    }
  }
  return check;
}

}  // namespace dp::tools
