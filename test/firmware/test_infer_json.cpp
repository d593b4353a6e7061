// Host tests of everything the inference board reads or writes as JSON, built against the
// real ArduinoJson 7.2.0 (../shared/vendor, test/vendor.cmake): the telemetry line
// (infer_line.h) against the hand-written writer's lines byte for byte, and its budget; the
// host's commands (infer_console.h through infer::App).
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include <vector>

#include "acq_config.h"
#include "infer_app.h"
#include "infer_line.h"
#include "infer_tx.h"
#include "golden.h"
#include "infer_model.h"
#include "mem_store.h"

#include HPDDO_GOLDEN_HEADER

#ifndef HPDDO_TELEMETRY_LINES
#error "HPDDO_TELEMETRY_LINES: path of test/fixtures/telemetry_lines.txt"
#endif

namespace {

using golden::from_bits;

infer::Telemetry widest() {
  infer::Telemetry t;
  t.seq = 65535;
  t.rpm = t.rpm_m2 = t.residual_rpm = t.rpm_ref = -1e30f;
  t.confidence = -1e30f;
  t.status = hpddo::kStatusFallback;  // the longest status name
  t.infer_us = 4294967295u;
  t.v_V = t.i_A = -1e30f;
  t.gaps = t.lost = t.crc_errors = 4294967295u;
  return t;
}

infer::LineWriter g_writer;  // as the sketch: one for the program (it holds the arena)

}  // namespace

TEST(InferLine, EveryReferenceLineByteForByte) {
  std::ifstream in(HPDDO_TELEMETRY_LINES);
  ASSERT_TRUE(in) << HPDDO_TELEMETRY_LINES;
  std::string row;
  size_t cases = 0, differ = 0;
  while (std::getline(in, row)) {
    if (row.empty() || row[0] == '#') continue;
    const size_t tab = row.find('\t');
    ASSERT_NE(tab, std::string::npos) << row;
    unsigned seq, status, us, gaps, lost, crc;
    unsigned b[7];
    ASSERT_EQ(std::sscanf(row.c_str(), "%u %x %x %x %x %u %u %x %x %x %u %u %u", &seq, &b[0], &b[1], &b[2], &b[3],
                          &status, &us, &b[4], &b[5], &b[6], &gaps, &lost, &crc),
              13)
        << row;
    infer::Telemetry t;
    t.seq = static_cast<uint16_t>(seq);
    t.rpm = from_bits(b[0]);
    t.rpm_m2 = from_bits(b[1]);
    t.residual_rpm = from_bits(b[2]);
    t.confidence = from_bits(b[3]);
    t.status = static_cast<hpddo::Status>(status);
    t.infer_us = us;
    t.rpm_ref = from_bits(b[4]);
    t.v_V = from_bits(b[5]);
    t.i_A = from_bits(b[6]);
    t.gaps = gaps;
    t.lost = lost;
    t.crc_errors = crc;
    char buf[infer::kJsonMaxLine + 1];
    const size_t n = g_writer.write(t, buf, sizeof buf);
    const std::string want = row.substr(tab + 1) + "\n";
    ++cases;
    if (std::string(buf, n) != want) {
      if (++differ <= 5) ADD_FAILURE() << "case " << cases << "\n got: " << std::string(buf, n) << " want: " << want;
    }
  }
  std::printf("%zu reference lines, %zu differ\n", cases, differ);
  EXPECT_GT(cases, 4000u);
  EXPECT_EQ(differ, 0u);
}

TEST(InferLine, FixedDecimalsRoundHalfAwayAndNoNegativeZero) {
  infer::Telemetry t = widest();
  t.seq = 412;
  t.rpm = 181.3f;
  t.rpm_m2 = 175.2f;
  t.residual_rpm = -0.004f;
  t.confidence = 1.0f;
  t.status = hpddo::kStatusOk;
  t.infer_us = 812;
  t.rpm_ref = hpddo::absent();
  t.v_V = 9.6125f;
  t.i_A = -0.8125f;
  t.gaps = 0;
  t.lost = 2;
  t.crc_errors = 1;
  char buf[infer::kJsonMaxLine + 1];
  const size_t n = g_writer.write(t, buf, sizeof buf);
  EXPECT_STREQ(buf, "{\"seq\":412,\"rpm\":181.30,\"rpm_m2\":175.20,\"residual\":0.00,\"confidence\":1.000,"
                    "\"status\":\"ok\",\"us\":812,\"v\":9.613,\"i\":-0.813,\"gaps\":0,\"lost\":2,\"crc_errors\":1}\n");
  EXPECT_EQ(n, std::strlen(buf));
  t.rpm = std::nanf("");
  g_writer.write(t, buf, sizeof buf);
  EXPECT_NE(std::strstr(buf, "\"rpm\":null"), nullptr);
}

TEST(InferLine, WidestLineFitsAndTooSmallABufferIsRefused) {
  char buf[512];
  const size_t n = g_writer.write(widest(), buf, sizeof buf);
  std::printf("widest telemetry line: %zu bytes: %s", n, buf);
  EXPECT_GT(n, 0u);
  EXPECT_LE(n, infer::kJsonMaxLine);
  EXPECT_NE(std::strstr(buf, "\"rpm\":-99999.00"), nullptr);
  // Every buffer shorter than the line and its NUL is refused whole; the exact size fits.
  for (size_t cap = 0; cap <= n; ++cap) {
    char small[512];
    std::memset(small, 'x', sizeof small);
    EXPECT_EQ(g_writer.write(widest(), small, cap), 0u) << cap;
    if (cap) {
      EXPECT_EQ(small[0], '\0') << cap;
    }
    EXPECT_EQ(small[cap], 'x') << "wrote past the buffer at cap " << cap;
  }
  EXPECT_EQ(g_writer.write(widest(), buf, n + 1), n);
}

