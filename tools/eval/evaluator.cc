#include "tools/eval/evaluator.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "tools/common/args.h"
#include "tools/common/body_model.h"
#include "tools/common/error.h"
#include "tools/info/info.h"
#include "tools/common/blob_error.h"

namespace dp::tools {

NameMap parse_name_map(const std::string& text_or_file, const std::string& option) {
  std::string text = text_or_file;
  if (!text.empty() && text[0] == '@') {
    std::ifstream f(text.substr(1));
    if (!f) fail(option + ": cannot read " + text.substr(1));
    std::stringstream ss;
    ss << f.rdbuf();
    text = ss.str();
    for (char& ch : text)
      if (ch == '\n' || ch == '\r' || ch == ' ' || ch == '\t') ch = ',';
  }
  NameMap map;
  for (const std::string& piece : split_list(text)) {
    const size_t eq = piece.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == piece.size())
      fail(option + ": '" + piece + "' is not DATASET_NAME=BLOB_NAME");
    map.emplace_back(piece.substr(0, eq), piece.substr(eq + 1));
  }
  return map;
}

namespace {

std::string fixed_name(const char (&raw)[blob::kNameBytes]) { return std::string(raw, strnlen(raw, blob::kNameBytes)); }

std::string join(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : ", ") + n;
  return s.empty() ? "(none)" : s;
}

// Dataset names after applying the map; refuses map entries that name nothing.
std::vector<std::string> renamed(const std::vector<std::string>& names, const NameMap& map, const std::string& option,
                                 const std::string& dataset_dir) {
  std::vector<std::string> out = names;
  for (const auto& [from, to] : map) {
    auto it = std::find(names.begin(), names.end(), from);
    if (it == names.end())
      fail(option + " names '" + from + "', which dataset " + dataset_dir + " does not have (it has: " + join(names) + ")");
    out[size_t(it - names.begin())] = to;
  }
  return out;
}

int argmax_part(const Pipeline& p, int32_t pixel, int parts) {
  uint16_t prob[blob::kMaxParts];
  p.part_distribution(pixel, prob);
  int best = 0;
  for (int c = 1; c < parts; ++c)
    if (prob[c] > prob[best]) best = c;
  return best;
}

}  // namespace


struct EvalSession::PreparedFrame {
  std::vector<uint16_t> depth;
  std::vector<uint8_t> mask;    // empty: the runtime's depth band decides
  std::vector<uint8_t> labels;  // empty: no parts image
};

EvalSession::EvalSession(std::vector<uint8_t> bytes, std::string blob_label, const std::string& dataset_dir,
                         const EvalOptions& options)
    : bytes_(std::move(bytes)), blob_label_(std::move(blob_label)), options_(options) {
  blob_ = load_blob_or_fail(bytes_, blob_label_);
  dataset_ = open_dataset(dataset_dir);
  frame_count_ = long(dataset_.frames.size());
  if (options_.max_frames > 0) frame_count_ = std::min(frame_count_, options_.max_frames);
  if (frame_count_ == 0) fail("dataset " + dataset_dir + " has no frames");

  // Joints: every blob joint must be found in the dataset (after --map-joints).
  const blob::ForestMeta& m = *blob_.meta;
  if (!dataset_.meta.joints.empty()) {
    const std::vector<std::string> ds = renamed(dataset_.meta.joints, options_.joint_map, "--map-joints", dataset_dir);
    std::vector<std::string> missing, blob_names;
    for (int j = 0; j < m.joint_count; ++j) {
      const std::string name = fixed_name(m.joint_names[j]);
      blob_names.push_back(name);
      auto it = std::find(ds.begin(), ds.end(), name);
      if (it == ds.end()) {
        missing.push_back(name);
        continue;
      }
      eval_joints_.push_back(j);
      dataset_joint_.push_back(int(it - ds.begin()));
    }
    if (!missing.empty() && options_.joint_map.empty())
      fail("dataset " + dataset_dir + " has no joint named " + join(missing) + " (blob " + blob_label_ + " joints: " +
           join(blob_names) + "; dataset joints: " + join(dataset_.meta.joints) +
           "); give --map-joints DATASET_NAME=BLOB_NAME,... to evaluate across naming schemes");
  }
  // Parts (BPC with a labelled dataset): every dataset part must be a blob part (after --map-parts).
  if (blob_.method() == blob::Method::kBpc && dataset_.has_parts && !dataset_.meta.parts.empty()) {
    const std::vector<std::string> ds = renamed(dataset_.meta.parts, options_.part_map, "--map-parts", dataset_dir);
    std::vector<std::string> blob_names, unmatched;
    for (int c = 0; c < m.part_count; ++c) blob_names.push_back(fixed_name(m.part_names[c]));
    for (const std::string& name : ds) {
      auto it = std::find(blob_names.begin(), blob_names.end(), name);
      blob_part_of_label_.push_back(it == blob_names.end() ? -1 : int(it - blob_names.begin()));
      if (it == blob_names.end()) unmatched.push_back(name);
    }
    if (!unmatched.empty() && options_.part_map.empty())
      fail("blob " + blob_label_ + " has no part named " + join(unmatched) + " (blob parts: " + join(blob_names) +
           "); give --map-parts DATASET_NAME=BLOB_NAME,... to evaluate across naming schemes");
  }

  const int w = dataset_.meta.width, h = dataset_.meta.height;
  arena_bytes_ = required_arena_bytes(blob_, w, h);
  if (arena_bytes_ == 0)
    fail("dataset " + dataset_dir + ": frame size " + std::to_string(w) + "x" + std::to_string(h) +
         " is outside what the runtime accepts");
  arena_ = platform::ArenaMemory(arena_bytes_);
  if (Status s = pipeline_.init(blob_, w, h, arena_.data(), arena_bytes_); s != Status::kOk)
    fail(blob_label_ + ": runtime init: " + status_message(s));
  if (Status s = pipeline_.set_kernel(options_.kernel); s != Status::kOk)
    fail(std::string("--kernel ") + kernel_isa_name(options_.kernel) + ": " + status_message(s));
}

