// MakeHuman proxy garments (clothes and hair): the `.mhclo` binding file and its `.obj` mesh.
//
// The mhclo format as the CC0 assets use it (../shared/assets/makehuman/clothes, hair):
//   # comment lines
//   basemesh hm08                     the body mesh the binding refers to (only hm08 is accepted)
//   name NAME / obj_file FILE.obj / uuid / tag / material / z_depth / max_pole /
//   vertexboneweights_file            metadata, one keyword and its value per line
//   x_scale A B D  (and y_scale, z_scale)
//                                     the offsets' scale on that axis: on a body with vertex
//                                     positions P, s_x = |P[A].x - P[B].x| / D (D in the base mesh's
//                                     decimetres), so offsets grow with the body
//   verts 0                           the binding section starts; its lines may interleave with
//                                     metadata keywords
//   i j k  wi wj wk  dx dy dz         one line per garment vertex, in .obj vertex order: three base
//                                     mesh vertices, their barycentric weights, an offset (decimetres)
//   i                                 (short form) the garment vertex sits on base vertex i
//   delete_verts                      then whitespace-separated base vertex indices and ranges
//   a - b ...                         "a - b" (inclusive): body vertices the garment hides
// A garment vertex on a body with vertex positions P is
//   wi*P[i] + wj*P[j] + wk*P[k] + (dx*s_x, dy*s_y, dz*s_z)
// (an axis without a scale line has scale 1 on the base mesh's units, i.e. 0.1 m per unit here).
//
// The .obj: `v x y z` lines (one per binding line) and `f` faces of 3 or more corners, each corner
// `v`, `v/vt` or `v/vt/vn` with 1-based (or negative, relative) vertex numbers; other records
// (vt, vn, g, o, s, usemtl, mtllib, comments) are ignored. Faces are split into triangles.
//
// Strict: anything else (an unknown keyword, a missing or extra field, a number that does not
// parse or is not finite, a vertex index outside the base mesh or the .obj, a binding count that
// differs from the .obj's vertex count, a missing obj_file) throws dp::tools::ToolError naming the
// file, the line and the field. The parsers take the text and never touch the file system, so
// the fuzz target (tests/fuzz/mhclo_fuzz.cc) drives them directly.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "tools/synth/geometry.h"

namespace dp::synth {

// One garment vertex: three base-mesh vertices, barycentric weights and an offset (mhclo units:
// the base mesh's decimetres, before the per-axis scale).
struct GarmentBinding {
  std::array<uint32_t, 3> vertices{};
  std::array<float, 3> weights{};
  std::array<float, 3> offset{};
};

// An x_scale / y_scale / z_scale line: s = |P[a] - P[b]| on its axis / denominator.
struct GarmentScale {
  bool present = false;
  uint32_t a = 0, b = 0;
  double denominator = 1;  // decimetres, > 0
};

struct Garment {
  std::string name;                            // the `name` line (the file stem when absent)
  std::string obj_file;                        // as written in the mhclo, relative to it
  std::vector<GarmentBinding> bindings;        // one per .obj vertex
  std::array<GarmentScale, 3> scales;          // x, y, z
  std::vector<uint32_t> delete_vertices;       // sorted, unique base-mesh vertex indices
  std::vector<std::array<uint32_t, 3>> triangles;  // indices into bindings (from the .obj)
  size_t obj_vertex_count = 0;                 // `v` lines of the .obj
};

// Parses mhclo text (`path` only names it in messages). Indices must be < base_vertex_count.
Garment parse_mhclo(const std::string& text, const std::string& path, size_t base_vertex_count);

// Parses the garment's .obj text into g.triangles and g.obj_vertex_count; then checks that the
// .obj has exactly one vertex per binding.
void parse_garment_obj(const std::string& text, const std::string& path, Garment& g);

// Reads FILE.mhclo and the .obj it names (relative to the mhclo's folder): both parsers above.
Garment load_garment(const std::string& mhclo_path, size_t base_vertex_count);

// Per-axis offset scale on a body (metres per offset unit): s_axis as above, times 0.1 m per
// decimetre for an axis without a scale line. `body` holds every base-mesh vertex (metres).
Vec3 garment_offset_scale(const Garment& g, const std::vector<Vec3f>& body);

// The garment's vertices on an unposed body (metres): the binding formula of the header comment.
void fit_garment(const Garment& g, const std::vector<Vec3f>& body, std::vector<Vec3f>& out);

}  // namespace dp::synth