TEST(InferLine, ArenaPeakWithinItsSize) {
  g_writer.write(widest(), nullptr, 0);
  std::printf("telemetry document arena: peak %zu of %zu bytes (%zu-bit host)\n", g_writer.arena_peak(),
              infer::kLineArena, sizeof(void*) * 8);
  EXPECT_GT(g_writer.arena_peak(), 0u);
  EXPECT_LT(g_writer.arena_peak(), infer::kLineArena);
}

TEST(InferLine, HostLinkCarriesEverySampleTheUnoCanSend) {
  // The UNO's link: 38400 baud, 8N1, one kFrameSize-byte frame a sample.
  const double frames_per_s = static_cast<double>(acq::kLinkBaud) / (10.0 * hpddo::kFrameSize);
  const double line_bits = 10.0 * infer::kJsonMaxLine;
  const double lines_per_s = static_cast<double>(infer::kHostBaud) / line_bits;
  std::printf("host link: %u baud, widest line %u bytes: %.1f lines/s; UNO link at most %.1f samples/s\n",
              static_cast<unsigned>(infer::kHostBaud), static_cast<unsigned>(infer::kJsonMaxLine), lines_per_s,
              frames_per_s);
  EXPECT_GE(lines_per_s, frames_per_s);
  EXPECT_GE(lines_per_s, 100.0 * 1.5);  // 100 Hz with half again to spare
  // While the widest line goes out, the link delivers fewer bytes than SoftwareSerial's
  // 64-byte receive buffer holds, even with a whole frame already waiting.
  const double link_bytes_per_s = static_cast<double>(acq::kLinkBaud) / 10.0;
  const double arriving = line_bits / static_cast<double>(infer::kHostBaud) * link_bytes_per_s + hpddo::kFrameSize;
  std::printf("link bytes arriving during the widest line, plus one frame: %.1f of 64\n", arriving);
  EXPECT_LE(arriving, 64.0);
}

// ---- commands from the host (infer_console.h), through the board's App
namespace {

typedef infer::App<infer::model::Net> App;

struct Lines : infer::LineSink {
  std::vector<std::string> got;
  void line(const char* text, size_t n) override { got.push_back(std::string(text, n)); }
};

// Sends text to the app's console at now_ms; the replies it wrote.
std::vector<std::string> send(App& app, const std::string& text, uint32_t now_ms = 0) {
  Lines out;
  for (char c : text) app.host_byte(static_cast<uint8_t>(c), now_ms, out);
  return out.got;
}

std::string error_of(const std::string& reply) {
  const size_t k = reply.find("\"error\":\"");
  if (reply.compare(0, 18, "{\"event\":\"error\",\"") != 0 || k == std::string::npos) return "";
  return reply.substr(k + 9, reply.find('"', k + 9) - k - 9);
}

App& fresh_app() {
  static App* app = nullptr;
  static MemStore* store = nullptr;
  delete app;
  delete store;
  store = new MemStore;
  app = new App(infer::model::kModel, infer::model::kChecksum, *store);
  Lines boot;
  app->begin(boot);
  return *app;
}

}  // namespace

TEST(InferConsole, StatusReportsTheModelAndCounters) {
  App& app = fresh_app();
  const std::vector<std::string> r = send(app, "{\"cmd\":\"status\"}\n");
  ASSERT_EQ(r.size(), 1u);
  char want[160];
  std::snprintf(want, sizeof want, "{\"event\":\"status\",\"model\":\"compiled\",\"model_crc\":%u,\"model_crc_ok\":true,",
                static_cast<unsigned>(infer::model::kChecksum));
  EXPECT_EQ(r[0].compare(0, std::strlen(want), want), 0) << r[0];
  EXPECT_NE(r[0].find("\"commands\":1,\"command_errors\":0,\"uploading\":false,\"fs\":\"mounted\",\"tx_dropped\":0}\n"),
            std::string::npos) << r[0];
  // CR LF line ends, members in any order, and members the filter drops change nothing.
  const std::vector<std::string> r2 = send(app, "{\"x\":1.5,\"cmd\":\"status\",\"z\":\"w\"}\r\n");
  ASSERT_EQ(r2.size(), 1u);
  EXPECT_EQ(r2[0].compare(0, 17, "{\"event\":\"status\""), 0) << r2[0];
}

