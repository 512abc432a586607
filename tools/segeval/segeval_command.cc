// `depthpose segeval`: how well dp::Segmenter finds the people of a labelled dataset (foreground
// IoU, people found, false users, cycles) and, with --blob, joint mAP with the segmenter's mask
// against the ground-truth mask. docs/segmentation.md describes the protocol.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>

#include "platform/arena_memory.h"
#include "runtime/segmentation/segmenter.h"
#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/body_model.h"
#include "tools/common/dataset.h"
#include "tools/common/error.h"
#include "tools/common/file_io.h"
#include "tools/common/png_io.h"
#include "tools/eval/metrics.h"
#include "tools/info/info.h"
#include "tools/segeval/segmentation_digest.h"
#include "tools/segeval/segmenter_config_text.h"

namespace dp::tools {
namespace {

using json = nlohmann::json;

static const char* const kUsage =
    "usage: depthpose segeval --data DATASET [--blob BLOB] [--frames N] [--live] [--json OUT.json]\n"
    "                         [--dtp D] [--min-visible-joints K]\n"
    "  Runs dp::Segmenter over a labelled dataset (layout v1 with parts/; people/ and the \"people\" key of\n"
    "  frames.jsonl for several bodies, see docs/dataset_format.md) and reports foreground IoU against the\n"
    "  ground-truth body mask, the share of people found, false users per frame and the segmenter's cycles.\n"
    "  With --blob: joint mAP per person with the segmenter's mask against the ground-truth mask of that\n"
    "  person (the whole chain per user over that user's pixels alone, as depthpose run does).\n"
    "  --live                 background model on (frames in sequence from a fixed camera); default off\n"
    "  --forest-once          with --blob: run the forest once per frame over all users, then votes and mean\n"
    "                         shift per user (Pipeline::process_user), instead of the whole chain per user\n"
    "  --dtp D                true-positive radius in metres (default 0.1)\n"
    "  --min-visible-joints K a person counts for the detection rate with >= K of 16 joints visible (default 8)\n"
    "  --min-visible-area A  a third detection rate over people with >= A m^2 of body surface in view\n"
    "                         (default 0.05, about a head and neck; a person showing less is not expected)\n"
    "  --dump DIR             write DIR/NNNNNN.png per frame: depth in grey, users in colour, missed body red\n"
    "  --digest OUT.txt       one line per frame: frame id and a 64-bit digest of everything the segmenter\n"
    "                         output (labels, users, floor, counts, flags; not the cycles), to compare two builds\n"
    "  --per-frame OUT.jsonl  one line per frame: people (pixels, visible joints, box, border, matched user, IoU),\n"
    "                         users (pixels, body pixels, top, matched person), missed and extra pixels by height\n"
    "  --segment-config FILE  SegmenterConfig settings (key = value lines or a JSON object; strict: an unknown\n"
    "                         key or a bad or out-of-range value is an error), over the defaults\n"
    "  --set K=V,...          override SegmenterConfig fields after --segment-config (same keys and checks)\n"
    "  --print-config-table   print the SegmenterConfig table (key, type, default, range, unit, meaning) as\n"
    "                         Markdown, as in docs/segmentation.md, and exit";

struct Person {
  std::vector<JointTruth> joints;
  int pixels = 0;
  int visible_joints = 0;
  double visible_area_m2 = 0;  // Σ (z/fx)·(z/fy) over the person's pixels: body surface in view
};

std::vector<Person> people_of(const Dataset& ds, size_t i) {
  const FrameRecord& r = ds.frames[i];
  std::vector<Person> out;
  const json extra = json::parse(r.extra_json.empty() ? "{}" : r.extra_json);
  if (extra.contains("people")) {
    const std::string frame = ds.dir + "/frames.jsonl frame " + r.id;
    if (!extra["people"].is_array()) fail(frame + ": \"people\" is not an array");
    for (const json& p : extra["people"]) {
      const std::string where = frame + " person " + std::to_string(out.size() + 1);
      if (!p.is_object() || !p.contains("joints") || !p["joints"].is_array())
        fail(where + ": no \"joints\" array");
      if (p["joints"].size() != ds.meta.joints.size())
        fail(where + ": has " + std::to_string(p["joints"].size()) + " joints, meta.json names " +
             std::to_string(ds.meta.joints.size()));
      Person person;
      for (const json& j : p["joints"]) person.joints.push_back(joint_truth_from_json(j, where));
      out.push_back(std::move(person));
    }
  } else {
    out.push_back(Person{r.joints, 0, 0});
  }
  for (Person& p : out)
    for (const JointTruth& t : p.joints) p.visible_joints += t.visible;
  return out;
}

int run_segeval(int argc, char** argv) {
  Args a(argc, argv, kUsage, {"--data", "--blob", "--frames", "--json", "--dtp", "--min-visible-joints", "--min-visible-area", "--dump", "--set", "--per-frame", "--digest", "--segment-config"},
         {"--live", "--forest-once", "--print-config-table"});
  if (a.help_requested()) {
    std::printf("%s\n", a.usage().c_str());
    return 0;
  }
  if (a.flag("--print-config-table")) {
    std::printf("%s", segmenter_config_table_markdown().c_str());
    return 0;
  }
  // The config first: a bad file or --set fails before any data is read.
  SegmenterConfig cfg = default_segmenter_config(a.flag("--live"));
  if (a.has("--segment-config")) cfg = load_segmenter_config_file(a.get("--segment-config"), cfg);
  if (a.has("--set")) {
    for (const std::string& kv : split_list(a.get("--set"))) {
      const size_t eq = kv.find('=');
      if (eq == std::string::npos) fail("--set wants K=V, got '" + kv + "'");
      set_segmenter_config_field(&cfg, kv.substr(0, eq), kv.substr(eq + 1), "--set");
    }
    check_segmenter_config_constraints(cfg, "--set");
  }
  const std::string dir = a.get("--data");
  const Dataset ds = open_dataset(dir);
  if (!ds.has_parts) fail(dir + ": segeval needs the ground-truth body mask (parts/)");
  const bool multi = std::filesystem::is_directory(dir + "/people");
  const long max_frames = long(a.get_int("--frames", 0));
  const long frames = max_frames > 0 ? std::min<long>(max_frames, long(ds.frames.size())) : long(ds.frames.size());
  const double d_tp = a.get_double("--dtp", 0.1);
  const int min_visible = int(a.get_int("--min-visible-joints", 8));
  const double min_area = a.get_double("--min-visible-area", 0.05);
  const int w = ds.meta.width, h = ds.meta.height;
  const CameraIntrinsics intr{float(ds.meta.fx), float(ds.meta.fy), float(ds.meta.cx), float(ds.meta.cy)};

  Segmenter seg;
  const size_t seg_bytes = segmenter_required_bytes(w, h);
  const platform::ArenaMemory seg_arena(seg_bytes);
  if (Status s = seg.init(cfg, w, h, seg_arena.data(), seg_bytes); s != Status::kOk)
    fail(std::string("segeval: segmenter init: ") + status_message(s));

  // Optional pipeline for joints.
  std::vector<uint8_t> blob_bytes;
  blob::LoadedBlob blob{};
  Pipeline pipeline;
  platform::ArenaMemory pipe_arena;
  std::vector<int> joint_blob, joint_data;  // evaluated joints: blob index, dataset index
  const bool joints = a.has("--blob");
  if (joints) {
    blob = load_blob_file_checked(a.get("--blob"), blob_bytes);
    const size_t n = required_arena_bytes(blob, w, h);
    pipe_arena = platform::ArenaMemory(n);
    if (Status s = pipeline.init(blob, w, h, pipe_arena.data(), n); s != Status::kOk)
      fail(a.get("--blob") + ": pipeline init: " + status_message(s));
    for (int j = 0; j < blob.meta->joint_count; ++j) {
      const std::string name(blob.meta->joint_names[j], strnlen(blob.meta->joint_names[j], blob::kNameBytes));
      for (size_t d = 0; d < ds.meta.joints.size(); ++d)
        if (ds.meta.joints[d] == name) {
          joint_blob.push_back(j);
          joint_data.push_back(int(d));
        }
    }
    if (joint_blob.empty()) fail(a.get("--blob") + ": no joint name in common with " + dir + "/meta.json");
  }
  std::vector<JointSamples> seg_samples(joint_blob.size()), gt_samples(joint_blob.size());
  // The same two runs over the people the Segmenter found only: how much of the gap is the masks
  // of the people found rather than the people missed.
  std::vector<JointSamples> seg_found(joint_blob.size()), gt_found(joint_blob.size());

  std::vector<uint8_t> labels(size_t(w) * h), own_mask(size_t(w) * h);
  const bool forest_per_user = !a.flag("--forest-once");
  std::unique_ptr<AtomicOutputFile> per_frame, digest_out;
  if (a.has("--per-frame")) per_frame = std::make_unique<AtomicOutputFile>(a.get("--per-frame"));
  if (a.has("--digest")) digest_out = std::make_unique<AtomicOutputFile>(a.get("--digest"));
  double inter_total = 0, union_total = 0, iou_sum = 0;
  long people_total = 0, people_found = 0, findable_total = 0, findable_found = 0, false_users = 0;
  long sizable_total = 0, sizable_found = 0;
  long frames_with_false = 0;
  std::array<double, kSegStageCount> stage_cycles{};
  double seg_cycles = 0, seg_wall_s = 0, user_joint_cycles = 0;
  for (long i = 0; i < frames; ++i) {
    const ImageU16 depth = ds.load_depth(size_t(i));
    const ImageU8 parts = ds.load_parts(size_t(i));
    std::vector<Person> people = people_of(ds, size_t(i));
    std::vector<uint8_t> truth(size_t(w) * h, 0);  // 1 + person index
    if (multi) {
      const std::string path = dir + "/people/" + ds.frames[size_t(i)].id + ".png";
      const ImageU8 img = read_png_u8(path);
      if (img.width != w || img.height != h) fail(path + ": not " + std::to_string(w) + "x" + std::to_string(h));
      for (size_t p = 0; p < truth.size(); ++p) {
        const uint8_t id = parts.pixels[p] != kNotBodyLabel ? img.pixels[p] : 0;
        if (id > people.size()) fail(path + ": body id " + std::to_string(id) + " but frames.jsonl lists " +
                                     std::to_string(people.size()) + " people");
        truth[p] = id;
      }
    } else {
      for (size_t p = 0; p < truth.size(); ++p) truth[p] = parts.pixels[p] != kNotBodyLabel && depth.pixels[p] ? 1 : 0;
    }
    for (size_t p = 0; p < truth.size(); ++p)
      if (truth[p]) {
        Person& person = people[truth[p] - 1];
        person.pixels++;
        const double z = depth.pixels[p] * 0.001;
        person.visible_area_m2 += z * z / (double(intr.fx) * double(intr.fy));
      }

    // Without --live every frame is its own scene (another camera): nothing carries over.
    if (!a.flag("--live")) seg.reset();
    DepthFrame frame{depth.pixels.data(), w, h, w, intr, nullptr};
    SegmentationResult r{};
    r.labels = labels.data();
    const auto t0 = std::chrono::steady_clock::now();
    if (Status s = seg.process(frame, &r); s != Status::kOk)
      fail(ds.depth_path(size_t(i)) + ": segmenter refused the frame: " + status_message(s));
    seg_wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    seg_cycles += double(r.total_cycles);
    for (int s = 0; s < kSegStageCount; ++s) stage_cycles[size_t(s)] += double(r.stage_cycles[s]);
    if (digest_out) {
      char hex[17];
      std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(segmentation_digest(r, w, h, w)));
      digest_out->write(ds.frames[size_t(i)].id + " " + hex + "\n");
    }

    if (a.has("--dump")) {
      ImageRgb img;
      img.resize(w, h);
      static const uint8_t colours[6][3] = {{40, 200, 40}, {40, 120, 255}, {255, 200, 0}, {200, 40, 255}, {0, 220, 220}, {255, 120, 0}};
      for (int v = 0; v < h; ++v)
        for (int u = 0; u < w; ++u) {
          const size_t p = size_t(v) * w + u;
          const uint8_t g = depth.pixels[p] ? uint8_t(255 - std::min(255, depth.pixels[p] / 25)) : 0;
          if (labels[p]) {
            const uint8_t* c = colours[(labels[p] - 1) % 6];
            img.set(u, v, c[0], c[1], c[2]);
          } else if (truth[p]) {
            img.set(u, v, 255, 0, 0);
          } else {
            img.set(u, v, g, g, g);
          }
        }
      std::filesystem::create_directories(a.get("--dump"));
      write_png_rgb(a.get("--dump") + "/" + ds.frames[size_t(i)].id + ".png", img);
    }
    // Foreground IoU.
    long inter = 0, uni = 0;
    for (size_t p = 0; p < truth.size(); ++p) {
      const bool a_ = labels[p] != 0, b_ = truth[p] != 0;
      inter += a_ && b_;
      uni += a_ || b_;
    }
    inter_total += double(inter);
    union_total += double(uni);
    iou_sum += uni ? double(inter) / double(uni) : 1.0;

    // Users ↔ people: greedy by IoU ≥ 0.5.
    const int nu = r.user_count, np = int(people.size());
    std::vector<long> overlap(size_t(nu) * np, 0);
    std::vector<int> user_index(256, -1);
    for (int u = 0; u < nu; ++u) user_index[size_t(r.users[u].id)] = u;
    for (size_t p = 0; p < truth.size(); ++p)
      if (labels[p] && truth[p] && user_index[labels[p]] >= 0)
        overlap[size_t(user_index[labels[p]]) * np + (truth[p] - 1)]++;
    std::vector<int> user_of_person(size_t(np), -1), person_of_user(size_t(nu), -1);
    for (;;) {
      double best = 0.5;
      int bu = -1, bp = -1;
      for (int u = 0; u < nu; ++u)
        for (int p = 0; p < np; ++p) {
          if (person_of_user[size_t(u)] >= 0 || user_of_person[size_t(p)] >= 0) continue;
          const double o = double(overlap[size_t(u) * np + p]);
          const double iou = o / double(r.users[u].pixel_count + people[size_t(p)].pixels - o);
          if (iou >= best) { best = iou; bu = u; bp = p; }
        }
      if (bu < 0) break;
      person_of_user[size_t(bu)] = bp;
      user_of_person[size_t(bp)] = bu;
    }
    long false_here = 0;
    for (int u = 0; u < nu; ++u) false_here += person_of_user[size_t(u)] < 0;
    if (per_frame) {
      // Diagnostics: where the IoU goes. Missed body pixels and extra user pixels by height above
      // the segmenter's floor (when it has one): < 5 cm, 5..15 cm, higher (or no floor).
      json line;
      line["id"] = ds.frames[size_t(i)].id;
      line["inter"] = inter;
      line["union"] = uni;
      line["floor"] = r.floor.valid != 0;
      long missed[3] = {0, 0, 0}, extra[3] = {0, 0, 0}, missed_unmatched = 0;
      for (int v = 0; v < h; ++v)
        for (int u = 0; u < w; ++u) {
          const size_t q = size_t(v) * w + u;
          const bool lab = labels[q] != 0, tru = truth[q] != 0;
          if (lab == tru) continue;
          int bucket = 2;
          if (r.floor.valid && depth.pixels[q]) {
            const float z = depth.pixels[q] * 0.001f;
            const float x = (u - intr.cx) * z / intr.fx, y = -(v - intr.cy) * z / intr.fy;
            const float up = r.floor.nx * x + r.floor.ny * y + r.floor.nz * z + r.floor.d;
            bucket = up < 0.05f ? 0 : up < 0.15f ? 1 : 2;
          }
          if (tru) {
            if (user_of_person[size_t(truth[q] - 1)] < 0) ++missed_unmatched;
            else ++missed[bucket];
          } else {
            ++extra[bucket];
          }
        }
      line["missed_unmatched_person"] = missed_unmatched;
      line["missed_matched_by_height"] = {missed[0], missed[1], missed[2]};
      line["extra_by_height"] = {extra[0], extra[1], extra[2]};
      json ps = json::array();
      for (int p = 0; p < np; ++p) {
        int u0 = w, u1 = -1, v0 = h, v1 = -1;
        for (int v = 0; v < h; ++v)
          for (int u = 0; u < w; ++u)
            if (truth[size_t(v) * w + u] == p + 1) {
              u0 = std::min(u0, u); u1 = std::max(u1, u); v0 = std::min(v0, v); v1 = std::max(v1, v);
            }
        const int mu = user_of_person[size_t(p)];
        double best_iou = 0;
        for (int u = 0; u < nu; ++u) {
          const double o = double(overlap[size_t(u) * np + p]);
          best_iou = std::max(best_iou, o / double(r.users[u].pixel_count + people[size_t(p)].pixels - o));
        }
        ps.push_back({{"pixels", people[size_t(p)].pixels}, {"visible_joints", people[size_t(p)].visible_joints},
                      {"visible_area_m2", people[size_t(p)].visible_area_m2},
                      {"box", {u0, v0, u1, v1}}, {"border", u1 >= 0 && (u0 == 0 || v0 == 0 || u1 == w - 1 || v1 == h - 1)},
                      {"user", mu >= 0 ? r.users[mu].id : 0}, {"best_iou", best_iou}});
      }
      line["people"] = ps;
      // Per user: pixels at least min_person_height_m above the segmenter's floor (−1 without one).
      std::vector<long> high(size_t(nu), r.floor.valid ? 0 : -1);
      if (r.floor.valid)
        for (int v = 0; v < h; ++v)
          for (int u = 0; u < w; ++u) {
            const size_t q = size_t(v) * w + u;
            if (!labels[q] || !depth.pixels[q]) continue;
            const float z = depth.pixels[q] * 0.001f;
            const float x = (u - intr.cx) * z / intr.fx, y = -(v - intr.cy) * z / intr.fy;
            if (r.floor.nx * x + r.floor.ny * y + r.floor.nz * z + r.floor.d < seg.config().min_person_height_m) continue;
            for (int k = 0; k < nu; ++k)
              if (r.users[k].id == labels[q]) ++high[size_t(k)];
          }
      json us = json::array();
      for (int u = 0; u < nu; ++u) {
        long body = 0;
        for (int p = 0; p < np; ++p) body += overlap[size_t(u) * np + p];
        const UserInfo& ui = r.users[u];
        us.push_back({{"id", ui.id}, {"pixels", ui.pixel_count}, {"body_pixels", body}, {"top", ui.top_height_m},
                      {"box", {ui.u_min, ui.v_min, ui.u_max, ui.v_max}}, {"z", ui.centroid_m[2]},
                      {"high_pixels", high[size_t(u)]},
                      {"person", person_of_user[size_t(u)]},
                      {"person_pixels", person_of_user[size_t(u)] >= 0
                                            ? overlap[size_t(u) * np + size_t(person_of_user[size_t(u)])] : 0}});
      }
      line["users"] = us;
      per_frame->write(line.dump() + "\n");
    }
    false_users += false_here;
    frames_with_false += false_here > 0;
    for (int p = 0; p < np; ++p) {
      if (people[size_t(p)].pixels == 0) continue;
      ++people_total;
      people_found += user_of_person[size_t(p)] >= 0;
      if (people[size_t(p)].visible_area_m2 >= min_area) {
        ++sizable_total;
        sizable_found += user_of_person[size_t(p)] >= 0;
      }
      if (people[size_t(p)].visible_joints >= min_visible) {
        ++findable_total;
        findable_found += user_of_person[size_t(p)] >= 0;
      }
    }

    if (!joints) continue;
    // Joints: with the segmenter's mask (forest once, aggregation per user) ...
    frame.foreground_mask = labels.data();
    FrameResult all, one;
    if (Status s = pipeline.process(frame, &all); s != Status::kOk)
      fail(ds.depth_path(size_t(i)) + ": runtime refused the frame: " + status_message(s));
    user_joint_cycles += double(all.total_cycles);
    auto add = [&](std::vector<JointSamples>& samples, const Person& person, const FrameResult* res) {
      for (size_t k = 0; k < joint_blob.size(); ++k) {
        const JointTruth& t = person.joints[size_t(joint_data[k])];
        samples[k].truth.push_back(JointSamples::Truth{Point3{t.x, t.y, t.z}, t.visible});
        std::vector<ScoredPoint> props;
        if (res)
          for (int q = 0; q < res->proposal_count[joint_blob[k]]; ++q) {
            const JointProposal& jp = res->proposals[joint_blob[k]][q];
            props.push_back(ScoredPoint{Point3{jp.x_m, jp.y_m, jp.z_m}, jp.confidence});
          }
        samples[k].proposals.push_back(std::move(props));
      }
    };
    for (int p = 0; p < np; ++p) {
      if (people[size_t(p)].pixels == 0) continue;
      const int u = user_of_person[size_t(p)];
      if (u >= 0 && forest_per_user) {
        // Like the ground-truth run: the forest over this user's pixels alone (other users are
        // background to the probes), so the difference is the mask and nothing else.
        for (size_t q = 0; q < labels.size(); ++q) own_mask[q] = labels[q] == r.users[u].id;
        DepthFrame fo = frame;
        fo.foreground_mask = own_mask.data();
        if (Status s = pipeline.process(fo, &one); s != Status::kOk)
          fail(ds.depth_path(size_t(i)) + ": runtime refused the frame: " + status_message(s));
        user_joint_cycles += double(one.total_cycles);
      } else if (u >= 0) {
        if (Status s = pipeline.process_user(frame, uint8_t(r.users[u].id), &one); s != Status::kOk)
          fail(std::string("segeval: process_user: ") + status_message(s));
        user_joint_cycles += double(one.total_cycles);
      }
      add(seg_samples, people[size_t(p)], u >= 0 ? &one : nullptr);
      if (u >= 0) add(seg_found, people[size_t(p)], &one);
    }
    // ... and with each person's ground-truth mask.
    std::vector<uint8_t> mask(truth.size());
    for (int p = 0; p < np; ++p) {
      if (people[size_t(p)].pixels == 0) continue;
      for (size_t q = 0; q < truth.size(); ++q) mask[q] = truth[q] == p + 1;
      frame.foreground_mask = mask.data();
      if (Status s = pipeline.process(frame, &one); s != Status::kOk)
        fail(ds.depth_path(size_t(i)) + ": runtime refused the frame: " + status_message(s));
      add(gt_samples, people[size_t(p)], &one);
      if (user_of_person[size_t(p)] >= 0) add(gt_found, people[size_t(p)], &one);
    }
  }

