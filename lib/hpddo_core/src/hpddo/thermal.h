// Winding temperature estimated from copper losses, for the thermal effects
// when a log carries no temperature: a first-order node heated by i^2 Ra,
//   tau dT/dt = r_th i^2 Ra(T) - (T - T_amb),
// advanced with the exact step of the linear ODE over dt (losses held).
#ifndef HPDDO_THERMAL_H
#define HPDDO_THERMAL_H

#include <math.h>

#include "physics.h"
#include "platform.h"

namespace hpddo {

/// First-order thermal state of the winding, C.
class ThermalEstimator {
 public:
  /// Starts at ambient.
  explicit ThermalEstimator(const PhysicsParams& p) : temp_C_(p.t_amb_C) {}

  /// True when the model has a thermal network to run.
  static bool enabled(const PhysicsParams& p) { return p.th_r_K_per_W > 0.0f && p.th_tau_s > 0.0f; }

  /// Current estimate, C.
  float temp_C() const { return temp_C_; }

  /// Restarts at ambient.
  void reset(const PhysicsParams& p) { temp_C_ = p.t_amb_C; }

  /// Advances by dt_s with the true armature current i_A held over the step.
  void step(const PhysicsParams& p, float i_A, float dt_s) {
    if (!enabled(p) || !(dt_s > 0.0f)) return;
    const float loss_W = i_A * i_A * ra_at_ohm(p, temp_C_);
    const float target_C = p.t_amb_C + p.th_r_K_per_W * loss_W;
    const float decay = expf(-dt_s / p.th_tau_s);
    temp_C_ = target_C + (temp_C_ - target_C) * decay;
  }

 private:
  float temp_C_;
};

}  // namespace hpddo

#endif  // HPDDO_THERMAL_H
