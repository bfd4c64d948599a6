#include "continuous.hpp"

#include "failure.hpp"

#include <algorithm>
#include <cmath>
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

  void run_continuous(
    CorePlant & plant, ContinuousLaw & law, const HermiteReference & reference, const Vector & q_start,
    const Vector & alpha0, const Vector & alpha_dot0, const Vector & z0, double dt, long samples,
    const RadauOptions & options, double max_joint_speed, ContinuousRun & run, int bdf2_substeps)
  {
    const int n = (int)alpha0.size(), nz = (int)z0.size();
    if (plant.dof() != n || alpha_dot0.size() != n)
      throw std::invalid_argument("alpha0 and alpha_dot0 need one value per actuated joint");
    if (!(dt > 0.0) || samples < 1)
      throw std::invalid_argument("run_continuous needs dt > 0 and at least one sample");
    Vector q_last = q_start, v;
    if (!plant.complete(alpha0, alpha_dot0, q_last, v))
      throw failure_at("cannot close the loops at alpha0=" + joint_values(alpha0), 0.0);
    Vector ref_a(n), ref_ad(n), ref_add(n), tau(n), z_dot(nz), q(plant.nq()), alpha_ddot(n);
    // (q, v, tau, z_dot) at (t, y): the completion, the law
    auto complete = [&](double t, const Vector & y)
    {
      const Vector alpha = y.head(n);
      q = q_last;  // the warm start
      if (!plant.complete(alpha, y.segment(n, n), q, v))
        throw failure_at("cannot close the loops at alpha=" + joint_values(alpha), t);
      q_last = q;
      reference.at(t, ref_a, ref_ad, ref_add);
      try
      {
        law.evaluate(t, q, alpha, y.segment(n, n), ref_a, ref_ad, ref_add, y.tail(nz), tau, z_dot);
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
        throw failure_at("the state became non-finite (alpha=" + joint_values(y.head(n)) + ")", t);
      complete(t, y);
      try
      {
        plant.active_accelerations(t, q, v, tau, alpha_ddot);
      }
      catch (SimulationFailure & error)
      {
        if (std::isnan(error.time))
          error.time = t;
        throw;
      }
      dy.resize(y.size());
      dy.head(n) = y.segment(n, n);
      dy.segment(n, n) = alpha_ddot;
      dy.tail(nz) = z_dot;
    };
    Vector y(2 * n + nz);
    y << alpha0, alpha_dot0, z0;
    run.alpha.setZero(samples, n);
    run.alpha_dot.setZero(samples, n);
    run.tau.setZero(samples, n);
    run.state.setZero(samples, nz);
    run.q.setZero(samples, plant.nq());
    run.v.setZero(samples, plant.nv());
    run.xyz.setZero(samples, 3);
    run.gap.setZero(samples);
    run.samples = 0;
    auto record = [&](long k, const Vector & yk)
    {
      const double t = (double)k * dt;
      check_sample(yk.allFinite(), yk.head(n), yk.segment(n, n), max_joint_speed, t);
      complete(t, yk);
      run.alpha.row(k) = yk.head(n).transpose();
      run.alpha_dot.row(k) = yk.segment(n, n).transpose();
      run.tau.row(k) = tau.transpose();
      run.state.row(k) = yk.tail(nz).transpose();
      law.keep(k, tau, yk.tail(nz));
      run.q.row(k) = q.transpose();
      run.v.row(k) = v.transpose();
      run.xyz.row(k) = plant.end_effector_position(q).transpose();
      run.gap[k] = plant.closure_gap(q);
      run.samples = k + 1;
    };
    try
    {
      record(0, y);
      if (bdf2_substeps > 0)  // fixed steps dt / bdf2_substeps, every stage on the tables' grid
      {
        Bdf2 bdf2(rhs, y, 0.0, dt / bdf2_substeps);
        try
        {
          for (long k = 1; k < samples; ++k)
          {
            for (int j = 0; j < bdf2_substeps; ++j)
            {
              bdf2.step();
              check_sample(
                bdf2.y().allFinite(), bdf2.y().head(n), bdf2.y().segment(n, n), max_joint_speed, bdf2.t());
            }
            record(k, bdf2.y());
          }
        }
        catch (...)
        {
          run.bdf2_counters = bdf2.counters;
          throw;
        }
        run.bdf2_counters = bdf2.counters;
        return;
      }
      RadauOptions bounded = options;
      bounded.t_bound = (double)(samples - 1) * dt;  // the reference ends there
      RadauIIA radau(rhs, y, 0.0, bounded);
      for (long k = 1; k < samples; ++k)
      {
        const double t = (double)k * dt;
        try
        {
          radau.advance_past(t);
        }
        catch (const SimulationFailure &)
        {
          run.counters = radau.counters;
          throw;
        }
        catch (const CallbackError &)
        {
          run.counters = radau.counters;
          throw;
        }
        catch (const std::exception & error)  // the step size collapsed, a non-finite derivative
        {
          run.counters = radau.counters;
          throw failure_at(std::string("radau: ") + error.what(), radau.t());
        }
        record(k, radau.at(t));
      }
      run.counters = radau.counters;
    }
    catch (const SimulationFailure & error)
    {
      run.failure_time = error.time;
      throw;
    }
  }
} // namespace delta_pin
