// Inference side of the link: bytes in, observer samples out. Decodes frames
// (hpddo::FrameDecoder resynchronises after corrupt bytes and refuses frames
// outside the model's channel limits), counts seq gaps and the samples they
// lost, and turns a frame into an observer Sample. The 16-bit seq cannot show
// 65536 lost samples; the arrival time can: a frame whose seq follows the last
// one but that arrives more than two periods plus kLinkSlack_ms after it
// follows a gap too (the board stopped, or a whole seq cycle was lost).
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

/// Delay beyond two sample periods after which a frame with the next seq is
/// taken to follow a gap, ms: covers the link's queueing and the loop's latency.
static const uint32_t kLinkSlack_ms = 1000;

/// Link receiver with gap accounting.
class LinkReceiver {
 public:
  /// limits: the channel and sensor limits of the model frames are checked
  /// against (pass &kModel.limits); without, only flags, absent fields and period.
  explicit LinkReceiver(const hpddo::InputLimits* limits = nullptr)
      : dec_(limits), has_seq_(false), has_time_(false), new_segment_(false), last_seq_(0), last_ms_(0),
        last_period_us_(0), gaps_(0), lost_(0) {}

  /// Feeds one byte; true when it completed a frame, written to *out.
  bool push(uint8_t byte, hpddo::SampleFrame* out) { return accept(byte, false, 0, out); }

  /// Feeds one byte received at now_ms (millis()); true when it completed a frame.
  /// The arrival times reveal a gap the 16-bit seq cannot show.
  bool push(uint8_t byte, uint32_t now_ms, hpddo::SampleFrame* out) { return accept(byte, true, now_ms, out); }

  /// True when the last frame followed a gap (seq or time): the observer's lags
  /// must restart (infer_step does).
  bool new_segment() const { return new_segment_; }

  uint32_t frames() const { return dec_.frames(); }           ///< valid frames
  uint32_t crc_errors() const { return dec_.crc_errors(); }   ///< damaged frames
  uint32_t rejected() const { return dec_.rejected(); }       ///< CRC-valid but implausible frames
  uint32_t dropped_bytes() const { return dec_.dropped_bytes(); }
  uint32_t gaps() const { return gaps_; }                     ///< seq discontinuities
  uint32_t lost() const { return lost_; }                     ///< samples missing in gaps

 private:
  bool accept(uint8_t byte, bool timed, uint32_t now_ms, hpddo::SampleFrame* out) {
    if (!dec_.push(byte, out)) return false;
    new_segment_ = false;
    if (has_seq_) {
      const uint16_t step = static_cast<uint16_t>(out->seq - last_seq_);
      const bool late = timed && has_time_ &&
                        now_ms - last_ms_ > 2u * (last_period_us_ / 1000u) + kLinkSlack_ms;
      if (step != 1u) {
        ++gaps_;
        lost_ += step ? static_cast<uint32_t>(step - 1u) : 0u;  // a repeat loses nothing
        new_segment_ = true;
      } else if (late) {
        ++gaps_;
        lost_ += 65536u;  // at least a whole seq cycle
        new_segment_ = true;
      }
    }
    has_seq_ = true;
    last_seq_ = out->seq;
    has_time_ = timed;
    last_ms_ = now_ms;
    last_period_us_ = out->period_us;
    return true;
  }

  hpddo::FrameDecoder dec_;
  bool has_seq_;
  bool has_time_;
  bool new_segment_;
  uint16_t last_seq_;
  uint32_t last_ms_;
  uint32_t last_period_us_;
  uint32_t gaps_;
  uint32_t lost_;
};

}  // namespace infer

#endif  // HPDDO_INFER_LINK_H
