// depthpose synth as a library: render labelled synthetic depth frames into memory.
// Other tools' tests (training, eval, recordings) use this to make frames without files:
//
//   dp::synth::SynthConfig config;               // 320x240, defaults of docs/synthetic_data.md
//   config.clips = {"02_01"};                    // optional: fewer clips load faster
//   dp::synth::Synthesizer synth("../shared/assets", config);   // loads assets, builds poses
//   dp::synth::SynthFrame f = synth.render_frame(/*seed=*/1, /*frame_index=*/0);
//   // f.depth (mm, 0 = none), f.parts (0..30, 255 = not body), f.joints (camera frame, metres)
//
// Frame i of seed s is a pure function of (assets, config, s, i): its random stream is seeded
// from (s, i), so any thread may render any frame. Synthesizer is immutable after construction;
// render_frame may be called concurrently. Throws dp::tools::ToolError for missing/malformed
// assets or clips (naming the file).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "tools/common/dataset.h"
#include "tools/common/png_io.h"
#include "tools/synth/clip_index.h"
#include "tools/synth/depth_noise.h"
#include "tools/synth/human_model.h"
#include "tools/synth/pose_pool.h"
#include "tools/synth/posing.h"
#include "tools/synth/random.h"
#include "tools/synth/rasterizer.h"
#include "tools/synth/wardrobe.h"

