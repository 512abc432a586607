// `make bench`: speed of `depthpose synth` per stage, on one thread, at 320x240 and 640x480
// (frames per second per core, with render, noise and PNG write apart; target >= 200 frames/s/core
// at 320x240 before PNG). Uses the real MakeHuman body and every CMU clip under the assets
// directory, SynthConfig's defaults (docs/synthetic_data.md: bare adult bodies; the synth command's
// own defaults add clothing and hair and widen the bodies, about 6-8 % more render time) and a
// fixed seed, so every frame has its own pose, shape, yaw, camera and noise as the synthesizer
// draws them. The stages are timed inside Synthesizer::render (SynthStageTimes, tools/synth/synth.h):
//   shape   shaped_vertices + measure_skeleton (MakeHuman targets, skeleton follows shape)
//   pose    pose_skeleton + linear blend skinning + joints + mirror + placement in the scene
//   raster  z-buffer rasterization: depth + part labels (+ body ownership)
//   noise   apply_sensor_noise (shadows, dropouts, disparity quantization, holes)
//   finish  parts/people images, joint visibility, frames.jsonl metadata
// then, as the synth command does, the depth (16-bit) and parts (8-bit) PNGs are encoded with the
// same libpng code (tools/common/png_io.h) and written to a temporary directory.
// Each resolution is run `rounds` times over the same frames; per stage the best round's mean is
// reported (the machine may be shared). frames/s/core = 1000 / (ms per frame on one thread).
// Prints a table and writes build/bench/synth.json.
//
// Assets: --assets DIR, else $DEPTHPOSE_ASSETS, else ../shared/assets (run from the repo root).
// Environment: SYNTH_BENCH_FRAMES (frames per round at 320x240, default 400; 640x480 uses half),
// SYNTH_BENCH_ROUNDS (default 3), SYNTH_BENCH_SEED (default 1).
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "tools/common/dataset.h"
#include "tools/common/error.h"
#include "tools/common/png_io.h"
#include "tools/synth/synth.h"

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

double thread_cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int env_int(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::atoi(v) : fallback;
}

// Mean milliseconds per frame of each stage.
struct StageMs {
  double shape = 0, pose = 0, raster = 0, noise = 0, finish = 0, png_encode = 0, png_write = 0;
  double before_png() const { return shape + pose + raster + noise + finish; }
  double png() const { return png_encode + png_write; }
  double total() const { return before_png() + png(); }
};

struct Result {
  int width = 0, height = 0, frames = 0, rounds = 0;
  size_t poses = 0;
  double load_s = 0;
  StageMs best;              // per stage: the lowest round mean
  double cpu_fraction = 1;   // thread CPU time / wall time over all rounds (< 1: the core was shared)
  double depth_png_bytes = 0, parts_png_bytes = 0;
};

void write_file(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f || std::fwrite(bytes.data(), 1, bytes.size(), f) != bytes.size() || std::fclose(f) != 0)
    dp::tools::fail("cannot write " + path);
}

