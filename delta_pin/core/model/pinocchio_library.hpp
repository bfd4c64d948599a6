// The Pinocchio algorithms the core calls, taken from the pin wheel's libpinocchio_default as
// compiled there (docs/architecture.md section 8, build time).
//
// Pinocchio's algorithm headers define every algorithm inline, so a unit that includes them
// instantiates and optimises each algorithm it calls anew (constraintDynamics alone took 8.7 s of
// front end and as much again of code generation per unit), although the library already holds
// them compiled for double scalars and VectorXd / Ref<const VectorXd> / Matrix6x arguments
// (PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION). This header declares those function templates,
// exactly as Pinocchio declares them, without their definitions, and wraps each in a function
// that passes exactly the argument types the library instantiates: the call then links to the
// library's copy. A declaration or an argument type that does not match an instantiation fails
// loudly, when the core is imported ("undefined symbol"), never silently: the tests import it
// first.
//
// Only multibody.hpp (the model, the data, the joints), constraints.hpp (the constraint models)
// and proximal.hpp (its settings) are included; no algorithm header may be, or the definitions
// come back.
#pragma once

#include <pinocchio/algorithm/proximal.hpp>
#include <pinocchio/constraints.hpp>
#include <pinocchio/multibody.hpp>

#include <Eigen/Core>

#include <vector>

namespace pinocchio
{
  // algorithm/kinematics.hpp (the library instantiates impl:: for Ref<const VectorXd>)
  namespace impl
  {
    template<typename Scalar, int Options, template<typename, int> class JointCollectionTpl, typename ConfigVectorType>
    void forwardKinematics(
      const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
      DataTpl<Scalar, Options, JointCollectionTpl> & data,
      const Eigen::MatrixBase<ConfigVectorType> & q);

    template<
      typename Scalar,
      int Options,
      template<typename, int> class JointCollectionTpl,
      typename ConfigVectorType,
      typename TangentVectorType1,
      typename TangentVectorType2>
    void forwardKinematics(
      const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
      DataTpl<Scalar, Options, JointCollectionTpl> & data,
      const Eigen::MatrixBase<ConfigVectorType> & q,
      const Eigen::MatrixBase<TangentVectorType1> & v,
      const Eigen::MatrixBase<TangentVectorType2> & a);

    // algorithm/jacobian.hpp
    template<
      typename Scalar,
      int Options,
      template<typename, int> class JointCollectionTpl,
      typename ConfigVectorType,
      typename TangentVectorType>
    const typename DataTpl<Scalar, Options, JointCollectionTpl>::Matrix6x & computeJointJacobiansTimeVariation(
      const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
      DataTpl<Scalar, Options, JointCollectionTpl> & data,
      const Eigen::MatrixBase<ConfigVectorType> & q,
      const Eigen::MatrixBase<TangentVectorType> & v);

    // algorithm/rnea.hpp
    template<
      typename Scalar,
      int Options,
      template<typename, int> class JointCollectionTpl,
      typename ConfigVectorType,
      typename TangentVectorType1,
      typename TangentVectorType2>
    const typename DataTpl<Scalar, Options, JointCollectionTpl>::TangentVectorType & rnea(
      const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
      DataTpl<Scalar, Options, JointCollectionTpl> & data,
      const Eigen::MatrixBase<ConfigVectorType> & q,
      const Eigen::MatrixBase<TangentVectorType1> & v,
      const Eigen::MatrixBase<TangentVectorType2> & a);

    template<
      typename Scalar,
      int Options,
      template<typename, int> class JointCollectionTpl,
      typename ConfigVectorType,
      typename TangentVectorType>
    const typename DataTpl<Scalar, Options, JointCollectionTpl>::MatrixXs & computeCoriolisMatrix(
      const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
      DataTpl<Scalar, Options, JointCollectionTpl> & data,
      const Eigen::MatrixBase<ConfigVectorType> & q,
      const Eigen::MatrixBase<TangentVectorType> & v);

