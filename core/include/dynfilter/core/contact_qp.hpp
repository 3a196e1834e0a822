#pragma once
/// @file
/// The QP mode's solve of Eq. 12 (beyond the paper): the paper's objective and equality
/// rows, plus the inequalities of physical contact and of the robot's limits.
///
/// Unknowns x = (v̇ (nv), τ_C (N_C, the virtual links' wrench rows in anchor axes)); the
/// joint torques are eliminated, τ_J = M x + b_J with M = [A_J, −H_C,Jᵀ] (the joint rows
/// of Eq. 12), so the joint rows hold exactly by construction.
///
///   minimise   ½ w_a ‖v̇ − v̇ᵈ‖² + ½ w_f ‖τ_C‖² + ½ w_τ ‖τ_J‖²
///   subject to A_b v̇ − H_C,bᵀ τ_C = −b_b          (base rows of Eq. 12, nb)
///              H_C v̇ = u_C                         (contact acceleration rows, N_C)
///              f_z ≥ f_min, f_z ≤ ramp bound      (unilateral; release ramp, per link)
///              f_z ≥ f_z,prev − rate dt           (no jerk: unloading rate, held links)
///              d_kᵀ f_t ≤ μ cos(π/K) f_z, k < K   (inscribed friction pyramid, per link)
///              CoP of faces and edges inside the support rectangle (minus a margin)
///              |m_z| ≤ μ r f_z                    (edges, faces: torsion; r = the farthest
///                                                  support point's distance from the origin)
///              a pivoting edge or face (VirtualLink::yaw_slip = σ ≠ 0; QpModeOptions::yaw_slip)
///              drops its yaw row for m_z = σ μ r f_z (Coulomb's twist while it turns)
///              a sliding link (VirtualLink::slide_A = ŝ ≠ 0; QpModeOptions::tangential_slip)
///              drops its tangential rows and its pyramid for f_t = −μ f_z ŝ
///              |τ_J| ≤ τ_max                      (URDF effort)
///              v̇_J within the bounds that keep q and q̇ in their limits over the tick
///
/// When that QP fails, edges and faces start to pivot (one re-solve): a link already turning
/// with σ against its turn; one at rest whose last twist sat at the bound with σ that
/// twist's sign, turning only against it, σ (H_yaw v̇ − u_yaw) ≤ 0. If that fails too they
/// hold again, and the QP is relaxed (ContactQpReport): at most four solves a tick, each
/// capped at QpSolverSettings::max_iterations; the caller falls back to the paper solve
/// only when even the last relaxation fails.
///
/// Problem sizes are fixed per size class (force capacity 12, 24, 6·max_links: two flat
/// feet need no padding); each class has its own solver instance, warm-started from its
/// previous solution. Nothing allocates per tick.

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "dynfilter/core/environment.hpp"
#include "dynfilter/core/filter_options.hpp"
#include "dynfilter/core/model_info.hpp"
#include "dynfilter/core/qp_solver.hpp"
#include "dynfilter/core/virtual_links.hpp"

namespace dynfilter {

/// Constraint families of the QP, as bits (reported when one is violated).
enum QpConstraintFamily : std::uint32_t {
  kQpFamilyNone = 0,
  kQpFamilyEquality = 1u << 0,    ///< base or contact rows of Eq. 12
  kQpFamilyUnilateral = 1u << 1,  ///< normal force below the minimum (or above the ramp)
  kQpFamilyFriction = 1u << 2,    ///< tangential force outside the friction pyramid
  kQpFamilyCop = 1u << 3,         ///< centre of pressure outside the support
  kQpFamilyTorque = 1u << 4,      ///< joint torque beyond its limit
  kQpFamilyJointLimit = 1u << 5,  ///< joint acceleration beyond the position/velocity bounds
};

/// Writes the names of the set bits of @p families, comma-separated ("unilateral,torque"),
/// into @p buffer (NUL-terminated, truncated to @p size); returns @p buffer.
const char* describeQpFamilies(std::uint32_t families, char* buffer, int size);

/// What one QP solve did.
struct ContactQpReport {
  QpSolveInfo info;
  std::uint32_t violated = kQpFamilyNone;  ///< families violated by the returned x
  int force_capacity = 0;                  ///< size class used
  double solver_time_s = 0.0;              ///< time inside the QP engine (all attempts)
  bool ok = false;                         ///< solved and every family satisfied
  /// Relaxations, tried in this order while the QP fails (the second keeps the first):
  /// 1. in one re-solve, the joint-limit acceleration bounds (a joint at its stop gets the
  ///    stop's torque) and the normal forces' rate bounds (release ramps, unloading rate),
  ///    each flag set when the problem had such bounds;
  bool joint_limits_dropped = false;
  bool ramps_dropped = false;
  /// 2. the links give way as a rigid floor does, each rung keeping the one before; the
  ///    last rung used (0 none): 1 the rows that depend on others are freed, 2 every edge
  ///    and face tips (its moments free; it holds as a point at its origin), 3 every link
  ///    is a frictionless point. The normal rows hold; rowFree() names the rows given up.
  int floor_rung = 0;
  /// 3. every virtual link released (the contacts break): the caller must release them.
  bool contacts_released = false;
  std::uint32_t violated_first = kQpFamilyNone;  ///< families the first (full) attempt violated
};

/// Weighted objective rows beyond the paper's (the balance layer's tasks, balance.hpp):
/// the QP adds ½ Σ_i w_i (T_i x − r_i)² over the first `rows` rows, x = (v̇, τ_C).
/// Columns past nv + N_C of T are ignored. Sized once (capacity rows × (nv + 6·max_links)).
struct QpObjectiveTasks {
  Eigen::MatrixXd T;  ///< capacity × (nv + 6·max_links)
  Eigen::VectorXd r;  ///< capacity
  Eigen::VectorXd w;  ///< capacity, ≥ 0
  int rows = 0;       ///< rows in use this tick

