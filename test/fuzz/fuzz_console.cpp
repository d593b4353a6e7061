// libFuzzer target: any byte stream from the host into the inference board's console
// (infer_console.h through infer::App, with the real ArduinoJson). Byte 0x01 also lets the
// clock jump past kCommandIdle_ms. Every reply must be one JSON object line with a string
// "event", within kReplyMax bytes; no more replies than lines and idle drops; and after the
// input a newline and {"cmd":"status"} must be answered with a status line (no stuck link).
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <string>
#include <vector>

#include "infer_app.h"
#include "infer_model.h"
#include "mem_store.h"

namespace {

struct Lines : infer::LineSink {
  std::vector<std::string> got;
  void line(const char* text, size_t n) override { got.push_back(std::string(text, n)); }
};

void check_reply(const std::string& s) {
  if (s.empty() || s.size() > infer::kReplyMax || s[s.size() - 1] != '\n') __builtin_trap();
  ArduinoJson::JsonDocument doc;
  if (ArduinoJson::deserializeJson(doc, s.data(), s.size() - 1)) __builtin_trap();
  if (!doc["event"].is<const char*>()) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  typedef infer::App<infer::model::Net> App;
  MemStore store;
  App* app = new App(infer::model::kModel, infer::model::kChecksum, store);
  Lines boot;
  app->begin(boot);  // mounts the store: uploads reach it
  Lines out;
  uint32_t now = 0;
  size_t events = 0;  // newlines and idle jumps: each may give one reply
  for (size_t k = 0; k < size; ++k) {
    if (data[k] == 0x01) {
      now += infer::kCommandIdle_ms + 1u;
      ++events;
    }
    if (data[k] == '\n') ++events;
    app->host_byte(data[k], now, out);
    app->poll(now, out);
  }
  if (out.got.size() > events) __builtin_trap();
  const char tail[] = "\n{\"cmd\":\"status\"}\n";
  for (size_t k = 0; k + 1 < sizeof tail; ++k) app->host_byte(static_cast<uint8_t>(tail[k]), now, out);
  if (out.got.empty() || out.got.back().compare(0, 17, "{\"event\":\"status\"") != 0) __builtin_trap();
  for (const std::string& s : out.got) check_reply(s);
  delete app;
  return 0;
}
