// `depthpose synth`: writes a synthetic dataset (layout v1, docs/dataset_format.md) rendered from
// the MakeHuman body and CMU motion; see docs/synthetic_data.md.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <thread>
#include <unistd.h>

#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/dataset.h"
#include "tools/common/file_io.h"
#include "tools/common/error.h"
#include "tools/synth/synth.h"
#include "tools/train/communicator.h"

namespace dp::synth {
namespace {

// An existing --out that synth may replace: a depthpose dataset (it has meta.json).
bool is_dataset_folder(const std::string& path) { return std::filesystem::exists(path + "/meta.json"); }
using dp::tools::fail;
namespace fs = std::filesystem;

const char* kUsage =
    "usage: depthpose synth --out DIR --frames N [options]\n"
    "Renders labelled synthetic depth frames (MakeHuman body, CMU motion) into a dataset (layout v1).\n"
    "  --assets DIR        shared assets (default ../shared/assets)\n"
    "  --out DIR           dataset directory to create\n"
    "  --frames N          number of frames\n"
    "  --seed S            random seed (default 1); same arguments + seed = identical dataset\n"
    "  --width W --height H  image size (default 320x240; 640x480 works; fx=fy=525*W/640)\n"
    "  --clips LIST        comma list: subject (02), clip (02_01), all (every clip of mocap/clips.tsv),\n"
    "                      split:train|validation|test (see --splits), or a .bvh/.amc file (plain or\n"
    "                      .gz); default: the 28 clips under mocap/cmu\n"
    "  --splits FILE       held-out splits table (default tools/synth/splits.tsv)\n"
    "  --threads N         worker threads (default: all cores); output does not depend on it\n"
    "  --distributed       one rank of an MPI job even when mpirun/srun is not detected: each rank\n"
    "                      renders its share of the frames into one dataset (a shared file system)\n"
    "  --preview FILE.png  contact sheet of the first frames (depth | parts | joints)\n"
    "  --rotation DEG      body yaw uniform in [-DEG, DEG] (default 60; 180 or 360 = any)\n"
    "  --floor             render a floor plane (label 255) instead of empty background\n"
    "  --people N          N bodies per frame (1..8, default 1): frames.jsonl gets \"people\", and\n"
    "                      people/NNNNNN.png (1 + body index per pixel) is written\n"
    "  --clutter N         N furniture-sized boxes/cylinders on the floor per frame (0..32, label 255)\n"
    "  --tall-clutter N    N room objects as tall as people per frame (0..16, label 255): chairs with\n"
    "                      backs, shelves 1.2-2.0 m, coat stands 1.6-1.9 m, doors ~2 m; drawn after\n"
    "                      everything else, so frames without it are unchanged (docs/synthetic_data.md)\n"
    "  --sequence          one scene for all frames (camera, bodies, clutter from frame 0); each body\n"
    "                      steps through its clip frame by frame (no pose pruning), fresh noise per\n"
    "                      frame: a recording-like sequence (e.g. for depthpose record, run, segeval --live)\n"
    "  --no-noise          clean depth (no shadows, dropouts, quantization)\n"
    "  --pose-distance M   D_pose of the pose pruning in metres (default 0.05)\n"
    "  --pose-stride N     use every N-th mocap frame before pruning (default 4)\n"
    "  --pose-pool KIND    clips (default): the sampled mocap frames; varied: plus their mirror images,\n"
    "                      one rotation-noise copy each within the mocap's joint limits and 0.5\n"
    "                      upper/lower-body recombinations per pose (docs/synthetic_data.md)\n"
    "  --pose-seed S       seed of the pose variation (default 1)\n"
    "  --pose-cache FILE   keep the pool's real poses (clips loaded and retargeted) in FILE and reuse\n"
    "                      them while clips, stride, assets and this executable are unchanged (else\n"
    "                      FILE is rebuilt); the dataset is byte-identical with or without it\n"
    "  --pool-report       print the pose pool per CMU category (before/after pruning, times)\n"
    "  --pool-sheet FILE.png  one row of pruned-pool poses per kind (real, mirror, noise, recombined)\n"
    "  --bodies KIND       wide (default): every macro control over its full range, ages 6-80,\n"
    "                      standing heights kept within 1.1-2.0 m; adult: the earlier adult ranges\n"
    "                      (ages 13-75, heights ~1.5-1.9 m, no limit); see docs/synthetic_data.md\n"
    "  --ages A-B          age range in years (default: by --bodies)\n"
    "  --camera-height A-B camera height above the floor in metres (default 0.5-1.9)\n"
    "  --camera-pitch A-B  camera pitch in degrees, positive looking down (default -5-25)\n"
    "  --camera-roll R     camera roll uniform in [-R, R] degrees (default 6)\n"
    "  --clothed F         share of bodies wearing an outfit and shoes from the MakeHuman CC0\n"
    "                      wardrobe (default 0.8; the rest are the bare mesh); 0 = never\n"
    "  --hat P --hair P    of clothed bodies, the share with a hat (default 0.15) and with hair (0.85)\n"
    "  --wardrobe-sheet FILE.png  every outfit (with shoes, hair, and a hat on some) on the base body\n"
    "                      in the A-pose, front row and back row, in part colours: checks garment fit\n"
    "  --parts-figure PREFIX  write PREFIX_front.png and PREFIX_back.png (labelled body, docs/parts.md)\n"
    "  --pose-sheet FILE.png  one row of posed bodies per skeleton naming of the selected clips\n"
    "                      (first frame, then frames spread over its clips): checks retargeting\n";

std::string format_seconds(double s) {
  char buf[32];
  if (s < 120) std::snprintf(buf, sizeof buf, "%.0fs", s);
  else std::snprintf(buf, sizeof buf, "%dm%02ds", int(s) / 60, int(s) % 60);
  return buf;
}

// "A-B" (or "A:B"; A may be negative, e.g. -5-25) with lo <= A <= B <= hi.
void parse_range(const std::string& text, const char* option, double lo, double hi, double& a, double& b) {
  char* end = nullptr;
  a = std::strtod(text.c_str(), &end);
  const bool separated = end != text.c_str() && (*end == '-' || *end == ':');
  if (separated) b = std::strtod(end + 1, &end);
  if (!separated || *end || !(a >= lo) || !(b >= a) || !(b <= hi))
    fail(std::string(option) + " wants A-B with " + std::to_string(lo) + " <= A <= B <= " + std::to_string(hi) +
         ", got '" + text + "'");
}

// Copies a figure cell into a contact sheet at (x0, y0).
void paste_cell(const dp::tools::ImageRgb& cell, dp::tools::ImageRgb& sheet, int x0, int y0) {
  for (int y = 0; y < cell.height; ++y)
    for (int x = 0; x < cell.width; ++x) {
      const uint8_t* c = &cell.pixels[(size_t(y) * cell.width + x) * 3];
      sheet.set(x0 + x, y0 + y, c[0], c[1], c[2]);
    }
}

void write_bytes(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  if (!f) fail("cannot write " + path);
}

int synth_main(int argc, char** argv, dp::train::Communicator* comm) {
  dp::tools::Args args(argc, argv, kUsage,
                       {"--assets", "--out", "--frames", "--seed", "--width", "--height", "--clips", "--threads",
                        "--preview", "--rotation", "--pose-distance", "--pose-stride", "--ages", "--parts-figure",
                        "--pose-sheet", "--people", "--clutter", "--tall-clutter", "--splits", "--pose-pool", "--pose-seed", "--pool-sheet",
                        "--clothed", "--hat", "--hair", "--wardrobe-sheet", "--bodies", "--camera-height",
                        "--camera-pitch", "--camera-roll", "--pose-cache"},
                       {"--floor", "--no-noise", "--sequence", "--pool-report", "--distributed"});
  if (args.help_requested()) {
    std::printf("%s", kUsage);
    return 0;
  }
  SynthConfig config;
  config.width = int(args.get_int("--width", 320));
  config.height = int(args.get_int("--height", 240));
  config.rotation_deg = args.get_double("--rotation", 60);
  config.floor = args.flag("--floor");
  config.people = int(args.get_int("--people", 1));
  config.clutter = int(args.get_int("--clutter", 0));
  config.tall_clutter = int(args.get_int("--tall-clutter", 0));
  config.sequence = args.flag("--sequence");
  config.noise.enabled = !args.flag("--no-noise");
  config.pose_min_distance_m = args.get_double("--pose-distance", 0.05);
  config.pose_frame_stride = int(args.get_int("--pose-stride", 4));
  if (config.pose_frame_stride < 1) fail("--pose-stride must be >= 1");
  if (!(config.pose_min_distance_m >= 0)) fail("--pose-distance must be >= 0");
  if (!(config.rotation_deg >= 0)) fail("--rotation must be >= 0");
  if (args.has("--clips")) config.clips = dp::tools::split_list(args.get("--clips"));
  config.splits_path = args.get("--splits", kDefaultSplitsPath);
  const std::string pool_kind = args.get("--pose-pool", "clips");
  if (pool_kind == "varied") {
    config.pose_variation.mirror = true;
    config.pose_variation.noise_copies = 1;
    config.pose_variation.recombined_per_pose = 0.5;
  } else if (pool_kind != "clips") {
    fail("--pose-pool must be clips or varied, got '" + pool_kind + "'");
  }
  config.pose_variation.seed = uint64_t(args.get_int("--pose-seed", 1));
  config.pose_cache_path = args.get("--pose-cache", "");
  config.clothed_share = args.get_double("--clothed", 0.8);
  config.hat_probability = args.get_double("--hat", 0.15);
  config.hair_probability = args.get_double("--hair", 0.85);
  for (const auto& [name, value] : {std::pair<const char*, double>{"--clothed", config.clothed_share},
                                    {"--hat", config.hat_probability}, {"--hair", config.hair_probability}})
    if (!(value >= 0 && value <= 1)) fail(std::string(name) + " must be a share in [0, 1], got " + std::to_string(value));
  const std::string bodies = args.get("--bodies", "wide");
  if (bodies == "wide") {
    config.muscle_min = config.weight_min = config.height_min = config.proportions_min = 0.0;
    config.muscle_max = config.weight_max = config.height_max = config.proportions_max = 1.0;
    config.age_min_years = 6;
    config.age_max_years = 80;
    config.stature_min_m = 1.1;
    config.stature_max_m = 2.0;
  } else if (bodies != "adult") {
    fail("--bodies must be wide or adult, got '" + bodies + "'");
  }
  if (args.has("--ages")) {
    parse_range(args.get("--ages"), "--ages", 1, 90, config.age_min_years, config.age_max_years);
  }
  if (args.has("--camera-height"))
    parse_range(args.get("--camera-height"), "--camera-height", 0.1, 3.0, config.camera_height_min_m,
                config.camera_height_max_m);
  if (args.has("--camera-pitch"))
    parse_range(args.get("--camera-pitch"), "--camera-pitch", -60, 60, config.camera_pitch_min_deg,
                config.camera_pitch_max_deg);
  config.camera_roll_max_deg = args.get_double("--camera-roll", config.camera_roll_max_deg);
  if (!(config.camera_roll_max_deg >= 0 && config.camera_roll_max_deg <= 45))
    fail("--camera-roll must be 0..45 degrees, got " + std::to_string(config.camera_roll_max_deg));
  const std::string assets = args.get("--assets", "../shared/assets");
  const bool figures_only =
      (args.has("--parts-figure") || args.has("--wardrobe-sheet") || args.has("--pose-sheet") || args.has("--pool-sheet") || args.flag("--pool-report")) &&
      !args.has("--out");

  const auto t0 = std::chrono::steady_clock::now();
  Synthesizer synth(assets, config);
  const double load_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::fprintf(stderr, "synth: %zu clips, %zu sampled frames -> %zu poses after pruning at D_pose = %.0f mm (%.1fs)\n",
               synth.clip_names().size(), synth.pose_library().candidate_count, synth.pose_library().poses.size(),
               config.pose_min_distance_m * 1000, load_s);
  if (!synth.pose_cache_note().empty()) std::fprintf(stderr, "synth: %s\n", synth.pose_cache_note().c_str());

  if (args.flag("--pool-report"))
    std::printf("%s", format_pose_pool_report(synth.pose_pool_report(), config.pose_min_distance_m).c_str());
  if (args.has("--parts-figure")) {
    const std::string prefix = args.get("--parts-figure");
    const BodyPose pose = rest_pose(synth.assets());
    dp::tools::write_png_rgb(prefix + "_front.png", synth.render_parts_figure(pose, 0, 480, 640));
    dp::tools::write_png_rgb(prefix + "_back.png", synth.render_parts_figure(pose, 180, 480, 640));
    std::fprintf(stderr, "synth: wrote %s_front.png and %s_back.png\n", prefix.c_str(), prefix.c_str());
  }
  if (args.has("--wardrobe-sheet")) {
    const Wardrobe& w = synth.wardrobe();
    if (w.empty()) fail("--wardrobe-sheet needs the wardrobe: --clothed must be > 0");
    const int cols = int(w.of(GarmentKind::kOutfit).size()), cw = 120, ch = 240;
    dp::tools::ImageRgb sheet;
    sheet.resize(cols * cw, 2 * ch);
    const BodyPose pose = rest_pose(synth.assets());
    for (int i = 0; i < cols; ++i) {
      Outfit outfit;
      outfit.outfit = i;
      outfit.shoes = i % int(w.of(GarmentKind::kShoes).size());
      outfit.hair = i % int(w.of(GarmentKind::kHair).size());
      if (i % 4 == 3) outfit.hat = (i / 4) % int(w.of(GarmentKind::kHat).size());
      for (int row = 0; row < 2; ++row) {
        const dp::tools::ImageRgb cell = synth.render_parts_figure(pose, row * 180.0, cw, ch, outfit);
        paste_cell(cell, sheet, i * cw, row * ch);
      }
    }
    dp::tools::write_png_rgb(args.get("--wardrobe-sheet"), sheet);
    std::fprintf(stderr, "synth: wrote %s\n", args.get("--wardrobe-sheet").c_str());
  }
  if (args.has("--pose-sheet")) {
    // One row per skeleton naming among the selected clips: its first frame (the rest pose of a
    // BVH conversion, where one exists), then frames spread evenly over all its clips. Left parts
    // and right parts have different colours (docs/parts.md), so a limb retargeted onto the wrong
    // bone or side shows at a glance.
    const std::vector<MotionClip> clips = load_clips(assets, config.clips, config.pose_frame_stride, config.splits_path);
    std::vector<std::string> namings;
    for (const MotionClip& c : clips)
      if (std::find(namings.begin(), namings.end(), c.skeleton) == namings.end()) namings.push_back(c.skeleton);
    const int cols = 8, cw = 160, ch = 240;
    const int rows = int(namings.size());
    dp::tools::ImageRgb sheet;
    sheet.resize(cols * cw, rows * ch);
    const Skeleton rest = measure_skeleton(synth.assets(), synth.assets().base_vertices);
    for (int row = 0; row < rows; ++row) {
      std::vector<std::pair<const MotionClip*, size_t>> frames;
      for (const MotionClip& c : clips)
        if (c.skeleton == namings[size_t(row)])
          for (size_t k = 0; k < c.frames.size(); ++k) frames.push_back({&c, k});
      std::fprintf(stderr, "synth: pose sheet row %d: %s (%zu frames)\n", row + 1, namings[size_t(row)].c_str(),
                   frames.size());
      for (int i = 0; i < cols; ++i) {
        const size_t at = i == 0 ? 0 : frames.size() * size_t(2 * i - 1) / size_t(2 * (cols - 1));
        const BodyPose pose = retarget_frame(synth.assets(), rest, *frames[at].first, frames[at].second);
        dp::tools::ImageRgb cell = synth.render_parts_figure(pose, 20, cw, ch);
        paste_cell(cell, sheet, i * cw, row * ch);
      }
    }
    dp::tools::write_png_rgb(args.get("--pose-sheet"), sheet);
    std::fprintf(stderr, "synth: wrote %s\n", args.get("--pose-sheet").c_str());
  }
  if (args.has("--pool-sheet")) {
    // One row per pose kind in the pruned pool (real, mirror, noise, recombined): poses spread
    // evenly over that kind's entries, to check that synthetic variation stays human.
    const PoseLibrary& lib = synth.pose_library();
    auto kind_of = [](const std::string& origin) {
      if (origin.find('+') != std::string::npos) return 3;
      if (origin.find(" noise ") != std::string::npos) return 2;
      if (origin.find(" mirror") != std::string::npos) return 1;
      return 0;
    };
    std::vector<std::vector<size_t>> by_kind(4);
    for (size_t i = 0; i < lib.poses.size(); ++i) by_kind[size_t(kind_of(lib.origin[i]))].push_back(i);
    std::vector<int> kinds;
    for (int k = 0; k < 4; ++k)
      if (!by_kind[size_t(k)].empty()) kinds.push_back(k);
    const int cols = 8, cw = 160, ch = 240;
    dp::tools::ImageRgb sheet;
    sheet.resize(cols * cw, int(kinds.size()) * ch);
    for (size_t row = 0; row < kinds.size(); ++row) {
      const std::vector<size_t>& members = by_kind[size_t(kinds[row])];
      std::fprintf(stderr, "synth: pool sheet row %zu: %s (%zu poses)\n", row + 1, pose_kind_name(PoseKind(kinds[row])),
                   members.size());
      for (int i = 0; i < cols; ++i) {
        const size_t pick = members[members.size() * size_t(2 * i + 1) / size_t(2 * cols)];
        dp::tools::ImageRgb cell = synth.render_parts_figure(lib.poses[pick], 20, cw, ch);
        paste_cell(cell, sheet, i * cw, int(row) * ch);
      }
    }
    dp::tools::write_png_rgb(args.get("--pool-sheet"), sheet);
    std::fprintf(stderr, "synth: wrote %s\n", args.get("--pool-sheet").c_str());
  }
  if (figures_only) return 0;

  const std::string out_final = args.get("--out");
  const long long frames = args.get_int("--frames", -1);
  if (frames < 1) fail("--frames N (N >= 1) is required");
  const uint64_t seed = uint64_t(args.get_int("--seed", 1));
  int threads = int(args.get_int("--threads", std::max(1u, std::thread::hardware_concurrency())));
  if (threads < 1) fail("--threads must be >= 1");
  // Distributed (mpirun/srun, docs/training.md "Distributed training"): rank r renders frames
  // rank_share(frames, r, N) into rank 0's temporary folder (a file system all ranks share); rank 0
  // writes frames.jsonl from every rank's records and swaps the folder in. Frames are a function of
  // (seed, index), so the dataset equals a one-process render byte for byte.
  const auto [first_frame, end_frame] = comm ? dp::train::rank_share(size_t(frames), comm->rank(), comm->size())
                                             : std::pair<size_t, size_t>(0, size_t(frames));
  const long long local_frames = static_cast<long long>(end_frame - first_frame);
  if (comm && args.has("--preview")) fail("--preview is not available with distributed rendering");
  threads = int(std::min<long long>(threads, local_frames));

  // The dataset is built in a temporary folder and swapped in whole at the end, so that a failed
  // or killed run never leaves a mix of old and new frames under --out.
  std::optional<dp::tools::AtomicOutputDirectory> out_dir;
  std::string out;
  if (!comm || comm->rank() == 0) {
    out_dir.emplace(out_final, is_dataset_folder, "depthpose dataset");
    out = out_dir->path();
    dp::tools::create_dataset(out, synth.dataset_meta(), true);
    if (config.people > 1) std::filesystem::create_directories(out + "/people");
  }
  if (comm) {
    std::vector<uint8_t> path(out.begin(), out.end());
    comm->broadcast(path);
    out.assign(path.begin(), path.end());
  }
  std::vector<dp::tools::FrameRecord> records(static_cast<size_t>(frames));
  const size_t preview_count = args.has("--preview") ? size_t(std::min<long long>(frames, 12)) : 0;
  std::vector<SynthFrame> preview(preview_count);

  std::atomic<long long> next{static_cast<long long>(first_frame)}, done{0};
  std::mutex error_mutex;
  std::string error;
  const auto start = std::chrono::steady_clock::now();
  auto worker = [&]() {
    for (;;) {
      const long long i = next.fetch_add(1);
      if (i >= static_cast<long long>(end_frame)) return;
      try {
        SynthFrame f = synth.render_frame(seed, uint64_t(i));
        const std::string id = dp::tools::frame_id(size_t(i));
        write_bytes(out + "/depth/" + id + ".png", dp::tools::encode_png_u16(f.depth));
        write_bytes(out + "/parts/" + id + ".png", dp::tools::encode_png_u8(f.parts));
        if (config.people > 1) write_bytes(out + "/people/" + id + ".png", dp::tools::encode_png_u8(f.people));
        dp::tools::FrameRecord& r = records[size_t(i)];
        r.id = id;
        r.joints = f.joints;
        r.extra_json = f.extra_json;
        if (size_t(i) < preview_count) preview[size_t(i)] = std::move(f);
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (error.empty()) error = e.what();
        next.store(static_cast<long long>(end_frame));
        return;
      }
      done.fetch_add(1);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(worker);
  const bool tty = isatty(fileno(stderr));
  auto last_print = std::chrono::steady_clock::now() - std::chrono::hours(1);
  for (;;) {
    const long long d = done.load();
    bool stop = d >= local_frames || next.load() > static_cast<long long>(end_frame);
    {
      std::lock_guard<std::mutex> lock(error_mutex);
      stop = stop || !error.empty();
    }
    const auto now = std::chrono::steady_clock::now();
    if (stop || now - last_print > std::chrono::milliseconds(tty ? 200 : 5000)) {
      last_print = now;
      const double el = std::chrono::duration<double>(now - start).count();
      const double rate = el > 0 ? d / el : 0;
      const int bar = local_frames ? int(30.0 * d / local_frames) : 30;
      std::fprintf(stderr, "%s[%.*s%*s] %lld/%lld  %.1f frames/s  ETA %s%s", tty ? "\r" : "", bar,
                   "##############################", 30 - bar, "", d, local_frames, rate,
                   rate > 0 ? format_seconds((local_frames - d) / rate).c_str() : "?", tty ? "" : "\n");
      std::fflush(stderr);
    }
    if (stop) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  for (auto& t : pool) t.join();
  if (tty) std::fprintf(stderr, "\n");
  if (!error.empty()) fail(error);
  if (!comm) {
    dp::tools::write_frames_jsonl(out, records);
  } else {
    std::string lines;
    for (size_t i = first_frame; i < end_frame; ++i) lines += dp::tools::frame_record_to_json_line(records[i]) + "\n";
    const auto all = comm->gather(std::vector<uint8_t>(lines.begin(), lines.end()));
    if (comm->rank() == 0) {
      std::ofstream f(out + "/frames.jsonl", std::ios::binary);
      for (const std::vector<uint8_t>& part : all) f.write(reinterpret_cast<const char*>(part.data()), std::streamsize(part.size()));
      if (!f.flush()) fail("cannot write " + out + "/frames.jsonl");
    }
  }
  if (out_dir) out_dir->commit();
  if (comm) comm->barrier();  // --out is complete when any rank exits 0
  const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fprintf(stderr, "synth: wrote %lld frames to %s in %.1fs (%.1f frames/s with %d threads)\n", frames,
               out_final.c_str(), el, frames / el, threads);

  if (preview_count) {
    const int W = config.width, H = config.height, cols = 2;
    const int rows = int((preview_count + cols - 1) / cols);
    dp::tools::ImageRgb sheet;
    sheet.resize(cols * 3 * W + (cols - 1) * 8, rows * H + (rows - 1) * 4);
    for (size_t i = 0; i < preview_count; ++i)
      draw_preview_row(preview[i], synth.intrinsics(), sheet, int(i % cols) * (3 * W + 8), int(i / cols) * (H + 4));
    dp::tools::write_png_rgb(args.get("--preview"), sheet);
    std::fprintf(stderr, "synth: preview %s\n", args.get("--preview").c_str());
  }
  return 0;
}

int run_synth(int argc, char** argv) {
  return dp::train::run_maybe_distributed("depthpose synth", argc, argv, synth_main);
}

}  // namespace
}  // namespace dp::synth

DP_REGISTER_COMMAND(synth, "synth", "render a labelled synthetic depth dataset (MakeHuman body, CMU mocap)",
                    dp::synth::run_synth);
