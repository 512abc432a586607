// `depthpose reid-eval`: measures the people finder's ids across leaving and re-entering
// (runtime/segmentation/users.h, "Re-identification") on synthetic sequences with two or more
// people (`depthpose synth --sequence --people N`), whose ground-truth masks (people/NNNNNN.png)
// let a person be taken out of view: their pixels become "no reading".
//
// Per sequence, two runs of the live segmenter (background model on, as for a fixed camera):
//   return     person 1 is in view for frames [0, leave), out of view for `gap` frames, then back;
//              the others are in view throughout. Outcome on the last frame it is found in the
//              kFindFrames (30) frames after coming back (a person lost again there and found
//              under another id counts with the later id): its own id back (`same`), a fresh id (`new`) or an id
//              someone else held before (`other`); `unseen` when it is not found.
//   newcomer   person 1 is in view for [0, leave) and gone from then on; person 2 stays out of view
//              until leave + gap, then enters: a different body. Outcome for person 2 (as above):
//              `new` (a fresh id), `false` (person 1's id: a false re-identification), `other`, `unseen`.
// A person "has" the id that labels most of its visible pixels.
#pragma once
#include <string>
#include <vector>

namespace dp::tools {

struct ReidEvalOptions {
  std::vector<std::string> datasets;
  int leave_frame = 30;  // frames person 1 is seen before leaving (≥ 1)
  int gap_frames = 60;   // frames out of view (≥ 1)
  bool reid = true;      // false: reid_window_frames = 0 (ids as before re-identification)
};

enum ReidOutcome : int { kReidSame = 0, kReidNew, kReidOther, kReidFalse, kReidUnseen, kReidOutcomes };
const char* reid_outcome_name(int outcome);  // "same", "new", "other", "false", "unseen"

struct ReidSequenceResult {
  std::string dataset;
  int return_outcome = kReidUnseen;
  int newcomer_outcome = kReidUnseen;
  // The people finder's heights (UserInfo::top_height_m): person 1's median while first in view and
  // when it is found again, person 2's when it enters in the newcomer run (0 when not found).
  double person1_height_m = 0, person1_back_height_m = 0, person2_height_m = 0;
};

// Throws ToolError naming a dataset that is missing, has fewer than two people, or is shorter than
// leave + gap + 1 frames.
std::vector<ReidSequenceResult> evaluate_reid(const ReidEvalOptions& options);

}  // namespace dp::tools
