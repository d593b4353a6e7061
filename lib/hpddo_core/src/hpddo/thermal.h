// Winding temperature from copper losses, for the thermal effects: the winding
// is a first-order node heated by i^2 Ra above a reference, the case reading
// where the sample carries one (the DS18B20 sits on the case, the copper runs
// hotter under load), else the ambient:
//   tau d(rise)/dt = r_th i^2 Ra(T_w) - rise,      T_w = reference + rise,
// advanced with the exact step of the linear ODE over dt (losses held). With a
// case reading, r_th and tau are the winding-to-case path (seconds); without,
// the winding-to-ambient path (minutes).
//
// Copper's Ra(T) makes the node unstable at high current (the loss grows faster
// than the node sheds it: a runaway), so after each step the rise is held
// within [0, kWindingMax_C - reference]: the node only heats, and no winding is
// hotter than its insulation class allows. Once the current falls back, the
// rise decays from there with tau as usual.
#ifndef HPDDO_THERMAL_H
#define HPDDO_THERMAL_H

#include <math.h>

#include "limits.h"
#include "physics.h"
#include "platform.h"

namespace hpddo {

/// First-order thermal rise of the winding above its reference, K.
class ThermalEstimator {
 public:
  constexpr ThermalEstimator() : rise_K_(0.0f), decay_dt_s_(0.0f), decay_tau_s_(0.0f), decay_(1.0f) {}

  /// True when the model has a thermal network to run.
  static constexpr bool enabled(const PhysicsParams& p) { return p.th_r_K_per_W > 0.0f && p.th_tau_s > 0.0f; }

  /// Current rise of the winding above its reference, K.
  float rise_K() const { return rise_K_; }

  /// Winding temperature for the reference ref_C, C.
  float temp_C(float ref_C) const { return ref_C + rise_K_; }

  /// Restarts with the winding at its reference.
  void reset() { rise_K_ = 0.0f; }

  /// Advances by dt_s with the true armature current i_A held over the step,
  /// above the reference ref_C of this sample; the rise stays within
  /// [0, kWindingMax_C - ref_C].
  void step(const PhysicsParams& p, float i_A, float dt_s, float ref_C) {
    if (!enabled(p) || !(dt_s > 0.0f)) return;
    const float loss_W = i_A * i_A * ra_at_ohm(p, ref_C + rise_K_);
    const float target_K = p.th_r_K_per_W * loss_W;
    // exp(-dt / tau) once per period and time constant: at a steady rate every step
    // reuses it (the same float as recomputing: no division, no expf per step).
    if (dt_s != decay_dt_s_ || p.th_tau_s != decay_tau_s_) {
      decay_ = expf(-dt_s / p.th_tau_s);
      decay_dt_s_ = dt_s;
      decay_tau_s_ = p.th_tau_s;
    }
    const float decay = decay_;
    float next_K = target_K + (rise_K_ - target_K) * decay;
    const float hottest_K = kWindingMax_C - ref_C;
    if (next_K > hottest_K) next_K = hottest_K;
    if (!(next_K >= 0.0f)) next_K = 0.0f;  // also catches a NaN
    rise_K_ = next_K;
  }

 private:
  float rise_K_;
  float decay_dt_s_;   ///< period of the cached decay, s (0: none yet)
  float decay_tau_s_;  ///< time constant of the cached decay, s
  float decay_;        ///< exp(-decay_dt_s_ / decay_tau_s_)
};

}  // namespace hpddo

#endif  // HPDDO_THERMAL_H
