// Trained forest (tools/train/forest_file.h, full precision) → forest blob v3 (fixed point).
// docs/convert.md documents the quantization and its error bounds.
//
// Quantization
//   thresholds      float, whole numbers in int16 range (validated by the reader) → int16: exact
//   offsets         int16 pixel·metres → int16: exact (|δ| > kMaxProbeOffsetPxm is refused)
//   BPC leaves      float p_c (Σ = 1) → uint16 Q15 by largest remainder: Σ q_c = round(32768·Σ p_c)
//                   ≤ 32768, |q_c − 32768·p_c| < 1, i.e. error < 2^-15 per probability
//   OJR vote offset float metres → int16 mm, round half away from zero: error ≤ 0.5 mm, clamped to
//                   ±kMaxVoteOffsetMm (counted and reported)
//   OJR vote weight float ≥ 0 → uint16: round(w · 65535 / w_max) with w_max the forest's largest
//                   weight; a nonzero weight never becomes 0 (min 1). Relative weights are what
//                   the runtime uses; relative error ≤ 0.5 / q.
//   K > kMaxVotesPerLeafJoint: the heaviest kMaxVotesPerLeafJoint votes of each leaf/joint are kept.
// Tree shape
//   Blob depth = the deepest trained leaf's level (≥ 1). Nodes are stored as trained, nothing padded
//   (blob_format.h kNodes): the trained nodes in heap-index order are the breadth-first order, a
//   leaf becomes a leaf node (left child itself, threshold kPadThreshold) holding its record, so a
//   traversal that reaches a leaf above that depth stays on it for the remaining steps.
// Output is byte-identical for identical input.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "forest_blob/blob_writer.h"
#include "tools/train/forest_file.h"
#include "tools/train/forest_truncate.h"

