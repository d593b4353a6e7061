// Must not compile: an integer gate over more inputs than its int32 sum holds.
// expect: hpddo::GateQ: 1 to 5 inputs (the int32 sum holds 5 squares)
#include "hpddo/gate_q.h"

#ifdef HPDDO_CONTROL
#define HPDDO_DIMS 5
#else
#define HPDDO_DIMS 6
#endif

float weigh(const hpddo::GateQ<HPDDO_DIMS, 2>& gate, const float (&g)[HPDDO_DIMS]) { return gate.weight(g); }