    template<
      typename Scalar,
      int Options,
      template<typename, int> class JointCollectionTpl,
      typename ConfigVectorType,
      typename TangentVectorType>
    const typename DataTpl<Scalar, Options, JointCollectionTpl>::TangentVectorType & nonLinearEffects(
      const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
      DataTpl<Scalar, Options, JointCollectionTpl> & data,
      const Eigen::MatrixBase<ConfigVectorType> & q,
      const Eigen::MatrixBase<TangentVectorType> & v);

    template<typename Scalar, int Options, template<typename, int> class JointCollectionTpl, typename ConfigVectorType>
    const typename DataTpl<Scalar, Options, JointCollectionTpl>::TangentVectorType & computeGeneralizedGravity(
      const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
      DataTpl<Scalar, Options, JointCollectionTpl> & data,
      const Eigen::MatrixBase<ConfigVectorType> & q);
  } // namespace impl

  // algorithm/frames.hpp
  template<typename Scalar, int Options, template<typename, int> class JointCollectionTpl>
  const typename DataTpl<Scalar, Options, JointCollectionTpl>::SE3 & updateFramePlacement(
    const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
    DataTpl<Scalar, Options, JointCollectionTpl> & data,
    const FrameIndex frame_id);

  template<typename Scalar, int Options, template<typename, int> class JointCollectionTpl, typename Matrix6xLike>
  void getFrameJacobian(
    const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
    DataTpl<Scalar, Options, JointCollectionTpl> & data,
    const FrameIndex frame_id,
    const ReferenceFrame reference_frame,
    const Eigen::MatrixBase<Matrix6xLike> & J);

  template<typename Scalar, int Options, template<typename, int> class JointCollectionTpl, typename Matrix6xLike>
  void getFrameJacobianTimeVariation(
    const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
    DataTpl<Scalar, Options, JointCollectionTpl> & data,
    const FrameIndex frame_id,
    const ReferenceFrame rf,
    const Eigen::MatrixBase<Matrix6xLike> & dJ);

  template<typename Scalar, int Options, template<typename, int> class JointCollectionTpl>
  MotionTpl<Scalar, Options> getFrameClassicalAcceleration(
    const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
    const DataTpl<Scalar, Options, JointCollectionTpl> & data,
    const FrameIndex frame_id,
    const ReferenceFrame rf);

  // algorithm/jacobian.hpp
  template<typename Scalar, int Options, template<typename, int> class JointCollectionTpl>
  const typename DataTpl<Scalar, Options, JointCollectionTpl>::Matrix6x & computeJointJacobians(
    const ModelTpl<Scalar, Options, JointCollectionTpl> & model, DataTpl<Scalar, Options, JointCollectionTpl> & data);

  // algorithm/crba.hpp
  template<typename Scalar, int Options, template<typename, int> class JointCollectionTpl, typename ConfigVectorType>
  const typename DataTpl<Scalar, Options, JointCollectionTpl>::MatrixXs & crba(
    const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
    DataTpl<Scalar, Options, JointCollectionTpl> & data,
    const Eigen::MatrixBase<ConfigVectorType> & q,
    const Convention convention);

  // algorithm/joint-configuration.hpp
  template<
    typename Scalar,
    int Options,
    template<typename, int> class JointCollectionTpl,
    typename ConfigVectorType,
    typename TangentVectorType,
    typename ReturnType>
  void integrate(
    const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
    const Eigen::MatrixBase<ConfigVectorType> & q,
    const Eigen::MatrixBase<TangentVectorType> & v,
    const Eigen::MatrixBase<ReturnType> & qout);

  template<typename Scalar, int Options, template<typename, int> class JointCollectionTpl, typename ReturnType>
  void neutral(const ModelTpl<Scalar, Options, JointCollectionTpl> & model, const Eigen::MatrixBase<ReturnType> & qout);

