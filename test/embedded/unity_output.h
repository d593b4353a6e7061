/* Unity's output where the suites run without an Arduino core (test/embedded/CMakeLists.txt):
 * on the ATmega328P in simavr (avr/unity_avr.c) and on the lx106 in QEMU
 * (lx106/unity_lx106.cpp). Forced into every translation unit with -include, named by
 * UNITY_OUTPUT_CHAR and UNITY_OUTPUT_COMPLETE. Not used by PlatformIO, whose Unity writes to
 * the Arduino Serial. */
#ifndef HPDDO_UNITY_OUTPUT_H
#define HPDDO_UNITY_OUTPUT_H
#ifdef __cplusplus
extern "C" {
#endif
void hpddo_unity_putchar(int c);
void hpddo_unity_done(void);
#ifdef __cplusplus
}
#endif
#endif