TEST(InferConsole, EveryMalformedLineGetsOneErrorLineAndTheNextCommandWorks) {
  struct Case {
    const char* line;
    const char* error;
  } cases[] = {
      {"status", "bad_json"},
      {"{\"x\":[1],\"cmd\":\"status\"}", "bad_json"},  // nested, even where filtered out
      {"{\"cmd\":\"status\"", "bad_json"},
      {"{\"cmd\":status}", "bad_json"},
      {"{\"cmd\":\"status\",}", "bad_json"},
      {"[\"cmd\",\"status\"]", "not_object"},
      {"42", "not_object"},
      {"\"status\"", "not_object"},
      {"{}", "no_cmd"},
      {"{\"cmd\":1}", "no_cmd"},
      {"{\"cmd\":null}", "no_cmd"},
      {"{\"cmd\":{\"a\":1}}", "bad_json"},  // nested deeper than kCommandNesting
      {"{\"cmd\":\"reboot\"}", "unknown_cmd"},
      {"{\"cmd\":\"\"}", "unknown_cmd"},
      {"{\"cmd\":\"st\\u0000atus\"}", "unknown_cmd"},
      {"{\"cmd\":\"status\"} trailing", "bad_json"},
      {"\xff\xfe{\"cmd\":\"status\"}", "bad_json"},
      {"{\"cmd\":\"status\"}{\"cmd\":\"status\"}", "bad_json"},
  };
  App& app = fresh_app();
  for (const Case& c : cases) {
    const std::vector<std::string> r = send(app, std::string(c.line) + "\n");
    ASSERT_EQ(r.size(), 1u) << c.line;
    EXPECT_EQ(error_of(r[0]), c.error) << c.line << " -> " << r[0];
    const std::vector<std::string> ok = send(app, "{\"cmd\":\"status\"}\n");
    ASSERT_EQ(ok.size(), 1u) << "after " << c.line;
    EXPECT_EQ(ok[0].compare(0, 17, "{\"event\":\"status\""), 0) << "after " << c.line << ": " << ok[0];
  }
  std::printf("example error line: %s", send(app, "{\"cmd\":status}\n")[0].c_str());
  EXPECT_TRUE(send(app, "\n\r\n\n").empty());  // empty lines are no commands
}

TEST(InferConsole, ALineBeyondTheLimitIsDroppedWholeAndTheLinkRecovers) {
  App& app = fresh_app();
  // Exactly kCommandMax bytes is still a command (padded with spaces JSON allows).
  std::string at_limit = "{\"cmd\":\"status\"}";
  at_limit += std::string(infer::kCommandMax - at_limit.size(), ' ');
  std::vector<std::string> r = send(app, at_limit + "\n");
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].compare(0, 17, "{\"event\":\"status\""), 0) << r[0];
  r = send(app, at_limit + " \n");
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(error_of(r[0]), "too_long");
  r = send(app, std::string(100000, 'x') + "\n{\"cmd\":\"status\"}\n");
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(error_of(r[0]), "too_long");
  EXPECT_EQ(r[1].compare(0, 17, "{\"event\":\"status\""), 0) << r[1];
}

TEST(InferConsole, APartialLineIsDroppedAfterTheIdleTime) {
  App& app = fresh_app();
  Lines out;
  EXPECT_TRUE(send(app, "{\"cmd\":\"sta", 1000).empty());
  app.poll(1000 + infer::kCommandIdle_ms, out);
  EXPECT_TRUE(out.got.empty());
  app.poll(1000 + infer::kCommandIdle_ms + 1, out);
  ASSERT_EQ(out.got.size(), 1u);
  EXPECT_EQ(error_of(out.got[0]), "incomplete_line");
  const std::vector<std::string> r = send(app, "{\"cmd\":\"status\"}\n", 5000);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].compare(0, 17, "{\"event\":\"status\""), 0) << r[0];
}

TEST(InferConsole, CommandsNeverTouchTheObserverOrTheLink) {
  // Telemetry of the golden rows with garbage commands between every two frames equals
  // the telemetry without them.
  namespace gold = ::HPDDO_GOLDEN_NS;
  App& quiet = fresh_app();
  static MemStore noisy_store;
  static App noisy(infer::model::kModel, infer::model::kChecksum, noisy_store);
  uint32_t clock_a = 0, clock_b = 0;
  Lines a, b, replies;
  uint32_t rnd = 12345u;
  for (uint16_t r = 0; r < gold::kCount; ++r) {
    const hpddo::Sample s = gold::sample(r);
    hpddo::SampleFrame f;
    std::memset(&f, 0, sizeof f);
    f.seq = static_cast<uint16_t>(r + 1u);
    f.v_mV = static_cast<uint16_t>(s.v_V * 1000.0f + 0.5f);
    f.i_mA = static_cast<int16_t>(std::lround(s.i_A * 1000.0f));
    f.period_us = 500000u;
    uint8_t buf[hpddo::kFrameSize];
    hpddo::encode_frame(f, buf);
    for (uint8_t byte : buf) {
      quiet.link_byte(byte, r * 500u, [&clock_a]() { return clock_a += 100u; }, a);
      noisy.link_byte(byte, r * 500u, [&clock_b]() { return clock_b += 100u; }, b);
    }
    for (int k = 0; k < 300; ++k) {
      rnd = rnd * 1664525u + 1013904223u;
      noisy.host_byte(static_cast<uint8_t>(rnd >> 24), r * 500u, replies);
    }
    noisy.host_byte('\n', r * 500u, replies);
  }
  ASSERT_EQ(a.got.size(), static_cast<size_t>(gold::kCount));
  EXPECT_EQ(a.got, b.got);
  EXPECT_GE(replies.got.size(), static_cast<size_t>(gold::kCount));
  for (const std::string& line : replies.got) EXPECT_EQ(line.compare(0, 17, "{\"event\":\"error\","), 0) << line;
  std::printf("console arena: peak %zu of %zu bytes\n", noisy.console().arena_peak(), infer::kConsoleArena);
  EXPECT_LT(noisy.console().arena_peak(), infer::kConsoleArena);
}

// ---- a new model without reflashing (infer_upload.h through the App's commands)

