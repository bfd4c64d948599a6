// The constrained plant of a closed-chain robot (ClosedChainPlant, closed_chain.hpp); its model's
// kinematics and projected dynamics are in closed_chain_model.cpp.

#include "closed_chain.hpp"

#include "checks.hpp"
#include "controller.hpp"
#include "failure.hpp"
#include "multibody.hpp"

#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace delta_pin
{
  using namespace pinocchio;
  using namespace library;

  namespace
  {
    enum RateKind
    {
      AXIS = 0,
      BALL = 1,
      FREE = 2,
      UNIT_COMPLEX = 3,
      PLANAR = 4,
      NONE = 5  // no rate here: the plant steps this chain in active coordinates only
    };

    // the kinds of ClosedChainRobot._joint_rate_kind (delta_pin/model/closed_chain.py)
    int rate_kind(const Model & model, JointIndex j)
    {
      const std::string name = model.joints[j].shortname();
      const bool starts_r = name.rfind("JointModelR", 0) == 0;
      const bool starts_p = name.rfind("JointModelP", 0) == 0 && name.rfind("JointModelPlanar", 0) != 0;
      if (model.nqs[j] == model.nvs[j] && (starts_r || starts_p || name == "JointModelTranslation"))
        return AXIS;
      if (name == "JointModelSpherical")
        return BALL;
      if (name == "JointModelFreeFlyer")
        return FREE;
      if (
        name == "JointModelRUBX" || name == "JointModelRUBY" || name == "JointModelRUBZ"
        || name == "JointModelRevoluteUnboundedUnaligned")
        return UNIT_COMPLEX;
      if (name == "JointModelPlanar")
        return PLANAR;
      return NONE;
    }

    // a homogeneous transform as Pinocchio's placement
    SE3 placement(const Eigen::Matrix4d & homogeneous)
    {
      return SE3(Eigen::Matrix3d(homogeneous.topLeftCorner<3, 3>()), Eigen::Vector3d(homogeneous.topRightCorner<3, 1>()));
    }

    // d/dt of a unit quaternion (x, y, z, w) turning at omega in its own frame: 0.5 quat * (omega, 0)
    void quaternion_rate(
      const Eigen::Ref<const Vector> & quaternion, const Eigen::Vector3d & omega, Eigen::Ref<Vector> out)
    {
      const Eigen::Vector3d u = quaternion.head<3>();
      const double w = quaternion[3];
      out.head<3>() = 0.5 * (w * omega + u.cross(omega));
      out[3] = 0.5 * (-u.dot(omega));
    }
  } // namespace

  ClosedChainPlant::ClosedChainPlant(
    const ChainDescription & chain,
    const std::vector<ConstraintSpec> & constraints,
    double baumgarte_kp,
    double baumgarte_kd,
    double proximal_accuracy,
    double proximal_mu,
    int proximal_iterations,
    double projection_tolerance)
  : chain_(chain)
  , dyn_(std::make_unique<Dynamics>(
      chain_.multibody().model, ProximalSettings(proximal_accuracy, proximal_mu, proximal_iterations)))
  , projection_tolerance_(projection_tolerance)
  , baumgarte_kp_(baumgarte_kp)
  , baumgarte_kd_(baumgarte_kd)
  {
    actuated_q_ = chain.actuated_q;
    actuated_v_ = chain.actuated_v;
    coefficient_rates_ = dyn_->model.nq != dyn_->model.nv;
    for (JointIndex j = 1; j < (JointIndex)dyn_->model.njoints; ++j)
      rate_kinds_.push_back(coefficient_rates_ ? rate_kind(dyn_->model, j) : AXIS);
    const RigidConstraintModel::BaumgarteCorrectorParameters gains(baumgarte_kp, baumgarte_kd);
    const std::string joints = "the model's " + std::to_string(dyn_->model.njoints) + " joints";
    for (size_t k = 0; k < constraints.size(); ++k)
    {
      const ConstraintSpec & spec = constraints[k];
      const std::string name = "constraints[" + std::to_string(k) + "]";
      check_closure_rows(spec.size, name);
      check_index((long long)spec.joint1, dyn_->model.njoints, name + "'s joint 1", joints);
      check_index((long long)spec.joint2, dyn_->model.njoints, name + "'s joint 2", joints);
      if (spec.reference_frame != LOCAL && spec.reference_frame != LOCAL_WORLD_ALIGNED)
        throw std::invalid_argument(
          name + "'s reference frame is " + std::to_string(spec.reference_frame) + ", expected "
          + std::to_string((int)LOCAL) + " (LOCAL) or " + std::to_string((int)LOCAL_WORLD_ALIGNED)
          + " (LOCAL_WORLD_ALIGNED)");
      RigidConstraintModel constraint(
        spec.size == 6 ? CONTACT_6D : CONTACT_3D, dyn_->model, spec.joint1, placement(spec.placement1), spec.joint2,
        placement(spec.placement2), (ReferenceFrame)spec.reference_frame);
      constraint.setBaumgarteCorrectorParameters(gains);
      dyn_->constraint_models.push_back(constraint);
      dyn_->constraint_datas.push_back(RigidConstraintData(constraint));
    }
    dyn_->data = Data(dyn_->model);
    init_constraint_dynamics(dyn_->model, dyn_->data, dyn_->constraint_models, dyn_->constraint_datas);
    tau_ = Vector::Zero(dyn_->model.nv);
    ddq_ = Vector::Zero(dyn_->model.nv);
    last_q_ = library::neutral(dyn_->model);
    friction_.normal_force = Vector::Zero(dof());
    if (proximal_mu == 0.0)
      use_axis_tree(true);
  }

  ClosedChainPlant::~ClosedChainPlant() = default;

  int ClosedChainPlant::nq() const
  {
    return dyn_->model.nq;
  }

  int ClosedChainPlant::nv() const
  {
    return dyn_->model.nv;
  }

  std::string ClosedChainPlant::stage() const
  {
    return dyn_->axis ? "axis_tree" : "constraint_dynamics";
  }

  namespace
  {
    // RX, RY, RZ, PX, PY, PZ as axis_tree.hpp's type codes 0..5, -1 for any other joint
    int axis_code(const pinocchio::JointModel & joint)
    {
      static const char * names[6] = {"JointModelRX", "JointModelRY", "JointModelRZ",
                                      "JointModelPX", "JointModelPY", "JointModelPZ"};
      const std::string name = joint.shortname();
      for (int code = 0; code < 6; ++code)
        if (name == names[code])
          return code;
      return -1;
    }

    void rotation_and_translation(const SE3 & placement, double * out)
    {
      typedef Eigen::Matrix<double, 3, 3, Eigen::RowMajor> RowMatrix3;
      Eigen::Map<RowMatrix3> rotation(out);
      Eigen::Map<Eigen::Vector3d> translation(out + 9);
      rotation = placement.rotation();
      translation = placement.translation();
    }
  } // namespace

  void ClosedChainPlant::use_axis_tree(bool use)
  {
    dyn_->axis.reset();
    if (!use || coefficient_rates_ || dyn_->settings.mu != 0.0)
      return;
    const int joints = dyn_->model.njoints - 1;
    std::vector<int> parents, types, closure_joints;
    std::vector<double> placements(12 * (size_t)joints), inertias(13 * (size_t)joints), anchors;
    for (JointIndex j = 1; j < (JointIndex)dyn_->model.njoints; ++j)
    {
      const int code = axis_code(dyn_->model.joints[j]);
      if (code < 0)
        return;  // a joint the axis stage does not hold
      types.push_back(code);
      parents.push_back((int)dyn_->model.parents[j]);
      rotation_and_translation(dyn_->model.jointPlacements[j], &placements[12 * (j - 1)]);
      const Inertia & inertia = dyn_->model.inertias[j];
      double * row = &inertias[13 * (j - 1)];
      row[0] = inertia.mass();
      Eigen::Map<Eigen::Vector3d> com(row + 1);
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> rotational(row + 4);
      com = inertia.lever();
      rotational = inertia.inertia().matrix();
    }
    for (const RigidConstraintModel & constraint : dyn_->constraint_models)
    {
      if (constraint.type != CONTACT_3D || constraint.reference_frame != LOCAL)
        return;
      closure_joints.push_back((int)constraint.joint1_id);
      closure_joints.push_back((int)constraint.joint2_id);
      anchors.resize(anchors.size() + 24);
      rotation_and_translation(constraint.joint1_placement, &anchors[anchors.size() - 24]);
      rotation_and_translation(constraint.joint2_placement, &anchors[anchors.size() - 12]);
    }
    const double gravity[3] = {dyn_->model.gravity.linear()[0], dyn_->model.gravity.linear()[1], dyn_->model.gravity.linear()[2]};
    dyn_->axis.reset(new dpn::AxisTree(
      joints, parents.data(), types.data(), placements.data(), inertias.data(), gravity,
      (int)dyn_->constraint_models.size(), closure_joints.data(), anchors.data(), baumgarte_kp_, baumgarte_kd_, 0));
  }

  void ClosedChainPlant::set_friction(const FrictionSpec & friction)
  {
    if (friction.enabled)
      check_size(friction.normal_force, dof(), "normal_force");  // one per actuated joint
    friction_ = friction;
    if (!friction_.enabled)
      friction_.normal_force = Vector::Zero(dof());
  }

  void ClosedChainPlant::set_truth(
    JointIndex joint, const Eigen::Vector3d & point, double step, const Vector & body_masses,
    const Vector & point_masses, const RowMatrix & normal_forces, const RowMatrix & disturbances)
  {
    if (joint == 0 || joint >= (JointIndex)dyn_->model.njoints)
      throw std::invalid_argument(
        "joint is " + std::to_string(joint) + ", expected the truth's body among the model's joints 1 to "
        + std::to_string(dyn_->model.njoints - 1));
    if (payload_joint_ != 0)
      dyn_->model.inertias[payload_joint_] = dyn_->base_inertia;  // the body of the last call restored
    payload_joint_ = joint;
    payload_point_ = point;
    dyn_->base_inertia = dyn_->model.inertias[joint];
    mass_ = 0.0;
    body_mass_ = dyn_->base_inertia.mass();
    set_truth_table(TruthTable{step, body_masses, point_masses, normal_forces, disturbances});
  }

  void ClosedChainPlant::set_truth_table(const TruthTable & truth)
  {
    if ((truth.normal_forces.rows() && truth.normal_forces.cols() != dof())
        || (truth.disturbances.rows() && truth.disturbances.cols() != dof()))
      throw std::invalid_argument(
        "normal_forces and disturbances have shapes " + shape_text(truth.normal_forces.rows(), truth.normal_forces.cols())
        + " and " + shape_text(truth.disturbances.rows(), truth.disturbances.cols()) + ", expected "
        + std::to_string(dof()) + " columns (one per actuated joint) or no rows");
    if ((truth.body_masses.size() || truth.point_masses.size()) && payload_joint_ == 0)
      throw std::invalid_argument("a table of masses needs the payload's joint (set_truth)");
    if (!(truth.step >= 0.0))
      throw std::invalid_argument("step is " + std::to_string(truth.step) + ", expected the truth table's step >= 0 s");
    truth_ = truth;
  }

  void ClosedChainPlant::set_body(double u)
  {
    const double body = TruthTable::value(truth_.body_masses, u, dyn_->base_inertia.mass());
    const double mass = TruthTable::value(truth_.point_masses, u, 0.0);
    if (mass == mass_ && body == body_mass_)
      return;
    // PinocchioPlant._set_mass: the body's COM kept, its rotational inertia scaled with its mass
    const Eigen::Matrix3d rotational = dyn_->base_inertia.inertia().matrix() * (body / dyn_->base_inertia.mass());
    const Inertia scaled(body, dyn_->base_inertia.lever(), Symmetric3(rotational));
    dyn_->model.inertias[payload_joint_] = scaled + Inertia(mass, payload_point_, Symmetric3::Zero());
    mass_ = mass;
    body_mass_ = body;
    if (dyn_->axis)
    {
      const Inertia & inertia = dyn_->model.inertias[payload_joint_];
      dyn_->axis->set_body((int)payload_joint_, inertia.mass(), inertia.lever(), inertia.inertia().matrix());
    }
  }

  const Vector & ClosedChainPlant::accelerations(const Vector & q, const Vector & v, const Vector & tau, double u)
  {
    check_size(q, dyn_->model.nq, "q");
    check_size(v, dyn_->model.nv, "v");
    check_size(tau, actuated_v_.size(), "tau");
    if (payload_joint_ != 0)
      set_body(u);
    tau_.setZero();
    for (Eigen::Index i = 0; i < actuated_v_.size(); ++i)
    {
      // tau - (F(t) + M_f(alpha_dot, F_n(t))), ClosedChainPlant.accelerations' arithmetic
      double resisting = TruthTable::value(truth_.disturbances, u, i, 0.0);
      if (friction_.enabled)
      {
        const double normal = TruthTable::value(truth_.normal_forces, u, i, friction_.normal_force[i]);
        resisting += friction_.torque(v[actuated_v_[i]], normal);
      }
      tau_[actuated_v_[i]] = tau[i] - resisting;
    }
    chain_.subtract_springs(q, v, tau_);
    constrained(q, v, tau_);
    if (chain_.couplings().empty())
      return ddq_;
    // the joint couplings' multipliers (ClosedChainPlant._coupled): ddq is affine in the joint
    // torques, so one more solve per coupling gives its response D_k to a unit multiplier along
    // its row J_k; the multipliers make J ddq + J_dot v = -kd J v - kp r (Baumgarte)
    chain_.coupling_terms(q, v, coupling_r_, coupling_J_, coupling_drift_);
    free_ = ddq_;
    const Eigen::Index k = coupling_r_.size();
    responses_.resize(dyn_->model.nv, k);
    for (Eigen::Index c = 0; c < k; ++c)
    {
      constrained(q, v, tau_ + coupling_J_.row(c).transpose());
      responses_.col(c) = ddq_ - free_;
    }
    target_ = -(coupling_J_ * free_ + coupling_drift_) - baumgarte_kd_ * (coupling_J_ * v) - baumgarte_kp_ * coupling_r_;
    // J D = J M_c^-1 J^T is symmetric positive semi-definite: LDLT solves it, and where a coupling
    // the closures already imply makes it singular (redundant rows), every solution it may give
    // moves ddq alike (D lambda = 0 for J D lambda = 0)
    const Matrix system = coupling_J_ * responses_;
    const Vector multipliers = system.ldlt().solve(target_);
    ddq_ = free_ + responses_ * multipliers;
    return ddq_;
  }

  void ClosedChainPlant::constrained(const Vector & q, const Vector & v, const Vector & joint_torques)
  {
    if (dyn_->axis)
    {
      if (dyn_->axis->dynamics(q.data(), v.data(), joint_torques.data(), 0.0, nullptr, ddq_.data()))
        return;
      dyn_->axis.reset();  // M or the Delassus matrix not positive definite: Pinocchio's from now on
    }
    ddq_ = constraint_dynamics(dyn_->model, dyn_->data, q, v, joint_torques, dyn_->constraint_models, dyn_->constraint_datas, dyn_->settings);
  }

  void ClosedChainPlant::configuration_rate(const Vector & q, const Vector & v, Eigen::Ref<Vector> rate) const
  {
    for (JointIndex j = 1; j < (JointIndex)dyn_->model.njoints; ++j)
    {
      const int iq = dyn_->model.idx_qs[j], iv = dyn_->model.idx_vs[j], nq = dyn_->model.nqs[j];
      switch (rate_kinds_[j - 1])
      {
      case AXIS:
        rate.segment(iq, nq) = v.segment(iv, nq);
        break;
      case NONE:
        throw std::invalid_argument(
          "joint " + dyn_->model.names[j] + " (" + dyn_->model.joints[j].shortname()
          + ") has no configuration rate in the compiled plant: step it in active coordinates");
      case BALL:
        quaternion_rate(q.segment<4>(iq), v.segment<3>(iv), rate.segment<4>(iq));
        break;
      case FREE:
      {
        const Eigen::Quaterniond quaternion(q[iq + 6], q[iq + 3], q[iq + 4], q[iq + 5]);
        rate.segment<3>(iq) = quaternion.toRotationMatrix() * v.segment<3>(iv);
        quaternion_rate(q.segment<4>(iq + 3), v.segment<3>(iv + 3), rate.segment<4>(iq + 3));
        break;
      }
      case UNIT_COMPLEX:
        rate[iq] = -q[iq + 1] * v[iv];
        rate[iq + 1] = q[iq] * v[iv];
        break;
      default:  // planar: x, y, cos, sin; v = (vx, vy) in the joint frame, omega
      {
        const double c = q[iq + 2], s = q[iq + 3], vx = v[iv], vy = v[iv + 1], w = v[iv + 2];
        rate[iq] = c * vx - s * vy;
        rate[iq + 1] = s * vx + c * vy;
        rate[iq + 2] = -s * w;
        rate[iq + 3] = c * w;
      }
      }
    }
  }

  void ClosedChainPlant::derivative(const Vector & x, const Vector & tau, double u, Vector & dx)
  {
    const int nq = dyn_->model.nq, nv = dyn_->model.nv;
    dx.resize(nq + nv);
    const Vector q = x.head(nq), v = x.tail(nv);
    if (coefficient_rates_)
      configuration_rate(q, v, dx.head(nq));
    else
      dx.head(nq) = v;
    dx.tail(nv) = accelerations(q, v, tau, u);
  }

  double ClosedChainPlant::step(Vector & x, const Vector & tau, double t, double h)
  {
    check_size(x, dyn_->model.nq + dyn_->model.nv, "x");
    if (active_)
      return active_step(x, tau, t, h);
    rk4_step(
      x, t, h, [&](const Vector & state, double time, Vector & dx) { derivative(state, tau, truth_.position(time), dx); },
      k1_, k2_,
      k3_, k4_, y_);
    return settle(x);
  }

  double ClosedChainPlant::settle(Vector & x)
  {
    const int nq = dyn_->model.nq, nv = dyn_->model.nv;
    if (coefficient_rates_)
    {
      Vector q = x.head(nq);
      library::normalize(dyn_->model, q);
      x.head(nq) = q;
    }
    // the axis tree's placements give the same gap as the chain's Pinocchio pass where the
    // closures are all it holds (no joint couplings)
    const double gap = dyn_->axis && chain_.couplings().empty() ? dyn_->axis->closureGap(x.data())
                                                                 : chain_.closure_gap(x.head(nq));
    if (gap <= projection_tolerance_)
      return gap;
    if (!(std::isfinite(gap) && x.allFinite()))
      throw SimulationFailure("the loop-closure gap is nan: the state is no longer finite");
    if (gap > failure_tolerance_)
    {
      std::ostringstream text;
      text << std::scientific << std::setprecision(3) << "the loop-closure gap reached " << gap << gap_unit_
           << ", above failure_tolerance=" << std::defaultfloat << std::setprecision(6) << failure_tolerance_
           << gap_unit_ << " (raise it, or shorten dt)";
      throw SimulationFailure(text.str());
    }
    last_q_ = x.head(nq);
    Vector q = last_q_, v = x.tail(nv);
    bool closed;
    if (chain_.unactuated())  // idle and passive state of its own: keep it
      closed = chain_.project_state(q, v);
    else  // q from the actuated coordinates (Newton from x's own q), v = S alpha_dot
    {
      Vector alpha(actuated_q_.size()), alpha_dot(actuated_v_.size());
      for (Eigen::Index i = 0; i < actuated_q_.size(); ++i)
        alpha[i] = x[actuated_q_[i]];
      for (Eigen::Index i = 0; i < actuated_v_.size(); ++i)
        alpha_dot[i] = x[nq + actuated_v_[i]];
      closed = chain_.configuration(alpha, last_q_, q);
      if (closed)
        v = chain_.velocity_map(q) * alpha_dot;
    }
    if (!closed)
    {
      // ClosedChainPlant.finish_step's message
      Vector alpha(actuated_q_.size());
      for (Eigen::Index i = 0; i < actuated_q_.size(); ++i)
        alpha[i] = x[actuated_q_[i]];
      std::ostringstream text;
      text.precision(3);
      text << std::scientific << "the loops cannot be re-assembled after a closure gap of " << gap
           << " (m or rad): Newton from the drifted state is still " << largest(chain_.residual(q))
           << " apart at alpha=" << joint_values(alpha);
      throw SimulationFailure(text.str());
    }
    x.head(nq) = q;
    x.tail(nv) = v;
    last_q_ = q;
    ++projections_;
    largest_projected_gap_ = std::max(largest_projected_gap_, gap);
    return chain_.closure_gap(q);
  }

  void ClosedChainPlant::set_failure_tolerance(double tolerance, const std::string & unit)
  {
    if (!(tolerance > 0.0))
      throw std::invalid_argument(
        "failure_tolerance is " + std::to_string(tolerance) + ", expected a closure gap > 0 (m or rad), or inf");
    failure_tolerance_ = tolerance;
    gap_unit_ = unit;
  }

  void ClosedChainPlant::integrate_active(bool active)
  {
    if (active && chain_.unactuated())
      throw std::invalid_argument(
        "active coordinates carry only the actuated joints, and this chain also moves idle motions or passive "
        "joints that no motor drives: integrate its whole state");
    active_ = active;
  }

  double ClosedChainPlant::active_step(Vector & x, const Vector & tau, double t, double h)
  {
    const int nq = dyn_->model.nq, nv = dyn_->model.nv;
    const Eigen::Index n = actuated_v_.size();
    last_q_ = x.head(nq);  // the warm start of every completion below
    joints_.resize(n);
    joint_rates_.resize(n);
    joint_state(x, joints_, joint_rates_);
    Vector state(2 * n);
    state << joints_, joint_rates_;
    // (q, v) at the actuated state y into last_q_, active_v_; a failure names alpha (its time set
    // by the loop)
    const auto complete_at = [&](const Vector & y)
    {
      joints_ = y.head(n);
      joint_rates_ = y.tail(n);
      if (!y.allFinite())
        throw SimulationFailure("the state became non-finite (alpha=" + joint_values(joints_) + ")");
      if (!complete(joints_, joint_rates_, last_q_, active_v_))
      {
        std::ostringstream text;
        text.precision(3);
        text << std::scientific << "cannot close the loops at alpha=" << joint_values(joints_)
             << ": Newton is still " << largest(chain_.residual(last_q_)) << " (m or rad) apart";
        throw SimulationFailure(text.str());
      }
    };
    rk4_step(
      state, t, h,
      [&](const Vector & y, double time, Vector & dy)
      {
        complete_at(y);
        active_accelerations(time, last_q_, active_v_, tau, active_ddot_);
        dy.resize(2 * n);
        dy.head(n) = joint_rates_;
        dy.tail(n) = active_ddot_;
      },
      k1_, k2_, k3_, k4_, y_);
    complete_at(state);
    x.head(nq) = last_q_;
    x.tail(nv) = active_v_;
    return chain_.closure_gap(last_q_);
  }

  bool ClosedChainPlant::project(Vector & x)
  {
    check_size(x, dyn_->model.nq + dyn_->model.nv, "x");
    const long before = projections_;
    Vector settled = x;
    settle(settled);
    if (projections_ == before)
      return false;  // within the tolerance: x as it was (not even renormalised)
    x = settled;
    return true;
  }

  bool ClosedChainPlant::complete(const Vector & alpha, const Vector & alpha_dot, Vector & q, Vector & v)
  {
    const Vector guess = q.size() == dyn_->model.nq ? q : library::neutral(dyn_->model);
    if (!chain_.configuration(alpha, guess, q))
      return false;
    v = chain_.velocity_map(q) * alpha_dot;
    return true;
  }

  void ClosedChainPlant::active_accelerations(
    double t, const Vector & q, const Vector & v, const Vector & tau, Vector & alpha_ddot)
  {
    const Vector & ddq = accelerations(q, v, tau, truth_.position(t));
    alpha_ddot.resize(actuated_v_.size());
    for (Eigen::Index i = 0; i < actuated_v_.size(); ++i)
      alpha_ddot[i] = ddq[actuated_v_[i]];
  }
} // namespace delta_pin
