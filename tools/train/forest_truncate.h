// Cutting a trained structure back to a smaller depth, so OJR vote leaves can be retro-fitted at a
// depth whose leaf table fits the size budget while reusing a deeper classification structure.
#pragma once
#include "tools/train/forest_file.h"

namespace dp::train {

// Returns `forest` with every split node at level `depth` turned into a leaf and all deeper nodes
// dropped. Leaf records are renumbered in heap order and carry no leaf data (pixel counts zero, no
// distributions, no votes): the result is a structure for retro-fitting. Throws ToolError when
// depth < 1. A depth at or beyond the forest's own returns the structure unchanged (data dropped).
TrainedForest truncate_structure(const TrainedForest& forest, int depth);

}  // namespace dp::train
