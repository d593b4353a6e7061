// Fixed-point form of the residual network (tools/hpddo/model/quant.py quantises a float
// model and computes the golden vectors, in Python integers): the scaler is folded
// into the first layer, every sum is int32, one float multiply at the end.
//
//   xq_j  = sat16(round(x_j 2^e_j))                    half away from zero; NaN -> 0
//   acc_o = B_o + sum_j W_oj h_j                       int32, cannot overflow (quant.py)
//   h_o   = min((max(acc_o, 0) + 2^(R-1)) >> R, 32767) hidden layers, shift R per layer
//   y     = float(acc_out) * out_scale                 RPM
//
// Layer 0's weights are W0 and the hidden layer's WH (int16_t or int8_t: the int16 model
// and the int8 one, model_<name>_q.h and model_<name>_q8.h); the output layer's are int16.
// Weights W[out][in] row-major, biases int32, all in flash. The type carries the shifts
// (template arguments), so they compile to byte moves.
#ifndef HPDDO_MLP_Q_H
#define HPDDO_MLP_Q_H

#include <stdint.h>

#include "crc.h"
#include "platform.h"
#include "scaler.h"

namespace hpddo {

/// Pointers to the flash arrays of one fixed-point network.
template <class WH, class W0 = int16_t>
struct MlpQWeights {
  const int8_t* in_exp;    ///< kIn input exponents e_j
  const W0* w0;            ///< kH1 x kIn, scaler folded in
  const int32_t* b0;       ///< kH1
  const WH* w1;            ///< kH2 x kH1 (unused when kH2 == 0)
  const int32_t* b1;       ///< kH2 (unused when kH2 == 0)
  const int16_t* w_out;    ///< 1 x (kH2 ? kH2 : kH1)
  const int32_t* b_out;    ///< 1
  const float* out_scale;  ///< 1: RPM per unit of the output accumulator
};

namespace detail {

template <class T>
inline int32_t flash_weight(const T* p);
template <>
inline int32_t flash_weight<int16_t>(const int16_t* p) { return flash_int16(p); }
template <>
inline int32_t flash_weight<int8_t>(const int8_t* p) { return flash_int8(p); }

#if defined(__AVR__) && defined(__AVR_HAVE_MUL__)
// After a MULS or MULSU (the signed 16-bit product in r1:r0, its sign in the carry), the
// product added into the 32-bit accumulator %[acc], the carry subtracted from the bytes above
// it first (the sign extension); %[z] holds zero. _BCD: the product of a high byte, at bytes
// B..D; _ABCD: of a low byte, at bytes A..D.
#define HPDDO_AVR_ADD_PRODUCT_BCD \
  "sbc   %D[acc], %[z] \n\t"      \
  "add   %B[acc], r0   \n\t"      \
  "adc   %C[acc], r1   \n\t"      \
  "adc   %D[acc], %[z] \n\t"
#define HPDDO_AVR_ADD_PRODUCT_ABCD \
  "sbc   %C[acc], %[z] \n\t"       \
  "sbc   %D[acc], %[z] \n\t"       \
  "add   %A[acc], r0   \n\t"       \
  "adc   %B[acc], r1   \n\t"       \
  "adc   %C[acc], %[z] \n\t"       \
  "adc   %D[acc], %[z] \n\t"
#endif

/// acc + a b, a and b int16, exactly (the sum cannot overflow: quant.py's bounds).
__attribute__((always_inline)) inline int32_t mac16(int32_t acc, int16_t a, int16_t b) {
#if defined(__AVR__) && defined(__AVR_HAVE_MUL__)
  // The four 8x8 products of AVR201 added into acc in place: about 20 cycles instead of
  // a call to __mulhisi3 and a 32-bit add. r1 (the zero register) is restored.
  uint8_t zero;
  __asm__(
      "clr   %[z]          \n\t"
      "muls  %B[a], %B[b]  \n\t"
      "add   %C[acc], r0   \n\t"
      "adc   %D[acc], r1   \n\t"
      "mul   %A[a], %A[b]  \n\t"
      "add   %A[acc], r0   \n\t"
      "adc   %B[acc], r1   \n\t"
      "adc   %C[acc], %[z] \n\t"
      "adc   %D[acc], %[z] \n\t"
      "mulsu %B[a], %A[b]  \n\t"
      HPDDO_AVR_ADD_PRODUCT_BCD
      "mulsu %B[b], %A[a]  \n\t"
      HPDDO_AVR_ADD_PRODUCT_BCD
      "clr   r1            \n\t"
      : [acc] "+r"(acc), [z] "=&r"(zero)
      : [a] "a"(a), [b] "a"(b)
      : "r0");
  return acc;
#else
  return acc + static_cast<int32_t>(a) * static_cast<int32_t>(b);
#endif
}

/// acc + w a, w int8 and a int16, exactly: two 8x8 products (w times a's high byte,
/// signed; w times a's low byte, signed by unsigned) added into acc in place, about 14
/// cycles on the AVR instead of mac16's 20. The carry after MULS/MULSU is the product's
/// sign: subtracting it from the bytes above is the sign extension.
__attribute__((always_inline)) inline int32_t mac8(int32_t acc, int8_t w, int16_t a) {
#if defined(__AVR__) && defined(__AVR_HAVE_MUL__)
  uint8_t zero;
  __asm__(
      "clr   %[z]          \n\t"
      "muls  %[w], %B[a]   \n\t"
      HPDDO_AVR_ADD_PRODUCT_BCD
      "mulsu %[w], %A[a]   \n\t"
      HPDDO_AVR_ADD_PRODUCT_ABCD
      "clr   r1            \n\t"
      : [acc] "+r"(acc), [z] "=&r"(zero)
      : [w] "a"(w), [a] "a"(a)
      : "r0");
  return acc;
#else
  return acc + static_cast<int32_t>(w) * static_cast<int32_t>(a);
#endif
}

/// acc_o = B_o + sum_k W_ok in_k for one row, int32.
template <uint8_t kIn, class W>
struct Dot {
  static int32_t run(const W* row, int32_t bias, const int16_t* in) {
    int32_t acc = bias;
    for (uint8_t k = 0; k < kIn; ++k) acc = mac16(acc, static_cast<int16_t>(flash_weight<W>(row + k)), in[k]);
    return acc;
  }
};
#if defined(__AVR__) && defined(__AVR_HAVE_MUL__) && !defined(HPDDO_FLASH_FAKE_ACTIVE)
/// int16 weights on the AVR: the row read with LPM Z+ (post-increment), no address
/// arithmetic per weight; about 35 cycles a weight. kSkipZero: a zero input skips its
/// weight (2 cycles instead of about 35; the sum is the same).
template <uint8_t kIn, bool kSkipZero>
inline int32_t dot_lpm16(const int16_t* row, int32_t bias, const int16_t* in) {
  int32_t acc = bias;
  const int16_t* p = row;
  for (uint8_t k = 0; k < kIn; ++k) {
    const int16_t v = in[k];
    if (kSkipZero && v == 0) {
      ++p;
      continue;
    }
    int16_t w;
    __asm__ __volatile__("lpm %A0, Z+\n\tlpm %B0, Z+" : "=r"(w), "+z"(p));
    acc = mac16(acc, w, v);
  }
  return acc;
}
template <uint8_t kIn>
struct Dot<kIn, int16_t> {
  static int32_t run(const int16_t* row, int32_t bias, const int16_t* in) { return dot_lpm16<kIn, false>(row, bias, in); }
};
/// int8 weights on the AVR: the whole row in assembly, unrolled (.rept kIn: no loop
/// count): the weight read with LPM Z+, the input with LD X+, mac8's two products and
/// adds; about 20 cycles a weight, against 33 where the compiler shuffles the pointers
/// through Z around mac8. kSkipZero: a zero input skips its products (11 cycles; the sum
/// is the same).
template <uint8_t kIn, bool kSkipZero>
inline int32_t dot_lpm8(const int8_t* row, int32_t bias, const int16_t* in) {
  int32_t acc = bias;
  const int8_t* p = row;
  const int16_t* x = in;
  uint8_t zero, w, lo, hi, t;
  __asm__ __volatile__(
      "clr   %[z]          \n\t"
      ".rept %[n]          \n\t"
      "lpm   %[w], Z+      \n\t"
      "ld    %[lo], X+     \n\t"
      "ld    %[hi], X+     \n\t"
      ".if %[skip]         \n\t"
      "mov   %[t], %[lo]   \n\t"
      "or    %[t], %[hi]   \n\t"
      "breq  2f            \n\t"
      ".endif              \n\t"
      "muls  %[w], %[hi]   \n\t"
      HPDDO_AVR_ADD_PRODUCT_BCD
      "mulsu %[w], %[lo]   \n\t"
      HPDDO_AVR_ADD_PRODUCT_ABCD
      "2:                  \n\t"
      ".endr               \n\t"
      "clr   r1            \n\t"
      : [acc] "+r"(acc), [z] "=&r"(zero), [w] "=&a"(w), [lo] "=&a"(lo), [hi] "=&d"(hi), [t] "=&r"(t),
        "+z"(p), "+x"(x)
      : [skip] "n"(kSkipZero ? 1 : 0), [n] "n"(kIn)
      : "r0", "memory");
  return acc;
}
template <uint8_t kIn>
struct Dot<kIn, int8_t> {
  static int32_t run(const int8_t* row, int32_t bias, const int16_t* in) { return dot_lpm8<kIn, false>(row, bias, in); }
};
#endif
template <uint8_t kIn, class W>
__attribute__((always_inline)) inline int32_t dot_q(const W* row, int32_t bias, const int16_t* in) {
  return Dot<kIn, W>::run(row, bias, in);
}

/// The same over the outputs of a ReLU layer, where about half the inputs are 0: on the
/// AVR a zero input skips its weight (dot_lpm16), elsewhere (a branch that mispredicts
/// costs more than the multiply) the plain dot.
template <uint8_t kIn, class W>
struct DotRelu {
  static int32_t run(const W* row, int32_t bias, const int16_t* in) { return Dot<kIn, W>::run(row, bias, in); }
};
#if defined(__AVR__) && defined(__AVR_HAVE_MUL__) && !defined(HPDDO_FLASH_FAKE_ACTIVE)
template <uint8_t kIn>
struct DotRelu<kIn, int16_t> {
  static int32_t run(const int16_t* row, int32_t bias, const int16_t* in) { return dot_lpm16<kIn, true>(row, bias, in); }
};
template <uint8_t kIn>
struct DotRelu<kIn, int8_t> {
  static int32_t run(const int8_t* row, int32_t bias, const int16_t* in) { return dot_lpm8<kIn, true>(row, bias, in); }
};
#endif
template <uint8_t kIn, class W>
__attribute__((always_inline)) inline int32_t dot_relu_q(const W* row, int32_t bias, const int16_t* in) {
  return DotRelu<kIn, W>::run(row, bias, in);
}

/// A hidden layer: h_o = min((max(acc_o, 0) + 2^(kR-1)) >> kR, 32767); kRelu: its
/// inputs are the outputs of a ReLU layer (dot_relu_q).
template <uint8_t kIn, uint8_t kOut, uint8_t kR, class W, bool kRelu>
inline void dense_q(const W* w, const int32_t* b, const int16_t* in, int16_t* out) {
  static_assert(kR <= 16, "hpddo::MlpQ: a shift above 16 would leave no room for the rounding (quant.py)");
  for (uint8_t o = 0; o < kOut; ++o) {
    const W* row = w + static_cast<uint16_t>(o) * kIn;
    int32_t acc = kRelu ? dot_relu_q<kIn, W>(row, flash_int32(b + o), in) : dot_q<kIn, W>(row, flash_int32(b + o), in);
    if (acc < 0) acc = 0;
    if (kR > 0) acc = (acc + (static_cast<int32_t>(1) << (kR > 0 ? kR - 1 : 0))) >> kR;
    out[o] = static_cast<int16_t>(acc > 32767 ? 32767 : acc);
  }
}

/// t >> s (0 <= s < 32; arithmetic for a signed T) as whole-byte moves first: on the AVR
/// a shift by a variable count is a loop of one bit a turn.
template <class T>
inline T shift_right(T t, uint8_t s) {
  if (s >= 16) {
    t >>= 16;
    s = static_cast<uint8_t>(s - 16);
  }
  if (s >= 8) {
    t >>= 8;
    s = static_cast<uint8_t>(s - 8);
  }
  return t >> s;
}

/// sat16(round(x 2^e)), halves away from zero, NaN -> 0: from the bits of x, no libm.
inline int16_t quantise_input(float x, int8_t e) {
  uint32_t u = 0;
  __builtin_memcpy(&u, &x, sizeof u);
  const bool negative = (u >> 31) != 0;
  // The exponent from the top two bytes (a shift by 23 is a loop of 23 turns on the AVR).
  const uint8_t top = static_cast<uint8_t>(u >> 24);
  const uint8_t next = static_cast<uint8_t>(u >> 16);
  const int16_t biased = static_cast<int16_t>(static_cast<uint8_t>((top << 1) | (next >> 7)));
  const uint32_t frac = u & 0x7FFFFFu;
  if (biased == 0xFF && frac != 0) return 0;  // NaN
  if (biased == 0) return 0;                  // zero or subnormal: below 2^-126 2^60, rounds to 0
  // |x| 2^e = mant 2^sh with mant = 1.frac in 24 bits.
  const int16_t sh = static_cast<int16_t>(biased - 150 + e);
  uint32_t mag;
  if (sh >= 0) {
    mag = 32767u;  // mant >= 2^23: beyond int16 (an infinity too)
  } else if (sh < -24) {
    mag = 0u;      // below 1/2
  } else {
    const uint32_t mant = frac | 0x800000u;
    mag = (shift_right(mant, static_cast<uint8_t>(-sh - 1)) + 1u) >> 1;  // floor(2 v) then halves up
    if (mag > 32767u) mag = 32767u;
  }
  const int16_t m = static_cast<int16_t>(mag);
  return negative ? static_cast<int16_t>(-m) : m;
}

inline uint32_t crc_flash_bytes(uint32_t crc, const void* p, uint16_t n) {
  const uint8_t* b = static_cast<const uint8_t*>(p);
  for (uint16_t k = 0; k < n; ++k) {
    const uint8_t v = flash_uint8(b + k);
    crc = crc32_update(crc, &v, 1);
  }
  return crc;
}

}  // namespace detail

/// Fixed-point kIn -> kH1 (ReLU) -> kH2 (ReLU) -> 1 network; kH2 == 0: one hidden layer.
/// WH is the hidden layer's weight type, W0 layer 0's; kR0, kR1 the shifts after layers 0 and 1.
template <uint8_t kIn, uint8_t kH1, uint8_t kH2, class WH, uint8_t kR0, uint8_t kR1, class W0 = int16_t>
struct MlpQ {
  static_assert(kIn > 0 && kH1 > 0, "hpddo::MlpQ: inputs and a first hidden layer are needed");
  static const uint8_t kInputs = kIn;
  static const uint8_t kHidden1 = kH1;
  static const uint8_t kHidden2 = kH2;
  static const uint8_t kLast = kH2 ? kH2 : kH1;
  typedef MlpQWeights<WH, W0> Weights;

