// dp::Segmenter: finds the people in a depth frame before the forest runs (the paper assumes
// background subtraction, section 1.2). One frame in, a per-pixel user-id mask out:
//
//   floor plane      RANSAC over a bounded grid sample of the lower image part, refined by least
//                    squares (orthogonal fit), tracked frame to frame; pitch and roll unknown.
//                    Pixels within a margin of the plane (or below it) are background.
//   background model per-pixel depth learned over the first frames, updated slowly (optional;
//                    on in default_segmenter_config(true) for live sources, off for independent
//                    frames). Pixels near the learned depth are background.
//   components       4-connected components in 3D: neighbours join when their depth difference
//                    is ≤ join_mm + join_mm_per_m · z. Components too small or too low for a
//                    person at their distance are dropped.
//   users            stable ids 1..max_users by greedy nearest-centroid association; a user who
//                    disappears keeps the id for track_keep_frames frames (short occlusions).
//
// Contract (same pattern as dp::Pipeline, docs/segmentation.md):
//   - The caller owns all memory: segmenter_required_bytes() says how much; init() takes a 64-byte
//     aligned arena. Persistent state (config, background model, tracks, floor) sits at the arena
//     tail, per-frame scratch at its head. Nothing allocates or throws.
//   - Every loop is bounded by the frame size and the caps below (validated by init/set_config);
//     a frame full of clutter costs O(W·H·log(W·H)) for the components plus
//     O(kMaxCandidates · W·H) at worst for the candidate selection, never more.
//   - process() is deterministic for the same config and frame sequence.
// Units: depth uint16 mm (0 = no reading); 3D points in metres, camera frame x right, y up,
// z forward (runtime/depthpose.h). Labels: uint8, 0 = background, 1..max_users = user id.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "runtime/depthpose.h"

namespace dp {

class ArenaCarver;

constexpr int kMaxUsers = 15;             // ids 1..15
constexpr int kMaxFloorSamples = 4096;    // RANSAC sample points
constexpr int kMaxFloorIterations = 1024; // RANSAC hypotheses per frame
constexpr int kMaxCandidates = 64;        // largest components examined per frame

struct SegmenterConfig {
  // Readings outside [near_mm, far_mm] are background.
  uint16_t near_mm = 400;
  uint16_t far_mm = 6000;

  // Floor. floor_enabled = false skips the fit; no pixel is then removed as floor.
  bool floor_enabled = true;
  float floor_sample_fraction = 0.5f;   // sample rows v ≥ (1 − fraction)·height, (0, 1]
  // Floor samples are taken from near_mm up to floor_far_mm, which may lie beyond far_mm: a camera
  // looking level from 1.2–1.9 m sees the floor only from 3–5 m on, and from there to far_mm it is
  // a strip of a few rows, mostly hidden by the people and furniture in front of it. Readings
  // beyond far_mm are never a user; they only help find the floor. ≥ near_mm.
  uint16_t floor_far_mm = 8000;
  int32_t floor_samples = 800;          // grid sample size, 16..kMaxFloorSamples
  int32_t floor_iterations = 512;       // hypotheses without a tracked plane, 1..kMaxFloorIterations
  int32_t floor_retry_iterations = 512; // more hypotheses when the first ones found no floor, 0..max
  int32_t floor_tracked_iterations = 32;// hypotheses when last frame's plane still has ≥ half its
                                        // inliers (it is scored first), 0..max
  float floor_fit_mm = 30.0f;           // inlier distance for fitting, > 0
  float floor_margin_mm = 10.0f;        // pixels closer than margin + margin_per_m2·z² to the
  float floor_margin_per_m2_mm = 1.0f;  //   plane, or below it, are floor (z in metres), ≥ 0
  float floor_max_tilt_deg = 45.0f;     // plane normal within this of the camera's up axis, (0, 90)
  float floor_min_inlier_fraction = 0.15f;  // of the sample, (0, 1]
  float floor_min_extent_m = 1.0f;      // the inliers' bounding box diagonal at least this, ≥ 0
                                        // (a torso seen from above is no floor)
  // A plane with fewer inliers, down to floor_wide_inlier_fraction of the sample, is the floor when
  // its inliers span at least floor_wide_extent_m (furniture tops are smaller). (0, min_inlier_fraction]
  float floor_wide_inlier_fraction = 0.05f;
  float floor_wide_extent_m = 3.0f;     // ≥ floor_min_extent_m
  // Camera above the floor, 0 < min < max. A Kinect stands 0.6–1.8 m high for skeleton tracking;
  // planes 0.15–0.4 m below the camera were mostly not the floor but slants across box faces and
  // the floor (on seeds 12, 16 and 18 they lost people and made false users), hence 0.4 (it was
  // 0.15): a camera lower than that finds no floor.
  float camera_height_min_m = 0.4f;
  float camera_height_max_m = 5.0f;
  int32_t floor_keep_frames = 15;       // a plane not found again is kept this many frames, ≥ 0

