// The ripple acquisition mode (issue 23, item 2): the armature current sampled once per
// PWM period at a fixed phase, the middle of the on-time, and sent to the host in framed,
// checked chunks beside each window's V and I means. Pure logic (timing, burst length,
// chunk encoding); the registers are in acq_ripple_board.h. docs/ripple-board.md, "The UNO's
// ripple mode", says why the PWM runs at the sample rate and gives the measured figures.
//
// Why the PWM frequency changes in this mode: one sample per PWM period at the middle of the
// on-time is the period mean of the current (continuous conduction: the current rises
// linearly during the on-time, so its middle value is its mean, and the mean over the on-time
// equals the mean over the off-time), so the PWM chop does not reach the samples. The sample
// rate must resolve the ripple (a few hundred Hz to a few kHz), so the PWM runs at the sample
// rate, 8..20 kHz, not at the bench's 490 Hz, where one sample per period would be 490 Hz and
// the current would not conduct continuously.
//
// A window: first the free-running V/I conversions of the normal mode, whose means are the
// window's V and I (a fixed-phase V sample would read the on or the off level of the terminal
// voltage, not its mean; the free-running conversions, 1664 cycles apart, step through every
// phase of the period), stopped stop_periods before the burst so that its first trigger finds
// the ADC idle; then the burst, the window's last n periods, one triggered conversion of the
// current each (Timer1 compare B starts the ADC in hardware). The burst comes last so that the
// main loop's work on the closed window (the log row, the observer: up to 7 ms) falls in the
// V/I part, while the ring is empty, not at the start of a burst.
//
// Chunk (little-endian, CRC-16/CCITT-FALSE of hpddo/crc.h like the sample frames of
// hpddo/frame.h), base64 on a text line "~<base64>\n" on the USB serial, so that a ripple
// chunk never looks like a log row:
//   0  1  sync0 0xA5
//   1  1  sync1 0x5B           (0x5A is a sample frame, 0x5C a coast probe's chunk: acq_coast.h)
//   2  1  payload length       13 + ceil(10 n / 8)
//   3  4  seq                  the window's seq (the log's)
//   7  2  first                index of the chunk's first sample in the burst
//   9  2  total                samples in the burst
//   11 2  start_period         the PWM period of the window in which sample 0 is taken
//   13 2  phase_cycles         CPU cycles from that period's start to each sample-and-hold
//   15 1  n                    samples in this chunk, 1..32
//   16 .  codes                10-bit ADC codes, packed LSB first
//   .  2  crc                  over bytes 2..end-3 (length to the last code byte)
#ifndef HPDDO_ACQ_RIPPLE_H
#define HPDDO_ACQ_RIPPLE_H

#include <stdint.h>

#include "acq_window.h"
#include "hpddo/crc.h"

