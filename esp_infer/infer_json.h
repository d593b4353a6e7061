// The inference board's telemetry line: JSON with fixed decimals, written into a
// caller's buffer (no heap, no library), so that its length is bounded and known:
//
//   {"seq":412,"rpm":181.30,"rpm_m2":175.20,"residual":6.10,"confidence":1.000,"status":"ok",
//    "us":812,"rpm_ref":180.40,"v":9.612,"i":0.812,"gaps":0,"lost":0,"crc_errors":0}
//
// Speeds and the residual with 2 decimals (0.01 RPM), confidence 3, V and I 3 (the
// frame carries mV and mA). A value beyond +-kJsonLimit prints as that limit (no speed
// the observer reports comes near it: its speed range is a few thousand RPM), a
// non-finite one as null. ArduinoJson printed the same floats widened to double
// (9.138000488): 177 bytes a line on average, about 65 lines/s at 115200 baud.
//
// The budget (test/firmware/test_infer.cpp, InferJson.*): the longest line this can
// write is kJsonMaxLine bytes; at the host baud kHostBaud a line takes at most
// kJsonMaxLine * 10 bits, so the host link carries every sample the UNO's link can
// deliver (38400 baud, 21-byte frames: at most 183 samples/s), and while one line goes
// out fewer link bytes arrive than the 64-byte receive buffer of SoftwareSerial holds.
#ifndef HPDDO_INFER_JSON_H
#define HPDDO_INFER_JSON_H

#include <stddef.h>
#include <stdint.h>

#include "hpddo/platform.h"
#include "hpddo/text.h"
#include "infer_telemetry.h"

namespace infer {

/// Host serial speed of the inference board, baud (esp_infer.cpp; the ESP8266's UART
/// divides 80 MHz by 174: 0.2 % off, within the USB bridge's tolerance).
static const uint32_t kHostBaud = 460800;

/// Largest magnitude a value is printed with.
static const float kJsonLimit = 99999.0f;

/// Longest line format_json() writes, newline included, bytes (checked by a test).
static const uint8_t kJsonMaxLine = 240;

/// The telemetry's text writer: hpddo::TextWriter (bounded, NUL-terminated, overflow
/// remembered) with the JSON numbers.
class JsonWriter : public hpddo::TextWriter {
 public:
  JsonWriter(char* buf, size_t cap) : hpddo::TextWriter(buf, cap) {}

  /// v with `decimals` fixed decimals, rounded half away from zero; null if not finite.
  void number(float v, uint8_t decimals) {
    if (!hpddo::is_finite(v)) {
      str("null");
      return;
    }
    if (v > kJsonLimit) v = kJsonLimit;
    if (v < -kJsonLimit) v = -kJsonLimit;
    const uint32_t scale = pow10(decimals);
    const bool negative = v < 0.0f;
    const float mag = negative ? -v : v;
    // Whole part and fraction apart (both exact below 2^23), so large values keep
    // their decimals: the fraction alone is scaled and rounded.
    uint32_t whole = static_cast<uint32_t>(mag);
    uint32_t frac = static_cast<uint32_t>((mag - static_cast<float>(whole)) * static_cast<float>(scale) + 0.5f);
    if (frac >= scale) {
      frac -= scale;
      ++whole;
    }
    if (negative && (whole != 0u || frac != 0u)) put('-');
    u32(whole);
    if (decimals) {
      put('.');
      digits(frac, scale);
    }
  }
};

/// Writes the telemetry line of t, newline included, into buf (cap bytes, NUL-terminated);
/// its length, or 0 when it did not fit.
inline size_t format_json(const Telemetry& t, char* buf, size_t cap) {
  JsonWriter w(buf, cap);
  w.str("{\"seq\":");
  w.u32(t.seq);
  w.str(",\"rpm\":");
  w.number(t.rpm, 2);
  w.str(",\"rpm_m2\":");
  w.number(t.rpm_m2, 2);
  w.str(",\"residual\":");
  w.number(t.residual_rpm, 2);
  w.str(",\"confidence\":");
  w.number(t.confidence, 3);
  w.str(",\"status\":\"");
  w.str(hpddo::status_name(t.status));
  w.str("\",\"us\":");
  w.u32(t.infer_us);
  if (hpddo::is_finite(t.rpm_ref)) {
    w.str(",\"rpm_ref\":");
    w.number(t.rpm_ref, 2);
  }
  w.str(",\"v\":");
  w.number(t.v_V, 3);
  w.str(",\"i\":");
  w.number(t.i_A, 3);
  w.str(",\"gaps\":");
  w.u32(t.gaps);
  w.str(",\"lost\":");
  w.u32(t.lost);
  w.str(",\"crc_errors\":");
  w.u32(t.crc_errors);
  w.str("}\n");
  return w.overflow() ? 0 : w.length();
}

}  // namespace infer

#endif  // HPDDO_INFER_JSON_H
