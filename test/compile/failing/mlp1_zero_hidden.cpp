// Must not compile: one hidden layer (kH2 = 0) without a neuron.
// expect: hpddo::Mlp: the first hidden layer needs at least one neuron (kH1 > 0)
#include "hpddo/mlp.h"

#ifdef HPDDO_CONTROL
#define HPDDO_N_H1 1
#else
#define HPDDO_N_H1 0
#endif

typedef hpddo::Mlp<5, HPDDO_N_H1, 0> Net;
uint16_t params() { return Net::kParamCount; }
