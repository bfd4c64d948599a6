// The compiled laws of the core's run (run.hpp), behind its one interface (Law, law.hpp):
// ProjectedLaw, the part every law on a closed chain's projected nominal model shares, and the
// built-in laws on it.
#pragma once

#include "law.hpp"
#include "nominal_terms.hpp"
#include "control/adaptive_robust_law.hpp"
#include "control/digital_robust_law.hpp"
#include "control/lqr_law.hpp"
#include "control/time_delay_control.hpp"

#include <Eigen/Dense>

#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

namespace delta_pin
{
  // A law's own records of its last run by name, one row (or entry) per sample, besides the torque
  // and the state: what its Python twin's evaluate() returns as internals (issue 38, item 3: the
  // names are written here once, and read by Python as `records`)
  struct Records
  {
    std::map<std::string, RowMatrix> matrices;  // (samples, width)
    std::map<std::string, Vector> vectors;  // (samples,)
  };

  // A law on a nominal model (nominal_terms.hpp: a closed chain's projection, the Delta's analytic
  // model or a Python one), sampled once per period: the part every such law shares -- the nominal model, the
  // reference table, the checks of each sample (the law's state finite, the torque finite: the
  // messages of delta_pin.sim.integrators.check_state and ControlLoop.control), the state
  // advanced by explicit Euler or to a discrete-time law's next state (Controller.advance) and
  // the records of its torque and state. It reads the joints as the run's drive gives them
  // (drive.hpp).
  class ProjectedLaw : public Law
  {
  public:
    // the law on `model` (its nominal M, C, G: nominal_terms.hpp), F̄ = disturbance [N m]
    ProjectedLaw(std::shared_ptr<NominalTerms> model, const Vector & disturbance, const std::string & name);
    virtual ~ProjectedLaw() = default;

    // the nominal friction compensated (eq. 23's M̄_f; not called: none)
    void set_friction(const FrictionSpec & friction);
    // the reference per sample (rows: alpha^d, alpha_dot^d, alpha_ddot^d), the sample period
    // [s], the initial state and the number of samples to record
    void start(const RowMatrix & alpha_d, const RowMatrix & alpha_dot_d, const RowMatrix & alpha_ddot_d, double dt,
               const Vector & state0, long samples);
    Vector control(long k, const Vector & x, const Vector & alpha, const Vector & alpha_dot) override;
    // one evaluation at a state: tau and the state's derivative
    void evaluate(const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot,
                  const Vector & ref_alpha_ddot, const Vector & state, Vector & tau, Vector & state_dot);

    // The continuous mode (run.hpp), where the integrator gives the reference and the
    // state: records for `samples` samples of `states` state values, then keep(k, ...) after the evaluate() of sample k
    // stores its torque, the state and the law's internals.
    void start_continuous(long samples, Eigen::Index states) override;
    void keep(long k, const Vector & torque, const Vector & state_k) override;
    // the continuous face: evaluate() from the plant's assembly q as the warm start
    void control_at(
      double, const Vector & q, const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha,
      const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot, const Vector & z, Vector & tau,
      Vector & z_dot) override
    {
      warm_start(q);
      evaluate(alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, z, tau, z_dot);
    }
    // a discrete-time law (set_discrete) has no continuous face: its state is not a rate
    bool continuous() const override { return !discrete_; }
    // the nominal model's next assembly starts from q (the plant's, where it has the same
    // configuration space: Newton then closes at once when the kinematics agree)
    void warm_start(const Vector & q) { model_->warm_start(q); }

    RowMatrix tau, state;  // the records of the last run (samples rows): the law's torque, its state
    // the law's own records (none by default)
    virtual Records records() const { return {}; }

