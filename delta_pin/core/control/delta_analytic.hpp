// The paper's analytic Delta (eqs. 1-10, the corrected G of docs/architecture.md section 4) at
// one state, Eigen only: forward kinematics by the intersection of the three forearm spheres,
// J, J_dot and the reduced M, C, G. The same arithmetic as delta_pin/compiled/delta_kernels.py
// (the readable reference: delta_pin/model/kinematics.py and dynamics.py). No heap allocation.
#pragma once

#include <Eigen/Dense>

#include <cmath>

namespace delta_pin
{
  // The robot's constants (delta_pin.model.dynamics.kernel_geometry) and the chain azimuths.
  struct DeltaGeometry
  {
    double R = 0.0, r = 0.0, l_a = 0.0, l_b = 0.0;  // [m]
    double arm_inertia = 0.0;  // the arm part of M (eq. 7) [kg m^2]
    double arm_gravity = 0.0;  // (m_a + m_b) g l_a / 2 [N m]
    double g = 9.81;  // [m/s^2]
    double m_eq = 0.0;  // m_o + 3/2 m_b [kg]
    // the chain azimuths phi_i = (2i/3 - 1/2) pi of eq. 2 (delta_pin.model.description.chain_azimuths)
    double cos_phi[3] = {0.8660254037844387, -0.8660254037844385, -1.8369701987210297e-16};
    double sin_phi[3] = {0.49999999999999983, 0.5000000000000003, -1.0};
  };

  typedef Eigen::Matrix3d Matrix3;
  typedef Eigen::Vector3d Vector3;

  // M^-1 for M with rows s_i, by cross products (delta_kernels._inverse_into; no pivoting: for
  // the well-conditioned matrices of this model)
  inline Matrix3 inverse_by_rows(const Matrix3 & s)
  {
    Matrix3 inverse;
    for (int column = 0; column < 3; ++column)
    {
      const int a = (column + 1) % 3, b = (column + 2) % 3;
      inverse(0, column) = s(a, 1) * s(b, 2) - s(a, 2) * s(b, 1);
      inverse(1, column) = s(a, 2) * s(b, 0) - s(a, 0) * s(b, 2);
      inverse(2, column) = s(a, 0) * s(b, 1) - s(a, 1) * s(b, 0);
    }
    const double det = s(0, 0) * inverse(0, 0) + s(0, 1) * inverse(1, 0) + s(0, 2) * inverse(2, 0);
    return inverse / det;
  }

  // FK, J, J_dot (eqs. 3-6, 10); false without an FK solution
  inline bool delta_kinematics(
    const DeltaGeometry & p, const Vector3 & alpha, const Vector3 & alpha_dot, Vector3 & xyz, Matrix3 & J,
    Matrix3 & J_dot)
  {
    Matrix3 centres, tangents, curvatures;
    for (int i = 0; i < 3; ++i)
    {
      const double ca = std::cos(alpha[i]), sa = std::sin(alpha[i]);
      const double reach = p.R - p.r + p.l_a * ca;
      centres.row(i) << reach * p.cos_phi[i], reach * p.sin_phi[i], -p.l_a * sa;
      tangents.row(i) << -p.l_a * sa * p.cos_phi[i], -p.l_a * sa * p.sin_phi[i], -p.l_a * ca;
      curvatures.row(i) << -p.l_a * ca * p.cos_phi[i], -p.l_a * ca * p.sin_phi[i], p.l_a * sa;
    }
    // the planes 2 (P_0 - P_k) . p = |P_0|^2 - |P_k|^2 meet on a line p0 + t n
    const Vector3 n1 = 2.0 * (centres.row(0) - centres.row(1)).transpose();
    const Vector3 n2 = 2.0 * (centres.row(0) - centres.row(2)).transpose();
    const double q0 = centres.row(0).squaredNorm();
    const double d1 = q0 - centres.row(1).squaredNorm(), d2 = q0 - centres.row(2).squaredNorm();
    const Vector3 n = n1.cross(n2);
    const double nn = n.squaredNorm();
    if (nn < 1e-24)
      return false;
    const Vector3 p0 = (d1 * n2.cross(n) + d2 * n.cross(n1)) / nn;
    Vector3 u = n / std::sqrt(nn);
    if (u[2] > 0.0)
      u = -u;  // the platform hangs below the base
    const Vector3 o = p0 - centres.row(0).transpose();
    const double half_b = u.dot(o);
    const double discriminant = half_b * half_b - (o.squaredNorm() - p.l_b * p.l_b);
    if (discriminant < 0.0)
      return false;
    xyz = p0 + (-half_b + std::sqrt(discriminant)) * u;
    // J = S^-1 diag(s_i . B_i'), s_i = p - P_i
    Matrix3 s;
    for (int i = 0; i < 3; ++i)
      s.row(i) = xyz.transpose() - centres.row(i);
    const Matrix3 inverse = inverse_by_rows(s);
    for (int i = 0; i < 3; ++i)
      J.col(i) = inverse.col(i) * s.row(i).dot(tangents.row(i));
    // J_dot = S^-1 (diag(d_dot) - S_dot J), s_i_dot = p_dot - B_i' alpha_dot_i
    const Vector3 velocity = J * alpha_dot;
    Matrix3 W;
    for (int i = 0; i < 3; ++i)
    {
      const Vector3 s_dot = velocity - tangents.row(i).transpose() * alpha_dot[i];
      W.row(i) = -(s_dot.transpose() * J);
      W(i, i) += s_dot.dot(tangents.row(i)) + s.row(i).dot(curvatures.row(i)) * alpha_dot[i];
    }
    J_dot = inverse * W;
    return true;
  }

  // M, C, G of eqs. 7-9 (G corrected) from the kinematics
  inline void delta_dynamics(
    const DeltaGeometry & p, const Vector3 & alpha, const Matrix3 & J, const Matrix3 & J_dot, Matrix3 & M, Matrix3 & C,
    Vector3 & G)
  {
    M = p.m_eq * (J.transpose() * J);
    C = p.m_eq * (J.transpose() * J_dot);
    M.diagonal().array() += p.arm_inertia;
    for (int i = 0; i < 3; ++i)
      G[i] = -p.arm_gravity * std::cos(alpha[i]) + p.m_eq * p.g * J(2, i);
  }
} // namespace delta_pin
