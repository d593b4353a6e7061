// hpddo inference board (ESP8266 NodeMCU, 80 MHz): receives the UNO's frames
// on GPIO14 (D5) at 38400 baud, runs the observer with the exported model and
// writes one JSON line per sample to USB (115200 baud). Thin glue only: the
// logic is in infer_link.h and infer_telemetry.h, tested on the host.
#include <Arduino.h>
#include <ArduinoJson.h>
#include <SoftwareSerial.h>

#include "hpddo_core.h"
#include "infer_link.h"
#include "infer_model.h"
#include "infer_telemetry.h"

namespace {

const uint8_t kPinLinkRx = 14;  // D5, from the UNO's D11 through a 1k/2k divider
const uint32_t kLinkBaud = 38400;
const uint32_t kHostBaud = 115200;

SoftwareSerial g_link(kPinLinkRx, -1);
infer::LinkReceiver g_rx(&infer::model::kModel.limits);  // frames beyond the model's channels are damage
hpddo::Observer<infer::model::Net> g_observer(infer::model::kModel);

uint32_t now_us() { return micros(); }

/// Members of one telemetry line (the keys below; rpm_ref only where the frame has one).
const size_t kTelemetryMembers = 13;

void write_json(const infer::Telemetry& t) {
  // On the stack, no heap; sized for the members (keys and status are static strings,
  // stored by pointer), so the size is right on 32- and 64-bit builds alike.
  StaticJsonDocument<JSON_OBJECT_SIZE(kTelemetryMembers)> doc;
  doc["seq"] = t.seq;
  doc["rpm"] = t.rpm;
  doc["rpm_m2"] = t.rpm_m2;
  doc["residual"] = t.residual_rpm;
  doc["confidence"] = t.confidence;
  doc["status"] = hpddo::status_name(t.status);
  doc["us"] = t.infer_us;
  if (hpddo::is_finite(t.rpm_ref)) doc["rpm_ref"] = t.rpm_ref;
  doc["v"] = t.v_V;
  doc["i"] = t.i_A;
  doc["gaps"] = t.gaps;
  doc["lost"] = t.lost;
  doc["crc_errors"] = t.crc_errors;
  if (doc.overflowed()) {  // a member was dropped: say so rather than print a partial line
    Serial.println("{\"event\":\"telemetry_overflow\"}");
    return;
  }
  serializeJson(doc, Serial);
  Serial.write('\n');
}

}  // namespace

void setup() {
  Serial.begin(kHostBaud);
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
