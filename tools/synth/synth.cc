#include "tools/synth/synth.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <atomic>
#include <filesystem>
#include <mutex>
#include <thread>
#include <nlohmann/json.hpp>

#include "tools/common/body_model.h"
#include "tools/common/error.h"
#include "tools/synth/pose_cache.h"

namespace dp::synth {
using dp::tools::fail;
namespace fs = std::filesystem;

namespace {

constexpr uint64_t kParamStream = 1, kNoiseStream = 2;
constexpr double kJointOcclusionMargin = 0.15;  // metres, visibility rule

// MakeHuman's age control from years: 1 -> 0, 11 -> 0.1875, 25 -> 0.5, 90 -> 1.
double age_control_from_years(double years) {
  if (years <= 1) return 0;
  if (years <= 11) return 0.1875 * (years - 1) / 10.0;
  if (years <= 25) return 0.1875 + (0.5 - 0.1875) * (years - 11) / 14.0;
  return std::min(1.0, 0.5 + 0.5 * (years - 25) / 65.0);
}

// frames.jsonl record of what a body wears (names from the mhclo files, null = none).
nlohmann::json outfit_json(const Wardrobe& wardrobe_, const Outfit& outfit) {
  auto name = [&](GarmentKind k, int i) { return i < 0 ? nlohmann::json(nullptr) : nlohmann::json(wardrobe_.of(k)[size_t(i)].garment.name); };
  return {{"clothes", name(GarmentKind::kOutfit, outfit.outfit)}, {"shoes", name(GarmentKind::kShoes, outfit.shoes)},
          {"hat", name(GarmentKind::kHat, outfit.hat)}, {"hair", name(GarmentKind::kHair, outfit.hair)}};
}

void sample_shape(Rng& rng, const SynthConfig& c, ShapeControls& s) {
  s.gender = rng.uniform();
  s.age = age_control_from_years(rng.uniform(c.age_min_years, c.age_max_years));
  s.muscle = rng.uniform(c.muscle_min, c.muscle_max);
  s.weight = rng.uniform(c.weight_min, c.weight_max);
  s.height = rng.uniform(c.height_min, c.height_max);  // adult defaults: ~1.5-1.9 m before the extra scale
  s.proportions = rng.uniform(c.proportions_min, c.proportions_max);
  s.african = rng.uniform();
  s.asian = rng.uniform();
  s.caucasian = rng.uniform();
  s.extra_height = 1.0 + rng.uniform(-c.extra_scale, c.extra_scale);
  s.extra_weight = 1.0 + rng.uniform(-c.extra_scale, c.extra_scale);
}

}  // namespace

std::vector<ClipEntry> selected_clip_entries(const std::string& assets_dir, const std::vector<std::string>& selection,
                                             const std::string& splits_path) {
  const std::string mocap = assets_dir + "/mocap";
  std::vector<ClipEntry> entries;
  if (selection.empty()) {
    // The original 28-clip corpus (mocap/cmu): the default before the index existed.
    for (ClipEntry& e : read_clip_index(mocap))
      if (e.path.rfind(mocap + "/cmu/", 0) == 0) entries.push_back(std::move(e));
    if (entries.empty()) fail(mocap + "/cmu holds no clips");
  } else {
    entries = select_clips(mocap, selection, splits_path);
  }
  return entries;
}

std::vector<MotionClip> load_clips(const std::string& assets_dir, const std::vector<std::string>& selection,
                                   int frame_stride, const std::string& splits_path,
                                   std::vector<ClipEntry>* entries_out) {
  std::vector<ClipEntry> entries = selected_clip_entries(assets_dir, selection, splits_path);
  std::vector<MotionClip> clips = load_clip_entries(entries, frame_stride);
  if (entries_out) *entries_out = std::move(entries);
  return clips;
}

std::vector<MotionClip> load_clip_entries(const std::vector<ClipEntry>& entries, int frame_stride) {
  // Clips parse independently: one worker per core.
  std::vector<MotionClip> clips(entries.size());
  std::atomic<size_t> next{0};
  std::mutex error_mutex;
  std::string error;
  auto worker = [&]() {
    for (;;) {
      const size_t i = next.fetch_add(1);
      if (i >= entries.size()) return;
      try {
        clips[i] = load_clip(entries[i], frame_stride);
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (error.empty()) error = e.what();
        next.store(entries.size());
        return;
      }
    }
  };
  const size_t threads = std::min<size_t>(entries.size(), std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::thread> pool;
  for (size_t t = 0; t < threads; ++t) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  if (!error.empty()) fail(error);
  return clips;
}

Synthesizer::Synthesizer(const std::string& assets_dir, const SynthConfig& config) : config_(config) {
  if (config_.width < 16 || config_.height < 16 || config_.width > 4096 || config_.height > 4096)
    fail("image size " + std::to_string(config_.width) + "x" + std::to_string(config_.height) + " out of range");
  if (config_.people < 1 || config_.people > 8) fail("--people must be 1..8, got " + std::to_string(config_.people));
  if (config_.clutter < 0 || config_.clutter > 32) fail("--clutter must be 0..32, got " + std::to_string(config_.clutter));
  if (config_.tall_clutter < 0 || config_.tall_clutter > 16)
    fail("--tall-clutter must be 0..16, got " + std::to_string(config_.tall_clutter));
  intrinsics_ = Intrinsics::kinect_like(config_.width, config_.height);
  intrinsics_.fx = intrinsics_.fy = config_.focal_640 * config_.width / 640.0;
  assets_ = load_human_assets(assets_dir);
  vertex_labels_ = vertex_part_labels(assets_);
  if (!(config_.clothed_share >= 0 && config_.clothed_share <= 1))
    fail("clothed share must be in [0, 1], got " + std::to_string(config_.clothed_share));
  if (config_.clothed_share > 0) wardrobe_ = load_wardrobe(assets_dir, assets_, vertex_labels_);
  const std::vector<ClipEntry> entries = selected_clip_entries(assets_dir, config_.clips, config_.splits_path);
  std::vector<std::string> categories;
  for (const ClipEntry& e : entries) categories.push_back(e.category);
  clip_categories_ = categories;
  if (config_.sequence) {
    if (!config_.pose_cache_path.empty()) fail("a pose cache serves the pruned pose pool; --sequence uses none");
    // A sequence walks through the clips frame by frame: no pruning, clip order kept.
    const std::vector<MotionClip> clips = load_clip_entries(entries, config_.pose_frame_stride);
    for (const MotionClip& c : clips) clip_names_.push_back(c.name);
    library_ = build_pose_library(assets_, clips, 0.0, /*keep_order=*/true);
  } else {
    // The real poses: from the pose cache when it was made for exactly these inputs, otherwise
    // loaded, retargeted (and cached). Variation and pruning run either way (they depend on the seed).
    RealPoses real;
    bool cached = false;
    std::string key;
    if (!config_.pose_cache_path.empty()) {
      key = pose_cache_key(assets_dir, entries, config_.pose_frame_stride);
      cached = read_pose_cache(config_.pose_cache_path, key, assets_.bones.size(), &real, &clip_names_,
                               &pose_cache_note_);
      if (cached && clip_names_.size() != entries.size()) {
        cached = false;
        pose_cache_note_ = "pose cache " + config_.pose_cache_path + " not used: it holds another number of clips";
      }
      if (cached) pose_cache_note_ = "pose cache " + config_.pose_cache_path + ": real poses read";
    }
    if (!cached) {
      const std::vector<MotionClip> clips = load_clip_entries(entries, config_.pose_frame_stride);
      clip_names_.clear();
      for (const MotionClip& c : clips) clip_names_.push_back(c.name);
      real = retarget_pool(assets_, clips, categories);
      if (!config_.pose_cache_path.empty()) {
        write_pose_cache(config_.pose_cache_path, key, real, clip_names_);
        pose_cache_note_ += "; written from the clips";
      }
    }
    library_ = build_pose_pool(assets_, std::move(real), config_.pose_variation, config_.pose_min_distance_m,
                               &pool_report_);
  }
  if (library_.poses.empty()) fail("no poses from the selected clips");
}

const char* clutter_kind_name(ClutterKind kind) {
  switch (kind) {
    case ClutterKind::kBox: return "box";
    case ClutterKind::kCylinder: return "cylinder";
    case ClutterKind::kChair: return "chair";
    case ClutterKind::kShelf: return "shelf";
    case ClutterKind::kCoatStand: return "coat_stand";
    case ClutterKind::kDoor: return "door";
  }
  return "unknown";
}

FrameParams Synthesizer::sample_frame_params(uint64_t seed, uint64_t frame_index) const {
  if (config_.sequence) {
    FrameParams p = sample_scene_params(seed, 0);
    const size_t n = library_.poses.size();
    p.frame_index = frame_index;
    p.noise_seed = Rng::for_frame(seed, frame_index, kNoiseStream).next();
    p.pose_index = (p.pose_index + frame_index) % n;
    for (OtherPerson& o : p.others) o.pose_index = (o.pose_index + frame_index) % n;
    return p;
  }
  return sample_scene_params(seed, frame_index);
}

FrameParams Synthesizer::sample_scene_params(uint64_t seed, uint64_t frame_index) const {
  Rng rng = Rng::for_frame(seed, frame_index, kParamStream);
  const SynthConfig& c = config_;
  FrameParams p;
  p.frame_index = frame_index;
  p.noise_seed = Rng::for_frame(seed, frame_index, kNoiseStream).next();
  p.pose_index = size_t(rng.below(library_.poses.size()));
  p.mirror = rng.chance(c.mirror_probability);
  sample_shape(rng, c, p.shape);
  const double rot = std::min(180.0, c.rotation_deg);
  p.yaw_deg = rng.uniform(-rot, rot);
  p.camera_height_m = rng.uniform(c.camera_height_min_m, c.camera_height_max_m);
  p.camera_pitch_deg = rng.uniform(c.camera_pitch_min_deg, c.camera_pitch_max_deg);
  p.camera_roll_deg = rng.uniform(-c.camera_roll_max_deg, c.camera_roll_max_deg);
  p.distance_m = rng.uniform(c.distance_min_m, c.distance_max_m);
  p.image_x = rng.uniform(c.image_x_margin, 1.0 - c.image_x_margin);
  // --people and --clutter draw after everything above, so one-body frames without clutter stay
  // exactly what they were. Placement: rejection sampling with a bounded number of tries.
  const Intrinsics& k = intrinsics_;
  auto floor_point = [&](double distance, double image_x, double out[2]) {
    const double lateral = (image_x * k.width - k.cx) / k.fx;
    out[0] = -distance * lateral;  // world x (camera right is −x)
    out[1] = distance;
  };
  std::vector<std::array<double, 2>> bodies(1);
  floor_point(p.distance_m, p.image_x, bodies[0].data());
  for (int n = 1; n < c.people; ++n) {
    OtherPerson o;
    for (int attempt = 0; attempt < 50; ++attempt) {
      o.distance_m = rng.uniform(c.distance_min_m, c.distance_max_m);
      o.image_x = rng.uniform(c.image_x_margin, 1.0 - c.image_x_margin);
      std::array<double, 2> at;
      floor_point(o.distance_m, o.image_x, at.data());
      bool clear = true;
      for (const auto& b : bodies) clear = clear && std::hypot(at[0] - b[0], at[1] - b[1]) >= 0.8;
      if (clear || attempt == 49) {
        bodies.push_back(at);
        break;
      }
    }
    o.pose_index = size_t(rng.below(library_.poses.size()));
    o.mirror = rng.chance(c.mirror_probability);
    sample_shape(rng, c, o.shape);
    o.yaw_deg = rng.uniform(-rot, rot);
    p.others.push_back(o);
  }
  // One piece: draw_shape draws its kind, size and yaw, then a floor point is drawn; up to 50
  // tries for a point clear of every body and every piece placed before, else no piece.
  auto place_clutter = [&](auto&& draw_shape) {
    for (int attempt = 0; attempt < 50; ++attempt) {
      ClutterItem item;
      draw_shape(item);
      double at[2];
      floor_point(rng.uniform(1.0, c.distance_max_m + 1.0), rng.uniform(0.0, 1.0), at);
      item.x = at[0];
      item.z = at[1];
      const double reach = 0.5 * std::hypot(item.width, item.depth);
      bool clear = true;
      for (const auto& b : bodies) clear = clear && std::hypot(at[0] - b[0], at[1] - b[1]) >= 0.55 + reach;
      for (const ClutterItem& q : p.clutter)
        clear = clear && std::hypot(at[0] - q.x, at[1] - q.z) >= reach + 0.5 * std::hypot(q.width, q.depth);
      if (clear) {
        p.clutter.push_back(item);
        return;
      }
    }
  };
  for (int n = 0; n < c.clutter; ++n) {
    place_clutter([&](ClutterItem& item) {
      item.kind = rng.chance(0.4) ? ClutterKind::kCylinder : ClutterKind::kBox;
      const bool cylinder = item.kind == ClutterKind::kCylinder;
      item.width = cylinder ? rng.uniform(0.3, 0.7) : rng.uniform(0.3, 1.0);
      item.depth = cylinder ? item.width : rng.uniform(0.3, 0.8);
      item.height = rng.uniform(0.3, 0.8);
      item.yaw_deg = rng.uniform(0.0, 90.0);
    });
  }
  // Clothes draw last, and only when enabled, so bare-mesh datasets stay what they were.
  if (c.clothed_share > 0) {
    sample_outfit(rng, p.outfit);
    for (OtherPerson& o : p.others) sample_outfit(rng, o.outfit);
  }
  // Tall clutter draws after everything, and only when asked for, so other datasets stay as they were.
  for (int n = 0; n < c.tall_clutter; ++n) {
    place_clutter([&](ClutterItem& item) {
      item.kind = ClutterKind(int(ClutterKind::kChair) + int(rng.below(4)));
      switch (item.kind) {
        case ClutterKind::kChair:
          item.width = rng.uniform(0.4, 0.55);
          item.depth = rng.uniform(0.4, 0.5);
          item.height = rng.uniform(0.8, 1.1);
          break;
        case ClutterKind::kShelf:
          item.width = rng.uniform(0.4, 1.0);
          item.depth = rng.uniform(0.3, 0.45);
          item.height = rng.uniform(1.2, 2.0);
          break;
        case ClutterKind::kCoatStand:
          item.width = item.depth = rng.uniform(0.3, 0.45);
          item.height = rng.uniform(1.6, 1.9);
          break;
        default:  // kDoor
          item.width = rng.uniform(0.75, 0.95);
          item.depth = 0.04;
          item.height = rng.uniform(1.95, 2.1);
          break;
      }
      item.yaw_deg = rng.uniform(0.0, 360.0);
    });
  }
  return p;
}

void Synthesizer::sample_outfit(Rng& rng, Outfit& out) const {
  out = Outfit{};
  if (!rng.chance(config_.clothed_share)) return;
  auto pick = [&](GarmentKind k) { return int(rng.below(wardrobe_.of(k).size())); };
  out.outfit = pick(GarmentKind::kOutfit);
  out.shoes = pick(GarmentKind::kShoes);
  if (rng.chance(config_.hat_probability)) out.hat = pick(GarmentKind::kHat);
  if (rng.chance(config_.hair_probability)) out.hair = pick(GarmentKind::kHair);
}

namespace {

// World: y up, floor y = 0, camera at (0, h, 0) looking along +z before pitch/roll (right-handed,
// so the camera's right is -x). Camera frame: x right, y up, z forward.
struct CameraPose {
  Mat3 world_to_camera;  // includes the x flip
  Vec3 position;
};

CameraPose make_camera(const FrameParams& p) {
  Mat3 flip;
  flip.m = {-1, 0, 0, 0, 1, 0, 0, 0, 1};
  CameraPose c;
  c.world_to_camera = rot_z(p.camera_roll_deg * kDegToRad) * flip * rot_x(-p.camera_pitch_deg * kDegToRad);
  c.position = {0, p.camera_height_m, 0};
  return c;
}

struct PosedBody {
  std::vector<Vec3f> vertices;  // camera frame
  JointSet joints;              // camera frame, meta order
  std::vector<uint8_t> const* labels = nullptr;
  bool mirrored = false;
};

}  // namespace

SynthFrame Synthesizer::render(const FrameParams& p, SynthStageTimes* times) const {
  // Stage clock for `times` (no clock reads when it is null).
  auto mark = std::chrono::steady_clock::time_point();
  auto lap = [&](double SynthStageTimes::*stage) {
    if (!times) return;
    const auto now = std::chrono::steady_clock::now();
    times->*stage += std::chrono::duration<double>(now - mark).count();
    mark = now;
  };
  if (times) mark = std::chrono::steady_clock::now();
  const Intrinsics& k = intrinsics_;
  const CameraPose cam = make_camera(p);
  SynthFrame f;
  f.clean.reset(k.width, k.height);
  std::vector<uint8_t> body_of(size_t(k.width) * k.height, 0);  // 1 + body index, 0 = none
  std::vector<float> before;
  bool drawn = false;
  // Draws into f.clean with the z-test; pixels it wins take `owner` in body_of. The first draw
  // starts from an all-zero depth, so there "changed" is "non-zero" and no copy is needed.
  auto draw = [&](const std::vector<Vec3f>& verts, const std::vector<std::array<uint32_t, 3>>& tris,
                  const std::vector<uint8_t>& labels, uint8_t owner) {
    if (!drawn) {
      drawn = true;
      rasterize(k, verts, tris, labels, f.clean);
      for (size_t i = 0; i < f.clean.depth.size(); ++i)
        if (f.clean.depth[i] != 0.0f) body_of[i] = owner;
      return;
    }
    before = f.clean.depth;
    rasterize(k, verts, tris, labels, f.clean);
    for (size_t i = 0; i < before.size(); ++i)
      if (f.clean.depth[i] != before[i]) body_of[i] = owner;
  };

  std::vector<JointSet> body_joints;
  double body0_stature = 0;
  const size_t bodies = 1 + p.others.size();
  for (size_t b = 0; b < bodies; ++b) {
    OtherPerson o;
    if (b == 0) {
      o.pose_index = p.pose_index;
      o.mirror = p.mirror;
      o.shape = p.shape;
      o.yaw_deg = p.yaw_deg;
      o.distance_m = p.distance_m;
      o.image_x = p.image_x;
      o.outfit = p.outfit;
    } else {
      o = p.others[b - 1];
    }
    if (o.pose_index >= library_.poses.size()) fail("pose index out of range");
    const BodyPose& pose = library_.poses[o.pose_index];

    // Shape, skeleton, pose, skin.
    std::vector<Vec3f> shaped = shaped_vertices(assets_, o.shape);
    const double stature = limit_stature(shaped, config_.stature_min_m, config_.stature_max_m);
    if (b == 0) body0_stature = stature;
    const Skeleton rest = measure_skeleton(assets_, shaped);
    lap(&SynthStageTimes::shape);
    const Skeleton posed = pose_skeleton(assets_, rest, pose);
    thread_local std::vector<Vec3f> verts;
    skin_body(assets_, shaped, rest, posed, pose, verts);
    JointSet joints = joints_of(assets_, posed);
    // Clothes and hair: garment vertices appended after the body's, hidden body triangles dropped.
    const std::vector<uint8_t>* labels = &vertex_labels_;
    const std::vector<std::array<uint32_t, 3>>* triangles = &assets_.body_triangles;
    thread_local std::vector<uint8_t> dressed_labels;
    thread_local std::vector<std::array<uint32_t, 3>> dressed_triangles;
    if (o.outfit.clothed()) {
      dress_body(wardrobe_, o.outfit, assets_, vertex_labels_, shaped, bone_skin_transforms(assets_, rest, posed, pose),
                 verts, dressed_labels, dressed_triangles);
      labels = &dressed_labels;
      triangles = &dressed_triangles;
    }

    // Mirror (in body space): x -> -x, swap left/right labels and joints.
    thread_local std::vector<uint8_t> mirrored_labels;
    if (o.mirror) {
      for (Vec3f& v : verts) v.x = -v.x;
      for (Vec3& j : joints) j.x = -j.x;
      JointSet swapped;
      for (int j = 0; j < dp::tools::kJointCount; ++j) swapped[dp::tools::kJointMirror[j]] = joints[j];
      joints = swapped;
      mirrored_labels.resize(labels->size());
      for (size_t i = 0; i < labels->size(); ++i) mirrored_labels[i] = dp::tools::kPartMirror[(*labels)[i]];
      labels = &mirrored_labels;
    }

    // Stand on the floor: lowest vertex at y = 0, hips above the placement point.
    const int hips = assets_.bone_index("Hips");
    Vec3 hip = posed.heads[hips];
    if (o.mirror) hip.x = -hip.x;
    float min_y = verts[0].y;
    for (const Vec3f& v : verts) min_y = std::min(min_y, v.y);
    // Body -> world: turn to face the camera (-z) and by yaw; place at distance along the view.
    const double lateral = (o.image_x * k.width - k.cx) / k.fx;  // tan of the horizontal angle
    const Vec3 place{-o.distance_m * lateral, 0, o.distance_m};     // camera right is -x
    const Mat3 body_rot = rot_y(M_PI + o.yaw_deg * kDegToRad);
    const Mat3 m = cam.world_to_camera * body_rot;
    const Vec3 offset = cam.world_to_camera * (place - cam.position) - m * Vec3{hip.x, double(min_y), hip.z};
    float mf[9];
    for (int i = 0; i < 9; ++i) mf[i] = float(m.m[i]);
    const float ox = float(offset.x), oy = float(offset.y), oz = float(offset.z);
    for (Vec3f& v : verts) {
      const float x = v.x, y = v.y, z = v.z;
      v = {mf[0] * x + mf[1] * y + mf[2] * z + ox, mf[3] * x + mf[4] * y + mf[5] * z + oy,
           mf[6] * x + mf[7] * y + mf[8] * z + oz};
    }
    for (Vec3& j : joints) j = m * j + offset;
    lap(&SynthStageTimes::pose);
    draw(verts, *triangles, *labels, uint8_t(b + 1));
    body_joints.push_back(joints);
    lap(&SynthStageTimes::raster);
  }

  // Clutter, label kNoLabel: each piece is one mesh of upright prisms (4-sided boxes, 16-sided
  // cylinders) with their side walls, a top fan and, when raised off the floor, a bottom fan.
  for (const ClutterItem& item : p.clutter) {
    std::vector<Vec3f> verts;
    std::vector<std::array<uint32_t, 3>> tris;
    const double c = std::cos(item.yaw_deg * kDegToRad), s = std::sin(item.yaw_deg * kDegToRad);
    auto add = [&](double lx, double y, double lz) {
      const Vec3 w{item.x + c * lx - s * lz, y, item.z + s * lx + c * lz};
      const Vec3 q = cam.world_to_camera * (w - cam.position);
      verts.push_back({float(q.x), float(q.y), float(q.z)});
    };
    // A prism centred at (cx, cz) in the piece's frame, width × depth (a cylinder: diameter
    // width), from y0 to y1 above the floor.
    auto prism = [&](bool cylinder, double cx, double cz, double width, double depth, double y0, double y1) {
      const uint32_t base = uint32_t(verts.size());
      const int sides = cylinder ? 16 : 4;
      for (int i = 0; i < sides; ++i) {
        double lx, lz;
        if (cylinder) {
          lx = 0.5 * width * std::cos(2 * M_PI * i / sides);
          lz = 0.5 * width * std::sin(2 * M_PI * i / sides);
        } else {
          lx = (i == 1 || i == 2 ? 0.5 : -0.5) * width;
          lz = (i >= 2 ? 0.5 : -0.5) * depth;
        }
        add(lx + cx, y0, lz + cz);
        add(lx + cx, y1, lz + cz);
      }
      add(cx, y1, cz);  // top centre
      const uint32_t top = uint32_t(verts.size() - 1);
      for (int i = 0; i < sides; ++i) {
        const uint32_t a0 = base + uint32_t(2 * i), a1 = a0 + 1, b0 = base + uint32_t(2 * ((i + 1) % sides)),
                       b1 = b0 + 1;
        tris.push_back({a0, b0, a1});
        tris.push_back({a1, b0, b1});
        tris.push_back({a1, b1, top});
      }
      if (y0 > 0) {
        add(cx, y0, cz);  // bottom centre
        const uint32_t bottom = uint32_t(verts.size() - 1);
        for (int i = 0; i < sides; ++i)
          tris.push_back({base + uint32_t(2 * i), base + uint32_t(2 * ((i + 1) % sides)), bottom});
      }
    };
    const double w = item.width, d = item.depth, h = item.height;
    switch (item.kind) {
      case ClutterKind::kBox:
      case ClutterKind::kShelf:
      case ClutterKind::kDoor:
        prism(false, 0.0, 0.0, w, d, 0.0, h);
        break;
      case ClutterKind::kCylinder:
        prism(true, 0.0, 0.0, w, w, 0.0, h);
        break;
      case ClutterKind::kChair: {
        // Seat top at 0.45 m (0.42–0.48 with the seat's size), legs at its corners, back at +z.
        const double seat_top = 0.42 + 0.06 * (w - 0.4) / 0.15, leg = 0.04, panel = 0.04;
        for (int corner = 0; corner < 4; ++corner)
          prism(false, (corner & 1 ? 0.5 : -0.5) * (w - leg), (corner & 2 ? 0.5 : -0.5) * (d - leg), leg, leg, 0.0,
                seat_top - 0.05);
        prism(false, 0.0, 0.0, w, d, seat_top - 0.05, seat_top);
        prism(false, 0.0, 0.5 * (d - panel), w, panel, seat_top, h);
        break;
      }
      case ClutterKind::kCoatStand:
        prism(true, 0.0, 0.0, 0.35, 0.35, 0.0, 0.03);
        prism(true, 0.0, 0.0, 0.05, 0.05, 0.03, h - 0.25);
        prism(true, 0.0, 0.0, w, w, h - 0.25, h);
        break;
    }
    draw(verts, tris, std::vector<uint8_t>(verts.size(), kNoLabel), 0);
  }
  if (config_.floor) {
    const Vec3 n = cam.world_to_camera * Vec3{0, 1, 0};
    rasterize_plane(k, n, -p.camera_height_m, config_.noise.max_range_m, f.clean);
  }
  lap(&SynthStageTimes::raster);

  Rng noise_rng(p.noise_seed);
  apply_sensor_noise(k, config_.noise, f.clean.depth, noise_rng, f.depth);
  lap(&SynthStageTimes::noise);
  f.parts.width = k.width;
  f.parts.height = k.height;
  f.parts.pixels.assign(size_t(k.width) * k.height, dp::tools::kNotBodyLabel);
  for (size_t i = 0; i < f.parts.pixels.size(); ++i)
    if (f.depth.pixels[i] != 0) f.parts.pixels[i] = f.clean.label[i];

  f.people.width = k.width;
  f.people.height = k.height;
  f.people.pixels.assign(size_t(k.width) * k.height, 0);
  for (size_t i = 0; i < f.people.pixels.size(); ++i)
    if (f.parts.pixels[i] != dp::tools::kNotBodyLabel) f.people.pixels[i] = body_of[i];
  for (const JointSet& joints : body_joints) {
    std::vector<dp::tools::JointTruth> truth(dp::tools::kJointCount);
    for (int j = 0; j < dp::tools::kJointCount; ++j) {
      dp::tools::JointTruth& t = truth[j];
      t.x = float(joints[j].x);
      t.y = float(joints[j].y);
      t.z = float(joints[j].z);
      t.visible = false;
      if (joints[j].z > kNearPlane) {
        const int u = int(std::lround(k.cx + k.fx * joints[j].x / joints[j].z));
        const int v = int(std::lround(k.cy - k.fy * joints[j].y / joints[j].z));
        if (u >= 0 && v >= 0 && u < k.width && v < k.height) {
          const float d = f.clean.depth[size_t(v) * k.width + u];
          t.visible = d == 0 || d >= joints[j].z - kJointOcclusionMargin;
        }
      }
    }
    f.people_joints.push_back(std::move(truth));
  }
  f.joints = f.people_joints[0];

  nlohmann::json extra;
  extra["pose"] = library_.origin[p.pose_index];
  // The clip the pose comes from (for a recombined pose, the clip of its lower body) and its clips.tsv
  // category: eval reports accuracy per held-out category and subject from these.
  const std::string& origin = library_.origin[p.pose_index];
  const std::string clip = origin.substr(0, origin.find(':'));
  extra["clip"] = clip;
  const auto named = std::find(clip_names_.begin(), clip_names_.end(), clip);
  if (named != clip_names_.end() && !clip_categories_[size_t(named - clip_names_.begin())].empty())
    extra["category"] = clip_categories_[size_t(named - clip_names_.begin())];
  extra["mirror"] = p.mirror;
  extra["shape"] = {{"gender", p.shape.gender},        {"age", p.shape.age},
                    {"muscle", p.shape.muscle},        {"weight", p.shape.weight},
                    {"height", p.shape.height},        {"proportions", p.shape.proportions},
                    {"extra_height", p.shape.extra_height}, {"extra_weight", p.shape.extra_weight},
                    {"stature", std::round(body0_stature * 1000) / 1000}};
  extra["rotation"] = p.yaw_deg;
  extra["camera"] = {{"height", p.camera_height_m}, {"pitch", p.camera_pitch_deg}, {"roll", p.camera_roll_deg}};
  extra["distance"] = p.distance_m;
  if (config_.clothed_share > 0) extra["outfit"] = outfit_json(wardrobe_, p.outfit);
  if (!p.others.empty()) {
    nlohmann::json people = nlohmann::json::array();
    for (size_t b = 0; b < f.people_joints.size(); ++b) {
      nlohmann::json joints = nlohmann::json::array();
      for (const dp::tools::JointTruth& t : f.people_joints[b]) joints.push_back({t.x, t.y, t.z, t.visible ? 1 : 0});
      nlohmann::json person;
      person["id"] = b + 1;
      person["joints"] = joints;
      person["pose"] = library_.origin[b == 0 ? p.pose_index : p.others[b - 1].pose_index];
      person["rotation"] = b == 0 ? p.yaw_deg : p.others[b - 1].yaw_deg;
      person["distance"] = b == 0 ? p.distance_m : p.others[b - 1].distance_m;
      if (config_.clothed_share > 0) person["outfit"] = outfit_json(wardrobe_, b == 0 ? p.outfit : p.others[b - 1].outfit);
      people.push_back(person);
    }
    extra["people"] = people;
  }
  if (!p.clutter.empty()) {
    nlohmann::json items = nlohmann::json::array();
    for (const ClutterItem& c : p.clutter)
      items.push_back({{"shape", clutter_kind_name(c.kind)}, {"x", c.x}, {"z", c.z}, {"yaw", c.yaw_deg},
                       {"width", c.width}, {"depth", c.depth}, {"height", c.height}});
    extra["clutter"] = items;
  }
  f.extra_json = extra.dump();
  lap(&SynthStageTimes::finish);
  return f;
}

dp::tools::DatasetMeta Synthesizer::dataset_meta() const {
  dp::tools::DatasetMeta m;
  m.width = intrinsics_.width;
  m.height = intrinsics_.height;
  m.fx = intrinsics_.fx;
  m.fy = intrinsics_.fy;
  m.cx = intrinsics_.cx;
  m.cy = intrinsics_.cy;
  for (const char* n : dp::tools::kPartNames) m.parts.push_back(n);
  for (const char* n : dp::tools::kJointNames) m.joints.push_back(n);
  nlohmann::json extra;
  extra["generator"] = "depthpose synth";
  extra["pose_count"] = library_.poses.size();
  extra["clips"] = clip_names_;
  extra["floor"] = config_.floor;
  extra["noise"] = config_.noise.enabled;
  if (config_.people > 1) extra["people"] = config_.people;
  if (config_.clutter > 0) extra["clutter"] = config_.clutter;
  if (config_.tall_clutter > 0) extra["tall_clutter"] = config_.tall_clutter;
  if (config_.sequence) extra["sequence"] = true;
  if (config_.clothed_share > 0)
    extra["clothing"] = {{"clothed_share", config_.clothed_share}, {"hat_probability", config_.hat_probability},
                         {"hair_probability", config_.hair_probability}};
  if (config_.pose_variation.any() && !config_.sequence)
    extra["pose_variation"] = {{"mirror", config_.pose_variation.mirror},
                               {"noise_copies", config_.pose_variation.noise_copies},
                               {"recombined_per_pose", config_.pose_variation.recombined_per_pose},
                               {"noise_scale", config_.pose_variation.noise_scale},
                               {"seed", config_.pose_variation.seed}};
  m.extra_json = extra.dump();
  return m;
}

void part_colour(uint8_t part, uint8_t rgb[3]) {
  if (part >= dp::tools::kPartCount) {
    rgb[0] = rgb[1] = rgb[2] = 0;
    return;
  }
  // Hues spread by the golden angle; left/right partners get clearly different hues.
  const double h = std::fmod(part * 0.618033988749895 * 360.0, 360.0);
  const double s = (part % 3 == 0) ? 0.95 : (part % 3 == 1 ? 0.7 : 0.55);
  const double v = (part % 2 == 0) ? 0.95 : 0.8;
  const double c = v * s, x = c * (1 - std::fabs(std::fmod(h / 60.0, 2) - 1)), m = v - c;
  double r = 0, g = 0, b = 0;
  if (h < 60) { r = c; g = x; } else if (h < 120) { r = x; g = c; } else if (h < 180) { g = c; b = x; }
  else if (h < 240) { g = x; b = c; } else if (h < 300) { r = x; b = c; } else { r = c; b = x; }
  rgb[0] = uint8_t(255 * (r + m));
  rgb[1] = uint8_t(255 * (g + m));
  rgb[2] = uint8_t(255 * (b + m));
}

namespace {
void colourize_depth(uint16_t mm, uint16_t lo, uint16_t hi, uint8_t rgb[3]) {
  if (mm == 0) {
    rgb[0] = rgb[1] = rgb[2] = 0;
    return;
  }
  const double t = hi > lo ? std::clamp(double(mm - lo) / double(hi - lo), 0.0, 1.0) : 0.5;
  // near = warm, far = cool
  rgb[0] = uint8_t(255 * std::clamp(1.5 - 2.0 * t, 0.0, 1.0));
  rgb[1] = uint8_t(255 * std::clamp(1.0 - std::fabs(2.0 * t - 0.8), 0.15, 1.0));
  rgb[2] = uint8_t(255 * std::clamp(2.0 * t - 0.3, 0.0, 1.0));
}

void draw_line(dp::tools::ImageRgb& img, int xa, int ya, int xb, int yb, int x_lo, int x_hi, const uint8_t c[3]) {
  const int n = std::max(std::abs(xb - xa), std::abs(yb - ya));
  for (int i = 0; i <= n; ++i) {
    const int x = n ? xa + (xb - xa) * i / n : xa, y = n ? ya + (yb - ya) * i / n : ya;
    if (x >= x_lo && x < x_hi) img.set(x, y, c[0], c[1], c[2]);
  }
}
}  // namespace

void draw_preview_row(const SynthFrame& f, const Intrinsics& k, dp::tools::ImageRgb& sheet, int x0, int y0) {
  const int W = f.depth.width, H = f.depth.height;
  uint16_t lo = 65535, hi = 0;
  for (uint16_t d : f.depth.pixels)
    if (d) {
      lo = std::min(lo, d);
      hi = std::max(hi, d);
    }
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t i = size_t(y) * W + x;
      uint8_t c[3];
      colourize_depth(f.depth.pixels[i], lo, hi, c);
      sheet.set(x0 + x, y0 + y, c[0], c[1], c[2]);
      part_colour(f.parts.pixels[i], c);
      sheet.set(x0 + W + x, y0 + y, c[0], c[1], c[2]);
      const uint8_t g = f.depth.pixels[i] ? uint8_t(60 + 160 * (hi > lo ? double(hi - f.depth.pixels[i]) / (hi - lo) : 0.5)) : 0;
      sheet.set(x0 + 2 * W + x, y0 + y, g, g, g);
    }
  // Joints and bones over the third panel; left side blue, right side red, centre green.
  static const int bones[][2] = {{0, 1}, {1, 2}, {1, 3}, {2, 4}, {3, 5}, {4, 6}, {5, 7}, {6, 8}, {7, 9},
                                 {2, 10}, {3, 11}, {10, 12}, {11, 13}, {12, 14}, {13, 15}};
  auto project = [&](int j, int& u, int& v) {
    const auto& t = f.joints[j];
    if (t.z <= kNearPlane) return false;
    u = int(std::lround(k.cx + k.fx * t.x / t.z));
    v = int(std::lround(k.cy - k.fy * t.y / t.z));
    return true;
  };
  auto colour_of = [](int j, uint8_t c[3]) {
    const bool left = j >= 2 && j % 2 == 0, right = j >= 2 && j % 2 == 1;
    c[0] = right ? 255 : 40;
    c[1] = (!left && !right) ? 230 : 60;
    c[2] = left ? 255 : 40;
  };
  for (auto& b : bones) {
    int ua, va, ub, vb;
    if (!project(b[0], ua, va) || !project(b[1], ub, vb)) continue;
    uint8_t c[3];
    colour_of(b[1], c);
    draw_line(sheet, x0 + 2 * W + ua, y0 + va, x0 + 2 * W + ub, y0 + vb, x0 + 2 * W, x0 + 3 * W, c);
  }
  for (int j = 0; j < int(f.joints.size()); ++j) {
    int u, v;
    if (!project(j, u, v)) continue;
    uint8_t c[3];
    colour_of(j, c);
    if (!f.joints[j].visible) c[0] = c[1] = c[2] = 255;
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx) {
        const int x = u + dx, y = v + dy;
        if (x >= 0 && y >= 0 && x < W && y < H && (std::abs(dx) == 2 || std::abs(dy) == 2))
          sheet.set(x0 + 2 * W + x, y0 + y, c[0], c[1], c[2]);
      }
  }
}

