#include "continuous.hpp"

#include "checks.hpp"
#include "failure.hpp"
#include "interrupt.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>
#include <string>

namespace delta_pin
{
  void HermiteReference::at(double t, Vector & a, Vector & a_dot, Vector & a_ddot) const
  {
    const long last = (long)alpha.rows() - 1;
    const double u = t / step;
    const long k = std::min(std::max((long)u, 0L), last);
    const double s = u - (double)k;
    if (s <= 1e-9 || k == last || s >= 1.0 - 1e-9)
    {
      const long row = (s >= 1.0 - 1e-9 && k < last) ? k + 1 : k;
      a = alpha.row(row).transpose();
      a_dot = alpha_dot.row(row).transpose();
      a_ddot = alpha_ddot.row(row).transpose();
      return;
    }
    if (linear)
    {
      a = ((1.0 - s) * alpha.row(k) + s * alpha.row(k + 1)).transpose();
      a_dot = ((1.0 - s) * alpha_dot.row(k) + s * alpha_dot.row(k + 1)).transpose();
      a_ddot = ((1.0 - s) * alpha_ddot.row(k) + s * alpha_ddot.row(k + 1)).transpose();
      return;
    }
    const double s2 = s * s, s3 = s2 * s, h = step;
    const double h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + s, h01 = -2 * s3 + 3 * s2, h11 = s3 - s2;
    auto hermite = [&](const RowMatrix & y, const RowMatrix & dy) -> Vector
    { return (h00 * y.row(k) + h10 * h * dy.row(k) + h01 * y.row(k + 1) + h11 * h * dy.row(k + 1)).transpose(); };
    a = hermite(alpha, alpha_dot);
    a_dot = hermite(alpha_dot, alpha_ddot);
    a_ddot = hermite(alpha_ddot, alpha_dddot);
  }

  namespace
  {
    void add(RadauCounters & total, const RadauCounters & part)
    {
      total.steps += part.steps;
      total.rejected += part.rejected;
      total.evaluations += part.evaluations;
      total.jacobians += part.jacobians;
      total.factorizations += part.factorizations;
    }

    void add(Bdf2Counters & total, const Bdf2Counters & part)
    {
      total.steps += part.steps;
      total.evaluations += part.evaluations;
      total.split_steps += part.split_steps;
      total.jacobians += part.jacobians;
    }
  } // namespace