  // Background model. learn_frames: frames averaged before the model is called learned (it is
  // applied from the second frame on). Newly revealed farther depth replaces the model after
  // reveal_frames consecutive frames; nearer non-user depth is absorbed after absorb_frames
  // (0 = never, the default: a chair moved in stays foreground unless the person test drops it).
  bool background_enabled = true;
  int32_t background_learn_frames = 30;   // 1..65535
  float background_tolerance_mm = 40.0f;  // |z − model| ≤ tol + tol_per_m2·z² ⇒ background, > 0
  float background_tolerance_per_m2_mm = 6.0f;
  int32_t background_update_shift = 5;    // model += (z − model) / 2^shift after learning, 0..12
  int32_t background_reveal_frames = 3;   // 1..65535
  int32_t background_absorb_frames = 0;   // 0..65535

  // Components and the person test. A component is a user when it has at least
  // min_person_area_m2 · fx·fy / z̄² pixels (z̄ its mean depth), its top is at least
  // min_person_height_m above the floor (its vertical extent when there is no floor) and it is
  // at most max_person_width_m wide. A component associated with a tracked user needs only
  // tracked_area_fraction of that area and no height.
  float join_mm = 30.0f;                  // > 0
  float join_mm_per_m = 45.0f;            // ≥ 0
  int32_t min_component_pixels = 24;      // smaller components are never examined, ≥ 1
  float min_person_area_m2 = 0.06f;       // > 0
  float min_person_height_m = 0.85f;      // ≥ 0
  float max_person_width_m = 1.8f;        // > 0
  float tracked_area_fraction = 0.35f;    // (0, 1]
  // Fragments: a component failing the person test that touches another (neighbouring pixels
  // within fragment_join_mm in depth: a person bending forward over their own legs, a limb cut
  // off by a depth jump) joins the nearest one with which the union passes the person test,
  // when their centroids are within fragment_radius_m of each other along the floor. Pieces
  // that do not touch (a person cut in two by someone standing in front) join the same way when
  // their centroids are within fragment_pair_radius_m.
  float fragment_join_mm = 450.0f;        // ≥ 0 (0 = no merging)
  float fragment_radius_m = 0.5f;         // ≥ 0
  // Two components that both pass the person test are one body when they are stacked in
  // the image (a torso over its legs) or when their centroids are within fragment_pair_radius_m
  // of each other along the floor (an arm or the upper body in front of the legs): two people
  // cannot stand closer than about a body's depth. 0 = stacked pieces only.
  float fragment_pair_radius_m = 0.4f;    // ≥ 0, ≤ fragment_radius_m to have an effect
  // When neither piece passes on its own, the smaller must hold at least this share of the union's
  // pixels: a hand reaching over a box is not what makes the box a person.
  float fragment_min_share = 0.05f;       // 0..0.5
  // A component about to become a new user whose image box lies inside a larger user's box (grown
  // by 2 pixels), which is nearer, and whose centroid is within absorb_radius_m of that user's
  // along the floor, is that user's own piece (legs seen between the arms of someone bending over,
  // beyond a depth jump): it joins that user instead. Two people do not stand within about a body's
  // depth one behind the other with the farther one's outline inside the nearer one's. 0 = off.
  float absorb_radius_m = 0.6f;           // ≥ 0
  // The top of a user's body beyond a depth jump: a component about to become a new user that lacks
  // a person's area (it passes only as hidden or cut), is farther than a larger user, reaches
  // higher than that user's top, starts above that user's top image row, shares image columns with
  // it and has its centroid within head_radius_m of that user's along the floor, joins that user.
  // On two-person tuning seeds 44, 45 and 47 a head or raised arm apart from the rest of its body
  // (0.22-0.48 m farther; centroids: two within 0.6 m, one 0.6-0.7 m), which matched no person. A second person
  // standing that close behind a shorter first one, showing only a head above them, would be
  // joined too (not seen on seeds 11-18, 40-49 up to 1.0 m). 0 = off.
  float head_radius_m = 0.7f;             // ≥ 0
  // Legs split from their body: a piece standing on the floor (lowest point within
  // cut_floor_contact_m) that does not pass alone joins a body that passes but does not reach the
  // floor (its lowest point higher than cut_floor_contact_m) when it is lower than the body (top
  // height and top image row), shares image columns with it, has at most twice its pixels and its
  // centroid is within legs_radius_m along the floor, touching or not: the upper body seen above a
  // box with the legs beside it, or a knee forward. Beyond fragment_pair_radius_m (0.4 m), since
  // legs stepping forward put the centroids 0.42-0.53 m apart on seeds 12 and 18; at 0.6 m a
  // person's legs joined another person's upper body on seed 14 (0.59 m). 0 = off.
  float legs_radius_m = 0.55f;            // ≥ 0
  // A person and a box as one component (a leg against a box, someone beside one): before a
  // component not cut by the top border becomes a new user, its pixels are binned on the floor in
  // cells of box_split_cell_m. Cells whose highest point is below box_split_height_m are low (the
  // synthetic clutter is 0.3-0.8 m tall); the lid is the 2·box_split_height_m/32-high band of
  // cell tops holding the most low-cell pixels (a box's cells all reach its top). The pixels of the
  // lid's cells are dropped (background) when they stand on the floor (lowest point within
  // cut_floor_contact_m), make at least box_split_min_share of the component, their centroid lies
  // at least box_split_min_dist_m from the rest's along the floor (a box stands beside or in front
  // of the person; a crouching body's shins, which also reach one height, lie under it: 0.02-0.53 m
  // on tuning seeds, the boxes 0.73-1.25 m), and the rest passes the person test on its own.
  // box_split_height_m = 0 turns this off (and box_reject_min_share with it).
  float box_split_height_m = 0.85f;       // ≥ 0
  float box_split_min_share = 0.4f;       // 0..1
  float box_split_cell_m = 0.1f;          // > 0
  float box_split_min_dist_m = 0.6f;      // ≥ 0
  // When the lid's cells are not dropped that way (the rest fails alone, or lies within
  // box_split_min_dist_m, or the lid holds less than box_split_min_share) but hold at least
  // box_reject_min_share of the component, it is no user: a box with the hand or arm of someone
  // hidden reaching over it (on seeds 16, 40, 44 and 48 lid shares 0.77-0.86; the people with a
  // lid share of at least a half 0.52-0.63). 0 = off.
  float box_reject_min_share = 0.7f;      // 0..1
  // People cut by the top image border (a low camera looking down at someone close: only the
  // legs are in view) cannot show their height. A component that touches the top border, stands
  // on the floor (lowest point within cut_floor_contact_m of it) and has the area and width of a
  // person passes without the height test when its silhouette fills at most cut_max_fill of its
  // image box: legs, arms and gaps, unlike the solid outline of a box or a cylinder cut by the
  // same border. Box pixels hidden by something nearer (farther than join_mm in front of the
  // component's nearest point) count as filled: an occluded box shows gaps that are not its own.
  // Needs a floor. cut_max_fill = 0 turns this off.
  float cut_max_fill = 0.6f;              // 0..1
  // The same components also pass when they fill at most cut_max_solidity of their row-wise convex
  // hull (hidden pixels and pixels without a reading counted as filled): the gap between two legs
  // stays open whatever the camera's roll, where a box or cylinder fills its hull. 0 = off.
  float cut_max_solidity = 0.8f;          // 0..1
  // ... but only when at most this share (of its own pixel count) of its image box is hidden by
  // something nearer: a box seen partly behind someone's legs takes on their outline.
  float cut_solidity_max_hidden = 0.05f;  // ≥ 0
  // The fill of a union of pieces (after merging) counts only its pieces that touch the top border
  // and the pieces that share image columns with them (below them: shins, feet, the body under
  // raised arms), over those columns and all rows of the union; a piece beside them adds neither
  // pixels nor columns. Without this, a box cut by the border that fills its box (and fails) joined
  // with a smaller piece beside it passes, the union's box widened by the piece and the empty rows
  // above it (boxes partly hidden by someone's legs on tuning seeds 16 and 42, 0.78-0.82 of their
  // own box, 0.41-0.57 of the union's). Pieces whose image boxes overlap by one column count as
  // sharing (a slanted edge can make a piece beside one share a column). 1 = on, 0 = off (all
  // pixels over the union's box, as before).
  int32_t cut_fill_border_columns = 1;    // 0 or 1
  float cut_floor_contact_m = 0.3f;       // ≥ 0
  // People cut by the top border far from a low camera show only their shins and feet: under the
  // person area although the same silhouette test (cut_max_fill, cut_max_solidity) already tells
  // them from boxes. A component about to become a new user that is cut by the top border, stands
  // on the floor and passes that test needs only this fraction of the person area
  // (min_person_area_m2); merging still judges pieces by the full area. With this on, a component
  // about to become a new user that touches the top border without the full area (however it
  // passed) joins instead a larger user also cut by the top border whose centroid is within
  // legs_radius_m along the floor (the other leg, a step nearer or farther). 0 = off (the full
  // area, as before). On tuning seeds 11-18/40-59, 0.8 finds 19 more people and adds no false
  // user; 0.3-0.7 find up to 10 more but add a false user on seeds 11-18 (docs/segmentation.md,
  // ninth pass).
  float cut_top_area_fraction = 0.8f;     // 0..1
  // People low over the floor (lying with an arm raised, crouching, on all fours, bending low) fail
  // the height test like the furniture (the synthetic clutter is 0.3-0.8 m tall). A component about
  // to become a new user that has the full person area and width, stands on the floor (lowest point
  // within cut_floor_contact_m), shows its top (not cut by the top border) and whose top is at least
  // low_min_height_m but below min_person_height_m passes when its lid share is at most
  // low_max_lid_share: its pixels are binned on the floor in box_split_cell_m cells, each cell's top
  // is its highest point, and the lid share is the largest share of the component's pixels whose
  // cells' tops lie within one height band of 2·(3 cm + 4 mm/m²·z̄²) (the depth noise spreads a
  // far box's cell tops). A box or cylinder reaches its top in every cell (lid share near 1); a
  // body's cells reach many heights. Needs a floor. On tuning seeds 11-18/40-59, 0.4 with 0.7 m
  // finds 10 more people and adds one false user (the second piece of someone lying); 0.45 with
  // 0.7 m finds 17 and adds 7 (docs/segmentation_passes.md, tenth pass). low_max_lid_share = 0 turns this
  // off (as before).
  float low_max_lid_share = 0.4f;         // 0..1 (share of the component's pixels)
  float low_min_height_m = 0.7f;          // ≥ 0, metres above the floor
  // Someone low over the floor whose cells do reach one height band (a back bent over; someone
  // lying or crouching 3-4 m away, whose cells the wide band merges: lid shares 0.41-0.82 among
  // the people this finds) but whose outline is no solid's (thirteenth pass): the same component
  // (person area and width, on the floor, top in view, low_min_height_m up to
  // min_person_height_m) also passes when at most low_outline_max_lid_share of its pixels lie in
  // the lid band and its silhouette fills at most low_max_solidity of its row-wise convex hull
  // (as for cut_max_solidity: readings in the hull nearer than its nearest point less join_mm
  // count as filled). The image of a box or cylinder is convex and fills its hull (the clutter
  // with lid shares up to 0.9 filled at least 0.69 on tuning seeds 11-18/40-59; the 15 people 0.6
  // finds 0.49-0.59; 0.55-0.65 add no false user there, 0.7 adds four). Far boxes that the depth
  // noise scatters fill 0.55-0.72 of their hull but keep their lid (shares 0.95-1.0): hence the
  // cap on the lid share (1 adds 11 false users at 0.65). A component passing only this way
  // that holds a box's lid apart from the rest (box_split_min_share of its pixels, centroids
  // box_split_min_dist_m apart, as in the box split) is a body beside a box, no user
  // (low_outline_box_split = 1; at 0.65 one false user on seed 49 without it). Needs a floor.
  // low_max_solidity = 0 turns this off (as before; docs/segmentation_passes.md, thirteenth pass).
  float low_max_solidity = 0.6f;          // 0..1 of the row-wise hull
  float low_outline_max_lid_share = 0.9f; // 0..1 (share of the component's pixels)
  int32_t low_outline_box_split = 1;      // 0 or 1
  // People cut by the bottom border (the head and shoulders of someone close to a high camera)
  // keep their height above the floor but lose area: a component touching the bottom border with
  // a floor known and its top at least min_person_height_m high needs only this fraction of the
  // person area. 0 turns this off.
  float cut_bottom_area_fraction = 0.3f;  // 0..1
  // Someone low over the floor cut by the bottom border (fifteenth pass: crouching, kneeling or bent
  // over close to the camera, the feet below the image): the component touches the bottom border
  // and its lowest point in view is higher than cut_floor_contact_m (the floor under it is out of
  // view too), so the low test (low_max_lid_share) never judged it, and its visible part (back,
  // shoulders, head, arms, without the legs and feet, whose cells reach other heights) reaches one
  // height band in more cells than a whole body does. Such a component with the person area and
  // width, its top in view and at least low_min_height_m but below min_person_height_m high passes
  // when at most cut_bottom_low_max_lid_share of its pixels lie in the lid band of the low test and
  // at most cut_solidity_max_hidden (of its pixel count) of its image box is hidden by something
  // nearer (what is hidden may be the rest of a lid: a box cut by the bottom border behind someone,
  // half hidden, showed 0.62). A box or cylinder cut by the bottom border above the floor shows its
  // lid and the top of its faces, whose cells all reach the lid: lid shares 0.95-1.0 (754 such
  // components on tuning seeds 11-18/40-59), the people 0.55-0.9. Needs a floor. On those seeds
  // 0.8 finds 4 more people and adds no false user (docs/segmentation_passes.md, fifteenth pass).
  // 0 = off (as before).
  float cut_bottom_low_max_lid_share = 0.8f;  // 0..1 (share of the component's pixels)
  // People cut by the left or right border (sixteenth pass: someone at the edge of the view, a
  // strip of their body inside it) keep their height above the floor but lose area, like those cut
  // by the bottom border: a component touching the left or right image border but not the top one
  // (whose top would be the border's, not the body's), with a floor known and its top at least
  // min_person_height_m high, needs only this fraction of the person area. The footing is not
  // asked: of the four side-cut people this finds on the tuning seeds, the three looked at show
  // their lowest point 0.48-0.93 m up (legs hidden or out of view). Furniture is lower than min_person_height_m (the
  // synthetic clutter is 0.3-0.8 m). 0.5-0.7 find the same people with no false user on the tuning
  // seeds; 0.4 adds 3 false users (pieces of bodies at the border, 1.4-1.55 m high), 0.3 adds 6.
  // 0 turns this off (docs/segmentation_passes.md, sixteenth pass).
  float cut_side_area_fraction = 0.6f;    // 0..1