DepthLabelImage Synthesizer::render_body_view(const BodyPose& pose, double yaw_deg, int width, int height,
                                              const Outfit& outfit) const {
  // A long lens far away: nearly orthographic, so part borders appear at their true heights.
  Intrinsics k = Intrinsics::kinect_like(width, height);
  k.fx = k.fy = k.fx * 10;
  const std::vector<Vec3f> shaped = shaped_vertices(assets_, ShapeControls{});
  const Skeleton rest = measure_skeleton(assets_, shaped);
  const Skeleton posed = pose_skeleton(assets_, rest, pose);
  std::vector<Vec3f> verts;
  skin_body(assets_, shaped, rest, posed, pose, verts);
  std::vector<uint8_t> labels = vertex_labels_;
  std::vector<std::array<uint32_t, 3>> triangles = assets_.body_triangles;
  if (outfit.any()) {
    if (wardrobe_.empty()) fail("render_body_view: clothes asked for, but the wardrobe is not loaded (clothed share 0)");
    dress_body(wardrobe_, outfit, assets_, vertex_labels_, shaped, bone_skin_transforms(assets_, rest, posed, pose), verts,
               labels, triangles);
  }
  float min_y = verts[0].y, max_y = verts[0].y, min_x = verts[0].x, max_x = verts[0].x;
  for (const Vec3f& v : verts) {
    min_y = std::min(min_y, v.y);
    max_y = std::max(max_y, v.y);
    min_x = std::min(min_x, v.x);
    max_x = std::max(max_x, v.x);
  }
  // Frontal, orthogonal-ish view: body centred, distance so that it fills ~90 % of the height.
  const double extent = std::max(double(max_y - min_y), double(max_x - min_x) * height / width);
  const double distance = k.fy * extent / (0.9 * height);
  const Mat3 rot = rot_y(M_PI + yaw_deg * kDegToRad);
  Mat3 flip;
  flip.m = {-1, 0, 0, 0, 1, 0, 0, 0, 1};
  const Mat3 m = flip * rot;
  const Vec3 centre{0.5 * (min_x + max_x), 0.5 * (min_y + max_y), rest.heads[assets_.bone_index("Hips")].z};
  for (Vec3f& v : verts) {
    Vec3 q = m * (Vec3{v.x, v.y, v.z} - centre) + Vec3{0, 0, distance};
    v = {float(q.x), float(q.y), float(q.z)};
  }
  DepthLabelImage img;
  img.reset(width, height);
  rasterize(k, verts, triangles, labels, img);
  return img;
}

dp::tools::ImageRgb Synthesizer::render_parts_figure(const BodyPose& pose, double yaw_deg, int width, int height,
                                                     const Outfit& outfit) const {
  const DepthLabelImage img = render_body_view(pose, yaw_deg, width, height, outfit);
  dp::tools::ImageRgb out;
  out.resize(width, height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      uint8_t c[3];
      part_colour(img.label[size_t(y) * width + x], c);
      if (img.label[size_t(y) * width + x] == kNoLabel) c[0] = c[1] = c[2] = 255;
      out.set(x, y, c[0], c[1], c[2]);
    }
  return out;
}

}  // namespace dp::synth
