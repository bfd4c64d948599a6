// The nominal models of the compiled laws (nominal_terms.hpp).

#include "nominal_terms.hpp"

#include "checks.hpp"
#include "failure.hpp"

namespace delta_pin
{
  ProjectedTerms::ProjectedTerms(const ChainDescription & chain, const Vector & reference_configuration)
  : model_(chain)
  , q_(reference_configuration)
  {
    check_size(q_, model_.nq(), "reference_configuration");
  }

  void ProjectedTerms::terms(const Vector & alpha, const Vector & alpha_dot, Matrix & M, Matrix & C, Vector & G)
  {
    Vector q;
    if (!model_.configuration(alpha, q_, q))
      throw SimulationFailure("the nominal model's loops do not close at alpha=" + joint_values(alpha));
    q_ = q;
    Vector C_alpha_dot;
    model_.reduced_terms(q, alpha_dot, M, C, G, C_alpha_dot);
  }

  void DeltaTerms::terms(const Vector & alpha, const Vector & alpha_dot, Matrix & M, Matrix & C, Vector & G)
  {
    Vector3 xyz, G3;
    Matrix3 J, J_dot, M3, C3;
    if (!delta_kinematics(geometry_, alpha, alpha_dot, xyz, J, J_dot))
      throw SimulationFailure("the nominal model's forward kinematics has no solution at alpha=" + joint_values(alpha));
    delta_dynamics(geometry_, alpha, J, J_dot, M3, C3, G3);
    M = M3;
    C = C3;
    G = G3;
  }
} // namespace delta_pin
