// The one run of the compiled core (docs/architecture.md section 7), built from parts: a plant
// (CorePlant, plant.hpp), a law (Law, law.hpp: compiled or a Python call-back), a drive between
// them (drive.hpp: the encoder and the torque path, sampled mode) and a stepper, the integrator that takes the plant from one sample
// t_k = k dt to the next:
//  - HeldTorqueRk4 (sampled mode): the law's torque at t_k held over the period while the plant
//    takes `substeps` RK4 steps (the zero-order hold of a digital controller);
//  - RadauSteps / Bdf2Steps (continuous mode): plant and law integrated as one ODE by Radau IIA
//    with error control or BDF2 with fixed steps (ContinuousSystem below),
// and run() the loop over the samples that they share: the Ctrl-C poll, the records, the time of
// a failure.
#pragma once

#include "bdf2.hpp"
#include "drive.hpp"
#include "law.hpp"
#include "plant.hpp"
#include "radau.hpp"

#include <cmath>
#include <memory>
#include <string>

namespace delta_pin
{
  // What a run is asked for, by name: the sample period [s] and count (t_k = k dt, k < samples),
  // the integrator ("rk4": sampled; "radau", "bdf2": continuous), its steps per sample (RK4's and
  // BDF2's fixed steps dt / substeps), Radau IIA's tolerances and step bounds [s], the divergence
  // limit on |alpha_dot| [rad/s], the samples between projections of a whole-state continuous
  // run onto the loops (0: none) and the drive between the plant and the law (sampled mode)
  struct RunSettings
  {
    std::string integrator = "rk4";
    double dt = 1e-3;
    long samples = 1;
    int substeps = 1;
    double rtol = 1e-6, atol = 1e-8, first_step = 1e-5, max_step = 1e-2;
    double max_joint_speed = 1e3;
    long projection_interval = 0;
    DriveSettings drive;
  };

  // What a run records at its samples (samples rows each): the actuated joints, the torque that
  // acted, the law's integrated state (continuous mode; the sampled law keeps its own), the
  // plant's q and v, the end effector [m] and the closure gap [m, rad]; with a drive the law's
  // commands [N m] and the samples at which the torque limit bound; the integrators' counters.
  struct RunRecords
  {
    RowMatrix alpha, alpha_dot, tau, state, q, v, xyz, commands;
    long hits = 0;
    Vector gap;
    RadauCounters radau;
    Bdf2Counters bdf2;
    long samples = 0;  // the samples recorded (all of them, or up to a failure)
    double failure_time = std::nan("");  // [s] the time of the SimulationFailure that stopped it
  };

  // The plant's state at a sample, as a stepper gives it to the loop
  struct Sample
  {
    Vector q, v, alpha, alpha_dot, tau, z;
    double gap = 0.0;
  };

  // The integrator of a run: the state at sample k with the torque acting from it, and the step to
  // sample k + 1. A SimulationFailure it throws carries its time.
  class Stepper
  {
  public:
    virtual ~Stepper() = default;
    virtual void sample(long k, Sample & s) = 0;
    virtual void advance(long k) = 0;
    // its counters into the records (after the run, or at a failure)
    virtual void count(RunRecords & /*records*/) const {}
  };

  // The loop: `samples` samples of the plant under the stepper, recorded (RunRecords); a
  // SimulationFailure leaves the samples before it recorded and its time in the records.
  void run(CorePlant & plant, Stepper & stepper, long samples, RunRecords & records);

  // Sampled mode: from the plant state x = [q, v], the law reads the joints through the drive's
  // encoder at t_k (the true state checked first: finite, |alpha_dot| within the limit), and its
  // command, through the drive's delay and limit, is held over the period while the plant takes
  // `substeps` RK4 steps of dt / substeps (CorePlant::step).
  class HeldTorqueRk4 : public Stepper
  {
  public:
    HeldTorqueRk4(CorePlant & plant, Law & law, const Vector & x, const RunSettings & settings);
    void sample(long k, Sample & s) override;
    void advance(long k) override;
    void count(RunRecords & records) const override;

  private:
    CorePlant & plant_;
    Law & law_;
    Vector x_, tau_, measured_, rate_;
    double dt_, h_, gap_, max_joint_speed_;
    int substeps_;
    std::unique_ptr<Drive> drive_;  // none without a sensor or a drive
  };

