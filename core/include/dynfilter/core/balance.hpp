#pragma once
/// @file
/// The balance layer (QP mode, beyond the paper): keeps the whole-body motion balanced by
/// giving the whole-body QP centroidal tasks weighted above the joint tracking of Eq. 17.
///
/// - Centre of mass c, its velocity and the centroidal angular momentum L come from the
///   joint-space mass matrix (free-flyer convention: A's first six rows are the spatial
///   momentum at the base origin in base axes), so every backend gives them.
/// - The reference's future (preview samples pushed ahead of the ticks) gives a feasible
///   divergent component of motion ξ_d = c + ċ/ω (capture point, ω = √(g/h)): the
///   reference's centre of pressure (LIPM: p = c − h c̈/(g + z̈)) is clamped into the
///   reference's own support (body points within stance_height of the ground and slow),
///   then ξ is integrated backwards from the end of the window, ξ_k = p_k +
///   e^{−ω Δt}(ξ_{k+1} − p_k).
/// - DCM feedback: the CoP command p = p_d + (1 + k)(ξ − ξ_d), clamped into the filter's
///   own support (its held virtual links), gives the desired CoM acceleration
///   c̈_xy = ω² (c − p); height by PD on the reference's CoM height.
/// - Tasks for the QP, rows on x = (v̇, τ_C): the CoM acceleration m c̈ = Σ f + m g written
///   on the contact forces (exact: the base rows of Eq. 12 are Newton's law), optionally
///   L̇ = −k L, and soles kept flat on the ground while their body is in contact (a
///   rolling sole turns as the reference's does, with its angular velocity and acceleration
///   fed forward, so that the rows do not brake a push-off).
/// - It also judges whether the reference can be followed at all: a reference that needs
///   a supporting force and has no support (hanging in the air), or whose needed force
///   lies outside the friction cone of its support (a 40° slope), is reported.
/// Nothing allocates after construction.

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "dynfilter/core/body_set.hpp"
#include "dynfilter/core/contact_qp.hpp"
#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/filter_options.hpp"
#include "dynfilter/core/reference_frame.hpp"
#include "dynfilter/core/virtual_links.hpp"

namespace dynfilter {

/// Centroidal quantities of a floating-base model at (q, v).
struct CentroidalState {
  Eigen::Vector3d c_W = Eigen::Vector3d::Zero();     ///< centre of mass, world (m)
  Eigen::Vector3d cdot_W = Eigen::Vector3d::Zero();  ///< its velocity, world (m/s)
  Eigen::Vector3d L_W = Eigen::Vector3d::Zero();     ///< angular momentum about c, world axes (kg m²/s)
};

/// From the mass matrix @p A (nv × nv) at @p q (nq), @p v (nv) of a floating-base model of
/// total mass @p mass_kg (free-flyer convention, model_info.hpp).
CentroidalState centroidalState(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                const Eigen::Ref<const Eigen::VectorXd>& q,
                                const Eigen::Ref<const Eigen::VectorXd>& v, double mass_kg);

/// Why the reference cannot be followed (with kStatusReferenceInfeasible).
enum class InfeasibleReason : int {
  kNone = 0,
  kNoSupport = 1,    ///< it needs a supporting force and no body of it is near the ground
  kOutsideCone = 2,  ///< the force it needs lies outside the friction cone of its support
};
/// "reference needs support it does not have (hanging in the air)", ...; static string.
const char* toString(InfeasibleReason reason);

/// What the balance layer computed this tick (for outputs and tests).
struct BalanceState {
  bool active = false;                             ///< tasks were given to the QP
  CentroidalState filter;                          ///< at the filter's state
  CentroidalState reference;                       ///< at the reference
  Eigen::Vector2d dcm = Eigen::Vector2d::Zero();   ///< ξ of the filter (m)
  Eigen::Vector2d dcm_desired = Eigen::Vector2d::Zero();  ///< ξ_d (m)
  Eigen::Vector2d cop_command = Eigen::Vector2d::Zero();  ///< p, in the support (m)
  Eigen::Vector3d com_accel_desired = Eigen::Vector3d::Zero();  ///< c̈_d (m/s²)
  int preview_samples = 0;                         ///< future samples used
  InfeasibleReason infeasible = InfeasibleReason::kNone;
};

class BalanceLayer {
 public:
  /// Throws std::invalid_argument on a fixed-base model or a sole body that is not a link
  /// of the model. Without BalanceOptions::soles, the soles are the bodies the model
  /// stands on in its neutral configuration (found with @p model's collision engine: the
  /// bodies within 1 cm of the lowest contact point), their normal the ground's there.
  BalanceLayer(IDynamicsModel& model, const BalanceOptions& options);

  /// Rows the layer may write into a QpObjectiveTasks.
  int maxTaskRows() const { return 6 + 6 * static_cast<int>(soles_.size()); }

