#include "tools/app/reid_eval.h"

#include <algorithm>
#include <memory>

#include <nlohmann/json.hpp>

#include "platform/arena_memory.h"
#include "runtime/segmentation/segmenter.h"
#include "tools/common/dataset.h"
#include "tools/common/error.h"
#include "tools/common/png_io.h"

namespace dp::tools {

namespace {

constexpr int kFindFrames = 30;  // frames after entering within which a person must be found

// The id labelling most of person `person`'s (1-based) pixels, 0 when none is labelled.
int id_of(const ImageU8& people, const std::vector<uint8_t>& labels, int person) {
  int votes[kMaxUsers + 1] = {};
  for (size_t p = 0; p < labels.size(); ++p)
    if (people.pixels[p] == person && labels[p] > 0 && labels[p] <= kMaxUsers) ++votes[labels[p]];
  int best = 0;
  for (int id = 1; id <= kMaxUsers; ++id)
    if (votes[id] > votes[best]) best = id;
  return best;
}

const UserInfo* user_with_id(const SegmentationResult& r, int id) {
  for (int i = 0; i < r.user_count; ++i)
    if (r.users[i].id == id) return &r.users[i];
  return nullptr;
}

// One run over a sequence; `visible(person, frame)` says who is in view (the others' pixels
// become "no reading"). Calls `observe(frame, people, labels, result)` after each frame.
template <typename Visible, typename Observe>
void run_sequence(const Dataset& ds, size_t frames, bool reid, Visible visible, Observe observe) {
  const int w = ds.meta.width, h = ds.meta.height;
  const size_t bytes = segmenter_required_bytes(w, h);
  const platform::ArenaMemory arena(bytes);
  Segmenter segmenter;
  SegmenterConfig config = default_segmenter_config(true);
  if (!reid) config.reid_window_frames = 0;
  if (Status s = segmenter.init(config, w, h, arena.data(), bytes); s != Status::kOk)
    fail(ds.dir + ": segmenter init: " + status_message(s));
  std::vector<uint8_t> labels(size_t(w) * h);
  auto result = std::make_unique<SegmentationResult>();
  const CameraIntrinsics intr{float(ds.meta.fx), float(ds.meta.fy), float(ds.meta.cx), float(ds.meta.cy)};
  for (size_t i = 0; i < frames; ++i) {
    ImageU16 depth = ds.load_depth(i);
    const std::string path = ds.dir + "/people/" + ds.frames[i].id + ".png";
    const ImageU8 people = read_png_u8(path);
    if (people.width != w || people.height != h) fail(path + ": not " + std::to_string(w) + "x" + std::to_string(h));
    for (size_t p = 0; p < depth.pixels.size(); ++p)
      if (people.pixels[p] > 0 && !visible(int(people.pixels[p]), int(i))) depth.pixels[p] = 0;
    const DepthFrame frame{depth.pixels.data(), w, h, w, intr, nullptr};
    result->labels = labels.data();
    if (Status s = segmenter.process(frame, result.get()); s != Status::kOk)
      fail(ds.dir + " frame " + ds.frames[i].id + ": segmenter: " + status_message(s));
    observe(int(i), people, labels, *result);
  }
}

int people_in(const Dataset& ds) {
  const nlohmann::json extra = nlohmann::json::parse(ds.frames[0].extra_json.empty() ? "{}" : ds.frames[0].extra_json);
  return extra.contains("people") && extra["people"].is_array() ? int(extra["people"].size()) : 1;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

const char* reid_outcome_name(int outcome) {
  switch (outcome) {
    case kReidSame: return "same";
    case kReidNew: return "new";
    case kReidOther: return "other";
    case kReidFalse: return "false";
    case kReidUnseen: return "unseen";
  }
  return "?";
}

std::vector<ReidSequenceResult> evaluate_reid(const ReidEvalOptions& o) {
  if (o.datasets.empty()) fail("reid-eval: no dataset given (--data DIR[,DIR...])");
  if (o.leave_frame < 1 || o.gap_frames < 1) fail("reid-eval: --leave and --gap must be at least 1");
  std::vector<ReidSequenceResult> out;
  for (const std::string& dir : o.datasets) {
    const Dataset ds = open_dataset(dir);
    if (people_in(ds) < 2) fail(dir + ": needs two or more people (synth --people 2)");
    const size_t back = size_t(o.leave_frame + o.gap_frames);
    if (ds.frames.size() <= back)
      fail(dir + ": " + std::to_string(ds.frames.size()) + " frames, needs more than --leave + --gap = " + std::to_string(back));
    const size_t frames = std::min(ds.frames.size(), back + kFindFrames);
    ReidSequenceResult res;
    res.dataset = dir;

    // Return run: person 1 leaves and comes back.
    int id_before = 0;
    std::vector<int> held_by_others;
    std::vector<double> heights;
    run_sequence(
        ds, frames, o.reid, [&](int person, int f) { return person != 1 || f < o.leave_frame || f >= int(back); },
        [&](int f, const ImageU8& people, const std::vector<uint8_t>& labels, const SegmentationResult& r) {
          const int id = id_of(people, labels, 1);
          if (f < o.leave_frame) {
            if (id) {
              id_before = id;
              if (const UserInfo* u = user_with_id(r, id)) heights.push_back(u->top_height_m);
            }
          } else if (f >= int(back) && id && id_before) {
            if (res.return_outcome == kReidUnseen)
              if (const UserInfo* u = user_with_id(r, id)) res.person1_back_height_m = u->top_height_m;
            res.return_outcome = id == id_before ? kReidSame
                                 : std::find(held_by_others.begin(), held_by_others.end(), id) != held_by_others.end()
                                     ? kReidOther
                                     : kReidNew;
          }
          if (f < int(back))
            for (int i = 0; i < r.user_count; ++i)
              if (r.users[i].id != id_before || f >= o.leave_frame) held_by_others.push_back(r.users[i].id);
        });
    res.person1_height_m = median(heights);

    // Newcomer run: person 1 leaves for good; person 2 first enters after the gap.
    int id_person1 = 0;
    std::vector<int> held;
    run_sequence(
        ds, frames, o.reid,
        [&](int person, int f) { return person == 1 ? f < o.leave_frame : person != 2 || f >= int(back); },
        [&](int f, const ImageU8& people, const std::vector<uint8_t>& labels, const SegmentationResult& r) {
          if (f < o.leave_frame) {
            if (const int id = id_of(people, labels, 1)) id_person1 = id;
          }
          const int id2 = f >= int(back) ? id_of(people, labels, 2) : 0;
          if (id2 && id_person1) {
            if (res.newcomer_outcome == kReidUnseen)
              if (const UserInfo* u = user_with_id(r, id2)) res.person2_height_m = u->top_height_m;
            res.newcomer_outcome = id2 == id_person1 ? kReidFalse
                                   : std::find(held.begin(), held.end(), id2) != held.end() ? kReidOther
                                                                                             : kReidNew;
          }
          if (f < int(back))
            for (int i = 0; i < r.user_count; ++i)
              if (r.users[i].id != id_person1) held.push_back(r.users[i].id);
        });
    out.push_back(res);
  }
  return out;
}

}  // namespace dp::tools
