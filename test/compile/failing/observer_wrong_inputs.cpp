// Must not compile: an observer over a network that does not take the five
// residual features [v, i, n_M2, i(t-1), n_M2(t-1)].
// expect: hpddo::Observer: the network must take the kFeatureCount residual features (Mlp<5, H1, H2>)
#include "hpddo/observer.h"

#ifdef HPDDO_CONTROL
#define HPDDO_N_IN 5
#else
#define HPDDO_N_IN 4
#endif

size_t observer_size() { return sizeof(hpddo::Observer<hpddo::Mlp<HPDDO_N_IN, 3, 0> >); }
