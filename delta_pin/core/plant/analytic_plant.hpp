// The paper's reduced Delta as a plant of the compiled core (plant.hpp): eq. 13,
//
//     M(alpha, m_o(t)) alpha_ddot + C alpha_dot + G + F(t) + M_f(alpha_dot, F_n(t)) = tau,
//
// with M, C, G of eqs. 7-9 (G corrected, control/delta_analytic.hpp) at m_eq = m_o(t) + 3/2 m_b,
// eq. 12's friction (sgn smoothed by tanh) and the truth m_o(t), F_n(t), F(t) of a TruthTable;
// x = [alpha, alpha_dot]. The arithmetic of delta_pin.sim.plants.AnalyticPlant, which the tests
// hold it to. Eigen only.
#pragma once

#include "closed_chain.hpp"
#include "control/delta_analytic.hpp"
#include "plant.hpp"

namespace delta_pin
{
  class AnalyticDeltaPlant : public CorePlant
  {
  public:
    // geometry: the robot's constants (its m_eq unused); arm_mass_share: 3/2 m_b [kg];
    // platform_mass: the nominal m_o [kg] (where the truth has no masses)
    AnalyticDeltaPlant(const DeltaGeometry & geometry, double arm_mass_share, double platform_mass);

    void set_friction(const FrictionSpec & friction);
    // the truth at t = i step [s]: m_o (body_masses), F_n and F; no point masses
    void set_truth_table(const TruthTable & truth) override;

    int nq() const override { return 3; }
    int nv() const override { return 3; }
    bool has_configuration() const override { return false; }

    // dx/dt at x under tau with the truth at the table's row position u
    void derivative(const Vector & x, const Vector & tau, double u, Vector & dx);
    double step(Vector & x, const Vector & tau, double t, double h) override;
    Eigen::Vector3d end_effector_position(const Vector & q) override;
    double closure_gap(const Vector &) override { return 0.0; }
    bool complete(const Vector & alpha, const Vector & alpha_dot, Vector & q, Vector & v) override;
    void active_accelerations(double t, const Vector & q, const Vector & v, const Vector & tau, Vector & alpha_ddot) override;

  private:
    void accelerations(const Vector3 & alpha, const Vector3 & alpha_dot, const Vector & tau, double u, Vector3 & out);

    DeltaGeometry geometry_;
    double arm_mass_share_, platform_mass_;
    FrictionSpec friction_;
    TruthTable truth_;
    Vector k1_, k2_, k3_, k4_, y_;
  };
} // namespace delta_pin
