// What the compiled core's run needs of a plant (docs/architecture.md section 8): its steppers
// (run.hpp: RK4 sub-steps under a held torque; Radau IIA or BDF2 in active coordinates) run any
// plant that implements CorePlant --
// the constrained plant of a closed chain (closed_chain.hpp) or the paper's reduced Delta
// (analytic_plant.hpp) -- and both plants read their time-varying truth from one TruthTable.
#pragma once

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace delta_pin
{
  typedef Eigen::VectorXd Vector;
  typedef Eigen::MatrixXd Matrix;
  typedef Eigen::VectorXi Indices;
  typedef Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> RowMatrix;

  // The plant's time-varying truth (delta_pin/sim/truth.py) tabulated at t = i step, i < rows:
  // the payload body's mass [kg], a point mass [kg], the friction's normal forces [N] and the
  // joint disturbance [N m] on the actuated joints. A column without rows is the plant's own
  // (nominal) value. Read by time, at the row position u = t / step: the row itself where u is a
  // whole number to 1e-9 (the sampled loop's stage times, whose t = k dt + j h carries round-off),
  // linear interpolation between rows elsewhere (the continuous loop), the last row past the end.
  struct TruthTable
  {
    double step = 0.0;  // [s]
    Vector body_masses, point_masses;
    RowMatrix normal_forces, disturbances;

    double position(double t) const
    {
      if (!(step > 0.0))
        return 0.0;
      const double u = t / step, row = std::round(u);
      return std::abs(u - row) <= 1e-9 * std::max(1.0, row) ? row : u;
    }
    static double value(const Vector & column, double u, double fallback)
    {
      if (column.size() == 0)
        return fallback;
      Eigen::Index k;
      double w;
      split(column.size(), u, k, w);
      return w == 0.0 ? column[k] : (1.0 - w) * column[k] + w * column[k + 1];
    }
    // entry i of a table's row position u (fallback where the table has no rows)
    static double value(const RowMatrix & table, double u, Eigen::Index i, double fallback)
    {
      if (table.rows() == 0)
        return fallback;
      Eigen::Index k;
      double w;
      split(table.rows(), u, k, w);
      return w == 0.0 ? table(k, i) : (1.0 - w) * table(k, i) + w * table(k + 1, i);
    }

  private:
    // the row k and the weight w of row k + 1 at u, in a table of `rows` rows
    static void split(Eigen::Index rows, double u, Eigen::Index & k, double & w)
    {
      const Eigen::Index last = rows - 1;
      if (!(u > 0.0))
      {
        k = 0;
        w = 0.0;
        return;
      }
      k = (Eigen::Index)u;
      if (k >= last)
      {
        k = last;
        w = 0.0;
        return;
      }
      w = u - (double)k;
    }
  };

  // One classical RK4 step of length h of x' = f(x, t) in place from time t [s], the stages at t,
  // t + h/2, t + h/2, t + h; f(x, t, dx). k1..k4 and y are the caller's scratch (no allocation
  // once sized).
  template<typename Derivative>
  void rk4_step(Vector & x, double t, double h, Derivative && f, Vector & k1, Vector & k2, Vector & k3, Vector & k4, Vector & y)
  {
    f(x, t, k1);
    y = x + 0.5 * h * k1;
    f(y, t + 0.5 * h, k2);
    y = x + 0.5 * h * k2;
    f(y, t + 0.5 * h, k3);
    y = x + h * k3;
    f(y, t + h, k4);
    x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
  }

  // A plant of the core's loops, x = [q, v] (for the reduced Delta q = alpha, v = alpha_dot).
  class CorePlant
  {
  public:
    virtual ~CorePlant() = default;

    virtual int nq() const = 0;
    virtual int nv() const = 0;
    int dof() const { return (int)actuated_v_.size(); }
    // the actuated joints' entries in q and in v
    const Indices & actuated_q() const { return actuated_q_; }
    const Indices & actuated_v() const { return actuated_v_; }
    // whether x's q and v are a multibody configuration worth recording (a run keeps them)
    virtual bool has_configuration() const = 0;

    // One RK4 step of length h [s] from time t [s] under the held actuated torque tau, the truth
    // read by time at t, t + h/2, t + h (TruthTable::position); returns the closure gap of the
    // result [m, rad]. May throw SimulationFailure (without a time).
    virtual double step(Vector & x, const Vector & tau, double t, double h) = 0;
    virtual Eigen::Vector3d end_effector_position(const Vector & q) = 0;
    // (alpha, alpha_dot) of the state x: its actuated entries (a plant whose state holds them
    // elsewhere says where)
    virtual void joint_state(const Vector & x, Vector & alpha, Vector & alpha_dot)
    {
      const int nq = this->nq();
      for (Eigen::Index i = 0; i < actuated_q_.size(); ++i)
        alpha[i] = x[actuated_q_[i]];
      for (Eigen::Index i = 0; i < actuated_v_.size(); ++i)
        alpha_dot[i] = x[nq + actuated_v_[i]];
    }
    virtual double closure_gap(const Vector & q) = 0;

    // The continuous loop in active coordinates: q (warm start in, the configuration out) and
    // v at the actuated (alpha, alpha_dot); false where the loops cannot be closed there.
    virtual bool complete(const Vector & alpha, const Vector & alpha_dot, Vector & q, Vector & v) = 0;
    // the actuated joints' accelerations at (q, v) under tau [N m] with the truth at time t [s]
    virtual void active_accelerations(double t, const Vector & q, const Vector & v, const Vector & tau, Vector & alpha_ddot) = 0;

    // Whether the continuous loop integrates the whole state x = [q, v] instead of (alpha,
    // alpha_dot): the plant moves in ways the actuated joints do not determine (idle motions,
    // passive joints), so completing (q, v) from them would lose that motion.
    virtual bool integrates_full_state() const { return false; }
    // dx/dt at the whole state x under tau with the truth at time t [s] (integrates_full_state)
    virtual void full_derivative(double /*t*/, const Vector & /*x*/, const Vector & /*tau*/, Vector & /*dx*/)
    {
      throw std::logic_error("this plant is integrated in active coordinates");
    }
    // x brought back onto the loops where its closure gap exceeds the plant's projection
    // tolerance (integrates_full_state); whether it changed x. May throw SimulationFailure.
    virtual bool project(Vector & /*x*/) { return false; }

    // the truth of the run (TruthTable); rows of normal forces and disturbances have dof() columns
    virtual void set_truth_table(const TruthTable & truth) = 0;

    long projections() const { return projections_; }
    // the largest closure gap a projection brought back [m, rad] (0 before one)
    double largest_projected_gap() const { return largest_projected_gap_; }
  protected:
    Indices actuated_q_, actuated_v_;
    long projections_ = 0;
    double largest_projected_gap_ = 0.0;
  };
} // namespace delta_pin
