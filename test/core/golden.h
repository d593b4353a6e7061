// Access to the golden vectors written by tools/gen_fixtures.py (numpy float32).
#ifndef HPDDO_TEST_GOLDEN_H
#define HPDDO_TEST_GOLDEN_H

#include <cmath>

#include "hpddo_core.h"

namespace golden {

/// Value of row r, column c of a golden table.
inline float at(const float* rows, int width, int r, int c) { return hpddo::flash_float(rows + r * width + c); }

/// The observer input of row r of a golden table (the columns of every table are alike).
inline hpddo::Sample sample(const float* rows, int width, int r, int col_v, int col_i, int col_temp, int col_dt,
                            int col_seq, int col_has_seq) {
  hpddo::Sample s;
  s.v_V = at(rows, width, r, col_v);
  s.i_A = at(rows, width, r, col_i);
  s.temp_C = at(rows, width, r, col_temp);
  s.dt_s = at(rows, width, r, col_dt);
  s.seq = static_cast<uint16_t>(at(rows, width, r, col_seq));
  s.has_seq = at(rows, width, r, col_has_seq) != 0.0f;
  return s;
}

/// |got - want| within 1e-4 relative to max(|want|, 1): the tolerance of every stage.
inline bool close(float got, float want) {
  if (std::isnan(want)) return std::isnan(got);
  const float scale = std::fabs(want) > 1.0f ? std::fabs(want) : 1.0f;
  return std::fabs(got - want) <= 1e-4f * scale;
}

}  // namespace golden

#endif
