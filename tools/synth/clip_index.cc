#include "tools/synth/clip_index.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "tools/common/error.h"

namespace dp::synth {
using dp::tools::fail;
namespace fs = std::filesystem;

namespace {

std::vector<std::string> split_tabs(const std::string& line) {
  std::vector<std::string> out;
  size_t start = 0;
  for (;;) {
    const size_t tab = line.find('\t', start);
    out.push_back(line.substr(start, tab == std::string::npos ? std::string::npos : tab - start));
    if (tab == std::string::npos) break;
    start = tab + 1;
  }
  return out;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// "…/NN_MM.amc.gz" -> "NN_MM"
std::string stem_of(const std::string& path) {
  std::string name = fs::path(path).filename().string();
  return name.substr(0, name.find('.'));
}

std::string existing_asf(const std::string& dir, const std::string& subject) {
  for (const char* ext : {".asf", ".asf.gz"}) {
    const std::string p = dir + "/" + subject + ext;
    if (fs::exists(p)) return p;
  }
  return dir + "/" + subject + ".asf";
}

bool is_amc(const std::string& p) { return ends_with(p, ".amc") || ends_with(p, ".amc.gz"); }
bool is_bvh(const std::string& p) { return ends_with(p, ".bvh") || ends_with(p, ".bvh.gz"); }

ClipEntry entry_for_file(const std::string& path) {
  ClipEntry e;
  e.id = stem_of(path);
  e.subject = e.id.substr(0, e.id.find('_'));
  e.path = path;
  if (is_amc(path)) {
    e.format = "asf/amc";
    e.asf_path = existing_asf(fs::path(path).parent_path().string(), e.subject);
  } else {
    e.format = "bvh";
  }
  return e;
}

std::vector<ClipEntry> scan(const std::string& mocap_dir) {
  std::vector<ClipEntry> out;
  for (const auto& f : fs::recursive_directory_iterator(mocap_dir)) {
    if (!f.is_regular_file()) continue;
    const std::string p = f.path().string();
    if (is_amc(p) || is_bvh(p)) out.push_back(entry_for_file(p));
  }
  return out;
}

}  // namespace

std::vector<ClipEntry> read_clip_index(const std::string& mocap_dir) {
  if (!fs::is_directory(mocap_dir)) fail("mocap directory " + mocap_dir + " does not exist (pass --assets ../shared/assets)");
  const std::string index = mocap_dir + "/clips.tsv";
  std::vector<ClipEntry> out;
  if (!fs::exists(index)) {
    out = scan(mocap_dir);
  } else {
    std::ifstream in(index);
    if (!in) fail("cannot open " + index);
    std::string line;
    int line_no = 0;
    std::map<std::string, size_t> column;
    const char* needed[] = {"cmu_id", "subject", "format", "frames", "path", "category", "description"};
    while (std::getline(in, line)) {
      ++line_no;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.empty()) continue;
      const std::vector<std::string> f = split_tabs(line);
      const std::string where = index + ":" + std::to_string(line_no) + ": ";
      if (column.empty()) {
        for (size_t i = 0; i < f.size(); ++i) column[f[i]] = i;
        for (const char* n : needed)
          if (!column.count(n)) fail(where + "header lacks column '" + n + "'");
        continue;
      }
      auto get = [&](const char* n) -> const std::string& {
        const size_t i = column.at(n);
        if (i >= f.size()) fail(where + "row has " + std::to_string(f.size()) + " fields, no '" + n + "'");
        return f[i];
      };
      ClipEntry e;
      e.id = get("cmu_id");
      e.subject = get("subject");
      e.format = get("format");
      e.category = get("category");
      e.description = get("description");
      char* end = nullptr;
      const std::string& frames = get("frames");
      e.frames = std::strtol(frames.c_str(), &end, 10);
      if (frames.empty() || *end || e.frames < 1) fail(where + "bad frame count '" + frames + "'");
      e.path = mocap_dir + "/" + get("path");
      if (e.format == "asf/amc") {
        e.asf_path = existing_asf(fs::path(e.path).parent_path().string(), e.subject);
      } else if (e.format.rfind("bvh", 0) != 0) {
        fail(where + "unknown format '" + e.format + "' (asf/amc, bvh-cmu31, bvh-daz43)");
      }
      out.push_back(std::move(e));
    }
    if (column.empty()) fail(index + ": empty");
  }
  std::sort(out.begin(), out.end(), [](const ClipEntry& a, const ClipEntry& b) { return a.id < b.id; });
  for (size_t i = 1; i < out.size(); ++i)
    if (out[i].id == out[i - 1].id) fail(mocap_dir + ": clip " + out[i].id + " listed twice");
  if (out.empty()) fail(mocap_dir + " holds no clips");
  return out;
}

std::vector<SplitRule> read_splits(const std::string& path) {
  std::ifstream in(path);
  if (!in) fail("cannot open splits file " + path + " (run from the repository root or pass --splits FILE)");
  std::vector<SplitRule> rules;
  std::string line;
  int line_no = 0;
  std::set<std::string> keys;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    const std::vector<std::string> f = split_tabs(line);
    const std::string where = path + ":" + std::to_string(line_no) + ": ";
    if (f.size() < 2) fail(where + "expected KEY<TAB>SPLIT<TAB>reason");
    if (f[1] != "train" && f[1] != "validation" && f[1] != "test")
      fail(where + "split '" + f[1] + "' is not train, validation or test");
    if (!keys.insert(f[0]).second) fail(where + "key '" + f[0] + "' listed twice");
    rules.push_back({f[0], f[1], f.size() > 2 ? f[2] : ""});
  }
  return rules;
}

