// Import of the Point Cloud Library's published people-detector trees (ASCII, bzip2) into a BPC
// blob. Format facts: ../shared/data/README.md; the semantic differences are in docs/convert.md.
//
// A PCL tree file holds its height H, then 2^H − 1 lines `du1 dv1 du2 dv2 thresh` in implicit heap
// order, then 2^H leaf labels (argmax part, 0..24). Offsets are pixels at 1 m for a 525 px
// camera, thresholds millimetres, "go right iff d1 − d2 > thresh": the same units and the same
// branch rule as the blob, so nodes are copied unchanged. Differences from PCL kept deliberately:
//   - probes off the image read the background constant (our rule) where PCL clamps to the border;
//   - the probe scale is the integer rule of runtime/fixed_point.h, PCL uses float 1000/z.
// Each leaf label becomes a one-hot Q15 distribution (32768 on that part), one record per label
// that occurs (in label order; all 25 for PCL's trees, where record = label), shared by all trees,
// so averaging trees gives PCL's vote fractions.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "forest_blob/blob_format.h"
#include "forest_blob/blob_writer.h"

namespace dp::tools {

constexpr int kPclPartCount = 25;
extern const char* const kPclPartNames[kPclPartCount];

struct PclTree {
  int depth = 0;                       // H
  std::vector<blob::TreeNode> nodes;   // 2^H − 1, heap order
  std::vector<uint8_t> leaf_labels;    // 2^H, each < kPclPartCount
};

// Reads one bzip2-compressed PCL tree file. Throws ToolError naming the file and the problem
// (unreadable, bad bzip2 stream, bad height, short file, value out of range, trailing data).
PclTree read_pcl_tree(const std::string& bz2_path);

// Builds a BPC blob from 1..kMaxTrees PCL trees of equal depth: PCL's 25 part names, one-hot
// leaves, reference focal 525 px, joints mapped from PCL parts (pcl_joint_parts), defaults for the
// rest of the runtime config. Throws ToolError when the trees disagree in depth.
blob::BlobContents pcl_blob_contents(const std::vector<PclTree>& trees);

// The PCL part mask used for each of our 16 joints (tools/common/body_model.h order).
uint32_t pcl_joint_parts(int joint);

}  // namespace dp::tools