#ifndef HPDDO_UPLOAD_DOCUMENT
#error "HPDDO_UPLOAD_DOCUMENT: path of test/fixtures/upload_default.json"
#endif

namespace {

std::string read_file(const char* path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The default model's document as `hpddo upload` writes it (test/fixtures/upload_default.json,
// regenerated and compared by test/py/test_upload.py).
const std::string& default_document() {
  static const std::string doc = read_file(HPDDO_UPLOAD_DOCUMENT);
  return doc;
}

uint32_t crc32_of(const std::string& s) {
  return hpddo::crc32(reinterpret_cast<const uint8_t*>(s.data()), s.size());
}

std::string json_line(const ArduinoJson::JsonDocument& doc) {
  std::string s;
  ArduinoJson::serializeJson(doc, s);
  return s + "\n";
}

std::string upload_line(size_t bytes, uint32_t crc) {
  ArduinoJson::JsonDocument d;
  d["cmd"] = "upload";
  d["bytes"] = bytes;
  d["crc32"] = crc;
  return json_line(d);
}

// The chunk commands of doc: pieces of at most `piece` bytes.
std::vector<std::string> chunk_lines(const std::string& doc, size_t piece = 300) {
  std::vector<std::string> out;
  for (size_t at = 0, seq = 0; at < doc.size(); at += piece, ++seq) {
    ArduinoJson::JsonDocument d;
    d["cmd"] = "chunk";
    d["seq"] = seq;
    d["data"] = doc.substr(at, piece);
    out.push_back(json_line(d));
  }
  return out;
}

// Uploads doc as `hpddo upload` does; the replies.
std::vector<std::string> upload(App& app, const std::string& doc) {
  std::vector<std::string> got = send(app, upload_line(doc.size(), crc32_of(doc)));
  for (const std::string& line : chunk_lines(doc)) {
    const std::vector<std::string> r = send(app, line);
    got.insert(got.end(), r.begin(), r.end());
  }
  const std::vector<std::string> r = send(app, "{\"cmd\":\"commit\"}\n");
  got.insert(got.end(), r.begin(), r.end());
  return got;
}

bool committed(const std::vector<std::string>& replies) {
  const std::string want = "{\"event\":\"commit\",\"model\":\"uploaded\",";
  return !replies.empty() && replies.back().compare(0, want.size(), want) == 0;
}

// The estimates of a fresh observer of the app's model in force over the golden rows,
// as bytes: equal strings are equal bit for bit.
std::string estimates(const App& app) {
  namespace gold = ::HPDDO_GOLDEN_NS;
  hpddo::Observer<infer::model::Net> obs(app.model());
  std::string out;
  for (uint16_t r = 0; r < gold::kCount; ++r) {
    const hpddo::Estimate e = obs.step(gold::sample(r));
    const float v[] = {e.rpm, e.rpm_m2, e.residual_rpm, e.confidence, static_cast<float>(e.status)};
    out.append(reinterpret_cast<const char*>(v), sizeof v);
  }
  return out;
}

}  // namespace

TEST(InferUpload, TheUploadedDefaultModelGivesTheGoldenVectorsBitForBitAndSurvivesAReset) {
  namespace gold = ::HPDDO_GOLDEN_NS;
  MemStore store;
  App app(infer::model::kModel, infer::model::kChecksum, store);
  Lines boot;
  app.begin(boot);
  ASSERT_EQ(boot.got.size(), 1u);
  EXPECT_NE(boot.got[0].find("\"model\":\"compiled\""), std::string::npos) << boot.got[0];
  const std::string compiled = estimates(app);
  const std::vector<std::string> r = upload(app, default_document());
  ASSERT_TRUE(committed(r)) << r.back();
  EXPECT_TRUE(app.uploaded());
  EXPECT_EQ(app.model_crc(), infer::model::kChecksum);
  EXPECT_NE(&app.model(), &infer::model::kModel);  // the RAM copy runs, not the compiled one
  EXPECT_EQ(estimates(app), compiled);             // bit for bit
  hpddo::Observer<infer::model::Net> obs(app.model());
  for (uint16_t row = 0; row < gold::kCount; ++row) {
    const hpddo::Estimate e = obs.step(gold::sample(row));
    EXPECT_TRUE(golden::close(e.rpm, gold::at(row, gold::kCol_rpm))) << row;
    EXPECT_EQ(static_cast<float>(e.status), gold::at(row, gold::kCol_status)) << row;
  }
  EXPECT_EQ(store.files.count(infer::kModelPath), 1u);
  EXPECT_EQ(store.files.count(infer::kModelNewPath), 0u);
  EXPECT_EQ(store.files[infer::kModelPath], default_document());
  std::printf("upload of the default model: %zu bytes, %zu chunk lines, parse arena peak %zu of %zu bytes\n",
              default_document().size(), chunk_lines(default_document()).size(), app.upload_arena_peak(),
              infer::kUploadArena);
  EXPECT_LT(app.upload_arena_peak(), infer::kUploadArena);
  // A reset: a new App over the same store runs the stored model.
  App after(infer::model::kModel, infer::model::kChecksum, store);
  Lines boot2;
  after.begin(boot2);
  ASSERT_EQ(boot2.got.size(), 1u);
  EXPECT_NE(boot2.got[0].find("\"model\":\"uploaded\""), std::string::npos) << boot2.got[0];
  EXPECT_TRUE(after.uploaded());
  EXPECT_EQ(estimates(after), compiled);
  // use_compiled forgets it.
  const std::vector<std::string> back = send(after, "{\"cmd\":\"use_compiled\"}\n");
  ASSERT_EQ(back.size(), 1u);
  EXPECT_NE(back[0].find("\"model\":\"compiled\""), std::string::npos) << back[0];
  EXPECT_EQ(store.files.count(infer::kModelPath), 0u);
  EXPECT_EQ(&after.model(), &infer::model::kModel);
}

TEST(InferUpload, AnotherModelIsPutInForceAndAChangedParameterShows) {
  // The default document with the armature resistance doubled and its checksum recomputed
  // (hpddo::model_checksum over the parsed model): the board runs the new physics.
  MemStore store;
  App app(infer::model::kModel, infer::model::kChecksum, store);
  Lines boot;
  app.begin(boot);
  const std::string compiled = estimates(app);
  ArduinoJson::JsonDocument d;
  ASSERT_FALSE(ArduinoJson::deserializeJson(d, default_document()));
  const float ra = 2.0f * golden::from_bits(d["physics"][0].as<uint32_t>());
  d["physics"][0] = golden::bits(ra);
  MemStore scratch_store;
  infer::ModelSlot<infer::model::Net> slot;
  infer::ModelError why;
  std::string text;
  ArduinoJson::serializeJson(d, text);
  infer::RangeReader in(text.data(), text.size());
  infer::ArenaAllocator<infer::kUploadArena> arena;
  EXPECT_FALSE(infer::read_model<infer::model::Net>(in, &arena, slot, &why));
  EXPECT_STREQ(why.code, "checksum");
  d["crc"] = hpddo::model_checksum(slot.model);
  text.clear();
  ArduinoJson::serializeJson(d, text);
  ASSERT_TRUE(committed(upload(app, text)));
  EXPECT_EQ(app.model().physics.ra_ohm, ra);
  EXPECT_NE(estimates(app), compiled);
}

TEST(InferUpload, FuzzedUploadsNeverChangeTheModelInForce) {
  MemStore store;
  App app(infer::model::kModel, infer::model::kChecksum, store);
  Lines boot;
  app.begin(boot);
  const std::string& doc = default_document();
  // In force: the default model, uploaded (so a damaged upload would have a RAM copy to spoil).
  ASSERT_TRUE(committed(upload(app, doc)));
  const std::string before = estimates(app);
  const uint32_t crc_before = app.model_crc();
  const hpddo::Model<infer::model::Net>* model_before = &app.model();
  const std::string stored_before = store.files[infer::kModelPath];
  std::map<std::string, int> refused;
  int cases = 0;
  auto check = [&](const std::vector<std::string>& replies, const char* kind) {
    ++cases;
    EXPECT_FALSE(committed(replies)) << kind;
    bool error = false;
    for (const std::string& line : replies) error |= !error_of(line).empty();
    EXPECT_TRUE(error) << kind << ": no error line";
    for (const std::string& line : replies) {  // the first error line: its code and reason
      if (error_of(line).empty()) continue;
      const size_t at = line.find("\"reason\":\"");
      ++refused[error_of(line) + (at == std::string::npos ? "" : " / " + line.substr(at + 10, line.find('"', at + 10) - at - 10))];
      break;
    }
    EXPECT_EQ(app.model_crc(), crc_before) << kind;
    EXPECT_EQ(&app.model(), model_before) << kind;
    EXPECT_EQ(store.files[infer::kModelPath], stored_before) << kind;
    EXPECT_EQ(store.files.count(infer::kModelNewPath), 0u) << kind;
  };
  uint32_t rnd = 20261125u;
  auto next = [&rnd]() {
    rnd ^= rnd << 13;
    rnd ^= rnd >> 17;
    rnd ^= rnd << 5;
    return rnd;
  };
  // Truncated documents (announced and sent as they are: the parser sees the cut).
  for (int k = 0; k < 60; ++k) check(upload(app, doc.substr(0, next() % doc.size())), "truncated");
  // Random bytes changed (CRC-32 recomputed: the transport is fine, the model is not).
  for (int k = 0; k < 120; ++k) {
    std::string d = doc;
    const int flips = 1 + static_cast<int>(next() % 3);
    for (int f = 0; f < flips; ++f) d[next() % d.size()] = static_cast<char>(next() & 0xFF);
    if (d == doc) continue;
    check(upload(app, d), "byte changed");
  }
  // Two array elements swapped (reordered values: the checksum sees it).
  for (int k = 0; k < 60; ++k) {
    ArduinoJson::JsonDocument d;
    ASSERT_FALSE(ArduinoJson::deserializeJson(d, doc));
    const char* keys[] = {"w0", "w1", "b0", "gate_prototypes", "scaler_mean", "physics"};
    ArduinoJson::JsonArray a = d[keys[next() % 6]];
    const size_t i = next() % a.size(), j = next() % a.size();
    if (a[i].as<uint32_t>() == a[j].as<uint32_t>()) continue;
    const uint32_t t = a[i];
    a[i] = a[j].as<uint32_t>();
    a[j] = t;
    std::string text;
    ArduinoJson::serializeJson(d, text);
    check(upload(app, text), "elements swapped");
  }
  // Wrong types and huge numbers in place of one element or member.
  const char* values[] = {"1.5",  "-1",  "1e30", "99999999999999999999999", "\"12\"", "null",
                          "true", "[1]", "{}",   "4294967296",              "2139095040" /* inf */};
  const char* members[] = {"w0", "b2", "gate_r", "limits", "physics", "crc", "clamp_rpm", "layout", "shape", "hpddo_model"};
  for (const char* member : members) {
    for (const char* value : values) {
      std::string d = doc;
      const size_t at = d.find(std::string("\"") + member + "\":");
      ASSERT_NE(at, std::string::npos) << member;
      size_t v = at + std::strlen(member) + 3;
      if (d[v] == '[') ++v;  // an array: its first element
      const size_t end = d.find_first_of(",]}", v);
      d.replace(v, end - v, value);
      check(upload(app, d), "wrong type");
    }
  }
  // Members missing, a wrong checksum, layout, format or shape.
  for (const char* member : members) {
    ArduinoJson::JsonDocument d;
    ASSERT_FALSE(ArduinoJson::deserializeJson(d, doc));
    d.remove(member);
    std::string text;
    ArduinoJson::serializeJson(d, text);
    check(upload(app, text), "member missing");
  }
  {
    ArduinoJson::JsonDocument d;
    ASSERT_FALSE(ArduinoJson::deserializeJson(d, doc));
    d["crc"] = d["crc"].as<uint32_t>() ^ 1u;
    std::string text;
    ArduinoJson::serializeJson(d, text);
    check(upload(app, text), "wrong crc");
    d["crc"] = d["crc"].as<uint32_t>() ^ 1u;
    d["shape"][1] = 32;
    text.clear();
    ArduinoJson::serializeJson(d, text);
    const std::vector<std::string> r = upload(app, text);
    check(r, "wrong shape");
    EXPECT_NE(r.back().find("\"reason\":\"shape\""), std::string::npos) << r.back();
    EXPECT_NE(r.back().find("pio run -e esp8266"), std::string::npos) << r.back();
  }
  // The transport: a chunk lost, chunks reordered, a wrong CRC-32 announced, fewer or more
  // bytes than announced, no commit (the upload times out), the store failing.
  const std::vector<std::string> chunks = chunk_lines(doc);
  {
    std::vector<std::string> r = send(app, upload_line(doc.size(), crc32_of(doc)));
    for (size_t k = 0; k < chunks.size(); ++k)
      if (k != 3) send(app, chunks[k]);
    r = send(app, "{\"cmd\":\"commit\"}\n");
    check(r, "chunk lost");
  }
  {
    std::vector<std::string> r = send(app, upload_line(doc.size(), crc32_of(doc)));
    send(app, chunks[0]);
    std::vector<std::string> r2 = send(app, chunks[2]);
    EXPECT_EQ(error_of(r2[0]), "upload_seq");
    send(app, chunks[1]);
    r = send(app, "{\"cmd\":\"commit\"}\n");
    check(r, "chunks reordered");
  }
  check(send(app, upload_line(doc.size(), crc32_of(doc) ^ 4u) + [&] {
          std::string all;
          for (const std::string& c : chunks) all += c;
          return all;
        }() + "{\"cmd\":\"commit\"}\n"),
        "wrong crc32 announced");
  check(upload(app, doc + "x"), "text after the document");
  {
    // A byte more than announced is refused while receiving.
    std::vector<std::string> r = send(app, upload_line(doc.size() - 1, crc32_of(doc)));
    for (const std::string& c : chunks) {
      const std::vector<std::string> rr = send(app, c);
      r.insert(r.end(), rr.begin(), rr.end());
    }
    check(r, "more than announced");
  }
  {
    Lines out;
    send(app, upload_line(doc.size(), crc32_of(doc)), 100);
    send(app, chunks[0], 200);
    app.poll(200 + infer::kUploadIdle_ms, out);
    EXPECT_TRUE(out.got.empty());
    app.poll(201 + infer::kUploadIdle_ms, out);
    check(out.got, "upload stopped");
    EXPECT_EQ(error_of(out.got[0]), "upload_timeout");
    check(send(app, chunks[1], 9000), "chunk after the timeout");
  }
  store.fail_append_at = store.appends() + 2;
  check(upload(app, doc), "store write fails");
  store.fail_append_at = -1;
  store.fail_rename = true;
  check(upload(app, doc), "store rename fails");
  store.fail_rename = false;
  std::printf("%d damaged uploads refused, the model in force unchanged; their first error lines:\n", cases);
  for (const auto& kv : refused) std::printf("  %4d  %s\n", kv.second, kv.first.c_str());
  EXPECT_EQ(estimates(app), before);
  // Members in another order are the same model: accepted, the same checksum.
  ArduinoJson::JsonDocument d;
  ASSERT_FALSE(ArduinoJson::deserializeJson(d, doc));
  ArduinoJson::JsonDocument rev;
  ArduinoJson::JsonObject src = d.as<ArduinoJson::JsonObject>();
  std::vector<ArduinoJson::JsonPair> pairs;
  for (ArduinoJson::JsonPair kv : src) pairs.push_back(kv);
  for (auto it = pairs.rbegin(); it != pairs.rend(); ++it) rev[it->key()] = it->value();
  std::string text;
  ArduinoJson::serializeJson(rev, text);
  ASSERT_NE(text, doc);
  ASSERT_TRUE(committed(upload(app, text)));
  ASSERT_TRUE(committed(upload(app, "\r\n " + doc + " \n")));  // JSON's whitespace around it
  EXPECT_EQ(app.model_crc(), crc_before);
  EXPECT_EQ(estimates(app), before);
}

TEST(InferUpload, AnUploadThatTimesOutCountsAsACommandError) {
  App& app = fresh_app();
  Lines out;
  send(app, upload_line(default_document().size(), crc32_of(default_document())), 100);
  app.poll(101 + infer::kUploadIdle_ms, out);
  ASSERT_EQ(out.got.size(), 1u);
  EXPECT_EQ(error_of(out.got[0]), "upload_timeout");
  const std::vector<std::string> r = send(app, "{\"cmd\":\"status\"}\n", 6000);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_NE(r[0].find("\"commands\":2,\"command_errors\":1,"), std::string::npos) << r[0];
}

// ---- the file system: mounted as it is, never formatted behind the user's back

namespace {
std::string status_of(App& app) {
  const std::vector<std::string> r = send(app, "{\"cmd\":\"status\"}\n");
  return r.size() == 1 ? r[0] : "";
}
}  // namespace

TEST(InferStore, AFileSystemThatDoesNotMountIsKeptTheCompiledModelRunsAndTheReadyLineSaysSo) {
  MemStore store;
  {  // a board with an uploaded model
    App app(infer::model::kModel, infer::model::kChecksum, store);
    Lines boot;
    app.begin(boot);
    ASSERT_EQ(boot.got.size(), 1u);
    EXPECT_NE(boot.got[0].find("\"fs\":\"mounted\""), std::string::npos) << boot.got[0];
    ASSERT_TRUE(committed(upload(app, default_document())));
  }
  const std::map<std::string, std::string> files = store.files;
  ASSERT_EQ(files.at(infer::kModelPath), default_document());
  // A reset, and the file system does not mount (damaged flash, a half-written block).
  store.mount_fails = true;
  App app(infer::model::kModel, infer::model::kChecksum, store);
  Lines boot;
  app.begin(boot);
  ASSERT_EQ(boot.got.size(), 1u);
  std::printf("ready line, the file system not mounted: %s", boot.got[0].c_str());
  EXPECT_NE(boot.got[0].find("\"model\":\"compiled\""), std::string::npos) << boot.got[0];
  EXPECT_NE(boot.got[0].find("\"fs\":\"unmounted\""), std::string::npos) << boot.got[0];
  EXPECT_FALSE(app.fs_mounted());
  EXPECT_EQ(&app.model(), &infer::model::kModel);  // the compiled model runs
  EXPECT_EQ(store.formats, 0);                     // never formatted
  EXPECT_EQ(store.files, files);                   // the stored model is still there
  EXPECT_NE(status_of(app).find("\"fs\":\"unmounted\""), std::string::npos) << status_of(app);
  // Uploads are refused, saying how to go on; nothing is written.
  std::vector<std::string> r = send(app, upload_line(default_document().size(), crc32_of(default_document())));
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(error_of(r[0]), "fs_unmounted") << r[0];
  EXPECT_NE(r[0].find("format"), std::string::npos) << r[0];
  EXPECT_EQ(store.files, files);
  // The telemetry runs on: a frame gives its line.
  hpddo::SampleFrame f;
  std::memset(&f, 0, sizeof f);
  f.seq = 1;
  f.v_mV = 9000;
  f.i_mA = 500;
  f.period_us = 10000;
  uint8_t buf[hpddo::kFrameSize];
  hpddo::encode_frame(f, buf);
  Lines tele;
  uint32_t clock = 0;
  for (uint8_t b : buf) app.link_byte(b, 0, [&clock]() { return clock += 10u; }, tele);
  ASSERT_EQ(tele.got.size(), 1u);
  EXPECT_EQ(tele.got[0].compare(0, 8, "{\"seq\":1"), 0) << tele.got[0];
  // Only the format command erases it; then uploads work again.
  r = send(app, "{\"cmd\":\"format\"}\n");
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0], "{\"event\":\"format\",\"fs\":\"mounted\"}\n");
  EXPECT_EQ(store.formats, 1);
  EXPECT_TRUE(store.files.empty());
  EXPECT_TRUE(committed(upload(app, default_document())));
  // A mounted file system is not formatted: its model stays.
  r = send(app, "{\"cmd\":\"format\"}\n");
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(error_of(r[0]), "fs_mounted") << r[0];
  EXPECT_EQ(store.formats, 1);
  EXPECT_EQ(store.files.at(infer::kModelPath), default_document());
}

