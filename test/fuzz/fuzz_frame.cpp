// libFuzzer target: any byte stream into hpddo::FrameDecoder. Every decoded
// frame must re-encode to the 21 bytes it came from, and the counters must add up.
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "hpddo/frame.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  hpddo::FrameDecoder dec;
  hpddo::SampleFrame f;
  uint32_t frames = 0;
  for (size_t k = 0; k < size; ++k) {
    if (!dec.push(data[k], &f)) continue;
    ++frames;
    uint8_t again[hpddo::kFrameSize];
    hpddo::encode_frame(f, again);
    if (k + 1 < hpddo::kFrameSize || memcmp(again, data + k + 1 - hpddo::kFrameSize, hpddo::kFrameSize) != 0)
      __builtin_trap();
  }
  if (dec.frames() != frames) __builtin_trap();
  if (static_cast<uint64_t>(dec.dropped_bytes()) + static_cast<uint64_t>(frames) * hpddo::kFrameSize > size)
    __builtin_trap();
  return 0;
}