  /// The output accumulator for quantised inputs xq (int32; residual = it x out_scale).
  static int32_t forward_acc(const Weights& w, const int16_t (&xq)[kIn]) {
    int16_t h1[kH1];
    int16_t h2[kH2 ? kH2 : 1];
    detail::dense_q<kIn, kH1, kR0, W0, false>(w.w0, w.b0, xq, h1);
    const int16_t* last = h1;
    if (kH2) {
      detail::dense_q<kH1, (kH2 ? kH2 : 1), kR1, WH, true>(w.w1, w.b1, h1, h2);
      last = h2;
    }
    return detail::dot_relu_q<kLast, int16_t>(w.w_out, flash_int32(w.b_out), last);
  }

  /// The quantised inputs of the raw features x (their own units; the scaler is folded in).
  static void quantise(const Weights& w, const float (&x)[kIn], int16_t (&xq)[kIn]) {
    for (uint8_t j = 0; j < kIn; ++j) xq[j] = detail::quantise_input(x[j], flash_int8(w.in_exp + j));
  }

  /// Network output for inputs already quantised (quantise()), RPM.
  static float forward_q(const Weights& w, const int16_t (&xq)[kIn]) {
    return static_cast<float>(forward_acc(w, xq)) * flash_float(w.out_scale);
  }

