#include "runtime/segmentation/segmenter_config.h"

namespace dp {

double segmenter_config_value(const SegmenterConfig& c, int32_t index) {
  switch (index) {
#define DP_SEGMENTER_CONFIG_GET(type, name, def, lo, hi, range, unit, meaning) \
  case segmenter_config_detail::k_##name:                                       \
    return double(c.name);
    DP_SEGMENTER_CONFIG_FIELDS(DP_SEGMENTER_CONFIG_GET)
#undef DP_SEGMENTER_CONFIG_GET
    default:
      return 0.0;
  }
}

bool segmenter_config_in_range(int32_t index, double v) {
  if (index < 0 || index >= kSegmenterConfigFieldCount) return false;
  const SegmenterConfigField& f = kSegmenterConfigFields[index];
  const bool above = f.range == kRangeOpenMin || f.range == kRangeOpen ? v > f.min : v >= f.min;
  const bool below = f.range == kRangeOpenMax || f.range == kRangeOpen ? v < f.max : v <= f.max;
  return above && below;  // false for NaN
}

bool segmenter_config_constraint_holds(const SegmenterConfig& c, int32_t index) {
  if (index < 0 || index >= kSegmenterConfigConstraintCount) return false;
  const SegmenterConfigConstraint& k = kSegmenterConfigConstraints[index];
  const double a = segmenter_config_value(c, k.field), b = segmenter_config_value(c, k.other);
  switch (k.relation) {
    case kRelationGreater: return a > b;
    case kRelationGreaterEqual: return a >= b;
    case kRelationLessEqual: return a <= b;
  }
  return false;
}

bool segmenter_config_check(const SegmenterConfig& c, int32_t* bad_field) {
  for (int32_t i = 0; i < kSegmenterConfigFieldCount; ++i)
    if (!segmenter_config_in_range(i, segmenter_config_value(c, i))) {
      if (bad_field) *bad_field = i;
      return false;
    }
  for (int32_t k = 0; k < kSegmenterConfigConstraintCount; ++k)
    if (!segmenter_config_constraint_holds(c, k)) {
      if (bad_field) *bad_field = -1 - k;
      return false;
    }
  return true;
}

}  // namespace dp
