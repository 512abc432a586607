// Training throughput of `depthpose train` on a reference configuration, with its own main.
// Reference: a whole small training — 1 tree grown to depth 20 (min 10 pixels per node) on 300
// procedural 320×240 stick-body images × 1000 pixels, 400 offset pairs × 20 thresholds per node
// (the shipped recipe's candidates), classification objective, all cores.
// Reports wall time and pixel·candidate evaluations per second per core (evaluations / process CPU
// time, so that other load on the machine does not distort it), where one evaluation =
// one feature (offset pair) computed at one pixel and binned against the node's thresholds; the
// paper's |T| candidates are offset pairs × thresholds, so the rate in (pixel·|T|) is ×20.
// It also prints the rate per depth band (levels 0–3, 4–7, 8–11, 12–15, 16+: evaluations / CPU
// seconds of the band's levels): near the root a node's pixels come a thousand at a time from
// each image, deeper they come from many images a few at a time and per-node work (candidates,
// thresholds, scoring) weighs more, so a whole training runs slower than its top levels.
// Environment: TRAIN_BENCH_METHOD (bpc|ojr: OJR adds the vote leaves), TRAIN_BENCH_IMAGES,
// TRAIN_BENCH_PIXELS (per image), TRAIN_BENCH_DATA (a dataset directory, layout v1, e.g. from
// `depthpose synth`, in place of the stick bodies; TRAIN_BENCH_IMAGES is then ignored),
// TRAIN_BENCH_DEPTH, TRAIN_BENCH_OFFSETS, TRAIN_BENCH_THRESHOLDS, TRAIN_BENCH_THREADS override
// the configuration; TRAIN_BENCH_LEVELS=1 prints each level's evaluations, wall and CPU time.
// DEPTHPOSE_TRAIN_NO_AVX2=1 (read by the trainer) measures the scalar feature path.
// Before/after comparisons: build both versions and alternate the two binaries back to back
// (docs/training.md, Throughput), since this shared machine's load varies from minute to minute.
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <vector>

#include "tests/train_stick_bodies.h"
#include "tools/train/forest_trainer.h"

namespace {

double cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int env_int(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v ? std::atoi(v) : fallback;
}

}  // namespace

int main() {
  using namespace dp::train;
  const int images = env_int("TRAIN_BENCH_IMAGES", 300);
  const int depth = env_int("TRAIN_BENCH_DEPTH", 20);
  const int offsets = env_int("TRAIN_BENCH_OFFSETS", 400);
  const int pixels = env_int("TRAIN_BENCH_PIXELS", 1000);
  const int thresholds = env_int("TRAIN_BENCH_THRESHOLDS", 20);
  const int threads = env_int("TRAIN_BENCH_THREADS", std::max(1u, std::thread::hardware_concurrency()));
  const auto t0 = std::chrono::steady_clock::now();
  const char* data = std::getenv("TRAIN_BENCH_DATA");
  TrainingSet set;
  if (data) {
    SamplingOptions so;
    so.pixels_per_image = pixels;
    so.threads = threads;
    set = load_training_set({data}, so);
  } else {
    set = testing_bodies::stick_body_set(images, pixels);
  }
  const double make_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("train_bench: %zu images %s x %d px = %zu training pixels (made in %.1f s), 1 tree, depth %d, "
              "%d offsets x %d thresholds, %d threads, %s kernels\n",
              set.images.size(), data ? data : "320x240 stick bodies", pixels, set.tree_pixels[0].size(), make_s, depth,
              offsets, thresholds, threads, dp::train::training_kernel_name());
  std::fflush(stdout);

  ForestOptions fo;
  fo.method = std::getenv("TRAIN_BENCH_METHOD") ? std::getenv("TRAIN_BENCH_METHOD") : "bpc";
  fo.tree.max_depth = depth;
  fo.tree.offset_candidates = offsets;
  fo.tree.threshold_candidates = thresholds;
  fo.tree.max_offset_pxm = 65;
  fo.tree.min_samples = 10;
  fo.tree.threads = threads;
  ForestStats stats;
  const auto t1 = std::chrono::steady_clock::now();
  const double c1 = cpu_seconds();
  // Per depth band: evaluations and process CPU seconds (the CPU clock read at each level's report,
  // which comes on the calling thread after the level's work on all threads has finished).
  constexpr int kBands = 5, kBandLevels = 4;
  double band_evaluations[kBands] = {}, band_cpu[kBands] = {}, band_pixels[kBands] = {};
  int band_levels[kBands] = {};
  double level_cpu_start = c1;
  const bool print_levels = std::getenv("TRAIN_BENCH_LEVELS") != nullptr;
  ProgressFn levels = [&](const LevelReport& r) {
    if (r.partial || r.resumed) return;
    const double now = cpu_seconds(), cpu = now - level_cpu_start;
    level_cpu_start = now;
    const int band = std::min(kBands - 1, r.level / kBandLevels);
    band_evaluations[band] += double(r.feature_evaluations);
    band_cpu[band] += cpu;
    band_pixels[band] += double(r.active_pixels) / std::max<size_t>(1, r.frontier_nodes);
    ++band_levels[band];
    if (print_levels)
      std::printf("train_bench:   level %2d: %6zu nodes, %8.0f px/node, %.3g evaluations, %.2f s wall, %.2f s CPU = "
                  "%.3g /s per core\n",
                  r.level, r.frontier_nodes, double(r.active_pixels) / std::max<size_t>(1, r.frontier_nodes),
                  double(r.feature_evaluations), r.seconds, cpu, r.feature_evaluations / std::max(1e-9, cpu));
  };
  const TrainedForest forest = train_forest(set, fo, levels, &stats);
  const double cpu = cpu_seconds() - c1;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  const double rate = stats.feature_evaluations / stats.structure_seconds;
  const double core_rate = stats.feature_evaluations / cpu;
  std::printf("train_bench: wall %.2f s (structure %.2f s, leaves %.2f s); %zu nodes, %zu leaves, deepest leaf %d\n", wall,
              stats.structure_seconds, stats.leaf_seconds, forest.trees[0].nodes.size(), forest.trees[0].leaf_count(),
              forest.trees[0].max_leaf_level());
  std::printf("train_bench: %.3g pixel*offset evaluations: %.3g /s wall; per core (CPU time %.2f s, %.0f%% of %d "
              "threads busy): %.3g /s = %.2f ns each; x20 thresholds = %.3g pixel*candidate /s per core\n",
              double(stats.feature_evaluations), rate, cpu, 100 * cpu / (wall * threads), threads, core_rate,
              1e9 / core_rate, 20 * core_rate);
  for (int b = 0; b < kBands; ++b) {
    if (band_evaluations[b] == 0) continue;
    const int last = b + 1 < kBands ? std::min(depth, (b + 1) * kBandLevels - 1) : depth;
    std::printf("train_bench: levels %2d-%2d: %5.1f%% of the evaluations, %6.2f s CPU, ~%.0f px per node: %.3g /s per core\n",
                b * kBandLevels, last, 100 * band_evaluations[b] / std::max(1.0, double(stats.feature_evaluations)),
                band_cpu[b], band_pixels[b] / band_levels[b], band_evaluations[b] / std::max(1e-9, band_cpu[b]));
  }
  std::printf("train_bench: memory %.0f bytes per training pixel\n", stats.bytes_per_pixel);
  return 0;
}
