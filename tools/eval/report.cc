#include "tools/eval/report.h"

#include <algorithm>
#include <string>

namespace dp::tools {
namespace {

nlohmann::json optional_number(const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(nullptr); }


std::string fmt_ap(const std::optional<double>& v) {
  if (!v) return "  n/a";
  char b[16];
  std::snprintf(b, sizeof b, "%5.3f", *v);
  return b;
}

nlohmann::json groups_to_json(const std::vector<GroupAccuracy>& groups, const std::vector<std::string>& joints) {
  nlohmann::json out = nlohmann::json::object();
  for (const GroupAccuracy& g : groups) {
    nlohmann::json per = nlohmann::json::object();
    for (size_t k = 0; k < joints.size(); ++k) per[joints[k]] = optional_number(g.ap[k]);
    out[g.name] = {{"frames", g.frames}, {"mAP", optional_number(g.mean_ap)}, {"per_joint_ap", per}};
  }
  return out;
}

// One row per group: frames, mAP, then the AP of every joint (columns in joint order).
void print_groups(const char* title, const std::vector<GroupAccuracy>& groups, const std::vector<std::string>& joints,
                  FILE* out) {
  if (groups.empty()) return;
  std::fprintf(out, "mAP per %s (%zu joint APs follow, in the order above):\n", title, joints.size());
  int width = 8;
  for (const GroupAccuracy& g : groups) width = std::max(width, int(g.name.size()));
  for (const GroupAccuracy& g : groups) {
    std::fprintf(out, "  %-*s %6ld frames  mAP %s  |", width, g.name.c_str(), g.frames, fmt_ap(g.mean_ap).c_str());
    for (const std::optional<double>& ap : g.ap) std::fprintf(out, " %s", fmt_ap(ap).c_str());
    std::fprintf(out, "\n");
  }
}

}  // namespace

nlohmann::json report_to_json(const EvalReport& r) {
  using nlohmann::json;
  json j;
  j["method"] = r.method;
  j["frames"] = r.frames;
  j["mAP"] = optional_number(r.mean_ap);
  j["d_tp"] = r.d_tp;
  j["d_tp_unit"] = r.d_tp_unit;
  j["silhouette"] = r.silhouette;
  j["penalize_occluded"] = r.penalize_occluded;
  j["ap_interpolation"] = "all-point (PASCAL VOC 2010+): sum over recall steps of the precision envelope";
  json per = json::object(), pos = json::object();
  for (size_t k = 0; k < r.joint_names.size(); ++k) {
    per[r.joint_names[k]] = optional_number(r.ap[k]);
    pos[r.joint_names[k]] = r.positives[k];
  }
  j["joints"] = r.joint_names;  // the blob's joint order (the per-joint objects below are keyed by name)
  j["per_joint_ap"] = per;
  j["positives"] = pos;
  json curve = json::array();
  for (size_t g = 0; g < r.dtp_grid.size(); ++g) {
    json aps = json::object();
    for (size_t k = 0; k < r.joint_names.size(); ++k) aps[r.joint_names[k]] = optional_number(r.ap_vs_dtp[g][k]);
    curve.push_back({{"d_tp", r.dtp_grid[g]}, {"mAP", optional_number(r.map_vs_dtp[g])}, {"per_joint_ap", aps}});
  }
  j["ap_vs_dtp"] = curve;
  // At d_tp, per motion category / mocap subject of the frames (null when frames.jsonl does not say).
  j["by_category"] = r.by_category.empty() ? json(nullptr) : groups_to_json(r.by_category, r.joint_names);
  j["by_subject"] = r.by_subject.empty() ? json(nullptr) : groups_to_json(r.by_subject, r.joint_names);
  j["class_accuracy"] = optional_number(r.class_accuracy);
  if (r.has_confusion) {
    json rows = json::array(), per_class = json::object();
    for (int t = 0; t < r.confusion.classes(); ++t) {
      json row = json::array();
      for (int p = 0; p < r.confusion.classes(); ++p) row.push_back(r.confusion.count(t, p));
      rows.push_back(row);
      per_class[r.part_names[size_t(t)]] =
          r.confusion.row_total(t) > 0 ? json(r.confusion.row_normalized(t, t)) : json(nullptr);
    }
    j["confusion"] = {{"parts", r.part_names}, {"counts", rows}, {"rows", "ground truth"}, {"columns", "most likely part"}};
    j["per_class_accuracy"] = per_class;
  } else {
    j["confusion"] = nullptr;
  }
  j["fps"] = r.fps;
  json stages = json::object();
  for (int s = 0; s < kStageCount; ++s) stages[stage_name(s)] = r.stage_ms[size_t(s)];
  j["speed"] = {{"fps", r.fps}, {"ms_per_frame", r.ms_per_frame}, {"stage_ms", stages}, {"kernel", r.kernel},
                {"mean_evaluated_pixels", r.mean_evaluated_pixels}};
  j["budget_override"] = r.budget.empty() ? json(nullptr) : json(r.budget);
  json flags = json::object();
  for (size_t b = 0; b < r.flag_frames.size(); ++b) flags[frame_flag_name(int32_t(b))] = r.flag_frames[b];
  j["flag_frames"] = flags;
  return j;
}

void print_report(const EvalReport& r, FILE* out) {
  std::fprintf(out, "%s blob, %ld frames%s; D_tp = %g %s%s\n", r.method.c_str(), r.frames,
               r.silhouette ? " (silhouette mode: depth flattened to 2 m)" : "", r.d_tp, r.d_tp_unit.c_str(),
               r.penalize_occluded ? ", occluded joints penalized" : "");
  if (!r.joint_names.empty()) {
    std::fprintf(out, "joint            AP     positives\n");
    for (size_t k = 0; k < r.joint_names.size(); ++k)
      std::fprintf(out, "  %-14s %s  %lld\n", r.joint_names[k].c_str(), fmt_ap(r.ap[k]).c_str(),
                   (long long)r.positives[k]);
  }
  std::fprintf(out, "mAP %s\n", fmt_ap(r.mean_ap).c_str());
  if (!r.dtp_grid.empty() && !r.joint_names.empty()) {
    std::fprintf(out, "mAP vs D_tp:");
    for (size_t g = 0; g < r.dtp_grid.size(); ++g)
      std::fprintf(out, " %g%s=%s", r.dtp_grid[g], r.d_tp_unit.c_str(), fmt_ap(r.map_vs_dtp[g]).c_str());
    std::fprintf(out, "\n");
  }
  print_groups("motion category", r.by_category, r.joint_names, out);
  print_groups("mocap subject", r.by_subject, r.joint_names, out);
  if (r.has_confusion) {
    std::fprintf(out, "per-class segmentation accuracy %s (mean diagonal of the row-normalized confusion matrix)\n",
                 fmt_ap(r.class_accuracy).c_str());
    std::fprintf(out, "confusion matrix, %% of each ground-truth row (columns: most likely part, same order):\n");
    for (int t = 0; t < r.confusion.classes(); ++t) {
      if (r.confusion.row_total(t) == 0) continue;
      std::fprintf(out, "  %-12s", r.part_names[size_t(t)].c_str());
      for (int p = 0; p < r.confusion.classes(); ++p)
        std::fprintf(out, " %3.0f", 100.0 * r.confusion.row_normalized(t, p));
      std::fprintf(out, "\n");
    }
  }
  if (!r.budget.empty()) std::fprintf(out, "budget override: %s\n", r.budget.c_str());
  std::fprintf(out, "speed: %.1f fps (%.3f ms/frame, kernel %s, %.0f evaluated pixels/frame);", r.fps, r.ms_per_frame,
               r.kernel.c_str(), r.mean_evaluated_pixels);
  for (int s = 0; s < kStageCount; ++s) std::fprintf(out, " %s %.3f ms", stage_name(s), r.stage_ms[size_t(s)]);
  std::fprintf(out, "\n");
  for (size_t b = 0; b < r.flag_frames.size(); ++b)
    if (r.flag_frames[b]) std::fprintf(out, "budget: %ld frames flagged %s\n", r.flag_frames[b], frame_flag_name(int32_t(b)));
}

}  // namespace dp::tools