  protected:
    // One evaluation: tau and the state's derivative (a continuous-time state) or its next value
    // (a discrete-time law, see set_discrete). By default law() on the nominal M, C, G at the
    // measured state; a law that evaluates the model elsewhere, or not at all, overrides this.
    virtual void compute(const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha,
                         const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot, const Vector & state,
                         Vector & tau, Vector & state_dot);
    // the law from the nominal M, C, G at the state and F̄ [+ M̄_f] (compensation); for the laws
    // that keep compute()'s default
    virtual void law(const Matrix & M, const Matrix & C, const Vector & G, const Vector & compensation,
                     const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot,
                     const Vector & ref_alpha_ddot, const Vector & state, Vector & tau, Vector & state_dot);
    // the nominal M, C, G at (alpha, alpha_dot), assembled from the previous call's configuration
    // (SimulationFailure where the loops do not close)
    void terms(const Vector & alpha, const Vector & alpha_dot, Matrix & M, Matrix & C, Vector & G);
    // F̄ [+ M̄_f(alpha_dot) where set_friction switched it on] [N m] into `out`
    void compensation(const Vector & alpha_dot, Vector & out) const;
    // the state advances to compute()'s next value each sample, not by Euler (Controller.advance
    // of a law with a next_state)
    void set_discrete() { discrete_ = true; }
    virtual void start_records(long /*samples*/) {}
    virtual void record(long /*k*/) {}
    int dof() const { return (int)model_->dof(); }

  private:
    bool discrete_ = false;
    std::shared_ptr<NominalTerms> model_;
    Vector disturbance_;
    FrictionSpec friction_;
    std::string name_;
    RowMatrix alpha_d_, alpha_dot_d_, alpha_ddot_d_;
    double dt_ = 0.0;
    Vector z_, z_dot_;
    // compute()'s M, C, G and compensation, kept between evaluations (no allocation once sized)
    Matrix M_, C_;
    Vector G_, compensation_;
  };

  // C1 + C2 (eqs. 23 and 26): tau = M̄ a_ref + C̄ v_ref + Ḡ + F̄ [+ M̄_f] - T_p r - T_v r_dot
  // (ComputedTorque in delta_pin/control/baselines.py)
  class ComputedTorqueLaw : public ProjectedLaw
  {
  public:
    ComputedTorqueLaw(
      std::shared_ptr<NominalTerms> model, const Vector & disturbance, const std::string & name, const Vector & D,
      const Vector & T_p, const Vector & T_v);

  protected:
    void law(const Matrix & M, const Matrix & C, const Vector & G, const Vector & compensation, const Vector & alpha,
             const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot,
             const Vector & state, Vector & tau, Vector & state_dot) override;

  private:
    Vector D_, T_p_, T_v_;
  };

  // tau = Ḡ + F̄ [+ M̄_f] - K_p r - K_d r_dot (PDGravity in delta_pin/control/baselines.py)
  class PDGravityLaw : public ProjectedLaw
  {
  public:
    PDGravityLaw(
      std::shared_ptr<NominalTerms> model, const Vector & disturbance, const std::string & name, const Vector & K_p,
      const Vector & K_d);

  protected:
    void law(const Matrix & M, const Matrix & C, const Vector & G, const Vector & compensation, const Vector & alpha,
             const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot,
             const Vector & state, Vector & tau, Vector & state_dot) override;

  private:
    Vector K_p_, K_d_;
  };

  // Designs I and II (eqs. 23-26, 30-33, 54-57, 67; adaptive_robust_law.hpp), rho_hat as the state,
  // recording the internals of the readable designs (tests/reference/laws.py).
  class AdaptiveRobust : public ProjectedLaw
  {
  public:
    AdaptiveRobust(
      std::shared_ptr<NominalTerms> model, const Vector & disturbance, const std::string & name,
      const AdaptiveRobustGains<Eigen::Dynamic> & gains);

