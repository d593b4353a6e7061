// Must not compile: Mlp<255, 255, 255> has 130816 parameters, which kParamCount
// (uint16_t) would silently wrap to 65280.
// expect: hpddo::Mlp: more than 65535 parameters do not fit kParamCount (uint16_t)
#include "hpddo/mlp.h"

#ifdef HPDDO_CONTROL
#define HPDDO_N_IN 5  // the control, Mlp<5, 255, 200>, has 52931
#define HPDDO_N_H2 200
#else
#define HPDDO_N_IN 255
#define HPDDO_N_H2 255
#endif

typedef hpddo::Mlp<HPDDO_N_IN, 255, HPDDO_N_H2> Net;
uint16_t params() { return Net::kParamCount; }
