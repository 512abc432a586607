#include "tools/app/run.h"

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdarg>
#include <cstdlib>
#include <memory>
#include <thread>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "platform/arena_memory.h"
#include "platform/hotplug_source.h"
#include "platform/usb_devices.h"
#include "runtime/cycle_counter.h"
#include "runtime/segmentation/segmenter.h"
#include "runtime/skeleton_tracker.h"
#include "tools/segeval/segmenter_config_text.h"
#include "tools/app/overlay.h"
#include "tools/common/error.h"
#include "tools/common/png_io.h"
#include "tools/common/blob_error.h"

namespace dp::tools {

namespace {

volatile std::sig_atomic_t g_stop = 0;

using Clock = std::chrono::steady_clock;

// A line of JSON in a buffer allocated once.
class LineBuffer {
 public:
  explicit LineBuffer(size_t capacity) : data_(capacity) {}
  void clear() { size_ = 0; }
  void add(const char* format, ...) __attribute__((format(printf, 2, 3))) {
    if (size_ >= data_.size()) return;
    va_list args;
    va_start(args, format);
    int n = std::vsnprintf(data_.data() + size_, data_.size() - size_, format, args);
    va_end(args);
    if (n > 0) size_ = std::min(data_.size() - 1, size_ + size_t(n));
  }
  void number(double v, const char* format = "%.4f") {
    if (std::isfinite(v)) add(format, v);
    else add("null");
  }
  // Names from the blob are printable ASCII (checked by the loader); escape quotes anyway.
  void string(const char* s, size_t max) {
    add("\"");
    for (size_t i = 0; i < max && s[i]; ++i) {
      if (s[i] == '"' || s[i] == '\\') add("\\%c", s[i]);
      else add("%c", s[i]);
    }
    add("\"");
  }
  void write(FILE* out) {
    add("\n");
    std::fwrite(data_.data(), 1, size_, out);
    std::fflush(out);
  }

 private:
  std::vector<char> data_;
  size_t size_ = 0;
};

// Frame times in 10 µs bins up to 5 s (longer frames land in the last bin; max is exact).
class TimeHistogram {
 public:
  TimeHistogram() : bins_(kBins, 0) {}
  void add(double ms) {
    size_t bin = size_t(std::max(0.0, ms) * 100.0);
    ++bins_[std::min(bin, kBins - 1)];
    ++count_;
    max_ = std::max(max_, ms);
  }
  double quantile(double q) const {
    if (!count_) return 0;
    const uint64_t rank = uint64_t(std::ceil(q * double(count_)));
    uint64_t seen = 0;
    for (size_t i = 0; i < kBins; ++i) {
      seen += bins_[i];
      if (seen >= std::max<uint64_t>(rank, 1)) return std::min(max_, (double(i) + 1.0) / 100.0);
    }
    return max_;
  }
  double max() const { return max_; }

