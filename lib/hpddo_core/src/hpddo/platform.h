// Platform glue: where constant model data lives and how it is read back.
//
// On the ATmega328P, constants marked HPDDO_FLASH stay in program memory and
// must be read with LPM (pgm_read_*). On the ESP8266 they live in the mapped
// SPI flash, where aligned 32-bit loads are valid, so a float reads directly.
// On a host they are ordinary constants.
#ifndef HPDDO_PLATFORM_H
#define HPDDO_PLATFORM_H

#include <stddef.h>
#include <stdint.h>

#if defined(__AVR__)
#include <avr/pgmspace.h>
#define HPDDO_FLASH PROGMEM
#elif defined(ESP8266) || defined(ARDUINO_ARCH_ESP8266)
#if defined(PROGMEM)
#define HPDDO_FLASH PROGMEM
#else
#define HPDDO_FLASH __attribute__((section(".irom.text"), aligned(4)))
#endif
#else
#define HPDDO_FLASH
#endif

namespace hpddo {

/// Reads one float stored with HPDDO_FLASH.
inline float flash_float(const float* p) {
#if defined(__AVR__)
  return pgm_read_float(p);
#else
  return *p;
#endif
}

/// True when x is neither NaN nor an infinity (no libm dependency).
inline bool is_finite(float x) {
  const float d = x - x;
  return d == d && d == 0.0f;
}

/// A quiet NaN, the marker of an absent optional reading.
inline float absent() { return __builtin_nanf(""); }

}  // namespace hpddo

#endif  // HPDDO_PLATFORM_H
