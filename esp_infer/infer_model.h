// The model the inference board runs. By default the one the training
// pipeline exports to models/default/model_default.h (put that folder on the
// include path); a build may pick another with
//   -DHPDDO_MODEL_HEADER='"model_tiny.h"' -DHPDDO_MODEL_NS=hpddo_model_tiny
#ifndef HPDDO_INFER_MODEL_H
#define HPDDO_INFER_MODEL_H

#ifndef HPDDO_MODEL_HEADER
#define HPDDO_MODEL_HEADER "model_default.h"
#endif
#ifndef HPDDO_MODEL_NS
#define HPDDO_MODEL_NS hpddo_model_default
#endif

#include "hpddo/dynamics.h"
HPDDO_DYNAMICS_DEFAULT(HPDDO_MODEL_NS)  // model::kDynamics: the header's, or the family off
#include HPDDO_MODEL_HEADER

namespace infer {
namespace model = ::HPDDO_MODEL_NS;
}  // namespace infer

#endif  // HPDDO_INFER_MODEL_H
