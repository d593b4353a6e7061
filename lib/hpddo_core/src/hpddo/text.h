// Text into a bounded buffer, without printf and without the heap: what both boards
// write to their hosts (uno_acq: the bench log rows; esp_infer: the telemetry JSON).
// The buffer stays NUL-terminated; what does not fit is dropped and remembered, so a
// caller sends a whole line or none.
#ifndef HPDDO_TEXT_H
#define HPDDO_TEXT_H

#include <stddef.h>
#include <stdint.h>

namespace hpddo {

class TextWriter {
 public:
  TextWriter(char* buf, size_t cap) : buf_(buf), cap_(cap), len_(0), overflow_(false) {
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
      const uint32_t q = div10(v);
      tmp[n++] = static_cast<char>('0' + static_cast<uint8_t>(v - q * 10u));
      v = q;
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
  /// The digits of frac (below scale, a power of ten), zero-padded to those of scale - 1.
  /// From the right, one division by ten a digit (div10), not four 32-bit divisions.
  void digits(uint32_t frac, uint32_t scale) {
    char tmp[10];
    uint8_t n = 0;
    for (uint32_t d = scale; d > 1u && n < sizeof tmp; d = div10(d)) {
      const uint32_t q = div10(frac);
      tmp[n++] = static_cast<char>('0' + static_cast<uint8_t>(frac - q * 10u));
      frac = q;
    }
    while (n) put(tmp[--n]);
  }
  /// Fixed point: scaled / 10^decimals with exactly `decimals` digits (decimals <= 9).
  /// The digits of |scaled| from the right, one division by ten each (div10), the point
  /// put in among them: no division by 10^decimals.
  void fixed(int32_t scaled, uint8_t decimals) {
    const uint32_t mag0 = scaled < 0 ? static_cast<uint32_t>(-(scaled + 1)) + 1u : static_cast<uint32_t>(scaled);
    if (scaled < 0) put('-');
    char tmp[11];
    uint8_t n = 0;
    uint32_t mag = mag0;
    do {  // at least decimals + 1 digits: the fraction and the units
      const uint32_t q = div10(mag);
      tmp[n++] = static_cast<char>('0' + static_cast<uint8_t>(mag - q * 10u));
      mag = q;
    } while ((mag || n <= decimals) && n < sizeof tmp);
    while (n) {
      if (n == decimals) put('.');
      put(tmp[--n]);
    }
  }

  size_t length() const { return len_; }
  bool overflow() const { return overflow_; }
  const char* c_str() const { return buf_; }

  /// v / 10: below 81920 as (v 0xCCCD) >> 19 (exact there; on the AVR a 16 x 16-bit
  /// product and byte moves, about 30 cycles, where a 32-bit division takes about 600).
  static uint32_t div10(uint32_t v) {
    if (v < 65536u) return (static_cast<uint32_t>(static_cast<uint16_t>(v)) * 0xCCCDu) >> 19;
    return v / 10u;
  }

  /// 10^n for n up to 9.
  static uint32_t pow10(uint8_t n) {
    uint32_t p = 1u;
    for (uint8_t k = 0; k < n; ++k) p *= 10u;
    return p;
  }

 private:
  char* buf_;
  size_t cap_;
  size_t len_;
  bool overflow_;
};

}  // namespace hpddo

#endif  // HPDDO_TEXT_H
