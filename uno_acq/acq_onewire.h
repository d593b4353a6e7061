// DS18B20 data handling: the Maxim CRC-8 and the scratchpad decoding. The
// bit timing lives in the sketch; the scheduling (start a conversion, read it
// 750 ms later, one reading a second) lives here.
#ifndef HPDDO_ACQ_ONEWIRE_H
#define HPDDO_ACQ_ONEWIRE_H

#include <stdint.h>

#include "hpddo/limits.h"

namespace acq {

/// Maxim/Dallas CRC-8 (poly x^8 + x^5 + x^4 + 1, reflected 0x8C, init 0).
inline uint8_t crc8_maxim(const uint8_t* data, uint8_t n) {
  uint8_t crc = 0;
  for (uint8_t k = 0; k < n; ++k) {
    uint8_t b = data[k];
    for (uint8_t bit = 0; bit < 8; ++bit) {
      const uint8_t mix = static_cast<uint8_t>((crc ^ b) & 1u);
      crc = static_cast<uint8_t>(crc >> 1);
      if (mix) crc ^= 0x8Cu;
      b = static_cast<uint8_t>(b >> 1);
    }
  }
  return crc;
}

/// Temperature of a 9-byte scratchpad in 1/16 C; false when the CRC fails or
/// the bus read all ones or all zeros (no sensor).
inline bool ds18b20_decode(const uint8_t (&pad)[9], int16_t* temp_c16) {
  uint8_t ones = 0xFF;
  uint8_t zeros = 0;
  for (uint8_t k = 0; k < 9; ++k) {
    ones &= pad[k];
    zeros |= pad[k];
  }
  if (ones == 0xFF || zeros == 0) return false;
  if (crc8_maxim(pad, 8) != pad[8]) return false;
  *temp_c16 = static_cast<int16_t>(static_cast<uint16_t>(pad[0]) | (static_cast<uint16_t>(pad[1]) << 8));
  return true;
}

/// When to start a conversion and when to read it, from a millisecond clock.
class TempSchedule {
 public:
  static const uint16_t kConvertMs = 800;   ///< 12-bit conversion takes 750 ms
  static const uint16_t kIntervalMs = 1000; ///< one reading a second
  static const uint16_t kMaxAgeMs = hpddo::kTempMaxAge_ms;  ///< older readings are reported as absent

  enum Action : uint8_t { kIdle = 0, kStartConversion = 1, kReadScratchpad = 2 };

  constexpr TempSchedule() : converting_(false), started_ms_(0), have_(false), read_ms_(0), value_(0) {}

  /// What to do now.
  Action poll(uint32_t now_ms) const {
    if (converting_) return (now_ms - started_ms_ >= kConvertMs) ? kReadScratchpad : kIdle;
    return (now_ms - started_ms_ >= kIntervalMs || started_ms_ == 0) ? kStartConversion : kIdle;
  }
  /// A conversion was started (ok) or the sensor did not answer.
  void started(uint32_t now_ms, bool ok) {
    converting_ = ok;
    started_ms_ = now_ms ? now_ms : 1;
  }
  /// The scratchpad was read (ok with temp_c16) or failed.
  void read(uint32_t now_ms, bool ok, int16_t temp_c16) {
    converting_ = false;
    if (ok) {
      have_ = true;
      read_ms_ = now_ms;
      value_ = temp_c16;
    }
  }
  /// The latest reading when it is fresh enough.
  bool current(uint32_t now_ms, int16_t* temp_c16) const {
    if (!have_ || now_ms - read_ms_ > kMaxAgeMs) return false;
    *temp_c16 = value_;
    return true;
  }

 private:
  bool converting_;
  uint32_t started_ms_;
  bool have_;
  uint32_t read_ms_;
  int16_t value_;
};

}  // namespace acq

#endif  // HPDDO_ACQ_ONEWIRE_H