  /// Network output for the raw features x, RPM.
  static float forward_raw(const Weights& w, const float (&x)[kIn]) {
    int16_t xq[kIn];
    quantise(w, x, xq);
    return forward_q(w, xq);
  }

  /// The observer's residual for features x, RPM: the scaler is folded into layer 0.
  template <class Scaler>
  static float residual(const Scaler&, const Weights& w, const float (&x)[kIn]) {
    return forward_raw(w, x);
  }

  /// CRC-32 update over the stored network, in quant.weight_bytes()'s order.
  static uint32_t crc_weights(uint32_t crc, const Weights& w) {
    crc = detail::crc_flash_bytes(crc, w.in_exp, kIn);
    crc = detail::crc_flash_bytes(crc, w.w0, static_cast<uint16_t>(sizeof(W0) * kIn * kH1));
    crc = detail::crc_flash_bytes(crc, w.b0, static_cast<uint16_t>(4u * kH1));
    if (kH2) {
      crc = detail::crc_flash_bytes(crc, w.w1, static_cast<uint16_t>(sizeof(WH) * kH1 * kH2));
      crc = detail::crc_flash_bytes(crc, w.b1, static_cast<uint16_t>(4u * kH2));
    }
    crc = detail::crc_flash_bytes(crc, w.w_out, static_cast<uint16_t>(2u * kLast));
    crc = detail::crc_flash_bytes(crc, w.b_out, 4u);
    crc = detail::crc_flash_bytes(crc, w.out_scale, 4u);
    return crc;
  }
};

}  // namespace hpddo

#endif  // HPDDO_MLP_Q_H
