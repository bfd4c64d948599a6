// The one run of the compiled core and its steppers (run.hpp).

#include "run.hpp"

#include "checks.hpp"
#include "failure.hpp"
#include "interrupt.hpp"

#include <algorithm>
#include <sstream>

namespace delta_pin
{
  void run(CorePlant & plant, Stepper & stepper, long samples, RunRecords & records)
  {
    if (samples < 1)
      throw std::invalid_argument("samples is " + std::to_string(samples) + ", expected at least one sample");
    const int n = plant.dof();
    records.alpha.setZero(samples, n);
    records.alpha_dot.setZero(samples, n);
    records.tau.setZero(samples, n);
    records.state.setZero(samples, 0);
    records.q.setZero(samples, plant.nq());
    records.v.setZero(samples, plant.nv());
    records.xyz.setZero(samples, 3);
    records.gap.setZero(samples);
    records.samples = 0;
    Sample s;
    try
    {
      for (long k = 0; k < samples; ++k)
      {
        poll_interrupt();
        stepper.sample(k, s);
        if (k == 0)
          records.state.setZero(samples, s.z.size());
        records.alpha.row(k) = s.alpha.transpose();
        records.alpha_dot.row(k) = s.alpha_dot.transpose();
        records.tau.row(k) = s.tau.transpose();
        records.state.row(k) = s.z.transpose();
        records.q.row(k) = s.q.transpose();
        records.v.row(k) = s.v.transpose();
        records.xyz.row(k) = plant.end_effector_position(s.q).transpose();
        records.gap[k] = s.gap;
        records.samples = k + 1;
        if (k + 1 < samples)
          stepper.advance(k);
      }
    }
    catch (const SimulationFailure & failure)
    {
      records.failure_time = failure.time;
      stepper.count(records);
      throw;
    }
    catch (...)
    {
      stepper.count(records);
      throw;
    }
    stepper.count(records);
  }

  // ---- sampled mode --------------------------------------------------------------------------

  HeldTorqueRk4::HeldTorqueRk4(CorePlant & plant, Law & law, const Vector & x, const RunSettings & settings)
  : plant_(plant)
  , law_(law)
  , x_(x)
  , dt_(settings.dt)
  , h_(settings.dt / settings.substeps)
  , max_joint_speed_(settings.max_joint_speed)
  , substeps_(settings.substeps)
  {
    if (settings.substeps < 1)
      throw std::invalid_argument("substeps is " + std::to_string(settings.substeps) + ", expected >= 1");
    check_positive(settings.dt, "dt");
    check_size(x_, plant.nq() + plant.nv(), "x");  // [q, v]
    check_finite(x_, "x");
    if (settings.drive.active())
      drive_ = std::make_unique<Drive>(settings.drive, settings.samples, plant.dof(), settings.dt);
    gap_ = plant.closure_gap(x_.head(plant.nq()));
  }

  void HeldTorqueRk4::sample(long k, Sample & s)
  {
    const int nq = plant_.nq(), nv = plant_.nv();
    s.alpha.resize(plant_.actuated_q().size());
    s.alpha_dot.resize(plant_.actuated_v().size());
    plant_.joint_state(x_, s.alpha, s.alpha_dot);
    Vector command;
    try
    {
      if (k > 0)
        check_sample(x_.allFinite(), s.alpha, s.alpha_dot, max_joint_speed_, k * dt_);
      if (drive_)
      {
        drive_->read(k, s.alpha, s.alpha_dot, measured_, rate_);
        command = law_.control(k, x_, measured_, rate_);
      }
      else
        command = law_.control(k, x_, s.alpha, s.alpha_dot);
    }
    catch (SimulationFailure & failure)
    {
      if (std::isnan(failure.time))
        failure.time = k * dt_;
      throw;
    }
    if (command.size() != plant_.dof())
      throw std::invalid_argument(
        "the control returned a torque of " + std::to_string(command.size()) + " entries at sample "
        + std::to_string(k) + ", expected " + std::to_string(plant_.dof()));
    tau_ = drive_ ? drive_->apply(k, command) : command;
    s.tau = tau_;
    s.z.resize(0);  // the sampled law keeps its own state
    s.q = x_.head(nq);
    s.v = x_.tail(nv);
    s.gap = gap_;
  }

  void HeldTorqueRk4::advance(long k)
  {
    for (int j = 0; j < substeps_; ++j)
    {
      try
      {
        gap_ = plant_.step(x_, tau_, k * dt_ + j * h_, h_);
      }
      catch (SimulationFailure & failure)
      {
        failure.time = k * dt_ + (j + 1) * h_;
        throw;
      }
    }
  }

  void HeldTorqueRk4::count(RunRecords & records) const
  {
    if (drive_)
    {
      records.commands = drive_->commands;
      records.hits = drive_->hits;
    }
  }

  // ---- continuous mode -----------------------------------------------------------------------

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