  // People mostly hidden behind someone (or something) nearer show pieces: a head, a shoulder, an
  // arm. A component with at least hidden_min_edge pixel edges to readings nearer by more than
  // hidden_gap_mm (per pixel and direction the first reading within 4 pixels: occluding edges
  // cast shadows without readings), and its top at least min_person_height_m above the floor, needs only
  // hidden_area_fraction of the person area (furniture is lower than that; 0 turns this off).
  // Such pieces count as fragments while merging (they join their body, or each other).
  float hidden_area_fraction = 0.5f;      // 0..1
  float hidden_gap_mm = 300.0f;           // > 0
  int32_t hidden_min_edge = 8;            // ≥ 1
  // Two pieces that each pass only this way (on either side of the person in front: a head, a
  // leg) join within this distance of each other along the floor, instead of
  // fragment_pair_radius_m / fragment_radius_m.
  float hidden_pair_radius_m = 0.8f;      // ≥ 0
  // The legs of someone partly hidden: the person in front cuts a body behind them into an upper
  // piece and its legs, and the legs are often the larger piece, which hidden_pair_radius_m does
  // not join. A piece standing on the floor (lowest point within cut_floor_contact_m) that does not
  // pass alone joins a piece that passes (also only as hidden, or after merges) and does not reach
  // the floor (lowest point higher than cut_floor_contact_m), touching or not, when
  //   - both have at least hidden_min_edge hidden edges (both are partly hidden),
  //   - the piece is lower than the other in height (top) and in the image (top row), and its top
  //     is at most hidden_legs_max_gap_m below the other's lowest point,
  //   - it does not itself hide part of the other (no pixel 4-neighbour to one of the other and
  //     nearer than it by more than fragment_join_mm: a box in front of someone's legs is not their
  //     legs),
  //   - it holds at most hidden_legs_max_ratio times the other's pixels, and
  //   - their centroids are within hidden_legs_radius_m of each other along the floor.
  // On two-person tuning seeds 41, 47 and 49 an upper body was a user of its own while its legs,
  // 0.40-0.67 m away and 1.3-4.6 times its pixels, were left out (a false user and a missed
  // person); boxes joined at 0.73-0.80 m (hence 0.7) and at 7.4 times the upper piece's pixels
  // (hence 5). 0 = off.
  float hidden_legs_radius_m = 0.7f;      // ≥ 0
  float hidden_legs_max_gap_m = 0.3f;     // ≥ 0
  float hidden_legs_max_ratio = 5.0f;     // > 0