namespace dp::tools {

// BPC leaf compaction: a leaf keeps at most max_parts parts, each with probability ≥ min_q15/32768;
// the mass of the others is dropped (not renormalized: the record's sum falls below 1 by it).
// Defaults, measured with `depthpose eval` (D_tp 0.1 m) on a 60-frame synth validation set
// (320×240, seed 77) with the shipped depth-16 BPC forest recompacted from its v1 blob:
//   max parts / min probability   mAP     per-class accuracy   dropped mass per leaf   blob bytes
//   32 / any nonzero (lossless)   0.765   0.455                0                       4 051 888
//    8 / 0.01                     0.770   0.454                0.0038                  3 989 406
//    4 / 0.02  (chosen)           0.766   0.454                0.046                   3 783 367
//    3 / 0.05                     0.761   0.454                0.094                   3 624 791
// 4 / 0.02 costs no measurable accuracy (differences are within the 60-frame noise) and bounds a
// record at 4 entries (4 + 4·3 = 16 bytes); the stored leaves of a depth-20 forest hold 1.8 parts on
// average anyway, so the cap matters for shallow trees and guarantees the bound.
struct BpcCompaction {
  int max_parts = 4;        // parts per leaf, 1..kMaxParts (kMaxParts with min_q15 = 1: lossless)
  uint16_t min_q15 = 656;   // Q15 probability, 1..32768; 656 = ⌈0.02 · 32768⌉
};

struct CompactionReport {
  uint64_t dropped_parts = 0;       // nonzero parts removed
  double mean_dropped_mass = 0;     // per record, probability
  double worst_dropped_mass = 0;    // largest over records
};

// Applies `compaction` to the dense BPC leaves of `contents` (no-op for OJR). Deterministic: parts
// ranked by probability, ties by part index.
CompactionReport compact_bpc_leaves(blob::BlobContents* contents, const BpcCompaction& compaction);

// OJR leaf compaction: a (leaf, joint) keeps at most max_votes votes, each at most max_length_mm
// long (0 = any length) and carrying at least min_share of the weight of that (leaf, joint)'s
// votes; the others are dropped (weight 0: not stored). A vote longer than the config's vote length
// λ_j is never cast (runtime/ojr_votes.h), so the length cut only removes votes the runtime would
// skip unless a config raises λ_j above it: compaction lowers each joint's λ_j to max_length_mm
// (0 or longer becomes max_length_mm), and a tuned λ_j beyond it changes nothing.
// Defaults, measured with `depthpose eval` (D_tp 0.1 m) on 300 held-out frames (split:test) with a
// depth-20 OJR forest (BPC structure from 1500 split:train frames, 3 trees, min 10 samples, K = 2,
// λ = 0.5 m at training), each blob tuned on 150 split:validation frames (`depthpose tune`):
//   votes / length cut / share   votes per record   blob bytes    mAP untuned   mAP tuned
//   as trained (lossless)        18.99              86 958 084    0.558         0.627
//   2 / 0.35 m / 0               10.25              54 536 964    0.564         0.628
//   2 / 0.30 m / 0  (chosen)      7.63              44 825 156    0.575         0.628
//   2 / 0.15 m / 0                1.99              23 875 908    0.620         0.629
// The tuned vote lengths of the shipped OJR blob are 100..350 mm (this forest's reach 450 mm): votes
// beyond 0.3 m are nearly never cast, and the cut halves the leaf entries at no measured accuracy
// cost, with a margin for joints whose best λ_j is long. A weight share of
// 0.2..0.3 dropped only 5..10 % of the votes at no gain, so it stays off; K stays as trained.
// Per-joint cuts (joint_max_length_mm, one per joint in the forest's joint order, replacing
// max_length_mm) serve a tuned blob: its λ_j are the longest votes the runtime casts per joint, so
// cutting each joint at its own λ_j (`convert --ojr-lengths-from TUNED.blob`) drops only votes that
// blob never casts. See docs/convert.md "OJR leaf compaction" for what that saves.
struct OjrCompaction {
  int max_votes = blob::kMaxVotesPerLeafJoint;  // per (leaf, joint), 1..kMaxVotesPerLeafJoint
  uint16_t max_length_mm = 300;                 // 0..kMaxVoteLengthMm; 0 = no limit
  double min_share = 0;                         // 0..1 of the (leaf, joint)'s total vote weight
  std::vector<uint16_t> joint_max_length_mm;    // empty, or per joint 0..kMaxVoteLengthMm (0 = no limit)
  std::vector<std::string> joint_names;         // when set: the joints those lengths are for, which
                                                // must be the forest's, in its order
};

struct OjrCompactionReport {
  uint64_t votes_before = 0, votes_after = 0;  // nonzero votes
  uint64_t dropped_long = 0, dropped_light = 0, dropped_beyond_k = 0;  // by the first rule that dropped each
};

// Applies `compaction` to the dense OJR leaves of `contents` (no-op for BPC) and lowers the config's
// vote lengths to its max_length_mm. Deterministic: votes ranked by weight, ties by lane.
OjrCompactionReport compact_ojr_leaves(blob::BlobContents* contents, const OjrCompaction& compaction);

struct ConvertOptions {
  uint32_t max_width = 640, max_height = 480;  // frame size the arena is sized for
  BpcCompaction bpc;                           // BPC leaf compaction (measured defaults)
  OjrCompaction ojr;                           // OJR leaf compaction (measured defaults)
};

struct QuantizationReport {
  double worst_probability_error = 0;    // max |q/32768 − p| over all BPC leaf entries
  double worst_vote_offset_error_mm = 0; // max |q − 1000·d| over unclamped vote components
  double worst_vote_weight_rel_error = 0;// max |q/scale − w| / w over nonzero weights
  uint64_t clamped_vote_components = 0;  // |offset| > kMaxVoteOffsetMm
  uint64_t dropped_votes = 0;            // beyond kMaxVotesPerLeafJoint per leaf/joint
  uint64_t leaf_nodes = 0;               // leaf nodes stored (the trained leaves)
  int blob_depth = 0;
  CompactionReport bpc_compaction;
  OjrCompactionReport ojr_compaction;
};

// The blob contents for `forest`. Throws ToolError (naming `what`) for what the blob cannot hold:
// depth > kMaxDepth, offsets beyond kMaxProbeOffsetPxm, > kMaxTrees trees, > kMaxParts parts,
// > kMaxJoints joints, a BPC forest without distributions, an OJR forest without votes, or joints
// with no part to map to.
blob::BlobContents convert_forest(const train::TrainedForest& forest, const ConvertOptions& options,
                                  const std::string& what, QuantizationReport* report);

// The joint part masks for a BPC forest: our 16 joints from our 31 parts (head = the four head
// parts, otherwise the part of the same name); for other part sets, every joint whose name equals
// a part name. Returns joint names and masks (same length, ≥ 1) or throws ToolError.
void bpc_joint_masks(const std::vector<std::string>& part_names, std::vector<std::string>* joint_names,
                     std::vector<uint32_t>* masks, const std::string& what);

// Pruning to a size budget (docs/convert.md "Pruning to a size budget"): a BPC forest is trained
// deep once and pruned at conversion (train::prune_forest: subtrees with fewer than N training
// pixels become leaves holding their pixels' merged part distribution).
//   min_leaf_pixels N   prune at N (0 = no pruning)
//   max_bytes B         then, if the blob exceeds B bytes, raise N to the smallest value whose blob
//                       fits (binary search; the blob never grows with N: a collapse removes two
//                       nodes and a record, and the merged record keeps no more parts than its
//                       leaves together under the same compaction). 0 = no budget.
//   by_gain             with max_bytes: prune by information gain instead (train::GainPruneOrder):
//                       keep the largest number of leaves whose blob fits (binary search over the
//                       nested order); min_leaf_pixels must be 0.
struct PruneBudget {
  uint64_t min_leaf_pixels = 0;
  uint64_t max_bytes = 0;
  bool by_gain = false;
};

struct BudgetedBlob {
  train::TrainedForest forest;  // the pruned forest the blob was converted from
  std::vector<uint8_t> bytes;   // the blob (write_blob)
  uint64_t min_leaf_pixels = 0; // N used (0: not pruned)
  uint64_t max_leaves = 0;      // leaves kept when pruned by gain (0: not pruned by gain)
  train::PruneReport prune;     // leaves and depth before / after
  QuantizationReport quantization;
  int conversions = 0;          // blobs built by the search
};

// Converts `forest` pruned as `budget` asks. Deterministic (same input, same N, same bytes). Throws
// ToolError naming `what` when the budget cannot be met: for BPC, when even every tree collapsed to
// its root exceeds it (that size is named); for OJR (votes do not merge), when the lossless blob
// exceeds it (the message names --structure-min-pixels at training), or when min_leaf_pixels is set.
BudgetedBlob convert_within_budget(const train::TrainedForest& forest, const ConvertOptions& options,
                                   const PruneBudget& budget, const std::string& what);

struct LeafCheck {
  uint64_t pixels = 0;      // pixel × tree evaluations compared
  uint64_t mismatches = 0;  // blob leaf record ≠ the trained forest's leaf
};

// Evaluates `frames` (depth mm, width × height each, focal length focal_px; 0 = no reading) with
// the trained forest's reference evaluator and with the blob's scalar and best runtime kernels, and
// counts leaf disagreements (each blob record maps back to one trained leaf).
LeafCheck check_leaves(const train::TrainedForest& forest, const std::vector<uint8_t>& blob_bytes,
                       const std::vector<std::vector<uint16_t>>& frames, int width, int height, float focal_px);

// Sample frames for check_leaves: tilted planes, discs and noisy blobs at 0.8–4 m, deterministic.
std::vector<std::vector<uint16_t>> sample_frames(int width, int height, int count);

}  // namespace dp::tools
