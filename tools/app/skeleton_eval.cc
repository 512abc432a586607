#include "tools/app/skeleton_eval.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include <nlohmann/json.hpp>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "platform/arena_memory.h"
#include "tools/common/blob_error.h"
#include "tools/common/body_model.h"
#include "tools/common/dataset.h"
#include "tools/common/error.h"
#include "tools/common/png_io.h"

namespace dp::tools {

namespace {

constexpr double kHitM = 0.1;            // "within 0.1 m of the truth"
constexpr double kStillM = 0.005;        // truth moved less than this between frames: a still joint
constexpr double kFastM = 1.5 / 30.0;    // truth moved more than this (1.5 m/s at 30 Hz): fast motion
constexpr int kMaxLag = 8;
constexpr int kMinBodyPixels = 200;      // a body with fewer pixels in view is not scored

using Vec = std::array<double, 3>;
double dist(const Vec& a, const Vec& b) { return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]); }

// Ground-truth joints of every body of frame i (body k+1 = entry k).
std::vector<std::vector<JointTruth>> bodies_of(const Dataset& ds, size_t i) {
  const FrameRecord& r = ds.frames[i];
  const nlohmann::json extra = nlohmann::json::parse(r.extra_json.empty() ? "{}" : r.extra_json);
  std::vector<std::vector<JointTruth>> out;
  if (!extra.contains("people")) {
    out.push_back(r.joints);
    return out;
  }
  const std::string frame = ds.dir + "/frames.jsonl frame " + r.id;
  for (const nlohmann::json& p : extra["people"]) {
    const std::string where = frame + " person " + std::to_string(out.size() + 1);
    if (!p.is_object() || !p.contains("joints") || !p["joints"].is_array() || p["joints"].size() != ds.meta.joints.size())
      fail(where + ": no \"joints\" array of " + std::to_string(ds.meta.joints.size()) + " joints");
    std::vector<JointTruth> joints;
    for (const nlohmann::json& j : p["joints"]) joints.push_back(joint_truth_from_json(j, where));
    out.push_back(std::move(joints));
  }
  return out;
}

// Per (dataset, body): the truth and each tracker's output over the frames, for jitter and lag.
struct Track {
  std::vector<std::array<Vec, kSkeletonJoints>> truth;
  std::vector<std::vector<std::array<Vec, kSkeletonJoints>>> out;   // [filter][frame]
  std::vector<std::vector<std::array<bool, kSkeletonJoints>>> located;
};

bool is_left_right(int j) { return j >= kShoulderL; }
int mirror(int j) { return j + ((j - kShoulderL) % 2 == 0 ? 1 : -1); }

// A left/right swap: the joint lies at its mirror joint's place (within 0.1 m of the mirror's
// truth) and not at its own.
bool swapped(int j, const Vec& p, const std::array<Vec, kSkeletonJoints>& truth) {
  const double own = dist(p, truth[size_t(j)]), other = dist(p, truth[size_t(mirror(j))]);
  return own > kHitM && other <= kHitM;
}
// Looser: off by more than 0.1 m and nearer the mirror's truth than its own.
bool nearer_mirror(int j, const Vec& p, const std::array<Vec, kSkeletonJoints>& truth) {
  const double own = dist(p, truth[size_t(j)]);
  return own > kHitM && dist(p, truth[size_t(mirror(j))]) < own;
}

