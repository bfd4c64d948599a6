// The drive of a sampled run (drive.hpp).

#include "drive.hpp"

#include "checks.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace delta_pin
{
  Drive::Drive(const DriveSettings & settings, long samples, int dof, double dt)
  : settings_(settings)
  , dt_(dt)
  {
    if (settings.sensor && !(settings.resolution > 0.0))
      throw std::invalid_argument(
        "the encoder's resolution is " + std::to_string(settings.resolution) + ", expected > 0 [rad]");
    if (settings.sensor && settings.noise.size())
      check_shape(settings.noise, samples, dof, "noise");  // one row per sample, one column per joint
    if (settings.delay < 0)
      throw std::invalid_argument("delay is " + std::to_string(settings.delay) + ", expected >= 0 samples");
    if (settings.torque_limit.size())
      check_size(settings.torque_limit, dof, "torque_limit");  // one per actuated joint (or none)
    if (!settings.drive)
    {
      settings_.delay = 0;
      settings_.torque_limit.resize(0);
    }
    commands.setZero(settings.drive ? samples : 0, dof);
    pending_.setZero(settings_.delay, dof);
  }

  void Drive::read(long k, const Vector & alpha, const Vector & alpha_dot, Vector & measured, Vector & rate)
  {
    measured = alpha;
    rate = alpha_dot;
    if (!settings_.sensor)
      return;
    const RowMatrix & noise = settings_.noise;
    const double resolution = settings_.resolution;
    for (Eigen::Index i = 0; i < measured.size(); ++i)
    {
      const double angle = noise.size() ? alpha[i] + noise(k, i) : alpha[i];
      measured[i] = std::nearbyint(angle / resolution) * resolution;  // np.round: half to even
    }
    if (!settings_.exact_velocity)
      rate = has_previous_ ? Vector((measured - previous_) / dt_) : Vector::Zero(measured.size());
    previous_ = measured;
    has_previous_ = true;
  }

  Drive::Vector Drive::apply(long k, const Vector & command)
  {
    if (!settings_.drive)
      return command;
    commands.row(k) = command.transpose();
    Vector torque = command;
    if (settings_.delay > 0)
    {
      torque = pending_.row(head_).transpose();
      pending_.row(head_) = command.transpose();
      head_ = (head_ + 1) % settings_.delay;
    }
    const Vector & limit = settings_.torque_limit;
    if (limit.size())
    {
      const Vector clipped = torque.cwiseMax(-limit).cwiseMin(limit);
      if (clipped != torque)
        ++hits;
      torque = clipped;
    }
    return torque;
  }
} // namespace delta_pin
