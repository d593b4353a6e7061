// Must not compile: a dense layer without outputs.
// expect: hpddo::dense: a layer needs at least one output (kOut > 0)
#include "hpddo/mlp.h"

#ifdef HPDDO_CONTROL
#define HPDDO_N_OUT 1
#else
#define HPDDO_N_OUT 0
#endif

void layer(const float* w, const float* b, const float* in, float* out) {
  hpddo::dense<3, HPDDO_N_OUT, false>(w, b, in, out);
}
