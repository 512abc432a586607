// The MakeHuman CC0 body as the synthesizer uses it (assets under --assets DIR, see
// ../shared/assets/README.md): base mesh, cmu_mb rig and skinning weights, macrodetail shape
// targets, the A-pose -> T-pose correction, and the vertex groups.
//
// Units: everything this header returns is in METRES, in the mesh frame: y up, the body facing
// +z, the subject's left at +x (the files are in decimetres; the loader converts).
// Only the `body` group (vertices 0..13379, quads split into triangles) is ever rendered; the
// other vertices (helpers, joint cubes) are kept because the skeleton is measured on the cubes.
//
// Errors: load_human_assets throws dp::tools::ToolError naming the file for a missing or
// malformed asset.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "tools/synth/geometry.h"

namespace dp::synth {

constexpr int kBodyVertexCount = 13380;

struct RigBone {
  std::string name;
  int parent = -1;                       // index into HumanAssets::bones, parents first
  std::vector<uint32_t> head_cube;       // vertex indices whose mean is the bone head
  std::vector<uint32_t> tail_cube;       // ... the bone tail
  double roll = 0;                       // Blender bone roll (radians), for t-pose.json frames
};

struct ShapeTarget {
  std::string name;                      // file stem, e.g. "universal-male-young-maxmuscle-minweight"
  std::vector<uint32_t> vertices;
  std::vector<Vec3f> deltas;             // metres
};

// Continuous shape controls, MakeHuman's macro modifiers (all in [0, 1]); see docs/synthetic_data.md.
struct ShapeControls {
  double gender = 0.5;       // 0 female, 1 male
  double age = 0.5;          // 0 = 1 year, 0.1875 = 11, 0.5 = 25, 1 = 90 years
  double muscle = 0.5;
  double weight = 0.5;
  double height = 0.5;
  double proportions = 0.5;  // 0 uncommon, 1 ideal
  double african = 1.0 / 3, asian = 1.0 / 3, caucasian = 1.0 / 3;  // normalised to sum 1
  double extra_height = 1.0; // additional vertical scale (paper: +-10 %)
  double extra_weight = 1.0; // additional horizontal scale about the body axis
};

struct HumanAssets {
  std::vector<Vec3f> base_vertices;           // all mesh vertices, metres
  std::vector<std::array<uint32_t, 3>> body_triangles;  // indices < kBodyVertexCount
  std::vector<RigBone> bones;                 // cmu_mb, parents before children
  // Skinning, compressed rows per mesh vertex (body and helpers; garments bind to helpers):
  // influences [skin_offsets[v], skin_offsets[v+1]); every body vertex has at least one.
  std::vector<uint32_t> skin_offsets;
  std::vector<uint16_t> skin_bones;
  std::vector<float> skin_weights;            // sum to 1 per vertex
  std::vector<ShapeTarget> targets;           // all macrodetail targets found
  // Per bone: world rotation taking the bone from the A-pose rest to the T-pose
  // (poses/cmu_mb_fk/t-pose.json evaluated on the base mesh's rest frames).
  std::vector<Mat3> tpose_world;
  std::vector<int8_t> vertex_side;            // per body vertex: +1 Left group, -1 Right, 0 Mid

  int bone_index(const std::string& name) const;  // -1 when absent
  const ShapeTarget* target(const std::string& name) const;  // nullptr when absent
};

HumanAssets load_human_assets(const std::string& assets_dir);

// Weight per target for the given controls, the MakeHuman way: each factor (gender, age, muscle,
// weight, height, proportions, race) gives piecewise-linear weights to its named values, and a
// combination target's weight is the product over its factors. Zero weights are omitted.
std::vector<std::pair<const ShapeTarget*, float>> target_weights(const HumanAssets& assets, const ShapeControls& c);

// Base + sum of weighted target deltas, then extra height/weight scaling about the feet / body
// axis. Returns all vertices (metres).
std::vector<Vec3f> shaped_vertices(const HumanAssets& assets, const ShapeControls& c);

// Standing height of a shaped body (metres: lowest to highest body vertex). When lo > 0 or
// hi > 0 and the height lies outside [lo, hi] (a limit of 0 is open), scales every vertex
// vertically about the feet to the nearer limit. Returns the height after that.
double limit_stature(std::vector<Vec3f>& vertices, double lo, double hi);

// Bone heads and tails measured on a (shaped) vertex array: means of the joint cubes.
struct Skeleton {
  std::vector<Vec3> heads, tails;
};
Skeleton measure_skeleton(const HumanAssets& assets, const std::vector<Vec3f>& vertices);

}  // namespace dp::synth
