// The function-like macros that Arduino.h defines, for compilers that have no
// Arduino core here: the core must compile after them without clashes.
#ifndef HPDDO_TEST_ARDUINO_MACROS_H
#define HPDDO_TEST_ARDUINO_MACROS_H
// Arduino.h includes these before it defines its macros.
#include <math.h>
#include <stdlib.h>
#define min(a, b) ((a) < (b) ? (a) : (b))
#define max(a, b) ((a) > (b) ? (a) : (b))
#define abs(x) ((x) > 0 ? (x) : -(x))
#define constrain(amt, low, high) ((amt) < (low) ? (low) : ((amt) > (high) ? (high) : (amt)))
#define round(x) ((x) >= 0 ? (long)((x) + 0.5) : (long)((x) - 0.5))
#define radians(deg) ((deg) * DEG_TO_RAD)
#define degrees(rad) ((rad) * RAD_TO_DEG)
#define sq(x) ((x) * (x))
#endif