  ContinuousSystem::ContinuousSystem(
    CorePlant & plant, Law & law, const HermiteReference & reference, const Vector & q_start, const Vector & alpha0,
    const Vector & alpha_dot0, const Vector & z0, const RunSettings & settings)
  : plant_(plant)
  , law_(law)
  , reference_(reference)
  , settings_(settings)
  , full_(plant.integrates_full_state())
  , n_(plant.dof())
  , nz_((int)z0.size())
  , nq_(plant.nq())
  , nv_(plant.nv())
  {
    if (n_ < 1)
      throw std::invalid_argument("a continuous run needs a plant with an actuated joint");
    check_size(alpha0, n_, "alpha0");  // one value per actuated joint
    check_size(alpha_dot0, n_, "alpha_dot0");
    check_positive(settings.dt, "dt");
    // the reference: at least one row, one column per actuated joint, the four tables alike
    check_positive(reference.step, "step");
    check_shape(reference.alpha, 1, n_, "alpha");
    const Eigen::Index rows = reference.alpha.rows();
    check_shape(reference.alpha_dot, rows, n_, "alpha_dot");
    check_shape(reference.alpha_ddot, rows, n_, "alpha_ddot");
    check_shape(reference.alpha_dddot, rows, n_, "alpha_dddot");
    if (!(settings.max_step > 0.0))
      throw std::invalid_argument("max_step is " + std::to_string(settings.max_step) + ", expected > 0 s");
    nx_ = full_ ? nq_ + nv_ : 2 * n_;
    q_last_ = q_start;
    if (!plant.complete(alpha0, alpha_dot0, q_last_, v_))
      throw failure_at("cannot close the loops at alpha0=" + joint_values(alpha0), 0.0);
    ref_a_.resize(n_);
    ref_ad_.resize(n_);
    ref_add_.resize(n_);
    tau_.resize(n_);
    z_dot_.resize(nz_);
    q_.resize(nq_);
    alpha_.resize(n_);
    alpha_dot_.resize(n_);
    alpha_ddot_.resize(n_);
    y0_.resize(nx_ + nz_);
    if (full_)
      y0_ << q_last_, v_, z0;
    else
      y0_ << alpha0, alpha_dot0, z0;
    law_.start_continuous(settings.samples, nz_);
  }

  // the actuated joints of a state y (its first nx entries: [alpha, alpha_dot] or [q, v])
  void ContinuousSystem::joints(const Vector & y)
  {
    if (!full_)
    {
      alpha_ = y.head(n_);
      alpha_dot_ = y.segment(n_, n_);
      return;
    }
    const Indices & actuated_q = plant_.actuated_q();
    const Indices & actuated_v = plant_.actuated_v();
    for (int i = 0; i < n_; ++i)
    {
      alpha_[i] = y[actuated_q[i]];
      alpha_dot_[i] = y[nq_ + actuated_v[i]];
    }
  }

  // (q, v, tau, z_dot) at (t, y): the completion (active coordinates) or y's own (q, v), the law
  void ContinuousSystem::complete(double t, const Vector & y)
  {
    joints(y);
    if (full_)
    {
      q_ = y.head(nq_);
      v_ = y.segment(nq_, nv_);
    }
    else
    {
      q_ = q_last_;  // the warm start
      if (!plant_.complete(alpha_, alpha_dot_, q_, v_))
        throw failure_at("cannot close the loops at alpha=" + joint_values(alpha_), t);
      q_last_ = q_;
    }
    reference_.at(t, ref_a_, ref_ad_, ref_add_);
    try
    {
      law_.control_at(t, q_, alpha_, alpha_dot_, ref_a_, ref_ad_, ref_add_, y.tail(nz_), tau_, z_dot_);
    }
    catch (SimulationFailure & error)
    {
      if (std::isnan(error.time))
        error.time = t;
      throw;
    }
    if (tau_.size() != n_ || z_dot_.size() != nz_)
    {
      std::ostringstream text;
      text << "the controller returned a torque of " << tau_.size() << " and a state rate of " << z_dot_.size()
           << " values, expected " << n_ << " and " << nz_;
      throw failure_at(text.str(), t);
    }
    if (!tau_.allFinite())
      throw failure_at("the controller returned a non-finite torque " + joint_values(tau_), t);
  }

  void ContinuousSystem::rhs(double t, const Vector & y, Vector & dy)
  {
    if (!y.allFinite())
    {
      joints(y);
      throw failure_at("the state became non-finite (alpha=" + joint_values(alpha_) + ")", t);
    }
    complete(t, y);
    dy.resize(y.size());
    try
    {
      if (full_)
      {
        plant_.full_derivative(t, y.head(nx_), tau_, dx_);
        dy.head(nx_) = dx_;
      }
      else
      {
        plant_.active_accelerations(t, q_, v_, tau_, alpha_ddot_);
        dy.head(n_) = alpha_dot_;
        dy.segment(n_, n_) = alpha_ddot_;
      }
    }
    catch (SimulationFailure & error)
    {
      if (std::isnan(error.time))
        error.time = t;
      throw;
    }
    dy.tail(nz_) = z_dot_;
  }

