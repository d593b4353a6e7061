// The paper's three test protocols (section 3.6.1) as a function of the
// sample index: which duty and load are in force during sample k.
//
//   sweep  duty 0 -> 100 % -> 0 in 20 % steps, no load, each step 30 s
//   load   80 % duty, 12 dwells of 25 s: loads 0, 1 (0.5 ohm), 2 (0.01 ohm), 0, 2,
//          1, 0, 1, 2, 1, 0, 2
//   long   80 % duty with load 2 (0.01 ohm) for 3600 s
// The steps, duties, loads and lengths are those of bench_gen.h (generated from
// tools/hpddo/bench.py, shared with the twin); `hold` and `long` may override
// the lengths.
#ifndef HPDDO_ACQ_PROTOCOL_H
#define HPDDO_ACQ_PROTOCOL_H

#include <stdint.h>

#include "bench_gen.h"

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
  constexpr ProtocolPlan() : proto_(kProtoNone), hold_(1), long_(1) {}
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
        out->duty_q = bench::kSweepDutyQ[k / hold_];
        out->load = 0;
        return true;
      }
      case kProtoLoad: {
        out->duty_q = HPDDO_BENCH_LOAD_DUTY_Q;
        out->load = bench::kLoadSequence[k / hold_];
        return true;
      }
      default:
        out->duty_q = HPDDO_BENCH_LONG_DUTY_Q;
        out->load = HPDDO_BENCH_LONG_LOAD;
        return true;
    }
  }

 private:
  static const uint8_t kSweepSteps = HPDDO_BENCH_SWEEP_STEPS;
  static const uint8_t kLoadSteps = HPDDO_BENCH_LOAD_STEPS;
  Protocol proto_;
  uint32_t hold_;
  uint32_t long_;
};

/// Step length of `p` in seconds: `hold_s` when positive, else the bench's own.
inline float step_seconds(Protocol p, float hold_s) {
  if (hold_s > 0.0f) return hold_s;
  return p == kProtoSweep ? HPDDO_BENCH_SWEEP_STEP_S : HPDDO_BENCH_LOAD_STEP_S;
}

/// Samples in `seconds` at rate_hz, rounded, at least 1.
inline uint32_t samples_for(float seconds, float rate_hz) {
  const float n = seconds * rate_hz + 0.5f;
  if (!(n >= 1.0f)) return 1;
  if (n >= 4.0e9f) return 4000000000UL;
  return static_cast<uint32_t>(n);
}

}  // namespace acq

#endif  // HPDDO_ACQ_PROTOCOL_H
