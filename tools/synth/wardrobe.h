// Clothing and hair for the synthetic bodies: the CC0 MakeHuman garments under
// assets/makehuman/clothes and assets/makehuman/hair (garment.h reads them), prepared once for the
// hm08 body, then fitted to a shaped body and skinned with its pose every frame.
//
// Kinds, by folder: clothes/shoes*/ are shoes, clothes/fedora*/ hats, hair/*/ hairstyles, every
// other clothes/*/ an outfit; each .mhclo of a folder is one item (fedora01 holds two hats).
//
// Labels: a garment vertex carries the part label (0..30) of the body vertex nearest to it when
// the garment is fitted to the unshaped base mesh in its rest pose: the body part beneath it, the
// way the paper's labels come from the body, never background.
//
// Posing: garment vertex = sum_i w_i * S_i(shaped[v_i]) + (sum_i w_i * L_i) * (offset * scale),
// with S_i the linear-blend skinning transform of bound vertex v_i and L_i its linear part, scale
// measured on the shaped, unposed body (garment.h). The barycentric part follows the posed body
// exactly; the offset turns with it.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "tools/synth/garment.h"
#include "tools/synth/human_model.h"
#include "tools/synth/posing.h"

namespace dp::synth {

enum class GarmentKind { kOutfit, kShoes, kHat, kHair };
constexpr int kGarmentKindCount = 4;

struct WornGarment {
  Garment garment;
  std::string path;                           // the .mhclo
  std::vector<uint8_t> labels;                // per garment vertex, 0..30
  std::vector<uint32_t> bound_vertices;       // distinct base-mesh vertices the bindings use
  std::vector<std::array<uint32_t, 3>> slots; // per binding: indices into bound_vertices
};

// What one body wears: indices into Wardrobe::of(kind), -1 = none. outfit < 0 = unclothed.
struct Outfit {
  int outfit = -1, shoes = -1, hat = -1, hair = -1;
  bool clothed() const { return outfit >= 0; }
  bool any() const { return outfit >= 0 || shoes >= 0 || hat >= 0 || hair >= 0; }
};

struct Wardrobe {
  std::array<std::vector<WornGarment>, kGarmentKindCount> items;  // indexed by GarmentKind
  const std::vector<WornGarment>& of(GarmentKind k) const { return items[size_t(k)]; }
  bool empty() const;
};

// Prepares one garment for `assets`: labels from `body_labels` (one per body vertex), binding
// slots; throws ToolError when a bound vertex has no skin weights.
WornGarment prepare_garment(Garment g, const std::string& path, const HumanAssets& assets,
                            const std::vector<uint8_t>& body_labels);

// Loads and prepares every garment under assets_dir/makehuman/{clothes,hair}, in sorted path
// order. Throws ToolError (naming the file) for a malformed one, or when a kind has no item.
Wardrobe load_wardrobe(const std::string& assets_dir, const HumanAssets& assets, const std::vector<uint8_t>& body_labels);

// The garment on a shaped body in a pose (vertices in the body's mesh frame, metres), as in the
// header comment. `bones` from bone_skin_transforms of the same shape and pose.
void pose_garment(const WornGarment& g, const HumanAssets& assets, const std::vector<Vec3f>& shaped,
                  const std::vector<SkinTransform>& bones, std::vector<Vec3f>& out);

// Dresses a skinned body: appends the outfit's posed garments (outfit, shoes, hat, hair) to
// `verts` (the kBodyVertexCount skinned body vertices on entry), sets `labels` to body_labels
// followed by the garments' labels, and `triangles` to the body triangles that use no vertex a
// worn garment's delete_verts hides, then the garments' triangles. Throws ToolError for an index
// outside the wardrobe.
void dress_body(const Wardrobe& wardrobe, const Outfit& outfit, const HumanAssets& assets,
                const std::vector<uint8_t>& body_labels, const std::vector<Vec3f>& shaped,
                const std::vector<SkinTransform>& bones, std::vector<Vec3f>& verts, std::vector<uint8_t>& labels,
                std::vector<std::array<uint32_t, 3>>& triangles);

}  // namespace dp::synth
