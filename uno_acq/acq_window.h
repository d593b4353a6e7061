// Sample windows: what the interrupts accumulate over one sample period and
// how it becomes V, I and speed, all means over the same period.
//
// The ADC converts A0 and A1 alternately, back to back, and every conversion
// adds to the window that is open when it completes. A window is a whole
// number of PWM periods (Timer1 overflows), so the PWM ripple averages out
// exactly and the period is exact in CPU cycles.
#ifndef HPDDO_ACQ_WINDOW_H
#define HPDDO_ACQ_WINDOW_H

#include <stdint.h>

#include "acq_config.h"
#include "hpddo/frame.h"
#include "hpddo/platform.h"

namespace acq {

static const uint32_t kCpuHz = 16000000u;
static const uint16_t kAdcCounts = 1024;  ///< 10-bit ADC: code = floor(Vin / Vref * 1024)

/// Raw sums of one closed window, copied out of the interrupts.
struct WindowSums {
  uint32_t seq;        ///< window counter since power-up
  uint32_t sum_v;      ///< sum of A0 codes
  uint32_t sum_i;      ///< sum of A1 codes
  uint32_t n_v;        ///< number of A0 conversions
  uint32_t n_i;        ///< number of A1 conversions
  int32_t enc_counts;  ///< encoder counts (x4) during the window, signed
  uint32_t period_us;  ///< window length, us
  uint16_t duty_q;     ///< duty in force, 0..10000 = 0..1
  uint8_t load;        ///< load relay state in force
};

/// One window in physical units.
struct Measurement {
  float v_V;   ///< mean terminal voltage, V (NaN when no conversion)
  float i_A;   ///< mean armature current, A (NaN when no conversion)
  float rpm;   ///< mean output-shaft speed from the encoder, RPM
};

/// Mean pin voltage of n codes summing to sum. A code c stands for an input in
/// [c, c+1) LSB, so the unbiased estimate adds half an LSB.
inline float mean_pin_V(uint32_t sum, uint32_t n, float ref_V) {
  if (n == 0) return hpddo::absent();
  const float mean_code = static_cast<float>(sum) / static_cast<float>(n);
  return (mean_code + 0.5f) * (ref_V / static_cast<float>(kAdcCounts));
}

/// Converts the raw sums of a window into V, I and speed.
inline Measurement measure(const WindowSums& w, const Calibration& cal, float counts_per_rev) {
  Measurement m;
  m.v_V = mean_pin_V(w.sum_v, w.n_v, cal.adc_ref_V) * cal.divider_ratio - cal.v_offset_V;
  m.i_A = mean_pin_V(w.sum_i, w.n_i, cal.adc_ref_V) / (cal.shunt_ohm * cal.shunt_gain) - cal.i_offset_A;
  const float rev = static_cast<float>(w.enc_counts) / counts_per_rev;
  m.rpm = w.period_us ? rev * 60.0e6f / static_cast<float>(w.period_us) : 0.0f;
  return m;
}

/// Timer1 settings for a PWM frequency: fast PWM, TOP = ICR1.
struct PwmTiming {
  uint8_t prescale;  ///< 1 or 8
  uint16_t top;      ///< ICR1; the period is (top + 1) * prescale cycles
};

/// Timer1 settings closest to pwm_hz, within 31 Hz .. 100 kHz; false outside.
inline bool pwm_timing(uint32_t pwm_hz, PwmTiming* out) {
  if (pwm_hz < 31 || pwm_hz > 100000u) return false;
  uint32_t ticks = (kCpuHz + pwm_hz / 2) / pwm_hz;
  out->prescale = 1;
  if (ticks > 65536u) {
    out->prescale = 8;
    ticks = (kCpuHz / 8 + pwm_hz / 2) / pwm_hz;
  }
  out->top = static_cast<uint16_t>(ticks - 1);
  return true;
}

/// Length of one PWM period in CPU cycles.
inline uint32_t pwm_period_cycles(const PwmTiming& t) {
  return (static_cast<uint32_t>(t.top) + 1u) * t.prescale;
}

/// Whole PWM periods per sample window for a sample rate (at least 1);
/// 0 when the rate is not positive or the window would exceed 65535 periods.
inline uint16_t periods_per_window(const PwmTiming& t, float rate_hz) {
  if (!(rate_hz > 0.0f)) return 0;
  const float n = static_cast<float>(kCpuHz) / (rate_hz * static_cast<float>(pwm_period_cycles(t)));
  if (!(n < 65535.5f)) return 0;
  const uint32_t k = static_cast<uint32_t>(n + 0.5f);
  return static_cast<uint16_t>(k ? k : 1);
}

/// Window length in us (exact when the cycle count divides by 16).
inline uint32_t window_us(const PwmTiming& t, uint16_t periods) {
  return static_cast<uint32_t>((static_cast<uint64_t>(pwm_period_cycles(t)) * periods) / (kCpuHz / 1000000u));
}

/// Compare value of OC1A for a duty of duty_q / 10000.
inline uint16_t pwm_compare(const PwmTiming& t, uint16_t duty_q) {
  const uint32_t ticks = (static_cast<uint32_t>(t.top) + 1u) * duty_q;
  return static_cast<uint16_t>((ticks + 5000u) / 10000u);
}

/// The link frame of a window. The encoder speed rides along for comparison
/// on the inference board; it is never an input of the observer there.
inline hpddo::SampleFrame make_frame(const WindowSums& w, const Measurement& m, bool has_temp,
                                     int16_t temp_c16) {
  hpddo::SampleFrame f;
  f.seq = static_cast<uint16_t>(w.seq & 0xFFFFu);
  f.flags = static_cast<uint8_t>((has_temp ? hpddo::kFrameFlagTemp : 0) | hpddo::kFrameFlagRpm);
  f.duty = static_cast<uint8_t>((static_cast<uint32_t>(w.duty_q) * 255u + 5000u) / 10000u);
  f.v_mV = static_cast<uint16_t>(hpddo::saturate_round(m.v_V * 1000.0f, 0, 65535));
  f.i_mA = static_cast<int16_t>(hpddo::saturate_round(m.i_A * 1000.0f, -32768, 32767));
  f.temp_c16 = has_temp ? temp_c16 : 0;
  f.rpm_x10 = static_cast<int16_t>(hpddo::saturate_round(m.rpm * 10.0f, -32768, 32767));
  f.period_us = w.period_us;
  return f;
}

/// Change of a x4 quadrature count from state old_ab to new_ab (bit1 = A, bit0 = B):
/// +1 or -1 for a valid step, 0 for no change or an impossible double step.
inline int8_t quadrature_step(uint8_t old_ab, uint8_t new_ab) {
  // Gray sequence forward: 00 -> 01 -> 11 -> 10 -> 00 (B leads A).
  static const int8_t kTable[16] = {0, 1, -1, 0, -1, 0, 0, 1, 1, 0, 0, -1, 0, -1, 1, 0};
  return kTable[((old_ab & 3u) << 2) | (new_ab & 3u)];
}

}  // namespace acq

#endif  // HPDDO_ACQ_WINDOW_H
