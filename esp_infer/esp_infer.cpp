// hpddo inference board (ESP8266 NodeMCU, 80 MHz): receives the UNO's frames
// on GPIO14 (D5) at 38400 baud, runs the observer with the exported model and
// writes one JSON line per sample to USB (infer::kHostBaud, 460800 baud). Thin glue
// only: the logic is in infer_link.h, infer_telemetry.h and infer_json.h (the line
// with fixed decimals and its budget), tested on the host.
#include <Arduino.h>
#include <SoftwareSerial.h>

#include "hpddo_core.h"
#include "infer_json.h"
#include "infer_link.h"
#include "infer_model.h"
#include "infer_telemetry.h"

namespace {

const uint8_t kPinLinkRx = 14;  // D5, from the UNO's D11 through a 1k/2k divider
const uint32_t kLinkBaud = 38400;

SoftwareSerial g_link(kPinLinkRx, -1);
infer::LinkReceiver g_rx(&infer::model::kModel.limits);  // frames beyond the model's channels are damage
hpddo::Observer<infer::model::Net> g_observer(infer::model::kModel);

uint32_t now_us() { return micros(); }

void write_json(const infer::Telemetry& t) {
  char line[infer::kJsonMaxLine + 1];  // on the stack; the widest line fits (InferJson tests)
  const size_t n = infer::format_json(t, line, sizeof line);
  if (n == 0) {
    Serial.println("{\"event\":\"telemetry_overflow\"}");
    return;
  }
  Serial.write(reinterpret_cast<const uint8_t*>(line), n);
}

}  // namespace

void setup() {
  Serial.begin(infer::kHostBaud);
  g_link.begin(kLinkBaud);
  const uint32_t crc = hpddo::model_checksum(infer::model::kModel);
  Serial.printf("{\"event\":\"ready\",\"model_crc_ok\":%s}\n", crc == infer::model::kChecksum ? "true" : "false");
}

void loop() {
  while (g_link.available() > 0) {
    hpddo::SampleFrame f;
    if (g_rx.push(static_cast<uint8_t>(g_link.read()), millis(), &f)) {
      write_json(infer::infer_step(g_observer, f, g_rx, now_us));
    }
  }
  yield();
}
