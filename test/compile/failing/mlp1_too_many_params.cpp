// Must not compile: Mlp<255, 255, 0> has 65536 parameters, which kParamCount
// (uint16_t) would silently wrap to 0. The control, Mlp<255, 254, 0>, has 65279.
// expect: hpddo::Mlp: more than 65535 parameters do not fit kParamCount (uint16_t)
#include "hpddo/mlp.h"

#ifdef HPDDO_CONTROL
#define HPDDO_N_H1 254
#else
#define HPDDO_N_H1 255
#endif

typedef hpddo::Mlp<255, HPDDO_N_H1, 0> Net;
uint16_t params() { return Net::kParamCount; }