EvalSession::~EvalSession() = default;

std::unique_ptr<EvalSession> open_eval_session(const std::string& blob_path, const std::string& dataset_dir,
                                               const EvalOptions& options) {
  std::vector<uint8_t> bytes;
  load_blob_file_checked(blob_path, bytes);
  return std::make_unique<EvalSession>(std::move(bytes), blob_path, dataset_dir, options);
}

EvalSession::PreparedFrame EvalSession::prepare(long i) const {
  PreparedFrame f;
  f.depth = dataset_.load_depth(size_t(i)).pixels;
  if (dataset_.has_parts) {
    f.labels = dataset_.load_parts(size_t(i)).pixels;
    f.mask.resize(f.labels.size());
    for (size_t p = 0; p < f.labels.size(); ++p) f.mask[p] = f.labels[p] != kNotBodyLabel;
  }
  if (options_.silhouette) {
    const blob::RuntimeConfig& c = pipeline_.config();
    for (size_t p = 0; p < f.depth.size(); ++p) {
      const uint16_t z = f.depth[p];
      const bool fg = f.mask.empty() ? (z >= c.near_mm && z <= c.far_mm) : (f.mask[p] != 0 && z != 0);
      f.depth[p] = fg ? kSilhouetteDepthMm : 0;
    }
  }
  return f;
}

MatchOptions EvalSession::match_options(double d_tp) const {
  return MatchOptions{float(d_tp), options_.penalize_occluded};
}

JointSamples::Truth EvalSession::truth_of(long frame, int k) const {
  const JointTruth& t = dataset_.frames[size_t(frame)].joints[size_t(dataset_joint_[size_t(k)])];
  Point3 p{t.x, t.y, t.z};
  if (options_.silhouette) p = project_to_pixels(p, dataset_.meta.fx, dataset_.meta.fy, dataset_.meta.cx, dataset_.meta.cy);
  return JointSamples::Truth{p, t.visible};
}

ScoredPoint EvalSession::to_metric_space(const JointProposal& q) const {
  Point3 p{q.x_m, q.y_m, q.z_m};
  if (options_.silhouette) p = project_to_pixels(p, dataset_.meta.fx, dataset_.meta.fy, dataset_.meta.cx, dataset_.meta.cy);
  return ScoredPoint{p, q.confidence};
}

std::vector<JointSamples> EvalSession::empty_samples() const {
  std::vector<JointSamples> s(eval_joints_.size());
  for (JointSamples& j : s) {
    j.truth.reserve(size_t(frame_count_));
    j.proposals.reserve(size_t(frame_count_));
  }
  return s;
}

void EvalSession::collect(long frame, const FrameResult& r, std::vector<JointSamples>& samples) const {
  for (size_t k = 0; k < eval_joints_.size(); ++k) {
    const int j = eval_joints_[k];
    samples[k].truth.push_back(truth_of(frame, int(k)));
    std::vector<ScoredPoint> props;
    for (int q = 0; q < r.proposal_count[j]; ++q) props.push_back(to_metric_space(r.proposals[j][q]));
    samples[k].proposals.push_back(std::move(props));
  }
}