  json out;
  out["dataset"] = dir;
  out["frames"] = frames;
  out["background_model"] = cfg.background_enabled;
  out["forest_per_user"] = forest_per_user;
  out["foreground_iou_pooled"] = union_total > 0 ? inter_total / union_total : 1.0;
  out["foreground_iou_mean"] = frames ? iou_sum / double(frames) : 1.0;
  out["people"] = people_total;
  out["people_found"] = people_found;
  out["detection_rate"] = people_total ? double(people_found) / double(people_total) : 1.0;
  out["findable_people"] = findable_total;
  out["findable_found"] = findable_found;
  out["findable_detection_rate"] = findable_total ? double(findable_found) / double(findable_total) : 1.0;
  out["min_visible_joints"] = min_visible;
  out["min_visible_area_m2"] = min_area;
  out["sizable_people"] = sizable_total;
  out["sizable_found"] = sizable_found;
  out["sizable_detection_rate"] = sizable_total ? double(sizable_found) / double(sizable_total) : 1.0;
  out["false_users"] = false_users;
  out["false_users_per_frame"] = frames ? double(false_users) / double(frames) : 0.0;
  out["frames_with_false_users"] = frames_with_false;
  json stages = json::object();
  for (int s = 0; s < kSegStageCount; ++s) stages[segmentation_stage_name(s)] = frames ? stage_cycles[size_t(s)] / frames : 0;
  out["segmentation_cycles_per_frame"] = frames ? seg_cycles / double(frames) : 0;
  out["segmentation_stage_cycles_per_frame"] = stages;
  out["segmentation_ms_per_frame"] = frames ? 1000.0 * seg_wall_s / double(frames) : 0;
  std::printf("segeval %s: %ld frames, background model %s\n", dir.c_str(), frames, cfg.background_enabled ? "on" : "off");
  std::printf("  foreground IoU      %.4f pooled, %.4f mean per frame\n", out["foreground_iou_pooled"].get<double>(),
              out["foreground_iou_mean"].get<double>());
  std::printf("  people found        %ld / %ld = %.4f (with >= %d visible joints: %ld / %ld = %.4f)\n", people_found,
              people_total, out["detection_rate"].get<double>(), min_visible, findable_found, findable_total,
              out["findable_detection_rate"].get<double>());
  std::printf("                      with >= %.3f m^2 of body in view: %ld / %ld = %.4f\n", min_area, sizable_found,
              sizable_total, out["sizable_detection_rate"].get<double>());
  std::printf("  false users         %ld = %.4f per frame (%ld frames with any)\n", false_users,
              out["false_users_per_frame"].get<double>(), frames_with_false);
  std::printf("  segmentation        %.0f cycles/frame (%.2f ms):", out["segmentation_cycles_per_frame"].get<double>(),
              out["segmentation_ms_per_frame"].get<double>());
  for (int s = 0; s < kSegStageCount; ++s)
    std::printf(" %s %.0f", segmentation_stage_name(s), frames ? stage_cycles[size_t(s)] / frames : 0.0);
  std::printf("\n");
  if (joints) {
    const MatchOptions mo{float(d_tp), false};
    std::vector<std::optional<double>> ap_seg, ap_gt;
    json per_joint = json::object();
    for (size_t k = 0; k < joint_blob.size(); ++k) {
      ap_seg.push_back(average_precision(match_joint(seg_samples[k], mo)));
      ap_gt.push_back(average_precision(match_joint(gt_samples[k], mo)));
      per_joint[ds.meta.joints[size_t(joint_data[k])]] = {{"segmented", ap_seg.back() ? json(*ap_seg.back()) : json()},
                                                          {"ground_truth_mask", ap_gt.back() ? json(*ap_gt.back()) : json()}};
    }
    const auto m_seg = mean_average_precision(ap_seg), m_gt = mean_average_precision(ap_gt);
    std::vector<std::optional<double>> ap_seg_found, ap_gt_found;
    for (size_t k = 0; k < joint_blob.size(); ++k) {
      ap_seg_found.push_back(average_precision(match_joint(seg_found[k], mo)));
      ap_gt_found.push_back(average_precision(match_joint(gt_found[k], mo)));
    }
    const auto f_seg = mean_average_precision(ap_seg_found), f_gt = mean_average_precision(ap_gt_found);
    out["map_segmented_people_found"] = f_seg ? json(*f_seg) : json();
    out["map_ground_truth_mask_people_found"] = f_gt ? json(*f_gt) : json();
    out["d_tp_m"] = d_tp;
    out["map_segmented"] = m_seg ? json(*m_seg) : json();
    out["map_ground_truth_mask"] = m_gt ? json(*m_gt) : json();
    out["ap_per_joint"] = per_joint;
    out["pipeline_cycles_per_frame_segmented"] = frames ? user_joint_cycles / double(frames) : 0;
    std::printf("  joint mAP (D_tp %.2f m)  segmented %.4f, ground-truth mask %.4f, difference %+.4f\n", d_tp,
                m_seg.value_or(0), m_gt.value_or(0), m_seg.value_or(0) - m_gt.value_or(0));
    std::printf("    over the people found only      segmented %.4f, ground-truth mask %.4f, difference %+.4f\n",
                f_seg.value_or(0), f_gt.value_or(0), f_seg.value_or(0) - f_gt.value_or(0));
  }
  if (per_frame) per_frame->commit();
  if (digest_out) digest_out->commit();
  if (a.has("--json")) write_file_atomic(a.get("--json"), out.dump(2) + "\n");
  check_output_stream();
  return 0;
}

}  // namespace
}  // namespace dp::tools

DP_REGISTER_COMMAND(segeval, "segeval", "segmentation quality (IoU, people found, false users) and joint mAP with it",
                    dp::tools::run_segeval);