namespace dp::synth {

struct SynthConfig {
  int width = 320, height = 240;
  double focal_640 = 525.0;          // fx = fy = focal_640 * width / 640
  double rotation_deg = 60;          // body yaw uniform in [-rotation, +rotation] (180+ = full turn)
  bool floor = false;                // render a floor plane behind the body (label 255)
  int people = 1;                    // bodies per frame, 1..8 (--people N); body 0 is `joints`
  int clutter = 0;                   // furniture on the floor per frame, 0..32 (--clutter N), label 255
  // Room objects as tall as people per frame, 0..16 (--tall-clutter N), label 255: chairs,
  // shelves, coat stands, doors (ClutterKind). Drawn after everything else in the frame's stream,
  // so a dataset without them is byte-identical to one made before they existed.
  int tall_clutter = 0;
  // --sequence: one scene (camera, bodies, shapes, placements, clutter) drawn from frame 0 of the
  // seed; frame i advances every body i steps through its clip (the pose library is then kept in
  // clip order, unpruned) and draws fresh sensor noise. A recording-like sequence for trackers.
  bool sequence = false;
  NoiseConfig noise;
  // Clips (clip_index.h): "02" (all clips of subject 02), "02_01" (one clip), "all" (every clip
  // of mocap/clips.tsv), "split:train|validation|test" (splits_path), or a path to a .bvh/.amc
  // file (plain or .gz). Empty = the clips under assets/mocap/cmu.
  std::vector<std::string> clips;
  std::string splits_path = kDefaultSplitsPath;
  int pose_frame_stride = 4;         // sample every 4th mocap frame (30 Hz of 120 Hz) before pruning
  double pose_min_distance_m = 0.05; // D_pose of the furthest-neighbour pruning
  PoseVariation pose_variation;      // synthetic poses added before pruning (pose_pool.h); none by default
  // A pose cache file (pose_cache.h, `--pose-cache`): its real poses are used when it was made
  // for these clips, stride, assets and executable; otherwise the clips are loaded and retargeted
  // and the file written again. The frames do not depend on it. Empty = no cache. Not with sequence.
  std::string pose_cache_path;
  double mirror_probability = 0.5;
  // Scene ranges (see docs/synthetic_data.md).
  double distance_min_m = 1.2, distance_max_m = 4.0;     // camera to body, along the floor
  double camera_height_min_m = 0.5, camera_height_max_m = 1.9;
  double camera_pitch_min_deg = -5, camera_pitch_max_deg = 25;  // positive = looking down
  double camera_roll_max_deg = 6;
  double image_x_margin = 0.05;      // hips project within [margin, 1 - margin] of the width
  // Clothing and hair (wardrobe.h): each body is clothed with probability clothed_share: an
  // outfit and shoes, a hat with hat_probability, a hairstyle with hair_probability, every choice
  // uniform over the wardrobe. An unclothed body is the bare mesh (no hair). 0 = the bare mesh
  // always and the wardrobe is not loaded (the library default; `depthpose synth` uses 0.8).
  double clothed_share = 0.0;
  double hat_probability = 0.15;
  double hair_probability = 0.85;
  // Body shape ranges.
  double age_min_years = 13, age_max_years = 75;
  // Macro controls (MakeHuman's sliders, [0, 1], human_model.h), each uniform in [min, max]. The
  // defaults are adult-like ranges; `synth --bodies wide` (its default) uses [0, 1] for all four.
  double muscle_min = 0.15, muscle_max = 0.85, weight_min = 0.1, weight_max = 0.9;
  double height_min = 0.4, height_max = 0.6, proportions_min = 0.3, proportions_max = 1.0;
  // Standing height (metres, rest pose, feet to crown, after the extra scale): a body outside
  // [stature_min_m, stature_max_m] is scaled vertically about its feet to the nearer limit.
  // 0 = no limit (the default; `synth --bodies wide` uses 1.1-2.0 m).
  double stature_min_m = 0, stature_max_m = 0;
  double extra_scale = 0.10;         // +-10 % extra height and weight (paper)
};

// A further body of a --people frame (placed like body 0, at least 0.8 m from every other body).
struct OtherPerson {
  size_t pose_index = 0;
  bool mirror = false;
  ShapeControls shape;
  double yaw_deg = 0, distance_m = 2.5, image_x = 0.5;
  Outfit outfit;
};

// What a piece of clutter is. kBox and kCylinder are --clutter (0.3–0.8 m tall); the rest are
// --tall-clutter, room objects whose heights and outlines overlap people's:
//   kChair      seat (width × depth, top 0.42–0.48 m) on four 4 cm legs, a 4 cm back panel
//               along the seat's +z edge up to `height` (0.8–1.1 m);
//   kShelf      a solid box 1.2–2.0 m tall (shelf, cabinet, wardrobe);
//   kCoatStand  a 5 cm pole up to `height` (1.6–1.9 m) on a 0.35 m base disc, with a crown of
//               diameter `width` (0.3–0.45 m) over its top 0.25 m (hooks, hanging coats);
//   kDoor       a 4 cm slab 0.75–0.95 m wide and 1.95–2.1 m tall (a door or room divider).
enum class ClutterKind : uint8_t { kBox, kCylinder, kChair, kShelf, kCoatStand, kDoor };
const char* clutter_kind_name(ClutterKind kind);  // "box", "cylinder", "chair", "shelf", "coat_stand", "door"

// A piece of clutter standing on the floor (world frame: floor y = 0, x = the camera's left,
// z forward; see make_camera in synth.cc), turned by yaw about its centre (x, z). width × depth is
// its footprint (a cylinder's or coat stand's: the diameter), height its top above the floor
// (metres). Kept clear of every body (0.55 m + half its footprint's diagonal from each body's
// placement point) and of the other pieces.
struct ClutterItem {
  ClutterKind kind = ClutterKind::kBox;
  double x = 0, z = 0, yaw_deg = 0, width = 0.5, depth = 0.5, height = 0.5;
};

// Everything that varies per frame; sample_frame_params draws it from the frame's stream, tests
// may edit it (e.g. fix yaw, mirror) before render.
struct FrameParams {
  uint64_t frame_index = 0;
  uint64_t noise_seed = 0;
  size_t pose_index = 0;
  bool mirror = false;
  ShapeControls shape;
  double yaw_deg = 0;               // 0 = facing the camera; positive turns the body to its left
  double camera_height_m = 1.0, camera_pitch_deg = 0, camera_roll_deg = 0;
  double distance_m = 2.5;          // along the floor, camera to hips
  double image_x = 0.5;             // where the hips project horizontally, fraction of width
  std::vector<OtherPerson> others;  // config.people − 1 further bodies
  std::vector<ClutterItem> clutter; // config.clutter items, then config.tall_clutter items
  Outfit outfit;                    // body 0's clothes and hair
};

struct SynthFrame {
  dp::tools::ImageU16 depth;        // millimetres after noise, 0 = no reading
  dp::tools::ImageU8 parts;         // 0..30 where the body has a reading, 255 elsewhere
  DepthLabelImage clean;            // noise-free render (metres, labels incl. dropped pixels)
  std::vector<dp::tools::JointTruth> joints;  // 16, camera frame, metres, with visibility
  // --people: joints of every body (body 0 = `joints`) and, per pixel, 1 + the index of the body
  // whose reading it is (0 = not a body). Filled for every frame; one entry for one body.
  std::vector<std::vector<dp::tools::JointTruth>> people_joints;
  dp::tools::ImageU8 people;
  std::string extra_json;           // per-frame metadata for frames.jsonl
};

// Optional per-stage wall time of one render() call (seconds, added to what is there), for
// build/bin/bench_synth. shape = shaped_vertices + measure_skeleton; pose = pose_skeleton,
// skinning, joints, mirror and placement; raster = z-buffer depth + labels of bodies, clutter and
// floor; noise = apply_sensor_noise; finish = parts/people images, joint visibility, metadata.
struct SynthStageTimes {
  double shape = 0, pose = 0, raster = 0, noise = 0, finish = 0;
  double total() const { return shape + pose + raster + noise + finish; }
};

class Synthesizer {
 public:
  Synthesizer(const std::string& assets_dir, const SynthConfig& config);

