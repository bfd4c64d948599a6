// Radau IIA of order 5 (three stages) with error control, for y' = f(t, y): the continuous-mode
// integrator of the compiled core, Eigen only.
//
// The method of Hairer & Wanner, Solving Ordinary Differential Equations II, section IV.8
// (RADAU5), arranged as SciPy's scipy.integrate.Radau (tests/sim/test_core_continuous.py holds runs
// with it to a tight LSODA reference):
// the collocation system solved by simplified Newton on the transformed system (one real and one
// complex n x n factorisation of MU/h I - J), J by forward differences, the embedded error
// estimate through the real factorisation, step-size prediction by Gustafsson's controller,
// continuous output by the collocation polynomial (the outputs between steps cost no step).
#pragma once

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <complex>
#include <functional>
#include <limits>
#include <stdexcept>

namespace delta_pin
{
  struct RadauOptions
  {
    double rtol = 1e-6;  // relative tolerance
    double atol = 1e-8;  // absolute tolerance
    double first_step = 1e-4;  // [s]
    double max_step = std::numeric_limits<double>::infinity();  // [s]
    double t_bound = std::numeric_limits<double>::infinity();  // [s]: no step, no stage beyond it
  };

  struct RadauCounters
  {
    long steps = 0, rejected = 0, evaluations = 0, jacobians = 0, factorizations = 0;
  };

  class RadauIIA
  {
  public:
    typedef Eigen::VectorXd Vector;
    typedef Eigen::MatrixXd Matrix;
    // f(t, y, dy): the right-hand side; it throws (SimulationFailure) where it cannot be evaluated
    typedef std::function<void(double, const Vector &, Vector &)> Function;

    RadauIIA(Function f, const Vector & y0, double t0, const RadauOptions & options)
    : f_(std::move(f)), options_(options), n_((int)y0.size()), t_(t0), y_(y0)
    {
      if (!(options.rtol > 0.0) || !(options.atol > 0.0) || !(options.first_step > 0.0))
        throw std::invalid_argument("Radau IIA needs rtol, atol and first_step > 0");
      // rtol below ~100 eps cannot be met in double precision (SciPy raises it likewise)
      options_.rtol = std::max(options_.rtol, 100.0 * std::numeric_limits<double>::epsilon());
      f0_.resize(n_);
      evaluate(t_, y_, f0_);
      h_abs_ = std::min(options.first_step, options.max_step);
      newton_tol_ = std::max(10.0 * eps() / options_.rtol, std::min(0.03, std::sqrt(options_.rtol)));
      jacobian(t_, y_, f0_);
    }

    double t() const { return t_; }
    const Vector & y() const { return y_; }
    RadauCounters counters;

    // Take steps until t() >= t_end; returns y at t_out (t() - last step <= t_out <= t()) from the
    // collocation polynomial of the last step.
    void advance_past(double t_out)
    {
      if (t_out > options_.t_bound)
        throw std::invalid_argument("Radau IIA cannot advance past its t_bound");
      while (t_ < t_out)
        step();
    }

    // y at t in [t_old, t] of the last step (the collocation polynomial; y0 before any step)
    Vector at(double t) const
    {
      if (!stepped_)
        return y_;
      const double x = (t - t_old_) / h_;
      const Eigen::Vector3d p(x, x * x, x * x * x);
      return y_old_ + Q_ * p;
    }

  private:
    static double eps() { return std::numeric_limits<double>::epsilon(); }

    void evaluate(double t, const Vector & y, Vector & dy)
    {
      dy.resize(n_);
      f_(t, y, dy);
      ++counters.evaluations;
      if (!dy.allFinite())
        throw std::runtime_error("the right-hand side is not finite");
    }

    // J = df/dy by forward differences (SciPy's num_jac step: sqrt(eps) scaled by |y|)
    void jacobian(double t, const Vector & y, const Vector & f)
    {
      J_.resize(n_, n_);
      Vector yp = y, fp(n_);
      for (int j = 0; j < n_; ++j)
      {
        const double scale = std::max(std::abs(y[j]), options_.atol / options_.rtol);
        double h = std::sqrt(eps()) * scale;
        yp[j] = y[j] + h;
        h = yp[j] - y[j];  // the step the arithmetic took
        evaluate(t, yp, fp);
        J_.col(j) = (fp - f) / h;
        yp[j] = y[j];
      }
      current_jacobian_ = true;
      factored_ = false;
      ++counters.jacobians;
    }

    void factor(double h)
    {
      const double mu_real = 3.0 + std::cbrt(9.0) - std::cbrt(3.0);
      const std::complex<double> mu_complex(
        3.0 + 0.5 * (std::cbrt(3.0) - std::cbrt(9.0)), -0.5 * (std::pow(3.0, 5.0 / 6.0) + std::pow(3.0, 7.0 / 6.0)));
      lu_real_.compute(Matrix::Identity(n_, n_) * (mu_real / h) - J_);
      lu_complex_.compute(
        Eigen::MatrixXcd::Identity(n_, n_) * (mu_complex / h) - J_.cast<std::complex<double>>());
      factored_ = true;
      ++counters.factorizations;
    }

