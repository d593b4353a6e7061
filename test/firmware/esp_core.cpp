// Everything of the ESP8266 sketch below its Arduino glue, in one translation unit for
// xtensa-lx106-elf-g++: infer::App (frame decoding, the observer with the deployed model,
// the telemetry line and the host's commands, with ArduinoJson). Its object size is what
// the sketch adds to the ESP8266 core and its libraries (docs/firmware.md).
#include "hpddo_core.h"
#include "infer_app.h"
#include "infer_model.h"

namespace {
// The store's functions come from LittleFS in the sketch; here they are extern.
extern "C" int hpddo_esp_store(int op, const char* path, uint8_t* data, size_t n);
class Store : public infer::Store {
 public:
  bool mount() override { return hpddo_esp_store(10, nullptr, nullptr, 0) == 0; }
  bool format() override { return hpddo_esp_store(11, nullptr, nullptr, 0) == 0; }
  bool begin_write(const char* path) override { return hpddo_esp_store(0, path, nullptr, 0) == 0; }
  bool append(const uint8_t* data, size_t n) override {
    return hpddo_esp_store(1, nullptr, const_cast<uint8_t*>(data), n) == 0;
  }
  bool end_write() override { return hpddo_esp_store(2, nullptr, nullptr, 0) == 0; }
  bool open_read(const char* path) override { return hpddo_esp_store(3, path, nullptr, 0) == 0; }
  int read() override { return hpddo_esp_store(4, nullptr, nullptr, 0); }
  size_t read_bytes(char* out, size_t n) override {
    return static_cast<size_t>(hpddo_esp_store(5, nullptr, reinterpret_cast<uint8_t*>(out), n));
  }
  void close_read() override { hpddo_esp_store(6, nullptr, nullptr, 0); }
  bool rename(const char* from, const char* to) override {
    return hpddo_esp_store(7, from, reinterpret_cast<uint8_t*>(const_cast<char*>(to)), 0) == 0;
  }
  bool remove(const char* path) override { return hpddo_esp_store(8, path, nullptr, 0) == 0; }
  bool exists(const char* path) override { return hpddo_esp_store(9, path, nullptr, 0) == 0; }
};
Store g_store;
infer::App<infer::model::Net> g_app(infer::model::kModel, infer::model::kChecksum, g_store, infer::model::kDynamics);  // as the sketch
uint32_t (*g_clock)();
uint32_t clock_us() { return g_clock(); }
class Sink : public infer::LineSink {
 public:
  void (*write)(const char*, size_t);
  void line(const char* text, size_t n) override { write(text, n); }
};
Sink g_sink;
}  // namespace

/// One byte from the link at now_ms; a completed frame's line goes to write.
extern "C" void hpddo_esp_link_byte(uint8_t byte, uint32_t now_ms, uint32_t (*clock)(),
                                    void (*write)(const char*, size_t)) {
  g_clock = clock;
  g_sink.write = write;
  g_app.link_byte(byte, now_ms, clock_us, g_sink);
}

/// Start-up: the stored model, the ready line.
extern "C" void hpddo_esp_begin(void (*write)(const char*, size_t)) {
  g_sink.write = write;
  g_app.begin(g_sink);
}

/// One byte from the host at now_ms; replies go to write.
extern "C" void hpddo_esp_host_byte(uint8_t byte, uint32_t now_ms, void (*write)(const char*, size_t)) {
  g_sink.write = write;
  g_app.host_byte(byte, now_ms, g_sink);
  g_app.poll(now_ms, g_sink);
}