namespace acq {

static const uint32_t kRippleHzMin = 8000;    ///< slowest ripple sample rate (= PWM), Hz
static const uint32_t kRippleHzMax = 20000;   ///< fastest
/// USB serial in the ripple mode: 500000 baud is exact at 16 MHz (U2X, UBRR 3; 115200 is 2.1 %
/// off) and carries 50000 characters/s. A 10 kHz burst needs 25625 (82 characters a 32-sample
/// chunk), more than 115200 baud carries at all; the 2 KB of RAM cannot hold a burst to send
/// it later, so the line must keep up while the burst runs.
static const uint32_t kRippleHostBaud = 500000;
static const uint8_t kRippleChunkSamples = 32;        ///< samples per chunk at most
static const uint8_t kRippleSync1 = 0x5B;
static const uint8_t kRippleHead = 16;                ///< bytes before the codes
static const uint8_t kRippleChunkMax = kRippleHead + (kRippleChunkSamples * 10 + 7) / 8 + 2;  ///< 58
/// Characters of a full chunk's line: '~', base64 of kRippleChunkMax bytes, '\n'.
static const uint8_t kRippleLineMax = 1 + (kRippleChunkMax + 2) / 3 * 4 + 1;  ///< 82
/// Share of the USB line the bursts may take (the rest: the log line, replies, slack).
static const float kRippleLinkShare = 0.8f;
/// Share of each window left to the free-running V/I conversions (its V and I means).
static const float kRippleViShare = 0.2f;
/// Characters of a log row at most (kLineMax less its NUL), budgeted per window.
static const uint16_t kRippleRowChars = 96;
/// Free-running conversion at the normal 125 kHz ADC clock: 13 ADC clocks of 128 cycles.
static const uint16_t kFreeConvCycles = 13u * 128u;

/// Timer1 and ADC settings of the ripple mode at one sample rate.
struct RippleTiming {
  PwmTiming pwm;          ///< the PWM at the sample rate
  uint8_t adps;           ///< ADPS2..0 of the triggered conversions
  uint16_t conv_cycles;   ///< a triggered conversion, CPU cycles (13.5 ADC clocks)
  uint16_t sh_cycles;     ///< trigger to sample-and-hold: 2 ADC clocks + 3 CPU cycles (datasheet 24.4)
  uint16_t stop_periods;  ///< free-running conversions stop this many periods before the close
};

/// The ripple mode's timing at hz (kRippleHzMin..kRippleHzMax); false outside. The ADC clock of
/// the triggered conversions is the slowest (most accurate) whose conversion takes at most 30 %
/// of a period, so that a conversion triggered at the middle of the longest on-time (half the
/// period) ends, with its interrupt, within the same period: 500 kHz at 8..10 kHz, 1 MHz at 20 kHz.
inline bool ripple_timing(uint32_t hz, RippleTiming* out) {
  if (hz < kRippleHzMin || hz > kRippleHzMax) return false;
  if (!pwm_timing(hz, &out->pwm) || out->pwm.prescale != 1) return false;
  const uint32_t period = pwm_period_cycles(out->pwm);
  uint8_t adps = 6;  // /64
  while (adps > 2 && 27u * (1u << adps) / 2u > period * 3u / 10u) --adps;
  out->adps = adps;
  out->conv_cycles = static_cast<uint16_t>(27u * (1u << adps) / 2u);
  out->sh_cycles = static_cast<uint16_t>(2u * (1u << adps) + 3u);
  out->stop_periods = static_cast<uint16_t>((kFreeConvCycles + period - 1u) / period + 1u);
  return true;
}

/// OCR1B for a sample-and-hold at the middle of the on-time. Fast PWM, non-inverting: the
/// output is high from BOTTOM through the compare match, ocr1a + 1 timer ticks; duty 0 (no
/// on-time) and duty 1 (always on) sample the middle of the period. A short on-time whose
/// middle comes before the sample-and-hold delay samples at the earliest (OCR1B 0).
inline uint16_t ripple_trigger(const PwmTiming& t, uint16_t ocr1a, uint16_t duty_q, uint16_t sh_cycles) {
  const uint32_t on = (duty_q == 0 || duty_q >= 10000) ? static_cast<uint32_t>(t.top) + 1u
                                                       : static_cast<uint32_t>(ocr1a) + 1u;
  const uint32_t mid = on / 2u;
  return static_cast<uint16_t>(mid > sh_cycles ? mid - sh_cycles : 0u);
}

/// Line characters of the chunks of a burst of n samples.
inline uint32_t ripple_burst_chars(uint16_t n) {
  const uint16_t full = static_cast<uint16_t>(n / kRippleChunkSamples);
  const uint8_t rest = static_cast<uint8_t>(n % kRippleChunkSamples);
  uint32_t chars = static_cast<uint32_t>(full) * kRippleLineMax;
  if (rest) {
    const uint8_t bytes = static_cast<uint8_t>(kRippleHead + (rest * 10u + 7u) / 8u + 2u);
    chars += 1u + (bytes + 2u) / 3u * 4u + 1u;
  }
  return chars;
}

/// Samples of each window's burst: the whole chunks that fit both the window less its V/I
/// share and stop periods, and kRippleLinkShare of the USB line (baud / 10 characters a
/// second) less one log row per window. 0 when not one chunk fits, or when the chunks of a
/// burst come faster than kRippleLinkShare of the line carries them (the ring holds only
/// kRippleRing codes): no burst.
inline uint16_t ripple_burst_samples(const RippleTiming& rt, uint16_t window_periods, uint32_t baud) {
  const float line_cps = static_cast<float>(baud) / 10.0f * kRippleLinkShare;
  const float sample_hz = static_cast<float>(kCpuHz) / static_cast<float>(pwm_period_cycles(rt.pwm));
  if (static_cast<float>(kRippleLineMax) / kRippleChunkSamples * sample_hz > line_cps) return 0;
  const float vi = static_cast<float>(window_periods) * kRippleViShare;
  const float room = static_cast<float>(window_periods) - vi - static_cast<float>(rt.stop_periods);
  if (!(room >= static_cast<float>(kRippleChunkSamples))) return 0;
  uint16_t n = static_cast<uint16_t>(static_cast<uint16_t>(room) / kRippleChunkSamples * kRippleChunkSamples);
  const float window_s = static_cast<float>(pwm_period_cycles(rt.pwm)) * static_cast<float>(window_periods) /
                         static_cast<float>(kCpuHz);
  const float chars = line_cps * window_s - kRippleRowChars;
  while (n && static_cast<float>(ripple_burst_chars(n)) > chars) n = static_cast<uint16_t>(n - kRippleChunkSamples);
  return n;
}

/// One chunk before encoding.
struct RippleChunk {
  uint32_t seq;
  uint16_t first;
  uint16_t total;
  uint16_t start_period;
  uint16_t phase_cycles;
  uint8_t n;
  const uint16_t* codes;  ///< n codes, 0..1023
};

/// Encodes a chunk into out (at least kRippleChunkMax bytes); returns its length. sync1: the chunk's
/// kind, kRippleSync1 (a burst of the current) or kCoastSync1 (a coast probe, acq_coast.h).
inline uint8_t encode_ripple_chunk(const RippleChunk& c, uint8_t* out, uint8_t sync1 = kRippleSync1) {
  const uint8_t packed = static_cast<uint8_t>((c.n * 10u + 7u) / 8u);
  out[0] = 0xA5;
  out[1] = sync1;
  out[2] = static_cast<uint8_t>(kRippleHead - 3u + packed);
  out[3] = static_cast<uint8_t>(c.seq);
  out[4] = static_cast<uint8_t>(c.seq >> 8);
  out[5] = static_cast<uint8_t>(c.seq >> 16);
  out[6] = static_cast<uint8_t>(c.seq >> 24);
  out[7] = static_cast<uint8_t>(c.first);
  out[8] = static_cast<uint8_t>(c.first >> 8);
  out[9] = static_cast<uint8_t>(c.total);
  out[10] = static_cast<uint8_t>(c.total >> 8);
  out[11] = static_cast<uint8_t>(c.start_period);
  out[12] = static_cast<uint8_t>(c.start_period >> 8);
  out[13] = static_cast<uint8_t>(c.phase_cycles);
  out[14] = static_cast<uint8_t>(c.phase_cycles >> 8);
  out[15] = c.n;
  uint8_t* p = out + kRippleHead;
  for (uint8_t k = 0; k < packed; ++k) p[k] = 0;
  uint16_t bit = 0;
  for (uint8_t k = 0; k < c.n; ++k, bit = static_cast<uint16_t>(bit + 10u)) {
    const uint16_t v = static_cast<uint16_t>(c.codes[k] & 0x3FFu);
    const uint8_t byte = static_cast<uint8_t>(bit >> 3);
    const uint8_t sh = static_cast<uint8_t>(bit & 7u);
    const uint32_t w = static_cast<uint32_t>(v) << sh;  // 10 bits over 2 or 3 bytes
    p[byte] = static_cast<uint8_t>(p[byte] | static_cast<uint8_t>(w));
    p[byte + 1] = static_cast<uint8_t>(p[byte + 1] | static_cast<uint8_t>(w >> 8));
    if (sh > 6) p[byte + 2] = static_cast<uint8_t>(p[byte + 2] | static_cast<uint8_t>(w >> 16));
  }
  const uint8_t end = static_cast<uint8_t>(kRippleHead + packed);
  const uint16_t crc = hpddo::crc16(out + 2, static_cast<size_t>(end - 2u));
  out[end] = static_cast<uint8_t>(crc);
  out[end + 1] = static_cast<uint8_t>(crc >> 8);
  return static_cast<uint8_t>(end + 2u);
}

/// Writes '~', the base64 of n bytes (RFC 4648, with '=' padding) and '\n' into out
/// (at least kRippleLineMax characters); returns the characters written.
inline uint8_t ripple_line(const uint8_t* data, uint8_t n, char* out) {
  static const char kB64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  uint8_t o = 0;
  out[o++] = '~';
  for (uint8_t k = 0; k < n; k = static_cast<uint8_t>(k + 3u)) {
    const uint8_t left = static_cast<uint8_t>(n - k);
    const uint32_t w = (static_cast<uint32_t>(data[k]) << 16) |
                       (left > 1 ? static_cast<uint32_t>(data[k + 1]) << 8 : 0u) | (left > 2 ? data[k + 2] : 0u);
    out[o++] = kB64[(w >> 18) & 63u];
    out[o++] = kB64[(w >> 12) & 63u];
    out[o++] = left > 1 ? kB64[(w >> 6) & 63u] : '=';
    out[o++] = left > 2 ? kB64[w & 63u] : '=';
  }
  out[o++] = '\n';
  return o;
}

/// Single-producer (ADC interrupt) single-consumer (main loop) ring of 10-bit codes; N a
/// power of two, at most 128. Single-byte indices are atomic on the AVR.
template <uint8_t N>
class SampleRing {
  static_assert(N && (N & (N - 1)) == 0 && N <= 128, "N must be a power of two <= 128");

