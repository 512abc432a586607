// `depthpose skeleton-eval`: measures the skeleton tracker (runtime/skeleton_tracker.h) on
// synthetic sequences with ground truth (`depthpose synth --sequence`, one or more people).
//
// Each body is cut out by its ground-truth mask (people/NNNNNN.png, or parts ≠ 255 for one
// body), so the figures measure the tracker and the forest, not the people finder. Per body and
// frame the pipeline's proposals feed one tracker per filter preset (off, default, strong).
// Figures (docs/skeleton.md): per joint, within-0.1 m rate of the first proposal and of the
// tracker's joint; left/right swaps per 1000 left/right joint-frames; the confidence's reliability
// (and a fitted calibration table); jitter of still joints and lag on fast motion per preset; the
// tracker's cost per user and frame.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "runtime/skeleton_tracker.h"

namespace dp::tools {

struct SkeletonEvalOptions {
  std::string blob_path;
  std::vector<std::string> datasets;  // each one sequence (frames in order)
  int max_frames = -1;                // per dataset, −1 = all
  // Extra filter settings measured besides the presets (--filter-sweep).
  std::vector<SkeletonFilterParams> sweep;
};

struct FilterFigures {
  SkeletonFilterParams params{};
  double jitter_mm = 0;     // RMS frame-to-frame motion of the output where the truth moved < 5 mm
  long still_samples = 0;
  double lag_frames = 0;    // shift s (0..8, parabola-refined) minimising mean |output(t) − truth(t − s)|, fast joints
  long fast_samples = 0;
  double within_rate = 0;   // all joints, reported position within 0.1 m
};

// One sequence's share of the counts (default filter): the unit the intervals resample, since the
// frames of a sequence, and often a whole sequence's swaps, come from the same few bodies.
struct SequenceFigures {
  long joint_frames = 0, proposal_hits = 0, tracker_hits = 0;  // all joints; hits within 0.1 m
  long proposal_swaps = 0, tracker_swaps = 0;                    // left/right joints
};

struct SkeletonEvalReport {
  long frames = 0, body_frames = 0;
  std::array<long, kSkeletonJoints> joint_frames{};
  std::array<long, kSkeletonJoints> proposal_hits{}, tracker_hits{};  // within 0.1 m
  // Swaps: a left/right joint within 0.1 m of its mirror joint's truth and not of its own; "nearer
  // mirror": off by more than 0.1 m and nearer the mirror's truth than its own.
  long lr_joint_frames = 0, proposal_swaps = 0, tracker_swaps = 0;
  long proposal_nearer_mirror = 0, tracker_nearer_mirror = 0;
  std::array<long, kSkeletonJoints> proposal_swaps_by_joint{}, tracker_swaps_by_joint{};
  // The same swaps among the left/right joint-frames whose truth is visible in the frame (the
  // dataset's flag: inside the image and not hidden behind a surface); the rest are hidden joints,
  // whose votes, when the forest casts any, can only come from other surfaces.
  long lr_visible_joint_frames = 0, proposal_swaps_visible = 0, tracker_swaps_visible = 0;
  // The tracker's swaps (default filter), per joint, by their SwapCause (below): by choice, and
  // how many had the facing crossed, the parent swapped, the pair crossed, the first proposal right.
  std::array<std::array<long, 4>, kSkeletonJoints> tracker_swap_choice{};
  std::array<long, kSkeletonJoints> tracker_swap_facing_flipped{}, tracker_swap_parent_swapped{};
  std::array<long, kSkeletonJoints> tracker_swap_pair_crossed{}, tracker_swap_first_right{};
  // Evidence classes of the tracker's confidence (skeleton_tracker.cc): count and hits.
  std::array<long, kEvidenceClasses> class_count{}, class_hits{};
  // Reliability: 10 confidence bins (of the reported confidence): count, Σ confidence, hits.
  std::array<long, 10> bin_count{}, bin_hits{};
  std::array<double, 10> bin_confidence_sum{};
  std::array<long, 3> state_count{};  // missing, inferred, tracked
  std::vector<FilterFigures> filters;  // off, default, strong, then the sweep
  std::vector<SequenceFigures> sequences;         // one per dataset, in --data order
  double tracker_cycles_per_user_frame = 0;
  double pipeline_cycles_per_user_frame = 0;
};

// What lies behind a tracker swap of left/right joint `joint` (skeleton-eval --swap-causes).
// Positions in metres, camera frame, indexed by SkeletonJoint; `out`/`located` the tracker's
// reported joints, `first` the joint's first proposal (when `has_first`).
enum class SwapChoice : int { kOwnFirst = 0, kOwnOther, kMirrorProposal, kPrediction };
struct SwapCause {
  SwapChoice choice;    // what the tracker took: its own first or other proposal, the mirror's, its last position
  bool facing_crossed;  // the tracker's facing (Skeleton::facing) points away from the true shoulders' facing
  bool parent_swapped;  // the parent is a left/right joint and is swapped too
  bool pair_crossed;    // the joint and its mirror lie in reverse order along the true shoulder_r → shoulder_l axis
  bool first_right;     // the first proposal was within 0.1 m of the truth: the tracker made this swap
};
using Position = std::array<double, 3>;
SwapCause swap_cause(int joint, const Skeleton& sk, const std::array<Position, kSkeletonJoints>& out,
                     const std::array<bool, kSkeletonJoints>& located, const std::array<Position, kSkeletonJoints>& truth,
                     bool has_first, const Position& first);

// Adds one scored body-frame of the default-filter tracker to `rep`: per joint the state, the
// confidence bin and evidence class, hits of the reported joint and of the first proposal
// (`proposals`), and for the left/right joints the swaps and the causes of the tracker's
// (swap_cause, read with every joint of `sk` placed). `truth` in metres, camera frame;
// `visible`: the truth's visibility flags (swaps of visible joints are also counted apart).
void add_frame_figures(const Skeleton& sk, const FrameResult& proposals, const std::array<Position, kSkeletonJoints>& truth,
                       const std::array<bool, kSkeletonJoints>& visible, SkeletonEvalReport* rep);

// 95 % percentile intervals over `resamples` bootstrap resamples of whole sequences (drawn with
// replacement, a fixed-seed generator, so the same counts give the same intervals) of: the gain of
// the tracker over the first proposal in the within-0.1 m rate (rate difference, all joints), and
// the relative change of the left/right swaps (tracker swaps / first-proposal swaps − 1). Also the
// point values over all sequences. A resample without first-proposal swaps counts as change 0.
struct SequenceIntervals {
  double gain = 0, gain_low = 0, gain_high = 0;
  double swap_change = 0, swap_change_low = 0, swap_change_high = 0;
};
constexpr int kIntervalResamples = 2000;  // enough for stable 2.5 / 97.5 percentiles
SequenceIntervals sequence_intervals(const std::vector<SequenceFigures>& sequences, int resamples = kIntervalResamples,
                                     uint64_t seed = 1);

// Throws ToolError for a missing/bad blob or dataset (naming it) or a blob whose joints are not the
// tracker's 16.
SkeletonEvalReport evaluate_skeletons(const SkeletonEvalOptions& options);

}  // namespace dp::tools
