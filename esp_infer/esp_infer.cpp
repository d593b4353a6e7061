// hpddo inference board (ESP8266 NodeMCU, 80 MHz): receives the UNO's frames on GPIO14
// (D5) at 38400 baud, runs the observer with the model in force and writes one JSON line
// per sample to USB (infer::kHostBaud, 460800 baud); reads JSON commands from USB, among
// them a new model, kept in LittleFS (docs/firmware.md). Every JSON is ArduinoJson's.
// Nothing listens on Wi-Fi: the sketch links no network library, and the core (3.x) turns
// the radio off at boot unless a sketch calls enableWiFiAtBootTime()
// (core_esp8266_main.cpp, __disableWiFiAtBootTime). Thin glue only: the logic is
// infer::App (infer_app.h), tested on the host and run there by host/esp_host.cpp.
#include <Arduino.h>
#include <LittleFS.h>
#include <SoftwareSerial.h>

#include "hpddo_core.h"
#include "infer_app.h"
#include "infer_model.h"
#include "infer_tx.h"

namespace {

const uint8_t kPinLinkRx = 14;  // D5, from the UNO's D11 through a 1k/2k divider
const uint32_t kLinkBaud = 38400;
const size_t kHostRxBuffer = 1024;  // two whole command lines (infer::kCommandMax)

/// The board's files: LittleFS. Mounted without the core's autoFormat (LittleFSConfig's default
/// is true: LittleFS.begin() formats a file system that does not mount, the stored model lost
/// silently); a new board's blank flash is formatted by the format command (docs/firmware.md).
class FsStore : public infer::Store {
 public:
  bool mount() override {
    LittleFS.setConfig(LittleFSConfig(false));
    return LittleFS.begin();
  }
  bool format() override { return LittleFS.format() && LittleFS.begin(); }
  bool begin_write(const char* path) override {
    w_ = LittleFS.open(path, "w");
    return static_cast<bool>(w_);
  }
  bool append(const uint8_t* data, size_t n) override { return w_ && w_.write(data, n) == n; }
  bool end_write() override {
    if (!w_) return false;
    w_.close();
    return true;
  }
  bool open_read(const char* path) override {
    r_ = LittleFS.open(path, "r");
    return static_cast<bool>(r_);
  }
  int read() override { return r_.read(); }
  size_t read_bytes(char* out, size_t n) override { return r_.read(reinterpret_cast<uint8_t*>(out), n); }
  void close_read() override { r_.close(); }
  bool rename(const char* from, const char* to) override { return LittleFS.rename(from, to); }
  bool remove(const char* path) override { return LittleFS.remove(path); }
  bool exists(const char* path) override { return LittleFS.exists(path); }

 private:
  File w_;
  File r_;
};

SoftwareSerial g_link(kPinLinkRx, -1);
FsStore g_store;
infer::App<infer::model::Net> g_app(infer::model::kModel, infer::model::kChecksum, g_store, infer::model::kDynamics);

// Lines to USB through a ring: Serial.write() never waits for the UART (infer_tx.h).
infer::TxQueue<infer::kTxRing> g_out;

uint32_t now_us() { return micros(); }

}  // namespace

void setup() {
  Serial.setRxBufferSize(kHostRxBuffer);
  Serial.begin(infer::kHostBaud);
  g_link.begin(kLinkBaud);
  g_app.begin(g_out);  // mounts LittleFS through g_store, never formatting it
}

void loop() {
  while (g_link.available() > 0) g_app.link_byte(static_cast<uint8_t>(g_link.read()), millis(), now_us, g_out);
  while (Serial.available() > 0) g_app.host_byte(static_cast<uint8_t>(Serial.read()), millis(), g_out);
  g_app.poll(millis(), g_out);
  g_out.pump(Serial);
  yield();
}