 public:
  constexpr SampleRing() : buf_(), head_(0), tail_(0), peak_(0) {}
  /// Producer: false when full (the caller counts the loss).
  bool push(uint16_t code) {
    const uint8_t used = static_cast<uint8_t>(head_ - tail_);
    if (used >= N) return false;
    buf_[head_ & (N - 1)] = code;
    head_ = static_cast<uint8_t>(head_ + 1);
    if (used + 1u > peak_) peak_ = static_cast<uint8_t>(used + 1u);
    return true;
  }
  uint8_t size() const { return static_cast<uint8_t>(head_ - tail_); }
  /// Consumer: takes n (<= size()) codes into out.
  void pop(uint16_t* out, uint8_t n) {
    uint8_t t = tail_;
    for (uint8_t k = 0; k < n; ++k) out[k] = buf_[static_cast<uint8_t>(t++) & (N - 1)];
    tail_ = t;
  }
  /// Most codes ever held at once (how close the ring came to overflowing).
  uint8_t peak() const { return peak_; }
  void clear() { head_ = tail_ = peak_ = 0; }

 private:
  uint16_t buf_[N];
  volatile uint8_t head_;
  volatile uint8_t tail_;
  volatile uint8_t peak_;
};

}  // namespace acq

#endif  // HPDDO_ACQ_RIPPLE_H
