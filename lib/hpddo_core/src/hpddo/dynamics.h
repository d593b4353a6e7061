// The dynamic family on the boards: a two-state observer at the output shaft, the speed w
// (rad/s) and the load torque T_L (N m) that the modelled friction does not explain. The
// process is the mechanical balance declared in tools/hpddo/schema.py (the dynamic family,
// DynamicsParams in params_gen.h):
//
//   J dw/dt = Kt i - B w - Tc sgn(w) - T_L,   dT_L/dt = 0,   Kt = Ke (SI),
//
// advanced one sample with the explicit step, the sign smoothed over kFrictionSmooth_rad_s so
// that the friction does not chatter at standstill. The measurement is the back-EMF speed of
// the physics model (M2 with its named effects; La di/dt among them when the inductance is
// named). The gains put both poles of the error's dynamics at p = exp(-dt / tau_obs): with
// a = 1 - dt B / J and g = dt / J, l_w = 1 - p^2 / a and l_T = -(1 - p)^2 / g. The result is a
// speed smoothed by the mechanics (the channels' noise filtered) that follows the back-EMF
// within a few tau_obs, and the load torque.
//
// Named when j_kgm2 > 0; otherwise step() returns the measured speed itself (the same float):
// a model without the family runs as before, bit for bit. No heap, float, C++11. The Python
// reference (tools/hpddo/model/dynamics_ref.py) computes the same bits (test_dynamics.cpp,
// test/py/test_dynamics.py, golden vector test/fixtures/dynamics_golden.h).
#ifndef HPDDO_DYNAMICS_H
#define HPDDO_DYNAMICS_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "crc.h"
#include "model.h"
#include "params_gen.h"
#include "physics.h"
#include "platform.h"

namespace hpddo {

/// The speed over which Coulomb friction reaches its full torque, rad/s.
static const float kFrictionSmooth_rad_s = 0.5f;

/// exp_neg's Taylor coefficients of e^r, highest first: 1/7! .. 1/1!, 1 (a loop over a table in
/// flash: less code on the UNO than the unrolled Horner).
HPDDO_FLASH static const float kExpTaylor[8] = {1.98412698e-4f, 1.38888889e-3f, 8.33333377e-3f, 4.16666679e-2f,
                                                1.66666672e-1f, 0.5f, 1.0f, 1.0f};

/// e^x for x <= 0 in float, the same bits on every target whose float is IEEE single rounded to
/// nearest (the host's SSE, avr-libc's and libgcc's soft float): only + - * / and a power of two
/// built from its bits, in a fixed order, no libm. The C libraries' expf differ from each other:
/// avr-libc's is off the correctly rounded value by up to 1 ulp on [-1, 0] and 12 on [-10, -3]
/// (docs/firmware.md), which would make the UNO's poles, and so its estimates, differ from the
/// host's. Cody-Waite reduction x = n ln2 + r, |r| <= ln2 / 2, and e^r by its Taylor series to r^7
/// (truncation below 6e-9 relative); within 1 ulp of the correctly rounded e^x (measured over
/// [-40, 0], dynamics_ref.py's exp_neg against math.exp). Below -40 (e^x < 4.3e-18) it returns 0,
/// so that the observer's p^2 never reaches the subnormals (which avr-libc flushes). Mirrored step
/// for step in float32 by tools/hpddo/model/dynamics_ref.py (exp_neg). Out of line: 272 bytes less
/// flash on the UNO than inlined into its main loop.
inline HPDDO_NOINLINE float exp_neg(float x) {
  if (!(x > -40.0f)) return 0.0f;
  if (x >= 0.0f) return 1.0f;
  const float t = x * 1.44269504f;                    // x / ln 2
  const int n = static_cast<int>(t - 0.5f);            // round to nearest (t < 0; the cast truncates)
  const float fn = static_cast<float>(n);
  const float r = (x - fn * 0.693359375f) - fn * -2.12194440e-4f;  // ln 2 = 0.693359375 - 2.12194440e-4
  float e = flash_float(&kExpTaylor[0]);
  for (uint8_t k = 1; k < sizeof kExpTaylor / sizeof kExpTaylor[0]; ++k) e = e * r + flash_float(&kExpTaylor[k]);
  const uint32_t bits = static_cast<uint32_t>(n + 127) << 23;  // 2^n, n in [-58, 0]
  float scale;
  memcpy(&scale, &bits, sizeof scale);
  return e * scale;
}

/// True when the dynamic family is named (the model computes it). A constant expression on a
/// model header's kDynamics (constexpr there): `hpddo::Observer<Net, dynamics_named(kDynamics)>`
/// compiles the family exactly where the model names it (observer.h; the UNO's uno_acq).
constexpr bool dynamics_named(const DynamicsParams& d) { return d.j_kgm2 > 0.0f; }

/// The family off: what a model header without kDynamics runs with (one initialiser per field:
/// -Wmissing-field-initializers says where a field was added to the schema and not here).
static constexpr DynamicsParams kDynamicsOff = {0.0f, 0.0f, 0.0f, 0.0f};

/// A model header carries `static constexpr hpddo::DynamicsParams kDynamics` in its namespace only
/// when the family is named (a model without it keeps its bytes). Before including a header
/// whose namespace is ns, HPDDO_DYNAMICS_DEFAULT(ns) gives ns::kDynamics = kDynamicsOff where
/// the header declares none (qualified lookup looks into a using-directive's namespace only
/// when ns itself declares no such name): `ns::kDynamics` is then the model's family either way,
/// a constant expression (dynamics_named(ns::kDynamics) decides at compile time). A copy of
/// kDynamicsOff, not a reference to it: avr-gcc 5.4 cannot fold a constexpr reference's address
/// into a static initialiser, so a global Observer given it was built by constructor code (the
/// UNO's g_obs; observer.h, docs/firmware-internals.md "Flash room").
namespace dynamics_default {
static constexpr DynamicsParams kDynamics = kDynamicsOff;
}  // namespace dynamics_default
#define HPDDO_DYNAMICS_DEFAULT(ns) \
  namespace ns {                   \
  using namespace ::hpddo::dynamics_default;  \
  }

/// CRC-32 of a model with its dynamic family: model_checksum(m), continued over the
/// DynamicsParams floats (schema order) when the family is named, else model_checksum(m)
/// itself (a model without the family keeps its checksum). The exporter's order
/// (tools/hpddo/model/export.py, checksum_floats: the family's floats last).
template <class Net>
uint32_t model_checksum(const Model<Net>& m, const DynamicsParams& d) {
  const uint32_t crc = model_checksum(m);
  if (!dynamics_named(d)) return crc;
  const float f[] = {d.j_kgm2, d.b_nms_per_rad, d.tc_nm, d.tau_obs_s};
  uint32_t state = crc ^ 0xFFFFFFFFu;
  for (uint8_t k = 0; k < sizeof f / sizeof f[0]; ++k) state = detail::crc_float(state, f[k]);
  return state ^ 0xFFFFFFFFu;
}

/// Two-state observer of the output shaft's speed and load torque.
class DynamicsObserver {
 public:
  constexpr DynamicsObserver() : w_rad_s_(0.0f), load_nm_(0.0f), started_(false) {}