Result run(const std::string& assets, int width, int height, int frames, int rounds, uint64_t seed,
           const std::string& tmp_dir) {
  Result r;
  r.width = width;
  r.height = height;
  r.frames = frames;
  r.rounds = rounds;
  dp::synth::SynthConfig config;  // the library's defaults: every clip, noise on, one bare adult body
  config.width = width;
  config.height = height;
  const auto t0 = Clock::now();
  const dp::synth::Synthesizer synth(assets, config);
  r.load_s = seconds_since(t0);
  r.poses = synth.pose_library().poses.size();
  std::printf("  %dx%d: %zu clips, %zu poses (loaded in %.1f s); %d frames x %d rounds, seed %llu\n", width, height,
              synth.clip_names().size(), r.poses, r.load_s, frames, rounds, (unsigned long long)seed);
  std::fflush(stdout);

  std::vector<dp::synth::FrameParams> params;
  for (int i = 0; i < frames; ++i) params.push_back(synth.sample_frame_params(seed, uint64_t(i)));
  for (int i = 0; i < std::min(frames, 5); ++i) synth.render(params[size_t(i)]);  // warm caches, thread_locals

  double cpu = 0, wall = 0;
  for (int round = 0; round < rounds; ++round) {
    dp::synth::SynthStageTimes t;
    double encode_s = 0, write_s = 0, depth_bytes = 0, parts_bytes = 0;
    const double c0 = thread_cpu_seconds();
    const auto w0 = Clock::now();
    for (int i = 0; i < frames; ++i) {
      const dp::synth::SynthFrame f = synth.render(params[size_t(i)], &t);
      auto e0 = Clock::now();
      const std::vector<uint8_t> depth_png = dp::tools::encode_png_u16(f.depth);
      const std::vector<uint8_t> parts_png = dp::tools::encode_png_u8(f.parts);
      encode_s += seconds_since(e0);
      e0 = Clock::now();
      const std::string id = dp::tools::frame_id(size_t(i));
      write_file(tmp_dir + "/depth_" + id + ".png", depth_png);
      write_file(tmp_dir + "/parts_" + id + ".png", parts_png);
      write_s += seconds_since(e0);
      depth_bytes += double(depth_png.size());
      parts_bytes += double(parts_png.size());
    }
    wall += seconds_since(w0);
    cpu += thread_cpu_seconds() - c0;
    const double k = 1000.0 / frames;
    const StageMs m{t.shape * k, t.pose * k, t.raster * k, t.noise * k, t.finish * k, encode_s * k, write_s * k};
    std::printf("    round %d: %.3f ms/frame before PNG, %.3f ms/frame with PNG\n", round + 1, m.before_png(),
                m.total());
    std::fflush(stdout);
    if (round == 0) {
      r.best = m;
    } else {
      r.best.shape = std::min(r.best.shape, m.shape);
      r.best.pose = std::min(r.best.pose, m.pose);
      r.best.raster = std::min(r.best.raster, m.raster);
      r.best.noise = std::min(r.best.noise, m.noise);
      r.best.finish = std::min(r.best.finish, m.finish);
      r.best.png_encode = std::min(r.best.png_encode, m.png_encode);
      r.best.png_write = std::min(r.best.png_write, m.png_write);
    }
    r.depth_png_bytes = depth_bytes / frames;
    r.parts_png_bytes = parts_bytes / frames;
  }
  r.cpu_fraction = wall > 0 ? cpu / wall : 1;
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  std::string assets = std::getenv("DEPTHPOSE_ASSETS") ? std::getenv("DEPTHPOSE_ASSETS") : "../shared/assets";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--assets" && i + 1 < argc) {
      assets = argv[++i];
    } else {
      std::fprintf(stderr, "usage: bench_synth [--assets DIR]   (default $DEPTHPOSE_ASSETS or ../shared/assets)\n");
      return 2;
    }
  }
  namespace fs = std::filesystem;
  if (!fs::is_directory(assets + "/makehuman") || !fs::is_directory(assets + "/mocap/cmu")) {
    std::fprintf(stderr,
                 "bench_synth: assets not found: %s must hold makehuman/ and mocap/cmu/ (run from the repo root so "
                 "that ../shared/assets exists, or pass --assets DIR or set DEPTHPOSE_ASSETS)\n",
                 assets.c_str());
    return 1;
  }
  const int frames = std::max(1, env_int("SYNTH_BENCH_FRAMES", 400));
  const int rounds = std::max(1, env_int("SYNTH_BENCH_ROUNDS", 3));
  const uint64_t seed = uint64_t(env_int("SYNTH_BENCH_SEED", 1));

  const std::string tmp = (fs::temp_directory_path() / ("bench_synth." + std::to_string(getpid()))).string();
  fs::create_directories(tmp);
  std::vector<Result> results;
  std::printf("synth bench: one thread, assets %s, synth defaults (all clips, noise, 1 body, no floor/clutter)\n",
              assets.c_str());
  try {
    results.push_back(run(assets, 320, 240, frames, rounds, seed, tmp));
    results.push_back(run(assets, 640, 480, std::max(1, frames / 2), rounds, seed, tmp));
  } catch (const std::exception& e) {
    fs::remove_all(tmp);
    std::fprintf(stderr, "bench_synth: %s\n", e.what());
    return 1;
  }
  fs::remove_all(tmp);

  std::printf("\nsynth, ms per frame on one core (best round mean) and frames/s/core:\n");
  std::printf("  %-26s %12s %12s %12s %12s\n", "stage", "320x240 ms", "fps/core", "640x480 ms", "fps/core");
  auto row = [&](const char* name, double StageMs::*field) {
    std::printf("  %-26s", name);
    for (const Result& r : results) std::printf(" %12.3f %12.0f", r.best.*field, 1000.0 / (r.best.*field));
    std::printf("\n");
  };
  auto row_fn = [&](const char* name, double (StageMs::*fn)() const) {
    std::printf("  %-26s", name);
    for (const Result& r : results) std::printf(" %12.3f %12.1f", (r.best.*fn)(), 1000.0 / (r.best.*fn)());
    std::printf("\n");
  };
  row("shape (targets, skeleton)", &StageMs::shape);
  row("pose + skin + place", &StageMs::pose);
  row("raster (depth, labels)", &StageMs::raster);
  row("noise", &StageMs::noise);
  row("finish (images, joints)", &StageMs::finish);
  row_fn("= total before PNG", &StageMs::before_png);
  row("PNG encode (depth+parts)", &StageMs::png_encode);
  row("PNG write (temp dir)", &StageMs::png_write);
  row_fn("= PNG", &StageMs::png);
  row_fn("= total with PNG", &StageMs::total);
  for (const Result& r : results)
    std::printf("  %dx%d: PNG sizes %.0f + %.0f bytes/frame; thread CPU / wall = %.2f%s\n", r.width, r.height,
                r.depth_png_bytes, r.parts_png_bytes, r.cpu_fraction,
                r.cpu_fraction < 0.9 ? " (core was shared: figures are pessimistic)" : "");
  const double target = 200;
  const double fps320 = 1000.0 / results[0].best.before_png();
  std::printf("target: >= %.0f frames/s/core at 320x240 before PNG: %.1f (%s)\n", target, fps320,
              fps320 >= target ? "met" : "NOT met");

  fs::create_directories("build/bench");
  FILE* j = std::fopen("build/bench/synth.json", "w");
  if (!j) {
    std::fprintf(stderr, "bench_synth: cannot write build/bench/synth.json (run from the repo root)\n");
    return 1;
  }
  std::fprintf(j, "{\n  \"threads\": 1,\n  \"rounds\": %d,\n  \"seed\": %llu", rounds, (unsigned long long)seed);
  for (const Result& r : results) {
    const std::string s = std::to_string(r.width) + "x" + std::to_string(r.height);
    const StageMs& m = r.best;
    auto key = [&](const char* name, double v) { std::fprintf(j, ",\n  \"%s_%s\": %.4f", name, s.c_str(), v); };
    std::fprintf(j, ",\n  \"frames_%s\": %d,\n  \"poses_%s\": %zu", s.c_str(), r.frames, s.c_str(), r.poses);
    std::fprintf(j, ",\n  \"fps_per_core_%s_before_png\": %.2f", s.c_str(), 1000.0 / m.before_png());
    std::fprintf(j, ",\n  \"fps_per_core_%s_with_png\": %.2f", s.c_str(), 1000.0 / m.total());
    key("shape_ms", m.shape);
    key("pose_ms", m.pose);
    key("render_ms", m.raster);
    key("noise_ms", m.noise);
    key("finish_ms", m.finish);
    key("before_png_ms", m.before_png());
    key("png_encode_ms", m.png_encode);
    key("png_write_ms", m.png_write);
    key("png_ms", m.png());
    key("total_ms", m.total());
    key("cpu_fraction", r.cpu_fraction);
  }
  std::fprintf(j, "\n}\n");
  std::fclose(j);
  std::printf("wrote build/bench/synth.json\n");
  return 0;
}
