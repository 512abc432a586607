// Text and JSON renderings of an EvalReport (docs/evaluation.md lists the JSON keys).
#pragma once
#include <cstdio>
#include <nlohmann/json.hpp>

#include "tools/eval/evaluator.h"

namespace dp::tools {

// {"mAP", "per_joint_ap", "class_accuracy", "frames", "fps", ...}; undefined values are null.
nlohmann::json report_to_json(const EvalReport& report);
// Human-readable summary: per-joint AP, mAP, AP vs D_tp, class accuracy and confusion matrix, speed.
void print_report(const EvalReport& report, FILE* out);

}  // namespace dp::tools
