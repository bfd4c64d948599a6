// A law's nominal model as a part of the law (controller.hpp): M̄, C̄ (the matrix), Ḡ of the
// actuated joints at a state (eqs. 16-20), and optionally its own compensation F̄ [+ M̄_f]. Three
// kinds: a closed chain's projected dynamics (ProjectedTerms), the Delta's analytic eqs. 7-10
// (DeltaTerms), and a nominal model written in Python called back (python/bind_laws.cpp), so a
// compiled law runs on any nominal model.
#pragma once

#include "closed_chain.hpp"
#include "control/delta_analytic.hpp"

#include <Eigen/Dense>

namespace delta_pin
{
  class NominalTerms
  {
  public:
    typedef Eigen::VectorXd Vector;
    typedef Eigen::MatrixXd Matrix;
    virtual ~NominalTerms() = default;

    // the actuated joints
    virtual Eigen::Index dof() const = 0;
    // M̄ [kg m^2], C̄ [kg m^2/s], Ḡ [N m] at (alpha [rad], alpha_dot [rad/s]); SimulationFailure
    // where the model cannot be evaluated there
    virtual void terms(const Vector & alpha, const Vector & alpha_dot, Matrix & M, Matrix & C, Vector & G) = 0;
    // the next evaluation starts from the plant's configuration q, where the model has one
    virtual void warm_start(const Vector & /*q*/) {}
    // F̄ [+ M̄_f(alpha_dot)] [N m] where the model computes its own (a Python model's
    // compensation()); false: the law's disturbance and friction (ProjectedLaw::set_friction)
    virtual bool compensation(const Vector & /*alpha_dot*/, Vector & /*out*/) { return false; }
  };

  // A closed chain's projected dynamics (ClosedChainModel::reduced_terms), each assembly
  // warm-started from the previous one (the reference configuration first)
  class ProjectedTerms : public NominalTerms
  {
  public:
    ProjectedTerms(const ChainDescription & chain, const Vector & reference_configuration);
    Eigen::Index dof() const override { return model_.dof(); }
    void terms(const Vector & alpha, const Vector & alpha_dot, Matrix & M, Matrix & C, Vector & G) override;
    void warm_start(const Vector & q) override
    {
      if (q.size() == q_.size())
        q_ = q;
    }

  private:
    ClosedChainModel model_;
    Vector q_;  // the last assembly (warm start)
  };

  // The Delta's analytic model (eqs. 7-10, control/delta_analytic.hpp): three actuated joints
  class DeltaTerms : public NominalTerms
  {
  public:
    explicit DeltaTerms(const DeltaGeometry & geometry)
    : geometry_(geometry)
    {
    }
    Eigen::Index dof() const override { return 3; }
    void terms(const Vector & alpha, const Vector & alpha_dot, Matrix & M, Matrix & C, Vector & G) override;

  private:
    DeltaGeometry geometry_;
  };
} // namespace delta_pin
