// The entry of a Unity suite on every target, included at the end of each suite after its
// `static int run()`: setup() on a board (PlatformIO, `pio test`; the 2 s wait lets the
// host open the port), main() on the host, in simavr and in QEMU.
#ifndef HPDDO_TEST_UNITY_MAIN_H
#define HPDDO_TEST_UNITY_MAIN_H

#ifdef ARDUINO
#include <Arduino.h>
void setup() {
  delay(2000);
  run();
}
void loop() {}
#else
int main() { return run(); }
#endif

#endif  // HPDDO_TEST_UNITY_MAIN_H
