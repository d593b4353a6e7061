// Text of the bench log lines the board writes to the host (spec: bench log
// format): metadata, the header, one row per sample. Fixed-point formatting
// without printf, so that no float printf support is linked on the AVR.
#ifndef HPDDO_ACQ_FORMAT_H
#define HPDDO_ACQ_FORMAT_H

#include <stddef.h>
#include <stdint.h>

#include "hpddo/platform.h"
#include "hpddo/text.h"

namespace acq {

/// Columns of every row, in order (in flash on the AVR: read with pgm_read_byte).
HPDDO_FLASH static const char kLogHeader[] = "t_s,duty,v_V,i_A,rpm_ref,temp_C,load,seq";

/// Columns the board appends when it runs the observer itself (uno_acq.cpp, ACQ_OBSERVER):
/// the estimate in RPM and its hpddo::Status as a number.
HPDDO_FLASH static const char kLogHeaderEstimate[] = ",rpm_est,est_status";

/// Longest line the board writes, with its terminating NUL.
static const uint8_t kLineMax = 96;

/// The bench log's text writer: hpddo::TextWriter (bounded, NUL-terminated, overflow
/// remembered) with the CSV cells of floats.
class LineWriter : public hpddo::TextWriter {
 public:
  LineWriter(char* buf, size_t cap) : hpddo::TextWriter(buf, cap) {}

  /// A float rounded to `decimals` digits (|x| < 2e9 / 10^decimals);
  /// writes nothing for NaN or infinity, an empty CSV cell.
  void real(float x, uint8_t decimals) {
    if (!hpddo::is_finite(x)) return;
    const float s = x * static_cast<float>(pow10(decimals));
    if (s > 2.0e9f || s < -2.0e9f) return;
    fixed(static_cast<int32_t>(s >= 0.0f ? s + 0.5f : s - 0.5f), decimals);
  }
  /// A float with up to 4 decimals, trailing zeros dropped ("2", "0.5", "7.1429").
  void compact(float x) {
    if (!hpddo::is_finite(x)) return;
    int32_t s = static_cast<int32_t>(x * 10000.0f + (x >= 0.0f ? 0.5f : -0.5f));
    uint8_t dec = 4;
    while (dec && s % 10 == 0) {
      s /= 10;
      --dec;
    }
    fixed(s, dec);
  }
};

/// One row of the log.
struct LogRow {
  uint32_t elapsed_samples;  ///< samples since the recording started
  uint32_t period_us;        ///< sample period, us
  uint16_t duty_q;           ///< 0..10000
  float v_V;
  float i_A;
  float rpm;                 ///< NaN: empty cell (no encoder)
  bool has_temp;
  int16_t temp_c16;          ///< DS18B20 reading, 1/16 C
  uint8_t load;
  uint32_t seq;
};

/// Writes a row without line ending: t_s with 6 decimals (exact in us),
/// duty 4, v_V 4, i_A 4, rpm_ref 2, temp_C 4 (exact in 1/16 C).
inline void format_row(LineWriter& w, const LogRow& r) {
  const uint64_t t_us = static_cast<uint64_t>(r.elapsed_samples) * r.period_us;
  // t_us / 10^6 as (t_us / 2^6) / 15625 (floors of floors), a 32-bit division below 2^38 us
  // (76 hours): on the AVR a 64-bit division costs thousands of cycles.
  const uint32_t t_s = (t_us >> 38) == 0 ? static_cast<uint32_t>(t_us >> 6) / 15625u
                                         : static_cast<uint32_t>(t_us / 1000000u);
  w.u32(t_s);
  w.put('.');
  w.digits(static_cast<uint32_t>(t_us - static_cast<uint64_t>(t_s) * 1000000u), 1000000u);
  w.put(',');
  w.fixed(r.duty_q, 4);
  w.put(',');
  w.real(r.v_V, 4);
  w.put(',');
  w.real(r.i_A, 4);
  w.put(',');
  w.real(r.rpm, 2);
  w.put(',');
  if (r.has_temp) w.fixed(static_cast<int32_t>(r.temp_c16) * 625, 4);
  w.put(',');
  w.u32(r.load);
  w.put(',');
  w.u32(r.seq);
}

/// Appends the observer's columns to a row: rpm_est with 2 decimals, est_status.
inline void format_estimate(LineWriter& w, float rpm, uint8_t status) {
  w.put(',');
  w.real(rpm, 2);
  w.put(',');
  w.u32(status);
}

}  // namespace acq

#endif  // HPDDO_ACQ_FORMAT_H
