#pragma once
/// @file
/// Contacts as the paper's virtual links (Sect. 3.1): each joins a robot body to the
/// environment through a 6-DoF joint of which some axes are constrained.
///
/// Frames: C is fixed on the body (origin at the contact, z along the surface normal at
/// creation); A is the anchor, fixed in the world on the environment surface where the
/// link was created (z = surface normal). The virtual joint's coordinates are the pose of
/// C relative to A, e = [R_WAᵀ (p_WC − p_WA); log(R_WAᵀ R_WC)], and its velocity is the
/// body's point velocity rotated into A. Constrained rows of that velocity form H_C.
///
/// Kinds, chosen from the geometry of the collision points of one body–object pair:
/// one point → kPoint (3 translations); points on a line → kEdge (all but the rotation
/// about the edge, which is A's x axis); a polygon → kFace (all 6 axes).
///
/// A link persists while held (collision points at a surface flicker; the constraint does
/// not). It is released when its normal force stays below ContactOptions::release_force_n
/// for release_ticks ticks; the pair then stays free until it penetrates again by
/// reengage_depth_m. More collision points on a held pair upgrade the link (point → edge
/// → face) with a new anchor.

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynfilter/core/body_set.hpp"
#include "dynfilter/core/contact.hpp"
#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/filter_options.hpp"
#include "dynfilter/core/filter_output.hpp"

namespace dynfilter {

/// A link's sole turning about its normal faster than this (rad/s) is sliding, not held.
constexpr double kPivotRestRate = 1e-4;

struct VirtualLink {
  int body = -1;
  int object = kGroundObject;
  ContactKind kind = ContactKind::kPoint;
  Eigen::Isometry3d X_BC = Eigen::Isometry3d::Identity();  ///< contact frame on the body
  Eigen::Isometry3d X_WA = Eigen::Isometry3d::Identity();  ///< anchor in world
  int num_axes = 3;
  std::array<int, 6> axes{};  ///< constrained axes of [x, y, z, rx, ry, rz] in A
  /// Support rectangle of the link in A's xy, relative to A's origin (m): the extent of
  /// the collision points at creation (zero for a point, along x only for an edge).
  Eigen::Vector2d support_min = Eigen::Vector2d::Zero();
  Eigen::Vector2d support_max = Eigen::Vector2d::Zero();
  int low_force_ticks = 0;
  bool created_this_tick = false;
  double normal_force_n = 0.0;  ///< normal force of the last solve (N)
  /// QP mode release ramp: started when the reference lifts the contact point off.
  bool releasing = false;
  /// The reference's contact schedule says this body is in stance (QP mode with the
  /// balance layer): a low normal force alone does not release the link then.
  bool reference_stance = false;
  /// The reference has had this body in stance while the link was held: only such a link
  /// unloads by the release ramp when the reference lifts it; a touch out of stance (a
  /// scuff) holds what it must and lets go when its force falls to the minimum.
  bool stance_seen = false;
  double release_elapsed_s = 0.0;
  double release_start_force_n = 0.0;
  /// The sole rolls with the reference (heel-off): no upgrade to a face while set.
  bool rolling = false;
  /// Edges, faces: the twist about A's z of the last solve (N m).
  double torsion_n_m = 0.0;
  /// Edges, faces (QP mode): the link pivots about A's z. 0: the yaw row holds (sticks);
  /// ±1: the sign of the twist m_z = ±μ r f_z friction gives while the body turns the
  /// other way. Set by the solve; kept while the pivot goes on; the anchor's yaw follows.
  int yaw_slip = 0;
  /// QP mode (QpModeOptions::tangential_slip): the unit direction, in A's xy, in which the
  /// contact point slides along the surface; zero while the link sticks. While it slides
  /// the anchor's origin follows the point, and the tangential rows give way to Coulomb's
  /// kinetic friction against ŝ.
  Eigen::Vector2d slide_A = Eigen::Vector2d::Zero();
};

/// Indices of the constrained axes of a link kind, in A's [x, y, z, rx, ry, rz].
int constrainedAxes(ContactKind kind, std::array<int, 6>& axes);

class VirtualLinkSet {
 public:
  /// @param max_links capacity; nothing allocates after construction.
  VirtualLinkSet(const ContactOptions& options, int nv);

  /// Creates, keeps or upgrades links from the collision candidates of the model's
  /// current state. Returns the number of links created or upgraded this tick (they
  /// need a plastic impact). Sets kStatusContactOverflow in @p status when full.
  int update(const IDynamicsModel& model, const ContactList& candidates, std::uint32_t& status);

  /// Forgets every link and released pair.
  void clear();

  /// Moves every held link's anchor to where its contact frame is at the model's current
  /// state (zero link error): used when the state is measured on a robot, whose own
  /// contact physics, not the filter's stabilisation, decides where the contact is.
  void reanchor(const IDynamicsModel& model);

  /// Releases every held link (the contacts broke): the pairs re-engage only when they
  /// penetrate again by reengage_depth_m.
  void releaseAll();

  int size() const { return size_; }
  const VirtualLink& operator[](int i) const { return links_[static_cast<std::size_t>(i)]; }