// ---- the host's UART: never waited for (infer_tx.h)

namespace {

/// HardwareSerial's transmit side as the ESP8266 has it: a FIFO of `fifo` bytes that the UART
/// empties at its baud (drain()); write() of more than availableForWrite() would spin on the
/// board, so here it is counted as a wait.
struct FakeSerial {
  size_t fifo;
  size_t used = 0;
  size_t waits = 0;  ///< writes that would have blocked
  std::string sent;  ///< what went into the FIFO, in order
  explicit FakeSerial(size_t fifo_bytes) : fifo(fifo_bytes) {}
  int availableForWrite() const { return static_cast<int>(fifo - used); }
  size_t write(const uint8_t* p, size_t n) {
    if (n > fifo - used) ++waits;
    used += n;
    sent.append(reinterpret_cast<const char*>(p), n);
    return n;
  }
  void drain(size_t n) { used -= n < used ? n : used; }
};

std::vector<std::string> split_lines(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string l; std::getline(in, l);) out.push_back(l + "\n");
  return out;
}

}  // namespace

TEST(InferTx, ALineThatDoesNotFitIsDroppedWholeAndCountedAndNothingWaits) {
  infer::TxQueue<256> q;
  FakeSerial uart(128);  // the ESP8266's UART FIFO
  std::vector<std::string> queued;
  for (int k = 0; k < 10; ++k) {  // 10 lines of 60 bytes, the UART not draining: 4 fit
    std::string line = "{\"seq\":" + std::to_string(k) + ",\"pad\":\"" + std::string(60 - 19, 'x') + "\"}\n";
    line.resize(60 - 1);
    line += "\n";
    if (q.queued() + line.size() <= 256) queued.push_back(line);
    q.line(line.data(), line.size());
    q.pump(uart);
  }
  EXPECT_EQ(uart.waits, 0u);
  EXPECT_EQ(uart.used, 128u);       // the FIFO full, no more was handed over
  EXPECT_EQ(q.lines_dropped(), 4u);  // 128 bytes in the FIFO + 256 in the ring: 6 lines of 60 kept
  for (int k = 0; k < 40; ++k) {
    uart.drain(50);
    q.pump(uart);
  }
  EXPECT_EQ(uart.waits, 0u);
  EXPECT_EQ(q.queued(), 0u);
  std::vector<std::string> got = split_lines(uart.sent);
  ASSERT_EQ(got.size(), queued.size() + 1) << uart.sent;
  for (size_t k = 0; k < queued.size(); ++k) EXPECT_EQ(got[k], queued[k]);  // whole, in order
  EXPECT_EQ(got.back(), "{\"event\":\"tx_dropped\",\"lines\":4}\n");
  std::printf("ring of 256 bytes, UART FIFO 128 bytes not draining: %zu lines of 60 bytes kept, %u dropped\n",
              queued.size(), static_cast<unsigned>(q.lines_dropped()));
}

