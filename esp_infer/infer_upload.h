// A new model for the inference board without reflashing: the model document, its storage
// and its checks. The host (`hpddo upload`, tools/hpddo/model/upload.py) sends the document in
// chunks over the serial line (infer_app.h's commands upload / chunk / commit); the board
// writes them to kModelNewPath, checks the transport CRC-32, parses the file with
// ArduinoJson as a stream into a spare ModelSlot, checks it, renames the file to kModelPath
// (atomic in LittleFS) and only then puts the model in force. At start-up the stored model
// is read the same way. The document (every float as the uint32 of its IEEE-754 bits, so
// that no decimal conversion stands between the trained and the running model):
//
//   {"hpddo_model":1,"layout":<hpddo::kParamsSchema>,"shape":[5,16,8,1],
//    "physics":[<16 float bits in the schema's order>,<effect bits>],
//    "scaler_mean":[5],"scaler_scale":[5],"w0":[80],"b0":[16],"w1":[128],"b1":[8],
//    "w2":[8],"b2":[1],"env_lo":[5],"env_hi":[5],"gate_centre":[5],"gate_scale":[5],
//    "gate_prototypes":[160],"gate_r":[r_in_sq,r_out_sq],"clamp_rpm":<bits>,
//    "limits":[v_max_V,i_max_A,temp_min_C,temp_max_C],"crc":<hpddo::model_checksum>}
//
// A model that names the dynamic family (hpddo/dynamics.h) adds "dynamics":[<4 float bits,
// DynamicsParams in the schema's order>], and its crc covers them (model_checksum(model,
// dynamics)); without the member the family is off.
//
// (a network with one hidden layer: "shape":[5,H1,1], "w1":[H1], "b1":[1], no w2, b2).
// Refused, the model in force unchanged, with the reason: another format or parameter
// layout, another network shape than the firmware's (with the command to rebuild), a
// missing member, an array of the wrong length, an element that is not a uint32 (a float,
// a negative or huge number, a string), a non-finite float, a checksum that differs.
#ifndef HPDDO_INFER_UPLOAD_H
#define HPDDO_INFER_UPLOAD_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <ArduinoJson.h>

#include "hpddo/dynamics.h"
#include "hpddo/model.h"
#include "infer_arena.h"

namespace infer {

/// Version of the model document this firmware reads ("hpddo_model").
static const uint32_t kModelFormat = 1;
/// Largest model document accepted, bytes.
static const uint32_t kUploadMax = 32768;
/// An upload with no chunk for this long is dropped, ms.
static const uint32_t kUploadIdle_ms = 5000;
/// Where the model in force is stored, and where an upload is received.
static const char kModelPath[] = "/model.json";
static const char kModelNewPath[] = "/model.new";

/// The files the board keeps (LittleFS on the ESP8266, a folder on the host). One file
/// is written and one read at a time.
class Store {
 public:
  /// Mounts the file system as it is, never formatting it (a damaged one and the model in it
  /// stay for a person to decide); true when mounted. Until then the other calls fail.
  virtual bool mount() = 0;
  /// Erases the file system (the stored model with it) and mounts it empty; true when mounted.
  virtual bool format() = 0;
  virtual bool begin_write(const char* path) = 0;  ///< creates or truncates
  virtual bool append(const uint8_t* data, size_t n) = 0;
  virtual bool end_write() = 0;
  virtual bool open_read(const char* path) = 0;
  virtual int read() = 0;  ///< the next byte, or -1 at the end
  virtual size_t read_bytes(char* out, size_t n) = 0;
  virtual void close_read() = 0;
  virtual bool rename(const char* from, const char* to) = 0;  ///< replaces `to`, atomically
  virtual bool remove(const char* path) = 0;
  virtual bool exists(const char* path) = 0;

 protected:
  ~Store() {}
};

/// ArduinoJson's reader over a Store opened for reading.
class StoreReader {
 public:
  explicit StoreReader(Store& s) : s_(s) {}
  int read() { return s_.read(); }
  size_t readBytes(char* out, size_t n) { return s_.read_bytes(out, n); }

 private:
  Store& s_;
};

/// Why a model document was refused: a code for programs, a sentence for people.
struct ModelError {
  const char* code;
  const char* detail;
};

/// A model held in RAM: its arrays and the Model whose pointers lead to them. Not
/// copyable (the pointers lead into the object itself).
template <class Net>
struct ModelSlot {
  static const uint8_t kF = hpddo::kFeatureCount;
  static const uint16_t kB1 = Net::kHidden2 ? Net::kHidden2 : 1;
  static const uint16_t kW2 = Net::kHidden2 ? Net::kW2Count : 1;
  static const uint16_t kProtos = static_cast<uint16_t>(hpddo::kFeatureCount) * hpddo::kGatePrototypes;

  float scaler_mean[kF], scaler_scale[kF];
  float w0[Net::kW0Count], b0[Net::kHidden1], w1[Net::kW1Count], b1[kB1], w2[kW2], b2[1];
  float env_lo[kF], env_hi[kF];
  float gate_centre[kF], gate_scale[kF], gate_prototypes[kProtos];
  hpddo::Model<Net> model;
  hpddo::DynamicsParams dynamics;  ///< the dynamic family ("dynamics"; all 0: off)
  uint32_t crc;  ///< the document's checksum, equal to hpddo::model_checksum(model, dynamics)

