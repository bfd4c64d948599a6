// The constrained plant of a closed-chain robot in the compiled core: Pinocchio's tree plus its
// loop closures, integrated in full coordinates x = [q, v] (docs/architecture.md section 8).
//
// The same physics as the Python ClosedChainPlant (delta_pin/sim/closed_chain_plant.py), which
// the tests hold this class to: pinocchio::constraintDynamics with Baumgarte stabilisation, the
// actuated torques minus the joint friction (eq. 12, sgn smoothed by tanh), joint springs and
// dampers, a payload point mass at a frame read from a table of the RK4 stage times, the
// configuration coefficients of ball, free and continuous joints integrated at their rates and
// renormalised; a step whose closure gap exceeds the projection tolerance is projected back onto
// the loops (Newton from the actuated coordinates, velocities through S = dq/dalpha; where the
// robot has idle motions or passive joints, the nearest state that keeps them: minimum-norm
// corrections of the dependent joints, ClosedChainRobot.project_state).
//
// Any robot of the one robot model is built here: idle motions (a rod spinning between two ball
// joints), passive joints (underactuated, a free base) and joint couplings (MuJoCo's <equality
// joint>: closure rows of their own, whose multipliers the plant adds to constraintDynamics'
// solution, as the Python plant does).
//
// This header includes no Pinocchio (docs/architecture.md section 8, build time): the Pinocchio
// model, its data and the constraint models live behind a pointer (ClosedChainModel::Multibody,
// ClosedChainPlant::Dynamics, multibody.hpp), so that the laws, the loops and the bindings, which
// include this header, compile without Pinocchio's headers.
#pragma once

#include "control/friction.hpp"
#include "model_spec.hpp"
#include "plant.hpp"

#include <Eigen/Dense>

