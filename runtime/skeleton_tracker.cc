// The kinematic choice: a min-sum dynamic program over the joint tree for every pair of shoulder
// candidates (the pair fixes the torso's mid-plane, which the side costs need), then states,
// calibrated confidences, bone-length statistics and the temporal filter. See the header for the
// cost terms; the weights below are declared once, with what they mean.
#include "runtime/skeleton_tracker.h"

#include <math.h>
#include <string.h>

#include "runtime/cycle_counter.h"

namespace dp {

namespace {

constexpr int32_t kParent[kSkeletonJoints] = {kNeck,   -1,     kNeck,   kNeck,   kShoulderL, kShoulderR,
                                              kElbowL, kElbowR, kWristL, kWristR, kNeck,      kNeck,
                                              kKneeL,  kKneeR,  kAnkleL, kAnkleR};
constexpr const char* kNames[kSkeletonJoints] = {"head",    "neck",    "shoulder_l", "shoulder_r", "elbow_l", "elbow_r",
                                                 "wrist_l", "wrist_r", "hand_l",     "hand_r",     "knee_l",  "knee_r",
                                                 "ankle_l", "ankle_r", "foot_l",     "foot_r"};
// Children before parents; the neck (root) last and not listed.
constexpr int32_t kLeavesFirst[kSkeletonJoints - 1] = {kHandL,  kHandR,  kWristL, kWristR, kElbowL,
                                                       kElbowR, kShoulderL, kShoulderR, kFootL, kFootR,
                                                       kAnkleL, kAnkleR, kKneeL, kKneeR, kHead};
// +1 for the subject's left joints, −1 for the right ones, 0 on the mid-line.
// The same joint on the other side (itself on the mid-line).
constexpr int32_t kMirror[kSkeletonJoints] = {kHead,   kNeck,   kShoulderR, kShoulderL, kElbowR, kElbowL,
                                              kWristR, kWristL, kHandR,     kHandL,     kKneeR,  kKneeL,
                                              kAnkleR, kAnkleL, kFootR,     kFootL};
constexpr float kSide[kSkeletonJoints] = {0, 0, 1, -1, 1, -1, 1, -1, 1, -1, 1, -1, 1, -1, 1, -1};

// Rest directions of the bones (by child joint; Skeleton::bone_rotation): a T-pose facing −z.
constexpr float kRestDirection[kSkeletonJoints][3] = {
    {0, 1, 0},  {0, 0, 0},  {1, 0, 0},  {-1, 0, 0}, {1, 0, 0},  {-1, 0, 0}, {1, 0, 0},  {-1, 0, 0},
    {1, 0, 0},  {-1, 0, 0}, {0, -1, 0}, {0, -1, 0}, {0, -1, 0}, {0, -1, 0}, {0, 0, -1}, {0, 0, -1}};

// Generic bone lengths (metres, by child joint): medians over synthetic bodies of every shape
// (`depthpose synth --bodies wide`, heights 1.1–2.0 m); they stand in until a user's own lengths are
// measured. The neck→knee "bone" spans torso and thigh, so it bends with the hips.
constexpr float kGenericBoneM[kSkeletonJoints] = {0.10f,  0.0f,   0.24f, 0.24f, 0.255f, 0.255f, 0.24f,  0.24f,
                                                  0.055f, 0.055f, 0.95f, 0.95f, 0.42f,  0.42f,  0.156f, 0.156f};
// Bone length tolerance as a fraction of the length (plus a slack, below): generic lengths cover bodies
// from 1.1 to 2.0 m tall; a user's measured lengths vary only with the proposals' noise, except the
// neck→knee span (hip flexion: 0.5–1.3 m on the synthetic motion).
constexpr float kBoneToleranceGeneric = 0.35f;
// Fraction, range tried 0.15–0.30. On the validation sequences (default filter; tall clutter seeds
// 191–196 and seeds 11–14 / 41–44 without it) with the shipped depth-20 models/ojr.blob and
// models/bpc.blob, the first proposal is within 0.1 m 0.617 / 0.606 (ojr) and 0.633 / 0.616 (bpc).
// With the mirror cost 1.5 and orphan cost 6, tolerance 0.15 / 0.20 / 0.25 / 0.30 gave the tracker
// 0.618 / 0.629 / 0.633 / 0.627 and 0.611 / 0.611 / 0.615 / 0.616 (ojr), 0.638 / 0.639 / 0.637 /
// 0.646 and 0.610 / 0.614 / 0.620 / 0.616 (bpc); with the mirror cost 3, 0.25 / 0.30 gave 0.634 /
// 0.629, 0.614 / 0.615, 0.640 / 0.640, 0.623 / 0.624: 0.25 has the best sum of the four gains.
// With the one-tree OJR blob (selection rule, at the cost weights below) 0.20 / 0.30 gave +0.062 /
// +0.063, 66.0 / 65.6 ‰, 32.1 / 32.8 mm (0.25: +0.063, 65.1 ‰, 32.0 mm).
constexpr float kBoneToleranceMeasured = 0.25f;
constexpr float kBoneToleranceHipSpan = 0.35f;
// Added to a bone's tolerance (metres): the noise of the two proposals a bone is measured between
// (a few cm each), which a fraction of the length does not cover on the short bones (wrist→hand
// 0.055 m, ankle→foot 0.156 m, neck→head 0.10 m). At 0.02 m for every bone the bone terms moved
// correct first proposals: of the joint-frames where the first proposal was within 0.1 m and the
// tracker's joint was not, the tracker had taken another proposal or the last position in 1136 of
// 1460 (validation seeds 11–14 / 41–44, models/ojr.blob), and the bone cost to the parent or the
// children was the term that favoured that choice most in 994 of them (docs/skeleton.md, "Why the
// tracker lost on set B and the lower legs"). Chosen on the validation sequences (default filter;
// W = seeds 11–14 / 41–44, V = tall clutter 191–196; ojr and bpc): the largest sum of the four gains
// over the first proposal within 0.1 m whose sum of the four swap rates stays at most the previous
// tracker's (74.2 ‰) and whose mean still-joint jitter (default filter) stays at most the previous
// tracker's (30.5 mm); ties within 0.001 go to fewer swaps.
// - One slack for every bone (no continuity weight), 0.02 / 0.04 / 0.06 / 0.08 / 0.09
//   / 0.10 / 0.11 / 0.12 / 0.15 m: +0.032 / +0.038 / +0.042 / +0.049 / +0.049 / +0.055 / +0.050 /
//   +0.047 / +0.040, joints (of 4 × 16) more than 0.005 below their first proposal 26 / 23 / 22 / 20
//   / 17 / 16 / 17 / 17 / 17; at 0.10 m swaps 65.0 ‰ and jitter 26.0 mm.
// - With the continuity weight (no floor), a separate slack for the generic lengths (a user's first
//   frames) 0.02 / 0.05 / 0.08 / as measured (0.10) × measured 0.08 / 0.10 / 0.12 m: +0.067 / +0.074
//   / +0.072, +0.069 / +0.073 / +0.071, +0.065 / +0.069 / +0.068, – / +0.064 / –.
// - With the weight's floor kMinContinuityWeight 0.7: generic 0.02 / 0.05 / 0.10 (measured 0.10)
//   +0.067 / +0.066 / +0.060, jitter 35.6 / 30.4 / 29.5 mm; measured 0.08 / 0.10 / 0.12 (generic
//   0.05) +0.057 / +0.066 / +0.062.
// - With the one-tree OJR blob (selection rule, at the cost weights below; 0.10 / 0.05 m: +0.063,
//   65.1 ‰, 32.0 mm): measured 0.08 / 0.12 m +0.061 / +0.064, 67.7 / 65.5 ‰, 32.1 / 32.0 mm;
//   generic 0.02 / 0.08 m +0.064 / +0.063, 70.9 / 68.2 ‰, 35.8 / 32.2 mm.
constexpr float kBoneSlackMeasuredM = 0.10f;
constexpr float kBoneSlackGenericM = 0.05f;

// Cost weights (dimensionless: each term is a squared normalised deviation, capped so that one bad
// term cannot dominate). Set by hand, except those whose comment gives the values tried on the
// validation sequences (docs/skeleton.md, "Measurements").
// "The selection rule" below: on the validation sequences (default filter; W = seeds 11–14 / 41–44,
// V = tall clutter 191–196; with models/ojr.blob and models/bpc.blob), the largest sum of the four
// gains of the tracker over the first proposal within 0.1 m whose sum of the four swap rates and
// whose mean still-joint jitter are at most the current tracker's; ties within 0.001 go to fewer
// swaps. With the shipped one-tree models/ojr.blob (held-out mAP 0.776) and the weights before
// the mirror, orphan and side-cap values below (mirror 3, orphan 4, side cap 6): gains ojr W / V,
// bpc W / V +0.012 / +0.020 / +0.012 / +0.019 (sum +0.063), swaps 16.5 / 15.5 / 15.9 / 17.2 ‰
// (sum 65.1), mean jitter 32.0 mm; one weight changed at a time, sum of gains / sum of swaps
// ‰ / mean jitter mm, unless stated with the chosen values: see each constant.
constexpr float kWeightProposal = 1.0f;    // per unit of −log(confidence ratio)
constexpr float kMaxProposalCost = 6.0f;
// Continuity: distance per frame that costs 1 (validation: 0.08 / 0.12 / 0.2 / 0.3 m gave 0.702 /
// 0.700 / 0.711 / 0.703 within 0.1 m; with the one-tree OJR blob, by the selection rule, 0.15 /
// 0.25 m gave +0.048 / +0.062, 68.4 / 72.8 ‰, 31.0 / 37.0 mm).
constexpr float kMotionScaleM = 0.2f;
constexpr float kMaxContinuityCost = 6.0f;
// The least weight of the continuity term (the last position's confidence over the best tracked
// class's, see update()), range 0–1 (1: no weighting). Chosen on the validation sequences by the
// rule of the bone slack above. With the bone slacks 0.10 / 0.05 m and the confidence
// tables fitted before them, floor 0 / 0.5 / 0.6 / 0.7 / 0.8 / 1 gave the sum of the four gains over
// the first proposal +0.073 / +0.071 / +0.071 / +0.066 / +0.064 / +0.053, swaps 66.3 / 66.7 / 65.0 /
// 63.9 / 65.3 / 65.5 ‰ (sum of the four) and jitter 36.2 / 32.4 / 31.2 / 30.4 / 30.4 / 27.2 mm: a
// weak last position no longer holds a wrong choice, but without a floor the choice hops more.
// With the one-tree OJR blob (selection rule, above): 0.5 / 0.6 / 0.8 gave +0.068 / +0.067 /
// +0.063, 67.5 / 67.0 / 64.1 ‰, 34.6 / 32.6 / 31.9 mm (0.7: +0.063, 65.1 ‰, 32.0 mm); with the
// chosen mirror and orphan costs 0.8 gave +0.064 against +0.066.
constexpr float kMinContinuityWeight = 0.7f;
constexpr float kWeightBone = 1.0f;
constexpr float kMaxBoneCost = 9.0f;
constexpr float kFitBoneCost = 4.0f;       // bone cost above which a proposal "does not fit" (2 tolerances)
// Side: distance on the wrong side of the mid-plane that costs 1. Chosen on the validation
// sequences (V, W below) with the previous three-tree OJR blob, tracker within 0.1 m minus the
// first proposal's summed over ojr V / W and bpc V / W: 0.06 m +0.018, 0.08 +0.012, 0.12 +0.025,
// 0.16 +0.032, 0.20 +0.032, 0.25 +0.034, with fewer swaps on all four sets from 0.16 on; 0.20 sits
// in the middle of that plateau (ojr +0.017 / +0.001, bpc +0.008 / +0.006; swaps ‰ 16.6 / 18.5,
// 19.9 / 19.2). Re-checked with the one-tree OJR blob (selection rule, above): 0.06 / 0.10 / 0.15
// / 0.25 / 0.30 / 0.40 m gave +0.044 / +0.049 / +0.060 / +0.062 / +0.060 / +0.061, 78.6 / 77.1 /
// 66.2 / 67.3 / 67.8 / 68.3 ‰ (0.20: +0.063, 65.1 ‰): 0.20 stays, with the fewest swaps.
constexpr float kSideScaleM = 0.20f;
// The side term's cap (in units of the weight below), range tried 2–9. With the one-tree OJR blob
// (selection rule, above), alone 3 / 9 gave +0.065 / +0.062, 63.4 / 65.4 ‰, 32.2 / 32.0 mm (6:
// +0.063, 65.1 ‰, 32.0 mm); with mirror cost 4 and orphan cost 3, cap 2 / 3 / 4 / 6 gave +0.065 /
// +0.066 / +0.066 / +0.066, 61.9 / 61.5 / 62.2 / 63.0 ‰, 32.4 / 32.05 / 31.9 / 32.0 mm: 4 is the
// one of the best gain whose jitter stays within the bound (3 has 0.7 ‰ fewer swaps, 0.05 mm more
// jitter). A capped side cost lets a limb joint cross the mid-plane (a crossed arm, a turned body)
// when its bones and proposal say so.
constexpr float kMaxSideCost = 4.0f;
// Per joint: elbows 1, wrists and hands 0.5, knees 0.5, ankles and feet 0.25. With the one-tree
// OJR blob (selection rule, above, on the 14 sequences W+V), one group at a time from elbows and
// knees 1, the others 0.5: ankles and feet 0.25 / 1 / 1.5 +0.063 / +0.055 / +0.054, 65.3 / 69.6 /
// 68.6 ‰; knees 0.5 / 2 +0.060 / +0.059, 66.4 / 67.4 ‰; wrists and hands 0.25 / 1 +0.060 / +0.062,
// 67.6 / 64.6 ‰; elbows 0.5 / 2 +0.062 / +0.063, 66.9 / 65.1 ‰ (those weights: +0.063, 65.1 ‰).
// On the 138 sequences W″+V″ (the same rule: sum of the four gains; sum of the four swap rates;
// mean still-joint jitter), the leg weights × 0 / 0.25 / 0.5 / 0.75 / 1 gave +0.041 / +0.044 /
// +0.045 / +0.045 / +0.043, 119.9 / 119.0 / 118.0 / 119.1 / 120.0 ‰, 33.55 / 33.40 / 33.35 /
// 33.35 / 33.43 mm: × 0.5 chosen (in profile and on crossing legs the mid-plane says little about
// which leg is which).
constexpr float kSideWeight[kSkeletonJoints] = {0, 0, 0, 0, 1.0f, 1.0f, 0.5f, 0.5f, 0.5f, 0.5f,
                                                0.5f, 0.5f, 0.25f, 0.25f, 0.25f, 0.25f};
// × (1 − cos) of the facing change since the last frame. With the one-tree OJR blob (selection
// rule, above) 1 / 2 / 4 / 6 gave +0.060 / +0.062 / +0.063 / +0.062, 66.5 / 66.2 / 65.1 / 66.0 ‰
// (3: +0.063, 65.1 ‰).
constexpr float kWeightFacingTurn = 3.0f;
// New user: × the facing's component away from the camera. 0 / 0.5 / 1 / 2 gave the same figures
// to the digit on the validation sequences (the users there start facing the camera).
constexpr float kWeightFacingAway = 1.0f;
constexpr float kMinShoulderSpanM = 0.10f; // two shoulders closer than this are one place
constexpr float kShoulderOverlapCost = 6.0f;
// A left and a right limb joint closer than this coincide (metres). With the one-tree OJR blob
// (selection rule, above) 0.06 / 0.10 m gave +0.066 / +0.056, 76.4 / 63.2 ‰ (0.08: +0.063, 65.1 ‰).
constexpr float kMinLimbSeparationM = 0.08f;
// With the one-tree OJR blob (selection rule, above) 2 / 3 / 3.5 / 5 / 6 / 8 gave +0.075 / +0.069
// / +0.064 / +0.061 / +0.061 / +0.060, 95.1 / 71.7 / 66.0 / 65.4 / 65.3 / 65.9 ‰ (4: +0.063, 65.1
// ‰); below 4 the gains rise with the swaps, above it both worsen; with mirror cost 4, 3.5 gave
// +0.066, 64.8 ‰, 32.1 mm.
constexpr float kCoincideCost = 4.0f;
// Taking the mirror joint's proposal (cost units as above), range tried 1–4. On the validation
// sequences (as for kBoneToleranceMeasured, tolerance 0.20, orphan cost 6), 1 / 1.5 / 2 / 3 / 4
// gave within 0.1 m 0.626 / 0.629 / 0.630 / 0.631 / 0.629 (tall clutter) and 0.613 / 0.611 / 0.612
// / 0.609 / 0.611 with models/ojr.blob, 0.625 / 0.639 / 0.639 / 0.639 / 0.638 and 0.614 / 0.614 /
// 0.618 / 0.622 / 0.620 with models/bpc.blob; swaps per 1000 (same order) ojr 24.0 / 19.6 / 17.7 /
// 16.7 / 16.2 and 24.5 / 23.0 / 21.3 / 21.6 / 21.6, bpc 40.1 / 26.3 / 24.6 / 22.5 / 22.2 and 28.5 /
// 27.5 / 23.8 / 20.5 / 20.8: 3 had the best sum of the four rates with the previous three-tree OJR
// blob. With the one-tree OJR blob (selection rule, above) 2 / 2.5 / 3 / 3.5 / 4 / 4.5 / 5 / 6 gave
// +0.057 / +0.059 / +0.063 / +0.064 / +0.065 / +0.065 / +0.064 / +0.064, swaps 71.5 / 69.0 / 65.1
// / 64.9 / 63.7 / 63.7 / 63.7 / 63.6 ‰, jitter 30.1 / 31.2 / 32.0 / 32.1 / 32.05 / 32.05 / 32.2 /
// 32.2 mm: from 4 on the swaps stop falling (ojr V 14.6 ‰ against 15.5 at 3).
constexpr float kMirrorCost = 4.0f;
// Choosing the last position instead of any proposal. With the one-tree OJR blob (selection rule,
// above) 2 / 4 gave +0.064 / +0.057, 68.7 / 68.9 ‰, 35.0 / 31.8 mm (3: +0.063, 65.1 ‰, 32.0 mm).
constexpr float kPredictedCost = 3.0f;
constexpr float kAbsentCost = 8.0f;        // choosing nothing
// A proposal whose parent is an "absent" neck or shoulder: the bone to it is unmeasured, and this
// is its cost. Without it (0) an absent neck or shoulder cut every bone to its children (and the
// torso's side and facing terms) for the one kAbsentCost, so a torso joint went absent whenever
// furniture left its children's proposals scattered, and good first proposals of the neck and
// shoulders were lost. Range 0–kMaxBoneCost; on validation sequences with tall clutter (seeds
// 191–196, models/ojr.blob), applied to every parent, cost 0 / 1 / 2 / 4 / 6 / 8 gave 0.527 / 0.527
// / 0.529 / 0.533 / 0.541 / 0.541 within 0.1 m and 47.3 / 48.8 / 50.3 / 43.7 / 37.1 / 38.3 swaps ‰;
// applied under every parent it also reported scattered limb proposals that used to be missing
// (still-joint jitter 25.2 → 30.5 mm), so it applies under the torso joints only (6: 0.534, 44.8 ‰,
// jitter 22.6 mm; models/bpc.blob 0.531 → 0.553, swaps 51.1 → 42.0 ‰; those figures are the
// previous forests', BPC depth 16 and OJR depth 13). With the shipped depth-20 models, tolerance 0.25 and mirror cost 3,
// on the validation sequences (tall clutter; without) cost 4 / 6 / 8 gave within 0.1 m ojr 0.635 /
// 0.634 / 0.634, 0.614 / 0.614 / 0.614, bpc 0.640 / 0.640 / 0.636, 0.623 / 0.623 / 0.623, and swaps
// per 1000 ojr 17.2 / 19.7 / 19.8, 19.7 / 20.0 / 20.4, bpc 21.7 / 22.3 / 26.1, 20.6 / 20.5 / 21.0:
// 4 kept the rates and had the fewest swaps with the previous three-tree OJR blob. With the one-tree
// OJR blob (selection rule, above), alone 1 / 2 / 3 / 6 gave +0.064 / +0.064 / +0.064 / +0.062,
// 63.0 / 63.7 / 64.4 / 65.5 ‰, 32.2 / 32.1 / 32.0 / 32.0 mm (4: +0.063, 65.1 ‰, 32.0 mm); with
// mirror cost 4, 2 / 3 gave +0.066 / +0.066, 62.2 / 63.0 ‰, 32.1 / 32.0 mm, and with the side cap
// 4 (the chosen combination), 3: +0.066, 62.2 ‰, 31.9 mm.
constexpr float kOrphanCost = 3.0f;
constexpr int32_t kMaxPredictedFrames = 10;  // a joint unseen longer than this is missing
// The joints the filter's offset limit (SkeletonFilterParams::max_offset_m) holds near their chosen
// proposal: tracked with a fit score exp(−local cost / 2) ≥ 0.5, evidence classes
// kFilterLimitMinEvidence..9. Inferred and weakly fitting joints keep the full smoothing (their raw
// position is the less trustworthy one). On the validation sequences with tall clutter (seeds
// 191–196, the previous depth-13 OJR forest, limit 0.03 m) classes 5–9 gave 0.543 within 0.1 m at 24.5 mm still-joint
// jitter, every tracked class (0–9) 0.545 at 31.6 mm.
constexpr int32_t kFilterLimitMinEvidence = 5;

// Calibration of the confidence (probability of being within 0.1 m of the truth) per evidence
// class (TrackedJoint::evidence), with the default filter, one table per forest method: the two
// shipped forests (models/ojr.blob, one BPC tree's structure pruned to 200 000 leaves with OJR
// votes, and models/bpc.blob, two one-tree runs merged and pruned to 16 MB by information gain;
// depth 20) are calibrated differently: in most classes bpc's joints lie within 0.1 m more often. Each
// table is its blob's fit by `depthpose skeleton-eval --blob BLOB --fit-calibration` on the 138
// validation sequences W″ + V″ (`--clips split:validation`, 3 people: seeds 501–560, and 191–268
// with tall clutter; 34 000 body-frames) with this tracker: each class's fraction within 0.1 m,
// made monotone over the tracked classes 0–9 by pool adjacent violators. The continuity weight
// reads the table (the last confidence over class kBestTrackedEvidence's), so the fit was repeated
// with the fitted table in place until it returned itself. Fitted before
// on 14 of those sequences' easier kin (seeds 11–14, 41–44, 191–196; OJR class 9 0.79), the tables
// promised ~0.08 too much on every larger set, held-out ones included; refitted, their expected
// calibration error on the 60-sequence held-out sets is 0.015–0.019 (docs/skeleton.md, "States and
// confidences").
constexpr float kCalibrationOjr[kEvidenceClasses] = {0.03f, 0.11f, 0.12f, 0.15f, 0.18f, 0.24f, 0.31f, 0.38f,
                                                     0.50f, 0.69f, 0.18f, 0.13f, 0.11f, 0.10f, 0.10f, 0.22f};
constexpr float kCalibrationBpc[kEvidenceClasses] = {0.05f, 0.13f, 0.15f, 0.19f, 0.23f, 0.32f, 0.39f, 0.46f,
                                                     0.55f, 0.69f, 0.15f, 0.10f, 0.08f, 0.07f, 0.06f, 0.18f};

// The tracked evidence class of the best fit (exp(−local cost / 2) ≥ 0.9); its calibrated
// confidence is the highest of the tracked classes (the tables are monotone over 0..9).
constexpr int kBestTrackedEvidence = 9;
constexpr int kMaxJointCandidates = 2 * kMaxProposals + 2;  // own and mirror proposals, the prediction, "absent"
constexpr int32_t kKindPredicted = -1;
constexpr int32_t kKindAbsent = -2;
constexpr float kInfinity = 3.0e38f;

float distance(const float* a, const float* b) {
  const float dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return sqrtf(dx * dx + dy * dy + dz * dz);
}
float capped(float v, float cap) { return v < cap ? v : cap; }
bool is_shoulder(int32_t joint) { return joint == kShoulderL || joint == kShoulderR; }

// The per-frame working set of one update (on the stack: ~8 KB).
struct Candidates {
  int32_t count[kSkeletonJoints];
  int32_t kind[kSkeletonJoints][kMaxJointCandidates];     // proposal index, kKindPredicted or kKindAbsent
  int32_t source[kSkeletonJoints][kMaxJointCandidates];   // the joint whose proposal it is
  float pos[kSkeletonJoints][kMaxJointCandidates][3];
  float unary[kSkeletonJoints][kMaxJointCandidates];
  float pair[kSkeletonJoints][kMaxJointCandidates][kMaxJointCandidates];  // [joint][its candidate][parent's]
};

// Side and facing terms of one shoulder pair.
struct Torso {
  int32_t valid;     // both shoulders located and apart
  float mid[3];      // shoulder midpoint
  float left[3];     // unit, shoulder_r → shoulder_l
  float facing[3];   // unit, up × left, in the horizontal plane
  float cost;        // facing + overlap
};

Torso torso_of(const Candidates& c, int a, int b, int32_t facing_known, const float* last_facing) {
  Torso t{};
  if (c.kind[kShoulderL][a] == kKindAbsent || c.kind[kShoulderR][b] == kKindAbsent) return t;
  const float* l = c.pos[kShoulderL][a];
  const float* r = c.pos[kShoulderR][b];
  const float span = distance(l, r);
  if (span < kMinShoulderSpanM) {
    t.cost = kShoulderOverlapCost;
    return t;
  }
  t.valid = 1;
  for (int k = 0; k < 3; ++k) {
    t.mid[k] = 0.5f * (l[k] + r[k]);
    t.left[k] = (l[k] - r[k]) / span;
  }
  // up × left = (left_z, 0, −left_x), normalised in the horizontal plane.
  const float horizontal = sqrtf(t.left[2] * t.left[2] + t.left[0] * t.left[0]);
  if (horizontal > 1e-3f) {
    t.facing[0] = t.left[2] / horizontal;
    t.facing[2] = -t.left[0] / horizontal;
    if (facing_known) {
      const float cosine = t.facing[0] * last_facing[0] + t.facing[2] * last_facing[2];
      t.cost += kWeightFacingTurn * (1.0f - cosine);
    } else if (t.facing[2] > 0.0f) {
      t.cost += kWeightFacingAway * t.facing[2];
    }
  }
  return t;
}

float side_cost(const Torso& t, int32_t joint, const float* p) {
  if (!t.valid || kSideWeight[joint] == 0.0f) return 0.0f;
  const float lateral = kSide[joint] * ((p[0] - t.mid[0]) * t.left[0] + (p[1] - t.mid[1]) * t.left[1] +
                                        (p[2] - t.mid[2]) * t.left[2]);
  if (lateral >= 0.0f) return 0.0f;
  const float n = lateral / kSideScaleM;
  return kSideWeight[joint] * capped(n * n, kMaxSideCost);
}

// Min-sum over the tree with the shoulders fixed to candidates a and b. Fills arg[j][parent
// candidate] and returns the total cost and the neck's best candidate.
float solve(const Candidates& c, const Torso& t, int a, int b, int32_t arg[kSkeletonJoints][kMaxJointCandidates],
            int32_t* neck_choice) {
  float child_sum[kSkeletonJoints][kMaxJointCandidates];
  float own[kSkeletonJoints][kMaxJointCandidates];  // unary + side, per candidate
  for (int j = 0; j < kSkeletonJoints; ++j)
    for (int k = 0; k < c.count[j]; ++k) {
      child_sum[j][k] = 0.0f;
      own[j][k] = c.unary[j][k] + side_cost(t, j, c.pos[j][k]);
    }
  for (int i = 0; i < kSkeletonJoints - 1; ++i) {
    const int32_t j = kLeavesFirst[i];
    const int32_t p = kParent[j];
    const int lo = j == kShoulderL ? a : j == kShoulderR ? b : 0;
    const int hi = j == kShoulderL ? a + 1 : j == kShoulderR ? b + 1 : c.count[j];
    for (int cp = 0; cp < c.count[p]; ++cp) {
      float best = kInfinity;
      int32_t best_k = lo;
      for (int k = lo; k < hi; ++k) {
        const float v = own[j][k] + c.pair[j][k][cp] + child_sum[j][k];
        if (v < best) {
          best = v;
          best_k = k;
        }
      }
      child_sum[p][cp] += best;
      arg[j][cp] = best_k;
    }
  }
  float best = kInfinity;
  *neck_choice = 0;
  for (int n = 0; n < c.count[kNeck]; ++n) {
    const float v = c.unary[kNeck][n] + child_sum[kNeck][n];
    if (v < best) {
      best = v;
      *neck_choice = n;
    }
  }
  return best + t.cost;
}

// A limb pair: the left joints from the torso outwards; the right ones are their mirrors.
struct LimbChain {
  int32_t left[3];
};
constexpr LimbChain kArmChain{{kElbowL, kWristL, kHandL}};
constexpr LimbChain kLegChain{{kKneeL, kAnkleL, kFootL}};

float pair_unary(const Candidates& c, const Torso& t, int32_t jl, int l, int32_t jr, int r) {
  float cost = c.unary[jl][l] + side_cost(t, jl, c.pos[jl][l]) + c.unary[jr][r] + side_cost(t, jr, c.pos[jr][r]);
  if (c.kind[jl][l] != kKindAbsent && c.kind[jr][r] != kKindAbsent &&
      distance(c.pos[jl][l], c.pos[jr][r]) < kMinLimbSeparationM)
    cost += kCoincideCost;
  return cost;
}

// Min-sum over the chain of (left, right) candidate pairs, the parents' choices fixed; writes the
// limbs' choices. O(3 · C⁴) for C candidates per joint.
void solve_limb_pair(const Candidates& c, const Torso& t, const LimbChain& chain, int32_t* choice) {
  // msg[l][r]: best cost of the levels below, given the pair (l, r) at the current level.
  float msg[kMaxJointCandidates][kMaxJointCandidates];
  int16_t arg[3][kMaxJointCandidates][kMaxJointCandidates][2];
  for (int l = 0; l < kMaxJointCandidates; ++l)
    for (int r = 0; r < kMaxJointCandidates; ++r) msg[l][r] = 0.0f;
  for (int level = 2; level >= 1; --level) {
    const int32_t jl = chain.left[level], jr = kMirror[jl];
    const int32_t pl = chain.left[level - 1], pr = kMirror[pl];
    float next[kMaxJointCandidates][kMaxJointCandidates];
    float own[kMaxJointCandidates][kMaxJointCandidates];
    for (int l = 0; l < c.count[jl]; ++l)
      for (int r = 0; r < c.count[jr]; ++r) own[l][r] = pair_unary(c, t, jl, l, jr, r) + msg[l][r];
    for (int a = 0; a < c.count[pl]; ++a)
      for (int b = 0; b < c.count[pr]; ++b) {
        float best = kInfinity;
        int16_t bl = 0, br = 0;
        for (int l = 0; l < c.count[jl]; ++l)
          for (int r = 0; r < c.count[jr]; ++r) {
            const float v = own[l][r] + c.pair[jl][l][a] + c.pair[jr][r][b];
            if (v < best) {
              best = v;
              bl = int16_t(l);
              br = int16_t(r);
            }
          }
        next[a][b] = best;
        arg[level][a][b][0] = bl;
        arg[level][a][b][1] = br;
      }
    for (int a = 0; a < c.count[pl]; ++a)
      for (int b = 0; b < c.count[pr]; ++b) msg[a][b] = next[a][b];
  }
  const int32_t jl = chain.left[0], jr = kMirror[jl];
  const int32_t a = choice[kParent[jl]], b = choice[kParent[jr]];
  float best = kInfinity;
  for (int l = 0; l < c.count[jl]; ++l)
    for (int r = 0; r < c.count[jr]; ++r) {
      const float v = pair_unary(c, t, jl, l, jr, r) + c.pair[jl][l][a] + c.pair[jr][r][b] + msg[l][r];
      if (v < best) {
        best = v;
        choice[jl] = l;
        choice[jr] = r;
      }
    }
  for (int level = 1; level <= 2; ++level) {
    const int32_t pl = chain.left[level - 1], pr = kMirror[pl];
    const int32_t l = chain.left[level];
    choice[l] = arg[level][choice[pl]][choice[pr]][0];
    choice[kMirror[l]] = arg[level][choice[pl]][choice[pr]][1];
  }
}

// Quaternion (w, x, y, z) products and rotation of a vector.
void quat_multiply(const float* a, const float* b, float* out) {
  out[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
  out[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
  out[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
  out[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
}
void quat_rotate(const float* q, const float* v, float* out) {
  const float p[4] = {0.0f, v[0], v[1], v[2]};
  const float conj[4] = {q[0], -q[1], -q[2], -q[3]};
  float t[4], r[4];
  quat_multiply(q, p, t);
  quat_multiply(t, conj, r);
  out[0] = r[1];
  out[1] = r[2];
  out[2] = r[3];
}
// The shortest rotation taking unit a onto unit b (half-angle form); for opposite vectors, a half
// turn about an axis perpendicular to a.
void quat_from_to(const float* a, const float* b, float* q) {
  float w = 1.0f + a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  float x = a[1] * b[2] - a[2] * b[1], y = a[2] * b[0] - a[0] * b[2], z = a[0] * b[1] - a[1] * b[0];
  if (w < 1e-6f) {
    w = 0.0f;
    // a × (unit axis least aligned with a)
    if (fabsf(a[0]) < 0.6f) { x = 0.0f; y = a[2]; z = -a[1]; }
    else { x = -a[2]; y = 0.0f; z = a[0]; }
  }
  const float n = sqrtf(w * w + x * x + y * y + z * z);
  q[0] = w / n;
  q[1] = x / n;
  q[2] = y / n;
  q[3] = z / n;
}

void bone_rotations(Skeleton* s) {
  // The torso's yaw: rest facing (0, 0, −1) turned about +y onto the facing.
  float yaw[4] = {1.0f, 0.0f, 0.0f, 0.0f};
  if (s->facing_known) {
    const float half = 0.5f * atan2f(-s->facing[0], -s->facing[2]);
    yaw[0] = cosf(half);
    yaw[2] = sinf(half);
  }
  for (int j = 0; j < kSkeletonJoints; ++j) {
    float* q = s->bone_rotation[j];
    q[0] = 1.0f;
    q[1] = q[2] = q[3] = 0.0f;
    s->bone_rotation_valid[j] = 0;
    const int32_t p = kParent[j];
    if (p < 0 || s->joints[j].state == JointState::kMissing || s->joints[p].state == JointState::kMissing) continue;
    float d[3] = {s->joints[j].x_m - s->joints[p].x_m, s->joints[j].y_m - s->joints[p].y_m,
                  s->joints[j].z_m - s->joints[p].z_m};
    const float n = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (n < 1e-6f) continue;
    for (int a = 0; a < 3; ++a) d[a] /= n;
    float rest[3], swing[4];
    quat_rotate(yaw, kRestDirection[j], rest);
    quat_from_to(rest, d, swing);
    quat_multiply(swing, yaw, q);
    s->bone_rotation_valid[j] = 1;
  }
}

float bone_tolerance(int32_t joint, float length, bool measured) {
  const float fraction = joint == kKneeL || joint == kKneeR ? kBoneToleranceHipSpan
                         : measured                          ? kBoneToleranceMeasured
                                                             : kBoneToleranceGeneric;
  return fraction * length + (measured ? kBoneSlackMeasuredM : kBoneSlackGenericM);
}

}  // namespace

int32_t skeleton_parent(int32_t joint) { return joint >= 0 && joint < kSkeletonJoints ? kParent[joint] : -1; }
const char* skeleton_joint_name(int32_t joint) {
  return joint >= 0 && joint < kSkeletonJoints ? kNames[joint] : "?";
}
const char* joint_state_name(JointState s) {
  switch (s) {
    case JointState::kMissing: return "missing";
    case JointState::kInferred: return "inferred";
    case JointState::kTracked: return "tracked";
  }
  return "?";
}

SkeletonConfig default_skeleton_config() {
  SkeletonConfig c{};
  c.max_candidates = 4;
  c.frame_period_s = 1.0f / 30.0f;
  c.forget_frames = 30;
  c.filter = skeleton_filter_preset(SkeletonFilterPreset::kDefault);
  return c;
}

Status SkeletonTracker::set_config(const SkeletonConfig& config) {
  if (config.max_candidates < 1 || config.max_candidates > kMaxProposals || !(config.frame_period_s > 0.0f) ||
      !(config.frame_period_s <= 1.0f) || config.forget_frames < 1 || config.forget_frames > 10000 ||
      !skeleton_filter_params_valid(config.filter))
    return Status::kBadConfig;
  config_ = config;
  return Status::kOk;
}

Status SkeletonTracker::init(const blob::ForestMeta& meta, const SkeletonConfig& config) {
  initialized_ = false;
  if (meta.joint_count != kSkeletonJoints) return Status::kBadArgument;
  for (int j = 0; j < kSkeletonJoints; ++j)
    if (strncmp(meta.joint_names[j], kNames[j], blob::kNameBytes) != 0) return Status::kBadArgument;
  if (Status s = set_config(config); s != Status::kOk) return s;
  calibration_ = meta.method == uint8_t(blob::Method::kBpc) ? kCalibrationBpc : kCalibrationOjr;
  for (int id = 0; id <= kMaxUsers; ++id) reset_user(users_[id]);
  initialized_ = true;
  return Status::kOk;
}

void SkeletonTracker::reset_user(UserState& u) {
  memset(&u, 0, sizeof u);
  for (int j = 0; j < kSkeletonJoints; ++j) u.bone_length[j] = kGenericBoneM[j];
}

void SkeletonTracker::restart_user(UserState& u) {
  float samples[kSkeletonJoints][kBoneSamples], length[kSkeletonJoints];
  int32_t count[kSkeletonJoints], next[kSkeletonJoints];
  memcpy(samples, u.bone_samples, sizeof samples);
  memcpy(length, u.bone_length, sizeof length);
  memcpy(count, u.bone_count, sizeof count);
  memcpy(next, u.bone_next, sizeof next);
  reset_user(u);
  memcpy(u.bone_samples, samples, sizeof samples);
  memcpy(u.bone_length, length, sizeof length);
  memcpy(u.bone_count, count, sizeof count);
  memcpy(u.bone_next, next, sizeof next);
}

void SkeletonTracker::forget(int32_t user_id) {
  if (user_id >= 1 && user_id <= kMaxUsers) reset_user(users_[user_id]);
}

void SkeletonTracker::user_returned(int32_t user_id) {
  if (user_id < 1 || user_id > kMaxUsers) return;
  users_[user_id].active = 0;
  users_[user_id].returning = 1;
}

void SkeletonTracker::note_arrival(int32_t user_id, int32_t arrival) {
  if (arrival == kUserNew) forget(user_id);
  else if (arrival == kUserReturned) user_returned(user_id);
}

void SkeletonTracker::begin_frame() {
  for (int id = 1; id <= kMaxUsers; ++id) {
    UserState& u = users_[id];
    if (!u.active) continue;
    if (++u.frames_unseen > config_.forget_frames) u.active = 0;  // update() restarts it
  }
}

void SkeletonTracker::update_bones(UserState& u, const Skeleton& s) {
  for (int j = 0; j < kSkeletonJoints; ++j) {
    const int32_t p = kParent[j];
    if (p < 0 || s.joints[j].state != JointState::kTracked || s.joints[p].state != JointState::kTracked) continue;
    u.bone_samples[j][u.bone_next[j]] = distance(s.joints[j].raw_m, s.joints[p].raw_m);
    u.bone_next[j] = (u.bone_next[j] + 1) % kBoneSamples;
    if (u.bone_count[j] < kBoneSamples) ++u.bone_count[j];
    if (u.bone_count[j] < kBoneSamplesTrusted) continue;
    float sorted[kBoneSamples];
    const int n = u.bone_count[j];
    for (int i = 0; i < n; ++i) {  // insertion sort of at most kBoneSamples values
      const float v = u.bone_samples[j][i];
      int k = i;
      for (; k > 0 && sorted[k - 1] > v; --k) sorted[k] = sorted[k - 1];
      sorted[k] = v;
    }
    u.bone_length[j] = sorted[n / 2];
  }
}

Status SkeletonTracker::update(int32_t user_id, const FrameResult& r, Skeleton* out) {
  if (!initialized_) return Status::kNotInitialized;
  if (!out || user_id < 1 || user_id > kMaxUsers || r.joint_count != kSkeletonJoints) return Status::kBadArgument;
  const uint64_t t0 = cycle_count();
  UserState& u = users_[user_id];
  if (!u.active) {
    if (u.returning) restart_user(u);
    else reset_user(u);
    u.active = 1;
  }
  u.frames_unseen = 0;
  ++u.frames_tracked;

  // Candidates and their own costs.
  Candidates c;
  for (int j = 0; j < kSkeletonJoints; ++j) {
    int n = 0;
    const float motion_scale = kMotionScaleM * float(1 + (u.missed[j] < 5 ? u.missed[j] : 5));
    // Continuity pulls towards the last position as far as that position was likely right: its
    // reported confidence over the best tracked class's, at least kMinContinuityWeight. Without
    // this weight a wrong choice held itself: the distance from it made the next frames' correct
    // proposals expensive (docs/skeleton.md, "Why the tracker lost on set B and the lower legs").
    const float best_class = calibration_[kBestTrackedEvidence];
    float continuity_weight = best_class > 0.0f ? u.last_confidence[j] / best_class : 1.0f;
    if (continuity_weight > 1.0f) continuity_weight = 1.0f;
    if (continuity_weight < kMinContinuityWeight) continuity_weight = kMinContinuityWeight;
    // The joint's own proposals, then its mirror joint's (the forest often puts a left joint's
    // best mode on the right limb and the reverse; the side and bone costs tell them apart). Not
    // for the shoulders: they anchor the torso's facing, and their own proposals rarely swap.
    const int32_t sources[2] = {j, kMirror[j]};
    for (int si = 0; si < (kMirror[j] != j && !is_shoulder(j) ? 2 : 1); ++si) {
      const int32_t src = sources[si];
      const int count = r.proposal_count[src] < config_.max_candidates ? r.proposal_count[src] : config_.max_candidates;
      const float src_top = count > 0 ? r.proposals[src][0].confidence : 0.0f;
      for (int k = 0; k < count; ++k, ++n) {
        const JointProposal& p = r.proposals[src][k];
        c.kind[j][n] = k;
        c.source[j][n] = src;
        c.pos[j][n][0] = p.x_m;
        c.pos[j][n][1] = p.y_m;
        c.pos[j][n][2] = p.z_m;
        const float ratio = src_top > 0.0f && p.confidence > 0.0f ? p.confidence / src_top : 0.0f;
        float cost = ratio > 0.0f ? capped(kWeightProposal * -logf(ratio), kMaxProposalCost) : kMaxProposalCost;
        if (src != j) cost += kMirrorCost;
        if (u.has_last[j]) {
          const float d = distance(c.pos[j][n], u.last[j]) / motion_scale;
          cost += continuity_weight * capped(d * d, kMaxContinuityCost);
        }
        c.unary[j][n] = cost;
      }
    }
    if (u.has_last[j]) {
      c.kind[j][n] = kKindPredicted;
      c.source[j][n] = j;
      for (int a = 0; a < 3; ++a) c.pos[j][n][a] = u.last[j][a];
      c.unary[j][n] = kPredictedCost;
      ++n;
    }
    c.kind[j][n] = kKindAbsent;
    c.source[j][n] = j;
    c.pos[j][n][0] = c.pos[j][n][1] = c.pos[j][n][2] = 0.0f;
    c.unary[j][n] = kAbsentCost;
    c.count[j] = n + 1;
  }
  // Bone costs against every parent candidate.
  for (int j = 0; j < kSkeletonJoints; ++j) {
    const int32_t p = kParent[j];
    if (p < 0) continue;
    const float length = u.bone_length[j];
    const float tolerance = bone_tolerance(j, length, u.bone_count[j] >= kBoneSamplesTrusted);
    for (int k = 0; k < c.count[j]; ++k)
      for (int q = 0; q < c.count[p]; ++q) {
        if (c.kind[j][k] == kKindAbsent || c.kind[p][q] == kKindAbsent) {
          const bool orphan = (p == kNeck || is_shoulder(p)) && c.kind[p][q] == kKindAbsent && c.kind[j][k] != kKindAbsent;
          c.pair[j][k][q] = orphan ? kOrphanCost : 0.0f;
          continue;
        }
        const float n = (distance(c.pos[j][k], c.pos[p][q]) - length) / tolerance;
        c.pair[j][k][q] = kWeightBone * capped(n * n, kMaxBoneCost);
      }
  }

  // Every shoulder pair, then the best again to read its choices.
  int32_t arg[kSkeletonJoints][kMaxJointCandidates];
  int32_t neck = 0;
  float best = kInfinity;
  int best_a = 0, best_b = 0;
  for (int a = 0; a < c.count[kShoulderL]; ++a)
    for (int b = 0; b < c.count[kShoulderR]; ++b) {
      const Torso t = torso_of(c, a, b, u.facing_known, u.facing);
      const float cost = solve(c, t, a, b, arg, &neck);
      if (cost < best) {
        best = cost;
        best_a = a;
        best_b = b;
      }
    }
  const Torso torso = torso_of(c, best_a, best_b, u.facing_known, u.facing);
  solve(c, torso, best_a, best_b, arg, &neck);
  int32_t choice[kSkeletonJoints];
  choice[kNeck] = neck;
  for (int i = kSkeletonJoints - 2; i >= 0; --i) {
    const int32_t j = kLeavesFirst[i];
    choice[j] = arg[j][choice[kParent[j]]];
  }
  // Second round: each pair of limbs (arms from the chosen shoulders, legs from the chosen neck)
  // as one chain of left/right pairs, so that the two sides cannot settle on the same place.
  solve_limb_pair(c, torso, kArmChain, choice);
  solve_limb_pair(c, torso, kLegChain, choice);

  // States, confidences, filter, and the user's memory.
  memset(out, 0, sizeof *out);
  out->user_id = user_id;
  out->frames_tracked = u.frames_tracked;
  for (int j = 0; j < kSkeletonJoints; ++j) {
    TrackedJoint& o = out->joints[j];
    const int k = choice[j];
    const int32_t kind = c.kind[j][k];
    o.proposal = kind >= 0 ? kind : -1;
    o.proposal_joint = kind >= 0 ? c.source[j][k] : -1;
    o.evidence = -1;
    if (kind == kKindAbsent) {
      o.state = JointState::kMissing;
      u.filters[j].reset();
      u.has_last[j] = 0;
      u.missed[j] = 0;
      continue;
    }
    const int32_t p = kParent[j];
    const float bone = p >= 0 && c.kind[p][choice[p]] != kKindAbsent ? c.pair[j][k][choice[p]] : 0.0f;
    int evidence;
    if (kind == kKindPredicted) {
      const int frames = u.missed[j] + 1;
      evidence = 10 + (frames < 5 ? frames : 5) - 1;
    } else if (bone > kFitBoneCost) {
      evidence = 15;
    } else {
      const float local = c.unary[j][k] + bone + side_cost(torso, j, c.pos[j][k]);
      int bin = int(10.0f * expf(-0.5f * local));
      evidence = bin > 9 ? 9 : bin;
    }
    o.evidence = evidence;
    o.state = evidence < 10 ? JointState::kTracked : JointState::kInferred;
    o.confidence = calibration_[evidence];
    for (int a = 0; a < 3; ++a) o.raw_m[a] = c.pos[j][k][a];
    float filtered[3];
    u.filters[j].update(config_.filter, config_.frame_period_s, o.raw_m, filtered);
    if (config_.filter.enabled && config_.filter.max_offset_m > 0.0f && evidence >= kFilterLimitMinEvidence && evidence < 10)
      u.filters[j].limit_offset(o.raw_m, config_.filter.max_offset_m, filtered);
    o.x_m = filtered[0];
    o.y_m = filtered[1];
    o.z_m = filtered[2];
    for (int a = 0; a < 3; ++a) u.last[j][a] = o.raw_m[a];
    u.last_confidence[j] = o.confidence;
    u.has_last[j] = 1;
    u.missed[j] = o.state == JointState::kTracked ? 0 : u.missed[j] + 1;
    if (u.missed[j] > kMaxPredictedFrames) u.has_last[j] = 0;
  }
  if (torso.valid && out->joints[kShoulderL].state == JointState::kTracked &&
      out->joints[kShoulderR].state == JointState::kTracked) {
    u.facing_known = 1;
    for (int a = 0; a < 3; ++a) u.facing[a] = torso.facing[a];
  }
  out->facing_known = torso.valid;
  for (int a = 0; a < 3; ++a) out->facing[a] = torso.facing[a];
  update_bones(u, *out);
  for (int j = 0; j < kSkeletonJoints; ++j) out->bone_length_m[j] = kParent[j] >= 0 ? u.bone_length[j] : 0.0f;
  bone_rotations(out);
  out->cycles = cycle_count() - t0;
  return Status::kOk;
}

}  // namespace dp
