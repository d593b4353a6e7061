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
#include "lx106_io.h"

extern "C" void lx106_main();

namespace {
using bench::ccount;
using bench::put;
using bench::putu;
__attribute__((unused)) bool close(float got, float want) {
  if (want != want) return got != got;
  const float scale = (want > 1.0f || want < -1.0f) ? (want < 0 ? -want : want) : 1.0f;
  const float d = got - want;
  return (d < 0 ? -d : d) <= 1e-4f * scale;
}
volatile float g_sink;
}  // namespace

extern "C" void lx106_main() {
  bench::calibrate();
  uint32_t t0, t1;
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
  bench::finish(0);
}
