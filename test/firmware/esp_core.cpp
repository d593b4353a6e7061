// Everything of the ESP8266 sketch below its Arduino glue, in one translation
// unit for xtensa-lx106-elf-g++: frame decoding, the observer with the
// deployed model, the telemetry step and its line. Its object size is what the glue adds
// to the ESP8266 core (docs/firmware.md).
#include "hpddo_core.h"
#include "infer_json.h"
#include "infer_link.h"
#include "infer_model.h"
#include "infer_telemetry.h"

namespace {
infer::LinkReceiver g_rx(&infer::model::kModel.limits);  // as the sketch
hpddo::Observer<infer::model::Net> g_observer(infer::model::kModel);
uint32_t (*g_clock)();
uint32_t clock_us() { return g_clock(); }
}  // namespace

/// One byte received at now_ms; true and *out filled when it completed a frame.
extern "C" bool hpddo_esp_push(uint8_t byte, uint32_t now_ms, infer::Telemetry* out, uint32_t (*clock)()) {
  hpddo::SampleFrame f;
  if (!g_rx.push(byte, now_ms, &f)) return false;
  g_clock = clock;
  *out = infer::infer_step(g_observer, f, g_rx, clock_us);
  return true;
}

/// True when the model in flash matches its checksum.
extern "C" bool hpddo_esp_model_ok() { return hpddo::model_checksum(infer::model::kModel) == infer::model::kChecksum; }

/// The telemetry line of t into buf (cap bytes); its length, 0 when it did not fit.
extern "C" size_t hpddo_esp_line(const infer::Telemetry* t, char* buf, size_t cap) {
  return infer::format_json(*t, buf, cap);
}
