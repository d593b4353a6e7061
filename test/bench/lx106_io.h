// Output and timing of the lx106 benchmarks in QEMU's sim machine (lx106_step.cpp,
// lx106_line.cpp): text collected in a buffer and written at the end through the
// simulator's simcall, CCOUNT read around a measured region (tools/hpddo/studies/perf.py).
#ifndef HPDDO_BENCH_LX106_IO_H
#define HPDDO_BENCH_LX106_IO_H

#include <stdint.h>

namespace bench {
static char g_out[16384];
static uint32_t g_out_n;
inline void put(const char* s) {
  while (*s && g_out_n + 1 < sizeof g_out) g_out[g_out_n++] = *s++;
}
inline void putu(uint32_t v) {
  char b[12];
  int n = 11;
  b[n] = 0;
  do {
    b[--n] = static_cast<char>('0' + v % 10u);
    v /= 10u;
  } while (v);
  put(b + n);
}
inline uint32_t ccount() {
  uint32_t c;
  __asm__ __volatile__("rsr.ccount %0" : "=a"(c)::"memory");
  return c;
}
inline void finish(int code) {
  register int a2 __asm__("a2") = 4;
  register int a3 __asm__("a3") = 1;
  register char* a4 __asm__("a4") = g_out;
  register uint32_t a5 __asm__("a5") = g_out_n;
  __asm__ __volatile__("simcall" : "+r"(a2), "+r"(a3) : "r"(a4), "r"(a5) : "memory");
  register int b2 __asm__("a2") = 1;
  register int b3 __asm__("a3") = code;
  __asm__ __volatile__("simcall" : "+r"(b2), "+r"(b3)::"memory");
  for (;;) {
  }
}
/// Prints "empty N" and "nop100 N": CCOUNT across an empty region and across 100 nops,
/// from which perf.py derives the counts per instruction.
/// Always inlined: the code around the measured regions stays as it was when the
/// committed figures were measured (docs/figures/bench_observer.json).
__attribute__((always_inline)) inline void calibrate() {
  uint32_t t0 = ccount();
  uint32_t t1 = ccount();
  put("empty ");
  putu(t1 - t0);
  put("\n");
  t0 = ccount();
  __asm__ __volatile__(".rept 100\n nop\n .endr");
  t1 = ccount();
  put("nop100 ");
  putu(t1 - t0);
  put("\n");
}
}  // namespace bench

#endif  // HPDDO_BENCH_LX106_IO_H
