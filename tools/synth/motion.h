// Motion-capture clips (Acclaim ASF/AMC and BVH) reduced to what retargeting needs: for every
// frame, the world-space rotation of each body segment relative to the clip's own rest pose, and
// each segment's rest direction.
//
// Segment names are the cmu_mb rig's bone names (Hips, LowerBack, Spine, Spine1, Neck, Neck1,
// Head, LeftShoulder, LeftArm, LeftForeArm, LeftHand, LeftFingerBase, LeftHandFinger1, LThumb,
// LHipJoint, LeftUpLeg, LeftLeg, LeftFoot, LeftToeBase and the Right mirror). ASF bone names
// (root, lfemur, ...) are mapped onto them; BVH skeletons are recognised by their joint names
// and mapped through skeleton_naming.h (MotionBuilder, DAZ, 3ds Max, MakeHuman). A segment named
// X spans from joint X to its child, so its rotation is the rotation of the bone X. A skeleton
// that lacks a joint the body needs is refused naming the missing joints, never rendered.
//
// Files: plain or gzip (read through zlib, which passes plain files through), LF or CRLF line
// ends, at most kMaxMocapFileBytes once decompressed. A motion file whose last line has no line
// break is taken as truncated and refused (a cut inside a number leaves a valid shorter number),
// unless the caller passes the frame count the clip index declares and the file has exactly
// that many complete frames (two CMU originals end without a line break).
//
// Coordinates: the source's world frame, which for CMU data is y up, the subject facing +z and
// the subject's left at +x, the same axes as the MakeHuman mesh. Root translation is not kept
// (the scene generator places the body itself).
//
// Errors: every parser throws dp::tools::ToolError "FILE:LINE: problem" on malformed input
// (unknown keyword, missing value, bad number, a row with the wrong number of channels, unknown
// bone in AMC, unbalanced braces), and "cannot open FILE" when a file is missing.
#pragma once
#include <string>
#include <vector>

#include "tools/synth/geometry.h"

namespace dp::synth {

// Largest decompressed mocap file we read (bytes): the biggest CMU clip is ~12 MB of text.
constexpr size_t kMaxMocapFileBytes = size_t(256) << 20;

// A whole text file in memory (plain or gzip-compressed).
struct MocapText {
  std::string path;
  std::string bytes;                // decompressed
  bool ends_with_line_break = false;
};
// Throws "cannot open PATH", "PATH: corrupt or truncated gzip data (...)", or "PATH: larger than
// ... bytes" (limit checked while reading, before growing further).
MocapText read_mocap_text(const std::string& path);

struct MotionClip {
  std::string name;                 // e.g. "02_01" (file stem)
  std::string skeleton;             // "cmu-asf" or the BVH naming ("motionbuilder", "daz", ...)
  double source_frame_rate = 120;   // frames per second of the source file
  int source_frame_count = 0;       // frames in the file (before stride sampling)
  int frame_stride = 1;             // frames kept: 0, stride, 2*stride, ...
  std::vector<std::string> segments;      // rig bone names present in the clip
  std::vector<Vec3> rest_directions;      // per segment, unit rest direction (0 if undefined)
  std::vector<std::vector<Mat3>> frames;  // frames[k][segment]: world rotation vs rest

  int segment_index(const std::string& rig_name) const;  // -1 when absent
};

// Reads an Acclaim skeleton and motion pair. `frame_stride` >= 1 keeps every stride-th frame.
// Every frame must list each bone the ASF gives degrees of freedom, once; a frame that lacks one
// (a truncated file) is refused naming the file, the frame number and the missing bones.
// expected_frames >= 0: the frame count the clip index declares (checked; see above).
MotionClip load_asf_amc(const std::string& asf_path, const std::string& amc_path, int frame_stride = 1,
                        long expected_frames = -1);
// Reads a BVH file (any rotation channel order per joint; position channels are used only for
// the root, which is not kept). The skeleton must match one of bvh_skeleton_namings().
MotionClip load_bvh(const std::string& path, int frame_stride = 1, long expected_frames = -1);

// The rig name for an ASF bone name ("lfemur" -> "LeftUpLeg"); empty when unknown.
std::string rig_name_for_asf_bone(const std::string& asf_name);

}  // namespace dp::synth
