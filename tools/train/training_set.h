// Training data of `depthpose train` held in memory: one probe image per training image (the
// exact image the runtime's feature reads, runtime/fixed_point.h) and, per tree, a compact record
// for each sampled training pixel. Images come from layout-v1 datasets (tools/common/dataset.h) or
// are added directly (tests, benchmarks).
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace dp::train {

// Deterministic, platform-independent random numbers (splitmix64). Streams are keyed by a seed
// and a few integers so every decision can be reproduced independently of thread scheduling.
class Rng {
 public:
  explicit Rng(uint64_t state) : state_(state) {}
  static Rng keyed(uint64_t seed, uint64_t a, uint64_t b = 0, uint64_t c = 0, uint64_t d = 0);
  uint64_t next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, n), n ≥ 1, without modulo bias.
  uint64_t below(uint64_t n);
  // Uniform integer in [lo, hi].
  int32_t range(int32_t lo, int32_t hi) { return lo + static_cast<int32_t>(below(uint64_t(hi - lo) + 1)); }
  double unit() { return double(next() >> 11) * 0x1.0p-53; }  // [0, 1)

 private:
  uint64_t state_;
};

struct CameraIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pixels
};

// One training image. `probe` covers only the bounding box of the frame's foreground (origin_u,
// origin_v, width × height): outside it every probe reads kBackgroundDepthMm anyway, so features
// computed on the crop with crop-relative coordinates equal those on the full frame, while the
// probe images take a fraction of the memory (and cache). Inside, probe = depth of foreground
// pixels, kBackgroundDepthMm elsewhere. make_training_image appends kProbePadding background
// elements after the width × height ones: the trainer's AVX-512 kernel reads each probe as a 32-bit
// word at the element's address, two bytes past it (an image without them gets a padded copy).
constexpr size_t kProbePadding = 1;  // elements
struct TrainingImage {
  int width = 0, height = 0;            // of the crop (≥ 1)
  int origin_u = 0, origin_v = 0;       // crop position in the frame
  int frame_width = 0, frame_height = 0;
  CameraIntrinsics camera;
  int32_t focal_factor = 1000;          // dp::focal_factor_mm(camera.fx, reference focal)
  std::vector<uint16_t> probe;          // width × height (+ kProbePadding), row-major; empty if not loaded here
  std::vector<float> joints;            // joint_count × {x, y, z} metres, camera frame (may be empty)
  std::string name;                     // "DIR frame ID", for messages
  // The crop's elements held here (not the padding): width × height, 0 if not loaded here.
  size_t crop_elements() const { return std::min(probe.size(), size_t(width) * height); }
};

// A sampled training pixel, 16 bytes; u, v relative to the image's crop. scale_q13 = dp::scale_q13(image focal_factor, depth_mm).
struct TrainingPixel {
  uint32_t image;
  uint16_t u, v;
  uint16_t scale_q13;
  uint16_t depth_mm;
  uint8_t label;        // part id (0 when the data has no part labels)
  uint8_t reserved[3];
};
static_assert(sizeof(TrainingPixel) == 16, "TrainingPixel is 16 bytes");

// The 3D point of a training pixel (crop coordinates u, v) in metres, camera frame (x right, y up,
// z forward), with frame coordinates U = u + origin_u, V = v + origin_v:
// x = (U − cx)·z/fx, y = −(V − cy)·z/fy, z = depth.
std::array<float, 3> pixel_point(const TrainingImage& image, int u, int v, int depth_mm);

struct TrainingSet {
  std::vector<TrainingImage> images;
  std::vector<std::vector<TrainingPixel>> tree_pixels;  // per tree, ordered by image then raster
  std::vector<std::string> part_names;
  std::vector<std::string> joint_names;
  bool has_labels = false;   // pixels carry part labels
  bool has_joints = false;   // every image has joint_count joints
  float reference_focal_px = 0;
  std::string datasets_json = "[]";  // identity of the source datasets
  double load_seconds = 0;

  size_t image_bytes() const;  // probe images + joints
  size_t pixel_count() const;  // over all trees
};

struct SamplingOptions {
  int pixels_per_image = 2000;   // N_ex; all foreground pixels when an image has fewer
  int trees = 1;
  int images_per_tree = 0;       // 0 = every tree uses every image
  uint64_t seed = 1;
  int threads = 1;
  float reference_focal_px = 0;  // 0 = fx of the first dataset
  bool need_labels = true;       // error when a dataset has no parts/
  bool need_joints = false;      // error when a frame has no joints
  // Distributed training: load only shard `shard` of `shards` — the contiguous image range
  // rank_share(images, shard, shards) (communicator.h) of the datasets' frames in order. Images
  // outside it stay empty (no probe) and contribute no pixels; pixel keys and image indices stay
  // global, so the shards' pixel lists concatenated in shard order are the one-process lists.
  int shard = 0, shards = 1;
};

// Loads every frame of the datasets (layout v1), builds probe images and samples per-tree pixels.
// Throws ToolError naming the dataset, file and frame on missing/corrupt/mis-sized images, labels
// outside the part list, or missing joints/labels that the options need. Uses `threads` threads.
TrainingSet load_training_set(const std::vector<std::string>& dataset_dirs, const SamplingOptions& options);

// Building blocks used by load_training_set, for tests and benchmarks that make images in memory.
// `depth` and `parts` are full frames; `parts` may be null (then foreground = valid depth, label 0).
TrainingImage make_training_image(const uint16_t* depth, const uint8_t* parts, int width, int height,
                                  const CameraIntrinsics& camera, float reference_focal_px,
                                  std::vector<float> joints, std::string name);
// Samples N_ex foreground pixels of image `image_index` for tree `tree` (key: seed, tree, image),
// appending them in raster order. `parts` (full frame, may be null) gives the labels.
void sample_pixels(const TrainingImage& image, const uint8_t* parts, uint32_t image_index, int tree,
                   int pixels_per_image, uint64_t seed, std::vector<TrainingPixel>& out);
// Which images tree `tree` uses: all of them, or images_per_tree drawn without replacement
// (key: seed, tree), returned sorted.
std::vector<uint32_t> images_for_tree(size_t image_count, int images_per_tree, int tree, uint64_t seed);

}  // namespace dp::train
