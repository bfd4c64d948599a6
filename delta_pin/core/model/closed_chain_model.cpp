// The kinematics and projected dynamics of a closed-chain robot (ClosedChainModel,
// closed_chain.hpp): the closure residual and Jacobian, Newton assembly, S and its derivative, the
// projected M, C, G, a frame's path as a joint reference. A translation unit of its own, apart from
// the plant's (closed_chain.cpp) and the model's rebuilding (model_spec.cpp), so that the
// heaviest parts of the core compile in parallel.

#include "closed_chain.hpp"
#include "multibody.hpp"

#include "checks.hpp"
#include "failure.hpp"
#include "interrupt.hpp"
#include "model_spec.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace delta_pin
{
  using namespace pinocchio;
  using namespace library;

  namespace
  {
    // inverse_kinematics: where Newton stops gaining (the frame's position at the floating-point
    // floor of the loops' closure), a point within this many times the tolerance counts as reached
    constexpr double IK_FLOOR_FACTOR = 1e3;

    // a * b. Each distinct Eigen product expression (a transpose, a product of products, ...)
    // instantiates Eigen's matrix-product kernels anew, and the idle projection's dozens of them
    // took ~80 s of this unit's compilation; through this function they share one.
    Matrix mul(const Matrix & a, const Matrix & b)
    {
      return a * b;
    }

    // x minimising |A x - b| for A of full column rank: LU when square, the normal equations
    // when tall (delta_pin.model.closed_chain.least_squares)
    Matrix least_squares(const Matrix & A, const Matrix & b)
    {
      if (A.rows() == A.cols())
        return A.partialPivLu().solve(b);
      return (A.transpose() * A).partialPivLu().solve(A.transpose() * b);
    }
  } // namespace

  void JointCouplingSpec::polynomial(double q2_value, double & value, double & slope, double & curvature) const
  {
    const double x = v2 < 0 ? 0.0 : q2_value - reference2;
    value = slope = curvature = 0.0;
    double power = 1.0;  // x^k
    for (Eigen::Index k = 0; k < coefficients.size(); ++k)
    {
      value += coefficients[k] * power;
      if (k + 1 < coefficients.size())
        slope += (double)(k + 1) * coefficients[k + 1] * power;
      if (k + 2 < coefficients.size())
        curvature += (double)((k + 2) * (k + 1)) * coefficients[k + 2] * power;
      power *= x;
    }
  }

  void ClosedChainModel::coupling_terms(const Vector & q, const Vector & v, Vector & r, Matrix & J, Vector & drift) const
  {
    const Eigen::Index k = (Eigen::Index)couplings_.size();
    r.resize(k);
    J.setZero(k, pin_->model.nv);
    drift.setZero(k);
    for (Eigen::Index row = 0; row < k; ++row)
    {
      const JointCouplingSpec & c = couplings_[row];
      double value, slope, curvature;
      c.polynomial(c.q2 >= 0 ? q[c.q2] : 0.0, value, slope, curvature);
      r[row] = q[c.q1] - c.reference1 - value;
      J(row, c.v1) = 1.0;
      if (c.v2 >= 0)
      {
        J(row, c.v2) -= slope;
        if (v.size())
          drift[row] = -curvature * v[c.v2] * v[c.v2];
      }
    }
  }

  ClosedChainModel::ClosedChainModel(const ChainDescription & chain)
  : pin_(std::make_unique<Multibody>())
  , closures_(chain.closures)
  , couplings_(chain.couplings)
  , springs_(chain.springs)
  , actuated_q_(chain.actuated_q)
  , actuated_v_(chain.actuated_v)
  , dependent_v_(chain.dependent_v)
  , idle_dof_(chain.idle_dof)
  , end_effector_(chain.end_effector)
  {
    build_model(chain.model, pin_->model);
    // every index the robot's description holds, checked once here for every later call
    const std::string frames = "the model's " + std::to_string(pin_->model.nframes) + " frames";
    const std::string q_entries = "the model's " + std::to_string(pin_->model.nq) + " entries of q";
    const std::string v_entries = "the model's " + std::to_string(pin_->model.nv) + " entries of v";
    check_index((long long)end_effector_, pin_->model.nframes, "end_effector", frames);
    if (actuated_q_.size() != actuated_v_.size())
      throw std::invalid_argument(
        "actuated_q has " + std::to_string(actuated_q_.size()) + " entries, expected one per entry of actuated_v ("
        + std::to_string(actuated_v_.size()) + ")");
    check_indices(actuated_q_, pin_->model.nq, "actuated_q", q_entries);
    check_indices(actuated_v_, pin_->model.nv, "actuated_v", v_entries);
    check_indices(dependent_v_, pin_->model.nv, "dependent_v", v_entries);
    if (idle_dof_ < 0 || idle_dof_ > dependent_v_.size())
      throw std::invalid_argument(
        "idle_dof is " + std::to_string(idle_dof_) + ", expected 0 to the dependent joints' "
        + std::to_string(dependent_v_.size()));
    int size = 0;
    for (size_t k = 0; k < closures_.size(); ++k)
    {
      const ClosureFrames & closure = closures_[k];
      const std::string name = "closures[" + std::to_string(k) + "]";
      check_index((long long)closure.frame1, pin_->model.nframes, name + "'s frame 1", frames);
      check_index((long long)closure.frame2, pin_->model.nframes, name + "'s frame 2", frames);
      check_closure_rows(closure.size, name);
      size += closure.size;
    }
    closure_rows_ = size;
    for (size_t k = 0; k < couplings_.size(); ++k)
    {
      const JointCouplingSpec & c = couplings_[k];
      const std::string name = "couplings[" + std::to_string(k) + "]";
      check_index(c.q1, pin_->model.nq, name + "'s q1", q_entries);
      check_index(c.v1, pin_->model.nv, name + "'s v1", v_entries);
      if ((c.q2 < 0) != (c.v2 < 0))
        throw std::invalid_argument(name + " has q2 = " + std::to_string(c.q2) + " and v2 = " + std::to_string(c.v2)
                                    + ", expected both entries of joint 2 or both -1 (none)");
      if (c.q2 >= 0)
      {
        check_index(c.q2, pin_->model.nq, name + "'s q2", q_entries);
        check_index(c.v2, pin_->model.nv, name + "'s v2", v_entries);
      }
    }
    size += (int)couplings_.size();
    const JointSprings & sp = springs_;
    const Eigen::Index springs = sp.q_index.size();
    check_size(sp.k, springs, "springs.k");  // one per entry of springs.q_index
    check_size(sp.ref, springs, "springs.ref");
    check_size(sp.d, springs, "springs.d");
    if (sp.v_index.size() != springs)
      throw std::invalid_argument(
        "springs.v_index has " + std::to_string(sp.v_index.size()) + " entries, expected one per entry of "
        "springs.q_index (" + std::to_string(springs) + ")");
    check_size(sp.damper_d, sp.damper_v.size(), "springs.damper_d");  // one per entry of springs.damper_v
    check_indices(sp.q_index, pin_->model.nq, "springs.q_index", q_entries);
    check_indices(sp.v_index, pin_->model.nv, "springs.v_index", v_entries);
    check_indices(sp.damper_v, pin_->model.nv, "springs.damper_v", v_entries);
    if (!sp.k.allFinite() || !sp.ref.allFinite() || !sp.d.allFinite() || !sp.damper_d.allFinite())
      throw std::invalid_argument("the joint springs' k, ref, d and damper_d must be finite");
    pin_->data = Data(pin_->model);
    for (JointIndex j = 1; j < (JointIndex)pin_->model.njoints; ++j)
    {
      const std::string kind = pin_->model.joints[j].shortname();
      if (kind == "JointModelUniversal" || kind == "JointModelSphericalZYX" || kind == "JointModelComposite")
        moving_subspace_ = true;
    }
    residual_ = Vector::Zero(size);
    jacobian_ = Matrix::Zero(size, pin_->model.nv);
    frame_jacobian1_.setZero(6, pin_->model.nv);
    frame_jacobian2_.setZero(6, pin_->model.nv);
  }

  ClosedChainModel::ClosedChainModel(const ClosedChainModel & other) = default;
  ClosedChainModel & ClosedChainModel::operator=(const ClosedChainModel & other) = default;
  ClosedChainModel::~ClosedChainModel() = default;

  void ClosedChainModel::subtract_springs(const Vector & q, const Vector & v, Vector & tau) const
  {
    const JointSprings & sp = springs_;
    for (Eigen::Index i = 0; i < sp.v_index.size(); ++i)
      tau[sp.v_index[i]] -= sp.k[i] * (q[sp.q_index[i]] - sp.ref[i]) + sp.d[i] * v[sp.v_index[i]];
    for (Eigen::Index i = 0; i < sp.damper_v.size(); ++i)
      tau[sp.damper_v[i]] -= sp.damper_d[i] * v[sp.damper_v[i]];
  }

  int ClosedChainModel::nq() const
  {
    return pin_->model.nq;
  }

  int ClosedChainModel::nv() const
  {
    return pin_->model.nv;
  }

  bool ClosedChainModel::unactuated() const
  {
    return idle_dof_ > 0 || actuated_v_.size() + dependent_v_.size() < pin_->model.nv;
  }

  const Vector & ClosedChainModel::residual(const Vector & q)
  {
    check_size(q, pin_->model.nq, "q");
    forward_kinematics(pin_->model, pin_->data, q);  // the joints; of the frames, the closures' only
    Eigen::Index row = 0;
    for (const ClosureFrames & closure : closures_)
    {
      const SE3 & M1 = update_frame_placement(pin_->model, pin_->data, closure.frame1);
      const SE3 & M2 = update_frame_placement(pin_->model, pin_->data, closure.frame2);
      residual_.segment<3>(row) = M1.translation() - M2.translation();
      if (closure.size == 6)
        residual_.segment<3>(row + 3) =
          -M1.rotation() * log3(Eigen::Matrix3d(M1.rotation().transpose() * M2.rotation()));
      row += closure.size;
    }
    if (!couplings_.empty())
    {
      Vector r, drift;
      Matrix J;
      coupling_terms(q, Vector(), r, J, drift);
      residual_.tail(r.size()) = r;
    }
    return residual_;
  }

  double ClosedChainModel::closure_gap(const Vector & q)
  {
    if (!q.allFinite())
      return std::numeric_limits<double>::quiet_NaN();
    return largest(residual(q));
  }

  const Matrix & ClosedChainModel::closure_jacobian(const Vector & q)
  {
    forward_kinematics(pin_->model, pin_->data, q);
    return closure_jacobian_at_placements(q);
  }

  const Matrix & ClosedChainModel::closure_jacobian_at_placements(const Vector & q)
  {
    joint_jacobians(pin_->model, pin_->data);  // from the joint placements already in pin_->data
    dependent_factored_ = false;
    Eigen::Index row = 0;
    for (const ClosureFrames & closure : closures_)
    {
      frame_jacobian1_.setZero();
      frame_jacobian2_.setZero();
      library::frame_jacobian(pin_->model, pin_->data, closure.frame1, LOCAL_WORLD_ALIGNED, frame_jacobian1_);
      library::frame_jacobian(pin_->model, pin_->data, closure.frame2, LOCAL_WORLD_ALIGNED, frame_jacobian2_);
      jacobian_.middleRows(row, closure.size) =
        (frame_jacobian1_ - frame_jacobian2_).topRows(closure.size);
      row += closure.size;
    }
    if (!couplings_.empty())
    {
      Vector r, drift;
      Matrix J;
      coupling_terms(q, Vector(), r, J, drift);
      jacobian_.bottomRows(J.rows()) = J;
    }
    return jacobian_;
  }

  bool ClosedChainModel::configuration(
    const Vector & alpha, const Vector & guess, Vector & q, double tolerance, int iterations)
  {
    check_size(alpha, actuated_q_.size(), "alpha");
    check_size(guess, pin_->model.nq, "the initial guess q");
    q = guess;
    for (Eigen::Index i = 0; i < actuated_q_.size(); ++i)
      q[actuated_q_[i]] = alpha[i];
    Vector dv = Vector::Zero(pin_->model.nv);
    for (int iteration = 0; iteration < iterations; ++iteration)
    {
      const Vector r = residual(q);
      if (largest(r) <= tolerance)
        return true;
      closure_jacobian_at_placements(q);
      Vector step = solve_dependent(r);
      const double biggest = step.size() ? step.cwiseAbs().maxCoeff() : 0.0;
      if (biggest > 0.5)
        step *= 0.5 / biggest;
      dv.setZero();
      for (Eigen::Index c = 0; c < dependent_v_.size(); ++c)
        dv[dependent_v_[c]] = -step[c];
      q = library::integrate(pin_->model, q, dv);
      if (!q.allFinite())
        return false;
    }
    residual(q);
    return false;
  }

  Matrix ClosedChainModel::dependent_columns() const
  {
    Matrix A(jacobian_.rows(), dependent_v_.size());
    for (Eigen::Index c = 0; c < dependent_v_.size(); ++c)
      A.col(c) = jacobian_.col(dependent_v_[c]);
    return A;
  }

  void ClosedChainModel::pseudo_inverse(const Matrix & A, Matrix & pinv, Matrix & null_basis) const
  {
    // A full-rank factorisation from the pivoted QR of A^T (a few times cheaper than an SVD):
    // A^T P = Q R, so A = P R^T Q^T = B Q_r^T with B = P R_r^T (rows x r, full column rank) and
    // Q_r the first r columns of Q; then A^+ = Q_r (B^T B)^-1 B^T and the last columns of Q span
    // A's null space. r = the columns less the idle motions (ClosedChainRobot._pseudo_inverse's
    // rank, fixed by the classification).
    const Eigen::Index columns = A.cols(), rank = columns - idle_dof_;
    if (rank > A.rows())
      throw SimulationFailure("the closures' Jacobian has fewer rows than its rank with the idle motions");
    const Eigen::ColPivHouseholderQR<Matrix> qr(A.transpose());
    const Matrix Q = qr.householderQ();
    const Matrix R = qr.matrixR().topRows(rank).triangularView<Eigen::Upper>();
    const Matrix B = qr.colsPermutation() * R.transpose();
    pinv = Q.leftCols(rank) * (B.transpose() * B).llt().solve(B.transpose());
    null_basis = Q.rightCols(idle_dof_);
  }

  void ClosedChainModel::factor_dependent()
  {
    if (dependent_factored_)
      return;
    // once per Jacobian: LU of A (square) or of A^T A (tall), or with idle motions A^+ and N
    dependent_A_ = dependent_columns();
    if (idle_dof_ > 0)
    {
      pseudo_inverse(dependent_A_, dependent_pinv_, dependent_null_basis_);
      dependent_null_ = Matrix::Zero(pin_->model.nv, idle_dof_);
      for (Eigen::Index r = 0; r < dependent_v_.size(); ++r)
        dependent_null_.row(dependent_v_[r]) = dependent_null_basis_.row(r);
    }
    else if (dependent_A_.rows() == dependent_A_.cols())
      dependent_lu_.compute(dependent_A_);
    else
      dependent_lu_.compute(dependent_A_.transpose() * dependent_A_);
    dependent_factored_ = true;
  }

  Matrix ClosedChainModel::solve_dependent(const Matrix & rhs)
  {
    factor_dependent();
    if (idle_dof_ > 0)
      return dependent_pinv_ * rhs;
    if (dependent_A_.rows() == dependent_A_.cols())
      return dependent_lu_.solve(rhs);
    return dependent_lu_.solve(dependent_A_.transpose() * rhs);  // least_squares' normal equations
  }

  Matrix ClosedChainModel::actuated_columns() const
  {
    Matrix B(jacobian_.rows(), actuated_v_.size());
    for (Eigen::Index c = 0; c < actuated_v_.size(); ++c)
      B.col(c) = jacobian_.col(actuated_v_[c]);
    return B;
  }

  Matrix ClosedChainModel::minimum_norm_map()
  {
    const Eigen::Index n = actuated_v_.size();
    const Matrix dependent = -solve_dependent(actuated_columns());
    Matrix S = Matrix::Zero(pin_->model.nv, n);
    for (Eigen::Index c = 0; c < n; ++c)
      S(actuated_v_[c], c) = 1.0;
    for (Eigen::Index r = 0; r < dependent_v_.size(); ++r)
      S.row(dependent_v_[r]) = dependent.row(r);
    return S;
  }

  Matrix ClosedChainModel::mass_matrix(const Vector & q)
  {
    library::crba(pin_->model, pin_->data, q);
    pin_->data.M.triangularView<Eigen::StrictlyLower>() = pin_->data.M.transpose().triangularView<Eigen::StrictlyLower>();
    return pin_->data.M;
  }

  Matrix ClosedChainModel::velocity_map(const Vector & q)
  {
    check_size(q, pin_->model.nq, "q");
    closure_jacobian(q);
    const Matrix S0 = minimum_norm_map();
    if (idle_dof_ == 0)
      return S0;
    // the map of least kinetic energy: S0 less its share along the idle motions N
    const Matrix & N = dependent_null_;
    const Matrix NtM = mul(N.transpose(), mass_matrix(q));
    return S0 - mul(N, mul(NtM, N).partialPivLu().solve(mul(NtM, S0)));
  }

  bool ClosedChainModel::project_state(Vector & q, Vector & v)
  {
    check_size(q, pin_->model.nq, "q");
    check_size(v, pin_->model.nv, "v");
    Vector alpha(actuated_q_.size()), closed;
    for (Eigen::Index i = 0; i < actuated_q_.size(); ++i)
      alpha[i] = q[actuated_q_[i]];
    const bool converged = configuration(alpha, q, closed);
    q = closed;
    if (!converged)
      return false;
    closure_jacobian(q);
    const Vector correction = solve_dependent(jacobian_ * v);
    for (Eigen::Index r = 0; r < dependent_v_.size(); ++r)
      v[dependent_v_[r]] -= correction[r];
    return true;
  }

  Matrix ClosedChainModel::closure_jacobian_derivative(const Vector & q, const Vector & v)
  {
    jacobians_time_variation(pin_->model, pin_->data, q, v);  // getFrameJacobianTimeVariation places the frames
    Matrix J_dot(jacobian_.rows(), pin_->model.nv);
    Eigen::Index row = 0;
    for (const ClosureFrames & closure : closures_)
    {
      frame_jacobian1_.setZero();
      frame_jacobian2_.setZero();
      frame_jacobian_time_variation(pin_->model, pin_->data, closure.frame1, LOCAL_WORLD_ALIGNED, frame_jacobian1_);
      frame_jacobian_time_variation(pin_->model, pin_->data, closure.frame2, LOCAL_WORLD_ALIGNED, frame_jacobian2_);
      J_dot.middleRows(row, closure.size) = (frame_jacobian1_ - frame_jacobian2_).topRows(closure.size);
      row += closure.size;
    }
    J_dot.bottomRows((Eigen::Index)couplings_.size()).setZero();
    for (size_t k = 0; k < couplings_.size(); ++k)  // -p'' v_2 e_2
    {
      const JointCouplingSpec & c = couplings_[k];
      if (c.v2 < 0)
        continue;
      double value, slope, curvature;
      c.polynomial(q[c.q2], value, slope, curvature);
      J_dot(closure_rows_ + (Eigen::Index)k, c.v2) = -curvature * v[c.v2];
    }
    return J_dot;
  }

  void ClosedChainModel::idle_projection(
    const Vector & q, const Vector & alpha_dot, Matrix & S, Matrix & S_dot, Matrix & M, Matrix & C_tree, Vector & v)
  {
    const Eigen::Index nv = pin_->model.nv, n = actuated_v_.size(), nd = dependent_v_.size();
    closure_jacobian(q);
    const Matrix S0 = minimum_norm_map();  // factors J_c's dependent columns A
    const Matrix & A = dependent_A_;
    const Matrix & A_pinv = dependent_pinv_;
    const Matrix & N = dependent_null_;
    const Matrix B = actuated_columns();
    M = mass_matrix(q);
    // every product through mul() (Matrix * Matrix): see mul's comment
    const Matrix Nt = N.transpose(), NtM = mul(Nt, M);
    const Matrix W = mul(NtM, N);
    const Eigen::PartialPivLU<Matrix> W_lu(W);
    const Matrix K = W_lu.solve(NtM);
    const Matrix P = Matrix::Identity(nv, nv) - mul(N, K);
    S = mul(P, S0);
    v = S * alpha_dot;
    const Matrix J_dot = closure_jacobian_derivative(q, v);
    Matrix A_dot(J_dot.rows(), nd), B_dot(J_dot.rows(), n);
    for (Eigen::Index c = 0; c < nd; ++c)
      A_dot.col(c) = J_dot.col(dependent_v_[c]);
    for (Eigen::Index c = 0; c < n; ++c)
      B_dot.col(c) = J_dot.col(actuated_v_[c]);
    const Eigen::Index rows = A.rows(), columns = A.cols();
    // d(A^+)/dt = -A^+ A_dot A^+ + A^+ A^+T A_dot^T (I - A A^+) + (I - A^+ A) A_dot^T A^+T A^+
    const Matrix A_pinv_t = A_pinv.transpose(), A_dot_t = A_dot.transpose();
    const Matrix pinv_dot = -mul(mul(A_pinv, A_dot), A_pinv)
                            + mul(mul(A_pinv, A_pinv_t), mul(A_dot_t, Matrix::Identity(rows, rows) - mul(A, A_pinv)))
                            + mul(mul(Matrix::Identity(columns, columns) - mul(A_pinv, A), A_dot_t), mul(A_pinv_t, A_pinv));
    const Matrix S0_dot_dependent = -(mul(pinv_dot, B) + mul(A_pinv, B_dot));
    const Matrix N_dot_dependent = -mul(mul(A_pinv, A_dot), dependent_null_basis_);
    Matrix S0_dot = Matrix::Zero(nv, n), N_dot = Matrix::Zero(nv, idle_dof_);
    for (Eigen::Index r = 0; r < nd; ++r)
    {
      S0_dot.row(dependent_v_[r]) = S0_dot_dependent.row(r);
      N_dot.row(dependent_v_[r]) = N_dot_dependent.row(r);
    }
    C_tree = coriolis_matrix(pin_->model, pin_->data, q, v);
    const Matrix M_dot = C_tree + C_tree.transpose();
    const Matrix N_dot_t = N_dot.transpose();
    const Matrix W_dot = mul(mul(N_dot_t, M), N) + mul(mul(Nt, M_dot), N) + mul(NtM, N_dot);
    const Matrix K_dot = W_lu.solve(mul(N_dot_t, M) + mul(Nt, M_dot) - mul(W_dot, K));
    const Matrix P_dot = -(mul(N_dot, K) + mul(N, K_dot));
    S_dot = mul(P_dot, S0) + mul(P, S0_dot);
  }

  void ClosedChainModel::reduced_terms(
    const Vector & q, const Vector & alpha_dot, Matrix & M_red, Matrix & C_red, Vector & G_red, Vector & C_alpha_dot)
  {
    check_size(q, pin_->model.nq, "q");
    check_size(alpha_dot, actuated_v_.size(), "alpha_dot");
    Matrix S, S_dot, M, C_tree;
    Vector v, rate;
    if (idle_dof_ > 0)
    {
      idle_projection(q, alpha_dot, S, S_dot, M, C_tree, v);
      rate = S_dot * alpha_dot;
    }
    else
    {
      S = velocity_map(q);  // J_c at q stays in jacobian_
      v = S * alpha_dot;
      const Matrix J_dot = closure_jacobian_derivative(q, v);
      S_dot = Matrix::Zero(pin_->model.nv, S.cols());
      const Matrix S_dot_dependent = -solve_dependent(mul(J_dot, S));
      for (Eigen::Index r = 0; r < dependent_v_.size(); ++r)
        S_dot.row(dependent_v_[r]) = S_dot_dependent.row(r);
      rate = S_dot * alpha_dot;  // -A^+ J_c_dot v: the drift's share of the accelerations
      if (moving_subspace_)  // J_c_dot misses the joints' bias c_J there too; the drift (classical
        rate = dependent_rate(q, v);  // accelerations at zero acceleration) has it
      M = mass_matrix(q);
      C_tree = coriolis_matrix(pin_->model, pin_->data, q, v);
    }
    Vector gravity = generalized_gravity(pin_->model, pin_->data, q);
    const Matrix St = S.transpose();
    const Matrix M_projected = mul(St, mul(M, S));
    M_red = 0.5 * (M_projected + M_projected.transpose());
    C_red = mul(St, mul(C_tree, S) + mul(M, S_dot));
    // C_tree v = nle - g (Pinocchio's Coriolis matrix), so no second RNEA pass -- except for joints
    // whose motion subspace moves with q (universal, ZYX spherical, composite), where Pinocchio
    // 4.1's Coriolis matrix and J_dot miss their bias c_J and only the RNEA gives nle (measured:
    // 0.8-26 N m); C_red keeps them (C alpha_dot is exact, the matrix C is not, for such a model)
    if (moving_subspace_)
      C_alpha_dot = St * (nonlinear_effects(pin_->model, pin_->data, q, v) - gravity + M * rate);
    else
      C_alpha_dot = St * (C_tree * v + M * rate);
    if (springs_.v_index.size() + springs_.damper_v.size() > 0)
    {
      // the springs as forces the model overcomes: k (q - ref) with gravity in G, S^T D S in C
      // (ClosedChainRobot.joint_spring_forces)
      const Vector zero = Vector::Zero(pin_->model.nv);
      Vector stiffness = Vector::Zero(pin_->model.nv);
      subtract_springs(q, zero, stiffness);
      gravity -= stiffness;
      Vector damping = Vector::Zero(pin_->model.nv);
      for (Eigen::Index i = 0; i < springs_.v_index.size(); ++i)
        damping[springs_.v_index[i]] += springs_.d[i];
      for (Eigen::Index i = 0; i < springs_.damper_v.size(); ++i)
        damping[springs_.damper_v[i]] += springs_.damper_d[i];
      const Matrix damped = mul(St, damping.asDiagonal() * S);
      C_red += damped;
      C_alpha_dot += damped * alpha_dot;
    }
    G_red = St * gravity;
  }

  Vector ClosedChainModel::actuated_torque(const Vector & q, const Vector & alpha_dot, const Vector & alpha_ddot)
  {
    check_size(q, pin_->model.nq, "q");
    check_size(alpha_dot, actuated_v_.size(), "alpha_dot");
    check_size(alpha_ddot, actuated_v_.size(), "alpha_ddot");
    if (idle_dof_ > 0)  // S of least kinetic energy and its rate: the projection's matrices
    {
      Matrix M, C;
      Vector G, C_alpha_dot;
      reduced_terms(q, alpha_dot, M, C, G, C_alpha_dot);
      return M * alpha_ddot + C_alpha_dot + G;
    }
    // S^T (M (S alpha_ddot + S_dot alpha_dot) + C_tree v + g) = M_red alpha_ddot + C_red alpha_dot + G_red;
    // S_dot alpha_dot from the closure's drift and the joints' bias c_J by the RNEA itself (what
    // reduced_terms does for joints whose motion subspace moves with q)
    const Matrix S = velocity_map(q);  // J_c at q stays in jacobian_ for dependent_rate
    const Vector v = S * alpha_dot;
    const Vector a = S * alpha_ddot + dependent_rate(q, v);
    Vector tau = rnea(pin_->model, pin_->data, q, v, a);
    if (springs_.v_index.size() + springs_.damper_v.size() > 0)
    {
      Vector forces = Vector::Zero(pin_->model.nv);  // minus what the springs and dampers exert
      subtract_springs(q, v, forces);
      tau -= forces;
    }
    return S.transpose() * tau;
  }

  void ClosedChainModel::path_coefficients(
    const Vector & q, const Vector & d1, const Vector & d2, Vector & a, Vector & b, Vector & c0, Vector & damping)
  {
    check_size(q, pin_->model.nq, "q");
    check_size(d1, actuated_v_.size(), "d1");
    check_size(d2, actuated_v_.size(), "d2");
    if (idle_dof_ > 0)
    {
      // C(d1) d1 = Q(d1) + D d1 with Q quadratic: Q = (C(2 d1) 2 d1 - 2 C(d1) d1) / 2
      Matrix M, C;
      Vector c_once, c_twice;
      reduced_terms(q, 2.0 * d1, M, C, c0, c_twice);
      reduced_terms(q, d1, M, C, c0, c_once);
      const Vector quadratic = 0.5 * (c_twice - 2.0 * c_once);
      a = M * d1;
      b = M * d2 + quadratic;
      damping = c_once - quadratic;
      return;
    }
    const Matrix S = velocity_map(q);  // J_c at q stays in jacobian_ for dependent_rate
    const Vector v = S * d1;
    const Vector zero = Vector::Zero(pin_->model.nv);
    const Vector gravity = generalized_gravity(pin_->model, pin_->data, q);  // a copy: the RNEA reuses the data
    const Vector inertial = rnea(pin_->model, pin_->data, q, zero, v) - gravity;  // M S d1 (v = S d1)
    // M (S d2 + S_dot d1) + C_tree v: the Coriolis torque of the projection at alpha_dot = d1
    const Vector moving = rnea(pin_->model, pin_->data, q, v, Vector(S * d2 + dependent_rate(q, v))) - gravity;
    Vector at_rest = zero, moving_springs = zero;  // minus the springs' (and dampers') forces
    subtract_springs(q, zero, at_rest);
    subtract_springs(q, v, moving_springs);
    const Matrix St = S.transpose();
    a = St * inertial;
    b = St * moving;
    c0 = St * (gravity - at_rest);
    damping = St * (at_rest - moving_springs);
  }

  Vector ClosedChainModel::closure_drift(const Vector & q, const Vector & v)
  {
    forward_kinematics(pin_->model, pin_->data, q, v, Vector::Zero(pin_->model.nv));
    Vector drift(jacobian_.rows());
    Eigen::Index row = 0;
    for (const ClosureFrames & closure : closures_)
    {
      const Motion a1 = frame_classical_acceleration(pin_->model, pin_->data, closure.frame1, LOCAL_WORLD_ALIGNED);
      const Motion a2 = frame_classical_acceleration(pin_->model, pin_->data, closure.frame2, LOCAL_WORLD_ALIGNED);
      drift.segment<3>(row) = a1.linear() - a2.linear();
      if (closure.size == 6)
        drift.segment<3>(row + 3) = a1.angular() - a2.angular();
      row += closure.size;
    }
    if (!couplings_.empty())
    {
      Vector r, coupling_drift;
      Matrix J;
      coupling_terms(q, v, r, J, coupling_drift);
      drift.tail(coupling_drift.size()) = coupling_drift;
    }
    return drift;
  }

  Vector ClosedChainModel::dependent_rate(const Vector & q, const Vector & v)
  {
    const Vector rate_dependent = -solve_dependent(closure_drift(q, v));  // J_c at q in jacobian_
    Vector rate = Vector::Zero(pin_->model.nv);
    for (Eigen::Index r = 0; r < dependent_v_.size(); ++r)
      rate[dependent_v_[r]] = rate_dependent[r];
    return rate;
  }

  Eigen::Vector3d ClosedChainModel::end_effector_position(const Vector & q)
  {
    check_size(q, pin_->model.nq, "q");
    forward_kinematics(pin_->model, pin_->data, q);
    return update_frame_placement(pin_->model, pin_->data, end_effector_).translation();
  }

  void ClosedChainModel::check_frame(FrameIndex frame) const
  {
    check_index((long long)frame, pin_->model.nframes, "frame", "the model's " + std::to_string(pin_->model.nframes) + " frames");
  }

  Matrix ClosedChainModel::frame_jacobian(const Vector & q, FrameIndex frame)
  {
    check_frame(frame);
    return frame_jacobian_of(velocity_map(q), frame);  // the joint Jacobians at q stay in pin_->data
  }

  Matrix ClosedChainModel::frame_jacobian_of(const Matrix & S, FrameIndex frame)
  {
    frame_jacobian1_.setZero();
    library::frame_jacobian(pin_->model, pin_->data, frame, LOCAL_WORLD_ALIGNED, frame_jacobian1_);
    return frame_jacobian1_ * S;
  }

  Eigen::Vector3d ClosedChainModel::frame_drift_of(const Vector & q, const Vector & v, FrameIndex frame)
  {
    const Vector rate = dependent_rate(q, v);
    forward_kinematics(pin_->model, pin_->data, q, v, rate);
    return frame_classical_acceleration(pin_->model, pin_->data, frame, LOCAL_WORLD_ALIGNED).linear();
  }

  Eigen::Vector3d ClosedChainModel::frame_acceleration_drift(const Vector & q, const Vector & alpha_dot, FrameIndex frame)
  {
    check_frame(frame);
    check_size(q, pin_->model.nq, "q");
    check_size(alpha_dot, actuated_v_.size(), "alpha_dot");
    if (idle_dof_ == 0)
      return frame_drift_of(q, velocity_map(q) * alpha_dot, frame);
    Vector v;
    Matrix S, S_dot, M, C_tree;
    idle_projection(q, alpha_dot, S, S_dot, M, C_tree, v);
    forward_kinematics(pin_->model, pin_->data, q, v, Vector(S_dot * alpha_dot));
    return frame_classical_acceleration(pin_->model, pin_->data, frame, LOCAL_WORLD_ALIGNED).linear();
  }

  bool ClosedChainModel::inverse_kinematics(
    const Eigen::Vector3d & target, FrameIndex frame, const Indices & rows, Vector & alpha, Vector & q,
    double tolerance, int iterations)
  {
    check_frame(frame);
    check_size(alpha, actuated_q_.size(), "alpha");
    for (Eigen::Index r = 0; r < rows.size(); ++r)
      check_index(rows[r], 3, "rows[" + std::to_string(r) + "]", "the task coordinates x, y, z");
    Vector assembled;
    Vector error(rows.size());
    Matrix J(rows.size(), actuated_v_.size());
    double previous = std::numeric_limits<double>::infinity();
    for (int iteration = 0; iteration < iterations; ++iteration)
    {
      if (!configuration(alpha, q, assembled))
        return false;
      q = assembled;
      forward_kinematics(pin_->model, pin_->data, q);
      const Eigen::Vector3d position = update_frame_placement(pin_->model, pin_->data, frame).translation();
      for (Eigen::Index r = 0; r < rows.size(); ++r)
        error[r] = position[rows[r]] - target[rows[r]];
      const double gap = largest(error);
      if (gap <= tolerance)
        return true;
      // Newton has stopped gaining at the floating-point floor of the loops' closure (itself solved
      // to `tolerance`, so the frame's position can sit just above it): reached, within
      // IK_FLOOR_FACTOR x tolerance
      if (gap > 0.5 * previous && gap <= IK_FLOOR_FACTOR * tolerance)
        return true;
      previous = gap;
      const Matrix J_frame = frame_jacobian(q, frame);
      for (Eigen::Index r = 0; r < rows.size(); ++r)
        J.row(r) = J_frame.row(rows[r]);
      Vector step = least_squares(J, error);
      const double biggest = step.size() ? step.cwiseAbs().maxCoeff() : 0.0;
      if (biggest > 0.2)
        step *= 0.2 / biggest;
      alpha -= step;
    }
    return false;
  }

  long ClosedChainModel::joint_reference(
    FrameIndex frame, const Indices & rows, const Vector & times, const RowMatrix & xyz, const RowMatrix & xyz_dot,
    const RowMatrix & xyz_ddot, const Vector & alpha0, Vector & q, RowMatrix & alpha, RowMatrix & alpha_dot,
    RowMatrix & alpha_ddot, RowMatrix & actual)
  {
    const Eigen::Index n = times.size(), dof = actuated_v_.size();
    check_frame(frame);
    if (rows.size() != dof)
      throw std::invalid_argument(
        "rows has " + std::to_string(rows.size()) + " entries, expected one task coordinate per actuator ("
        + std::to_string(dof) + ")");
    for (Eigen::Index r = 0; r < rows.size(); ++r)
      check_index(rows[r], 3, "rows[" + std::to_string(r) + "]", "the task coordinates x, y, z");
    check_shape(xyz, n, 3, "xyz");
    check_shape(xyz_dot, n, 3, "xyz_dot");
    check_shape(xyz_ddot, n, 3, "xyz_ddot");
    if (xyz.rows() != n || xyz_dot.rows() != n || xyz_ddot.rows() != n)
      throw std::invalid_argument(
        "xyz, xyz_dot and xyz_ddot have " + std::to_string(xyz.rows()) + ", " + std::to_string(xyz_dot.rows()) + " and "
        + std::to_string(xyz_ddot.rows()) + " rows, expected one per time (" + std::to_string(n) + ")");
    check_finite(times, "times");
    check_finite(xyz, "xyz");
    check_finite(xyz_dot, "xyz_dot");
    check_finite(xyz_ddot, "xyz_ddot");
    check_size(alpha0, dof, "alpha0");
    check_finite(alpha0, "alpha0");
    check_size(q, pin_->model.nq, "q_start");
    alpha.resize(n, dof);
    alpha_dot.resize(n, dof);
    alpha_ddot.resize(n, dof);
    actual.resize(n, 3);
    Vector guess = alpha0;
    Matrix J(dof, dof);
    Vector task(dof);
    for (Eigen::Index k = 0; k < n; ++k)
    {
      poll_interrupt();
      if (k > 0)
      {
        const double step = times[k] - times[k - 1];
        guess = alpha.row(k - 1).transpose() + step * alpha_dot.row(k - 1).transpose()
                + 0.5 * step * step * alpha_ddot.row(k - 1).transpose();
      }
      if (!inverse_kinematics(xyz.row(k).transpose(), frame, rows, guess, q))
        return (long)k;
      // one S for the frame's Jacobian and its drift where there are no idle motions
      const bool idle = idle_dof_ > 0;
      const Matrix S = idle ? Matrix() : velocity_map(q);
      const Matrix J_frame = idle ? frame_jacobian(q, frame) : frame_jacobian_of(S, frame);
      for (Eigen::Index r = 0; r < dof; ++r)
        J.row(r) = J_frame.row(rows[r]);
      Eigen::PartialPivLU<Matrix> lu(J);
      alpha.row(k) = guess.transpose();
      for (Eigen::Index r = 0; r < dof; ++r)
        task[r] = xyz_dot(k, rows[r]);
      const Vector rates = lu.solve(task);
      alpha_dot.row(k) = rates.transpose();
      const Eigen::Vector3d drift = idle ? frame_acceleration_drift(q, rates, frame) : frame_drift_of(q, S * rates, frame);
      for (Eigen::Index r = 0; r < dof; ++r)
        task[r] = xyz_ddot(k, rows[r]) - drift[rows[r]];
      alpha_ddot.row(k) = lu.solve(task).transpose();
      // the drift's forward pass left q's placements in the data
      actual.row(k) = update_frame_placement(pin_->model, pin_->data, frame).translation().transpose();
    }
    return -1;
  }
} // namespace delta_pin