EvalReport EvalSession::evaluate(const blob::RuntimeConfig* config) {
  const blob::RuntimeConfig effective =
      config ? *config : with_budget(*blob_.config, options_.budget, blob_.config->max_evaluated_pixels);
  if (Status s = pipeline_.set_config(effective); s != Status::kOk)
    fail(blob_label_ + ": runtime config refused: " + status_message(s));
  const blob::ForestMeta& m = *blob_.meta;
  const bool bpc = blob_.method() == blob::Method::kBpc;
  EvalReport rep;
  rep.method = bpc ? "BPC" : "OJR";
  rep.frames = frame_count_;
  rep.silhouette = options_.silhouette;
  rep.penalize_occluded = options_.penalize_occluded;
  rep.d_tp = options_.silhouette ? options_.d_tp_px : options_.d_tp_m;
  rep.d_tp_unit = options_.silhouette ? "px" : "m";
  if (!config) rep.budget = describe_budget(options_.budget);
  rep.kernel = kernel_isa_name(pipeline_.kernel());
  for (int j : eval_joints_) rep.joint_names.push_back(fixed_name(m.joint_names[j]));
  rep.has_confusion = bpc && !blob_part_of_label_.empty();
  if (rep.has_confusion) {
    for (int c = 0; c < m.part_count; ++c) rep.part_names.push_back(fixed_name(m.part_names[c]));
    rep.confusion = ConfusionMatrix(m.part_count);
  }

  std::vector<long> overlay_ids;
  const int k_overlays = std::max(0, std::min<int>(options_.overlay_frames, int(frame_count_)));
  for (int k = 0; k < k_overlays; ++k)
    overlay_ids.push_back(k_overlays == 1 ? 0 : long(k) * (frame_count_ - 1) / (k_overlays - 1));

  std::vector<JointSamples> samples = empty_samples();
  const int w = dataset_.meta.width, h = dataset_.meta.height;
  const CameraIntrinsics intr{float(dataset_.meta.fx), float(dataset_.meta.fy), float(dataset_.meta.cx),
                              float(dataset_.meta.cy)};
  double wall_s = 0, pixels = 0;
  uint64_t cycles_total = 0;
  std::array<uint64_t, kStageCount> stage_cycles{};
  FrameResult r;
  for (long i = 0; i < frame_count_; ++i) {
    const PreparedFrame pf = prepare(i);
    const DepthFrame frame{pf.depth.data(), w, h, w, intr, pf.mask.empty() ? nullptr : pf.mask.data()};
    const auto t0 = std::chrono::steady_clock::now();
    const Status s = pipeline_.process(frame, &r);
    const auto t1 = std::chrono::steady_clock::now();
    if (s != Status::kOk) fail(dataset_.depth_path(size_t(i)) + ": runtime refused the frame: " + status_message(s));
    wall_s += std::chrono::duration<double>(t1 - t0).count();
    cycles_total += r.total_cycles;
    for (int st = 0; st < kStageCount; ++st) stage_cycles[size_t(st)] += r.stage_cycles[st];
    for (size_t b = 0; b < rep.flag_frames.size(); ++b) rep.flag_frames[b] += (r.flags >> b) & 1u;
    pixels += r.evaluated_pixels;
    collect(i, r, samples);

    const int n = pipeline_.evaluated_pixel_count();
    const EvaluatedPixel* px = pipeline_.evaluated_pixels();
    if (rep.has_confusion && !pf.labels.empty()) {
      for (int32_t p = 0; p < n; ++p) {
        const uint8_t label = pf.labels[size_t(px[p].v) * w + px[p].u];
        const int truth = label < blob_part_of_label_.size() ? blob_part_of_label_[label] : -1;
        if (truth >= 0) rep.confusion.add(truth, argmax_part(pipeline_, p, m.part_count));
      }
    }
    if (std::find(overlay_ids.begin(), overlay_ids.end(), i) != overlay_ids.end() &&
        (rep.overlays.empty() || rep.overlays.back().id != dataset_.frames[size_t(i)].id)) {
      OverlayFrame o;
      o.id = dataset_.frames[size_t(i)].id;
      o.width = w;
      o.height = h;
      o.depth_mm = pf.depth;
      o.part.assign(size_t(w) * h, -1);
      o.part_is_prediction = bpc;
      if (bpc) {
        for (int32_t p = 0; p < n; ++p) o.part[size_t(px[p].v) * w + px[p].u] = int16_t(argmax_part(pipeline_, p, m.part_count));
      } else if (!pf.labels.empty()) {
        for (size_t p = 0; p < pf.labels.size(); ++p)
          if (pf.labels[p] != kNotBodyLabel) o.part[p] = pf.labels[p];
      }
      for (size_t k = 0; k < eval_joints_.size(); ++k) {
        const int j = eval_joints_[k];
        std::vector<ScoredPoint> props;
        for (int q = 0; q < r.proposal_count[j]; ++q) {
          const JointProposal& jp = r.proposals[j][q];
          props.push_back(ScoredPoint{project_to_pixels(Point3{jp.x_m, jp.y_m, jp.z_m}, intr.fx, intr.fy, intr.cx, intr.cy),
                                      jp.confidence});
        }
        o.proposals.push_back(std::move(props));
        const JointTruth& t = dataset_.frames[size_t(i)].joints[size_t(dataset_joint_[k])];
        o.truth.push_back(JointSamples::Truth{project_to_pixels(Point3{t.x, t.y, t.z}, intr.fx, intr.fy, intr.cx, intr.cy),
                                              t.visible});
      }
      rep.overlays.push_back(std::move(o));
    }
  }

  // Joint accuracy at D_tp and against D_tp.
  for (size_t k = 0; k < eval_joints_.size(); ++k) {
    const JointMatches mt = match_joint(samples[k], match_options(rep.d_tp));
    rep.ap.push_back(average_precision(mt));
    rep.curves.push_back(pr_curve(mt));
    rep.positives.push_back(mt.positives);
  }
  rep.mean_ap = mean_average_precision(rep.ap);
  const double step = options_.silhouette ? 2.0 : 0.02;
  for (int g = 1; g <= 10; ++g) {
    const double d = step * g;
    rep.dtp_grid.push_back(d);
    std::vector<std::optional<double>> aps;
    for (size_t k = 0; k < eval_joints_.size(); ++k) aps.push_back(average_precision(match_joint(samples[k], match_options(d))));
    rep.map_vs_dtp.push_back(mean_average_precision(aps));
    rep.ap_vs_dtp.push_back(std::move(aps));
  }
  for (auto [key, out] : {std::pair{FrameGroupKey::kCategory, &rep.by_category}, std::pair{FrameGroupKey::kSubject, &rep.by_subject}}) {
    const std::vector<std::string> groups = frame_groups(dataset_, frame_count_, key);
    if (!groups.empty() && !eval_joints_.empty()) *out = accuracy_by_group(samples, groups, match_options(rep.d_tp));
  }
  if (rep.has_confusion) rep.class_accuracy = rep.confusion.class_accuracy();

  rep.mean_evaluated_pixels = pixels / double(frame_count_);
  if (wall_s > 0) {
    rep.fps = double(frame_count_) / wall_s;
    rep.ms_per_frame = 1000.0 * wall_s / double(frame_count_);
    // Stage cycles (TSC) converted to time with the rate observed over the whole run.
    if (cycles_total > 0) {
      const double cycles_per_s = double(cycles_total) / wall_s;
      for (int st = 0; st < kStageCount; ++st)
        rep.stage_ms[size_t(st)] = 1000.0 * double(stage_cycles[size_t(st)]) / cycles_per_s / double(frame_count_);
    }
  }
  return rep;
}