    static double rms(const Eigen::ArrayXd & x) { return std::sqrt(x.square().mean()); }

    // the collocation system by simplified Newton from Z (rows: stages); false where it does not
    // converge; iterations and the contraction rate in its arguments
    bool solve_collocation(double h, const Vector & scale, Matrix & Z, int & iterations, double & rate)
    {
      static const double S6 = std::sqrt(6.0);
      static const double C[3] = {(4.0 - S6) / 10.0, (4.0 + S6) / 10.0, 1.0};
      static const double T[3][3] = {
        {0.09443876248897524, -0.14125529502095421, 0.03002919410514742},
        {0.25021312296533332, 0.20412935229379994, -0.38294211275726192},
        {1.0, 1.0, 0.0}};
      static const double TI[3][3] = {
        {4.17871859155190428, 0.32768282076106237, 0.52337644549944951},
        {-4.17871859155190428, -0.32768282076106237, 0.47662355450055044},
        {0.50287263494578682, -2.57192694985560522, 0.59603920482822492}};
      const double mu_real = 3.0 + std::cbrt(9.0) - std::cbrt(3.0);
      const std::complex<double> mu_complex(
        3.0 + 0.5 * (std::cbrt(3.0) - std::cbrt(9.0)), -0.5 * (std::pow(3.0, 5.0 / 6.0) + std::pow(3.0, 7.0 / 6.0)));
      Matrix W(3, n_), F(3, n_), dW(3, n_);
      for (int i = 0; i < 3; ++i)
        W.row(i) = TI[i][0] * Z.row(0) + TI[i][1] * Z.row(1) + TI[i][2] * Z.row(2);
      Vector stage(n_), value(n_);
      double previous = -1.0;
      rate = -1.0;
      for (int k = 0; k < kNewtonIterations; ++k)
      {
        iterations = k + 1;
        for (int i = 0; i < 3; ++i)
        {
          stage = y_ + Z.row(i).transpose();
          evaluate(t_ + C[i] * h, stage, value);
          F.row(i) = value.transpose();
        }
        const Vector f_real = TI[0][0] * F.row(0) + TI[0][1] * F.row(1) + TI[0][2] * F.row(2);
        const Vector f_imag1 = TI[1][0] * F.row(0) + TI[1][1] * F.row(1) + TI[1][2] * F.row(2);
        const Vector f_imag2 = TI[2][0] * F.row(0) + TI[2][1] * F.row(1) + TI[2][2] * F.row(2);
        const Vector r_real = f_real - (mu_real / h) * W.row(0).transpose();
        const Eigen::VectorXcd w_complex =
          W.row(1).transpose().cast<std::complex<double>>() + std::complex<double>(0.0, 1.0) * W.row(2).transpose();
        const Eigen::VectorXcd r_complex =
          (f_imag1.cast<std::complex<double>>() + std::complex<double>(0.0, 1.0) * f_imag2) - (mu_complex / h) * w_complex;
        const Vector d_real = lu_real_.solve(r_real);
        const Eigen::VectorXcd d_complex = lu_complex_.solve(r_complex);
        dW.row(0) = d_real.transpose();
        dW.row(1) = d_complex.real().transpose();
        dW.row(2) = d_complex.imag().transpose();
        Eigen::ArrayXd scaled(3 * n_);
        for (int i = 0; i < 3; ++i)
          scaled.segment(i * n_, n_) = dW.row(i).transpose().array() / scale.array();
        const double norm = rms(scaled);
        if (previous >= 0.0)
          rate = norm / previous;
        if (rate >= 0.0
            && (rate >= 1.0 || std::pow(rate, kNewtonIterations - k) / (1.0 - rate) * norm > newton_tol_))
          return false;
        W += dW;
        for (int i = 0; i < 3; ++i)
          Z.row(i) = T[i][0] * W.row(0) + T[i][1] * W.row(1) + T[i][2] * W.row(2);
        if (norm == 0.0 || (rate >= 0.0 && rate / (1.0 - rate) * norm < newton_tol_))
          return true;
        previous = norm;
      }
      return false;
    }

    double predict_factor(double h_abs, double error_norm) const
    {
      double multiplier = 1.0;
      if (error_norm_old_ >= 0.0 && h_abs_old_ > 0.0 && error_norm > 0.0)
        multiplier = h_abs / h_abs_old_ * std::pow(error_norm_old_ / error_norm, 0.25);
      return std::min(1.0, multiplier) * (error_norm > 0.0 ? std::pow(error_norm, -0.25) : 1e300);
    }

