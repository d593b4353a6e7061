// Must not compile: an integer gate without prototypes.
// expect: hpddo::GateQ: a gate needs at least one prototype (kProtos > 0)
#include "hpddo/gate_q.h"

#ifdef HPDDO_CONTROL
#define HPDDO_PROTOS 1
#else
#define HPDDO_PROTOS 0
#endif

float weigh(const hpddo::GateQ<5, HPDDO_PROTOS>& gate, const float (&g)[5]) { return gate.weight(g); }
