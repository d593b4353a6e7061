// Must not compile: a fixed-point network without a first hidden layer.
// expect: hpddo::MlpQ: inputs and a first hidden layer are needed
#include "hpddo/mlp_q.h"

#ifdef HPDDO_CONTROL
#define HPDDO_N_H1 2
#else
#define HPDDO_N_H1 0
#endif

int32_t net(const hpddo::MlpQWeights<int16_t>& w, const int16_t (&xq)[5]) {
  return hpddo::MlpQ<5, HPDDO_N_H1, 0, int16_t, 16, 0>::forward_acc(w, xq);
}
