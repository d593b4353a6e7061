// The inference board's logic in one object, without the Arduino glue: the link from the
// UNO, the observer with the model in force, the telemetry line and the host's commands,
// among them a new model without reflashing (infer_upload.h):
//   {"cmd":"status"}                          the model in force, link and command counters
//   {"cmd":"upload","bytes":N,"crc32":C}      starts receiving a model document of N bytes
//   {"cmd":"chunk","seq":K,"data":"..."}      its next piece (K = 0, 1, ...), acknowledged
//   {"cmd":"commit"}                          checks it whole; stores it and puts it in force
//   {"cmd":"abort"}                           drops an upload
//   {"cmd":"use_compiled"}                    forgets the stored model: the firmware's again
//   {"cmd":"format"}                          erases and mounts a file system that did not mount
// At start-up the file system is mounted as it is, never formatted: when the mount fails the
// compiled model runs, the ready line and the status say "fs":"unmounted", uploads are
// refused, and only the format command (refused while the file system is mounted) erases it.
// An upload that is interrupted (no chunk for kUploadIdle_ms, a chunk out of order, a
// byte count or CRC-32 that differs) or whose model is refused leaves the model in force
// running and says why in an error line. The sketch (esp_infer.cpp) feeds it bytes and
// clocks and writes its lines to Serial; the host build (host/esp_host.cpp) does the same
// from files and pipes, so what runs on the desk is what runs on the board.
#ifndef HPDDO_INFER_APP_H
#define HPDDO_INFER_APP_H

#include <stddef.h>
#include <stdint.h>

#include <ArduinoJson.h>

#include "hpddo/model.h"
#include "hpddo/observer.h"
#include "infer_console.h"
#include "infer_line.h"
#include "infer_link.h"
#include "infer_telemetry.h"
#include "infer_upload.h"

namespace infer {

template <class Net>
class App {
 public:
  typedef hpddo::Model<Net> ModelT;
  typedef hpddo::Observer<Net> ObserverT;

  /// compiled: the model built into the firmware (kModel), crc its kChecksum; store: where
  /// models are kept (LittleFS on the board).
  /// compiled_dynamics: the compiled model's dynamic family (its header's kDynamics; infer_model.h).
  App(const ModelT& compiled, uint32_t compiled_crc, Store& store,
      const hpddo::DynamicsParams& compiled_dynamics = hpddo::kDynamicsOff)
      : compiled_(compiled), compiled_crc_(compiled_crc), store_(store), model_(&compiled), model_crc_(compiled_crc),
        compiled_dynamics_(compiled_dynamics), dynamics_(&compiled_dynamics),
        active_slot_(-1), limits_(compiled.limits), rx_(&limits_), observer_(compiled, compiled_dynamics),
        console_(*this), out_(nullptr), now_ms_(0), fs_mounted_(false),
        receiving_(false), expect_bytes_(0), got_bytes_(0), expect_crc_(0), running_crc_(0), next_seq_(0),
        last_chunk_ms_(0) {}

  /// At start-up: mounts the store (never formatting it), puts the stored model in force
  /// when there is one and it passes every check (else says why and keeps the compiled one),
  /// then writes the ready line, "fs" saying whether the store mounted.
  void begin(LineSink& out) {
    fs_mounted_ = store_.mount();
    if (fs_mounted_) {
      if (store_.exists(kModelNewPath)) store_.remove(kModelNewPath);  // an upload cut by a reset
      if (store_.exists(kModelPath)) {
        ModelError why;
        if (!load(kModelPath, &why)) send_error(out, "stored_model", why);
      }
    }
    ArduinoJson::JsonDocument doc(&scratch_);
    doc["event"] = "ready";
    doc["model_crc_ok"] = hpddo::model_checksum(*model_, *dynamics_) == model_crc_;
    doc["model"] = source();
    doc["model_crc"] = model_crc_;
    doc["fs"] = fs_state();
    send_json(doc, out);
  }

  /// One byte from the UNO's link at now_ms; a completed frame runs the observer and its
  /// telemetry line goes to out. now_us: a microsecond clock (the step's time).
  template <class Clock>
  void link_byte(uint8_t byte, uint32_t now_ms, Clock now_us, LineSink& out) {
    hpddo::SampleFrame f;
    if (!rx_.push(byte, now_ms, &f)) return;
    const Telemetry t = infer_step(observer_, f, rx_, now_us);
    char line[kJsonMaxLine + 1];
    const size_t n = line_.write(t, line, sizeof line);
    if (n) {
      out.line(line, n);
    } else {
      static const char kOverflow[] = "{\"event\":\"telemetry_overflow\"}\n";
      out.line(kOverflow, sizeof kOverflow - 1);
    }
  }

  /// One byte from the host (commands) at now_ms.
  void host_byte(uint8_t byte, uint32_t now_ms, LineSink& out) {
    now_ms_ = now_ms;
    out_ = &out;
    console_.push(byte, now_ms, out);
    out_ = nullptr;
  }

