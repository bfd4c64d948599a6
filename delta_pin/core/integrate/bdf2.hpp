// BDF2 with fixed steps h, the second integrator of the core's continuous mode (run.hpp):
//
//     y_1 - y_0 = h f(t_1, y_1);    y_{n+1} - 4/3 y_n + 1/3 y_{n-1} = 2/3 h f(t_{n+1}, y_{n+1}),
//
// second order and A-stable, its stages on the step grid (where the reference and the truth
// tables are exact). Why it suits the paper's continuous mode (docs/architecture.md section 6):
// inside the robust term's boundary layer the closed loop is a damper of gain Lambda^2 / xi, and
// a fully implicit step with Newton's method lands on the layer's equivalent control.
//
// Each step is solved by Newton's method on y - anchor - c h f(y) = 0 from a quadratic
// extrapolation of the last three points, with a forward-difference Jacobian and its LU factors
// reused across steps while the iteration contracts (re-computed when it needs backtracking or
// more than STALE_ITERATIONS iterations), a backtracking line search (the steep tanh of the
// friction sign and the layer's kink defeat plain Newton; a trial point where f cannot be
// evaluated counts as a worse one), and the stopping test of Hairer & Wanner (IV.8): the last
// correction, or theta / (1 - theta) times it with theta the observed contraction, below
// NEWTON_TOLERANCE. Where Newton fails on a step (the first milliseconds of a reaching phase), the
// step is retried as 2, 4, ... 1024 implicit Euler sub-steps. The arithmetic of the Delta's
// former compiled BDF2 (numba), which the figures of section 6 were measured with.
#pragma once

#include "failure.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>

namespace delta_pin
{
  struct Bdf2Counters
  {
    long steps = 0, evaluations = 0, split_steps = 0, jacobians = 0;
  };

  class Bdf2
  {
  public:
    typedef Eigen::VectorXd Vector;
    typedef Eigen::MatrixXd Matrix;
    // f(t, y, dy): the right-hand side; it throws SimulationFailure where it cannot be evaluated
    typedef std::function<void(double, const Vector &, Vector &)> Function;

    static constexpr double NEWTON_TOLERANCE = 1e-10;  // largest correction accepted (rad, rad/s, -)
    static constexpr int MAX_NEWTON_ITERATIONS = 12;
    static constexpr int STALE_ITERATIONS = 3;  // iterations on a reused Jacobian before a new one
    static constexpr int MAX_SPLIT_DEPTH = 10;  // a failing step retried as 2, 4, ... 1024 Euler steps

    Bdf2(Function f, const Vector & y0, double t0, double h)
    : f_(std::move(f)), n_((int)y0.size()), h_(h), t_(t0), y_(y0), previous_(y0), previous2_(y0)
    {
      if (!(h > 0.0))
        throw std::invalid_argument("BDF2 needs a step h > 0");
      J_ = Matrix::Zero(n_, n_);
    }

    double t() const { return t_; }
    const Vector & y() const { return y_; }

    // One step of length h. Throws SimulationFailure where Newton does not converge even on the
    // finest split or f cannot be evaluated at the solution.
    void step()
    {
      const double t_next = t_ + h_;
      double c;
      if (taken_ == 0)
      {
        anchor_ = y_;
        c = 1.0;
        guess_ = y_;
      }
      else
      {
        anchor_ = (4.0 * y_ - previous_) / 3.0;
        c = 2.0 / 3.0;
        if (taken_ == 1)
          guess_ = 2.0 * y_ - previous_;
        else
          guess_ = 3.0 * (y_ - previous_) + previous2_;
      }
      bool converged = implicit_step(t_next, anchor_, c, h_, guess_, next_);
      int depth = 0;
      while (!converged && depth < MAX_SPLIT_DEPTH)
      {
        ++depth;
        converged = split_step(depth, next_);
      }
      if (depth > 0)
      {
        ++counters.split_steps;
        valid_ = false;
      }
      if (!converged)
        throw failure_at(
          "bdf2: Newton's method did not converge even on 1024 sub-steps: the fixed-step BDF2 cannot follow "
          "this run's robust term (on the Adept cycle its damper gain reaches ~5e7 N m s/rad); "
          "integrator='radau' (the default) or 'lsoda' can",
          t_next);
      ++taken_;
      ++counters.steps;
      previous2_ = previous_;
      previous_ = y_;
      y_ = next_;
      t_ = t_next;
    }

    Bdf2Counters counters;

  private:
    // f at (t, y); false where it cannot be evaluated there
    bool evaluate(double t, const Vector & y, Vector & dy)
    {
      ++counters.evaluations;
      try
      {
        f_(t, y, dy);
      }
      catch (const SimulationFailure &)
      {
        return false;
      }
      return dy.allFinite();
    }