std::vector<CachedFrame> EvalSession::cache_forest() {
  std::vector<CachedFrame> cache(static_cast<size_t>(frame_count_));
  const int w = dataset_.meta.width, h = dataset_.meta.height;
  const CameraIntrinsics intr{float(dataset_.meta.fx), float(dataset_.meta.fy), float(dataset_.meta.cx),
                              float(dataset_.meta.cy)};
  FrameResult r;
  const int trees = blob_.tree_count();
  for (long i = 0; i < frame_count_; ++i) {
    const PreparedFrame pf = prepare(i);
    const DepthFrame frame{pf.depth.data(), w, h, w, intr, pf.mask.empty() ? nullptr : pf.mask.data()};
    if (Status s = pipeline_.process(frame, &r); s != Status::kOk)
      fail(dataset_.depth_path(size_t(i)) + ": runtime refused the frame: " + status_message(s));
    CachedFrame& c = cache[size_t(i)];
    c.intrinsics = intr;
    const int n = pipeline_.evaluated_pixel_count();
    c.pixels.assign(pipeline_.evaluated_pixels(), pipeline_.evaluated_pixels() + n);
    c.leaves.resize(size_t(n) * trees);
    for (int t = 0; t < trees; ++t)
      for (int p = 0; p < n; ++p) c.leaves[size_t(t) * n + p] = pipeline_.leaf_of(p, t);
  }
  return cache;
}