  /// Call often: drops a stale partial command line and an upload that stopped.
  void poll(uint32_t now_ms, LineSink& out) {
    now_ms_ = now_ms;
    console_.poll(now_ms, out);
    if (receiving_ && now_ms - last_chunk_ms_ > kUploadIdle_ms) {
      drop_upload();
      send_error(out, "upload_timeout", ModelError{"upload_timeout", "no chunk within kUploadIdle_ms: upload dropped, the model in force unchanged"});
    }
  }

  /// Console hook: the commands this board knows (see the top of this file).
  bool command(const char* cmd, ArduinoJson::JsonObjectConst args, ArduinoJson::JsonDocument& reply) {
    if (strcmp(cmd, "status") == 0) {
      reply["model"] = source();
      reply["model_crc"] = model_crc_;
      reply["model_crc_ok"] = hpddo::model_checksum(*model_, *dynamics_) == model_crc_;
      reply["frames"] = rx_.frames();
      reply["gaps"] = rx_.gaps();
      reply["lost"] = rx_.lost();
      reply["crc_errors"] = rx_.crc_errors();
      reply["commands"] = console_.lines();
      reply["command_errors"] = console_.errors();
      reply["uploading"] = receiving_;
      reply["fs"] = fs_state();
      reply["tx_dropped"] = out_ ? out_->lines_dropped() : 0u;
      return true;
    }
    if (strcmp(cmd, "upload") == 0) return upload(args, reply);
    if (strcmp(cmd, "chunk") == 0) return chunk(args, reply);
    if (strcmp(cmd, "commit") == 0) return commit(reply);
    if (strcmp(cmd, "abort") == 0) {
      reply["dropped"] = receiving_;
      drop_upload();
      return true;
    }
    if (strcmp(cmd, "use_compiled") == 0) {
      drop_upload();
      if (store_.exists(kModelPath) && !store_.remove(kModelPath)) return fail(reply, "store", "cannot remove the stored model");
      put_in_force(-1);
      reply["model"] = source();
      reply["model_crc"] = model_crc_;
      return true;
    }
    if (strcmp(cmd, "format") == 0) {
      if (fs_mounted_) return fail(reply, "fs_mounted", "the file system is mounted: format erases only one that did not mount");
      fs_mounted_ = store_.format();
      if (!fs_mounted_) return fail(reply, "store", "format failed: the file system is still not mounted");
      reply["fs"] = fs_state();
      return true;
    }
    return false;
  }

  const ModelT& model() const { return *model_; }
  /// The model in force's dynamic family (kDynamicsOff where it names none).
  const hpddo::DynamicsParams& dynamics() const { return *dynamics_; }
  uint32_t model_crc() const { return model_crc_; }
  bool uploaded() const { return active_slot_ >= 0; }
  bool fs_mounted() const { return fs_mounted_; }
  ObserverT& observer() { return observer_; }
  const LinkReceiver& link() const { return rx_; }
  const Console<App>& console() const { return console_; }
  size_t upload_arena_peak() const { return upload_arena_.peak(); }

 private:
  const char* source() const { return active_slot_ < 0 ? "compiled" : "uploaded"; }
  const char* fs_state() const { return fs_mounted_ ? "mounted" : "unmounted"; }

  static bool fail(ArduinoJson::JsonDocument& reply, const char* code, const char* detail) {
    reply["error"] = code;
    reply["detail"] = detail;
    return true;
  }

  void send_error(LineSink& out, const char* code, const ModelError& why) {
    ArduinoJson::JsonDocument doc(&scratch_);
    doc["event"] = "error";
    doc["error"] = code;
    doc["reason"] = why.code;
    doc["detail"] = why.detail;
    console_.count_error();
    send_json(doc, out);
  }

  /// Closes the upload file.
  void end_upload() {
    if (receiving_) store_.end_write();
    receiving_ = false;
  }

  /// Ends an upload that will not be committed: its file goes.
  void drop_upload() {
    if (!receiving_) return;
    end_upload();
    store_.remove(kModelNewPath);
  }

  bool upload(ArduinoJson::JsonObjectConst args, ArduinoJson::JsonDocument& reply) {
    drop_upload();
    if (!fs_mounted_)
      return fail(reply, "fs_unmounted", "the file system did not mount (ready line): {\"cmd\":\"format\"} erases it");
    if (!args["bytes"].is<uint32_t>() || !args["crc32"].is<uint32_t>())
      return fail(reply, "bad_args", "upload needs \"bytes\" and \"crc32\" (unsigned integers)");
    const uint32_t bytes = args["bytes"];
    if (bytes == 0 || bytes > kUploadMax) return fail(reply, "too_big", "a model document is 1..kUploadMax bytes");
    if (!store_.begin_write(kModelNewPath)) return fail(reply, "store", "cannot create the upload file");
    receiving_ = true;
    expect_bytes_ = bytes;
    expect_crc_ = args["crc32"];
    got_bytes_ = 0;
    running_crc_ = 0xFFFFFFFFu;
    next_seq_ = 0;
    last_chunk_ms_ = now_ms_;
    reply["bytes"] = bytes;
    reply["max_line"] = kCommandMax;
    return true;
  }

