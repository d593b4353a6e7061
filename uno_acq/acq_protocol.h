// The paper's three test protocols (section 3.6.1) as a function of the
// sample index: which duty and load are in force during sample k.
//
//   sweep  duty 0 -> 100 % -> 0 in 20 % steps, no load, each step `hold` long
//   load   80 % duty, loads 0, 1 (0.5 ohm), 2 (0.01 ohm), 1, 0, each `hold` long
//   long   80 % duty with load 2 (0.01 ohm) for `long` seconds
#ifndef HPDDO_ACQ_PROTOCOL_H
#define HPDDO_ACQ_PROTOCOL_H

#include <stdint.h>

namespace acq {

enum Protocol : uint8_t { kProtoNone = 0, kProtoSweep = 1, kProtoLoad = 2, kProtoLong = 3 };

/// Name of a protocol, as used by the `run` command and the log's condition.
inline const char* protocol_name(Protocol p) {
  switch (p) {
    case kProtoSweep: return "sweep";
    case kProtoLoad: return "load";
    case kProtoLong: return "long";
    default: return "manual";
  }
}

/// Duty (0..10000 = 0..1) and load in force during one sample.
struct Setpoint {
  uint16_t duty_q;
  uint8_t load;
};

/// A protocol with its step lengths in samples.
class ProtocolPlan {
 public:
  ProtocolPlan() : proto_(kProtoNone), hold_(1), long_(1) {}
  /// hold_samples: length of each sweep/load step; long_samples: length of `long`.
  ProtocolPlan(Protocol p, uint32_t hold_samples, uint32_t long_samples)
      : proto_(p), hold_(hold_samples ? hold_samples : 1), long_(long_samples ? long_samples : 1) {}

  Protocol protocol() const { return proto_; }

  /// Number of samples of the whole protocol.
  uint32_t total() const {
    switch (proto_) {
      case kProtoSweep: return kSweepSteps * hold_;
      case kProtoLoad: return kLoadSteps * hold_;
      case kProtoLong: return long_;
      default: return 0;
    }
  }

  /// Setpoint of sample k; false once the protocol is over (k >= total()).
  bool at(uint32_t k, Setpoint* out) const {
    if (k >= total()) return false;
    switch (proto_) {
      case kProtoSweep: {
        const uint32_t step = k / hold_;  // 0..10
        const uint32_t level = step <= 5 ? step : 10 - step;
        out->duty_q = static_cast<uint16_t>(level * 2000u);
        out->load = 0;
        return true;
      }
      case kProtoLoad: {
        static const uint8_t kLoads[kLoadSteps] = {0, 1, 2, 1, 0};
        out->duty_q = 8000;
        out->load = kLoads[k / hold_];
        return true;
      }
      default:
        out->duty_q = 8000;
        out->load = 2;
        return true;
    }
  }

 private:
  static const uint8_t kSweepSteps = 11;
  static const uint8_t kLoadSteps = 5;
  Protocol proto_;
  uint32_t hold_;
  uint32_t long_;
};

/// Samples in `seconds` at rate_hz, rounded, at least 1.
inline uint32_t samples_for(float seconds, float rate_hz) {
  const float n = seconds * rate_hz + 0.5f;
  if (!(n >= 1.0f)) return 1;
  if (n >= 4.0e9f) return 4000000000UL;
  return static_cast<uint32_t>(n);
}

}  // namespace acq

#endif  // HPDDO_ACQ_PROTOCOL_H