  // Users.
  int32_t max_users = 8;                  // 1..kMaxUsers
  // A user keeps its id when a component's centroid is within association_distance_m (plus
  // association_growth_m per frame it has been lost) of the track's position predicted from its
  // last velocity.
  float association_distance_m = 0.6f;    // > 0
  float association_growth_m = 0.08f;     // ≥ 0
  int32_t track_keep_frames = 30;         // frames a lost user keeps its id, 0..65535

  // Legs together, cut by the top border (a component that touches the top border, stands on the
  // floor and has a person's area and width, as for cut_max_fill): two legs close together, or
  // the thighs over them, fill more than cut_max_fill of the image box and more than
  // cut_max_solidity of the hull, but the floor or the wall shows between them. Such a component
  // also passes when at least cut_gap_min_share of its image rows (a share of the rows, 0..1) have
  // a gap of at least 2 pixels between two runs of its pixels, seen through (readings not nearer
  // than its nearest point less join_mm; pixels without a reading allowed, at least one with a
  // reading) and not hidden by something in front, and it fills at most cut_gap_max_fill of its
  // image box (counted as for cut_max_fill), whatever share of the box is hidden (a gap hidden by
  // something nearer does not count). Boxes and cylinders show few such rows (a box is seen whole
  // or hidden by something nearer): at most 4.7 % on tuning seeds 11-14/40-49, 3.6 % of those
  // filling at most 0.8 of their box; the legs found 5-49 %. On tuning seeds
  // 11-14/40-49, 0.05 finds 13 more people (all with at least 0.05 m² in view) and adds no false
  // user; 0.03 adds two (boxes with 3.4-3.6 % of their rows showing such a gap), and a box with
  // 5.3 % such rows and a fill of 0.90 is kept out by cut_gap_max_fill (the legs found fill
  // 0.60-0.73). 0 = off (as before; docs/segmentation_passes.md, eleventh pass).
  float cut_gap_min_share = 0.05f;        // 0..1 of the rows
  float cut_gap_max_fill = 0.8f;          // 0..1 of the image box