  void ContinuousSystem::check(const Vector & y, double t)
  {
    joints(y);
    check_sample(y.allFinite(), alpha_, alpha_dot_, settings_.max_joint_speed, t);
  }

  void ContinuousSystem::sample(long k, const Vector & y, Sample & s)
  {
    const double t = (double)k * settings_.dt;
    check(y, t);
    complete(t, y);
    s.alpha = alpha_;
    s.alpha_dot = alpha_dot_;
    s.tau = tau_;
    s.z = y.tail(nz_);
    law_.keep(k, tau_, s.z);
    s.q = q_;
    s.v = v_;
    s.gap = plant_.closure_gap(q_);
  }

  // A whole state drifts off the loops under the integrator's error (Baumgarte pulls it back):
  // every projection_interval samples it is projected back where its gap exceeds the plant's
  // tolerance, and the integrator starts again from there.
  bool ContinuousSystem::projected(long k, Vector & y)
  {
    const long interval = settings_.projection_interval;
    if (!full_ || interval <= 0 || k % interval != 0 || k == settings_.samples - 1)
      return false;
    Vector x = y.head(nx_);
    try
    {
      if (!plant_.project(x))
        return false;
    }
    catch (SimulationFailure & error)
    {
      if (std::isnan(error.time))
        error.time = (double)k * settings_.dt;
      throw;
    }
    y.head(nx_) = x;
    return true;
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

  RadauSteps::RadauSteps(ContinuousSystem & system, const RunSettings & settings)
  : system_(system)
  , dt_(settings.dt)
  , y_(system.y0())
  {
    options_.rtol = settings.rtol;
    options_.atol = settings.atol;
    options_.first_step = settings.first_step;
    options_.max_step = settings.max_step;
    options_.t_bound = (double)(settings.samples - 1) * settings.dt;  // the reference ends there
  }

  void RadauSteps::sample(long k, Sample & s)
  {
    if (k > 0)
      y_ = radau_->at((double)k * dt_);
    system_.sample(k, y_, s);
  }

  void RadauSteps::restart(const Vector & y, double t)
  {
    if (radau_)
      add(done_, radau_->counters);
    radau_.reset();  // a constructor that throws leaves none to count twice
    radau_ = std::make_unique<RadauIIA>(
      [this](double time, const Vector & state, Vector & rate) { system_.rhs(time, state, rate); }, y, t, options_);
  }

  void RadauSteps::advance(long k)
  {
    const double t = (double)(k + 1) * dt_;
    try
    {
      if (!radau_)  // the first step starts after the first sample (its law evaluated first)
        restart(y_, 0.0);
      else if (k > 0 && system_.projected(k, y_))
        restart(y_, (double)k * dt_);
      radau_->advance_past(t);
    }
    catch (const SimulationFailure &)
    {
      throw;
    }
    catch (const CallbackError &)
    {
      throw;
    }
    catch (const std::invalid_argument &)  // a setting the integrator refuses
    {
      throw;
    }
    catch (const std::exception & error)  // the step size collapsed, a non-finite derivative
    {
      throw failure_at(std::string("radau: ") + error.what(), radau_ ? radau_->t() : (double)k * dt_);
    }
  }

  void RadauSteps::count(RunRecords & records) const
  {
    records.radau = done_;
    if (radau_)
      add(records.radau, radau_->counters);
  }

  Bdf2Steps::Bdf2Steps(ContinuousSystem & system, const RunSettings & settings)
  : system_(system)
  , dt_(settings.dt)
  , substeps_(settings.substeps)
  , y_(system.y0())
  {
    if (settings.substeps < 1)
      throw std::invalid_argument("substeps is " + std::to_string(settings.substeps) + ", expected >= 1");
  }

  void Bdf2Steps::sample(long k, Sample & s)
  {
    if (k > 0)
      y_ = bdf2_->y();
    system_.sample(k, y_, s);
  }

  void Bdf2Steps::advance(long k)
  {
    auto restart = [&](double t)
    {
      if (bdf2_)
        add(done_, bdf2_->counters);
      bdf2_.reset();
      bdf2_ = std::make_unique<Bdf2>(
        [this](double time, const Vector & state, Vector & rate) { system_.rhs(time, state, rate); }, y_, t,
        dt_ / substeps_);
    };
    if (!bdf2_)
      restart(0.0);
    else if (k > 0 && system_.projected(k, y_))
      restart((double)k * dt_);
    for (int j = 0; j < substeps_; ++j)
    {
      bdf2_->step();
      system_.check(bdf2_->y(), bdf2_->t());
    }
  }

  void Bdf2Steps::count(RunRecords & records) const
  {
    records.bdf2 = done_;
    if (bdf2_)
      add(records.bdf2, bdf2_->counters);
  }
} // namespace delta_pin
