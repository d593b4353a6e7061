// Platform glue: where constant model data lives and how it is read back.
//
// On the ATmega328P, constants marked HPDDO_FLASH stay in program memory and
// must be read with LPM (pgm_read_*). On the ESP8266 they live in the mapped
// SPI flash, where aligned 32-bit loads are valid, so a float reads directly.
// On a host they are ordinary constants.
//
// The host flash fake (define HPDDO_FLASH_FAKE, host tests only: Linux, GNU ld
// or lld): HPDDO_FLASH puts the data in a section of its own, hpddo_flash_fake,
// whose every byte is XOR-masked with kFlashFakeMask before main() (and before
// the first flash_float()). flash_float() undoes the mask; a direct dereference
// reads masked bytes, a wrong value, as a direct read of PROGMEM reads RAM on the
// AVR; flash_float() of a pointer outside the section aborts (on the AVR it would
// read flash at a RAM address). The generated model headers need no change.
#ifndef HPDDO_PLATFORM_H
#define HPDDO_PLATFORM_H

#include <math.h>
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
#elif defined(HPDDO_FLASH_FAKE)
#define HPDDO_FLASH __attribute__((section("hpddo_flash_fake")))
#else
#define HPDDO_FLASH
#endif

/// A function kept out of line: one copy of code called from one place in a long function (the
/// UNO's main loop), where inlined it costs flash for the registers it shuffles (dynamics.h).
#if defined(__GNUC__)
#define HPDDO_NOINLINE __attribute__((noinline))
#else
#define HPDDO_NOINLINE
#endif

/// 1 where the novelty gate stops a prototype's distance sum once it reaches the best so
/// far (the boards: no vector unit, a taken branch costs a cycle or two), 0 where every
/// sum runs in full and the minimum is taken without a data-dependent branch (hosts: the
/// early exits mispredict, the full sums vectorise). The weight is the same either way.
/// The host flash fake (below) stands for a board: its tests run the boards' path.
#if !defined(HPDDO_GATE_EARLY_EXIT)
#if defined(__AVR__) || defined(ESP8266) || defined(ARDUINO_ARCH_ESP8266) || defined(__XTENSA__) || \
    defined(HPDDO_FLASH_FAKE)
#define HPDDO_GATE_EARLY_EXIT 1
#else
#define HPDDO_GATE_EARLY_EXIT 0
#endif
#endif

#if defined(HPDDO_FLASH_FAKE) && !defined(__AVR__) && !defined(ESP8266) && !defined(ARDUINO_ARCH_ESP8266)
#define HPDDO_FLASH_FAKE_ACTIVE 1
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <unistd.h>

// Bounds of the fake flash section, from the linker (weak: zero without flash data).
extern "C" __attribute__((weak)) unsigned char __start_hpddo_flash_fake[];
extern "C" __attribute__((weak)) unsigned char __stop_hpddo_flash_fake[];

namespace hpddo {
namespace flash_fake {

/// Every byte of the fake flash is stored XOR this mask (1.0f reads as about -3.4e-23).
static const uint8_t kFlashFakeMask = 0xA5u;

/// Masks the whole section once; the pages are made writable for it, then read-only.
inline bool mask_section() {
  unsigned char* lo = __start_hpddo_flash_fake;
  unsigned char* hi = __stop_hpddo_flash_fake;
  if (!lo || !hi || hi <= lo) return true;
  const uintptr_t page = static_cast<uintptr_t>(sysconf(_SC_PAGESIZE));
  const uintptr_t a = reinterpret_cast<uintptr_t>(lo) & ~(page - 1u);
  const uintptr_t b = (reinterpret_cast<uintptr_t>(hi) + page - 1u) & ~(page - 1u);
  if (mprotect(reinterpret_cast<void*>(a), b - a, PROT_READ | PROT_WRITE) != 0) {
    perror("hpddo flash fake: mprotect");
    abort();
  }
  for (unsigned char* p = lo; p < hi; ++p) *p = static_cast<unsigned char>(*p ^ kFlashFakeMask);
  if (mprotect(reinterpret_cast<void*>(a), b - a, PROT_READ) != 0) {
    perror("hpddo flash fake: mprotect");
    abort();
  }
  return true;
}

/// Masks the section the first time it is called (a static local: once per program).
inline void ensure_masked() {
  static const bool masked = mask_section();
  (void)masked;
}

/// Runs before main() in every program that includes this header.
__attribute__((constructor)) static void mask_at_start() { ensure_masked(); }

/// Reads n bytes of fake flash at p into out, unmasked; aborts outside the section.
inline void read(const void* p, void* out, size_t n) {
  ensure_masked();
  const unsigned char* src = static_cast<const unsigned char*>(p);
  __asm__("" : "+r"(src));  // the compiler may not fold the read from the initialiser
  if (src < __start_hpddo_flash_fake || src + n > __stop_hpddo_flash_fake) {
    fprintf(stderr, "hpddo flash fake: flash read at %p outside HPDDO_FLASH data\n", p);
    abort();
  }
  unsigned char* dst = static_cast<unsigned char*>(out);
  for (size_t k = 0; k < n; ++k) dst[k] = static_cast<unsigned char>(src[k] ^ kFlashFakeMask);
}

}  // namespace flash_fake
}  // namespace hpddo
#endif