    void step()
    {
      static const double S6 = std::sqrt(6.0);
      static const double C[3] = {(4.0 - S6) / 10.0, (4.0 + S6) / 10.0, 1.0};
      static const double E[3] = {(-13.0 - 7.0 * S6) / 3.0, (-13.0 + 7.0 * S6) / 3.0, -1.0 / 3.0};
      static const double P[3][3] = {
        {13.0 / 3.0 + 7.0 * S6 / 3.0, -23.0 / 3.0 - 22.0 * S6 / 3.0, 10.0 / 3.0 + 5.0 * S6},
        {13.0 / 3.0 - 7.0 * S6 / 3.0, -23.0 / 3.0 + 22.0 * S6 / 3.0, 10.0 / 3.0 - 5.0 * S6},
        {1.0 / 3.0, -8.0 / 3.0, 10.0 / 3.0}};
      const double min_step = 10.0 * std::abs(std::nextafter(t_, std::numeric_limits<double>::infinity()) - t_);
      double h_abs = h_abs_;
      if (h_abs > options_.max_step)
      {
        h_abs = options_.max_step;
        h_abs_old_ = -1.0;
        error_norm_old_ = -1.0;
      }
      else if (h_abs < min_step)
      {
        h_abs = min_step;
        h_abs_old_ = -1.0;
        error_norm_old_ = -1.0;
      }
      bool rejected = false;
      Matrix Z(3, n_);
      Vector y_new(n_), scale(n_), error(n_), ZE(n_), f_error(n_);
      double error_norm = 0.0, safety = 0.9, rate = -1.0;
      int iterations = 0;
      for (;;)
      {
        if (h_abs < min_step)
          throw std::runtime_error("the step size fell below its minimum");
        if (t_ + h_abs > options_.t_bound)  // the last step ends on t_bound (SciPy's t_bound)
          h_abs = options_.t_bound - t_;
        const double h = h_abs;
        Matrix Z0(3, n_);
        if (stepped_)  // the last step's collocation polynomial, extrapolated
          for (int i = 0; i < 3; ++i)
            Z0.row(i) = (at(t_ + C[i] * h) - y_).transpose();
        else
          Z0.setZero();
        scale = options_.atol + y_.array().abs() * options_.rtol;
        bool converged = false;
        for (;;)
        {
          if (!factored_ || factored_h_ != h)
          {
            factor(h);
            factored_h_ = h;
          }
          Z = Z0;  // each attempt (a fresh Jacobian) starts from the prediction
          converged = solve_collocation(h, scale, Z, iterations, rate);
          if (converged || current_jacobian_)
            break;
          jacobian(t_, y_, f0_);
        }
        if (!converged)
        {
          h_abs *= 0.5;
          ++counters.rejected;
          continue;
        }
        y_new = y_ + Z.row(2).transpose();
        ZE = (E[0] * Z.row(0) + E[1] * Z.row(1) + E[2] * Z.row(2)).transpose() / h;
        error = lu_real_.solve(f0_ + ZE);
        scale = options_.atol + y_.array().abs().max(y_new.array().abs()) * options_.rtol;
        error_norm = rms(error.array() / scale.array());
        safety = 0.9 * (2 * kNewtonIterations + 1) / (2 * kNewtonIterations + iterations);
        if (rejected && error_norm > 1.0)
        {
          evaluate(t_, y_ + error, f_error);
          error = lu_real_.solve(f_error + ZE);
          error_norm = rms(error.array() / scale.array());
        }
        if (error_norm > 1.0)
        {
          h_abs *= std::max(kMinFactor, safety * predict_factor(h_abs, error_norm));
          rejected = true;
          ++counters.rejected;
          continue;
        }
        break;
      }
      const bool recompute_jacobian = iterations > 2 && rate > 1e-3;
      double factor = std::min(kMaxFactor, safety * predict_factor(h_abs, error_norm));
      if (!recompute_jacobian && factor < 1.2)
        factor = 1.0;
      // the step is accepted: the dense output of [t, t + h], then the new state
      const double h = h_abs;
      Q_.resize(n_, 3);
      for (int j = 0; j < 3; ++j)
        Q_.col(j) = (P[0][j] * Z.row(0) + P[1][j] * Z.row(1) + P[2][j] * Z.row(2)).transpose();
      y_old_ = y_;
      t_old_ = t_;
      h_ = h;
      t_ = t_ + h;
      y_ = y_new;
      evaluate(t_, y_, f0_);
      stepped_ = true;
      ++counters.steps;
      if (recompute_jacobian)
        jacobian(t_, y_, f0_);
      else
        current_jacobian_ = false;
      if (factor != 1.0)
        factored_ = false;
      h_abs_old_ = h_abs_;  // the step proposed before this one's rejections (as SciPy keeps it)
      error_norm_old_ = error_norm;
      h_abs_ = h_abs * factor;
    }

    static constexpr int kNewtonIterations = 6;
    static constexpr double kMinFactor = 0.2, kMaxFactor = 10.0;

    Function f_;
    RadauOptions options_;
    int n_;
    double t_, t_old_ = 0.0, h_ = 0.0, h_abs_ = 0.0, h_abs_old_ = -1.0, error_norm_old_ = -1.0;
    double newton_tol_ = 0.0, factored_h_ = 0.0;
    bool stepped_ = false, current_jacobian_ = false, factored_ = false;
    Vector y_, y_old_, f0_;
    Matrix J_, Q_;
    Eigen::PartialPivLU<Matrix> lu_real_;
    Eigen::PartialPivLU<Eigen::MatrixXcd> lu_complex_;
  };
} // namespace delta_pin
