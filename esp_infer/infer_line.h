// The inference board's telemetry line, written with ArduinoJson 7 (one document a line,
// its memory in a fixed arena: no heap):
//
//   {"seq":412,"rpm":181.30,"rpm_m2":175.20,"residual":6.10,"confidence":1.000,"status":"ok",
//    "us":812,"rpm_ref":180.40,"v":9.612,"i":0.812,"gaps":0,"lost":0,"crc_errors":0}
//
// Speeds and the residual with 2 decimals (0.01 RPM), confidence 3, V and I 3 (the frame
// carries mV and mA), rounded half away from zero, never "-0.00". ArduinoJson has no
// fixed-decimal option (it prints a float with up to 9 digits: 9.138000488), so each number
// is formatted here and added as serialized() text; a value beyond +-kJsonLimit prints as
// that limit, a non-finite one as null. rpm_ref is left out when the frame had none.
// The lines are those of the hand-written writer this replaces, byte for byte
// (test/fixtures/telemetry_lines.txt, InferLine tests).
//
// The budget (test/firmware/test_infer.cpp, InferLine.*): the longest line is kJsonMaxLine
// bytes; at kHostBaud a line takes at most kJsonMaxLine * 10 bits, so the host link carries
// every sample the UNO's link can deliver (38400 baud, 21-byte frames: at most 183
// samples/s), and while one line goes out fewer link bytes arrive than the 64-byte receive
// buffer of SoftwareSerial holds.
#ifndef HPDDO_INFER_LINE_H
#define HPDDO_INFER_LINE_H

#include <stddef.h>
#include <stdint.h>

#include <ArduinoJson.h>

#include "hpddo/platform.h"
#include "hpddo/text.h"
#include "infer_arena.h"
#include "infer_telemetry.h"

namespace infer {

/// Host serial speed of the inference board, baud (esp_infer.cpp; the ESP8266's UART
/// divides 80 MHz by 174: 0.2 % off, within the USB bridge's tolerance).
static const uint32_t kHostBaud = 460800;

/// Largest magnitude a value is printed with.
static const float kJsonLimit = 99999.0f;

/// Longest line the telemetry writer writes, newline included, bytes (checked by a test).
static const uint8_t kJsonMaxLine = 240;

/// Longest fixed-decimal number: sign, 5 digits, point, 3 decimals, NUL.
static const size_t kNumberMax = 12;

/// v with `decimals` (0..3) fixed decimals, clamped to +-kJsonLimit, rounded half away from
/// zero, into buf (kNumberMax bytes); its length, 0 when v is not finite.
inline size_t fixed_text(float v, uint8_t decimals, char* buf) {
  if (!hpddo::is_finite(v)) return 0;
  if (v > kJsonLimit) v = kJsonLimit;
  if (v < -kJsonLimit) v = -kJsonLimit;
  hpddo::TextWriter w(buf, kNumberMax);
  const uint32_t scale = hpddo::TextWriter::pow10(decimals);
  const bool negative = v < 0.0f;
  const float mag = negative ? -v : v;
  // Whole part and fraction apart (both exact below 2^23), so large values keep their
  // decimals: the fraction alone is scaled and rounded.
  uint32_t whole = static_cast<uint32_t>(mag);
  uint32_t frac = static_cast<uint32_t>((mag - static_cast<float>(whole)) * static_cast<float>(scale) + 0.5f);
  if (frac >= scale) {
    frac -= scale;
    ++whole;
  }
  if (negative && (whole != 0u || frac != 0u)) w.put('-');
  w.u32(whole);
  if (decimals) {
    w.put('.');
    w.digits(frac, scale);
  }
  return w.length();
}

/// Arena of one telemetry document: ArduinoJson's first slot pool (ARDUINOJSON_POOL_CAPACITY
/// slots of two pointers: 128 of 8 bytes on the lx106, 256 of 16 on a 64-bit host) and 1 KB
/// for the line's strings (the peak is printed and checked by InferLine.ArenaPeakWithinItsSize).
static const size_t kLineArena = ARDUINOJSON_POOL_CAPACITY * 2 * sizeof(void*) + 1024;

/// Writes telemetry lines; holds the arena (kLineArena bytes), so one lives for the sketch.
class LineWriter {
 public:
  /// Writes the line of t, newline included, into buf (cap bytes, NUL-terminated); its
  /// length, or 0 when it did not fit (buf or arena).
  size_t write(const Telemetry& t, char* buf, size_t cap) {
    size_t n = 0;
    {
      ArduinoJson::JsonDocument doc(&arena_);
      doc["seq"] = t.seq;
      number(doc["rpm"], t.rpm, 2);
      number(doc["rpm_m2"], t.rpm_m2, 2);
      number(doc["residual"], t.residual_rpm, 2);
      number(doc["confidence"], t.confidence, 3);
      doc["status"] = hpddo::status_name(t.status);
      doc["us"] = t.infer_us;
      if (hpddo::is_finite(t.rpm_ref)) number(doc["rpm_ref"], t.rpm_ref, 2);
      number(doc["v"], t.v_V, 3);
      number(doc["i"], t.i_A, 3);
      doc["gaps"] = t.gaps;
      doc["lost"] = t.lost;
      doc["crc_errors"] = t.crc_errors;
      if (!doc.overflowed() && cap >= 2) n = ArduinoJson::serializeJson(doc, buf, cap - 1);
    }
    if (n == 0 || n + 2 > cap) {
      if (cap) buf[0] = '\0';
      return 0;
    }
    buf[n++] = '\n';
    buf[n] = '\0';
    return n;
  }

  /// Most arena bytes one line has used.
  size_t arena_peak() const { return arena_.peak(); }

 private:
  template <class Slot>
  static void number(Slot slot, float v, uint8_t decimals) {
    char text[kNumberMax];
    const size_t n = fixed_text(v, decimals, text);
    if (n)
      slot = ArduinoJson::serialized(static_cast<const char*>(text), n);
    else
      slot = nullptr;
  }

  ArenaAllocator<kLineArena> arena_;
};

}  // namespace infer

#endif  // HPDDO_INFER_LINE_H