  QpObjectiveTasks() = default;
  QpObjectiveTasks(int capacity, int columns)
      : T(Eigen::MatrixXd::Zero(capacity, columns)),
        r(Eigen::VectorXd::Zero(capacity)),
        w(Eigen::VectorXd::Zero(capacity)) {}
};

class ContactQp {
 public:
  /// Makes one solver per size class with @p factory. Throws std::invalid_argument when
  /// the factory is empty, and whatever the factory throws.
  ContactQp(const ModelInfo& info, int max_links, double dt_s, const QpModeOptions& options,
            const QpSolverFactory& factory);
  ~ContactQp();
  ContactQp(const ContactQp&) = delete;
  ContactQp& operator=(const ContactQp&) = delete;

  /// Solves the QP above for the links of @p links (their rows in the order of H_C).
  /// @param A nv × nv, @param b nv, @param H_C N_C × nv, @param u_C N_C, @param q nq,
  /// @param v nv (the state the rows were built at), @param vdot_desired nv.
  /// Writes vdot (nv), tau_C (N_C), tau_J (nj) from the solver's x even when !ok.
  ContactQpReport solve(const Eigen::Ref<const Eigen::MatrixXd>& A,
                        const Eigen::Ref<const Eigen::VectorXd>& b,
                        const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                        const Eigen::Ref<const Eigen::VectorXd>& u_C, const VirtualLinkSet& links,
                        const Environment& environment, const Eigen::Ref<const Eigen::VectorXd>& q,
                        const Eigen::Ref<const Eigen::VectorXd>& v,
                        const Eigen::Ref<const Eigen::VectorXd>& vdot_desired,
                        Eigen::Ref<Eigen::VectorXd> vdot, Eigen::Ref<Eigen::VectorXd> tau_C,
                        Eigen::Ref<Eigen::VectorXd> tau_J);

  /// The next solves add these rows to the objective (nullptr: none). Not owned; must
  /// outlive the solves that use it.
  void setObjectiveTasks(const QpObjectiveTasks* tasks) {
    tasks_ = tasks;
    if (tasks != nullptr) weighted_tasks_.resize(tasks->T.rows(), tasks->T.cols());
  }

  /// Checks a candidate (v̇, τ_C, τ_J) against Eq. 12 and the bounds built by the last
  /// solve() (the QP's own answer, or a fallback's). Returns the violated families' bits.
  std::uint32_t check(const Eigen::Ref<const Eigen::MatrixXd>& A,
                      const Eigen::Ref<const Eigen::VectorXd>& b,
                      const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                      const Eigen::Ref<const Eigen::VectorXd>& u_C,
                      const Eigen::Ref<const Eigen::VectorXd>& vdot,
                      const Eigen::Ref<const Eigen::VectorXd>& tau_C,
                      const Eigen::Ref<const Eigen::VectorXd>& tau_J) const;

  /// Link @p i's pivot in the last solve's answer: 0 (its yaw row held) or the sign σ of
  /// its twist m_z = σ μ r f_z (VirtualLink::yaw_slip).
  int yawSlip(int i) const { return i < num_links_ ? link_bounds_[static_cast<std::size_t>(i)].yaw_slip : 0; }

  /// Row @p r of H_C (the last solve's numbering) holds no equality in the answer: a
  /// pivoting link's yaw, a sliding link's tangents, or a row a relaxation freed.
  bool rowFree(int r) const;

  /// Joint acceleration bounds of the last solve (dim nj; ±kQpInfinity when unbounded).
  const Eigen::VectorXd& jointAccelLower() const { return accel_lo_; }
  const Eigen::VectorXd& jointAccelUpper() const { return accel_hi_; }

 private:
  struct SizeClass;
  // Solves sc.qp into sc.x; bounds_only: only the bounds changed since the last solve.
  QpSolveInfo timedSolve(SizeClass& sc, ContactQpReport& report, bool bounds_only);
  void buildJointBounds(const Eigen::Ref<const Eigen::VectorXd>& q,
                        const Eigen::Ref<const Eigen::VectorXd>& v);