  /// Adds a reference frame of the future (time after the previous one's; otherwise the
  /// preview restarts from it). Poses @p model at the frame. Returns false when the frame
  /// is not valid for the model (nothing kept). No allocation.
  bool pushPreview(IDynamicsModel& model, const ReferenceFrame& frame);
  void clearPreview() { size_ = 0; }
  /// Moves the preview by the rigid motion @p X_WW' (world; the reference leash): CoM,
  /// its velocity, angular momentum and support polygons (their points taken on the ground
  /// of the last prepare(), z = 0 before one). No allocation.
  void transformPreview(const Eigen::Isometry3d& X_WW);
  int previewSize() const { return size_; }

  /// Start of a tick, with @p model posed at @p reference: the reference's centroidal
  /// sample (from the preview when it brackets the time, else from @p model), the DCM
  /// target over the preview window, and the feasibility judgement. @p dt_s: the tick.
  void prepare(IDynamicsModel& model, const ReferenceFrame& reference, double dt_s);

  /// The QP's tasks at the filter's state: @p model posed there, @p A its mass matrix,
  /// @p links the held links in the order of τ_C. Writes @p tasks (rows = 0 when inactive).
  void buildTasks(const IDynamicsModel& model, const Eigen::Ref<const Eigen::MatrixXd>& A,
                  const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
                  const VirtualLinkSet& links, QpObjectiveTasks& tasks);

  /// Soles come down flat: for every sole body that holds a point or edge link, its
  /// collision points within BalanceOptions::sole_margin_m of the surface are added to
  /// @p candidates (depth 0), so that the link upgrades to a face once the sole is nearly
  /// flat (points exactly at the surface are not reported by collision engines). Poses
  /// @p model at the lowered state and back at (q, v).
  void addSoleCandidates(IDynamicsModel& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                         const Eigen::Ref<const Eigen::VectorXd>& v, const VirtualLinkSet& links,
                         ContactList& candidates);

  /// Flat landing: every sole body holding a point or edge link on the ground plane, tilted
  /// from the surface by at most BalanceOptions::flat_landing_max_tilt_rad, holds a face
  /// link over its whole sole instead (its footprint at the neutral configuration),
  /// anchored flat on the surface so that the touching point stays where it is, once the
  /// reference (at the last prepare()) has that sole within 0.1 rad of the surface. The
  /// link's stabilisation brings the sole down. Not for a sole whose leg has fewer than six
  /// joints (no ankle roll): it cannot lay its sole flat wherever it lands, and the face
  /// link's rows would ask the rest of the body to. Returns the links changed. No allocation.
  int flattenLandings(const IDynamicsModel& model, VirtualLinkSet& links) const;

  /// Rolling soles (BalanceOptions::roll_tilt_rad): where the reference (at the last
  /// prepare()) has a sole on its toes — tilted from its surface by more than roll_tilt_rad,
  /// its normal leaning towards its toes (SoleFootprint::X_BS's x) — and its preview lifts
  /// that sole within 0.25 s (heel-off, push-off), the sole's held face link becomes an edge
  /// link on the rectangle's side at the toes, so that the sole can hinge there, and its links
  /// are marked rolling (no upgrade to a face) until the reference's sole is within half
  /// that tilt or the rest of the sole sinks 2 mm into the surface (it has landed).
  /// Returns the links changed. No allocation.
  int rollSoles(VirtualLinkSet& links) const;

  const BalanceState& state() const { return state_; }
  /// The reference's contact schedule at the last prepare(): the bodies the reference has
  /// within stance_height_m of the environment and slower than stance_speed_mps.
  const BodySet& referenceStance() const { return now_.stance; }
  /// The bodies whose held links the contact schedule keeps (VirtualLinkSet::
  /// applyReferenceSchedule): referenceStance(); or, while the reference has no body in
  /// stance but its centre of mass needs a supporting force (c̈_z + g > 0.3 g: a foot
  /// rolling on its edge or gliding, not a flight), every body — the figure keeps the
  /// contacts it holds instead of letting go of the ground.
  BodySet heldStance() const {
    return now_.stance.none() && needs_support_ ? BodySet().set() : now_.stance;
  }
  /// Bodies kept flat on the ground while in contact (body indices).
  const std::vector<int>& soleBodies() const { return sole_bodies_; }

  /// A sole's face in its body frame, found once from the neutral configuration standing on
  /// the ground and sunk 2.5 mm into it: the sole's collision points lowest along its normal
  /// (within 2 mm); the flat landing holds its face link there.
  struct SoleFootprint {
    /// Frame S in the body: z out of the sole, x towards the toes (along the face's longer
    /// side, away from the body's origin, the ankle; the body's x when the ankle stands within
    /// 5 % of the sole's length of its middle), origin at the face's centroid.
    Eigen::Isometry3d X_BS = Eigen::Isometry3d::Identity();
    Eigen::Vector2d min = Eigen::Vector2d::Zero();  ///< the face's extent in S's x and y (m)
    Eigen::Vector2d max = Eigen::Vector2d::Zero();
    bool valid = false;  ///< a face at least 1 cm wide each way (not a point or an edge)
  };
  /// One per soleBodies() entry.
  const std::vector<SoleFootprint>& soleFootprints() const { return footprints_; }

