// Must not compile: a shift above 16 after a hidden layer (quant.py never writes one).
// expect: hpddo::MlpQ: a shift above 16 would leave no room for the rounding (quant.py)
#include "hpddo/mlp_q.h"

#ifdef HPDDO_CONTROL
#define HPDDO_SHIFT 16
#else
#define HPDDO_SHIFT 17
#endif

int32_t net(const hpddo::MlpQWeights<int16_t>& w, const int16_t (&xq)[5]) {
  return hpddo::MlpQ<5, 4, 3, int16_t, HPDDO_SHIFT, 16>::forward_acc(w, xq);
}
