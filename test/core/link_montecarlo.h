// Monte-Carlo of the link: a stream of plausible frames, about half of them damaged
// the ways a serial line damages bytes, through hpddo::FrameDecoder. Counts the
// damaged frames, the false accepts (a decoded frame that is not one that was sent)
// and the good frames lost. Used by test_frame.cpp (bounded count) and by
// link_false_accepts.cpp (the figure in docs/firmware.md).
#ifndef HPDDO_TEST_LINK_MONTECARLO_H
#define HPDDO_TEST_LINK_MONTECARLO_H

#include <stdint.h>
#include <string.h>

#include <random>
#include <vector>

#include "hpddo/frame.h"

namespace linkmc {

/// Totals of one run.
struct Result {
  uint64_t sent = 0;           ///< frames sent
  uint64_t damaged = 0;        ///< of which damaged
  uint64_t decoded = 0;        ///< frames the decoder gave
  uint64_t false_accepts = 0;  ///< decoded frames that were never sent
  uint64_t good_lost = 0;      ///< undamaged frames not decoded
  uint64_t rejected = 0;       ///< CRC-valid candidates refused as implausible
};

/// A frame as the acquisition board sends it: 2 Hz or 100 Hz, V, I, temperature
/// and speed of a small motor.
inline hpddo::SampleFrame plausible_frame(std::mt19937& rng, uint16_t seq) {
  std::uniform_int_distribution<int> v(0, 14000), i(-300, 3000), t(15 * 16, 70 * 16), n(-100, 40000), d(0, 255);
  hpddo::SampleFrame f;
  f.seq = seq;
  const bool temp = (rng() & 3u) != 0;
  f.flags = static_cast<uint8_t>(hpddo::kFrameFlagRpm | (temp ? hpddo::kFrameFlagTemp : 0));
  f.duty = static_cast<uint8_t>(d(rng));
  f.v_mV = static_cast<uint16_t>(v(rng));
  f.i_mA = static_cast<int16_t>(i(rng));
  f.temp_c16 = static_cast<int16_t>(temp ? t(rng) : 0);
  f.rpm_x10 = static_cast<int16_t>(n(rng));
  f.period_us = (rng() & 1u) ? 500000u : 10000u;
  return f;
}

/// Damages the bytes of one frame: bit flips, a replaced byte, a burst, a dropped
/// or inserted byte, the last 1-3 bytes lost, or the frame cut short.
inline void damage(std::mt19937& rng, std::vector<uint8_t>& b) {
  const uint32_t kind = static_cast<uint32_t>(rng() % 7u);
  const auto at = [&](size_t n) { return static_cast<size_t>(rng() % n); };
  switch (kind) {
    case 0: {
      const int flips = 1 + static_cast<int>(rng() % 4u);
      for (int k = 0; k < flips; ++k) b[at(b.size())] ^= static_cast<uint8_t>(1u << (rng() % 8u));
      break;
    }
    case 1: b[at(b.size())] = static_cast<uint8_t>(rng()); break;
    case 2: {
      const size_t len = 2 + at(7), start = at(b.size() - len + 1);
      for (size_t k = 0; k < len; ++k) b[start + k] = static_cast<uint8_t>(rng());
      break;
    }
    case 3: b.erase(b.begin() + static_cast<long>(at(b.size()))); break;
    case 4: b.insert(b.begin() + static_cast<long>(at(b.size() + 1)), static_cast<uint8_t>(rng())); break;
    case 5: b.resize(b.size() - 1 - at(3)); break;
    default: b.resize(1 + at(b.size() - 1)); break;
  }
}

/// Runs until `damaged_target` damaged frames were sent (each frame damaged with
/// probability 1/2), decoding with the given limits.
inline Result run(uint64_t damaged_target, uint32_t seed, const hpddo::InputLimits* limits) {
  std::mt19937 rng(seed);
  hpddo::FrameDecoder dec(limits);
  Result r;
  // The last few frames sent, to tell a genuine decode from a false accept.
  const int kWindow = 4;
  uint8_t recent[kWindow][hpddo::kFrameSize];
  bool intact[kWindow] = {false, false, false, false};
  bool seen[kWindow] = {false, false, false, false};
  uint16_t seq = 0;
  std::vector<uint8_t> bytes;
  while (r.damaged < damaged_target) {
    const int slot = static_cast<int>(r.sent % kWindow);
    if (r.sent >= kWindow && intact[slot] && !seen[slot]) ++r.good_lost;
    const hpddo::SampleFrame f = plausible_frame(rng, seq++);
    hpddo::encode_frame(f, recent[slot]);
    bytes.assign(recent[slot], recent[slot] + hpddo::kFrameSize);
    intact[slot] = (rng() & 1u) != 0;
    seen[slot] = false;
    if (!intact[slot]) {
      damage(rng, bytes);
      ++r.damaged;
    }
    ++r.sent;
    for (uint8_t byte : bytes) {
      hpddo::SampleFrame got;
      if (!dec.push(byte, &got)) continue;
      ++r.decoded;
      uint8_t enc[hpddo::kFrameSize];
      hpddo::encode_frame(got, enc);
      bool genuine = false;
      for (int k = 0; k < kWindow; ++k) {
        if (static_cast<uint64_t>(k) < r.sent && memcmp(enc, recent[k], hpddo::kFrameSize) == 0) {
          genuine = true;
          seen[k] = true;
        }
      }
      if (!genuine) ++r.false_accepts;
    }
  }
  r.rejected = dec.rejected();
  return r;
}

}  // namespace linkmc

#endif  // HPDDO_TEST_LINK_MONTECARLO_H