    RowMatrix robust_torque;  // records, with the state (rho_hat) and the torque
    Vector Lambda, robust_gain, omega_norm, adaptation_active;
    Records records() const override
    {
      return {{{"rho_hat", state}, {"robust_torque", robust_torque}},
              {{"Lambda", Lambda}, {"robust_gain", robust_gain}, {"omega_norm", omega_norm},
               {"adaptation_active", adaptation_active}}};
    }

  protected:
    void law(const Matrix & M, const Matrix & C, const Vector & G, const Vector & compensation, const Vector & alpha,
             const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot,
             const Vector & state, Vector & tau, Vector & state_dot) override;
    void start_records(long samples) override;
    void record(long k) override;

  private:
    AdaptiveRobustGains<Eigen::Dynamic> gains_;
    AdaptiveRobustInternals<Eigen::Dynamic> info_;
    // three actuated joints (the Delta's): the same law at a fixed size, without the heap
    // allocations of the dynamic one's temporaries
    AdaptiveRobustGains<3> gains3_;
  };

  // Time-delay control (TimeDelayControl in delta_pin/control/digital.py; time_delay_control.hpp),
  // discrete-time: its state is the Python law's, the estimate N̂ recorded as lumped_estimate.
  class TimeDelayControlLaw : public ProjectedLaw
  {
  public:
    TimeDelayControlLaw(
      std::shared_ptr<NominalTerms> model, const Vector & disturbance, const std::string & name,
      const TimeDelayGains & gains);

    RowMatrix lumped_estimate;  // records [N m]
    Records records() const override { return {{{"lumped_estimate", lumped_estimate}}, {}}; }

  protected:
    void law(const Matrix & M, const Matrix & C, const Vector & G, const Vector & compensation, const Vector & alpha,
             const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot,
             const Vector & state, Vector & tau, Vector & next_state) override;
    void start_records(long samples) override;
    void record(long k) override;

  private:
    TimeDelayGains gains_;
    Vector lumped_;
  };

  // The sampled-data adaptive robust law with its extended-state observer (DigitalRobustController
  // in delta_pin/control/digital_robust.py; digital_robust_law.hpp), discrete-time, the nominal
  // model evaluated at the observer's estimate (and at the predicted ones over the delay).
  class DigitalRobustLaw : public ProjectedLaw
  {
  public:
    DigitalRobustLaw(
      std::shared_ptr<NominalTerms> model, const Vector & disturbance, const std::string & name,
      const DigitalRobustGains<Eigen::Dynamic> & gains);

    // records: rho_hat (samples x 1) [N m], the robust torque and M̄ f̂ [N m], the velocity
    // estimate and s [rad/s]
    RowMatrix rho_hat, robust_torque, disturbance_estimate, velocity_estimate, s;
    Records records() const override
    {
      return {{{"rho_hat", rho_hat}, {"robust_torque", robust_torque}, {"disturbance_estimate", disturbance_estimate},
               {"velocity_estimate", velocity_estimate}, {"s", s}},
              {}};
    }

  protected:
    void compute(const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot,
                 const Vector & ref_alpha_ddot, const Vector & state, Vector & tau, Vector & next_state) override;
    void start_records(long samples) override;
    void record(long k) override;

  private:
    DigitalRobustGains<Eigen::Dynamic> gains_;
    DigitalRobustInternals<Eigen::Dynamic> info_;
  };

  // The LQR baseline (LQR in delta_pin/control/baselines.py; lqr_law.hpp): no model evaluation
  // per sample, only the compensation F̄ [+ M̄_f].
  class LqrLaw : public ProjectedLaw
  {
  public:
    LqrLaw(
      std::shared_ptr<NominalTerms> model, const Vector & disturbance, const std::string & name,
      const LqrGains<Eigen::Dynamic> & gains);

  protected:
    void compute(const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot,
                 const Vector & ref_alpha_ddot, const Vector & state, Vector & tau, Vector & state_dot) override;

  private:
    LqrGains<Eigen::Dynamic> gains_;
  };
} // namespace delta_pin