  // The feet hidden (twelfth pass): a component cut by the top border whose lowest point is
  // above cut_floor_contact_m because something nearer (a box, another person) hides its lower
  // part still counts as standing on the floor for the top-border test (cut_max_fill,
  // cut_max_solidity, cut_gap_min_share, cut_top_area_fraction) when its lowest point is at most
  // cut_hidden_floor_contact_m (metres above the floor) and it has at least hidden_min_edge
  // downward hidden edges (pixels whose first reading below, within 4 pixels, is nearer by more
  // than hidden_gap_mm). The silhouette tests still apply: a box cut by the top border and hidden
  // at its bottom fills its box. Needs hidden_area_fraction > 0 (the hidden edges are counted
  // only then). On tuning seeds 11-18/40-59, 0.6 finds 20 more people (all with at least 0.05 m²
  // in view, the missed top-border people's lowest points were 0.32-0.56 m up) and adds no false
  // user; 0.45 finds 17, 0.8-1.5 find 21, none adds a false user. 0 = off (as before;
  // docs/segmentation_passes.md, twelfth pass).
  float cut_hidden_floor_contact_m = 0.6f;  // metres above the floor, ≥ 0; 0 = off (matters above cut_floor_contact_m)

  // Two people joined by an arm (fourteenth pass): one reaches out and touches the other, and both
  // are one component that passes the person test (width under max_person_width_m), one user that
  // matches one of them. A component about to become a new user, standing on the floor and reaching
  // min_person_height_m (also when cut by the top border), is profiled along the floor's horizontal
  // axis (the axis of its width) in 5 cm bins (at most 64), each with its highest and lowest point
  // above the floor. A bin is a bridge bin when it holds only an arm held out: its lowest point at
  // least min_person_height_m up and its highest at most pair_bridge_max_m above that (an empty bin
  // is none: pieces of one body joined across someone in front leave empty bins between them). A
  // bin is a standing bin when it reaches from the floor (within cut_floor_contact_m) to
  // min_person_height_m: legs under a body. The component is cut in the middle of the first run of
  // bridge bins with a standing bin on each side, when each side alone passes the person test (full
  // area, height, width; no border relaxations) and stands on the floor: two users. A single body's
  // thin slices are lower (between the legs, a knee, a leg held out), and an arm held out has no
  // standing bin beyond it. On tuning seeds 11-18/40-59, 0.4 finds 9 more people and adds no false
  // user (0.5 and 0.6 the same; 0.3 one person fewer; 0.8 one false user more); without the height
  // condition on bridge bins and with a side only needing to reach the floor and the height
  // somewhere, 11 bodies were cut in two (12 false users). Needs a floor. 0 = off (as before;
  // docs/segmentation_passes.md, fourteenth pass).
  float pair_bridge_max_m = 0.4f;         // metres, ≥ 0; 0 = off
};

// Live sources (static camera, frames in sequence): everything on. Independent frames (datasets
// of unrelated frames): background model off.
SegmenterConfig default_segmenter_config(bool live_source);

struct FloorPlane {
  // n·p + d = signed height of p above the floor (metres); n unit, pointing up; d = camera height.
  float nx, ny, nz, d;
  int32_t valid;        // 1 when a plane is known this frame (found, tracked or held)
  int32_t inliers;      // sample points within floor_fit_mm of the plane
  int32_t samples;      // sample points this frame
  int32_t held_frames;  // frames since the plane was last fitted (0 = fitted this frame)
};

struct UserInfo {
  int32_t id;              // 1..max_users, stable across frames
  int32_t pixel_count;
  float centroid_m[3];     // mean 3D point (x, y, z)
  int16_t u_min, v_min, u_max, v_max;  // bounding box, inclusive
  float top_height_m;      // highest point above the floor (camera y extent without floor)
  int32_t frames_tracked;  // consecutive frames this id has been seen (1 = new)
};

enum SegmentationStage : int32_t {
  kSegStageFloor = 0,     // sample, RANSAC, refinement
  kSegStageBackground,    // per-pixel floor/background/band test
  kSegStageComponents,    // union-find, candidate selection, statistics
  kSegStageUsers,         // person test, association, labelling, model update
  kSegStageCount
};
const char* segmentation_stage_name(int32_t stage);

enum SegmentationFlag : uint32_t {
  kSegFlagFloorFitted = 1u << 0,        // a plane was fitted this frame
  kSegFlagFloorHeld = 1u << 1,          // no fit this frame; last plane kept (floor_keep_frames)
  kSegFlagBackgroundLearning = 1u << 2, // fewer than background_learn_frames frames seen
  kSegFlagCandidatesTruncated = 1u << 3,// more than kMaxCandidates components: smallest ignored
  kSegFlagUsersTruncated = 1u << 4,     // more people than free ids: smallest dropped
};

struct SegmentationResult {
  // Caller-owned output, set before process(): height × frame.stride_px bytes, written with the
  // frame's stride so it can serve directly as DepthFrame::foreground_mask. process() keeps it.
  uint8_t* labels;
  int32_t user_count;
  UserInfo users[kMaxUsers];   // visible users, by increasing id
  FloorPlane floor;
  int32_t candidate_pixels;    // valid, in band, not floor, not background
  int32_t user_pixels;         // labelled with a user id
  int32_t component_count;     // components ≥ min_component_pixels
  uint64_t stage_cycles[kSegStageCount];  // TSC cycles
  uint64_t total_cycles;
  uint32_t flags;              // SegmentationFlag bits
};

// Arena bytes for frames up to max_width × max_height (0 for sizes outside 1..kMaxFrameDimension).
size_t segmenter_required_bytes(int32_t max_width, int32_t max_height);

class Segmenter {
 public:
  // kOk, kBadArgument (null arena, bad size), kArenaMisaligned, kArenaTooSmall, kBadConfig.
  Status init(const SegmenterConfig& config, int32_t max_width, int32_t max_height, uint8_t* arena,
              size_t arena_bytes);
  // kOk; kBadArgument (null result or labels, bad frame or intrinsics); kFrameTooLarge;
  // kNotInitialized. A frame of another size than the previous one restarts the background model
  // and the tracks. On error the labels are untouched and the result (except labels) zeroed.
  Status process(const DepthFrame& frame, SegmentationResult* result);
  // Replaces the config (kBadConfig when invalid); keeps the learned state.
  Status set_config(const SegmenterConfig& config);
  // Forgets the floor, the background model and the tracks (e.g. after the camera moved).
  void reset();

