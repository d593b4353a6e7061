// Must not compile: a network without inputs.
// expect: hpddo::Mlp: the network needs at least one input (kIn > 0)
#include "hpddo/mlp.h"

#ifdef HPDDO_CONTROL
#define HPDDO_N_IN 1
#else
#define HPDDO_N_IN 0
#endif

typedef hpddo::Mlp<HPDDO_N_IN, 4, 3> Net;
uint16_t params() { return Net::kParamCount; }