  // Adds the objective tasks' rows to H and g (balance layer; not part of the paper's QP).
  void addObjectiveTasks(DenseQp& qp, int nc);

  QpModeOptions options_;
  const QpObjectiveTasks* tasks_ = nullptr;
  double dt_s_;
  int nv_, nb_, nj_, max_links_;
  std::vector<std::unique_ptr<SizeClass>> classes_;
  Eigen::VectorXd accel_lo_, accel_hi_;  // nj
  Eigen::VectorXd q_lower_, q_upper_, v_max_, tau_max_;  // nj, from ModelInfo
  Eigen::VectorXd facet_cos_, facet_sin_;               // friction pyramid directions
  Eigen::MatrixXd M_;                    // nj × (nv + capacity)
  mutable Eigen::VectorXd residual_;     // nv scratch of check()
  Eigen::MatrixXd weighted_tasks_;       // diag(w) T of the objective tasks (their T's size)
  // Per-link bounds of the last solve, for check().
  struct LinkBounds {
    int row = 0;        // first τ_C row of the link
    int num_axes = 3;   // 3 (point), 5 (edge), 6 (face)
    double mu = 0.0;
    double f_min = 0.0, f_max = 0.0;
    Eigen::Vector2d cop_min = Eigen::Vector2d::Zero(), cop_max = Eigen::Vector2d::Zero();
    double torsion_arm_m = 0.0;  // edges, faces: |m_z| ≤ μ · this · f_z
    int torsion_row = 0;         // first of the two torsion rows in C
    int yaw_slip = 0;            // pivoting: m_z = yaw_slip · μ r f_z, the yaw row dropped
    bool pivot_from_rest = false;  // ... and the yaw acceleration opposes the twist
    int facet_row = 0;           // first friction-pyramid row in C
    Eigen::Vector2d slide = Eigen::Vector2d::Zero();  // sliding: f_t = −μ f_z ŝ (VirtualLink::slide_A)
    bool rotations_free = false;  // relaxed: its moments are zero, it holds as a point
    bool tangents_free = false;   // relaxed: its tangential force is zero (no friction)
  };
  // Relaxation: frees row @p r of H_C (its force slot held at zero; rowFree(r) then true).
  void freeRow(DenseQp& qp, int r);
  // Relaxation: unbounds @p count inequality rows of C from @p first.
  void dropInequalityRows(DenseQp& qp, int first, int count);
  // Relaxation: frees link @p i's moment rows (and with @p tangents its tangential rows),
  // with the inequality rows that bound them.
  void freeLinkRows(DenseQp& qp, int i, bool tangents);
  // Relaxation: frees the rows of H_C (top @p nc) that depend on rows of higher precedence
  // (normals, then tangents, then moments; older links first). Returns the number freed.
  int freeDependentRows(DenseQp& qp, const Eigen::Ref<const Eigen::MatrixXd>& H_C, int nc);
  Eigen::MatrixXd basis_;          // nv × capacity: orthonormal basis of the rows kept
  std::vector<char> row_free_;     // capacity: rows freed by a relaxation this solve
  // Makes link @p i slide along lb.slide: its tangential rows become Coulomb's kinetic
  // friction, and its friction pyramid gives way.
  void slide(DenseQp& qp, int i);
  // Makes link @p i pivot in qp (see the file comment); rows of H_C, u_C for the sign test.
  void pivot(DenseQp& qp, int i, int sign, bool from_rest, const Eigen::Ref<const Eigen::MatrixXd>& H_C,
             const Eigen::Ref<const Eigen::VectorXd>& u_C);
  // Writes link @p lb's two torsion rows |m_z| ≤ μ r f_z into qp.C at lb.torsion_row.
  void setTorsionRows(DenseQp& qp, const LinkBounds& lb) const;
  // Inequality rows of C after the friction pyramid that bound a link's moments: CoP along
  // x and torsion (edges), and CoP along y (faces).
  static int momentRows(const LinkBounds& lb) { return lb.num_axes == 6 ? 6 : lb.num_axes == 5 ? 4 : 0; }
  // The τ_C row (and Eq. 9 row) of an edge's or a face's yaw: rz is its last axis.
  static int yawRow(const LinkBounds& lb) { return lb.row + lb.num_axes - 1; }
  // Undoes pivot(): link @p i's yaw row and torsion rows as built.
  void stick(DenseQp& qp, int i, const Eigen::Ref<const Eigen::MatrixXd>& H_C,
             const Eigen::Ref<const Eigen::VectorXd>& u_C);
  std::vector<LinkBounds> link_bounds_;
  int num_links_ = 0;
  double equality_tolerance_ = 0.0;  // N, from the body weight
  double weight_n_ = 0.0;            // body weight (N): scales the unloading rate
};

}  // namespace dynfilter