#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace delta_pin
{
  // Pinocchio's indices (FrameIndex and JointIndex are std::size_t)
  typedef std::size_t FrameIndex;
  typedef std::size_t JointIndex;

  // A value kept behind a pointer so that its type need not be complete where its owner is
  // declared; copied with its owner. Its owner declares its copies and destructor and defines
  // them (= default) where T is complete.
  template<class T>
  class Hidden
  {
  public:
    Hidden() = default;
    explicit Hidden(std::unique_ptr<T> value)
    : value_(std::move(value))
    {
    }
    Hidden(const Hidden & other)
    : value_(other.value_ ? std::make_unique<T>(*other.value_) : nullptr)
    {
    }
    Hidden & operator=(const Hidden & other)
    {
      value_ = other.value_ ? std::make_unique<T>(*other.value_) : nullptr;
      return *this;
    }
    Hidden(Hidden &&) noexcept = default;
    Hidden & operator=(Hidden &&) noexcept = default;
    ~Hidden() = default;
    T * operator->() const { return value_.get(); }
    T & operator*() const { return *value_; }

  private:
    std::unique_ptr<T> value_;
  };

  // One loop closure: its two frames in the model and its equations (3: a point, 6: a weld).
  struct ClosureFrames
  {
    FrameIndex frame1, frame2;
    int size;
  };

  // One point or weld constraint for constraintDynamics (RigidConstraintModel's numbers).
  struct ConstraintSpec
  {
    int size;  // 3 or 6
    JointIndex joint1, joint2;
    Eigen::Matrix4d placement1, placement2;  // homogeneous transforms in the joints' frames
    int reference_frame;  // pinocchio::ReferenceFrame
  };

  // One joint coupling (JointCoupling, delta_pin/model/closed_chain.py): q1 - reference1 =
  // p(q2 - reference2) with p(x) = sum_k coefficients[k] x^k, a closure row r = q1 - reference1 - p,
  // the velocity row e1 - p' e2 and the drift -p'' v2^2 (joint 2's entries -1: none, p(0) held).
  struct JointCouplingSpec
  {
    int q1, v1, q2, v2;
    double reference1, reference2;
    Vector coefficients;
    // (p, p', p'') at joint 2's coordinate
    void polynomial(double q2_value, double & value, double & slope, double & curvature) const;
  };

  // The robot's joint springs and dampers (ClosedChainRobot.joint_springs, MJCF stiffness and
  // damping): on 1-DOF joints tau -= k (q - ref) + d v at entries q_index, v_index [N m/rad, rad,
  // N m s/rad or N/m, m, N s/m]; dampers on the other joints' entries damper_v: tau -= damper_d v.
  struct JointSprings
  {
    Indices q_index, v_index;
    Vector k, ref, d;
    Indices damper_v;
    Vector damper_d;
  };

  // What the core needs of a closed-chain robot (ClosedChainRobot, delta_pin/model/closed_chain.py;
  // delta_pin/model/core_model.py builds it): its Pinocchio model (model_spec.hpp, closure frames
  // included), the closures' frames, the actuated joints' entries in q and v, the dependent joints'
  // entries in v (neither actuated nor passive: the closures determine them up to the idle
  // motions), the number of idle motions (motions of the dependent joints that move no independent
  // joint, docs/architecture.md section 10) and the end-effector frame, and its joint couplings
  // (rows after the closures'), and its joint springs and dampers. Passive joints are the entries of
  // v in neither list.
  struct ChainDescription
  {
    ModelSpec model;
    std::vector<ClosureFrames> closures;
    std::vector<JointCouplingSpec> couplings;
    Indices actuated_q, actuated_v, dependent_v;
    int idle_dof = 0;
    FrameIndex end_effector = 0;
    JointSprings springs;
  };

  // Stribeck friction on the actuated joints (eq. 12): r_a, v_s, mu_s, mu_d, mu_v, the normal
  // force per joint [N] and the sign's smoothing scale [rad/s].
  struct FrictionSpec : StribeckFriction
  {
    Vector normal_force;
  };

  // The kinematics and projected dynamics of a closed-chain robot: the same arithmetic as
  // ClosedChainRobot (delta_pin/model/closed_chain.py). With idle motions the dependent joints'
  // closure Jacobian A has a null space N: Newton and the velocity corrections take minimum-norm
  // steps (A's pseudo-inverse), and S is the map of least kinetic energy, S = P S0 with
  // P = I - N (N^T M N)^-1 N^T M (docs/architecture.md section 10).
  class ClosedChainModel
  {
  public:
    explicit ClosedChainModel(const ChainDescription & chain);
    ClosedChainModel(const ClosedChainModel & other);
    ClosedChainModel & operator=(const ClosedChainModel & other);
    ~ClosedChainModel();

    // the Pinocchio model and its data (multibody.hpp)
    struct Multibody;
    const Multibody & multibody() const { return *pin_; }
    int nq() const;
    int nv() const;
    int dof() const { return (int)actuated_v_.size(); }
    const Indices & actuated_q() const { return actuated_q_; }
    const Indices & actuated_v() const { return actuated_v_; }
    int idle_dof() const { return idle_dof_; }
    const std::vector<JointCouplingSpec> & couplings() const { return couplings_; }
    // tau -= the joint springs' and dampers' forces at (q, v) (JointSprings)
    void subtract_springs(const Vector & q, const Vector & v, Vector & tau) const;
    // the joint couplings' rows at (q, v): r (k), J (k, nv), J_dot v (k)
    void coupling_terms(const Vector & q, const Vector & v, Vector & r, Matrix & J, Vector & drift) const;
    // whether the robot moves in ways the actuated joints do not determine (idle motions, passive
    // joints): its state is then (q, v) whole, never (alpha, alpha_dot)
    bool unactuated() const;

    // closure residual r(q) [m, rad] and its largest entry (NaN where q holds one)
    const Vector & residual(const Vector & q);
    double closure_gap(const Vector & q);
    // a closure-consistent q with the actuated joints at alpha (Newton from `guess`, steps of at
    // most 0.5); false where it does not converge to `tolerance`
    bool configuration(const Vector & alpha, const Vector & guess, Vector & q, double tolerance = 1e-12, int iterations = 60);
    // S = dq/dalpha (nv, dof) at a closed q (named passive joints at rest; with idle motions the
    // map of least kinetic energy)
    Matrix velocity_map(const Vector & q);
    // The nearest closure-consistent (q, v) that keeps the actuated and passive joints' values and
    // the idle motions' state (ClosedChainRobot.project_state): Newton from q over the dependent
    // joints, then v's dependent part less the minimum-norm velocity that closes the loops; false
    // where Newton does not converge (q then holds its last iterate)
    bool project_state(Vector & q, Vector & v);
    // M (dof, dof), C (dof, dof), G (dof), C alpha_dot (dof) on the actuated joints by projection
    // (ClosedChainRobot.reduced_terms) at a closed q
    void reduced_terms(const Vector & q, const Vector & alpha_dot, Matrix & M, Matrix & C, Vector & G, Vector & C_alpha_dot);
    // tau = M alpha_ddot + C alpha_dot + G (dof) at a closed q, the same projection in one pass:
    // S^T (RNEA(q, S alpha_dot, S alpha_ddot + S_dot alpha_dot) + the springs' and dampers' forces)
    Vector actuated_torque(const Vector & q, const Vector & alpha_dot, const Vector & alpha_ddot);
    // A path's torque coefficients at a closed q (the time-optimal planner's, time_optimal.py):
    // with alpha' = d1 and alpha'' = d2, a = M d1, b = M d2 + Q(d1) (the Coriolis torque at
    // alpha_dot = d1, quadratic in it), c0 = G (the springs' stiffness in) and damping = D d1 (the
    // joint dampers, linear): by RNEA passes where there are no idle motions, else the matrices
    void path_coefficients(
      const Vector & q, const Vector & d1, const Vector & d2, Vector & a, Vector & b, Vector & c0, Vector & damping);
    Eigen::Vector3d end_effector_position(const Vector & q);
    // the closed-loop Jacobian (6, dof) of a frame, J_frame S (LOCAL_WORLD_ALIGNED)
    Matrix frame_jacobian(const Vector & q, FrameIndex frame);
    // the frame's classical linear acceleration at zero actuated acceleration [m/s^2]
    Eigen::Vector3d frame_acceleration_drift(const Vector & q, const Vector & alpha_dot, FrameIndex frame);
    // alpha putting the frame's origin at `target` along `rows` (0..2), Newton on alpha from
    // `alpha` with each iterate assembled from the previous q (ClosedChainRobot.inverse_kinematics);
    // q is the assembled configuration on success
    bool inverse_kinematics(
      const Eigen::Vector3d & target, FrameIndex frame, const Indices & rows, Vector & alpha, Vector & q,
      double tolerance = 1e-12, int iterations = 60);
    // A task-space path of a frame as a joint reference (FramePath.joint_reference): alpha,
    // alpha_dot, alpha_ddot and the frame's reached position per sample, each IK started from the
    // second-order prediction off the previous sample. Returns -1, or the first sample that
    // cannot be reached or assembled.
    long joint_reference(
      FrameIndex frame, const Indices & rows, const Vector & times, const RowMatrix & xyz,
      const RowMatrix & xyz_dot, const RowMatrix & xyz_ddot, const Vector & alpha0, Vector & q, RowMatrix & alpha,
      RowMatrix & alpha_dot, RowMatrix & alpha_ddot, RowMatrix & actual);

  private:
    // std::invalid_argument where frame is not one of the model's
    void check_frame(FrameIndex frame) const;
    const Matrix & closure_jacobian(const Vector & q);
    // J_c from the joint placements already in the data (after residual(q) or forwardKinematics)
    const Matrix & closure_jacobian_at_placements(const Vector & q);
    // J_c_dot (closure rows, nv) at (q, v): Pinocchio's LOCAL_WORLD_ALIGNED dJ, the time derivative of J
    Matrix closure_jacobian_derivative(const Vector & q, const Vector & v);
    // J_c's dependent columns (after closure_jacobian)
    Matrix dependent_columns() const;
    // x minimising |A x - rhs| for A = J_c's dependent columns: least squares, or with idle
    // motions the minimum-norm solution A^+ rhs (A factorised once per Jacobian)
    Matrix solve_dependent(const Matrix & rhs);
    // A^+ and an orthonormal basis (columns) of A's null space, of dimension idle_dof (a full-rank
    // factorisation by the pivoted QR of A^T, A's rank taken as its columns less the idle motions,
    // as ClosedChainRobot._pseudo_inverse takes it for its SVD)
    void pseudo_inverse(const Matrix & A, Matrix & pinv, Matrix & null_basis) const;
    // J_c's actuated columns B (after closure_jacobian)
    Matrix actuated_columns() const;
    // A's factorisation for solve_dependent (and with idle motions A^+ and the idle basis N), once
    // per Jacobian
    void factor_dependent();
    // S0 = the minimum-norm map (nv, dof): the actuated joints' identity, -A^+ B on the dependent
    // joints, zero on passive joints (after closure_jacobian)
    Matrix minimum_norm_map();
    // The idle motions' projection at a closed q along v = S alpha_dot
    // (ClosedChainRobot._idle_projection): S, its time derivative S_dot, the tree's M and
    // C_tree(q, v), and v; S_dot from the pseudo-inverse's derivative, N_dot = -A^+ A_dot N and
    // M_dot = C_tree + C_tree^T
    void idle_projection(
      const Vector & q, const Vector & alpha_dot, Matrix & S, Matrix & S_dot, Matrix & M, Matrix & C_tree, Vector & v);
    // the tree's joint-space inertia at q, both triangles filled
    Matrix mass_matrix(const Vector & q);
    // J_c_dot v: the closures' relative classical accelerations at zero joint acceleration
    Vector closure_drift(const Vector & q, const Vector & v);
    // S_dot alpha_dot (nv): -J_dep^+ J_c_dot v on the dependent coordinates, zero elsewhere
    Vector dependent_rate(const Vector & q, const Vector & v);
    // without idle motions, right after velocity_map(q) gave S (the joint Jacobians at q in the
    // data, J_c in jacobian_): the frame's closed-loop Jacobian J_frame S, and its classical linear
    // acceleration at zero actuated acceleration for v = S alpha_dot
    Matrix frame_jacobian_of(const Matrix & S, FrameIndex frame);
    Eigen::Vector3d frame_drift_of(const Vector & q, const Vector & v, FrameIndex frame);

    Hidden<Multibody> pin_;
    std::vector<ClosureFrames> closures_;
    std::vector<JointCouplingSpec> couplings_;
    JointSprings springs_;
    bool moving_subspace_ = false;  // a joint whose motion subspace depends on q (reduced_terms)
    Eigen::Index closure_rows_ = 0;  // the frame closures' rows; the couplings' follow
    Indices actuated_q_, actuated_v_, dependent_v_;
    int idle_dof_;
    FrameIndex end_effector_;
    Vector residual_;
    Matrix jacobian_;
    // two frames' Jacobians: 6 x nv, the type Pinocchio's library instantiates getFrameJacobian for
    Eigen::Matrix<double, 6, Eigen::Dynamic> frame_jacobian1_, frame_jacobian2_;
    // J_c's dependent columns and their factorisation (solve_dependent), valid until the next Jacobian
    bool dependent_factored_ = false;
    Matrix dependent_A_, dependent_pinv_;
    Matrix dependent_null_basis_, dependent_null_;  // A's null space: its rows, and N (nv, idle_dof)
    Eigen::PartialPivLU<Matrix> dependent_lu_;
  };

  class ClosedChainPlant : public CorePlant
  {
  public:
    ClosedChainPlant(
      const ChainDescription & chain,
      const std::vector<ConstraintSpec> & constraints,
      double baumgarte_kp,
      double baumgarte_kd,
      double proximal_accuracy,
      double proximal_mu,
      int proximal_iterations,
      double projection_tolerance);
    ClosedChainPlant(const ClosedChainPlant &) = delete;
    ~ClosedChainPlant() override;

    void set_friction(const FrictionSpec & friction);
    // The time-varying truth (TruthTable, plant.hpp) at t = i step [s]: the body of joint `joint`
    // with the mass body_masses[i] [kg] (its COM kept, its rotational inertia about the COM
    // scaled from the model's with the mass; empty: the model's body) plus a point mass
    // point_masses[i] [kg] at `point` (empty: none), the friction's normal forces [N] and the
    // joint disturbance [N m] on the actuated joints (no rows: the friction's own, none). The
    // sampled loop reads by time, a row per RK4 stage time (step = h / 2).
    void set_truth(
      JointIndex joint, const Eigen::Vector3d & point, double step, const Vector & body_masses,
      const Vector & point_masses, const RowMatrix & normal_forces, const RowMatrix & disturbances);
    void set_truth_table(const TruthTable & truth) override;

    int nq() const override;
    int nv() const override;
    bool has_configuration() const override { return true; }

    ClosedChainModel & chain() { return chain_; }
    // The stage that gives the accelerations: "axis_tree" (axis_tree.hpp, delta-pin's recursive
    // algorithms, where the tree has only RX..PZ joints, the closures are LOCAL points with the
    // exact KKT solution asked for, proximal mu = 0) or "constraint_dynamics" (Pinocchio's).
    // use_axis_tree(false) keeps Pinocchio's; a step where the axis stage finds M or the Delassus
    // matrix not positive definite falls back to Pinocchio's for good.
    std::string stage() const;
    void use_axis_tree(bool use);
    // ddq at (q, v) under actuated torques tau with the truth at the table's row position u
    // (a stage of the sampled loop, or t / step)
    const Vector & accelerations(const Vector & q, const Vector & v, const Vector & tau, double u);
    // dx/dt at x
    void derivative(const Vector & x, const Vector & tau, double u, Vector & dx);
    // one RK4 step (CorePlant::step): of the whole x = [q, v], then settle(); or, integrating
    // active coordinates, of (alpha, alpha_dot) with (q, v) completed at every stage, x the
    // completion of the result
    double step(Vector & x, const Vector & tau, double t, double h) override;
    // Whether step() integrates the actuated coordinates (alpha, alpha_dot) instead of x = [q, v]:
    // every RK4 stage completes q(alpha) by Newton (warm-started from the last completion) and
    // v = S alpha_dot, so the loops are closed by construction (ClosedChainPlant(coordinates=
    // "active") of delta_pin.sim.closed_chain_plant). Refused for a chain with idle motions or
    // passive joints (the actuated joints do not determine its state).
    void integrate_active(bool active);
    bool integrates_active() const { return active_; }
    // The closure gap [m, rad] above which settle() stops the run instead of projecting (default:
    // none, +inf), named in its message with `unit` (" m" where every closure is a point)
    void set_failure_tolerance(double tolerance, const std::string & unit);
    double failure_tolerance() const { return failure_tolerance_; }
    // x's configuration coefficients renormalised and, where its closure gap exceeds the
    // projection tolerance, x projected back onto the loops (from the actuated coordinates, or
    // keeping the idle and passive state); returns the gap of the result. Throws
    // SimulationFailure where x is not finite or the loops cannot be closed again.
    double settle(Vector & x);
    bool integrates_full_state() const override { return chain_.unactuated(); }
    void full_derivative(double t, const Vector & x, const Vector & tau, Vector & dx) override
    {
      derivative(x, tau, truth_.position(t), dx);
    }
    bool project(Vector & x) override;
    Eigen::Vector3d end_effector_position(const Vector & q) override { return chain_.end_effector_position(q); }
    double closure_gap(const Vector & q) override { return chain_.closure_gap(q); }
    // q(alpha) by Newton from q's own value, v = S alpha_dot
    bool complete(const Vector & alpha, const Vector & alpha_dot, Vector & q, Vector & v) override;
    void active_accelerations(double t, const Vector & q, const Vector & v, const Vector & tau, Vector & alpha_ddot) override;

  private:
    // ddq of the tree closed by the frame closures under the joint torques tau_ (the axis-tree
    // stage or constraintDynamics), into ddq_
    void constrained(const Vector & q, const Vector & v, const Vector & joint_torques);
    void set_body(double u);
    void configuration_rate(const Vector & q, const Vector & v, Eigen::Ref<Vector> rate) const;

    ClosedChainModel chain_;  // the kinematics: closures, assembly, S
    // the Pinocchio model of the dynamics (its payload inertia rewritten in time), its data, the
    // constraint models and settings of constraintDynamics, the axis-tree stage (multibody.hpp)
    struct Dynamics;
    Hidden<Dynamics> dyn_;
    std::vector<int> rate_kinds_;  // per joint: 0 axis, 1 ball, 2 free, 3 unit complex, 4 planar
    bool coefficient_rates_;
    double projection_tolerance_;
    // friction, payload (the springs and dampers are the chain's)
    FrictionSpec friction_;
    JointIndex payload_joint_ = 0;
    Eigen::Vector3d payload_point_ = Eigen::Vector3d::Zero();
    TruthTable truth_;
    double mass_ = 0.0, body_mass_ = -1.0;
    double baumgarte_kp_, baumgarte_kd_;
    Vector ddq_;
    // the joint couplings' multipliers (accelerations): their rows and the responses to them
    Vector coupling_r_, coupling_drift_, free_, target_;
    Matrix coupling_J_, responses_;
    bool active_ = false;  // step() in active coordinates (integrate_active)
    double failure_tolerance_ = std::numeric_limits<double>::infinity();
    std::string gap_unit_;
    double active_step(Vector & x, const Vector & tau, double t, double h);
    // scratch
    Vector tau_, last_q_, k1_, k2_, k3_, k4_, y_, joints_, joint_rates_, active_v_, active_ddot_;
  };
} // namespace delta_pin