  const SegmenterConfig& config() const { return *config_; }
  size_t arena_used_bytes() const { return arena_used_; }

 private:
  struct Track {
    int32_t active;        // slot in use (visible or lost ≤ track_keep_frames)
    int32_t lost_frames;
    int32_t frames_tracked;
    float centroid[3];
    float velocity[3];     // metres per frame, smoothed
  };
  struct BackgroundCell {
    uint16_t depth_mm;     // 0 = unknown
    uint16_t far_frames;   // consecutive frames seen farther than the model
    uint16_t near_frames;  // consecutive frames seen nearer (not a user)
    uint16_t learned;      // frames averaged into depth_mm (saturating)
  };
  struct Candidate {
    int32_t root, pixels;
    double sx, sy, sz;
    float x_min, x_max, y_min, y_max, z_min, z_max, top;
    float bottom;          // lowest point above the floor (with a floor)
    int32_t occluded;      // box pixels hidden by something in front (top-border components)
    int32_t hidden_edge;   // pixel edges where the neighbour is nearer by more than hidden_gap_mm
    int32_t hidden_below;  // of those: the downward ones (cut_hidden_floor_contact_m)
    int32_t hull;          // pixels of the row-wise convex hull (top-border components, else 0)
    int32_t hull_filled;   // of those: the component's own plus the ones hidden by something in front
    int32_t cut_pixels;    // pixels of the pieces touching the top border and of merged pieces
                           // sharing their columns (cut_fill_border_columns)
    int16_t cut_u_min, cut_u_max;  // those pieces' image columns; none: cut_u_max < cut_u_min
    int32_t gap_rows;      // image rows with a seen-through gap between two runs of its pixels
                           // (top-border components; cut_gap_min_share)
    int16_t u_min, v_min, u_max, v_max;
    int32_t user;          // id or 0
    int32_t owner;         // candidate this one was merged into (itself when not merged)
  };