    void jacobian(double t, const Vector & y, const Vector & dy)
    {
      Vector & shifted = shifted_;
      Vector & shifted_dot = shifted_dot_;
      shifted = y;
      shifted_dot.resize(n_);
      for (int i = 0; i < n_; ++i)
      {
        const double step = 1e-8 * std::max(1.0, std::abs(y[i]));
        shifted[i] = y[i] + step;
        if (!evaluate(t, shifted, shifted_dot))
          f_(t, shifted, shifted_dot);  // raise the failure where a neighbour cannot be evaluated
        shifted[i] = y[i];
        J_.col(i) = (shifted_dot - dy) / step;
      }
      ++counters.jacobians;
    }

    // Solve y = anchor + c h f(t, y) from `guess` by Newton with backtracking; false where it does
    // not converge in MAX_NEWTON_ITERATIONS. Throws where f cannot be evaluated at the start.
    bool implicit_step(double t, const Vector & anchor, double c, double h, const Vector & guess, Vector & y)
    {
      const double ch = c * h;
      y = guess;
      // the scratch of the iteration, the integrator's own (no allocation once sized)
      Vector & y_dot = y_dot_;
      Vector & residual = residual_;
      Vector & delta = delta_;
      Vector & trial = trial_;
      Vector & trial_dot = trial_dot_;
      Vector & trial_residual = trial_residual_;
      Eigen::PartialPivLU<Matrix> & lu = lu_;
      y_dot.resize(n_);
      trial_dot.resize(n_);
      if (!evaluate(t, y, y_dot))
        f_(t, y, y_dot);  // the failure, with its message
      residual = y - anchor - ch * y_dot;
      double norm = residual.norm();
      int since_refresh = 0;
      double previous = std::numeric_limits<double>::infinity();
      bool factored = false;
      for (int iteration = 0; iteration < MAX_NEWTON_ITERATIONS; ++iteration)
      {
        if (!valid_ || since_refresh >= STALE_ITERATIONS)
        {
          jacobian(t, y, y_dot);
          valid_ = true;
          since_refresh = 0;
          previous = std::numeric_limits<double>::infinity();
          factored = false;
        }
        if (!factored)  // one factorisation of I - ch J per Jacobian (and step)
        {
          lu.compute(Matrix::Identity(n_, n_) - ch * J_);
          factored = true;
        }
        ++since_refresh;
        delta = lu.solve(-residual);
        const double largest = delta.cwiseAbs().maxCoeff();
        if (!std::isfinite(largest))
        {
          valid_ = false;
          throw failure_at("bdf2: the run diverged (|alpha_dot| > 1000 rad/s or a non-finite state)", t);
        }
        const double theta = largest / previous;
        if (largest <= NEWTON_TOLERANCE || (0.0 < theta && theta < 0.5 && theta / (1.0 - theta) * largest <= NEWTON_TOLERANCE))
        {
          y += delta;
          return true;
        }
        previous = largest;
        double fraction = 1.0, trial_norm;
        bool ok;
        while (true)  // backtracking
        {
          trial = y + fraction * delta;
          ok = evaluate(t, trial, trial_dot);
          trial_norm = std::numeric_limits<double>::infinity();
          if (ok)
          {
            trial_residual = trial - anchor - ch * trial_dot;
            trial_norm = trial_residual.norm();
          }
          if (trial_norm <= (1.0 - 1e-4 * fraction) * norm || fraction < 1e-3)
            break;
          fraction *= 0.5;
        }
        if (!ok)
        {
          valid_ = false;
          f_(t, trial, trial_dot);  // the failure, with its message
        }
        if (fraction < 1.0)
        {
          previous = std::numeric_limits<double>::infinity();  // theta estimates full steps only
          if (since_refresh > 1)
            valid_ = false;  // a stale Jacobian that needs backtracking: refresh it
        }
        y = trial;
        residual = trial_residual;
        y_dot = trial_dot;
        norm = trial_norm;
      }
      valid_ = false;
      return false;
    }

    // Cross the step by 2^depth implicit Euler steps from y_; false where one does not converge
    bool split_step(int depth, Vector & y)
    {
      const long parts = 1L << depth;
      const double small = h_ / (double)parts;
      y = y_;
      valid_ = false;
      Vector next;
      for (long m = 0; m < parts; ++m)
      {
        if (!implicit_step(t_ + (double)(m + 1) * small, y, 1.0, small, y, next))
          return false;
        y = next;
      }
      return true;
    }

    Function f_;
    int n_;
    double h_, t_;
    Vector y_, previous_, previous2_;
    Matrix J_;
    // step()'s and implicit_step()'s vectors and factors, kept between steps
    Vector anchor_, guess_, next_, y_dot_, residual_, delta_, trial_, trial_dot_, trial_residual_, shifted_,
      shifted_dot_;
    Eigen::PartialPivLU<Matrix> lu_;
    bool valid_ = false;
    long taken_ = 0;  // steps taken: the first is implicit Euler, the predictor's order grows to 2
  };
} // namespace delta_pin
