// The link's residual false-accept rate after CRC-16 and the plausibility checks
// (docs/firmware.md): N damaged frames (default 8 million) through the decoder
// with the channel limits of a model (the fixture's, 40 V, 10 A, -55..125 C).
//
//   build-core/test/core/link_false_accepts [N] [SEED]
#include <cstdio>
#include <cstdlib>

#include "link_montecarlo.h"
#include "model_tiny.h"

int main(int argc, char** argv) {
  const uint64_t n = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 8000000ull;
  const uint32_t seed = argc > 2 ? static_cast<uint32_t>(std::strtoul(argv[2], nullptr, 10)) : 20261121u;
  const linkmc::Result r = linkmc::run(n, seed, &hpddo_model_tiny::kModel.limits);
  const double d = static_cast<double>(r.damaged);
  std::printf("frames sent %llu, damaged %llu, decoded %llu\n", static_cast<unsigned long long>(r.sent),
              static_cast<unsigned long long>(r.damaged), static_cast<unsigned long long>(r.decoded));
  std::printf("CRC-valid but implausible (rejected): %llu (%.3g per damaged frame)\n",
              static_cast<unsigned long long>(r.rejected), static_cast<double>(r.rejected) / d);
  std::printf("false accepts after CRC-16 and plausibility: %llu (%.3g per damaged frame)\n",
              static_cast<unsigned long long>(r.false_accepts), static_cast<double>(r.false_accepts) / d);
  std::printf("good frames lost: %llu\n", static_cast<unsigned long long>(r.good_lost));
  return r.good_lost == 0 ? 0 : 1;
}
