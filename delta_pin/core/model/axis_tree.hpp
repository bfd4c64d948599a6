// Constrained forward dynamics of a tree of 1-DOF axis joints closed by point constraints,
// written out for that case: the default stage of delta-pin's compiled sampled loops on the
// Pinocchio plant (docs/architecture.md, section 8).
//
// It computes what pinocchio::constraintDynamics computes for these models (CONTACT_3D closures
// in LOCAL frames, Baumgarte gains, proximal mu = 0 with one iteration: the exact KKT solution),
//
//     M(q) ddq = tau - nle(q, v) + J_c^T lambda,      J_c ddq = rhs(q, v)   (Baumgarte),
//
// with the recursive algorithms of Featherstone's "Rigid Body Dynamics Algorithms" (2008) in world
// coordinates, specialised to revolute and prismatic joints along a frame axis (RX .. PZ):
//
// 1. forward pass: body placements, world joint axes S_i, velocities v_i, bias accelerations
//    (ddq = 0) a_i, body forces f_i = I_i (a_i - g) + v_i x* I_i v_i (RNEA, RBDA 5.3);
// 2. backward pass: nle_i = S_i . f_i, composite inertias and M by the composite-rigid-body
//    algorithm (RBDA 6.2), only the entries M_ij with j an ancestor of i (the tree's sparsity);
// 3. M = L^T D L with the tree's sparsity (RBDA 6.5, "LTDL"), no fill-in;
// 4. the closure Jacobian and right-hand side (the anchors' relative classical acceleration in the
//    first anchor's frame, Pinocchio's convention), then the KKT system by its Schur complement:
//    with V = D^-1/2 L^-T J_c^T and u = D^-1/2 L^-T (tau - nle), the Delassus matrix J_c M^-1 J_c^T
//    = V^T V and J_c M^-1 (tau - nle) = V^T u; lambda from its Cholesky factor; then
//    ddq = L^-1 D^-1/2 (u + V lambda).
//
// Only the kinematic tree's own numbers are read (placements, inertias, gravity, closures), the
// same that build the Pinocchio model. It agrees with pinocchio::constraintDynamics to ~1e-13
// relative (tests/sim/test_native.py), not bit for bit: the order of the floating-point operations
// differs. It costs ~1.9 us a call on the Delta's 12-joint tree, against ~5.2 us
// (benchmarks/bench_mujoco.py).
//
// Spatial vectors are in world coordinates at the world origin: a motion (linear, angular) =
// (velocity of the body point at the origin, angular velocity); a force (linear, angular) =
// (force, moment about the origin). Inertias are kept as (mass m, first moment h = m c, rotational
// inertia about the origin I_O), which add for composite bodies.