void add_filter_figures(const std::vector<Track>& tracks, size_t f, FilterFigures* fig) {
  double still_sq = 0;
  std::array<double, kMaxLag + 1> lag_sum{};
  std::array<long, kMaxLag + 1> lag_n{};
  long hits = 0, total = 0;
  for (const Track& t : tracks) {
    const size_t n = t.truth.size();
    for (size_t i = 0; i < n; ++i)
      for (int j = 0; j < kSkeletonJoints; ++j) {
        ++total;
        if (t.located[f][i][size_t(j)] && dist(t.out[f][i][size_t(j)], t.truth[i][size_t(j)]) <= kHitM) ++hits;
        if (i == 0) continue;
        const double moved = dist(t.truth[i][size_t(j)], t.truth[i - 1][size_t(j)]);
        const bool both = t.located[f][i][size_t(j)] && t.located[f][i - 1][size_t(j)];
        if (both && moved < kStillM) {
          const double d = dist(t.out[f][i][size_t(j)], t.out[f][i - 1][size_t(j)]);
          still_sq += d * d;
          ++fig->still_samples;
        }
        if (both && moved > kFastM && i >= size_t(kMaxLag)) {
          ++fig->fast_samples;
          for (int s = 0; s <= kMaxLag; ++s) {
            lag_sum[size_t(s)] += dist(t.out[f][i][size_t(j)], t.truth[i - size_t(s)][size_t(j)]);
            ++lag_n[size_t(s)];
          }
        }
      }
  }
  fig->jitter_mm = fig->still_samples ? 1000.0 * std::sqrt(still_sq / double(fig->still_samples)) : 0;
  fig->within_rate = total ? double(hits) / double(total) : 0;
  if (fig->fast_samples) {
    int best = 0;
    for (int s = 1; s <= kMaxLag; ++s)
      if (lag_sum[size_t(s)] < lag_sum[size_t(best)]) best = s;
    double lag = best;
    if (best > 0 && best < kMaxLag) {  // parabola through the minimum and its neighbours
      const double a = lag_sum[size_t(best - 1)], b = lag_sum[size_t(best)], c = lag_sum[size_t(best + 1)];
      const double den = a - 2 * b + c;
      if (den > 0) lag += 0.5 * (a - c) / den;
    }
    fig->lag_frames = lag;
  }
}

}  // namespace

SwapCause swap_cause(int j, const Skeleton& sk, const std::array<Position, kSkeletonJoints>& out,
                     const std::array<bool, kSkeletonJoints>& located, const std::array<Position, kSkeletonJoints>& truth,
                     bool has_first, const Position& first) {
  const TrackedJoint& tj = sk.joints[j];
  SwapCause c{};
  c.choice = tj.proposal < 0 ? SwapChoice::kPrediction
             : tj.proposal_joint != j ? SwapChoice::kMirrorProposal
             : tj.proposal == 0 ? SwapChoice::kOwnFirst
                                : SwapChoice::kOwnOther;
  // The true facing, up × (shoulder_l − shoulder_r) in the horizontal plane, against the tracker's.
  const Vec& tl = truth[size_t(kShoulderL)];
  const Vec& tr = truth[size_t(kShoulderR)];
  const double true_facing_x = tl[2] - tr[2], true_facing_z = -(tl[0] - tr[0]);
  c.facing_crossed = sk.facing_known && sk.facing[0] * true_facing_x + sk.facing[2] * true_facing_z < 0.0;
  const int parent = skeleton_parent(j);
  c.parent_swapped = is_left_right(parent) && located[size_t(parent)] && swapped(parent, out[size_t(parent)], truth);
  // Left-minus-right along the true axis to the subject's left: negative when the pair is crossed.
  const int m = mirror(j);
  const double side = (j - kShoulderL) % 2 == 0 ? 1.0 : -1.0;  // +1 for a left joint
  double order = 0;
  for (size_t a = 0; a < 3; ++a) order += side * (out[size_t(j)][a] - out[size_t(m)][a]) * (tl[a] - tr[a]);
  c.pair_crossed = located[size_t(m)] && order < 0.0;
  c.first_right = has_first && dist(first, truth[size_t(j)]) <= kHitM;
  return c;
}

