// Text of the bench log lines the board writes to the host (spec: bench log
// format): metadata, the header, one row per sample. Fixed-point formatting
// without printf, so that no float printf support is linked on the AVR.
#ifndef HPDDO_ACQ_FORMAT_H
#define HPDDO_ACQ_FORMAT_H

#include <stddef.h>
#include <stdint.h>

#include "hpddo/platform.h"

namespace acq {

/// Columns of every row, in order (in flash on the AVR: read with pgm_read_byte).
HPDDO_FLASH static const char kLogHeader[] = "t_s,duty,v_V,i_A,rpm_ref,temp_C,load,seq";

/// Columns the board appends when it runs the observer itself (uno_acq.cpp, ACQ_OBSERVER):
/// the estimate in RPM and its hpddo::Status as a number.
HPDDO_FLASH static const char kLogHeaderEstimate[] = ",rpm_est,est_status";

/// Longest line the board writes, with its terminating NUL.
static const uint8_t kLineMax = 96;

/// Appends text to a bounded buffer; keeps it NUL-terminated and remembers
/// an overflow instead of writing past the end.
class LineWriter {
 public:
  LineWriter(char* buf, size_t cap) : buf_(buf), cap_(cap), len_(0), overflow_(false) {
    if (cap_) buf_[0] = '\0';
  }

  void put(char c) {
    if (len_ + 1 < cap_) {
      buf_[len_++] = c;
      buf_[len_] = '\0';
    } else {
      overflow_ = true;
    }
  }
  void str(const char* s) {
    while (*s) put(*s++);
  }
  /// Unsigned decimal.
  void u32(uint32_t v) {
    char tmp[10];
    uint8_t n = 0;
    do {
      tmp[n++] = static_cast<char>('0' + v % 10u);
      v /= 10u;
    } while (v);
    while (n) put(tmp[--n]);
  }
  /// Signed decimal.
  void i32(int32_t v) {
    if (v < 0) {
      put('-');
      u32(static_cast<uint32_t>(-(v + 1)) + 1u);
    } else {
      u32(static_cast<uint32_t>(v));
    }
  }
  /// Fixed point: scaled / 10^decimals with exactly `decimals` digits.
  void fixed(int32_t scaled, uint8_t decimals) {
    uint32_t div = 1;
    for (uint8_t k = 0; k < decimals; ++k) div *= 10u;
    uint32_t mag = scaled < 0 ? static_cast<uint32_t>(-(scaled + 1)) + 1u : static_cast<uint32_t>(scaled);
    if (scaled < 0) put('-');
    u32(mag / div);
    if (decimals) {
      put('.');
      uint32_t frac = mag % div;
      for (uint32_t d = div / 10u; d; d /= 10u) {
        put(static_cast<char>('0' + frac / d));
        frac %= d;
      }
    }
  }
  /// A float rounded to `decimals` digits (|x| < 2e9 / 10^decimals);
  /// writes nothing for NaN or infinity, an empty CSV cell.
  void real(float x, uint8_t decimals) {
    if (!hpddo::is_finite(x)) return;
    float scale = 1.0f;
    for (uint8_t k = 0; k < decimals; ++k) scale *= 10.0f;
    const float s = x * scale;
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

  size_t length() const { return len_; }
  bool overflow() const { return overflow_; }
  const char* c_str() const { return buf_; }

 private:
  char* buf_;
  size_t cap_;
  size_t len_;
  bool overflow_;
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
  w.u32(static_cast<uint32_t>(t_us / 1000000u));
  w.put('.');
  uint32_t frac = static_cast<uint32_t>(t_us % 1000000u);
  for (uint32_t d = 100000u; d; d /= 10u) {
    w.put(static_cast<char>('0' + frac / d));
    frac %= d;
  }
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
