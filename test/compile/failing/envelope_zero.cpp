// Must not compile: a training envelope of no features.
// expect: hpddo::Envelope: a training range needs at least one feature (kN > 0)
#include "hpddo/envelope.h"

#ifdef HPDDO_CONTROL
#define HPDDO_N 1
#else
#define HPDDO_N 0
#endif

size_t envelope_size() { return sizeof(hpddo::Envelope<HPDDO_N>); }
