// `make bench`: the skeleton tracker's cost per user and frame (runtime/skeleton_tracker.h), beside
// the pipeline's, on the shipped recording (models/demo.oni, two people) with the shipped OJR blob.
// Each user's proposals are computed once (segmenter, then the pipeline on that user's pixels);
// the tracker then replays them ROUNDS times, best round reported (docs/skeleton.md).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "platform/arena_memory.h"
#include "platform/frame_source.h"
#include "runtime/cycle_counter.h"
#include "runtime/segmentation/segmenter.h"
#include "runtime/skeleton_tracker.h"

using namespace dp;

int main() {
  constexpr int kFrames = 30, kRounds = 20;
  std::vector<uint8_t> bytes = blob::read_blob_file("models/ojr.blob");
  blob::LoadedBlob b;
  if (blob::load_blob(bytes.data(), bytes.size(), &b) != blob::BlobStatus::kOk) {
    std::fprintf(stderr, "skeleton bench: models/ojr.blob does not load\n");
    return 1;
  }
  std::unique_ptr<platform::FrameSource> source = platform::open_source("oni:models/demo.oni");
  const int w = source->width(), h = source->height();
  const size_t arena_bytes = required_arena_bytes(b, w, h), seg_bytes = segmenter_required_bytes(w, h);
  platform::ArenaMemory arena(arena_bytes), seg_arena(seg_bytes);
  Pipeline pipeline;
  Segmenter segmenter;
  if (pipeline.init(b, w, h, arena.data(), arena_bytes) != Status::kOk ||
      segmenter.init(default_segmenter_config(true), w, h, seg_arena.data(), seg_bytes) != Status::kOk) {
    std::fprintf(stderr, "skeleton bench: init failed\n");
    return 1;
  }
  std::vector<uint16_t> depth(size_t(w) * h);
  std::vector<uint8_t> labels(depth.size()), mask(depth.size());
  auto seg = std::make_unique<SegmentationResult>();
  seg->labels = labels.data();
  struct UserFrame {
    int frame;
    int32_t id;
    std::unique_ptr<FrameResult> proposals;
  };
  std::vector<UserFrame> cached;
  double pipeline_ticks = 0;
  platform::FrameInfo info;
  for (int f = 0; f < kFrames && source->next(depth.data(), &info) == platform::NextStatus::kFrame; ++f) {
    const DepthFrame frame{depth.data(), w, h, w, source->intrinsics(), labels.data()};
    if (segmenter.process(frame, seg.get()) != Status::kOk) return 1;
    for (int i = 0; i < seg->user_count; ++i) {
      for (size_t p = 0; p < labels.size(); ++p) mask[p] = labels[p] == seg->users[i].id;
      DepthFrame own = frame;
      own.foreground_mask = mask.data();
      auto r = std::make_unique<FrameResult>();
      if (pipeline.process(own, r.get()) != Status::kOk) return 1;
      pipeline_ticks += double(r->total_cycles);
      cached.push_back({f, seg->users[i].id, std::move(r)});
    }
  }
  if (cached.empty()) {
    std::fprintf(stderr, "skeleton bench: no user found in models/demo.oni\n");
    return 1;
  }
  auto tracker = std::make_unique<SkeletonTracker>();
  double best_ticks = 1e300, best_ns = 1e300;
  Skeleton s;
  for (int round = 0; round < kRounds; ++round) {
    tracker->init(*b.meta, default_skeleton_config());
    double ticks = 0;
    int frame = -1;
    const auto t0 = std::chrono::steady_clock::now();
    for (const UserFrame& u : cached) {
      if (u.frame != frame) {
        tracker->begin_frame();
        frame = u.frame;
      }
      tracker->update(u.id, *u.proposals, &s);
      ticks += double(s.cycles);
    }
    const double ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count();
    best_ticks = std::min(best_ticks, ticks / double(cached.size()));
    best_ns = std::min(best_ns, ns / double(cached.size()));
  }
  std::printf("skeleton tracker: %zu user-frames (%dx%d, models/demo.oni, models/ojr.blob)\n", cached.size(), w, h);
  std::printf("  tracker  %10.0f %s per user and frame (%.1f us), best of %d rounds\n", best_ticks, cycle_counter_unit(),
              best_ns / 1000.0, kRounds);
  std::printf("  pipeline %10.0f %s per user and frame (forest, votes, mean shift)\n",
              pipeline_ticks / double(cached.size()), cycle_counter_unit());
  std::printf("  tracker / pipeline: %.2f %%\n", 100.0 * best_ticks / (pipeline_ticks / double(cached.size())));
  return 0;
}
