// Commands from the host to the inference board: one JSON object a line on the USB serial,
//   {"cmd":"status"}
// read with ArduinoJson 7 and answered with one JSON line, {"event":"<cmd>",...}. Whatever
// comes in, the console answers and stays ready for the next line:
//  - a line longer than kCommandMax bytes is dropped whole: {"event":"error","error":"too_long"};
//  - a partial line idle for kCommandIdle_ms is dropped: {"event":"error","error":"incomplete_line"};
//  - text that is not JSON (or more than one JSON value), JSON nested deeper than
//    kCommandNesting (a command is a flat object), anything but an object,
//    an object without a string "cmd", a command the board does not know, or arguments of
//    the wrong type: {"event":"error","error":"bad_json"|"not_object"|"no_cmd"|
//    "unknown_cmd"|"bad_args","detail":"..."} (bad_json's detail is ArduinoJson's error);
//  - members other than those in kCommandKeys are filtered out while parsing (never stored).
// The documents live in a fixed arena (no heap); the console holds its line buffer.
// Tested on the host (test/firmware/test_infer_json.cpp, InferConsole.*) and fuzzed with
// libFuzzer (test/fuzz/fuzz_console.cpp, ctest firmware.fuzz.console).
#ifndef HPDDO_INFER_CONSOLE_H
#define HPDDO_INFER_CONSOLE_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <ArduinoJson.h>

#include "infer_arena.h"

namespace infer {

/// Longest command line, newline excluded, bytes.
static const size_t kCommandMax = 512;
/// A partial line is dropped after this long without a byte, ms.
static const uint32_t kCommandIdle_ms = 2000;
/// Deepest nesting a command may have: a flat object of scalars and strings.
static const uint8_t kCommandNesting = 1;
/// Longest reply line, newline included, bytes.
static const size_t kReplyMax = 512;
/// The members a command may carry; any other is dropped by the parser's filter.
static const char* const kCommandKeys[] = {"cmd", "seq", "data", "bytes", "crc32"};

/// Arena of the console's documents: the filter, the command and the reply, each one
/// ArduinoJson slot pool, and the command's strings.
static const size_t kConsoleArena = 3 * ARDUINOJSON_POOL_CAPACITY * 2 * sizeof(void*) + kCommandMax + 1024;

/// Where lines to the host go, one whole line (newline included) at a time.
class LineSink {
 public:
  virtual void line(const char* text, size_t n) = 0;
  /// Lines this sink could not pass on (infer_tx.h's ring when full); 0 for a sink that never drops.
  virtual uint32_t lines_dropped() const { return 0; }

 protected:
  ~LineSink() {}
};

/// ArduinoJson reader over a byte range that remembers how far the parser read, so that
/// what follows the JSON value can be checked (ArduinoJson stops after the first value).
class RangeReader {
 public:
  RangeReader(const char* begin, size_t n) : p_(begin), end_(begin + n) {}
  int read() { return p_ < end_ ? static_cast<unsigned char>(*p_++) : -1; }
  size_t readBytes(char* out, size_t n) {
    size_t k = 0;
    while (k < n && p_ < end_) out[k++] = *p_++;
    return k;
  }
  /// True when only JSON whitespace is left unread.
  bool rest_is_blank() const {
    for (const char* q = p_; q < end_; ++q)
      if (*q != ' ' && *q != '\t' && *q != '\r' && *q != '\n') return false;
    return true;
  }

 private:
  const char* p_;
  const char* end_;
};

/// Writes doc as one line to out, or an error line when it does not fit kReplyMax.
inline void send_json(const ArduinoJson::JsonDocument& doc, LineSink& out) {
  char buf[kReplyMax + 1];
  size_t n = doc.overflowed() ? 0 : ArduinoJson::serializeJson(doc, buf, kReplyMax);
  if (n == 0 || n + 1 >= kReplyMax) {
    static const char kOverflow[] = "{\"event\":\"error\",\"error\":\"reply_too_long\"}\n";
    out.line(kOverflow, sizeof kOverflow - 1);
    return;
  }
  buf[n++] = '\n';
  buf[n] = '\0';
  out.line(buf, n);
}

/// Reads command lines, parses them and hands each command to app:
///   bool App::command(const char* cmd, ArduinoJson::JsonObjectConst args,
///                     ArduinoJson::JsonDocument& reply)
/// which fills reply (its "event" already the command's name) and returns false for a
/// command it does not know. A command that finds its arguments wrong sets
/// reply["error"] = "bad_args" (and a "detail"): the console makes that an error line.
template <class App>
class Console {
 public:
  explicit Console(App& app) : app_(app), n_(0), dropping_(false), last_ms_(0), lines_(0), errors_(0) {}

