// Link frames from the acquisition board (UNO) to the inference board
// (ESP8266): one sample per frame, fixed point, little-endian, CRC-protected.
//
//   offset  size  field
//   0       1     sync0 0xA5
//   1       1     sync1 0x5A
//   2       1     payload length (16)
//   3       2     seq           sample counter, wraps at 65536
//   5       1     flags         bit0 temp present, bit1 rpm_ref present
//   6       1     duty          PWM duty, 0..255 = 0..1
//   7       2     v_mV          terminal voltage, mV, unsigned
//   9       2     i_mA          armature current, mA, signed
//   11      2     temp_c16      case temperature, 1/16 C (DS18B20 native), signed
//   13      2     rpm_x10       encoder speed, 0.1 RPM, signed (comparison only)
//   15      4     period_us     sample period, us
//   19      2     crc           CRC-16/CCITT-FALSE over bytes 2..18
//
// 21 bytes a sample, 210 bits in 8N1. The link runs at 38400 baud (the UNO's
// Timer2 gives 38462, the ESP8266 receives at 38400; uno_acq/acq_config.h and
// esp_infer/esp_infer.cpp, kLinkBaud): a frame takes 5.5 ms, so the link carries
// about 180 samples/s; 100 Hz uses 21 kbit/s. At faster rates the UNO drops whole
// frames (counted in link_drops) and the ESP8266 sees the seq gaps.
// A frame is accepted only when its CRC matches and its fields are ones the
// acquisition board can send (frame_plausible).
#ifndef HPDDO_FRAME_H
#define HPDDO_FRAME_H

#include <stddef.h>
#include <stdint.h>

#include "crc.h"
#include "limits.h"
#include "platform.h"

namespace hpddo {

static const uint8_t kFrameSync0 = 0xA5;
static const uint8_t kFrameSync1 = 0x5A;
static const uint8_t kFramePayloadSize = 16;
static const uint8_t kFrameSize = 3 + kFramePayloadSize + 2;
static const uint8_t kFrameFlagTemp = 1u << 0;
static const uint8_t kFrameFlagRpm = 1u << 1;
static const uint8_t kFrameFlagsKnown = kFrameFlagTemp | kFrameFlagRpm;

/// One sample as it crosses the link, in the frame's fixed-point units.
struct SampleFrame {
  uint16_t seq;
  uint8_t flags;
  uint8_t duty;
  uint16_t v_mV;
  int16_t i_mA;
  int16_t temp_c16;
  int16_t rpm_x10;
  uint32_t period_us;
};

namespace detail {
inline void put_u16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v & 0xFFu);
  p[1] = static_cast<uint8_t>(v >> 8);
}
inline uint16_t get_u16(const uint8_t* p) {
  return static_cast<uint16_t>(p[0] | static_cast<uint16_t>(p[1] << 8));
}
inline void put_u32(uint8_t* p, uint32_t v) {
  put_u16(p, static_cast<uint16_t>(v & 0xFFFFu));
  put_u16(p + 2, static_cast<uint16_t>(v >> 16));
}
inline uint32_t get_u32(const uint8_t* p) {
  return static_cast<uint32_t>(get_u16(p)) | (static_cast<uint32_t>(get_u16(p + 2)) << 16);
}
}  // namespace detail

/// Writes f as a complete frame into out (kFrameSize bytes).
inline void encode_frame(const SampleFrame& f, uint8_t (&out)[kFrameSize]) {
  out[0] = kFrameSync0;
  out[1] = kFrameSync1;
  out[2] = kFramePayloadSize;
  detail::put_u16(out + 3, f.seq);
  out[5] = f.flags;
  out[6] = f.duty;
  detail::put_u16(out + 7, f.v_mV);
  detail::put_u16(out + 9, static_cast<uint16_t>(f.i_mA));
  detail::put_u16(out + 11, static_cast<uint16_t>(f.temp_c16));
  detail::put_u16(out + 13, static_cast<uint16_t>(f.rpm_x10));
  detail::put_u32(out + 15, f.period_us);
  detail::put_u16(out + 19, crc16(out + 2, 1u + kFramePayloadSize));
}

/// Rounds x to the nearest integer within [lo, hi] (NaN gives lo).
inline int32_t saturate_round(float x, int32_t lo, int32_t hi) {
  if (!(x >= static_cast<float>(lo))) return lo;
  if (x >= static_cast<float>(hi)) return hi;
  return static_cast<int32_t>(x >= 0.0f ? x + 0.5f : x - 0.5f);
}

/// Voltage in V from a frame.
inline float frame_v_V(const SampleFrame& f) { return static_cast<float>(f.v_mV) * 0.001f; }
/// Current in A from a frame.
inline float frame_i_A(const SampleFrame& f) { return static_cast<float>(f.i_mA) * 0.001f; }
/// Temperature in C from a frame; NaN when absent.
inline float frame_temp_C(const SampleFrame& f) {
  return (f.flags & kFrameFlagTemp) ? static_cast<float>(f.temp_c16) * 0.0625f : absent();
}
/// Sample period in s from a frame.
inline float frame_dt_s(const SampleFrame& f) { return static_cast<float>(f.period_us) * 1e-6f; }

