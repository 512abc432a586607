// A 64-bit digest of everything dp::Segmenter::process() reports for one frame, for regression
// checks (tests/segmentation_golden_test.cc, `depthpose segeval --digest`): two runs whose digests
// agree produced the same label image and the same result fields.
#pragma once
#include <cstdint>

#include "runtime/segmentation/segmenter.h"

namespace dp::tools {

// Covers the labels (width × height, read with `stride_px`), user_count, all kMaxUsers UserInfo
// slots field by field, the floor plane, candidate_pixels, user_pixels, component_count and flags:
// every output of process() except the cycle counts (timing). FNV-1a over a fixed byte order.
uint64_t segmentation_digest(const SegmentationResult& result, int32_t width, int32_t height, int32_t stride_px);

}  // namespace dp::tools
