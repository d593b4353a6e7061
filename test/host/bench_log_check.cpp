// Reads bench logs with host/bench_log.h and prints what it read, in a form the
// differential test (test/py/test_conformance.py) parses:
//   FILE <path>
//   FAULT <line> <keyword>                       for a refused file, or
//   OK <rows> <has_rpm_ref> <has_temp_C> <has_load> <has_seq>
//   M <key>=<value>                              one per metadata entry
//   R <line> <t_s> <duty> <v_V> <i_A> <rpm_ref> <temp_C> <load> <seq>   one per row
// Numbers are printed with 17 significant digits, so they read back to the same doubles.
#include <cstdio>
#include <string>

#include "bench_log.h"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_log_check LOG...\n");
    return 2;
  }
  for (int a = 1; a < argc; ++a) {
    std::printf("FILE %s\n", argv[a]);
    try {
      const hpddo_host::BenchLog log = hpddo_host::read_bench_log(argv[a]);
      std::printf("OK %zu %d %d %d %d\n", log.size(), log.has_rpm_ref, log.has_temp_C, log.has_load, log.has_seq);
      for (const auto& kv : log.meta) {  // values are any text, NUL included: written whole
        const std::string line = "M " + kv.first + "=" + kv.second + "\n";
        std::fwrite(line.data(), 1, line.size(), stdout);
      }
      for (size_t k = 0; k < log.size(); ++k)
        std::printf("R %zu %.17g %.17g %.17g %.17g %.17g %.17g %lld %lld\n", log.lines[k], log.t_s[k], log.duty[k],
                    log.v_V[k], log.i_A[k], log.rpm_ref[k], log.temp_C[k], static_cast<long long>(log.load[k]),
                    static_cast<long long>(log.seq[k]));
    } catch (const hpddo_host::LogError& e) {
      std::printf("FAULT %zu %s\n", e.line(), e.fault().c_str());
    }
  }
  return 0;
}
