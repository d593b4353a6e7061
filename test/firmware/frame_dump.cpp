// Decodes a captured byte stream of link frames with hpddo's FrameDecoder and
// prints one CSV line per valid frame, then a summary line:
//   seq,flags,duty,v_mV,i_mA,temp_c16,rpm_x10,period_us
//   # frames=N crc_errors=E dropped_bytes=D
#include <cstdio>

#include "hpddo/frame.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s link.bin\n", argv[0]);
    return 2;
  }
  std::FILE* f = std::fopen(argv[1], "rb");
  if (!f) {
    std::perror(argv[1]);
    return 2;
  }
  hpddo::FrameDecoder dec;
  hpddo::SampleFrame fr;
  std::printf("seq,flags,duty,v_mV,i_mA,temp_c16,rpm_x10,period_us\n");
  int c;
  while ((c = std::fgetc(f)) != EOF) {
    if (dec.push(static_cast<uint8_t>(c), &fr)) {
      std::printf("%u,%u,%u,%u,%d,%d,%d,%lu\n", fr.seq, fr.flags, fr.duty, fr.v_mV, fr.i_mA, fr.temp_c16,
                  fr.rpm_x10, static_cast<unsigned long>(fr.period_us));
    }
  }
  std::fclose(f);
  std::printf("# frames=%lu crc_errors=%lu dropped_bytes=%lu\n", static_cast<unsigned long>(dec.frames()),
              static_cast<unsigned long>(dec.crc_errors()), static_cast<unsigned long>(dec.dropped_bytes()));
  return 0;
}