  bool chunk(ArduinoJson::JsonObjectConst args, ArduinoJson::JsonDocument& reply) {
    if (!receiving_) return fail(reply, "no_upload", "chunk without upload");
    if (!args["seq"].is<uint32_t>() || !args["data"].is<const char*>())
      return fail(reply, "bad_args", "chunk needs \"seq\" (unsigned integer) and \"data\" (string)");
    const uint32_t seq = args["seq"];
    ArduinoJson::JsonString data = args["data"];
    if (seq != next_seq_) {
      drop_upload();
      return fail(reply, "upload_seq", "chunk out of order: upload dropped, the model in force unchanged");
    }
    if (data.size() > expect_bytes_ - got_bytes_) {
      drop_upload();
      return fail(reply, "upload_bytes", "more bytes than announced: upload dropped, the model in force unchanged");
    }
    const uint8_t* p = reinterpret_cast<const uint8_t*>(data.c_str());
    if (!store_.append(p, data.size())) {
      drop_upload();
      return fail(reply, "store", "cannot write the upload file: upload dropped, the model in force unchanged");
    }
    running_crc_ = hpddo::crc32_update(running_crc_, p, data.size());
    got_bytes_ += static_cast<uint32_t>(data.size());
    ++next_seq_;
    last_chunk_ms_ = now_ms_;
    reply["seq"] = seq;
    reply["received"] = got_bytes_;
    return true;
  }

  bool commit(ArduinoJson::JsonDocument& reply) {
    if (!receiving_) return fail(reply, "no_upload", "commit without upload");
    const bool whole = got_bytes_ == expect_bytes_;
    const bool crc_ok = (running_crc_ ^ 0xFFFFFFFFu) == expect_crc_;
    end_upload();
    if (!whole || !crc_ok) {
      store_.remove(kModelNewPath);
      return fail(reply, whole ? "upload_crc" : "upload_bytes",
                  whole ? "the bytes received have another CRC-32 than announced: the model in force unchanged"
                        : "fewer bytes received than announced: the model in force unchanged");
    }
    ModelError why;
    const int spare = active_slot_ == 0 ? 1 : 0;
    if (!parse(kModelNewPath, spare, &why)) {
      store_.remove(kModelNewPath);
      reply["error"] = "model_refused";
      reply["reason"] = why.code;
      reply["detail"] = why.detail;
      return true;
    }
    if (!store_.rename(kModelNewPath, kModelPath)) {
      store_.remove(kModelNewPath);
      return fail(reply, "store", "cannot store the model: the model in force unchanged");
    }
    put_in_force(spare);
    reply["model"] = source();
    reply["model_crc"] = model_crc_;
    return true;
  }

  /// Parses and checks the document at path into slot k.
  bool parse(const char* path, int k, ModelError* why) {
    if (!store_.open_read(path)) {
      *why = ModelError{"store", "cannot open the model file"};
      return false;
    }
    StoreReader in(store_);
    const bool ok = read_model<Net>(in, &upload_arena_, slots_[k], why);
    store_.close_read();
    return ok;
  }

  /// Parses the stored model into a spare slot and puts it in force.
  bool load(const char* path, ModelError* why) {
    const int spare = active_slot_ == 0 ? 1 : 0;
    if (!parse(path, spare, why)) return false;
    put_in_force(spare);
    return true;
  }

  /// Slot k (or the compiled model, k < 0) in force: a new observer (its lags and thermal
  /// state start again) and the link judging frames by the model's limits.
  void put_in_force(int k) {
    active_slot_ = k;
    model_ = k < 0 ? &compiled_ : &slots_[k].model;
    model_crc_ = k < 0 ? compiled_crc_ : slots_[k].crc;
    dynamics_ = k < 0 ? &compiled_dynamics_ : &slots_[k].dynamics;
    limits_ = model_->limits;
    observer_ = ObserverT(*model_, *dynamics_);
  }

  const ModelT& compiled_;
  const uint32_t compiled_crc_;
  Store& store_;
  const ModelT* model_;
  uint32_t model_crc_;
  const hpddo::DynamicsParams& compiled_dynamics_;
  const hpddo::DynamicsParams* dynamics_;  ///< the model in force's dynamic family (kDynamicsOff: none)
  int active_slot_;  ///< -1: the compiled model; 0 or 1: that slot
  ModelSlot<Net> slots_[2];
  hpddo::InputLimits limits_;  ///< the model in force's, which the link judges frames by
  LinkReceiver rx_;
  ObserverT observer_;
  LineWriter line_;
  Console<App> console_;
  LineSink* out_;  ///< where the command being handled replies (its lines_dropped for the status)
  ArenaAllocator<kLineArena> scratch_;
  ArenaAllocator<kUploadArena> upload_arena_;
  uint32_t now_ms_;
  bool fs_mounted_;  ///< the store mounted at begin() or by the format command
  bool receiving_;
  uint32_t expect_bytes_;
  uint32_t got_bytes_;
  uint32_t expect_crc_;
  uint32_t running_crc_;
  uint32_t next_seq_;
  uint32_t last_chunk_ms_;
};

}  // namespace infer

#endif  // HPDDO_INFER_APP_H