  /// One byte from the host, received at now_ms (millis()).
  void push(uint8_t byte, uint32_t now_ms, LineSink& out) {
    last_ms_ = now_ms;
    if (byte == '\n') {
      if (dropping_) {
        dropping_ = false;
        error(out, "too_long", "line longer than kCommandMax bytes, dropped");
      } else if (n_) {
        handle(out);
      }
      n_ = 0;
      return;
    }
    if (byte == '\r' || dropping_) return;
    if (n_ == kCommandMax) {
      dropping_ = true;
      n_ = 0;
      return;
    }
    buf_[n_++] = static_cast<char>(byte);
  }

  /// Drops a partial line that has waited kCommandIdle_ms since its last byte.
  void poll(uint32_t now_ms, LineSink& out) {
    if ((n_ || dropping_) && now_ms - last_ms_ > kCommandIdle_ms) {
      n_ = 0;
      dropping_ = false;
      error(out, "incomplete_line", "no newline within kCommandIdle_ms, dropped");
    }
  }

  uint32_t lines() const { return lines_; }    ///< command lines handled
  uint32_t errors() const { return errors_; }  ///< error lines sent (the console's and the app's: count_error)
  /// Counts an error line the app sent outside a command's reply (an upload that timed out).
  void count_error() { ++errors_; }
  size_t arena_peak() const { return arena_.peak(); }

 private:
  void error(LineSink& out, const char* code, const char* detail) {
    ArduinoJson::JsonDocument reply(&arena_);
    reply["event"] = "error";
    reply["error"] = code;
    reply["detail"] = detail;
    ++errors_;
    send_json(reply, out);
  }

  void handle(LineSink& out) {
    ++lines_;
    const char* code = nullptr;
    const char* detail = nullptr;
    {
      ArduinoJson::JsonDocument filter(&arena_);
      for (size_t k = 0; k < sizeof kCommandKeys / sizeof kCommandKeys[0]; ++k) filter[kCommandKeys[k]] = true;
      ArduinoJson::JsonDocument cmd(&arena_);
      RangeReader in(buf_, n_);
      const ArduinoJson::DeserializationError err =
          ArduinoJson::deserializeJson(cmd, in, ArduinoJson::DeserializationOption::Filter(filter),
                                       ArduinoJson::DeserializationOption::NestingLimit(kCommandNesting));
      if (err) {
        code = "bad_json";
        detail = err.c_str();
      } else if (!in.rest_is_blank()) {
        code = "bad_json";
        detail = "text after the JSON value";
      } else if (!cmd.is<ArduinoJson::JsonObjectConst>()) {
        code = "not_object";
        detail = "a command is a JSON object";
      } else if (!cmd["cmd"].is<const char*>()) {
        code = "no_cmd";
        detail = "a command has a string member \"cmd\"";
      } else {
        const char* name = cmd["cmd"];
        ArduinoJson::JsonDocument reply(&arena_);
        reply["event"] = name;
        if (!app_.command(name, cmd.as<ArduinoJson::JsonObjectConst>(), reply)) {
          code = "unknown_cmd";
          detail = "commands: see docs/firmware.md";
        } else if (reply["error"].is<const char*>()) {
          reply["event"] = "error";
          ++errors_;
          send_json(reply, out);
        } else {
          send_json(reply, out);
        }
      }
    }
    if (code) error(out, code, detail);
  }

  App& app_;
  char buf_[kCommandMax];
  size_t n_;
  bool dropping_;
  uint32_t last_ms_;
  uint32_t lines_;
  uint32_t errors_;
  ArenaAllocator<kConsoleArena> arena_;
};

}  // namespace infer

#endif  // HPDDO_INFER_CONSOLE_H