  template<typename Scalar, int Options, template<typename, int> class JointCollectionTpl, typename ConfigVectorType>
  void normalize(
    const ModelTpl<Scalar, Options, JointCollectionTpl> & model, const Eigen::MatrixBase<ConfigVectorType> & qout);

  // algorithm/constrained-dynamics.hpp
  template<
    typename Scalar,
    int Options,
    template<typename, int> class JointCollectionTpl,
    class ConstraintModel,
    class ConstraintModelAllocator,
    class ConstraintData,
    class ConstraintDataAllocator>
  void initConstraintDynamics(
    const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
    DataTpl<Scalar, Options, JointCollectionTpl> & data,
    const std::vector<ConstraintModel, ConstraintModelAllocator> & contact_models,
    const std::vector<ConstraintData, ConstraintDataAllocator> & contact_datas);

  template<
    typename Scalar,
    int Options,
    template<typename, int> class JointCollectionTpl,
    typename ConfigVectorType,
    typename TangentVectorType1,
    typename TangentVectorType2,
    class ConstraintModelAllocator,
    class ConstraintDataAllocator>
  const typename DataTpl<Scalar, Options, JointCollectionTpl>::TangentVectorType & constraintDynamics(
    const ModelTpl<Scalar, Options, JointCollectionTpl> & model,
    DataTpl<Scalar, Options, JointCollectionTpl> & data,
    const Eigen::MatrixBase<ConfigVectorType> & q,
    const Eigen::MatrixBase<TangentVectorType1> & v,
    const Eigen::MatrixBase<TangentVectorType2> & tau,
    const std::vector<RigidConstraintModelTpl<Scalar, Options>, ConstraintModelAllocator> & contact_models,
    std::vector<RigidConstraintDataTpl<Scalar, Options>, ConstraintDataAllocator> & contact_datas,
    ProximalSettingsTpl<Scalar> & settings);
} // namespace pinocchio

// The calls, with the argument types the library is compiled for.
namespace delta_pin::library
{
  typedef Eigen::VectorXd Vector;
  typedef Eigen::Ref<const Eigen::VectorXd> ConstRef;
  typedef pinocchio::Data::Matrix6x Matrix6x;

  // the joints' placements at q
  inline void forward_kinematics(const pinocchio::Model & model, pinocchio::Data & data, const Vector & q)
  {
    pinocchio::impl::forwardKinematics(model, data, ConstRef(q));
  }

  // placements, velocities and accelerations at (q, v, a)
  inline void forward_kinematics(
    const pinocchio::Model & model, pinocchio::Data & data, const Vector & q, const Vector & v, const Vector & a)
  {
    pinocchio::impl::forwardKinematics(model, data, ConstRef(q), ConstRef(v), ConstRef(a));
  }

  // a frame's placement, from the joints' placements
  inline const pinocchio::SE3 &
  update_frame_placement(const pinocchio::Model & model, pinocchio::Data & data, pinocchio::FrameIndex frame)
  {
    return pinocchio::updateFramePlacement(model, data, frame);
  }

  // the joints' Jacobians from the placements in data
  inline void joint_jacobians(const pinocchio::Model & model, pinocchio::Data & data)
  {
    pinocchio::computeJointJacobians(model, data);
  }

  // a frame's Jacobian (after joint_jacobians) into J (6, nv)
  inline void frame_jacobian(
    const pinocchio::Model & model,
    pinocchio::Data & data,
    pinocchio::FrameIndex frame,
    pinocchio::ReferenceFrame reference,
    Matrix6x & J)
  {
    pinocchio::getFrameJacobian(model, data, frame, reference, J);
  }

  // the joints' Jacobians and their time variation at (q, v)
  inline void
  jacobians_time_variation(const pinocchio::Model & model, pinocchio::Data & data, const Vector & q, const Vector & v)
  {
    pinocchio::impl::computeJointJacobiansTimeVariation(model, data, ConstRef(q), ConstRef(v));
  }

