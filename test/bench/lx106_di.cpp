// The 64-bit integer helpers of libgcc (libgcc2.c) that Debian's lx106 libgcc lacks, for the
// lx106 programs run in QEMU (test/bench/lx106_line.cpp, test/embedded/lx106): ArduinoJson
// and the acquisition code multiply and divide 64-bit integers.
#include <stdint.h>

// Division: libgcc's __udivdi3 takes the 32-bit path when both high words are zero, as
// every integer of the telemetry line does; this one does the same, and shifts and
// subtracts otherwise.
namespace {
uint64_t divmod64(uint64_t n, uint64_t d, uint64_t* rem) {
  if ((n >> 32) == 0 && (d >> 32) == 0) {
    *rem = static_cast<uint32_t>(n) % static_cast<uint32_t>(d);
    return static_cast<uint32_t>(n) / static_cast<uint32_t>(d);
  }
  uint64_t q = 0, r = 0;
  for (int b = 63; b >= 0; --b) {
    r = (r << 1) | ((n >> b) & 1u);
    if (r >= d) {
      r -= d;
      q |= uint64_t(1) << b;
    }
  }
  *rem = r;
  return q;
}
}  // namespace
extern "C" uint64_t __udivdi3(uint64_t n, uint64_t d) {
  uint64_t r;
  return divmod64(n, d, &r);
}
extern "C" uint64_t __umoddi3(uint64_t n, uint64_t d) {
  uint64_t r;
  divmod64(n, d, &r);
  return r;
}
// ArduinoJson's number parser multiplies 64-bit integers: libgcc2.c's __muldi3, from the 32 x 32 -> 64
// product that libsoft.a has (__umulsidi3), as libgcc builds it for the xtensa.
extern "C" uint64_t __umulsidi3(uint32_t a, uint32_t b);
extern "C" uint64_t __muldi3(uint64_t a, uint64_t b) {
  const uint32_t al = static_cast<uint32_t>(a), ah = static_cast<uint32_t>(a >> 32);
  const uint32_t bl = static_cast<uint32_t>(b), bh = static_cast<uint32_t>(b >> 32);
  return __umulsidi3(al, bl) + (static_cast<uint64_t>(al * bh + ah * bl) << 32);
}
