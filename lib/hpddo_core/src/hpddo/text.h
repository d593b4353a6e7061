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
  /// The digits of frac (below scale, a power of ten), zero-padded to those of scale - 1.
  void digits(uint32_t frac, uint32_t scale) {
    for (uint32_t d = scale / 10u; d; d /= 10u) {
      put(static_cast<char>('0' + frac / d));
      frac %= d;
    }
  }
  /// Fixed point: scaled / 10^decimals with exactly `decimals` digits.
  void fixed(int32_t scaled, uint8_t decimals) {
    const uint32_t div = pow10(decimals);
    const uint32_t mag = scaled < 0 ? static_cast<uint32_t>(-(scaled + 1)) + 1u : static_cast<uint32_t>(scaled);
    if (scaled < 0) put('-');
    u32(mag / div);
    if (decimals) {
      put('.');
      digits(mag % div, div);
    }
  }

  size_t length() const { return len_; }
  bool overflow() const { return overflow_; }
  const char* c_str() const { return buf_; }

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