void assign_splits(const std::vector<SplitRule>& rules, std::vector<ClipEntry>& clips) {
  std::map<std::string, std::string> by_key;
  for (const SplitRule& r : rules) by_key[r.key] = r.split;
  for (ClipEntry& c : clips) {
    auto it = by_key.find(c.id);
    if (it == by_key.end()) it = by_key.find(c.subject);
    if (it == by_key.end()) it = by_key.find("*");
    if (it == by_key.end()) fail("no split rule covers clip " + c.id + " (add its subject or '*')");
    c.split = it->second;
  }
}

std::vector<ClipEntry> select_clips(const std::string& mocap_dir, const std::vector<std::string>& selection,
                                    const std::string& splits_path) {
  std::vector<ClipEntry> index;
  bool have_index = false, have_splits = false;
  auto need_index = [&]() {
    if (!have_index) index = read_clip_index(mocap_dir);
    have_index = true;
  };
  auto need_splits = [&]() {
    need_index();
    if (!have_splits) assign_splits(read_splits(splits_path), index);
    have_splits = true;
  };
  std::vector<ClipEntry> out;
  std::set<std::string> taken;
  auto take = [&](const ClipEntry& e) {
    if (taken.insert(e.path).second) out.push_back(e);
  };
  for (const std::string& item : selection) {
    if (is_amc(item) || is_bvh(item)) {
      if (!fs::exists(item)) fail("clip file " + item + " does not exist");
      take(entry_for_file(item));
      continue;
    }
    need_index();
    size_t before = out.size();
    if (item == "all") {
      for (const ClipEntry& e : index) take(e);
    } else if (item.rfind("split:", 0) == 0) {
      need_splits();
      const std::string name = item.substr(6);
      if (name != "train" && name != "validation" && name != "test")
        fail("--clips " + item + ": split must be train, validation or test");
      for (const ClipEntry& e : index)
        if (e.split == name) take(e);
    } else {
      for (const ClipEntry& e : index)
        if (e.id == item || e.subject == item) take(e);
    }
    if (out.size() == before && item != "all" && item.rfind("split:", 0) != 0)
      fail("unknown clip '" + item + "': no clip or subject of that name in " + mocap_dir +
           " (clips.tsv ids like 02_01, subjects like 02, all, split:train|validation|test, or a .bvh/.amc path)");
  }
  if (have_splits) {
    // Keep the split on clips selected by other means too (reporting).
    std::map<std::string, std::string> split_of;
    for (const ClipEntry& e : index) split_of[e.path] = e.split;
    for (ClipEntry& e : out)
      if (split_of.count(e.path)) e.split = split_of[e.path];
  }
  return out;
}

MotionClip load_clip(const ClipEntry& e, int frame_stride) {
  if (e.format == "asf/amc") return load_asf_amc(e.asf_path, e.path, frame_stride, e.frames);
  return load_bvh(e.path, frame_stride, e.frames);
}

}  // namespace dp::synth
