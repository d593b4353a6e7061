// Must not compile: a novelty gate without a prototype.
// expect: hpddo::Gate: a gate needs at least one prototype (kProtos > 0)
#include "hpddo/gate.h"

#ifdef HPDDO_CONTROL
#define HPDDO_N 1
#else
#define HPDDO_N 0
#endif

size_t gate_size() { return sizeof(hpddo::Gate<6, HPDDO_N>); }
