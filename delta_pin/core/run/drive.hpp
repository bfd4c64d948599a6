// The drive of a sampled run (run.hpp: HeldTorqueRk4), a part between the plant and any law --
// compiled or called back from Python: the encoder the law reads the joints through and the torque
// path its command takes to the plant (delta_pin/sim/drive.py's Encoder.read and Drive.apply, the
// readable twins it is tested against).
#pragma once

#include <Eigen/Dense>

namespace delta_pin
{
  // The encoder and the drive by name: the encoder's resolution [rad] and noise per sample [rad]
  // (rows of one column per actuated joint, one row per sample, or none), whether it gives the
  // exact velocity; the drive's delay [samples] and torque limit [N m] (one per actuated joint, or
  // none).
  struct DriveSettings
  {
    bool sensor = false;
    double resolution = 0.0;
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> noise;
    bool exact_velocity = false;
    bool drive = false;
    int delay = 0;
    Eigen::VectorXd torque_limit;

    bool active() const { return sensor || drive; }
  };

  class Drive
  {
  public:
    typedef Eigen::VectorXd Vector;
    typedef Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> RowMatrix;

    // for a run of `samples` samples dt [s] apart on `dof` actuated joints (ValueError on a bad
    // setting, naming it)
    Drive(const DriveSettings & settings, long samples, int dof, double dt);

    // Encoder.read at sample k: the law reads round((alpha + noise_k) / q) q (q: the resolution,
    // numpy's rounding of halves to even) and, unless the velocity is exact, the backward
    // difference of the readings (zero at the first sample); without a sensor, the joints as they are
    void read(long k, const Vector & alpha, const Vector & alpha_dot, Vector & measured, Vector & rate);
    // Drive.apply: the command of sample k acts from sample k + delay (zero before), clipped to
    // +-torque_limit; returns the torque acting from sample k and records the command
    Vector apply(long k, const Vector & command);

    RowMatrix commands;  // the law's command at each sample (samples rows; none without a drive)
    long hits = 0;  // the samples at which the torque limit bound

  private:
    DriveSettings settings_;
    double dt_;
    RowMatrix pending_;  // the delayed commands, a ring of `delay` rows
    long head_ = 0;
    Vector previous_;
    bool has_previous_ = false;
  };
} // namespace delta_pin
