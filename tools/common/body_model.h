// The project's label contract, shared by synth, train, eval and the shipped blobs:
// 31 body parts and 16 joints, in this order (L/R = the subject's own side; U/W = upper/lower).
// docs/parts.md shows the parts on the body; docs/dataset_format.md uses these names.
#pragma once
#include <array>
#include <cstdint>

namespace dp::tools {

constexpr int kPartCount = 31;
constexpr int kJointCount = 16;
constexpr uint8_t kNotBodyLabel = 255;  // parts PNG value for pixels that are not body

constexpr std::array<const char*, kPartCount> kPartNames = {
    "head_lu", "head_ru", "head_lw", "head_rw", "neck", "shoulder_l", "shoulder_r", "arm_lu",
    "arm_ru", "arm_lw", "arm_rw", "elbow_l", "elbow_r", "wrist_l", "wrist_r", "hand_l",
    "hand_r", "torso_lu", "torso_ru", "torso_lw", "torso_rw", "leg_lu", "leg_ru", "leg_lw",
    "leg_rw", "knee_l", "knee_r", "ankle_l", "ankle_r", "foot_l", "foot_r"};

constexpr std::array<const char*, kJointCount> kJointNames = {
    "head", "neck", "shoulder_l", "shoulder_r", "elbow_l", "elbow_r", "wrist_l", "wrist_r",
    "hand_l", "hand_r", "knee_l", "knee_r", "ankle_l", "ankle_r", "foot_l", "foot_r"};

// Mirror partner of each part / joint (left <-> right; centre parts map to themselves).
constexpr std::array<uint8_t, kPartCount> kPartMirror = {1, 0, 3, 2, 4, 6, 5, 8, 7, 10, 9,
                                                         12, 11, 14, 13, 16, 15, 18, 17, 20, 19,
                                                         22, 21, 24, 23, 26, 25, 28, 27, 30, 29};
constexpr std::array<uint8_t, kJointCount> kJointMirror = {0, 1, 3, 2, 5, 4, 7, 6,
                                                           9, 8, 11, 10, 13, 12, 15, 14};

}  // namespace dp::tools
