// The paper's reduced Delta in the compiled core (analytic_plant.hpp).

#include "analytic_plant.hpp"

#include "checks.hpp"
#include "failure.hpp"

#include <stdexcept>

namespace delta_pin
{
  AnalyticDeltaPlant::AnalyticDeltaPlant(const DeltaGeometry & geometry, double arm_mass_share, double platform_mass)
  : geometry_(geometry)
  , arm_mass_share_(arm_mass_share)
  , platform_mass_(platform_mass)
  {
    actuated_q_ = Indices::LinSpaced(3, 0, 2);
    actuated_v_ = actuated_q_;
    friction_.normal_force = Vector::Zero(3);
    k1_ = k2_ = k3_ = k4_ = y_ = Vector::Zero(6);
  }

  void AnalyticDeltaPlant::set_friction(const FrictionSpec & friction)
  {
    check_size(friction.normal_force, 3, "normal_force");  // one per actuated joint
    friction_ = friction;
  }

  void AnalyticDeltaPlant::set_truth_table(const TruthTable & truth)
  {
    if ((truth.normal_forces.rows() && truth.normal_forces.cols() != 3)
        || (truth.disturbances.rows() && truth.disturbances.cols() != 3))
      throw std::invalid_argument(
        "normal_forces and disturbances have shapes " + shape_text(truth.normal_forces.rows(), truth.normal_forces.cols())
        + " and " + shape_text(truth.disturbances.rows(), truth.disturbances.cols())
        + ", expected 3 columns (one per actuated joint) or no rows");
    if (truth.point_masses.size())
      throw std::invalid_argument("the analytic Delta takes the platform mass m_o(t), not a point payload");
    if (!(truth.step >= 0.0))
      throw std::invalid_argument("step is " + std::to_string(truth.step) + ", expected the truth table's step >= 0 s");
    truth_ = truth;
  }

  void AnalyticDeltaPlant::accelerations(
    const Vector3 & alpha, const Vector3 & alpha_dot, const Vector & tau, double u, Vector3 & out)
  {
    DeltaGeometry p = geometry_;
    p.m_eq = TruthTable::value(truth_.body_masses, u, platform_mass_) + arm_mass_share_;
    Vector3 xyz;
    Matrix3 J, J_dot, M, C;
    Vector3 G;
    if (!delta_kinematics(p, alpha, alpha_dot, xyz, J, J_dot))
      throw SimulationFailure("alpha=" + joint_values(alpha) + " rad has no forward kinematics");
    delta_dynamics(p, alpha, J, J_dot, M, C, G);
    Vector3 rhs;
    for (int i = 0; i < 3; ++i)
    {
      // F(t) + M_f(alpha_dot, F_n(t)): DeltaPlant.acceleration_terms
      double passive = TruthTable::value(truth_.disturbances, u, i, 0.0);
      if (friction_.enabled)
        passive += friction_.torque(alpha_dot[i], TruthTable::value(truth_.normal_forces, u, i, friction_.normal_force[i]));
      rhs[i] = tau[i] - C.row(i).dot(alpha_dot) - G[i] - passive;
    }
    out = inverse_by_rows(M) * rhs;  // solve3: M^-1 by cross products
  }

  void AnalyticDeltaPlant::derivative(const Vector & x, const Vector & tau, double u, Vector & dx)
  {
    check_size(x, 6, "x");  // [alpha, alpha_dot]
    check_size(tau, 3, "tau");
    Vector3 ddq;
    accelerations(x.head<3>(), x.tail<3>(), tau, u, ddq);
    dx.resize(6);
    dx.head<3>() = x.tail<3>();
    dx.tail<3>() = ddq;
  }

  double AnalyticDeltaPlant::step(Vector & x, const Vector & tau, double t, double h)
  {
    check_size(x, 6, "x");  // [alpha, alpha_dot]
    check_size(tau, 3, "tau");
    rk4_step(
      x, t, h, [&](const Vector & state, double time, Vector & dx) { derivative(state, tau, truth_.position(time), dx); },
      k1_, k2_,
      k3_, k4_, y_);
    return 0.0;
  }

  Eigen::Vector3d AnalyticDeltaPlant::end_effector_position(const Vector & q)
  {
    check_size(q, 3, "q");  // alpha
    Vector3 xyz;
    Matrix3 J, J_dot;
    if (!delta_kinematics(geometry_, q.head<3>(), Vector3::Zero(), xyz, J, J_dot))
      xyz.setConstant(std::numeric_limits<double>::quiet_NaN());
    return xyz;
  }

  bool AnalyticDeltaPlant::complete(const Vector & alpha, const Vector & alpha_dot, Vector & q, Vector & v)
  {
    q = alpha;
    v = alpha_dot;
    return true;
  }

  void AnalyticDeltaPlant::active_accelerations(
    double t, const Vector & q, const Vector & v, const Vector & tau, Vector & alpha_ddot)
  {
    check_size(q, 3, "q");  // alpha
    check_size(v, 3, "v");  // alpha_dot
    check_size(tau, 3, "tau");
    Vector3 ddq;
    accelerations(q.head<3>(), v.head<3>(), tau, truth_.position(t), ddq);
    alpha_ddot = ddq;
  }
} // namespace delta_pin
