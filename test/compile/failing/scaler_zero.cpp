// Must not compile: a scaler of no features.
// expect: hpddo::Scaler: standardising needs at least one feature (kN > 0)
#include "hpddo/scaler.h"

#ifdef HPDDO_CONTROL
#define HPDDO_N 1
#else
#define HPDDO_N 0
#endif

size_t scaler_size() { return sizeof(hpddo::Scaler<HPDDO_N>); }
