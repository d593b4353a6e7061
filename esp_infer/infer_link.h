// Inference side of the link: bytes in, observer samples out. Decodes frames
// (hpddo::FrameDecoder resynchronises after corrupt bytes), counts seq gaps
// and the samples they lost, and turns a frame into an observer Sample.
// The encoder speed a frame carries is kept apart, for telemetry only: the
// observer's Sample has no field it could go into.
#ifndef HPDDO_INFER_LINK_H
#define HPDDO_INFER_LINK_H

#include <stdint.h>

#include "hpddo/frame.h"
#include "hpddo/observer.h"

namespace infer {

/// Observer input from a frame: V, I, temperature where present, dt and seq.
inline hpddo::Sample sample_from_frame(const hpddo::SampleFrame& f) {
  hpddo::Sample s;
  s.v_V = hpddo::frame_v_V(f);
  s.i_A = hpddo::frame_i_A(f);
  s.temp_C = hpddo::frame_temp_C(f);
  s.dt_s = hpddo::frame_dt_s(f);
  s.seq = f.seq;
  s.has_seq = true;
  return s;
}

/// Encoder speed of a frame in RPM, NaN when it carries none (comparison only).
inline float frame_rpm_ref(const hpddo::SampleFrame& f) {
  return (f.flags & hpddo::kFrameFlagRpm) ? static_cast<float>(f.rpm_x10) * 0.1f : hpddo::absent();
}

/// Link receiver with gap accounting.
class LinkReceiver {
 public:
  LinkReceiver() : has_seq_(false), last_seq_(0), gaps_(0), lost_(0) {}

  /// Feeds one byte; true when it completed a frame, written to *out.
  bool push(uint8_t byte, hpddo::SampleFrame* out) {
    if (!dec_.push(byte, out)) return false;
    if (has_seq_) {
      const uint16_t step = static_cast<uint16_t>(out->seq - last_seq_);
      if (step != 1u) {
        ++gaps_;
        lost_ += step ? static_cast<uint32_t>(step - 1u) : 0u;  // a repeat loses nothing
      }
    }
    has_seq_ = true;
    last_seq_ = out->seq;
    return true;
  }

  uint32_t frames() const { return dec_.frames(); }           ///< valid frames
  uint32_t crc_errors() const { return dec_.crc_errors(); }   ///< damaged frames
  uint32_t dropped_bytes() const { return dec_.dropped_bytes(); }
  uint32_t gaps() const { return gaps_; }                     ///< seq discontinuities
  uint32_t lost() const { return lost_; }                     ///< samples missing in gaps

 private:
  hpddo::FrameDecoder dec_;
  bool has_seq_;
  uint16_t last_seq_;
  uint32_t gaps_;
  uint32_t lost_;
};

}  // namespace infer

#endif  // HPDDO_INFER_LINK_H