 private:
  static constexpr size_t kBins = 500000;
  std::vector<uint32_t> bins_;
  uint64_t count_ = 0;
  double max_ = 0;
};

// ,"x":..,"y":..,"z":.. (metres).
void write_position(LineBuffer& line, float x, float y, float z) {
  line.add(",\"x\":");
  line.number(x);
  line.add(",\"y\":");
  line.number(y);
  line.add(",\"z\":");
  line.number(z);
}

// [{"name":..,"x":..,"y":..,"z":..,"confidence":..,"state":..}, ...]. With a skeleton (the tracker
// runs): its joints, confidence in [0, 1], the chosen proposal's vote weight, the orientation of
// the bone ending at the joint. Without: the best
// proposal of every joint, confidence = its vote weight.
void write_joints_json(LineBuffer& line, const blob::LoadedBlob& b, const FrameResult& r, const Skeleton* sk) {
  line.add("[");
  for (int j = 0; j < r.joint_count; ++j) {
    line.add(j ? ",{\"name\":" : "{\"name\":");
    line.string(b.meta->joint_names[j], blob::kNameBytes);
    if (sk) {
      const TrackedJoint& t = sk->joints[j];
      if (t.state == JointState::kMissing) line.add(",\"x\":null,\"y\":null,\"z\":null");
      else write_position(line, t.x_m, t.y_m, t.z_m);
      line.add(",\"confidence\":");
      line.number(t.confidence, "%.2f");
      line.add(",\"state\":\"%s\",\"vote_weight\":", joint_state_name(t.state));
      if (t.proposal >= 0) line.number(r.proposals[t.proposal_joint][t.proposal].confidence, "%.5g");
      else line.add("null");
      if (sk->bone_rotation_valid[j]) {
        const float* q = sk->bone_rotation[j];
        line.add(",\"orientation\":[%.4f,%.4f,%.4f,%.4f]", q[0], q[1], q[2], q[3]);
      } else {
        line.add(",\"orientation\":null");
      }
    } else if (r.proposal_count[j] > 0) {
      const JointProposal& p = r.proposals[j][0];
      write_position(line, p.x_m, p.y_m, p.z_m);
      line.add(",\"confidence\":");
      line.number(p.confidence, "%.5g");
      line.add(",\"state\":\"tracked\"");
    } else {
      line.add(",\"x\":null,\"y\":null,\"z\":null,\"confidence\":0,\"state\":\"missing\"");
    }
    line.add("}");
  }
  line.add("]");
}

// Segmentation output of one frame: what the frame loop hands to the writers.
struct SegmentedFrame {
  const SegmentationResult* seg = nullptr;  // null without segmentation
  const FrameResult* users = nullptr;       // [seg->user_count]
  const Skeleton* skeletons = nullptr;      // [seg->user_count] with the tracker, else null
  const Skeleton* frame_skeleton = nullptr; // the top-level joints' skeleton (primary user or whole frame)
};

void write_flag_names(LineBuffer& line, uint32_t flags, const char* (*name)(int)) {
  bool first = true;
  for (int bit = 0; bit < 32; ++bit)
    if (flags & (1u << bit)) {
      line.add("%s\"%s\"", first ? "" : ",", name(bit));
      first = false;
    }
}

const char* seg_flag_name(int bit) {
  static const char* const names[] = {"floor_fitted", "floor_held", "background_learning", "candidates_truncated",
                                      "users_truncated"};
  return bit >= 0 && bit < int(sizeof names / sizeof names[0]) ? names[bit] : "unknown_flag";
}

// Index (into seg.users) of the user with the most pixels; 0 when there is none.
int primary_user_index(const SegmentationResult& seg) {
  int primary = 0;
  for (int i = 1; i < seg.user_count; ++i)
    if (seg.users[i].pixel_count > seg.users[primary].pixel_count) primary = i;
  return primary;
}

void write_users_json(LineBuffer& line, const blob::LoadedBlob& b, const FrameResult& r, const SegmentedFrame& sf) {
  const SegmentationResult& s = *sf.seg;
  // With users, r sums their cycles (combine_users); without, it is the one empty pass.
  const uint64_t frame_cycles = r.total_cycles + s.total_cycles;
  const int primary = primary_user_index(s);
  if (s.user_count > 0) line.add(",\"primary_user\":%d", s.users[primary].id);
  else line.add(",\"primary_user\":null");
  line.add(",\"users\":[");
  for (int i = 0; i < s.user_count; ++i) {
    const UserInfo& u = s.users[i];
    line.add("%s{\"id\":%d,\"pixels\":%d,\"centroid\":[", i ? "," : "", u.id, u.pixel_count);
    line.number(u.centroid_m[0]);
    line.add(",");
    line.number(u.centroid_m[1]);
    line.add(",");
    line.number(u.centroid_m[2]);
    line.add("],\"frames_tracked\":%d,\"arrival\":\"%s\",\"joints\":", u.frames_tracked, user_arrival_name(u.arrival));
    write_joints_json(line, b, sf.users[i], sf.skeletons ? &sf.skeletons[i] : nullptr);
    line.add(",\"cycles\":%llu,\"evaluated_pixels\":%d,\"flags\":[", (unsigned long long)sf.users[i].total_cycles,
             sf.users[i].evaluated_pixels);
    write_flag_names(line, sf.users[i].flags, frame_flag_name);
    line.add("]}");
  }
  line.add("],\"segmentation\":{\"floor\":");
  if (s.floor.valid) {
    line.add("[%.4f,%.4f,%.4f,%.4f]", s.floor.nx, s.floor.ny, s.floor.nz, s.floor.d);
  } else {
    line.add("null");
  }
  line.add(",\"candidate_pixels\":%d,\"flags\":[", s.candidate_pixels);
  write_flag_names(line, s.flags, seg_flag_name);
  line.add("],\"stage_cycles\":{");
  for (int st = 0; st < kSegStageCount; ++st)
    line.add("%s\"%s\":%llu", st ? "," : "", segmentation_stage_name(st) + 4,  // drop "seg_"
             (unsigned long long)s.stage_cycles[st]);
  line.add("}},\"frame_cycles\":%llu", (unsigned long long)frame_cycles);
}

void write_frame_json(LineBuffer& line, const RunOptions& options, const blob::LoadedBlob& b, const Pipeline& pipeline,
                      int64_t frame, const platform::FrameInfo& info, double frame_ms, const FrameResult& r,
                      const SegmentedFrame& sf) {
  line.clear();
  line.add("{\"frame\":%lld,\"source_index\":%lld,\"timestamp_us\":%llu,\"frame_ms\":", (long long)frame,
           (long long)info.index, (unsigned long long)info.timestamp_us);
  line.number(frame_ms, "%.3f");
  // The unit of every *_cycles field of this line (runtime/cycle_counter.h): "tsc_cycles" on x86-64,
  // "cntvct_ticks" on aarch64.
  line.add(",\"kernel\":\"%s\",\"counter_unit\":\"%s\",\"joints\":", kernel_isa_name(pipeline.kernel()),
           cycle_counter_unit());
  write_joints_json(line, b, r, sf.frame_skeleton);
  line.add(",\"skeleton\":%s", sf.frame_skeleton ? "true" : "false");
  if (options.all_proposals) {
    line.add(",\"proposals\":[");
    for (int j = 0; j < r.joint_count; ++j) {
      line.add(j ? ",[" : "[");
      for (int k = 0; k < r.proposal_count[j]; ++k) {
        const JointProposal& p = r.proposals[j][k];
        line.add(k ? ",[" : "[");
        line.number(p.x_m);
        line.add(",");
        line.number(p.y_m);
        line.add(",");
        line.number(p.z_m);
        line.add(",");
        line.number(p.confidence, "%.5g");
        line.add("]");
      }
      line.add("]");
    }
    line.add("]");
  }
  line.add(",\"stage_cycles\":{");
  for (int s = 0; s < kStageCount; ++s)
    line.add("%s\"%s\":%llu", s ? "," : "", stage_name(s), (unsigned long long)r.stage_cycles[s]);
  line.add("},\"total_cycles\":%llu,\"flags\":[", (unsigned long long)r.total_cycles);
  write_flag_names(line, r.flags, frame_flag_name);
  line.add("],\"over_budget\":%s,\"foreground_pixels\":%d,\"evaluated_pixels\":%d,\"pixel_stride\":%d",
           (r.flags & kFlagOverCycleBudget) ? "true" : "false", r.foreground_pixels, r.evaluated_pixels,
           r.pixel_stride);
  if (sf.seg) write_users_json(line, b, r, sf);
  line.add("}");
}

// " head 0.012 0.457 2.055 tracked 0.80 | neck - | ...": with a skeleton, each joint's filtered
// position, state and calibrated confidence (as in --json); "-" for a missing joint. Without (other
// joint sets), each joint's best proposal and its summed vote weight ("votes 2.95e+08").
void write_joints_text(LineBuffer& line, const blob::LoadedBlob& b, const FrameResult& r, const Skeleton* sk) {
  for (int j = 0; j < r.joint_count; ++j) {
    line.add(j ? " | %.*s" : " %.*s", blob::kNameBytes, b.meta->joint_names[j]);
    if (sk) {
      const TrackedJoint& t = sk->joints[j];
      if (t.state == JointState::kMissing) line.add(" -");
      else line.add(" %.3f %.3f %.3f %s %.2f", t.x_m, t.y_m, t.z_m, joint_state_name(t.state), t.confidence);
    } else if (r.proposal_count[j] > 0) {
      const JointProposal& p = r.proposals[j][0];
      line.add(" %.3f %.3f %.3f (votes %.3g)", p.x_m, p.y_m, p.z_m, p.confidence);
    } else {
      line.add(" -");
    }
  }
}

void write_frame_text(LineBuffer& line, const blob::LoadedBlob& b, int64_t frame, const platform::FrameInfo& info,
                      double frame_ms, const FrameResult& r, const SegmentedFrame& sf, FILE* out) {
  line.clear();
  line.add("frame %lld (source %lld, %.2f ms):", (long long)frame, (long long)info.index, frame_ms);
  if (sf.seg) line.add(" %d user(s):", sf.seg->user_count);
  write_joints_text(line, b, r, sf.frame_skeleton);
  if (r.flags & kFlagOverCycleBudget) line.add(" [over budget]");
  line.write(out);
  if (!sf.seg) return;
  for (int i = 0; i < sf.seg->user_count; ++i) {
    const UserInfo& u = sf.seg->users[i];
    line.clear();
    line.add("frame %lld user %d (%d px, tracked %d frames):", (long long)frame, u.id, u.pixel_count,
             u.frames_tracked);
    write_joints_text(line, b, sf.users[i], sf.skeletons ? &sf.skeletons[i] : nullptr);
    line.write(out);
  }
}

// The frame-level result of a segmented frame processed per user: the joints and proposals of
// the user with the most pixels (the primary user), cycles and pixel counts summed over users,
// budget flags or-ed, the largest stride.
void combine_users(const SegmentationResult& seg, const FrameResult* users, FrameResult* out) {
  *out = users[primary_user_index(seg)];
  out->total_cycles = 0;
  out->flags = 0;
  out->foreground_pixels = out->evaluated_pixels = 0;
  for (int s = 0; s < kStageCount; ++s) out->stage_cycles[s] = 0;
  for (int i = 0; i < seg.user_count; ++i) {
    for (int s = 0; s < kStageCount; ++s) out->stage_cycles[s] += users[i].stage_cycles[s];
    out->total_cycles += users[i].total_cycles;
    out->flags |= users[i].flags;
    out->foreground_pixels += users[i].foreground_pixels;
    out->evaluated_pixels += users[i].evaluated_pixels;
    out->pixel_stride = std::max(out->pixel_stride, users[i].pixel_stride);
  }
}

}  // namespace


void request_stop() { g_stop = 1; }

RunSummary run_app(const RunOptions& options, FILE* json_out, FILE* log) {
  g_stop = 0;
  if (options.every < 1) fail("--every must be at least 1");
  // ---- setup: everything the loop needs, allocated once ----
  std::vector<uint8_t> blob_bytes = blob::read_blob_file(options.blob_path);
  const blob::LoadedBlob b = load_blob_or_fail(blob_bytes, options.blob_path);
  platform::SourceOptions source_options = options.source_options;
  if (options.realtime) source_options.latest_only = true;
  std::unique_ptr<platform::FrameSource> source = platform::open_source(options.source_spec, source_options);
  if (options.loop < 1) fail("--loop must be at least 1");
  if (options.loop > 1 && source->live())
    fail("--loop " + std::to_string(options.loop) + ": " + options.source_spec +
         " is a live source; only files (raw, dataset, oni) can be played again");
  if (source->live() && options.usb_watch) {
    // With a depth camera on the bus, its disappearance is noticed even when the driver says
    // nothing. (Which camera a /dev/videoN or OpenNI2 URI is cannot be told portably: the first
    // depth camera is watched.)
    try {
      std::unique_ptr<platform::UsbLister> lister = platform::make_libusb_lister();
      std::vector<platform::UsbDevice> cameras = platform::depth_cameras(lister->list());
      if (!cameras.empty()) {
        std::fprintf(log, "run: watching %s for hotplug\n", platform::describe(cameras[0]).c_str());
        const std::string spec = options.source_spec;
        source = platform::watch_hotplug(std::move(source), [spec, source_options] { return platform::open_source(spec, source_options); },
                                         std::move(lister), cameras[0]);
      }
    } catch (const std::exception& e) {
      std::fprintf(log, "run: no USB hotplug watch (%s)\n", e.what());
    }
  }
  const int w = source->width(), h = source->height();
  const size_t arena_bytes = required_arena_bytes(b, w, h);
  if (!arena_bytes) fail("blob " + options.blob_path + " cannot run on " + std::to_string(w) + "x" + std::to_string(h) + " frames");
  const platform::ArenaMemory arena(arena_bytes);
  Pipeline pipeline;
  if (Status s = pipeline.init(b, w, h, arena.data(), arena_bytes); s != Status::kOk)
    fail(std::string("pipeline init: ") + status_message(s));
  if (Status s = pipeline.set_kernel(options.kernel); s != Status::kOk)
    fail(std::string("kernel ") + kernel_isa_name(options.kernel) + ": " + status_message(s));
  if (options.budget.any()) {
    const blob::RuntimeConfig c = with_budget(*b.config, options.budget, b.config->max_evaluated_pixels);
    if (Status s = pipeline.set_config(c); s != Status::kOk)
      fail("budget " + describe_budget(options.budget) + ": " + status_message(s));
    std::fprintf(log, "run: %s (blob: pixel budget %u, cycle budget %llu)\n", describe_budget(options.budget).c_str(),
                 unsigned(b.config->max_evaluated_pixels), (unsigned long long)b.config->cycle_budget);
  }
  if (!options.overlay_dir.empty()) {
    ::mkdir(options.overlay_dir.c_str(), 0755);
    struct stat st{};
    if (::stat(options.overlay_dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
      fail("--overlay " + options.overlay_dir + ": cannot create the directory");
  }
  std::vector<uint16_t> depth(size_t(w) * h);
  const CameraIntrinsics intrinsics = source->intrinsics();
  DepthFrame frame{depth.data(), w, h, w, intrinsics, nullptr};
  // Segmentation: its arena, the label image (the frame's mask) and per-user results, once.
  const bool sequential = source->live() || options.source_spec.rfind("oni:", 0) == 0;
  const bool segment = options.segment == SegmentMode::kOn || (options.segment == SegmentMode::kAuto && sequential);
  Segmenter segmenter;
  platform::ArenaMemory seg_arena;
  std::vector<uint8_t> labels, user_mask;
  std::vector<FrameResult> user_results;
  auto seg_result = std::make_unique<SegmentationResult>();
  if (!segment && !options.segment_config_path.empty())
    fail("--segment-config " + options.segment_config_path + ": segmentation is off for this source (use --segment on)");
  if (segment) {
    SegmenterConfig seg_config = default_segmenter_config(sequential);
    if (!options.segment_config_path.empty())
      seg_config = load_segmenter_config_file(options.segment_config_path, seg_config);
    const size_t seg_bytes = segmenter_required_bytes(w, h);
    if (!seg_bytes) fail("segmentation cannot run on " + std::to_string(w) + "x" + std::to_string(h) + " frames");
    seg_arena = platform::ArenaMemory(seg_bytes);
    if (Status s = segmenter.init(seg_config, w, h, seg_arena.data(), seg_bytes);
        s != Status::kOk)
      fail(std::string("segmenter init: ") + status_message(s));
    labels.assign(size_t(w) * h, 0);
    user_mask.assign(size_t(w) * h, 0);
    user_results.resize(kMaxUsers);
    seg_result->labels = labels.data();
    frame.foreground_mask = labels.data();
  }
  // The skeleton tracker, when the blob's joints are its 16 (otherwise joints are the best proposals).
  auto tracker = std::make_unique<SkeletonTracker>();
  SkeletonConfig skeleton_config = default_skeleton_config();
  skeleton_config.filter = skeleton_filter_preset(options.smoothing);
  const bool track = tracker->init(*b.meta, skeleton_config) == Status::kOk;
  std::vector<Skeleton> skeletons(static_cast<size_t>(kMaxUsers));
  std::fprintf(log, "run: skeleton tracker %s\n",
               track ? (options.smoothing == SkeletonFilterPreset::kOff     ? "on (smoothing off)"
                        : options.smoothing == SkeletonFilterPreset::kStrong ? "on (smoothing strong)"
                                                                             : "on (smoothing default)")
                     : "off (the blob's joints are not the 16 of docs/dataset_format.md)");
  std::vector<bool> ids_seen(kMaxUsers + 1, false);
  auto result = std::make_unique<FrameResult>();
  ImageRgb overlay;
  if (!options.overlay_dir.empty()) overlay.resize(w, h);
  std::vector<char> overlay_path(options.overlay_dir.size() + 32);
  LineBuffer line(1 << 16);
  TimeHistogram times;
  RunSummary summary;

  std::fprintf(log, "run: %s on %s (%dx%d, fx %.1f fy %.1f cx %.1f cy %.1f), kernel %s (forest %s), arena %zu bytes%s\n",
               options.blob_path.c_str(), options.source_spec.c_str(), w, h, intrinsics.fx, intrinsics.fy, intrinsics.cx,
               intrinsics.cy, kernel_isa_name(pipeline.kernel()), kernel_isa_name(pipeline.forest_kernel()), arena_bytes,
               arena.huge_page_advice() ? " (2 MiB pages advised)" : "");
  if (segment)
    std::fprintf(log, "run: segmentation on (floor, %s, users), arena %zu bytes, config %s\n",
                 segmenter.config().background_enabled ? "background model" : "no background model",
                 segmenter.arena_used_bytes(),
                 options.segment_config_path.empty() ? "defaults" : options.segment_config_path.c_str());
  summary.segmented = segment;

  // ---- the loop: no allocation from here on ----
  const auto loop_start = Clock::now();
  bool lost = false, paced = false;
  Clock::time_point pace_wall{};
  uint64_t pace_ts = 0;
  int64_t corrupt_seen = 0, passes_done = 0, earlier_corrupt = 0, earlier_dropped = 0;
  platform::FrameInfo info;
  while (!g_stop && (options.max_frames < 0 || summary.frames_processed < options.max_frames)) {
    const platform::NextStatus status = source->next(depth.data(), &info);
    if (source->stats().corrupt_frames != corrupt_seen) {
      corrupt_seen = source->stats().corrupt_frames;
      std::fprintf(log, "run: %s\n", source->last_warning().c_str());
    }
    if (status == platform::NextStatus::kEnd) {
      if (++passes_done < options.loop) {
        if (!source->rewind()) {
          // A source that cannot rewind is reopened (allocating); its counts carry over.
          earlier_corrupt += source->stats().corrupt_frames;
          earlier_dropped += source->stats().dropped_frames;
          source.reset();
          source = platform::open_source(options.source_spec, source_options);
          corrupt_seen = 0;
          if (source->width() != w || source->height() != h) {
            summary.source_failed = true;
            summary.source_error = options.source_spec + " changed its frame size between --loop passes";
            std::fprintf(log, "run: %s\n", summary.source_error.c_str());
            break;
          }
        }
        continue;
      }
      break;
    }
    if (status == platform::NextStatus::kError) {
      summary.source_failed = true;
      summary.source_error = source->last_error();
      std::fprintf(log, "run: source error: %s\n", summary.source_error.c_str());
      break;
    }
    if (status == platform::NextStatus::kDeviceLost) {
      if (!lost) std::fprintf(log, "run: %s; waiting for it to come back\n", source->last_warning().c_str());
      lost = true;
      continue;
    }
    if (status == platform::NextStatus::kNoFrame) continue;
    if (lost) {
      std::fprintf(log, "run: device back, resuming\n");
      lost = false;
    }
    ++summary.frames_read;
    if ((summary.frames_read - 1) % options.every != 0) {
      ++summary.skipped_by_every;
      continue;
    }
    if (options.realtime && !source->live()) {
      // Replay at the recording's pace; a frame whose time has passed is dropped, not queued.
      const auto now = Clock::now();
      if (!paced) {
        paced = true;
        pace_wall = now;
        pace_ts = info.timestamp_us;
      }
      const auto due = pace_wall + std::chrono::microseconds(int64_t(info.timestamp_us - pace_ts));
      if (now > due + std::chrono::milliseconds(5)) {
        ++summary.dropped;
        continue;
      }
      if (now < due) std::this_thread::sleep_until(due);
    }
    const auto t0 = Clock::now();
    Status s = Status::kOk;
    SegmentedFrame sf;
    if (segment) {
      s = segmenter.process(frame, seg_result.get());
      sf.seg = seg_result.get();
      sf.users = user_results.data();
    }
    const bool draw = !options.overlay_dir.empty();
    if (s == Status::kOk && segment && seg_result->user_count > 0) {
      // The whole chain once per user over that user's pixels alone: to each user's probes the
      // other people are background, as every person was alone in the training images.
      if (draw) draw_depth_grey(frame, pipeline.config(), &overlay);
      for (int i = 0; s == Status::kOk && i < seg_result->user_count; ++i) {
        const uint8_t id = uint8_t(seg_result->users[i].id);
        for (size_t q = 0; q < labels.size(); ++q) user_mask[q] = labels[q] == id;
        DepthFrame own = frame;
        own.foreground_mask = user_mask.data();
        s = pipeline.process(own, &user_results[size_t(i)]);
        if (draw && s == Status::kOk) draw_evaluated_pixels(pipeline, &overlay);
      }
      if (s == Status::kOk && track) {
        tracker->begin_frame();
        for (int i = 0; i < seg_result->user_count; ++i) {
          FrameResult& ur = user_results[size_t(i)];
          tracker->note_arrival(seg_result->users[i].id, seg_result->users[i].arrival);
          tracker->update(seg_result->users[i].id, ur, &skeletons[size_t(i)]);
          ur.stage_cycles[kStageSkeleton] = skeletons[size_t(i)].cycles;
          ur.total_cycles += skeletons[size_t(i)].cycles;
        }
        sf.skeletons = skeletons.data();
        sf.frame_skeleton = &skeletons[size_t(primary_user_index(*seg_result))];
      }
      if (s == Status::kOk) combine_users(*seg_result, user_results.data(), result.get());
    } else if (s == Status::kOk) {
      s = pipeline.process(frame, result.get());  // no segmentation, or nobody: labels all zero
      if (s == Status::kOk && track) {
        // Without segmentation the frame is one person (user 1); with segmentation and nobody in
        // view there is no skeleton.
        tracker->begin_frame();
        if (!segment) {
          tracker->update(1, *result, &skeletons[0]);
          result->stage_cycles[kStageSkeleton] = skeletons[0].cycles;
          result->total_cycles += skeletons[0].cycles;
          sf.frame_skeleton = &skeletons[0];
        }
      }
    }
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    if (s != Status::kOk) {
      std::fprintf(log, "run: frame %lld: %s (skipped)\n", (long long)info.index, status_message(s));
      ++summary.corrupt;
      continue;
    }
    times.add(ms);
    if (result->flags & kFlagOverCycleBudget) ++summary.overruns;
    if (result->flags & (kFlagPixelsStrided | kFlagBudgetPixels | kFlagBudgetVotes | kFlagBudgetStarts |
                         kFlagBudgetIterations | kFlagBudgetInfeasible))
      ++summary.degraded;
    if (result->flags & (kFlagVotesTruncated | kFlagStartsTruncated | kFlagProposalsTruncated)) ++summary.capped;
    if (segment) {
      summary.user_frames += seg_result->user_count;
      summary.max_users_in_frame = std::max(summary.max_users_in_frame, int(seg_result->user_count));
      for (int i = 0; i < seg_result->user_count; ++i) {
        const int id = seg_result->users[i].id;
        if (id >= 1 && id <= kMaxUsers && !ids_seen[size_t(id)]) {
          ids_seen[size_t(id)] = true;
          ++summary.distinct_user_ids;
        }
      }
    }
    if (options.json) {
      write_frame_json(line, options, b, pipeline, summary.frames_processed, info, ms, *result, sf);
      line.write(json_out);
    } else if (!options.quiet) {
      write_frame_text(line, b, summary.frames_processed, info, ms, *result, sf, json_out);
    }
    if (!options.overlay_dir.empty()) {
      if (segment && seg_result->user_count > 0) {  // depth and pixels were drawn pass by pass
        for (int i = 0; i < seg_result->user_count; ++i)
          draw_skeleton(frame, *b.meta, user_results[size_t(i)], &overlay);
      } else {
        draw_overlay(frame, pipeline, *result, &overlay);
      }
      std::snprintf(overlay_path.data(), overlay_path.size(), "%s/%06lld.png", options.overlay_dir.c_str(),
                    (long long)summary.frames_processed);
      try {
        write_png_rgb(overlay_path.data(), overlay);
      } catch (const std::exception& e) {
        std::fprintf(log, "run: overlay: %s\n", e.what());
      }
    }
    ++summary.frames_processed;
    if (options.on_frame) options.on_frame(summary.frames_processed);
  }
  summary.seconds = std::chrono::duration<double>(Clock::now() - loop_start).count();
  summary.fps = summary.seconds > 0 ? double(summary.frames_processed) / summary.seconds : 0;
  summary.p50_ms = times.quantile(0.50);
  summary.p99_ms = times.quantile(0.99);
  summary.max_ms = times.max();
  const platform::SourceStats& st = source->stats();
  summary.corrupt += st.corrupt_frames + earlier_corrupt;
  summary.dropped += st.dropped_frames + earlier_dropped;
  summary.device_lost = st.device_lost;
  summary.reconnects = st.reconnects;
  std::fprintf(log,
               "summary: %lld frames processed (%lld read, %lld skipped by --every) in %.2f s = %.1f frames/s; "
               "frame time p50 %.3f ms p99 %.3f ms max %.3f ms; budget overruns %lld, degraded %lld, top-N capped %lld; "
               "dropped %lld, corrupt %lld; device lost %lld, reconnects %lld\n",
               (long long)summary.frames_processed, (long long)summary.frames_read, (long long)summary.skipped_by_every,
               summary.seconds, summary.fps, summary.p50_ms, summary.p99_ms, summary.max_ms, (long long)summary.overruns,
               (long long)summary.degraded, (long long)summary.capped, (long long)summary.dropped, (long long)summary.corrupt,
               (long long)summary.device_lost, (long long)summary.reconnects);
  if (summary.frames_processed == 0 && summary.corrupt > 0 && !summary.source_failed && !g_stop) {
    // Exit 0 with "0 frames processed" would pass for success: every frame was bad.
    summary.source_failed = true;
    summary.source_error = options.source_spec + ": none of its frames could be processed (" +
                           std::to_string(summary.corrupt) + " corrupt or refused; see the messages above)";
    std::fprintf(log, "run: %s\n", summary.source_error.c_str());
  }
  if (segment)
    std::fprintf(log, "segmentation: %.2f users per frame on average, at most %d in a frame, %d distinct ids\n",
                 summary.frames_processed ? double(summary.user_frames) / double(summary.frames_processed) : 0.0,
                 summary.max_users_in_frame, summary.distinct_user_ids);
  return summary;
}

}  // namespace dp::tools