  // a frame's dJ/dt (after jacobians_time_variation) into dJ (6, nv)
  inline void frame_jacobian_time_variation(
    const pinocchio::Model & model,
    pinocchio::Data & data,
    pinocchio::FrameIndex frame,
    pinocchio::ReferenceFrame reference,
    Matrix6x & dJ)
  {
    pinocchio::getFrameJacobianTimeVariation(model, data, frame, reference, dJ);
  }

  // a frame's classical acceleration (after forward_kinematics at (q, v, a))
  inline pinocchio::Motion frame_classical_acceleration(
    const pinocchio::Model & model,
    const pinocchio::Data & data,
    pinocchio::FrameIndex frame,
    pinocchio::ReferenceFrame reference)
  {
    return pinocchio::getFrameClassicalAcceleration(model, data, frame, reference);
  }

  // the joint-space inertia's upper triangle into data.M (CRBA)
  inline const Eigen::MatrixXd & crba(const pinocchio::Model & model, pinocchio::Data & data, const Vector & q)
  {
    return pinocchio::crba(model, data, ConstRef(q), pinocchio::Convention::LOCAL);
  }

  // the Coriolis matrix C(q, v)
  inline const Eigen::MatrixXd &
  coriolis_matrix(const pinocchio::Model & model, pinocchio::Data & data, const Vector & q, const Vector & v)
  {
    return pinocchio::impl::computeCoriolisMatrix(model, data, ConstRef(q), ConstRef(v));
  }

  // the inverse dynamics M(q) a + C(q, v) v + g(q) (RNEA)
  inline const Vector &
  rnea(const pinocchio::Model & model, pinocchio::Data & data, const Vector & q, const Vector & v, const Vector & a)
  {
    return pinocchio::impl::rnea(model, data, ConstRef(q), ConstRef(v), ConstRef(a));
  }

  // the bias forces b(q, v) = C(q, v) v + g(q) (RNEA at zero acceleration)
  inline const Vector &
  nonlinear_effects(const pinocchio::Model & model, pinocchio::Data & data, const Vector & q, const Vector & v)
  {
    return pinocchio::impl::nonLinearEffects(model, data, ConstRef(q), ConstRef(v));
  }

  // the generalised gravity g(q)
  inline const Vector & generalized_gravity(const pinocchio::Model & model, pinocchio::Data & data, const Vector & q)
  {
    return pinocchio::impl::computeGeneralizedGravity(model, data, ConstRef(q));
  }

  // q (+) dv on the model's configuration space
  inline Vector integrate(const pinocchio::Model & model, const Vector & q, const Vector & dv)
  {
    Vector result(model.nq);
    pinocchio::integrate(model, q, dv, result);
    return result;
  }

  // the model's neutral configuration
  inline Vector neutral(const pinocchio::Model & model)
  {
    Vector q(model.nq);
    pinocchio::neutral(model, q);
    return q;
  }

  // q's unit quaternions and complex numbers renormalised, in place
  inline void normalize(const pinocchio::Model & model, Vector & q)
  {
    pinocchio::normalize(model, q);
  }

  inline void init_constraint_dynamics(
    const pinocchio::Model & model,
    pinocchio::Data & data,
    const std::vector<pinocchio::RigidConstraintModel> & models,
    const std::vector<pinocchio::RigidConstraintData> & datas)
  {
    pinocchio::initConstraintDynamics(model, data, models, datas);
  }

  // ddq of the constrained tree under the joint torques tau
  inline const Vector & constraint_dynamics(
    const pinocchio::Model & model,
    pinocchio::Data & data,
    const Vector & q,
    const Vector & v,
    const Vector & tau,
    const std::vector<pinocchio::RigidConstraintModel> & models,
    std::vector<pinocchio::RigidConstraintData> & datas,
    pinocchio::ProximalSettings & settings)
  {
    return pinocchio::constraintDynamics(model, data, q, v, tau, models, datas, settings);
  }
} // namespace delta_pin::library
