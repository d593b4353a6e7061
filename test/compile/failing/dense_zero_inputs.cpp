// Must not compile: a dense layer without inputs (its output would be its bias).
// expect: hpddo::dense: a layer needs at least one input (kIn > 0)
#include "hpddo/mlp.h"

#ifdef HPDDO_CONTROL
#define HPDDO_N_IN 1
#else
#define HPDDO_N_IN 0
#endif

void layer(const float* w, const float* b, const float* in, float* out) {
  hpddo::dense<HPDDO_N_IN, 2, true>(w, b, in, out);
}