void add_frame_figures(const Skeleton& sk, const FrameResult& proposals, const std::array<Position, kSkeletonJoints>& truth,
                       const std::array<bool, kSkeletonJoints>& visible, SkeletonEvalReport* rep_out) {
  SkeletonEvalReport& rep = *rep_out;
  // Every joint's output first: a swap's cause reads the mirror joint's, which for a left joint
  // comes later in the joint order.
  std::array<Vec, kSkeletonJoints> out{};
  std::array<bool, kSkeletonJoints> located{};
  for (int j = 0; j < kSkeletonJoints; ++j) {
    const TrackedJoint& tj = sk.joints[j];
    located[size_t(j)] = tj.state != JointState::kMissing;
    out[size_t(j)] = {tj.x_m, tj.y_m, tj.z_m};
  }
  for (int j = 0; j < kSkeletonJoints; ++j) {
    const TrackedJoint& tj = sk.joints[j];
    ++rep.state_count[size_t(tj.state)];
    const bool hit = located[size_t(j)] && dist(out[size_t(j)], truth[size_t(j)]) <= kHitM;
    if (located[size_t(j)]) {
      const int bin = std::min(9, int(tj.confidence * 10.0f));
      ++rep.bin_count[size_t(bin)];
      rep.bin_confidence_sum[size_t(bin)] += tj.confidence;
      rep.bin_hits[size_t(bin)] += hit;
      const int cls = tj.evidence;
      ++rep.class_count[size_t(cls)];
      rep.class_hits[size_t(cls)] += hit;
    }
    ++rep.joint_frames[size_t(j)];
    rep.tracker_hits[size_t(j)] += hit;
    const bool has_proposal = proposals.proposal_count[j] > 0;
    const JointProposal& p0 = proposals.proposals[j][0];
    const Vec first{p0.x_m, p0.y_m, p0.z_m};
    rep.proposal_hits[size_t(j)] += has_proposal && dist(first, truth[size_t(j)]) <= kHitM;
    if (!is_left_right(j)) continue;
    ++rep.lr_joint_frames;
    const bool proposal_swap = has_proposal && swapped(j, first, truth);
    const bool tracker_swap = located[size_t(j)] && swapped(j, out[size_t(j)], truth);
    rep.proposal_swaps += proposal_swap;
    rep.tracker_swaps += tracker_swap;
    if (visible[size_t(j)]) {
      ++rep.lr_visible_joint_frames;
      rep.proposal_swaps_visible += proposal_swap;
      rep.tracker_swaps_visible += tracker_swap;
    }
    rep.proposal_swaps_by_joint[size_t(j)] += proposal_swap;
    rep.proposal_nearer_mirror += has_proposal && nearer_mirror(j, first, truth);
    rep.tracker_nearer_mirror += located[size_t(j)] && nearer_mirror(j, out[size_t(j)], truth);
    rep.tracker_swaps_by_joint[size_t(j)] += tracker_swap;
    if (tracker_swap) {
      const SwapCause cause = swap_cause(j, sk, out, located, truth, has_proposal, first);
      ++rep.tracker_swap_choice[size_t(j)][size_t(cause.choice)];
      rep.tracker_swap_facing_flipped[size_t(j)] += cause.facing_crossed;
      rep.tracker_swap_parent_swapped[size_t(j)] += cause.parent_swapped;
      rep.tracker_swap_pair_crossed[size_t(j)] += cause.pair_crossed;
      rep.tracker_swap_first_right[size_t(j)] += cause.first_right;
    }
  }
}

SequenceIntervals sequence_intervals(const std::vector<SequenceFigures>& sequences, int resamples, uint64_t seed) {
  SequenceIntervals out;
  if (sequences.empty() || resamples < 1) return out;
  auto figures = [](const SequenceFigures& sum, double* gain, double* change) {
    const double n = double(std::max(1L, sum.joint_frames));
    *gain = double(sum.tracker_hits - sum.proposal_hits) / n;
    *change = sum.proposal_swaps > 0 ? double(sum.tracker_swaps) / double(sum.proposal_swaps) - 1.0 : 0.0;
  };
  auto add = [](SequenceFigures* sum, const SequenceFigures& s) {
    sum->joint_frames += s.joint_frames;
    sum->proposal_hits += s.proposal_hits;
    sum->tracker_hits += s.tracker_hits;
    sum->proposal_swaps += s.proposal_swaps;
    sum->tracker_swaps += s.tracker_swaps;
  };
  SequenceFigures all;
  for (const SequenceFigures& s : sequences) add(&all, s);
  figures(all, &out.gain, &out.swap_change);
  // splitmix64: a fixed, portable stream (std:: distributions differ between standard libraries).
  uint64_t state = seed;
  auto next = [&state]() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  };
  std::vector<double> gains(static_cast<size_t>(resamples)), changes(static_cast<size_t>(resamples));
  for (int r = 0; r < resamples; ++r) {
    SequenceFigures sum;
    for (size_t i = 0; i < sequences.size(); ++i) add(&sum, sequences[size_t(next() % sequences.size())]);
    figures(sum, &gains[size_t(r)], &changes[size_t(r)]);
  }
  std::sort(gains.begin(), gains.end());
  std::sort(changes.begin(), changes.end());
  const size_t lo = size_t(0.025 * double(resamples - 1) + 0.5), hi = size_t(0.975 * double(resamples - 1) + 0.5);
  out.gain_low = gains[lo];
  out.gain_high = gains[hi];
  out.swap_change_low = changes[lo];
  out.swap_change_high = changes[hi];
  return out;
}