/// True when f is a frame the acquisition board can send: no unknown flag bits,
/// absent fields zero, a period within [kFramePeriodMin_us, kFramePeriodMax_us]
/// and, given limits (the model's channel and sensor limits), V, I and the
/// temperature within them. A CRC-valid frame that is not is damage.
inline bool frame_plausible(const SampleFrame& f, const InputLimits* limits) {
  if (f.flags & static_cast<uint8_t>(~kFrameFlagsKnown)) return false;
  if (!(f.flags & kFrameFlagTemp) && f.temp_c16 != 0) return false;
  if (!(f.flags & kFrameFlagRpm) && f.rpm_x10 != 0) return false;
  if (f.period_us < kFramePeriodMin_us || f.period_us > kFramePeriodMax_us) return false;
  if (!limits) return true;
  const float i_A = frame_i_A(f);
  if (frame_v_V(f) > limits->v_max_V || i_A > limits->i_max_A || i_A < -limits->i_max_A) return false;
  if (f.flags & kFrameFlagTemp) {
    const float t_C = frame_temp_C(f);
    if (t_C < limits->temp_min_C || t_C > limits->temp_max_C) return false;
  }
  return true;
}

/// Byte-at-a-time frame decoder that resynchronises after corrupt bytes: on a
/// bad length, a bad CRC or an implausible frame (frame_plausible) it rescans
/// the bytes it held from the one after the failed sync, so a frame that starts
/// inside a damaged one is not lost. A decoded frame whose last bytes could be
/// the start of the next one (a frame that lost its last byte completes on the
/// next frame's sync) keeps them as such, so a truncated frame never costs the
/// frame after it.
class FrameDecoder {
 public:
  /// limits: the channel and sensor limits frames are checked against (the
  /// model's InputLimits); without, only flags, absent fields and period.
  explicit FrameDecoder(const InputLimits* limits = nullptr)
      : limits_(limits), len_(0), held_(0), frames_(0), crc_errors_(0), rejected_(0), dropped_bytes_(0),
        reused_bytes_(0) {}

  /// Feeds one byte; true when it completed a valid frame, written to *out.
  bool push(uint8_t byte, SampleFrame* out) {
    buf_[len_++] = byte;
    for (;;) {
      const uint8_t verdict = check();
      if (verdict == kNeedMore) return false;
      if (verdict == kComplete) {
        SampleFrame f;
        parse(&f);
        if (frame_plausible(f, limits_)) {
          *out = f;
          ++frames_;
          reused_bytes_ += held_;
          keep_sync_tail();
          return true;
        }
        ++rejected_;
      } else if (verdict == kBadCrc) {
        ++crc_errors_;
      }
      // Not a frame: drop the first byte and rescan what remains.
      shift_one();
    }
  }

  uint32_t frames() const { return frames_; }              ///< valid frames decoded
  uint32_t crc_errors() const { return crc_errors_; }      ///< candidates with a bad CRC
  uint32_t rejected() const { return rejected_; }          ///< CRC-valid candidates that were implausible
  uint32_t dropped_bytes() const { return dropped_bytes_; }///< bytes discarded while resyncing
  uint32_t reused_bytes() const { return reused_bytes_; }  ///< bytes that ended one frame and began the next

 private:
  enum : uint8_t { kNeedMore = 0, kComplete = 1, kBadSync = 2, kBadCrc = 3 };

  uint8_t check() const {
    if (len_ == 0) return kNeedMore;
    if (buf_[0] != kFrameSync0) return kBadSync;
    if (len_ < 2) return kNeedMore;
    if (buf_[1] != kFrameSync1) return kBadSync;
    if (len_ < 3) return kNeedMore;
    if (buf_[2] != kFramePayloadSize) return kBadSync;
    if (len_ < kFrameSize) return kNeedMore;
    const uint16_t want = detail::get_u16(buf_ + 19);
    return crc16(buf_ + 2, 1u + kFramePayloadSize) == want ? kComplete : kBadCrc;
  }

  /// Keeps the longest tail of a decoded frame that is a start of a frame header.
  void keep_sync_tail() {
    const uint8_t head[3] = {kFrameSync0, kFrameSync1, kFramePayloadSize};
    uint8_t keep = 3;
    for (; keep > 0; --keep) {
      uint8_t k = 0;
      while (k < keep && buf_[kFrameSize - keep + k] == head[k]) ++k;
      if (k == keep) break;
    }
    for (uint8_t k = 0; k < keep; ++k) buf_[k] = buf_[kFrameSize - keep + k];
    len_ = keep;
    held_ = keep;
  }

  void shift_one() {
    for (uint8_t k = 1; k < len_; ++k) buf_[k - 1] = buf_[k];
    --len_;
    if (held_) {
      --held_;  // a byte of the last frame: not dropped
    } else {
      ++dropped_bytes_;
    }
  }

  void parse(SampleFrame* f) const {
    f->seq = detail::get_u16(buf_ + 3);
    f->flags = buf_[5];
    f->duty = buf_[6];
    f->v_mV = detail::get_u16(buf_ + 7);
    f->i_mA = static_cast<int16_t>(detail::get_u16(buf_ + 9));
    f->temp_c16 = static_cast<int16_t>(detail::get_u16(buf_ + 11));
    f->rpm_x10 = static_cast<int16_t>(detail::get_u16(buf_ + 13));
    f->period_us = detail::get_u32(buf_ + 15);
  }

  const InputLimits* limits_;
  uint8_t buf_[kFrameSize];
  uint8_t len_;
  uint8_t held_;
  uint32_t frames_;
  uint32_t crc_errors_;
  uint32_t rejected_;
  uint32_t dropped_bytes_;
  uint32_t reused_bytes_;
};

}  // namespace hpddo

#endif  // HPDDO_FRAME_H