  ModelSlot() : crc(0) {
    memset(&model, 0, sizeof model);
    memset(&dynamics, 0, sizeof dynamics);
    model.scaler.mean = scaler_mean;
    model.scaler.scale = scaler_scale;
    model.weights.w0 = w0;
    model.weights.b0 = b0;
    model.weights.w1 = w1;
    model.weights.b1 = b1;
    model.weights.w2 = w2;
    model.weights.b2 = b2;
    model.envelope.lo = env_lo;
    model.envelope.hi = env_hi;
    model.gate.centre = gate_centre;
    model.gate.scale = gate_scale;
    model.gate.prototypes = gate_prototypes;
  }

 private:
  ModelSlot(const ModelSlot&);
  ModelSlot& operator=(const ModelSlot&);
};

/// Arena of the document being parsed: about 470 values, a uint32 above 2^31 taking a
/// second slot (ArduinoJson 7 keeps 64-bit integers apart on a 32-bit chip): 8 slot pools
/// (8 KB on the lx106, 32 KB on a 64-bit host); the peak is printed by a test.
static const size_t kUploadArena = 8 * ARDUINOJSON_POOL_CAPACITY * 2 * sizeof(void*) + 1024;

namespace detail {

inline float float_of_bits(uint32_t b) {
  float f;
  memcpy(&f, &b, sizeof f);
  return f;
}

/// n floats of doc[key] (uint32 bits, finite) into out.
inline bool read_floats(ArduinoJson::JsonObjectConst doc, const char* key, float* out, uint16_t n,
                        ModelError* why) {
  ArduinoJson::JsonArrayConst a = doc[key];
  if (a.isNull()) {
    *why = ModelError{"missing", key};
    return false;
  }
  if (a.size() != n) {
    *why = ModelError{"length", key};
    return false;
  }
  uint16_t k = 0;
  for (ArduinoJson::JsonVariantConst v : a) {
    if (!v.is<uint32_t>()) {
      *why = ModelError{"type", key};
      return false;
    }
    out[k] = float_of_bits(v.as<uint32_t>());
    if (!hpddo::is_finite(out[k])) {
      *why = ModelError{"not_finite", key};
      return false;
    }
    ++k;
  }
  return true;
}

/// One float of doc[key] (uint32 bits, finite).
inline bool read_float(ArduinoJson::JsonObjectConst doc, const char* key, float* out, ModelError* why) {
  ArduinoJson::JsonVariantConst v = doc[key];
  if (v.isNull()) {
    *why = ModelError{"missing", key};
    return false;
  }
  if (!v.is<uint32_t>()) {
    *why = ModelError{"type", key};
    return false;
  }
  *out = float_of_bits(v.as<uint32_t>());
  if (!hpddo::is_finite(*out)) {
    *why = ModelError{"not_finite", key};
    return false;
  }
  return true;
}

/// The physics fields in the schema's order (hpddo::for_each_param): floats from bits,
/// the effect bits as a number.
struct PhysicsReader {
  ArduinoJson::JsonArrayConst a;
  uint8_t k;
  bool ok;
  bool finite;
  void operator()(float& f) {
    ArduinoJson::JsonVariantConst v = a[k++];
    if (!v.is<uint32_t>()) {
      ok = false;
      return;
    }
    f = float_of_bits(v.as<uint32_t>());
    if (!hpddo::is_finite(f)) finite = false;
  }
  void operator()(uint16_t& bits) {
    ArduinoJson::JsonVariantConst v = a[k++];
    if (!v.is<uint16_t>()) {
      ok = false;
      return;
    }
    bits = v.as<uint16_t>();
  }
};

}  // namespace detail

/// The network shape the firmware was built for, as the document states it.
template <class Net>
inline bool shape_matches(ArduinoJson::JsonArrayConst shape) {
  const bool two = Net::kHidden2 != 0;
  if (shape.size() != (two ? 4u : 3u)) return false;
  if (!shape[0].is<uint8_t>() || shape[0].as<uint8_t>() != Net::kInputs) return false;
  if (!shape[1].is<uint8_t>() || shape[1].as<uint8_t>() != Net::kHidden1) return false;
  if (two && (!shape[2].is<uint8_t>() || shape[2].as<uint8_t>() != Net::kHidden2)) return false;
  const ArduinoJson::JsonVariantConst out = shape[two ? 3 : 2];
  return out.is<uint8_t>() && out.as<uint8_t>() == 1;
}

/// Parses a model document from in (an ArduinoJson reader) with the arena's memory into
/// slot and checks it; false with the reason otherwise (slot is then partly written).
template <class Net, class Reader>
bool read_model(Reader& in, ArduinoJson::Allocator* arena, ModelSlot<Net>& slot, ModelError* why) {
  ArduinoJson::JsonDocument doc(arena);
  const ArduinoJson::DeserializationError err =
      ArduinoJson::deserializeJson(doc, in, ArduinoJson::DeserializationOption::NestingLimit(2));
  if (err) {
    *why = ModelError{"bad_json", err.c_str()};
    return false;
  }
  for (int c = in.read(); c >= 0; c = in.read()) {
    if (c != ' ' && c != '\t' && c != '\r' && c != '\n') {
      *why = ModelError{"bad_json", "text after the document"};
      return false;
    }
  }
  if (doc.overflowed()) {
    *why = ModelError{"too_big", "the document needs more memory than the board keeps for it"};
    return false;
  }
  ArduinoJson::JsonObjectConst o = doc.as<ArduinoJson::JsonObjectConst>();
  if (o.isNull() || !o["hpddo_model"].is<uint32_t>() || o["hpddo_model"].as<uint32_t>() != kModelFormat) {
    *why = ModelError{"format", "not an hpddo model document of the version this firmware reads (hpddo_model 1)"};
    return false;
  }
  if (!o["layout"].is<uint32_t>() || o["layout"].as<uint32_t>() != hpddo::kParamsSchema) {
    *why = ModelError{"layout",
                      "the model was exported for another physics parameter layout than this firmware's "
                      "(hpddo::kParamsSchema): export it with this version of hpddo, or rebuild the firmware"};
    return false;
  }
  if (!shape_matches<Net>(o["shape"])) {
    *why = ModelError{"shape",
                      "this firmware runs another network shape: build it with the model's header "
                      "(copy model_<name>.h into models/default or pass -DHPDDO_MODEL_HEADER, then "
                      "pio run -e esp8266 -t upload; docs/firmware.md)"};
    return false;
  }
  ArduinoJson::JsonArrayConst phys = o["physics"];
  if (phys.isNull() || phys.size() != hpddo::kPhysicsParamCount) {
    *why = ModelError{phys.isNull() ? "missing" : "length", "physics"};
    return false;
  }
  detail::PhysicsReader pr = {phys, 0, true, true};
  hpddo::for_each_param(slot.model.physics, pr);
  if (!pr.ok || !pr.finite) {
    *why = ModelError{pr.ok ? "not_finite" : "type", "physics"};
    return false;
  }
  typedef ModelSlot<Net> S;
  const bool two = Net::kHidden2 != 0;
  float r[2], lim[4];
  if (!detail::read_floats(o, "scaler_mean", slot.scaler_mean, S::kF, why) ||
      !detail::read_floats(o, "scaler_scale", slot.scaler_scale, S::kF, why) ||
      !detail::read_floats(o, "w0", slot.w0, Net::kW0Count, why) ||
      !detail::read_floats(o, "b0", slot.b0, Net::kHidden1, why) ||
      !detail::read_floats(o, "w1", slot.w1, Net::kW1Count, why) ||
      !detail::read_floats(o, "b1", slot.b1, S::kB1, why) ||
      (two && !detail::read_floats(o, "w2", slot.w2, Net::kW2Count, why)) ||
      (two && !detail::read_floats(o, "b2", slot.b2, 1, why)) ||
      !detail::read_floats(o, "env_lo", slot.env_lo, S::kF, why) ||
      !detail::read_floats(o, "env_hi", slot.env_hi, S::kF, why) ||
      !detail::read_floats(o, "gate_centre", slot.gate_centre, S::kF, why) ||
      !detail::read_floats(o, "gate_scale", slot.gate_scale, S::kF, why) ||
      !detail::read_floats(o, "gate_prototypes", slot.gate_prototypes, S::kProtos, why) ||
      !detail::read_floats(o, "gate_r", r, 2, why) || !detail::read_float(o, "clamp_rpm", &slot.model.clamp_rpm, why) ||
      !detail::read_floats(o, "limits", lim, 4, why))
    return false;
  slot.model.gate.r_in_sq = r[0];
  slot.model.gate.r_out_sq = r[1];
  slot.model.limits.v_max_V = lim[0];
  slot.model.limits.i_max_A = lim[1];
  slot.model.limits.temp_min_C = lim[2];
  slot.model.limits.temp_max_C = lim[3];
  if (!o["crc"].is<uint32_t>()) {
    *why = ModelError{o["crc"].isNull() ? "missing" : "type", "crc"};
    return false;
  }
  float dyn[hpddo::kDynamicsParamCount] = {0.0f, 0.0f, 0.0f, 0.0f};
  if (!o["dynamics"].isNull() && !detail::read_floats(o, "dynamics", dyn, hpddo::kDynamicsParamCount, why)) return false;
  slot.dynamics.j_kgm2 = dyn[0];
  slot.dynamics.b_nms_per_rad = dyn[1];
  slot.dynamics.tc_nm = dyn[2];
  slot.dynamics.tau_obs_s = dyn[3];
  slot.crc = o["crc"].as<uint32_t>();
  if (hpddo::model_checksum(slot.model, slot.dynamics) != slot.crc) {
    *why = ModelError{"checksum", "the model's checksum differs from its crc: damaged, or edited by hand"};
    return false;
  }
  return true;
}

}  // namespace infer

#endif  // HPDDO_INFER_UPLOAD_H
