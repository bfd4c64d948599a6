// The joint friction of eq. 12 (Stribeck), Eigen only: what the plants add and what a
// controller's friction compensation subtracts.
#pragma once

#include <cmath>

namespace delta_pin
{
  // eq. 12 with sgn smoothed by tanh where sign_scale > 0 (delta_pin.model.friction.stribeck_torque)
  struct StribeckFriction
  {
    bool enabled = false;
    double r_a = 0.0, v_s = 1.0, mu_s = 0.0, mu_d = 0.0, mu_v = 0.0, sign_scale = 0.0;

    double torque(double speed, double normal) const
    {
      const double sliding = speed * r_a / v_s;
      const double sign = sign_scale > 0.0 ? std::tanh(speed / sign_scale)
                                           : (speed == 0.0 ? 0.0 : std::copysign(1.0, speed));
      const double level = mu_d * normal + (mu_s - mu_d) * normal * std::exp(-(sliding * sliding));
      return level * sign * r_a + mu_v * speed * r_a;
    }
  };
} // namespace delta_pin
