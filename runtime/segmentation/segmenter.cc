// Orchestration: the arena layout and the stages in order. Each stage lives in its own file pair
// (floor, background, components, person_tests, users); this file holds no rule of its own.
#include "runtime/segmentation/segmenter.h"

#include <string.h>

#include "runtime/arena.h"
#include "runtime/segmentation/background.h"
#include "runtime/segmentation/cycle_counter.h"
#include "runtime/segmentation/floor.h"

namespace dp {

const char* segmentation_stage_name(int32_t stage) {
  static const char* const names[kSegStageCount] = {"seg_floor", "seg_background", "seg_components", "seg_users"};
  return stage >= 0 && stage < kSegStageCount ? names[stage] : "?";
}

SegmenterConfig default_segmenter_config(bool live_source) {
  SegmenterConfig c;
  c.background_enabled = live_source;
  return c;
}

bool Segmenter::carve(ArenaCarver& c, int32_t w, int32_t h, Segmenter* into) {
  const size_t pixels = size_t(w) * size_t(h);
  SegmenterConfig* config = c.tail<SegmenterConfig>(1);
  seg::BackgroundCell* background = c.tail<seg::BackgroundCell>(pixels);
  seg::Track* tracks = c.tail<seg::Track>(kMaxUsers);
  seg::FurnitureMark* furniture_marks = c.tail<seg::FurnitureMark>(kMaxUsers);
  FloorPlane* floor = c.tail<FloorPlane>(1);
  State* state = c.tail<State>(1);
  int32_t* parent = c.head<int32_t>(pixels);
  int32_t* aux = c.head<int32_t>(pixels);
  float* samples = c.head<float>(size_t(kMaxFloorSamples) * 3);
  uint8_t* inlier = c.head<uint8_t>(kMaxFloorSamples);
  seg::Candidate* candidates = c.head<seg::Candidate>(kMaxCandidates);
  int16_t* hull_rows = c.head<int16_t>(size_t(h) * 4);
  if (!c.ok()) return false;
  if (into) {
    into->config_ = config;
    into->background_ = background;
    into->floor_ = floor;
    into->state_ = state;
    into->samples_ = samples;
    into->inlier_ = inlier;
    seg::UserStage& s = into->stages_;
    s.config_ = config;
    s.floor_ = floor;
    s.parent_ = parent;
    s.aux_ = aux;
    s.candidates_ = candidates;
    s.hull_rows_ = hull_rows;
    s.tracks_ = tracks;
    s.furniture_marks_ = furniture_marks;
  }
  return true;
}

size_t segmenter_required_bytes(int32_t max_width, int32_t max_height) {
  if (max_width < 1 || max_height < 1 || max_width > blob::kMaxFrameDimension ||
      max_height > blob::kMaxFrameDimension)
    return 0;
  ArenaCarver counter(nullptr, size_t(-1) / 2);
  Segmenter::carve(counter, max_width, max_height, nullptr);
  return counter.used();
}

Status Segmenter::init(const SegmenterConfig& config, int32_t max_width, int32_t max_height, uint8_t* arena,
                       size_t arena_bytes) {
  initialized_ = false;
  if (!arena || max_width < 1 || max_height < 1 || max_width > blob::kMaxFrameDimension ||
      max_height > blob::kMaxFrameDimension)
    return Status::kBadArgument;
  if (reinterpret_cast<uintptr_t>(arena) % kArenaAlignment != 0) return Status::kArenaMisaligned;
  if (arena_bytes < segmenter_required_bytes(max_width, max_height)) return Status::kArenaTooSmall;
  if (!segmenter_config_check(config)) return Status::kBadConfig;
  ArenaCarver c(arena, arena_bytes);
  if (!carve(c, max_width, max_height, this)) return Status::kArenaTooSmall;
  *config_ = config;
  max_width_ = max_width;
  max_height_ = max_height;
  arena_used_ = c.used();
  initialized_ = true;
  reset();
  return Status::kOk;
}

Status Segmenter::set_config(const SegmenterConfig& config) {
  if (!initialized_) return Status::kNotInitialized;
  if (!segmenter_config_check(config)) return Status::kBadConfig;
  *config_ = config;
  return Status::kOk;
}

void Segmenter::reset() {
  if (!initialized_) return;
  memset(background_, 0, sizeof(seg::BackgroundCell) * size_t(max_width_) * size_t(max_height_));
  memset(stages_.tracks_, 0, sizeof(seg::Track) * kMaxUsers);
  memset(stages_.furniture_marks_, 0, sizeof(seg::FurnitureMark) * kMaxUsers);
  memset(floor_, 0, sizeof *floor_);
  memset(state_, 0, sizeof *state_);
}

Status Segmenter::process(const DepthFrame& f, SegmentationResult* r) {
  if (!r) return Status::kBadArgument;
  uint8_t* labels = r->labels;
  memset(r, 0, sizeof *r);
  r->labels = labels;
  if (!initialized_) return Status::kNotInitialized;
  if (!labels || !f.depth_mm || f.width < 1 || f.height < 1 || f.stride_px < f.width ||
      !(f.intrinsics.fx > 0.0f) || !(f.intrinsics.fy > 0.0f))
    return Status::kBadArgument;
  if (f.width > max_width_ || f.height > max_height_) return Status::kFrameTooLarge;
  if (state_->width != f.width || state_->height != f.height) {
    reset();
    state_->width = f.width;
    state_->height = f.height;
  }
  const uint64_t t0 = seg::segmentation_cycles_now();
  seg::fit_floor(*config_, f, state_->frames, samples_, inlier_, floor_, r);
  const uint64_t t1 = seg::segmentation_cycles_now();
  r->candidate_pixels = seg::classify_pixels(*config_, f, *floor_, background_, state_->frames, stages_.parent_, stages_.aux_);
  const uint64_t t2 = seg::segmentation_cycles_now();
  const int32_t candidates = stages_.label_components(f, r);
  const uint64_t t3 = seg::segmentation_cycles_now();
  stages_.assign_users(f, candidates, r);
  if (config_->background_enabled) seg::update_background(*config_, f, labels, r, state_->frames, background_);
  if (state_->frames < config_->background_learn_frames && config_->background_enabled)
    r->flags |= kSegFlagBackgroundLearning;
  if (state_->frames < 0x7fffffff) ++state_->frames;
  const uint64_t t4 = seg::segmentation_cycles_now();
  r->stage_cycles[kSegStageFloor] = t1 - t0;
  r->stage_cycles[kSegStageBackground] = t2 - t1;
  r->stage_cycles[kSegStageComponents] = t3 - t2;
  r->stage_cycles[kSegStageUsers] = t4 - t3;
  r->total_cycles = t4 - t0;
  return Status::kOk;
}

void Segmenter::take(Segmenter& o) {
  config_ = o.config_;
  max_width_ = o.max_width_;
  max_height_ = o.max_height_;
  arena_used_ = o.arena_used_;
  initialized_ = o.initialized_;
  background_ = o.background_;
  floor_ = o.floor_;
  state_ = o.state_;
  samples_ = o.samples_;
  inlier_ = o.inlier_;
  stages_ = o.stages_;
  o.initialized_ = false;
  o.config_ = nullptr;
  o.background_ = nullptr;
  o.floor_ = nullptr;
  o.state_ = nullptr;
  o.samples_ = nullptr;
  o.inlier_ = nullptr;
  o.stages_ = seg::UserStage{};
}

}  // namespace dp
