// Instruction counts of the observer on the ESP8266's core (Xtensa LX106), run in QEMU
// (qemu-system-xtensa -M sim -cpu lx106 -icount shift=10; tools/hpddo/studies/perf.py): one full
// Observer::step per golden row of models/default, the model and rows chosen by
// bench_model.h in the build folder (float or fixed point, (16, 8) or the (128, 64)
// timing model). CCOUNT is read around each step; with -icount shift=10 it advances
// 40.96 per instruction, checked in the same run on 100 nops ("nop100") against an empty
// region ("empty"). Each estimate is checked against the golden row (1e-4 relative)
// unless bench_model.h defines BENCH_NO_CHECK (the timing model has no goldens); the
// output (through the simulator's simcall write) is one line per measurement, then exit.
#include <stdint.h>
#include "bench_model.h"

extern "C" void lx106_main();

namespace {
char g_out[16384];
uint32_t g_out_n;
void put(const char* s) {
  while (*s && g_out_n + 1 < sizeof g_out) g_out[g_out_n++] = *s++;
}
void putu(uint32_t v) {
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
void finish(int code) {
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
__attribute__((unused)) bool close(float got, float want) {
  if (want != want) return got != got;
  const float scale = (want > 1.0f || want < -1.0f) ? (want < 0 ? -want : want) : 1.0f;
  const float d = got - want;
  return (d < 0 ? -d : d) <= 1e-4f * scale;
}
volatile float g_sink;
}  // namespace

extern "C" void lx106_main() {
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
  uint32_t bad = 0;
  hpddo::Observer<m::Net> obs(m::kModel);
  for (uint16_t r = 0; r < g::kCount; ++r) {
    const hpddo::Sample s = g::sample(r);
    t0 = ccount();
    const hpddo::Estimate e = obs.step(s);
    t1 = ccount();
#if !defined(BENCH_NO_CHECK)
    if (!close(e.rpm, g::at(r, g::kCol_rpm)) || e.status != static_cast<uint8_t>(g::at(r, g::kCol_status))) ++bad;
#endif
    g_sink = e.rpm;
    put("step ");
    putu(t1 - t0);
    put("\n");
  }
  put("bad ");
  putu(bad);
  put("\n");
  finish(0);
}