#ifndef DELTA_PIN_AXIS_TREE_HPP
#define DELTA_PIN_AXIS_TREE_HPP

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace dpn
{
  typedef Eigen::Vector3d Vec3;
  typedef Eigen::Matrix3d Mat3;

  // A motion or a force: (linear, angular) in world coordinates at the origin.
  struct Spatial
  {
    Vec3 linear = Vec3::Zero();
    Vec3 angular = Vec3::Zero();
  };

  // A rigid-body inertia about the world origin: mass, first moment h = m c, rotational inertia.
  struct Inertia
  {
    double mass = 0.0;
    Vec3 first_moment = Vec3::Zero();
    Mat3 rotational = Mat3::Zero();

    // The momentum I v of a motion v: (m v_lin - h x omega, I_O omega + h x v_lin).
    Spatial times(const Spatial & v) const
    {
      Spatial out;
      out.linear = mass * v.linear - first_moment.cross(v.angular);
      out.angular = rotational * v.angular + first_moment.cross(v.linear);
      return out;
    }

    void add(const Inertia & other)
    {
      mass += other.mass;
      first_moment += other.first_moment;
      rotational += other.rotational;
    }
  };

  inline double dot(const Spatial & a, const Spatial & b)
  {
    return a.linear.dot(b.linear) + a.angular.dot(b.angular);
  }

  // v x m for motions v, m (RBDA eq. 2.31).
  inline Spatial cross_motion(const Spatial & v, const Spatial & m)
  {
    Spatial out;
    out.linear = v.angular.cross(m.linear) + v.linear.cross(m.angular);
    out.angular = v.angular.cross(m.angular);
    return out;
  }

  // v x* f for a motion v and a force f (RBDA eq. 2.32).
  inline Spatial cross_force(const Spatial & v, const Spatial & f)
  {
    Spatial out;
    out.linear = v.angular.cross(f.linear);
    out.angular = v.angular.cross(f.angular) + v.linear.cross(f.linear);
    return out;
  }

  struct AxisJoint
  {
    int parent;  // index of the parent joint, -1 for the world
    bool revolute;
    int axis;  // 0, 1, 2: x, y, z of the joint frame
    Mat3 placement_rotation;  // the joint frame in its parent's, at q = 0
    bool placement_turns;  // placement_rotation is not the identity
    Vec3 placement_translation;
    double mass;  // the body on the joint, in the joint frame
    Vec3 com;
    Mat3 com_inertia;  // about the COM
    bool massless;  // mass and inertia zero
  };

  struct PointClosure
  {
    int joints[2];  // -1 for the world
    Mat3 rotations[2];  // the anchors' frames in their joints' frames
    Vec3 translations[2];
    // the joints that move an anchor (the two joints and their ancestors), in decreasing order:
    // the only nonzero columns of the closure's Jacobian rows, and of their L^-T images
    std::vector<int> support;
  };

  class AxisTree
  {
  public:
    // types: 0..5 = RX, RY, RZ, PX, PY, PZ; parents: 0 for the world, else the parent's 1-based
    // index, smaller than the joint's own (Pinocchio's order); placements: 12 numbers each (the
    // rotation row by row, then the translation); inertias: 13 each (mass, COM (3), rotational
    // inertia about the COM row by row (9)); closures: the two joints (0: world) and the anchor
    // placements (24 numbers each); kp [1/s^2], kd [1/s] the Baumgarte gains.
    AxisTree(
      int joints, const int * parents, const int * types, const double * placements,
      const double * inertias, const double * gravity, int closures, const int * closure_joints,
      const double * anchors, double kp, double kd, int platform_joint)
    : kp_(kp), kd_(kd), platform_(platform_joint - 1)
    {
      gravity_ = Eigen::Map<const Vec3>(gravity);
      for (int i = 0; i < joints; ++i)
      {
        if (types[i] < 0 || types[i] > 5)
          throw std::invalid_argument("joint type code " + std::to_string(types[i]) + " is not in 0..5");
        if (parents[i] < 0 || parents[i] > i)
          throw std::invalid_argument("joint " + std::to_string(i + 1) + " comes before its parent");
        AxisJoint joint;
        joint.parent = parents[i] - 1;
        joint.revolute = types[i] < 3;
        joint.axis = types[i] % 3;
        joint.placement_rotation = rowMajor(placements + 12 * i);
        joint.placement_turns = !joint.placement_rotation.isIdentity(0.0);
        joint.placement_translation = Eigen::Map<const Vec3>(placements + 12 * i + 9);
        const double * inertia = inertias + 13 * i;
        joint.mass = inertia[0];
        joint.com = Eigen::Map<const Vec3>(inertia + 1);
        joint.com_inertia = rowMajor(inertia + 4);
        joint.massless = joint.mass == 0.0 && joint.com_inertia.isZero(0.0);
        joints_.push_back(joint);
      }
      for (int j = joints - 1; j >= 0; --j)
        all_joints_.push_back(j);
      for (const AxisJoint & joint : joints_)
        parent_.push_back(joint.parent);
      for (int c = 0; c < closures; ++c)
      {
        PointClosure closure;
        for (int side = 0; side < 2; ++side)
        {
          closure.joints[side] = closure_joints[2 * c + side] - 1;
          closure.rotations[side] = rowMajor(anchors + 24 * c + 12 * side);
          closure.translations[side] = Eigen::Map<const Vec3>(anchors + 24 * c + 12 * side + 9);
        }
        std::vector<bool> moves((size_t)joints, false);
        for (int side = 0; side < 2; ++side)
          for (int j = closure.joints[side]; j >= 0; j = parent_[(size_t)j])
            moves[(size_t)j] = true;
        for (int j = joints - 1; j >= 0; --j)
          if (moves[(size_t)j])
            closure.support.push_back(j);
        closures_.push_back(closure);
      }
      for (int a = 0; a < closures; ++a)  // the joints two closures share, for J M^-1 J^T
        for (int b = 0; b <= a; ++b)
        {
          std::vector<int> shared;
          for (int j : closures_[(size_t)a].support)
            for (int k : closures_[(size_t)b].support)
              if (j == k)
                shared.push_back(j);
          shared_.push_back(shared);
        }
      const int n = joints, rows = 3 * closures;
      rotation_.resize(n);
      position_.resize(n);
      axis_.resize(n);
      velocity_.resize(n);
      bias_.resize(n);
      force_.resize(n);
      composite_.resize(n);
      mass_matrix_ = Eigen::MatrixXd::Zero(n, n);
      nle_.resize(n);
      inverse_root_d_.resize(n);
      jacobian_ = Eigen::MatrixXd::Zero(rows, n);
      rhs_.resize(rows);
      scaled_ = Eigen::MatrixXd::Zero(n, rows);
      free_.resize(n);
      delassus_ = Eigen::MatrixXd::Zero(rows, rows);
      multipliers_.resize(rows);
    }

    int nv() const
    {
      return (int)joints_.size();
    }

    // the body of joint `joint` (1-based) given a new mass [kg], COM in the joint frame [m] and
    // rotational inertia about the COM [kg m^2] (a payload added to it)
    void set_body(int joint, double mass, const Vec3 & com, const Mat3 & com_inertia)
    {
      AxisJoint & body = joints_.at((size_t)(joint - 1));
      body.mass = mass;
      body.com = com;
      body.com_inertia = com_inertia;
      body.massless = mass == 0.0 && com_inertia.isZero(0.0);
    }

    // ddq (nv) at (q, v) under joint torques tau (nv), the platform body's mass [kg] and
    // rotational inertia about its COM (9 numbers, row by row) set first. Returns false where M or
    // the Delassus matrix is not positive definite (a massless mechanism, dependent closures).
    bool dynamics(
      const double * q, const double * v, const double * tau, double mass, const double * rotational,
      double * ddq)
    {
      if (platform_ >= 0)
      {
        AxisJoint & platform = joints_[(size_t)platform_];
        platform.mass = mass;
        platform.com_inertia = rowMajor(rotational);
        platform.massless = mass == 0.0 && platform.com_inertia.isZero(0.0);
      }
      forwardPass(q, v);
      backwardPass();
      if (!factorise())
        return false;
      closureTerms();
      return solve(tau, ddq);
    }

    // The closures' gap at q: the largest coordinate of p_1 - p_2 over the closures' anchor points
    // (world coordinates) [m], NaN where one is NaN -- ClosedChainModel::closure_gap's value for a
    // tree of point closures, from the placements alone
    double closureGap(const double * q)
    {
      for (size_t i = 0; i < joints_.size(); ++i)
        place(i, q[i]);
      double gap = 0.0;
      for (const PointClosure & closure : closures_)
      {
        Vec3 points[2];
        for (int side = 0; side < 2; ++side)
        {
          const int j = closure.joints[side];
          points[side] = j < 0 ? closure.translations[side]
                               : Vec3(position_[(size_t)j] + rotation_[(size_t)j] * closure.translations[side]);
        }
        for (int k = 0; k < 3; ++k)
        {
          const double difference = std::abs(points[0][k] - points[1][k]);
          if (std::isnan(difference))
            return difference;
          gap = std::max(gap, difference);
        }
      }
      return gap;
    }

  private:
    static Mat3 rowMajor(const double * numbers)
    {
      return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(numbers);
    }

    // Joint i's frame at q_i (its parent's placed first): rotation_, position_ and the axis as a
    // motion axis_ (world coordinates at the origin). Forced inline: called out of line from the
    // forward pass it cost ~280 instructions a joint more (callgrind, the Delta's sampled run).
    __attribute__((always_inline)) inline void place(size_t i, double q_i)
    {
      const AxisJoint & joint = joints_[i];
      const int p = joint.parent;
      const Mat3 parent_rotation = p < 0 ? Mat3::Identity() : rotation_[(size_t)p];
      const Vec3 parent_position = p < 0 ? Vec3::Zero() : position_[(size_t)p];
      // the joint frame at q = 0
      const Mat3 frame = joint.placement_turns ? Mat3(parent_rotation * joint.placement_rotation) : parent_rotation;
      Vec3 position = parent_position + parent_rotation * joint.placement_translation;
      const Vec3 axis = frame.col(joint.axis);
      Spatial & s = axis_[i];
      if (joint.revolute)
      {
        rotation_[i] = frame;  // times the rotation about `axis`: it turns the other two columns
        const double c = std::cos(q_i), sn = std::sin(q_i);
        const int a = (joint.axis + 1) % 3, b = (joint.axis + 2) % 3;
        rotation_[i].col(a) = c * frame.col(a) + sn * frame.col(b);
        rotation_[i].col(b) = c * frame.col(b) - sn * frame.col(a);
        s.linear = position.cross(axis);  // the velocity at the origin of a turn about the axis
        s.angular = axis;
      }
      else
      {
        rotation_[i] = frame;
        position += q_i * axis;
        s.linear = axis;
        s.angular.setZero();
      }
      position_[i] = position;
    }

    // Step 1: placements, axes, velocities, bias accelerations, RNEA body forces, body inertias.
    void forwardPass(const double * q, const double * v)
    {
      const Spatial at_rest;
      for (size_t i = 0; i < joints_.size(); ++i)
      {
        place(i, q[i]);
        const AxisJoint & joint = joints_[i];
        const int p = joint.parent;
        const Spatial & s = axis_[i];
        const Vec3 & position = position_[i];
        const Spatial & parent_velocity = p < 0 ? at_rest : velocity_[(size_t)p];
        Spatial joint_velocity;
        joint_velocity.linear = v[i] * s.linear;
        joint_velocity.angular = v[i] * s.angular;
        velocity_[i].linear = parent_velocity.linear + joint_velocity.linear;
        velocity_[i].angular = parent_velocity.angular + joint_velocity.angular;
        const Spatial & parent_bias = p < 0 ? at_rest : bias_[(size_t)p];
        const Spatial coriolis = cross_motion(velocity_[i], joint_velocity);
        bias_[i].linear = parent_bias.linear + coriolis.linear;
        bias_[i].angular = parent_bias.angular + coriolis.angular;
        // the body's inertia about the origin: I_O = R I_c R^T + m (|c|^2 1 - c c^T), c in world
        Inertia & body = composite_[i];
        if (joint.massless)  // a body without mass or inertia (a cross, a slide): no force
        {
          body = Inertia();
          force_[i] = Spatial();
          continue;
        }
        const Vec3 com = position + rotation_[i] * joint.com;
        body.mass = joint.mass;
        body.first_moment = joint.mass * com;
        body.rotational = rotation_[i] * joint.com_inertia * rotation_[i].transpose()
                          + joint.mass * (com.squaredNorm() * Mat3::Identity() - com * com.transpose());
        Spatial acceleration = bias_[i];
        acceleration.linear -= gravity_;
        const Spatial momentum = body.times(velocity_[i]);
        const Spatial inertial = body.times(acceleration);
        const Spatial gyroscopic = cross_force(velocity_[i], momentum);
        force_[i].linear = inertial.linear + gyroscopic.linear;
        force_[i].angular = inertial.angular + gyroscopic.angular;
      }
    }

    // Step 2: nle by the RNEA's backward pass; M by the CRBA, on and below the tree's ancestors.
    void backwardPass()
    {
      for (int i = (int)joints_.size() - 1; i >= 0; --i)
      {
        const int p = parent_[(size_t)i];
        const Spatial & s = axis_[(size_t)i];
        nle_[i] = dot(s, force_[(size_t)i]);
        const Spatial f = composite_[(size_t)i].times(s);  // the subtree's momentum per unit rate
        mass_matrix_(i, i) = dot(s, f);
        for (int j = p; j >= 0; j = parent_[(size_t)j])
          mass_matrix_(i, j) = mass_matrix_(j, i) = dot(axis_[(size_t)j], f);
        if (p >= 0)
        {
          force_[(size_t)p].linear += force_[(size_t)i].linear;
          force_[(size_t)p].angular += force_[(size_t)i].angular;
          composite_[(size_t)p].add(composite_[(size_t)i]);
        }
      }
    }

    // Step 3: M = L^T D L in place (RBDA Table 6.3): D on the diagonal, L below it, on the
    // ancestors' entries only; and D^-1/2.
    bool factorise()
    {
      Eigen::MatrixXd & m = mass_matrix_;
      for (int k = (int)joints_.size() - 1; k >= 0; --k)
      {
        if (!(m(k, k) > 0.0))
          return false;
        for (int i = parent_[(size_t)k]; i >= 0; i = parent_[(size_t)i])
        {
          const double a = m(k, i) / m(k, k);
          for (int j = i; j >= 0; j = parent_[(size_t)j])
            m(i, j) -= a * m(k, j);
          m(k, i) = a;
        }
        inverse_root_d_[k] = 1.0 / std::sqrt(m(k, k));
      }
      return true;
    }

    // x <- D^-1/2 L^-T x (RBDA Table 6.4's first half, then the scaling), for x nonzero only on
    // `support` (joints in decreasing order, closed under ancestors; the image stays on it).
    void halfSolve(double * x, const std::vector<int> & support) const
    {
      for (int k : support)
        for (int i = parent_[(size_t)k]; i >= 0; i = parent_[(size_t)i])
          x[i] -= mass_matrix_(k, i) * x[k];
      for (int k : support)
        x[k] *= inverse_root_d_[k];
    }

    // The velocity of a point of joint j's body at `point` [m], and its classical acceleration
    // with ddq = 0; zero for the world (j = -1).
    void pointMotion(int j, const Vec3 & point, Vec3 & velocity, Vec3 & drift) const
    {
      if (j < 0)
      {
        velocity.setZero();
        drift.setZero();
        return;
      }
      const Spatial & vj = velocity_[(size_t)j];
      const Spatial & aj = bias_[(size_t)j];
      velocity = vj.linear + vj.angular.cross(point);
      drift = aj.linear + aj.angular.cross(point) + vj.angular.cross(velocity);
    }

    // Step 4a: J_c and rhs, three rows per closure in the first anchor's frame: the anchors'
    // relative acceleration J_c ddq + drift_1 - drift_2 = -kp e - kd e_dot with
    // e = R_c1^T (p_1 - p_2), e_dot = R_c1^T (p_1_dot - p_2_dot) (Pinocchio's Baumgarte
    // corrector).
    void closureTerms()
    {
      jacobian_.setZero();
      for (size_t c = 0; c < closures_.size(); ++c)
      {
        const PointClosure & closure = closures_[c];
        Vec3 points[2], velocities[2], drifts[2];
        Mat3 frame = closure.rotations[0];
        for (int side = 0; side < 2; ++side)
        {
          const int j = closure.joints[side];
          points[side] = j < 0 ? closure.translations[side]
                               : Vec3(position_[(size_t)j] + rotation_[(size_t)j] * closure.translations[side]);
          if (side == 0 && j >= 0)
            frame = rotation_[(size_t)j] * closure.rotations[0];
          pointMotion(j, points[side], velocities[side], drifts[side]);
        }
        const Eigen::Index row = 3 * (Eigen::Index)c;
        for (int side = 0; side < 2; ++side)
        {
          const double sign = side == 0 ? 1.0 : -1.0;
          for (int j = closure.joints[side]; j >= 0; j = parent_[(size_t)j])
          {
            const Spatial & s = axis_[(size_t)j];
            jacobian_.block<3, 1>(row, j) += sign * (frame.transpose() * (s.linear + s.angular.cross(points[side])));
          }
        }
        const Vec3 error = frame.transpose() * (points[0] - points[1]);
        const Vec3 error_rate = frame.transpose() * (velocities[0] - velocities[1]);
        rhs_.segment<3>(row) = frame.transpose() * (drifts[1] - drifts[0]) - kp_ * error - kd_ * error_rate;
      }
    }

    // x <- D^-1/2 L^-T x for the three columns of one closure at once (`first` and the next two
    // of scaled_), which share the closure's support: the ancestor walk is done once for the three.
    void halfSolveClosure(Eigen::Index first, const std::vector<int> & support)
    {
      double * x0 = scaled_.col(first).data();
      double * x1 = scaled_.col(first + 1).data();
      double * x2 = scaled_.col(first + 2).data();
      for (int k : support)
      {
        const double a0 = x0[k], a1 = x1[k], a2 = x2[k];
        for (int i = parent_[(size_t)k]; i >= 0; i = parent_[(size_t)i])
        {
          const double l = mass_matrix_(k, i);
          x0[i] -= l * a0;
          x1[i] -= l * a1;
          x2[i] -= l * a2;
        }
      }
      for (int k : support)
      {
        const double d = inverse_root_d_[k];
        x0[k] *= d;
        x1[k] *= d;
        x2[k] *= d;
      }
    }

    // Step 4b: the KKT system by its Schur complement (see the file's head), closure by closure:
    // V's three columns of a closure share its support, so V^T u, V^T V (a 3 x 3 block per pair of
    // closures, over the joints they share) and V lambda are formed a block at a time.
    bool solve(const double * tau, double * ddq)
    {
      const Eigen::Index n = (Eigen::Index)joints_.size(), rows = rhs_.size();
      const size_t closures = closures_.size();
      for (Eigen::Index i = 0; i < n; ++i)
        free_[i] = tau[i] - nle_[i];
      halfSolve(free_.data(), all_joints_);  // u
      scaled_ = jacobian_.transpose();
      for (size_t a = 0; a < closures; ++a)
        halfSolveClosure(3 * (Eigen::Index)a, closures_[a].support);  // V
      for (size_t a = 0; a < closures; ++a)
      {
        const Eigen::Index ra = 3 * (Eigen::Index)a;
        const double * va[3] = {scaled_.col(ra).data(), scaled_.col(ra + 1).data(), scaled_.col(ra + 2).data()};
        double product[3] = {0.0, 0.0, 0.0};
        for (int k : closures_[a].support)
          for (int r = 0; r < 3; ++r)
            product[r] += va[r][k] * free_[k];
        for (int r = 0; r < 3; ++r)
          multipliers_[ra + r] = rhs_[ra + r] - product[r];
        for (size_t b = 0; b <= a; ++b)
        {
          const Eigen::Index rb = 3 * (Eigen::Index)b;
          const double * vb[3] = {scaled_.col(rb).data(), scaled_.col(rb + 1).data(), scaled_.col(rb + 2).data()};
          double block[3][3] = {{0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}};
          for (int k : shared_[a * (a + 1) / 2 + b])
            for (int r = 0; r < 3; ++r)
              for (int c = 0; c < 3; ++c)
                block[r][c] += va[r][k] * vb[c][k];
          for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3 && rb + c <= ra + r; ++c)  // the lower triangle
              delassus_(ra + r, rb + c) = block[r][c];
        }
      }
      // Cholesky of the Delassus matrix (lower triangle; the diagonal keeps 1 / L_jj), then lambda
      for (Eigen::Index j = 0; j < rows; ++j)
      {
        double diagonal = delassus_(j, j);
        for (Eigen::Index m = 0; m < j; ++m)
          diagonal -= delassus_(j, m) * delassus_(j, m);
        if (!(diagonal > 0.0))
          return false;
        const double inverse = 1.0 / std::sqrt(diagonal);
        delassus_(j, j) = inverse;
        for (Eigen::Index i = j + 1; i < rows; ++i)
        {
          double value = delassus_(i, j);
          for (Eigen::Index m = 0; m < j; ++m)
            value -= delassus_(i, m) * delassus_(j, m);
          delassus_(i, j) = value * inverse;
        }
      }
      for (Eigen::Index i = 0; i < rows; ++i)
      {
        double value = multipliers_[i];
        for (Eigen::Index m = 0; m < i; ++m)
          value -= delassus_(i, m) * multipliers_[m];
        multipliers_[i] = value * delassus_(i, i);
      }
      for (Eigen::Index i = rows - 1; i >= 0; --i)
      {
        double value = multipliers_[i];
        for (Eigen::Index m = i + 1; m < rows; ++m)
          value -= delassus_(m, i) * multipliers_[m];
        multipliers_[i] = value * delassus_(i, i);
      }
      // ddq = L^-1 D^-1/2 (u + V lambda)
      for (size_t a = 0; a < closures; ++a)
      {
        const Eigen::Index ra = 3 * (Eigen::Index)a;
        const double * v0 = scaled_.col(ra).data();
        const double * v1 = scaled_.col(ra + 1).data();
        const double * v2 = scaled_.col(ra + 2).data();
        const double l0 = multipliers_[ra], l1 = multipliers_[ra + 1], l2 = multipliers_[ra + 2];
        for (int k : closures_[a].support)
          free_[k] += v0[k] * l0 + v1[k] * l1 + v2[k] * l2;
      }
      for (Eigen::Index k = 0; k < n; ++k)
        free_[k] *= inverse_root_d_[k];
      for (Eigen::Index k = 0; k < n; ++k)
      {
        double value = free_[k];
        for (int i = parent_[(size_t)k]; i >= 0; i = parent_[(size_t)i])
          value -= mass_matrix_(k, i) * free_[i];
        free_[k] = value;
        ddq[k] = value;
      }
      return true;
    }

    std::vector<AxisJoint> joints_;
    std::vector<PointClosure> closures_;
    std::vector<int> parent_;  // joints_[j].parent, packed: the hot loops walk ancestors through it
    std::vector<int> all_joints_;  // n - 1, ..., 0
    std::vector<std::vector<int>> shared_;  // the joints closures a >= b share, at a (a + 1) / 2 + b
    Vec3 gravity_;
    double kp_, kd_;
    int platform_;  // the 0-based joint whose body the payload changes, -1 for none
    // per evaluation
    std::vector<Mat3> rotation_;
    std::vector<Vec3> position_;
    std::vector<Spatial> axis_, velocity_, bias_, force_;
    std::vector<Inertia> composite_;
    Eigen::MatrixXd mass_matrix_, jacobian_, scaled_, delassus_;
    Eigen::VectorXd nle_, inverse_root_d_, rhs_, free_, multipliers_;
  };
} // namespace dpn

#endif
