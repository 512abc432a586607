// Trained forest (tools/train/forest_file.h, full precision) → forest blob v1 (fixed point).
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
//   Blob depth = the deepest trained leaf's level (≥ 1). A leaf above that depth is padded: its
//   subtree's nodes get threshold kPadThreshold with zero offsets (always left) and all its leaf
//   slots point at its record, so the padded traversal ends on that record.
// Output is byte-identical for identical input.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "forest_blob/blob_writer.h"
#include "tools/train/forest_file.h"

namespace dp::tools {

struct ConvertOptions {
  uint32_t max_width = 640, max_height = 480;  // frame size the arena is sized for
};

struct QuantizationReport {
  double worst_probability_error = 0;    // max |q/32768 − p| over all BPC leaf entries
  double worst_vote_offset_error_mm = 0; // max |q − 1000·d| over unclamped vote components
  double worst_vote_weight_rel_error = 0;// max |q/scale − w| / w over nonzero weights
  uint64_t clamped_vote_components = 0;  // |offset| > kMaxVoteOffsetMm
  uint64_t dropped_votes = 0;            // beyond kMaxVotesPerLeafJoint per leaf/joint
  uint64_t padded_nodes = 0;             // nodes added below early leaves
  int blob_depth = 0;
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
