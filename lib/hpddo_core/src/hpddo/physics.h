// The physics models M1 and M2: shaft speed from the armature voltage balance
//
//   v_true = ra(T_w) i_true + brush(i_true) + la di/dt + ke(T_m, i_true) w
//
// with T_w the winding and T_m the magnet temperature, solved for w (rad/s) and
// returned in RPM of the output shaft. M1 uses the
// nameplate Ke with every effect off; M2 uses the identified Ra and Ke, plus
// any effect terms that diagnosis found missing. Each effect is one named
// coefficient; zero switches it off. The parameters and effects are declared
// once, in tools/hpddo/schema.py, from which params_gen.h is generated; the
// terms below exist once more in Python (tools/hpddo/model/physics.py) and a parity
// test holds the two together.
#ifndef HPDDO_PHYSICS_H
#define HPDDO_PHYSICS_H

#include <stdint.h>

#include "limits.h"
#include "params_gen.h"
#include "platform.h"

namespace hpddo {

/// RPM per rad/s (60 / 2 pi).
constexpr float kRpmPerRadS = 9.54929658551372f;

/// The smallest brush knee the term takes, A: the knee (brush_knee_A, the current at
/// which the drop reaches half its full value) smooths the sign of i so that the term is
/// continuous at zero current; a knee below this (or NaN) is taken as this.
static const float kBrushKneeMin_A = 0.001f;

// PhysicsParams, the Effect bits and for_each_param() are generated from the one
// declaration of every parameter and effect, tools/hpddo/schema.py (params_gen.h).

/// One sample as the physics model sees it.
struct PhysicsInput {
  float v_V;            ///< terminal voltage reading, V
  float i_A;            ///< armature current reading, A
  float di_dt_A_per_s;  ///< rate of change of the true current, A/s
  float temp_C;         ///< winding temperature, for thermal_ra, C
  float magnet_C;       ///< magnet temperature, for magnet_thermal, C
};

// A term whose coefficient is zero is skipped below, not computed: with finite inputs
// (the observer checks them) x - 0, x (1 + 0 y) and x - 0 y are x, the same float, so the
// result is the one of the full expression (tools/hpddo/model/physics.py computes it in full),
// and the default model (every effect off) pays no float operation for them (on the AVR
// each costs about 100 to 500 cycles).

/// Armature current with the current-channel offset removed, A.
inline float true_current_A(const PhysicsParams& p, float i_A) {
  return p.i_offset_A == 0.0f ? i_A : i_A - p.i_offset_A;
}

/// The same with the offset's drift with the case temperature case_C removed too
/// (current_offset_drift): i - i_offset - i_offset_tc_A_per_K (case_C - t_ref_C), A.
inline float true_current_A(const PhysicsParams& p, float i_A, float case_C) {
  const float i = true_current_A(p, i_A);
  return p.i_offset_tc_A_per_K == 0.0f ? i : i - p.i_offset_tc_A_per_K * (case_C - p.t_ref_C);
}

/// Reciprocals the physics model would otherwise divide by at every sample, computed once
/// per model (physics_const(); the observer keeps them): the step multiplies instead. The
/// brush term's |i| + knee depends on the current and stays a division (only when the
/// term is on), as does an effective Ke that depends on temperature or current.
struct PhysicsConst {
  float v_gain_inv;   ///< 1 / (1 + v_gain)
  float rpm_per_V;    ///< kRpmPerRadS / ke_vs_per_rad: RPM per volt of back-EMF (0 when Ke <= 0)
  bool ke_constant;   ///< no ke_tc_per_K and no ke_sat_per_A: the effective Ke is ke_vs_per_rad
  bool drift;         ///< the current channel's offset drifts with the case (i_offset_tc_A_per_K)
};

/// The reciprocals of the parameters p (two float divisions, once). constexpr (one return,
/// C++11): the observer's constructor is, so a global observer of a generated model is
/// constant-initialised (no constructor code on the boards, observer.h).
constexpr PhysicsConst physics_const(const PhysicsParams& p) {
  return PhysicsConst{p.v_gain == 0.0f ? 1.0f : 1.0f / (1.0f + p.v_gain),                  // v_gain_inv
                      p.ke_vs_per_rad > 0.0f ? kRpmPerRadS / p.ke_vs_per_rad : 0.0f,       // rpm_per_V
                      p.ke_tc_per_K == 0.0f && p.ke_sat_per_A == 0.0f,                     // ke_constant
                      p.i_offset_tc_A_per_K != 0.0f};                                      // drift
}

/// Terminal voltage with the voltage channel's offset and gain error removed, V:
/// (v - v_offset) x 1 / (1 + v_gain), the reciprocal from k.
inline float true_voltage_V(const PhysicsParams& p, const PhysicsConst& k, float v_V) {
  const float v = p.v_offset_V == 0.0f ? v_V : v_V - p.v_offset_V;
  return p.v_gain == 0.0f ? v : v * k.v_gain_inv;  // without a gain error x 1 is skipped: the same float
}

/// The same, the reciprocal computed here (the same float as physics_const()'s).
inline float true_voltage_V(const PhysicsParams& p, float v_V) { return true_voltage_V(p, physics_const(p), v_V); }

/// Armature resistance at temperature temp_C, ohm.
inline float ra_at_ohm(const PhysicsParams& p, float temp_C) {
  return p.ra_tc_per_K == 0.0f ? p.ra_ohm : p.ra_ohm * (1.0f + p.ra_tc_per_K * (temp_C - p.t_ref_C));
}

/// Brush contact drop at current i_A (true current), V: brush_V f_m(i) with m = brush_order.
/// The base form m = 1 (an order below 1, or NaN, is taken as 1) is f_1 = i / (|i| + knee),
/// one division. A higher order levels off more sharply (tanh- and exp-like drops): f_2 =
/// i / sqrt(i^2 + knee^2), and between them the straight blend f_1 + (m - 1) (f_2 - f_1):
/// one square root, no pow (600 bytes of flash on the AVR).
inline float brush_drop_V(const PhysicsParams& p, float i_A) {
  if (p.brush_V == 0.0f) return 0.0f;  // off: no division (0 x a finite ratio is 0)
  const float mag = i_A < 0.0f ? -i_A : i_A;
  const float knee = p.brush_knee_A > kBrushKneeMin_A ? p.brush_knee_A : kBrushKneeMin_A;
  if (!(p.brush_order > 1.0f)) return p.brush_V * i_A / (mag + knee);
  const float f1 = i_A / (mag + knee);
  const float f2 = i_A / sqrt_f(i_A * i_A + knee * knee);
  return p.brush_V * (f1 + (p.brush_order - 1.0f) * (f2 - f1));
}

/// The armature reaction's growth with the current, A: |i| (1 - q + q |i| / 1 A) with
/// q = ke_sat_quad, linear in |i| (q = 0) to quadratic (q = 1).
inline float saturation_shape_A(const PhysicsParams& p, float i_A) {
  const float mag = i_A < 0.0f ? -i_A : i_A;
  return mag * ((1.0f - p.ke_sat_quad) + p.ke_sat_quad * mag);
}

/// Effective back-EMF constant at temperature temp_C and current i_A, V s/rad.
inline float ke_at_vs_per_rad(const PhysicsParams& p, float temp_C, float i_A) {
  float ke = p.ke_vs_per_rad;
  if (p.ke_tc_per_K != 0.0f) ke = ke * (1.0f + p.ke_tc_per_K * (temp_C - p.t_ref_C));
  if (p.ke_sat_per_A != 0.0f) ke = ke * (1.0f - p.ke_sat_per_A * saturation_shape_A(p, i_A));
  return ke;
}

/// Back-EMF implied by the voltage balance at the true current i (true_current_A), V.
inline float back_emf_at_V(const PhysicsParams& p, const PhysicsConst& k, const PhysicsInput& in, float i) {
  float emf = true_voltage_V(p, k, in.v_V) - ra_at_ohm(p, in.temp_C) * i;
  if (p.brush_V != 0.0f) emf = emf - brush_drop_V(p, i);
  if (p.la_H != 0.0f) emf = emf - p.la_H * in.di_dt_A_per_s;
  return emf;
}

/// Back-EMF implied by the voltage balance, V. The current channel's offset drifts with the
/// case temperature: in.magnet_C, the case reading where one is read (observer.h).
inline float back_emf_V(const PhysicsParams& p, const PhysicsConst& k, const PhysicsInput& in) {
  return back_emf_at_V(p, k, in, k.drift ? true_current_A(p, in.i_A, in.magnet_C) : true_current_A(p, in.i_A));
}

/// The same, the reciprocals computed here.
inline float back_emf_V(const PhysicsParams& p, const PhysicsInput& in) { return back_emf_V(p, physics_const(p), in); }

/// Output-shaft speed in RPM; false (and *rpm untouched) when the effective Ke is not
/// positive or the result is not finite. k = physics_const(p). With a constant Ke the
/// speed is emf x rpm_per_V (one multiply); else emf / ke x kRpmPerRadS.
inline bool physics_rpm(const PhysicsParams& p, const PhysicsConst& k, const PhysicsInput& in, float* rpm) {
  // once, for Ke and the balance; the drift's term only where it is on (k.drift: no float compare per sample)
  const float i = k.drift ? true_current_A(p, in.i_A, in.magnet_C) : true_current_A(p, in.i_A);
  const float ke = k.ke_constant ? p.ke_vs_per_rad : ke_at_vs_per_rad(p, in.magnet_C, i);
  if (!(ke > 0.0f)) return false;
  const float emf = back_emf_at_V(p, k, in, i);
  const float n = k.ke_constant ? emf * k.rpm_per_V : emf / ke * kRpmPerRadS;
  if (!is_finite(n)) return false;
  *rpm = n;
  return true;
}

/// The same, the reciprocals computed here (tools and tests; the observer keeps them).
inline bool physics_rpm(const PhysicsParams& p, const PhysicsInput& in, float* rpm) {
  return physics_rpm(p, physics_const(p), in, rpm);
}

/// Edge of the model's physical speed range, RPM: kSpeedLimitFactor times the speed at
/// which the back-EMF would balance the largest voltage the channel reports plus the
/// largest resistive drop, (v_max + i_max Ra) / Ke; 0 when Ke is not positive.
/// constexpr (one return, C++11) as physics_const(); emf_V = v_max + i_max Ra.
constexpr float speed_limit_rpm(const PhysicsParams& p, const InputLimits& lim) {
  return !(p.ke_vs_per_rad > 0.0f) ? 0.0f
                                   : kSpeedLimitFactor * (lim.v_max_V + lim.i_max_A * p.ra_ohm) / p.ke_vs_per_rad * kRpmPerRadS;
}

/// Nameplate back-EMF constant (M1): rated voltage over rated no-load speed,
/// the armature drop neglected, V s/rad.
inline float nameplate_ke_vs_per_rad(float rated_V, float rated_rpm) {
  return rated_V / (rated_rpm / kRpmPerRadS);
}

/// Parameters of the nameplate model M1: Ra and nameplate Ke, no effects.
inline PhysicsParams nameplate_params(float ra_ohm, float rated_V, float rated_rpm) {
  PhysicsParams p = PhysicsParams();
  p.ra_ohm = ra_ohm;
  p.ke_vs_per_rad = nameplate_ke_vs_per_rad(rated_V, rated_rpm);
  return p;
}

}  // namespace hpddo

#endif  // HPDDO_PHYSICS_H