TEST(InferTx, TelemetryAt100HzNeverWaitsNorDropsAndTheStatusReportsDrops) {
  // The golden rows' telemetry at 100 frames/s through the board's ring to a 128-byte FIFO
  // drained at 460800 baud (46.08 bytes/ms), pumped once a millisecond as loop() does at least.
  namespace gold = ::HPDDO_GOLDEN_NS;
  App& app = fresh_app();
  infer::TxQueue<infer::kTxRing> q;
  FakeSerial uart(128);
  uint32_t clock = 0;
  size_t bytes = 0, lines = 0;
  for (uint16_t r = 0; r < gold::kCount; ++r) {
    const hpddo::Sample s = gold::sample(r);
    hpddo::SampleFrame f;
    std::memset(&f, 0, sizeof f);
    f.seq = static_cast<uint16_t>(r + 1u);
    f.v_mV = static_cast<uint16_t>(s.v_V * 1000.0f + 0.5f);
    f.i_mA = static_cast<int16_t>(std::lround(s.i_A * 1000.0f));
    f.period_us = 10000u;
    uint8_t buf[hpddo::kFrameSize];
    hpddo::encode_frame(f, buf);
    for (uint8_t b : buf) app.link_byte(b, r * 10u, [&clock]() { return clock += 100u; }, q);
    for (int ms = 0; ms < 10; ++ms) {
      q.pump(uart);
      uart.drain(46);
    }
  }
  for (int ms = 0; ms < 100; ++ms, uart.drain(46)) q.pump(uart);
  bytes = uart.sent.size();
  lines = split_lines(uart.sent).size();
  EXPECT_EQ(uart.waits, 0u);
  EXPECT_EQ(q.lines_dropped(), 0u);
  EXPECT_EQ(lines, static_cast<size_t>(gold::kCount));
  std::printf("%zu telemetry lines (%zu bytes) at 100 Hz: no write waited, 0 dropped, ring peak %zu of %zu bytes\n",
              lines, bytes, q.peak(), infer::kTxRing);
  // A host line that stops (the UART not drained) fills the ring: lines are dropped, the
  // status says how many, and the stream says so once there is room.
  for (int k = 0; k < 40; ++k) {
    char line[64];
    const int n = std::snprintf(line, sizeof line, "{\"seq\":%d,\"filler\":\"%040d\"}\n", k, 0);
    q.line(line, static_cast<size_t>(n));
    q.pump(uart);
  }
  EXPECT_EQ(uart.waits, 0u);
  ASSERT_GT(q.lines_dropped(), 0u);
  std::vector<std::string> r;
  for (char c : std::string("{\"cmd\":\"status\"}\n")) app.host_byte(static_cast<uint8_t>(c), 0, q);
  const uint32_t dropped = q.lines_dropped();  // the status reply itself did not fit either
  for (int ms = 0; ms < 200; ++ms, uart.drain(46)) q.pump(uart);
  r = split_lines(uart.sent);
  EXPECT_EQ(r.back(), "{\"event\":\"tx_dropped\",\"lines\":" + std::to_string(dropped) + "}\n");
  // With room again, the status reports the count.
  for (char c : std::string("{\"cmd\":\"status\"}\n")) app.host_byte(static_cast<uint8_t>(c), 0, q);
  for (int ms = 0; ms < 20; ++ms, uart.drain(46)) q.pump(uart);
  r = split_lines(uart.sent);
  EXPECT_NE(r.back().find("\"tx_dropped\":" + std::to_string(dropped) + "}"), std::string::npos) << r.back();
}