  struct State {
    int32_t frames;        // frames processed since init/reset (saturating)
    int32_t width, height; // geometry of the model and tracks
  };

  // Carves the arena (counting only when `into` is null); shared by init and
  // segmenter_required_bytes so both agree.
  static bool carve(ArenaCarver& carver, int32_t max_width, int32_t max_height, Segmenter* into);
  friend size_t segmenter_required_bytes(int32_t max_width, int32_t max_height);

  SegmenterConfig* config_ = nullptr;
  int32_t max_width_ = 0, max_height_ = 0;
  size_t arena_used_ = 0;
  bool initialized_ = false;
  // persistent
  BackgroundCell* background_ = nullptr;
  Track* tracks_ = nullptr;          // [kMaxUsers], slot i ↔ id i + 1
  FloorPlane* floor_ = nullptr;
  State* state_ = nullptr;
  // scratch
  int32_t* parent_ = nullptr;        // union-find over pixels (−1 = not a candidate pixel)
  int32_t* aux_ = nullptr;           // root: component size, then candidate index or −1
  float* samples_ = nullptr;         // [kMaxFloorSamples][3]
  uint8_t* inlier_ = nullptr;        // [kMaxFloorSamples]
  int16_t* hull_rows_ = nullptr;     // [4 · max_height]: row extents and hull chains of one component
  Candidate* candidates_ = nullptr;  // [kMaxCandidates]

