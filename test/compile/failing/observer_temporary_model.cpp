// Must not compile: an observer keeps a reference to its model, so a temporary
// Model (destroyed at the end of the statement) would leave it dangling.
// expect: use of deleted function
#include "model_tiny.h"

float first_estimate(const hpddo::Sample& s) {
#ifdef HPDDO_CONTROL
  hpddo::Observer<hpddo_model_tiny::Net> obs(hpddo_model_tiny::kModel);
#else
  hpddo::Observer<hpddo_model_tiny::Net> obs(hpddo::Model<hpddo_model_tiny::Net>(hpddo_model_tiny::kModel));
#endif
  return obs.step(s).rpm;
}