  /// Restarts: the next sample sets the state.
  void reset() {
    w_rad_s_ = 0.0f;
    load_nm_ = 0.0f;
    started_ = false;
  }

  /// The load torque beyond the modelled friction, N m (0 before the first sample).
  float load_nm() const { return load_nm_; }

  /// The speed estimate, RPM, after one sample of current i_A (A) and the physics model's
  /// back-EMF speed n_meas_rpm, dt_s after the previous sample. Not named, or a sample it
  /// cannot use (dt not positive, a NaN): n_meas_rpm itself, the state unchanged.
  /// (Out of line: 80 bytes less flash on the UNO than inlined into its main loop.)
  HPDDO_NOINLINE float step(float ke_vs_per_rad, const DynamicsParams& d, float i_A, float n_meas_rpm, float dt_s) {
    if (!dynamics_named(d)) return n_meas_rpm;
    if (!(dt_s > 0.0f) || n_meas_rpm != n_meas_rpm || i_A != i_A) return n_meas_rpm;
    const float y = n_meas_rpm / kRpmPerRadS;
    if (!started_) {  // start settled: the load torque that holds the measured speed
      w_rad_s_ = y;
      load_nm_ = ke_vs_per_rad * i_A - d.b_nms_per_rad * y - d.tc_nm * sign(y);
      started_ = true;
      return n_meas_rpm;
    }
    const float g = dt_s / d.j_kgm2;
    const float a = 1.0f - g * d.b_nms_per_rad;
    float p = 0.0f;  // the poles: tau_obs 0 puts them at the origin (the estimate is the measurement)
    if (d.tau_obs_s > 0.0f) p = exp_neg(-dt_s / d.tau_obs_s);  // not expf: the same bits on every board
    const float lw = 1.0f - (p * p) / a;
    const float lt = -((1.0f - p) * (1.0f - p)) / g;
    const float torque = (ke_vs_per_rad * i_A - d.tc_nm * sign(w_rad_s_)) - load_nm_;
    const float w_pred = a * w_rad_s_ + g * torque;
    const float e = y - w_pred;
    w_rad_s_ = w_pred + lw * e;
    load_nm_ = load_nm_ + lt * e;
    return w_rad_s_ * kRpmPerRadS;
  }

 private:
  static float sign(float w) {
    const float s = w / kFrictionSmooth_rad_s;
    return s > 1.0f ? 1.0f : (s < -1.0f ? -1.0f : s);
  }

  float w_rad_s_;  ///< speed estimate at the output shaft, rad/s
  float load_nm_;  ///< load torque beyond the modelled friction, N m
  bool started_;   ///< whether a sample has set the state
};

}  // namespace hpddo

#endif  // HPDDO_DYNAMICS_H
