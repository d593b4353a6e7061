// Instruction counts of the ESP8266's JSON on the lx106 in QEMU (tools/hpddo/studies/perf.py):
//  - the telemetry line (infer::LineWriter, ArduinoJson 7 with pre-formatted fixed-decimal
//    numbers): the golden rows of models/default go through the link and the observer as on
//    the board (infer::infer_step; a row whose frame the link refuses gives no line), and
//    CCOUNT is read around LineWriter::write only: "line N" per line, "len N" its bytes;
//  - an uploaded model's parse and checks (infer::read_model of the default model's
//    document, upload_doc.h written by perf.py from test/fixtures/upload_default.json):
//    "parse N" its count, "parse_ok 1" when it was accepted, "arena N" the arena's peak
//    and "arena_capacity N" its size (infer::kUploadArena on the lx106).
// The compiler-runtime helpers the chip has in ROM come from perf.py's libsoft.a, the
// 64-bit ones Debian's lx106 libgcc lacks from lx106_di.cpp.
#include <stdint.h>
#include <string.h>

#include "golden_default.h"
#include "infer_line.h"
#include "infer_link.h"
#include "infer_telemetry.h"
#include "lx106_io.h"
#include "model_default.h"
#include "infer_console.h"
#include "infer_upload.h"
#include "upload_doc.h"

extern "C" void lx106_main();

extern "C" void __cxa_pure_virtual() { bench::finish(3); }

namespace {
uint32_t g_clock;
uint32_t fake_us() { return g_clock += 731u; }
}  // namespace

extern "C" void lx106_main() {
  namespace gold = hpddo_golden_default;
  namespace mdl = hpddo_model_default;
  bench::calibrate();
  infer::LineWriter writer;  // a local: the benchmark has no start-up code to construct globals
  hpddo::Observer<mdl::Net> obs(mdl::kModel);
  infer::LinkReceiver rx(&mdl::kModel.limits);
  char line[infer::kJsonMaxLine + 1];
  for (uint16_t r = 0; r < gold::kCount; ++r) {
    const hpddo::Sample s = gold::sample(r);
    hpddo::SampleFrame f;
    memset(&f, 0, sizeof f);
    f.seq = static_cast<uint16_t>(r + 1u);
    f.flags = hpddo::kFrameFlagRpm;
    f.v_mV = static_cast<uint16_t>(hpddo::saturate_round(s.v_V * 1000.0f, 0, 65535));
    f.i_mA = static_cast<int16_t>(hpddo::saturate_round(s.i_A * 1000.0f, -32768, 32767));
    f.rpm_x10 = static_cast<int16_t>(r * 37);
    f.period_us = 500000u;
    uint8_t buf[hpddo::kFrameSize];
    hpddo::encode_frame(f, buf);
    hpddo::SampleFrame got;
    bool done = false;
    for (uint8_t k = 0; k < hpddo::kFrameSize; ++k) done = rx.push(buf[k], &got);
    if (!done) continue;  // a row the link refuses (an infinite current): no line, as on the board
    const infer::Telemetry t = infer::infer_step(obs, got, rx, fake_us);
    const uint32_t t0 = bench::ccount();
    const size_t n = writer.write(t, line, sizeof line);
    const uint32_t t1 = bench::ccount();
    bench::put("line ");
    bench::putu(t1 - t0);
    bench::put("\nlen ");
    bench::putu(static_cast<uint32_t>(n));
    bench::put("\n");
  }
  {
    infer::ArenaAllocator<infer::kUploadArena> arena;  // locals, as above
    infer::ModelSlot<mdl::Net> slot;
    infer::RangeReader in(kUploadDoc, sizeof kUploadDoc - 1);
    infer::ModelError why;
    const uint32_t t0 = bench::ccount();
    const bool ok = infer::read_model<mdl::Net>(in, &arena, slot, &why);
    const uint32_t t1 = bench::ccount();
    bench::put("parse ");
    bench::putu(t1 - t0);
    bench::put("\nparse_ok ");
    bench::putu(ok ? 1u : 0u);
    bench::put("\narena ");
    bench::putu(static_cast<uint32_t>(arena.peak()));
    bench::put("\narena_capacity ");
    bench::putu(static_cast<uint32_t>(infer::kUploadArena));
    bench::put("\n");
  }
  bench::finish(0);
}
