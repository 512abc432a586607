// The mocap clip index (assets/mocap/clips.tsv), the held-out splits (tools/synth/splits.tsv) and
// clip selection for `synth --clips`.
//
// clips.tsv: a header row naming at least the columns cmu_id, subject, format, frames,
// fps_in_header, path, category, description (any order; more columns are ignored), then one row
// per clip. format is "asf/amc" (the subject's skeleton NN.asf or NN.asf.gz sits beside the .amc),
// "bvh-cmu31" or "bvh-daz43"; path is relative to the mocap directory. Without clips.tsv the
// mocap directory is scanned (every *.amc[.gz] with its NN.asf[.gz], every *.bvh[.gz]).
//
// splits.tsv: rows "KEY<TAB>SPLIT<TAB>reason", KEY a subject ("94"), a clip ("105_13") or "*"
// (everything else); a clip row overrides its subject's row, a subject row overrides "*".
// SPLIT is train, validation or test. docs/synthetic_data.md explains the choice.
//
// Errors throw dp::tools::ToolError naming the file, the line and the field.
#pragma once
#include <string>
#include <vector>

#include "tools/synth/motion.h"

namespace dp::synth {

struct ClipEntry {
  std::string id;           // "02_01"
  std::string subject;      // "02"
  std::string format;       // "asf/amc", "bvh-cmu31", "bvh-daz43", "bvh" (scanned)
  long frames = -1;         // frames the index declares (-1 = unknown, scanned)
  std::string path;         // motion file, full path
  std::string asf_path;     // skeleton for asf/amc clips, full path
  std::string category;     // CMU category ("" when scanned)
  std::string description;
  std::string split;        // train / validation / test ("" until assign_splits)
};

// Reads mocap_dir/clips.tsv when present, otherwise scans mocap_dir. Sorted by id.
std::vector<ClipEntry> read_clip_index(const std::string& mocap_dir);

struct SplitRule {
  std::string key, split, reason;
};
std::vector<SplitRule> read_splits(const std::string& splits_path);
// Sets entry.split for every clip from the rules (throws when no rule covers a clip).
void assign_splits(const std::vector<SplitRule>& rules, std::vector<ClipEntry>& clips);

// The default splits file, relative to the repository root (the CLI's working directory).
constexpr const char* kDefaultSplitsPath = "tools/synth/splits.tsv";

// Resolves a --clips list against the index: "all", "split:NAME" (needs splits_path), a subject
// ("02", "105"), a clip id ("02_01"), or a path to a .bvh/.amc file (plain or .gz; an .amc takes
// the NN.asf beside it). Duplicates are dropped; order follows the list, then the index.
std::vector<ClipEntry> select_clips(const std::string& mocap_dir, const std::vector<std::string>& selection,
                                    const std::string& splits_path);

// Loads one clip (any format), checking the frame count the index declares.
MotionClip load_clip(const ClipEntry& entry, int frame_stride);

}  // namespace dp::synth