  // alpha^d(t) on a uniform grid read by cubic Hermite interpolation (the arithmetic of
  // delta_pin.sim.reference.ReferenceTable: exact at the grid points), or with `linear` by linear
  // interpolation of each row's entries (BDF2's: its stages lie on the grid, and its split steps
  // read the reference as its truth, linearly inside the step)
  struct HermiteReference
  {
    double step = 0.0;
    RowMatrix alpha, alpha_dot, alpha_ddot, alpha_dddot;
    bool linear = false;
    void at(double t, Vector & a, Vector & a_dot, Vector & a_ddot) const;
  };

  // Continuous mode: the plant and the law as one ODE in active coordinates
  //
  //     y = [alpha, alpha_dot, z],   y' = [alpha_dot, alpha_ddot(q(alpha), v(alpha_dot), tau, t), z_dot],
  //
  // where every evaluation completes (q, v) from the actuated joints (for a closed chain q(alpha)
  // by Newton, warm-started, and v = S alpha_dot; for the reduced Delta q = alpha), the law gives
  // (tau, z_dot) at the reference of that time (eqs. 23-26, 30-33 for designs I/II), and the
  // plant's dynamics give alpha_ddot with its truth interpolated at t. A plant with motion the
  // actuated joints do not determine (idle motions, passive joints) is integrated in its whole
  // state instead, y = [q, v, z] (CorePlant::integrates_full_state), started from its completion
  // and projected back onto the loops every projection_interval samples where its gap exceeds
  // the plant's tolerance.
  class ContinuousSystem
  {
  public:
    // from (alpha0, alpha_dot0, z0) at t = 0, a closed chain's loops assembled from q_start
    ContinuousSystem(
      CorePlant & plant, Law & law, const HermiteReference & reference, const Vector & q_start, const Vector & alpha0,
      const Vector & alpha_dot0, const Vector & z0, const RunSettings & settings);
    // dy/dt at (t, y); throws SimulationFailure with t
    void rhs(double t, const Vector & y, Vector & dy);
    // the state y at sample k into s, the law evaluated there and kept
    void sample(long k, const Vector & y, Sample & s);
    // the loop's check of a state at t (finite, |alpha_dot| within the limit)
    void check(const Vector & y, double t);
    // y projected back onto the loops at sample k (a whole-state run, every projection_interval
    // samples, where its gap exceeds the plant's tolerance): whether it changed y
    bool projected(long k, Vector & y);
    const Vector & y0() const { return y0_; }

  private:
    void joints(const Vector & y);
    void complete(double t, const Vector & y);

    CorePlant & plant_;
    Law & law_;
    const HermiteReference & reference_;
    RunSettings settings_;
    bool full_;
    int n_, nz_, nq_, nv_, nx_;
    Vector q_last_, q_, v_, ref_a_, ref_ad_, ref_add_, tau_, z_dot_, alpha_, alpha_dot_, alpha_ddot_, dx_, y0_;
  };

  // Continuous mode by Radau IIA of order 5 with error control (radau.hpp): the samples read from
  // the collocation polynomial of the step that covers them.
  class RadauSteps : public Stepper
  {
  public:
    RadauSteps(ContinuousSystem & system, const RunSettings & settings);
    void sample(long k, Sample & s) override;
    void advance(long k) override;
    void count(RunRecords & records) const override;

  private:
    void restart(const Vector & y, double t);
    ContinuousSystem & system_;
    RadauOptions options_;
    double dt_;
    std::unique_ptr<RadauIIA> radau_;
    RadauCounters done_;  // of the integrators a projection ended
    Vector y_;
  };

  // Continuous mode by BDF2 with fixed steps dt / substeps (bdf2.hpp), every stage on the
  // tables' grid.
  class Bdf2Steps : public Stepper
  {
  public:
    Bdf2Steps(ContinuousSystem & system, const RunSettings & settings);
    void sample(long k, Sample & s) override;
    void advance(long k) override;
    void count(RunRecords & records) const override;

  private:
    ContinuousSystem & system_;
    double dt_;
    int substeps_;
    std::unique_ptr<Bdf2> bdf2_;
    Bdf2Counters done_;
    Vector y_;
  };
} // namespace delta_pin