std::vector<std::optional<double>> EvalSession::joint_ap_from_cache(const std::vector<CachedFrame>& cache,
                                                                     const blob::RuntimeConfig& config, int threads) {
  blob::BlobProblem problem;
  if (blob::BlobStatus s = blob::validate_config(*blob_.meta, config, &problem); s != blob::BlobStatus::kOk)
    fail("tuned config refused: " + blob_error_message(s, problem));
  const long n = long(cache.size());
  threads = std::max(1, std::min<int>(threads, int(std::max(1L, n))));
  std::vector<FrameResult> results(static_cast<size_t>(n));
  std::vector<Status> failure(static_cast<size_t>(threads), Status::kOk);
  auto work = [&](int t) {
    platform::ArenaMemory arena;
    try {
      arena = platform::ArenaMemory(arena_bytes_);
    } catch (const ToolError&) {
      failure[size_t(t)] = Status::kArenaTooSmall;
      return;
    }
    Pipeline p;
    Status s = p.init(blob_, dataset_.meta.width, dataset_.meta.height, arena.data(), arena_bytes_);
    if (s == Status::kOk) s = p.set_config(config);
    for (long i = t; s == Status::kOk && i < n; i += threads) {
      const CachedFrame& c = cache[size_t(i)];
      if (c.pixels.empty()) {
        std::memset(&results[size_t(i)], 0, sizeof(FrameResult));
        continue;
      }
      s = p.aggregate_from_leaves(c.intrinsics, c.pixels.data(), c.leaves.data(), int32_t(c.pixels.size()),
                                  &results[size_t(i)]);
    }
    failure[size_t(t)] = s;
  };
  if (threads == 1) {
    work(0);
  } else {
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) pool.emplace_back(work, t);
    for (std::thread& th : pool) th.join();
  }
  for (Status s : failure)
    if (s != Status::kOk) fail(std::string("re-aggregation failed: ") + status_message(s));
  std::vector<JointSamples> samples = empty_samples();
  for (long i = 0; i < n; ++i) collect(i, results[size_t(i)], samples);
  std::vector<std::optional<double>> ap;
  const double d_tp = options_.silhouette ? options_.d_tp_px : options_.d_tp_m;
  for (const JointSamples& s : samples) ap.push_back(average_precision(match_joint(s, match_options(d_tp))));
  return ap;
}

std::vector<GroupAccuracy> accuracy_by_group(const std::vector<JointSamples>& samples,
                                             const std::vector<std::string>& group_of_frame,
                                             const MatchOptions& options) {
  std::vector<std::string> names = group_of_frame;
  std::sort(names.begin(), names.end());
  names.erase(std::unique(names.begin(), names.end()), names.end());
  std::vector<GroupAccuracy> out;
  for (const std::string& name : names) {
    GroupAccuracy g;
    g.name = name;
    for (const JointSamples& joint : samples) {
      if (joint.truth.size() != group_of_frame.size() || joint.proposals.size() != group_of_frame.size())
        fail("accuracy_by_group: " + std::to_string(group_of_frame.size()) + " frame groups for " +
             std::to_string(joint.truth.size()) + " frames");
      JointSamples subset;
      for (size_t f = 0; f < group_of_frame.size(); ++f)
        if (group_of_frame[f] == name) {
          subset.truth.push_back(joint.truth[f]);
          subset.proposals.push_back(joint.proposals[f]);
        }
      g.frames = long(subset.truth.size());
      g.ap.push_back(average_precision(match_joint(subset, options)));
    }
    g.mean_ap = mean_average_precision(g.ap);
    out.push_back(std::move(g));
  }
  return out;
}

std::vector<std::string> frame_groups(const Dataset& dataset, long frames, FrameGroupKey key) {
  const char* field = key == FrameGroupKey::kCategory ? "category" : "clip";
  std::vector<std::string> groups(size_t(frames), "(none)");
  bool any = false;
  for (long f = 0; f < frames; ++f) {
    const nlohmann::json extra = nlohmann::json::parse(dataset.frames[size_t(f)].extra_json);
    const auto it = extra.find(field);
    if (it == extra.end()) continue;
    if (!it->is_string() || it->get<std::string>().empty())
      fail(dataset.dir + "/frames.jsonl: frame " + dataset.frames[size_t(f)].id + ": \"" + field +
           "\" must be a non-empty string");
    std::string value = it->get<std::string>();
    if (key == FrameGroupKey::kSubject) value = value.substr(0, value.find('_'));
    groups[size_t(f)] = std::move(value);
    any = true;
  }
  if (!any) groups.clear();
  return groups;
}

}  // namespace dp::tools
