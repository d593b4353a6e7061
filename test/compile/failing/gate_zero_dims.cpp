// Must not compile: a novelty gate over no input dimension.
// expect: hpddo::Gate: a gate needs at least one input dimension (kDims > 0)
#include "hpddo/gate.h"

#ifdef HPDDO_CONTROL
#define HPDDO_N 1
#else
#define HPDDO_N 0
#endif

size_t gate_size() { return sizeof(hpddo::Gate<HPDDO_N, 4>); }
