// Left/right check on real frames without 3D ground truth (`depthpose side-check`).
//
// Real depth frames (the 12 Skeltrack Kinect frames in ../shared/data/skeltrack-frames) have no
// joint truth, but a person can mark, per front-facing person, where each arm's shoulder, elbow and
// hand are in the image. That is enough to say whether a tracker put its left joints on the
// person's left: a reported joint is on the correct side when its image projection is nearer the
// marked joint of its own side than the marked joint of the other side. The ruler is coarse on
// purpose (a few tens of pixels of marking error change nothing) and catches what matters on these
// frames: raised or crossed arms whose joints jump to the other arm.
//
// Convention: a front-facing person seen by an unmirrored camera (our synthetic camera, a Kinect
// read through libfreenect or OpenNI with mirroring off) has the left arm on the image's right.
// The truth file marks the person's own sides ("left" = the person's left).
//
// Truth file (JSON):
//   {"camera": {"width": 640, "height": 480, "fx": 525, "fy": 525, "cx": 319.5, "cy": 239.5},
//    "frames": [{"file": "depth-data-1028894671.raw",
//                "people": [{"head": [u, v],
//                            "left":  {"shoulder": [u, v], "elbow": [u, v], "hand": [u, v]},
//                            "right": {...}}]}, ...]}
// Pixel coordinates (u right, v down) in the frame's own resolution; a joint that cannot be seen
// may be left out of both sides (then it is not judged). People who are not front-facing or are
// mostly hidden are simply not listed.
#pragma once
#include <array>
#include <optional>
#include <string>
#include <vector>

namespace dp::tools {

// The arm joints judged, in the pipeline's joint names without the _l/_r suffix.
inline constexpr std::array<const char*, 3> kSideJoints = {"shoulder", "elbow", "hand"};

struct Pixel {
  double u = 0, v = 0;
};

struct PersonSides {
  Pixel head;
  // Per kSideJoints entry: the marked position of the person's left and right joint (both or none).
  std::array<std::optional<Pixel>, 3> left, right;
};

struct SideTruthFrame {
  std::string file;  // relative to the frames folder
  std::vector<PersonSides> people;
};

struct SideTruth {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pixels; camera x right, y up, z forward (metres)
  std::vector<SideTruthFrame> frames;
};

// Reads and checks a truth file; a ToolError names the file and the field that is wrong.
SideTruth load_side_truth(const std::string& path);

// One reported skeleton: per kSideJoints entry its left and right joint in camera metres (none
// when the tracker reported the joint missing), and the head.
struct ReportedSkeleton {
  std::optional<std::array<double, 3>> head;
  std::array<std::optional<std::array<double, 3>>, 3> left, right;
};

enum class SideOutcome { kCorrect, kSwapped, kMissing };

struct PersonVerdict {
  int skeleton = -1;                     // index of the matched reported skeleton, −1 = none
  std::array<SideOutcome, 3> left{}, right{};  // per kSideJoints entry (kMissing when not judged)
  int correct = 0, swapped = 0, missing = 0;   // over the joints the truth marks
};

struct FrameVerdict {
  std::vector<PersonVerdict> people;
  // Every marked person matched and no marked joint on the wrong side (a missing joint is not on
  // the wrong side; it is counted apart).
  bool sides_correct = false;
  int swapped = 0, missing = 0;
};

// Matches each marked person to the reported skeleton whose projected head is nearest its marked
// head (one-to-one, nearest pairs first, within `max_head_px`), then judges each marked joint.
FrameVerdict judge_sides(const SideTruth& camera, const SideTruthFrame& truth,
                         const std::vector<ReportedSkeleton>& skeletons, double max_head_px = 120.0);

// Projects camera metres (x right, y up, z forward) to pixels (u right, v down).
Pixel project(const SideTruth& camera, const std::array<double, 3>& p);

}  // namespace dp::tools
