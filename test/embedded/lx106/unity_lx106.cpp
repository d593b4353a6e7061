// Unity's output on the lx106 in QEMU's sim machine (test/embedded/lx106/run_unity.py): the
// characters collected and written through the simulator's simcall at the end, which
// also ends the run with the suite's status. The suite's main() is renamed
// hpddo_suite_main (-Dmain=...), called from the benchmark start stub's lx106_main.
#include <stdint.h>

#include "../unity_output.h"
#include "lx106_io.h"

int hpddo_suite_main();  // the suite's main() (C++ linkage)
extern "C" void lx106_main();

namespace {
int g_status = 1;
}

extern "C" void hpddo_unity_putchar(int c) {
  const char s[2] = {static_cast<char>(c), 0};
  bench::put(s);
}

extern "C" void hpddo_unity_done(void) {}

extern "C" void lx106_main() {
  g_status = hpddo_suite_main();
  bench::finish(g_status);
}