  void run_continuous(
    CorePlant & plant, ContinuousLaw & law, const HermiteReference & reference, const Vector & q_start,
    const Vector & alpha0, const Vector & alpha_dot0, const Vector & z0, double dt, long samples,
    const RadauOptions & options, double max_joint_speed, ContinuousRun & run, int bdf2_substeps,
    long projection_interval)
  {
    const int n = (int)alpha0.size(), nz = (int)z0.size();
    if (plant.dof() < 1)
      throw std::invalid_argument("run_continuous needs a plant with an actuated joint");
    check_size(alpha0, plant.dof(), "alpha0");  // one value per actuated joint
    check_size(alpha_dot0, plant.dof(), "alpha_dot0");
    check_positive(dt, "dt");
    if (samples < 1)
      throw std::invalid_argument("samples is " + std::to_string(samples) + ", expected at least one sample");
    // the reference: at least one row, one column per actuated joint, the four tables alike
    check_positive(reference.step, "step");
    check_shape(reference.alpha, 1, n, "alpha");
    const Eigen::Index rows = reference.alpha.rows();
    check_shape(reference.alpha_dot, rows, n, "alpha_dot");
    check_shape(reference.alpha_ddot, rows, n, "alpha_ddot");
    check_shape(reference.alpha_dddot, rows, n, "alpha_dddot");
    if (!(options.max_step > 0.0))
      throw std::invalid_argument("max_step is " + std::to_string(options.max_step) + ", expected > 0 s");
    const bool full = plant.integrates_full_state();
    const int nq = plant.nq(), nv = plant.nv(), nx = full ? nq + nv : 2 * n;
    const Indices & actuated_q = plant.actuated_q();
    const Indices & actuated_v = plant.actuated_v();
    Vector q_last = q_start, v;
    if (!plant.complete(alpha0, alpha_dot0, q_last, v))
      throw failure_at("cannot close the loops at alpha0=" + joint_values(alpha0), 0.0);
    Vector ref_a(n), ref_ad(n), ref_add(n), tau(n), z_dot(nz), q(nq), alpha(n), alpha_dot(n), alpha_ddot(n), dx;
    // the actuated joints of a state y (its first nx entries: [alpha, alpha_dot] or [q, v])
    auto joints = [&](const Vector & y)
    {
      if (!full)
      {
        alpha = y.head(n);
        alpha_dot = y.segment(n, n);
        return;
      }
      for (int i = 0; i < n; ++i)
      {
        alpha[i] = y[actuated_q[i]];
        alpha_dot[i] = y[nq + actuated_v[i]];
      }
    };
    // (q, v, tau, z_dot) at (t, y): the completion (active coordinates) or y's own (q, v), the law
    auto complete = [&](double t, const Vector & y)
    {
      joints(y);
      if (full)
      {
        q = y.head(nq);
        v = y.segment(nq, nv);
      }
      else
      {
        q = q_last;  // the warm start
        if (!plant.complete(alpha, alpha_dot, q, v))
          throw failure_at("cannot close the loops at alpha=" + joint_values(alpha), t);
        q_last = q;
      }
      reference.at(t, ref_a, ref_ad, ref_add);
      try
      {
        law.evaluate(t, q, alpha, alpha_dot, ref_a, ref_ad, ref_add, y.tail(nz), tau, z_dot);
      }
      catch (SimulationFailure & error)
      {
        if (std::isnan(error.time))
          error.time = t;
        throw;
      }
      if (tau.size() != n || z_dot.size() != nz)
      {
        std::ostringstream text;
        text << "the controller returned a torque of " << tau.size() << " and a state rate of " << z_dot.size()
             << " values, expected " << n << " and " << nz;
        throw failure_at(text.str(), t);
      }
      if (!tau.allFinite())
        throw failure_at("the controller returned a non-finite torque " + joint_values(tau), t);
    };
    auto rhs = [&](double t, const Vector & y, Vector & dy)
    {
      if (!y.allFinite())
      {
        joints(y);
        throw failure_at("the state became non-finite (alpha=" + joint_values(alpha) + ")", t);
      }
      complete(t, y);
      dy.resize(y.size());
      try
      {
        if (full)
        {
          plant.full_derivative(t, y.head(nx), tau, dx);
          dy.head(nx) = dx;
        }
        else
        {
          plant.active_accelerations(t, q, v, tau, alpha_ddot);
          dy.head(n) = alpha_dot;
          dy.segment(n, n) = alpha_ddot;
        }
      }
      catch (SimulationFailure & error)
      {
        if (std::isnan(error.time))
          error.time = t;
        throw;
      }
      dy.tail(nz) = z_dot;
    };
    Vector y(nx + nz);
    if (full)
      y << q_last, v, z0;
    else
      y << alpha0, alpha_dot0, z0;
    run.alpha.setZero(samples, n);
    run.alpha_dot.setZero(samples, n);
    run.tau.setZero(samples, n);
    run.state.setZero(samples, nz);
    run.q.setZero(samples, nq);
    run.v.setZero(samples, nv);
    run.xyz.setZero(samples, 3);
    run.gap.setZero(samples);
    run.samples = 0;
    auto check = [&](const Vector & yk, double t)
    {
      joints(yk);
      check_sample(yk.allFinite(), alpha, alpha_dot, max_joint_speed, t);
    };
    auto record = [&](long k, const Vector & yk)
    {
      const double t = (double)k * dt;
      poll_interrupt();
      check(yk, t);
      complete(t, yk);
      run.alpha.row(k) = alpha.transpose();
      run.alpha_dot.row(k) = alpha_dot.transpose();
      run.tau.row(k) = tau.transpose();
      run.state.row(k) = yk.tail(nz).transpose();
      law.keep(k, tau, yk.tail(nz));
      run.q.row(k) = q.transpose();
      run.v.row(k) = v.transpose();
      run.xyz.row(k) = plant.end_effector_position(q).transpose();
      run.gap[k] = plant.closure_gap(q);
      run.samples = k + 1;
    };
    // A whole state drifts off the loops under the integrator's error (Baumgarte pulls it back):
    // every projection_interval samples it is projected back where its gap exceeds the plant's
    // tolerance, and the integrator starts again from there (the Python loop's finish_step
    // between its LSODA chunks, delta_pin.sim.integrators.integrate_lsoda).
    auto projected = [&](long k, Vector & yk)
    {
      if (!full || projection_interval <= 0 || k % projection_interval != 0 || k == samples - 1)
        return false;
      Vector x = yk.head(nx);
      try
      {
        if (!plant.project(x))
          return false;
      }
      catch (SimulationFailure & error)
      {
        if (std::isnan(error.time))
          error.time = (double)k * dt;
        throw;
      }
      yk.head(nx) = x;
      return true;
    };
    try
    {
      record(0, y);
      if (bdf2_substeps > 0)  // fixed steps dt / bdf2_substeps, every stage on the tables' grid
      {
        auto bdf2 = std::make_unique<Bdf2>(rhs, y, 0.0, dt / bdf2_substeps);
        try
        {
          for (long k = 1; k < samples; ++k)
          {
            for (int j = 0; j < bdf2_substeps; ++j)
            {
              bdf2->step();
              check(bdf2->y(), bdf2->t());
            }
            Vector yk = bdf2->y();
            record(k, yk);
            if (projected(k, yk))
            {
              add(run.bdf2_counters, bdf2->counters);
              bdf2 = std::make_unique<Bdf2>(rhs, yk, (double)k * dt, dt / bdf2_substeps);
            }
          }
        }
        catch (...)
        {
          add(run.bdf2_counters, bdf2->counters);
          throw;
        }
        add(run.bdf2_counters, bdf2->counters);
        return;
      }
      RadauOptions bounded = options;
      bounded.t_bound = (double)(samples - 1) * dt;  // the reference ends there
      auto radau = std::make_unique<RadauIIA>(rhs, y, 0.0, bounded);
      for (long k = 1; k < samples; ++k)
      {
        const double t = (double)k * dt;
        try
        {
          radau->advance_past(t);
        }
        catch (const SimulationFailure &)
        {
          add(run.counters, radau->counters);
          throw;
        }
        catch (const CallbackError &)
        {
          add(run.counters, radau->counters);
          throw;
        }
        catch (const std::exception & error)  // the step size collapsed, a non-finite derivative
        {
          add(run.counters, radau->counters);
          throw failure_at(std::string("radau: ") + error.what(), radau->t());
        }
        Vector yk = radau->at(t);
        record(k, yk);
        if (projected(k, yk))
        {
          add(run.counters, radau->counters);
          radau = std::make_unique<RadauIIA>(rhs, yk, t, bounded);
        }
      }
      add(run.counters, radau->counters);
    }
    catch (const SimulationFailure & error)
    {
      run.failure_time = error.time;
      throw;
    }
  }
} // namespace delta_pin
