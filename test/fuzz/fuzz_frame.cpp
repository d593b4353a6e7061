// libFuzzer target: any byte stream into hpddo::FrameDecoder (with the channel
// limits of a model). Every decoded frame must be plausible and re-encode to the
// 21 bytes it came from, and the counters must add up (a byte that ended one frame
// and began the next counts in both).
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "hpddo/frame.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const hpddo::InputLimits kLimits = {40.0f, 10.0f, -55.0f, 125.0f};
  hpddo::FrameDecoder dec(&kLimits);
  hpddo::SampleFrame f;
  uint32_t frames = 0;
  for (size_t k = 0; k < size; ++k) {
    if (!dec.push(data[k], &f)) continue;
    ++frames;
    if (!hpddo::frame_plausible(f, &kLimits)) __builtin_trap();
    uint8_t again[hpddo::kFrameSize];
    hpddo::encode_frame(f, again);
    if (k + 1 < hpddo::kFrameSize || memcmp(again, data + k + 1 - hpddo::kFrameSize, hpddo::kFrameSize) != 0)
      __builtin_trap();
  }
  if (dec.frames() != frames) __builtin_trap();
  if (static_cast<uint64_t>(dec.dropped_bytes()) + static_cast<uint64_t>(frames) * hpddo::kFrameSize >
      size + static_cast<uint64_t>(dec.reused_bytes()))
    __builtin_trap();
  if (dec.reused_bytes() > 3u * frames) __builtin_trap();
  return 0;
}