  const SynthConfig& config() const { return config_; }
  const Intrinsics& intrinsics() const { return intrinsics_; }
  const HumanAssets& assets() const { return assets_; }
  const PoseLibrary& pose_library() const { return library_; }
  const PosePoolReport& pose_pool_report() const { return pool_report_; }
  const std::vector<uint8_t>& vertex_labels() const { return vertex_labels_; }
  const std::vector<std::string>& clip_names() const { return clip_names_; }
  // What became of config.pose_cache_path ("" without one): read, or why not and rewritten.
  const std::string& pose_cache_note() const { return pose_cache_note_; }
  const Wardrobe& wardrobe() const { return wardrobe_; }  // empty unless config.clothed_share > 0

  FrameParams sample_frame_params(uint64_t seed, uint64_t frame_index) const;
  SynthFrame render(const FrameParams& params, SynthStageTimes* times = nullptr) const;
  SynthFrame render_frame(uint64_t seed, uint64_t frame_index) const {
    return render(sample_frame_params(seed, frame_index));
  }
  // meta.json content for a dataset made with this synthesizer.
  dp::tools::DatasetMeta dataset_meta() const;

  // Noise-free render of the base-shape body in `pose`, seen from the front (yaw 0) or back
  // (yaw 180) through a long lens (10x the Kinect focal length, nearly orthographic), centred and
  // filling ~90 % of the image. For figures and tests.
  // `outfit` (indices into wardrobe()) dresses the body; any garment needs a loaded wardrobe.
  DepthLabelImage render_body_view(const BodyPose& pose, double yaw_deg, int width, int height,
                                   const Outfit& outfit = {}) const;
  // Renders one labelled body (base shape, given pose, no noise) from the front (yaw 0) or back
  // (yaw 180), camera at hip height, as an image of part colours (docs/parts.md figures).
  dp::tools::ImageRgb render_parts_figure(const BodyPose& pose, double yaw_deg, int width, int height,
                                          const Outfit& outfit = {}) const;

 private:
  FrameParams sample_scene_params(uint64_t seed, uint64_t frame_index) const;
  void sample_outfit(Rng& rng, Outfit& out) const;

  SynthConfig config_;
  Intrinsics intrinsics_;
  HumanAssets assets_;
  std::vector<uint8_t> vertex_labels_;
  PoseLibrary library_;
  PosePoolReport pool_report_;
  std::vector<std::string> clip_names_;
  std::vector<std::string> clip_categories_;  // clips.tsv category per clip_names_ entry ("" = none)
  std::string pose_cache_note_;
  Wardrobe wardrobe_;
};

// Loads the clips named by config.clips (see SynthConfig::clips and clip_index.h) from
// assets_dir/mocap, in parallel; an empty selection means the clips under mocap/cmu. entries_out
// (optional) receives each clip's index entry (category, split), in the same order.
std::vector<MotionClip> load_clips(const std::string& assets_dir, const std::vector<std::string>& selection,
                                   int frame_stride, const std::string& splits_path = kDefaultSplitsPath,
                                   std::vector<ClipEntry>* entries_out = nullptr);
// The two halves of load_clips: the index entries a selection names, and those clips loaded.
std::vector<ClipEntry> selected_clip_entries(const std::string& assets_dir, const std::vector<std::string>& selection,
                                             const std::string& splits_path = kDefaultSplitsPath);
std::vector<MotionClip> load_clip_entries(const std::vector<ClipEntry>& entries, int frame_stride);

// Part colours (31 distinct RGB) for figures and previews; index kNoLabel = black.
void part_colour(uint8_t part, uint8_t rgb[3]);
// Contact sheet row: colourized depth | coloured parts | joints over depth. Appends to `sheet`
// at row `row` (sheet must be 3*w wide and at least (row+1)*h tall).
void draw_preview_row(const SynthFrame& frame, const Intrinsics& k, dp::tools::ImageRgb& sheet, int x0, int y0);

}  // namespace dp::synth
