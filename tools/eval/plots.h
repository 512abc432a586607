// PNG plots of an EvalReport, drawn with tools/eval/raster.h: recall–precision per joint, AP
// against D_tp, the confusion matrix, and example overlays (parts coloured, proposals as circles
// whose radius grows with confidence, ground truth as crosses).
#pragma once
#include <string>
#include <vector>

#include "tools/eval/evaluator.h"

namespace dp::tools {

// Creates `dir` if needed and writes the plots; returns the paths written. ToolError on failure.
std::vector<std::string> write_eval_plots(const EvalReport& report, const std::string& dir);

}  // namespace dp::tools