 private:
  static constexpr int kMaxSupport = 24;  // hull vertices of one support polygon
  BodySet lifting_soon_;  // bodies in stance now that the preview lifts within 0.25 s
  struct Sample {
    double t = 0.0;
    Eigen::Vector3d c = Eigen::Vector3d::Zero(), cdot = Eigen::Vector3d::Zero();
    Eigen::Vector3d L = Eigen::Vector3d::Zero();  // angular momentum about c, world axes
    int num_support = 0;
    std::array<Eigen::Vector2d, kMaxSupport> support;  // convex hull, counter-clockwise
    BodySet stance;  // bodies in stance
    // The CoP excess of the segment ending here (prepare's backward pass), and the times of
    // the samples it was computed from (before, segment start, after; NaN: not computed).
    // The excess is a function of those samples alone, so it is reused while they stay.
    Eigen::Vector2d excess = Eigen::Vector2d::Zero();
    std::array<double, 3> excess_key{{std::numeric_limits<double>::quiet_NaN(),
                                      std::numeric_limits<double>::quiet_NaN(),
                                      std::numeric_limits<double>::quiet_NaN()}};
  };
  struct SoleReference {  // a sole's pose and motion in the reference at this tick
    Eigen::Vector3d p = Eigen::Vector3d::Zero(), pdot = Eigen::Vector3d::Zero(), pddot = Eigen::Vector3d::Zero();
    Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
    Eigen::Vector3d omega = Eigen::Vector3d::Zero(), omegadot = Eigen::Vector3d::Zero();
    double clearance_m = 1e9;  // height of its lowest point above the environment (≤ stance height)
  };
  void makeSample(IDynamicsModel& model, const ReferenceFrame& frame, Sample& out);
  int swingSoleRows(const IDynamicsModel& model, const Eigen::Ref<const Eigen::VectorXd>& v,
                    std::size_t s, int rows, QpObjectiveTasks& tasks);
  const Sample& at(int i) const;  // 0 = oldest
  std::size_t ringIndex(int i) const;  // ring_ slot of at(i)
  double groundHeight(const Eigen::Vector2d& p_xy) const;
  // Reference CoP over [a, b] of the wrench it needs (force m (c̈ + g), moment L̇ about c),
  // clamped into a's support; c̈ and L̇ are the changes from `before` to `after`, samples
  // about kAccelHalfWindowS around the segment (captured motion's second derivative is
  // noisy). excess (optional): the clamped CoP minus the unclamped one.
  Eigen::Vector2d segmentCop(const Sample& before, const Sample& a, const Sample& b, const Sample& after,
                             Eigen::Vector3d* cddot, Eigen::Vector2d* excess = nullptr) const;
  // The latest preview sample at or before time t, from i backwards (at most i); the
  // earliest at or after t, from i forwards.
  int sampleBefore(int i, double t) const;
  int sampleAfter(int i, double t) const;
  static constexpr double kAccelHalfWindowS = 0.04;

  BalanceOptions options_;
  const ModelInfo& info_;
  double mass_kg_ = 0.0;
  const Environment* environment_ = nullptr;  // the model's, from the last prepare()
  std::vector<int> sole_bodies_;
  std::vector<char> sole_free_;  // per sole: KinematicTree::posesFreely
  std::vector<SoleOptions> soles_;
  std::vector<SoleReference> sole_refs_;
  std::vector<SoleFootprint> footprints_;
  std::vector<Sample> ring_;
  int head_ = 0, size_ = 0;
  struct CachedGround {  // the ground the samples' cached excesses were computed on
    bool has_ground = false;
    Eigen::Vector3d n_W = Eigen::Vector3d::Zero();
    double offset_m = 0.0;
  } cached_ground_;
  Sample now_;                  // the reference at this tick
  Eigen::Vector2d dcm_target_ = Eigen::Vector2d::Zero(), cop_target_ = Eigen::Vector2d::Zero();
  Eigen::Vector3d cddot_ref_ = Eigen::Vector3d::Zero();
  double omega_ = 3.0;
  double infeasible_s_ = 0.0;   // time the reference has looked infeasible
  bool needs_support_ = false;  // the reference's CoM needs a supporting force now
  InfeasibleReason pending_ = InfeasibleReason::kNone;
  BalanceState state_;
  // Scratch.
  Eigen::MatrixXd A_;
  Matrix6Xd J_;
  ContactList candidates_;
  Eigen::VectorXd q_lowered_;
  std::array<Eigen::Vector2d, 64> points_;
};

}  // namespace dynfilter