  // owner < 0: the pixels of `candidate`'s own component; else those of every component merged
  // into candidate `owner` (Candidate::owner).
  void measure_hull(const DepthFrame& frame, Candidate* candidate, int32_t owner = -1);
  bool owned(int32_t root, const Candidate* candidate, int32_t owner) const {
    return root >= 0 && aux_[root] >= 0 &&
           (owner < 0 ? &candidates_[aux_[root]] == candidate : candidates_[aux_[root]].owner == owner);
  }
  // visit(u, v, pixel index, depth mm) for every pixel of the components merged into candidate
  // `owner` (owned(·, ·, owner)), in raster order within candidates_[owner]'s image box.
  template <class Visit>
  void for_each_pixel_of(const DepthFrame& frame, int32_t owner, Visit&& visit) const;
  void fit_floor(const DepthFrame& frame, SegmentationResult* result);
  int32_t classify_pixels(const DepthFrame& frame);
  int32_t label_components(const DepthFrame& frame, SegmentationResult* result);
  // cut: also the relaxed tests for components cut by the image border.
  // short_top: a component cut by the top border may have only cut_top_area_fraction of the area
  // (only for new users: merging judges pieces as before).
  bool passes_person_test(const DepthFrame& frame, const Candidate& candidate, bool cut = true, bool short_top = false) const;
  // cut_side_area_fraction's relaxation (touches the left or right border, not the top one, a floor
  // known, min_person_height_m high, that fraction of `need` pixels); no width test. O(1).
  bool cut_by_side(const DepthFrame& frame, const Candidate& candidate, float need) const;
  void merge_fragments(const DepthFrame& frame, int32_t candidate_count);
  bool in_front_of_a_user(const DepthFrame& frame, int32_t candidate_count, int32_t k, const float* mean_z,
                          const bool* passes) const;
  int32_t absorbing_user(const DepthFrame& frame, int32_t candidate_count, int32_t k, const float* cx, const float* cy,
                         const float* cz) const;
  // 0 = not low or not a person; 1 = by its lid share (low_max_lid_share); 2 = by its outline only
  // (low_max_solidity); 3 = cut by the bottom border above the floor, by its lid share
  // (cut_bottom_low_max_lid_share). Non-const: the outline uses the hull scratch rows.
  int32_t low_person(const DepthFrame& frame, int32_t k);  // low_max_lid_share (header)
  // 0 = kept, 1 = box dropped, 2 = no user. low_outline: the component passed only as low by its
  // outline (low_max_solidity): judged although low, and a lid apart from the rest makes it no user.
  int32_t split_box(const DepthFrame& frame, int32_t k, bool low_outline = false);
  // pair_bridge_max_m (header): cuts candidate k in two at a bridge; returns the index of the new
  // candidate (candidate_count, which the caller then counts) or −1 when k is kept whole.
  int32_t split_pair(const DepthFrame& frame, int32_t candidate_count, int32_t k);
  void assign_users(const DepthFrame& frame, int32_t candidate_count, SegmentationResult* result);
  void update_background(const DepthFrame& frame, const uint8_t* labels, const SegmentationResult* result);
};

}  // namespace dp