SkeletonEvalReport evaluate_skeletons(const SkeletonEvalOptions& o) {
  std::vector<uint8_t> blob_bytes = blob::read_blob_file(o.blob_path);
  const blob::LoadedBlob b = load_blob_or_fail(blob_bytes, o.blob_path);
  if (o.datasets.empty()) fail("skeleton-eval: no dataset given (--data DIR[,DIR...])");

  std::vector<SkeletonFilterParams> filters = {skeleton_filter_preset(SkeletonFilterPreset::kOff),
                                               skeleton_filter_preset(SkeletonFilterPreset::kDefault),
                                               skeleton_filter_preset(SkeletonFilterPreset::kStrong)};
  filters.insert(filters.end(), o.sweep.begin(), o.sweep.end());
  constexpr size_t kDefaultFilter = 1;

  SkeletonEvalReport rep;
  std::vector<Track> tracks;
  double tracker_cycles = 0, pipeline_cycles = 0;
  long tracker_updates = 0;
  // The report's running counts as one sequence's figures; a dataset's share is the difference.
  auto running = [&rep]() {
    SequenceFigures f;
    for (int j = 0; j < kSkeletonJoints; ++j) {
      f.joint_frames += rep.joint_frames[size_t(j)];
      f.proposal_hits += rep.proposal_hits[size_t(j)];
      f.tracker_hits += rep.tracker_hits[size_t(j)];
    }
    f.proposal_swaps = rep.proposal_swaps;
    f.tracker_swaps = rep.tracker_swaps;
    return f;
  };
  for (const std::string& dir : o.datasets) {
    const SequenceFigures before = running();
    const Dataset ds = open_dataset(dir);
    const int w = ds.meta.width, h = ds.meta.height;
    if (ds.meta.joints.size() != size_t(kSkeletonJoints))
      fail(dir + ": meta.json names " + std::to_string(ds.meta.joints.size()) + " joints, the tracker wants 16");
    if (!ds.has_parts) fail(dir + ": no parts/ (the body masks come from it)");
    const size_t arena_bytes = required_arena_bytes(b, w, h);
    if (!arena_bytes) fail(o.blob_path + " cannot run on " + dir + "'s " + std::to_string(w) + "x" + std::to_string(h) + " frames");
    const platform::ArenaMemory arena(arena_bytes);
    Pipeline pipeline;
    if (Status s = pipeline.init(b, w, h, arena.data(), arena_bytes); s != Status::kOk)
      fail(std::string("pipeline init: ") + status_message(s));
    std::vector<std::unique_ptr<SkeletonTracker>> trackers;
    for (const SkeletonFilterParams& p : filters) {
      trackers.push_back(std::make_unique<SkeletonTracker>());
      SkeletonConfig c = default_skeleton_config();
      c.filter = p;
      if (Status s = trackers.back()->init(*b.meta, c); s != Status::kOk)
        fail(o.blob_path + ": the skeleton tracker refuses it (" + status_message(s) +
             "): its joints must be the 16 of docs/dataset_format.md, in that order");
    }
    const size_t frames = o.max_frames < 0 ? ds.frames.size() : std::min(ds.frames.size(), size_t(o.max_frames));
    const size_t first_track = tracks.size();
    std::vector<uint8_t> mask(size_t(w) * h);
    auto result = std::make_unique<FrameResult>();
    const CameraIntrinsics intr{float(ds.meta.fx), float(ds.meta.fy), float(ds.meta.cx), float(ds.meta.cy)};
    for (size_t i = 0; i < frames; ++i) {
      const ImageU16 depth = ds.load_depth(i);
      const ImageU8 parts = ds.load_parts(i);
      const std::vector<std::vector<JointTruth>> bodies = bodies_of(ds, i);
      ImageU8 people;
      if (bodies.size() > 1) {
        const std::string path = dir + "/people/" + ds.frames[i].id + ".png";
        people = read_png_u8(path);
        if (people.width != w || people.height != h) fail(path + ": not " + std::to_string(w) + "x" + std::to_string(h));
      }
      if (i == 0)
        for (size_t k = 0; k < bodies.size(); ++k) {
          Track t;
          t.out.resize(filters.size());
          t.located.resize(filters.size());
          tracks.push_back(std::move(t));
        }
      if (tracks.size() - first_track != bodies.size()) fail(dir + ": the number of people changes at frame " + ds.frames[i].id);
      ++rep.frames;
      for (auto& t : trackers) t->begin_frame();
      for (size_t k = 0; k < bodies.size(); ++k) {
        int pixels = 0;
        for (size_t p = 0; p < mask.size(); ++p) {
          const bool body = parts.pixels[p] != kNotBodyLabel && depth.pixels[p] &&
                            (bodies.size() == 1 || people.pixels[p] == k + 1);
          mask[p] = body;
          pixels += body;
        }
        Track& track = tracks[first_track + k];
        std::array<Vec, kSkeletonJoints> truth;
        std::array<bool, kSkeletonJoints> visible{};
        for (int j = 0; j < kSkeletonJoints; ++j) {
          truth[size_t(j)] = {bodies[k][size_t(j)].x, bodies[k][size_t(j)].y, bodies[k][size_t(j)].z};
          visible[size_t(j)] = bodies[k][size_t(j)].visible;
        }
        track.truth.push_back(truth);
        const bool scored = pixels >= kMinBodyPixels;
        if (scored) {
          const DepthFrame frame{depth.pixels.data(), w, h, w, intr, mask.data()};
          if (Status s = pipeline.process(frame, result.get()); s != Status::kOk)
            fail(dir + " frame " + ds.frames[i].id + ": " + status_message(s));
          pipeline_cycles += double(result->total_cycles);
          ++rep.body_frames;
        }
        for (size_t f = 0; f < filters.size(); ++f) {
          std::array<Vec, kSkeletonJoints> out{};
          std::array<bool, kSkeletonJoints> located{};
          if (scored) {
            Skeleton sk;
            if (Status s = trackers[f]->update(int32_t(k + 1), *result, &sk); s != Status::kOk)
              fail(std::string("tracker: ") + status_message(s));
            if (f == kDefaultFilter) {
              tracker_cycles += double(sk.cycles);
              ++tracker_updates;
            }
            for (int j = 0; j < kSkeletonJoints; ++j) {
              const TrackedJoint& tj = sk.joints[j];
              located[size_t(j)] = tj.state != JointState::kMissing;
              out[size_t(j)] = {tj.x_m, tj.y_m, tj.z_m};
            }
            if (f == kDefaultFilter) add_frame_figures(sk, *result, truth, visible, &rep);
          }
          track.out[f].push_back(out);
          track.located[f].push_back(located);
        }
      }
    }
    const SequenceFigures after = running();
    rep.sequences.push_back({after.joint_frames - before.joint_frames, after.proposal_hits - before.proposal_hits,
                             after.tracker_hits - before.tracker_hits, after.proposal_swaps - before.proposal_swaps,
                             after.tracker_swaps - before.tracker_swaps});
  }
  for (size_t f = 0; f < filters.size(); ++f) {
    FilterFigures fig;
    fig.params = filters[f];
    add_filter_figures(tracks, f, &fig);
    rep.filters.push_back(fig);
  }
  rep.tracker_cycles_per_user_frame = tracker_updates ? tracker_cycles / double(tracker_updates) : 0;
  rep.pipeline_cycles_per_user_frame = rep.body_frames ? pipeline_cycles / double(rep.body_frames) : 0;
  return rep;
}

}  // namespace dp::tools
