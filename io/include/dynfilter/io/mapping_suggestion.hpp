#pragma once
/// @file
/// A first mapping of a BVH skeleton onto a floating-base model, found from the structure
/// of both alone (no joint or link name is known to the code), for the user to review
/// (`dynfilter-bvh2ref --suggest-mapping`; README "A first mapping").
///
/// The BVH, in its rest pose (every rotation zero):
///  - the pelvis is the first joint from the root with two or more children; of its
///    branches the one with the most joints is the spine, the two of the others reaching
///    furthest from the spine's centroid the legs;
///  - up is the spine's centroid minus the legs', forward the mean direction from each
///    ankle to its toe along the ground, each turned to the nearest axis; left = up × forward;
///  - along each leg, the two consecutive bones with the largest summed length pointing
///    down are the thigh and the shank: their joints are the hip (base position), the knee
///    and the ankle;
///  - the arms are the branches of the spine holding its leftmost and rightmost joints;
///    their nearest common joint is the chest (the trunk's orientation, its bone towards the
///    neck); along each arm (to a fingertip), the forearm is the last bone at least half
///    as long as the arm's longest (hands and fingers have short bones), the upper arm the
///    one before: the elbow and the wrist are the forearm's joints;
///  - units: of metres, centimetres, millimetres, inches and the CMU database's unit, the
///    one that makes thigh and shank closest to 0.85 m.
///
/// The model, at its neutral configuration:
///  - the legs and arms of jointGroupsOf; a leg ends in the body it stands on there (the
///    foot), an arm in the deepest body of its chain (following the heaviest branch);
///    limbs it stands on that hang from more than a tenth of their length above the
///    trunk's origin are arms (an upper body standing on its hands), and it is refused;
///  - forward is where the knees do not bend the feet: each knee is bent 0.3 rad into the
///    side of its range with at least twice the room, and the feet move backwards. A
///    model whose base frame faces −x (iCub) keeps its left leg left; `bvh_forward` turns
///    the capture's forward onto that direction. Knees with no such side: the base's +x;
///  - from the limb's root, the first run of two or more joints whose axes meet (within
///    2 cm) is the hip (shoulder), where they meet its pivot; the first joint after it whose
///    axis does not pass through the pivot is the knee (elbow);
///  - the wrist is the last joint of the first run of joints more than 5 cm past the
///    elbow each within 5 cm of the one before (a hand's fingers further on are not part
///    of it);
///  - the trunk is chooseTrunkBody's, its bone the world's up in its frame; the base
///    position point is the midpoint of the hips' pivots (where their axes meet).
/// Joints between no two mapped links (head, fingers, grippers) are held at their neutral
/// value (`allow_unmapped: true`, listed in a comment).

#include <string>
#include <vector>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/io/bvh.hpp"

namespace dynfilter::io {

struct MappingSuggestion {
  std::string yaml;                ///< an IK-mode mapping (parseRetargetMapping reads it), commented
  std::vector<std::string> notes;  ///< guesses made and what could not be matched
};

/// Suggests a mapping of @p bvh onto @p model (see the file comment). @p bvh read with
/// length_scale 1 (the file's own units). @p bvh_skipped_frames: leading frames a
/// T-pose detection dropped (BvhMotion::skipped_frames with detect_t_pose), kept as
/// skip_frames. Changes the model's state.
/// @throws InputError (bvh.source, line 0) when the BVH has no pelvis with a spine and two
///         legs or no two arms; std::invalid_argument when the model is not a floating-base
///         model standing on two legs.
MappingSuggestion suggestMapping(const BvhMotion& bvh, IDynamicsModel& model, int bvh_skipped_frames = 0);

}  // namespace dynfilter::io