  /// Turns link @p i into a face link: frame @p X_BC on its body (z out of the body's
  /// surface), anchor @p X_WA on the environment's surface, support rectangle
  /// [@p support_min, @p support_max] in the link frame's xy (m). The difference between
  /// X_WB X_BC and X_WA is the link error its stabilisation removes. Marks it created.
  void makeFace(int i, const Eigen::Isometry3d& X_BC, const Eigen::Isometry3d& X_WA,
                const Eigen::Vector2d& support_min, const Eigen::Vector2d& support_max);
  /// Turns link @p i into an edge link along the x axis of @p X_BC / @p X_WA (as makeFace),
  /// its support [@p x_min, @p x_max] along that edge (m), and marks it rolling: a sole
  /// that hinges on that edge. Marks it created.
  void makeRollingEdge(int i, const Eigen::Isometry3d& X_BC, const Eigen::Isometry3d& X_WA, double x_min,
                       double x_max);
  /// Sets or clears link @p i's rolling flag (VirtualLink::rolling).
  void setRolling(int i, bool rolling) { links_[static_cast<std::size_t>(i)].rolling = rolling; }
  /// Sets link @p i's pivot (VirtualLink::yaw_slip: −1, 0 or +1).
  void setYawSlip(int i, int sign) { links_[static_cast<std::size_t>(i)].yaw_slip = sign; }
  /// Total constrained rows N_C.
  int numRows() const;

  /// Lets links slide along the surface (QpModeOptions::tangential_slip; assemble()
  /// decides per link and tick).
  void enableSliding(bool enabled) { sliding_enabled_ = enabled; }

  /// Whether a held link slides (set by the last assemble()).
  bool anySliding() const;
  /// Link @p i sticks from now on (its anchor stays where assemble() last put it).
  void stopSlide(int i) { links_[static_cast<std::size_t>(i)].slide_A.setZero(); }

  /// Copies the rows of @p H_C that a plastic impact stops into the top of @p H_out (a
  /// sliding link's tangential rows are not among them) and returns their number.
  int impactRows(const Eigen::Ref<const Eigen::MatrixXd>& H_C, Eigen::Ref<Eigen::MatrixXd> H_out) const;

  /// Fills the rows of Eq. 9 with Baumgarte stabilisation:
  /// H_C (N_C × nv) and u_C = θ̈_C,desired − Ḣ_C v (N_C), with θ̈_C,desired = −kd θ̇_C − kp e.
  /// A pivoting link (yaw_slip ≠ 0) first moves its anchor's yaw to its body's, and keeps
  /// pivoting only while its body still turns against the twist (else it sticks again).
  /// With sliding enabled, a link of a body out of the reference's stance slides while its
  /// contact point moves along the surface faster than 1 cm/s; in the reference's stance a
  /// slide goes on until the point is slower than 5 cm/s, and none starts. A sliding link's
  /// tangential rows carry no stabilisation (θ̈_C,desired = 0) and its anchor follows the
  /// point.
  /// @param H_C, u_C at least numRows() rows; only the top numRows() are written.
  void assemble(const IDynamicsModel& model, Eigen::Ref<Eigen::MatrixXd> H_C,
                Eigen::Ref<Eigen::VectorXd> u_C);

  /// QP mode: with @p model posed at the reference state, starts the release ramp of every
  /// held link whose contact point there lies more than @p clearance_m above its anchor
  /// (along the anchor's normal). Returns the number of ramps started. A pair released
  /// while the reference lifts it does not re-engage (even when it penetrates) until the
  /// reference brings that point back within clearance_m / 2 of where it was held.
  int startLiftoffReleases(const IDynamicsModel& model, double clearance_m);

  /// The reference's contact schedule (QP mode with the balance layer), the bodies the
  /// reference has in stance: held links of bodies out of stance start their release ramp
  /// (and may slide, see assemble()); links in stance are not released for a low force
  /// alone; a released pair whose body the reference holds out of stance does not
  /// re-engage on penetration.
  /// Replaces startLiftoffReleases.
  void applyReferenceSchedule(const BodySet& stance_bodies);

  /// Upper bound on link @p i's normal force this tick: +∞, or during a release ramp the
  /// force at the ramp's start decreasing linearly to @p min_force_n over @p transition_s.
  double normalForceUpperBound(int i, double min_force_n, double transition_s) const;

  /// After a solve: converts τ_C (N_C, in anchor axes) to per-link outputs, counts low
  /// normal force (< @p low_force_n) and releases links that stayed low for release_ticks
  /// ticks or whose release ramp (advanced by @p dt_s) has run @p transition_s.
  /// @param contacts capacity ≥ size(); returns the number written.
  int finishTick(const IDynamicsModel& model, const Eigen::Ref<const Eigen::VectorXd>& tau_C,
                 std::vector<ContactOutput>& contacts, bool allow_release, double low_force_n,
                 double dt_s, double transition_s);

 private:
  struct ReleasedPair {
    int body;
    int object;
    // Where the link was (for the reference's clearance) and whether the reference still
    // holds that contact point lifted: then the pair does not re-engage on penetration.
    Eigen::Isometry3d X_BC = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d X_WA = Eigen::Isometry3d::Identity();
    bool reference_lifted = false;
  };
  int findLink(int body, int object) const;
  bool isReleased(int body, int object) const;
  // The last applied schedule has @p body in stance (none before one is applied).
  bool inReferenceStance(int body) const {
    return schedule_applied_ && holds(stance_bodies_, body);
  }
  // Sets link.slide_A from the contact point p_WC, its velocity v_WC and the schedule, and
  // moves a sliding (or stopping) link's anchor origin to the point.
  void decideSlide(VirtualLink& link, const Eigen::Vector3d& p_WC, const Eigen::Vector3d& v_WC) const;
  bool makeLink(const IDynamicsModel& model, const ContactList& candidates, int body, int object,
                VirtualLink& link) const;

  ContactOptions options_;
  std::vector<VirtualLink> links_;
  int size_ = 0;
  std::vector<ReleasedPair> released_;
  int num_released_ = 0;
  std::vector<char> grouped_;  // per candidate, scratch
  bool sliding_enabled_ = false;
  bool schedule_applied_ = false;   // applyReferenceSchedule has run: stance_bodies_ holds
  BodySet stance_bodies_;
  Matrix6Xd J_;                // 6 × nv scratch
};

}  // namespace dynfilter