namespace hpddo {

/// The square root in float on every target (correctly rounded, as IEEE 754 requires).
/// avr-libc has no sqrtf of its own (it names sqrt, whose double is a 32-bit float there):
/// the call goes through sqrt with the conversions written out, which cost nothing on the AVR.
inline float sqrt_f(float x) {
#if defined(__AVR__)
  return static_cast<float>(sqrt(static_cast<double>(x)));
#else
  return sqrtf(x);
#endif
}

/// Reads one float stored with HPDDO_FLASH (and only such a float).
inline float flash_float(const float* p) {
#if defined(__AVR__)
  return pgm_read_float(p);
#elif defined(HPDDO_FLASH_FAKE_ACTIVE)
  float f;
  flash_fake::read(p, &f, sizeof f);
  return f;
#else
  return *p;
#endif
}

/// Reads one integer stored with HPDDO_FLASH (and only such an integer).
inline int8_t flash_int8(const int8_t* p) {
#if defined(__AVR__)
  return static_cast<int8_t>(pgm_read_byte(p));
#elif defined(HPDDO_FLASH_FAKE_ACTIVE)
  int8_t v;
  flash_fake::read(p, &v, sizeof v);
  return v;
#else
  return *p;
#endif
}

/// Reads one byte stored with HPDDO_FLASH.
inline uint8_t flash_uint8(const uint8_t* p) {
#if defined(__AVR__)
  return pgm_read_byte(p);
#elif defined(HPDDO_FLASH_FAKE_ACTIVE)
  uint8_t v;
  flash_fake::read(p, &v, sizeof v);
  return v;
#else
  return *p;
#endif
}

/// Reads one int16_t stored with HPDDO_FLASH.
inline int16_t flash_int16(const int16_t* p) {
#if defined(__AVR__)
  return static_cast<int16_t>(pgm_read_word(p));
#elif defined(HPDDO_FLASH_FAKE_ACTIVE)
  int16_t v;
  flash_fake::read(p, &v, sizeof v);
  return v;
#else
  return *p;
#endif
}

/// One value stored with HPDDO_FLASH, by its type (for code written once over float and
/// integer tables: the gates' distances).
inline float flash_read(const float* p) { return flash_float(p); }
inline int16_t flash_read(const int16_t* p) { return flash_int16(p); }

/// Reads one int32_t stored with HPDDO_FLASH.
inline int32_t flash_int32(const int32_t* p) {
#if defined(__AVR__)
  return static_cast<int32_t>(pgm_read_dword(p));
#elif defined(HPDDO_FLASH_FAKE_ACTIVE)
  int32_t v;
  flash_fake::read(p, &v, sizeof v);
  return v;
#else
  return *p;
#endif
}

/// True when x is neither NaN nor an infinity (no libm dependency): its exponent bits
/// are not all ones. (A bit test: on the AVR a float subtraction and two compares cost
/// about a hundred cycles more.)
inline bool is_finite(float x) {
  uint32_t u;
  __builtin_memcpy(&u, &x, sizeof u);
  return (u & 0x7F800000u) != 0x7F800000u;
}

/// An integer with the order of the floats: order_key(a) <= order_key(b) exactly where
/// a <= b, for every a and b that are not NaN (-0 and +0 both 0); a NaN's key lies beyond
/// the infinities' (above +inf with its sign bit clear, below -inf with it set), so no
/// compare with a bound that is not NaN holds for it on both sides. On the AVR a compare
/// of keys is about 15 cycles, a float compare (__gesf2 and friends) about 80.
inline int32_t order_key(float x) {
  uint32_t u;
  __builtin_memcpy(&u, &x, sizeof u);
  const int32_t m = static_cast<int32_t>(u & 0x7FFFFFFFu);
  return (u & 0x80000000u) ? -m : m;
}

/// lo <= x <= hi, by order_key (false for a NaN x; lo and hi not NaN).
inline bool within(float x, float lo, float hi) {
  const int32_t k = order_key(x);
  return k >= order_key(lo) && k <= order_key(hi);
}

/// x > 0 by the order key: false for zeros, negatives and NaN, as the float compare.
inline bool above_zero(float x) {
  const int32_t k = order_key(x);
  return k > 0 && k <= 0x7F800000;  // up to +inf's key; a NaN's lies above it
}

/// A quiet NaN, the marker of an absent optional reading.
inline float absent() { return __builtin_nanf(""); }

}  // namespace hpddo

#endif  // HPDDO_PLATFORM_H
