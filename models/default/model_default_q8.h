// GENERATED fixed-point model header: DO NOT EDIT. Regenerate with the command below.
// command: tools/gen_weights.py data/default/load.csv data/default/long.csv data/default/sweep.csv --name default --seed 1 --out <the folder of this file>
// seed: 1
// data: load.csv, long.csv, sweep.csv
// data_sha256: 6135cd48ac08b5160f3d9723ffd8aabe88a9e64df719dd4cdaa72b9c7e136f93
// ra_ohm: 4.5 (log metadata ra_ohm)
// ke_fit: eq20
// effects: none
// training: Adam lr=0.001 batch=200 iterations=2000, 6759 rows, chronological 80% of each recording
// rounding: data-aware, for the training rows' features (quant.quantise calibration)
// generator: hpddo.model.export 2
// quantiser: hpddo.model.quant (tools/hpddo/model/quant.py)
// shapes: 5-16-8-1
// weights: layer 0 int8 (scaler folded in), hidden int8, output int16; int32 sums
// shifts: 8 8
// checksum: crc32 0xe583b337
#ifndef HPDDO_MODEL_DEFAULT_Q8_H
#define HPDDO_MODEL_DEFAULT_Q8_H

#include <stdint.h>

#include "model_default.h"

namespace hpddo_model_default_q8 {

typedef hpddo::MlpQ<5, 16, 8, int8_t, 8, 8, int8_t> Net;

/// CRC-32 over the stored model (see hpddo::model_checksum).
static const uint32_t kChecksum = 0xe583b337u;

static const uint16_t kEffects = hpddo_model_default::kEffects;

/// Input exponents: xq_j = round(x_j 2^e_j).
HPDDO_FLASH static const int8_t kInExp[5] = {
    11, 14, 7, 14, 7};
HPDDO_FLASH static const int8_t kW0[80] = {
    3, -127, 54, -25, 97, 121, -11, 67, 95, -29, -114, -50,
    -12, -28, -20, 110, -97, 113, -10, 44, -61, 73, -110, -60,
    89, 84, -104, 113, -57, 104, -36, -36, -70, -116, -127, -83,
    9, -110, -49, 29, -27, 47, -18, 66, 123, 102, 19, 118,
    37, 31, 116, 38, 51, 76, 4, 45, -74, 76, 28, -110,
    16, -85, 110, -75, 21, 123, -36, 101, -69, 110, -99, 46,
    -58, 18, 113, 54, -64, 110, -75, 97};
HPDDO_FLASH static const int32_t kB0[16] = {
    177703, -4190638, 3857883, -2733139, 1694576, -2418503,
    6598675, 3153404, -2521274, -5091902, -4552526, 252179,
    225220, -3655236, 208743, -1831556};
HPDDO_FLASH static const int8_t kW1[128] = {
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    0, 0, 0, 0, -6, 125, 25, 84, 20, -9, 13, 24,
    26, 112, -98, -88, -5, 3, 13, -61, -1, 38, 40, 6,
    -4, 1, 8, -103, -20, 27, -116, 14, -11, 6, -3, 7,
    10, -30, -10, 29, 28, -23, 12, 0, 5, 25, -63, -116,
    -11, 9, 18, -8, 11, 118, 25, 36, 37, -37, 7, -70,
    -5, 54, -32, -50, -8, 16, 3, -21, 5, 76, 35, -26,
    35, -18, 1, -121, -2, 52, -32, -70, -2, -8, 9, 26,
    20, 29, 12, 46, 44, -40, 21, -36, -15, 66, -116, -23,
    -28, 28, 20, -34, -20, -35, 14, -87, 2, 0, 7, 0,
    32, 0, 43, 37, -118, 26, -3, -56};
HPDDO_FLASH static const int32_t kB1[8] = {
    -16777216, 33696, -1153, 801, 5141, 12125,
    14011, 22940};
HPDDO_FLASH static const int16_t kWOut[8] = {
    0, 3112, 20775, 4300, 6897, 4922, 5459, -20052};
HPDDO_FLASH static const int32_t kBOut[1] = {
    -680655};
/// RPM per unit of the output accumulator.
HPDDO_FLASH static const float kOutScale[1] = {
    1.00952377e-06f};
/// Novelty gate in integers (gate_q.h), the float gate's prototypes and thresholds.
HPDDO_FLASH static const int16_t kGateCentreQ[5] = {
    18286, 14727, 14375, 14725, 14374};
HPDDO_FLASH static const int8_t kGateShiftQ[5] = {
    15, 15, 15, 15, 15};
HPDDO_FLASH static const int16_t kGateMultQ[5] = {
    14044, 12725, 12068, 12700, 12037};
HPDDO_FLASH static const int16_t kGatePrototypesQ[160] = {
    -7837, -5670, -5332, -5659, -5317, -5890, -3773, -4381, -3761, -4037,
    -5601, -3673, -4102, -3700, -4162, -2577, -3157, -762, -3113, -764,
    -2463, -3025, -723, -3076, -501, -2427, -2919, -759, -2991, -897,
    -2295, -3039, -504, -3036, -715, -452, -2578, 1418, -2553, 1463,
    -351, -2755, 1678, -2636, 1441, -254, -2618, 1693, -2655, 1687,
    -152, 400, -494, 316, 14, -147, 257, -379, 320, -257,
    -87, 186, -250, 372, 44, -40, 456, -398, 435, -393,
    12, -79, 76, -110, 269, 78, 399, -209, 245, 207,
    94, 196, -34, 335, -270, 99, 467, -236, 266, -163,
    101, 309, -112, 495, -68, 203, -22, 268, -42, 437,
    206, 188, 110, 358, 113, 228, -130, 381, -78, 76,
    255, 243, 129, 157, -277, 270, 476, -32, 382, -427,
    276, 417, 20, 343, -86, 332, -170, 541, -137, 364,
    423, 311, 284, 329, -123, 860, -2333, 2851, -2382, 2979,
    943, -2363, 2977, -2476, 3199, 1017, -2409, 3103, -2307, 2859,
    1102, -2388, 3192, -2335, 3183, 2496, -2088, 4683, -2099, 4683};

/// The physics initialisers are positional: this header holds for one parameter layout.
static_assert(hpddo::kParamsSchema == 0x432e337eu,
              "model_default_q8.h was written for another parameter layout (tools/hpddo/schema.py): regenerate it");
static_assert(hpddo::kPhysicsParamCount == 19, "one initialiser per hpddo::PhysicsParams field");

/// The deployed fixed-point model.
static const hpddo::Model<Net> kModel = {
    {
        4.5f,           // ra_ohm [ohm]
        0.415295243f,   // ke_vs_per_rad [V s/rad]
        31.6875f,       // t_ref_C [C]
        0.0f,           // ra_tc_per_K [1/K]
        0.0f,           // ke_tc_per_K [1/K]
        0.0f,           // brush_V [V]
        0.0f,           // ke_sat_per_A [1/A]
        0.0f,           // i_offset_A [A]
        0.0f,           // v_gain [1]
        0.0f,           // la_H [H]
        0.0f,           // v_offset_V [V]
        0.0f,           // i_offset_tc_A_per_K [A/K]
        0.0199999996f,  // brush_knee_A [A]
        1.0f,           // brush_order [1]
        0.0f,           // ke_sat_quad [1]
        0.0f,           // th_r_K_per_W [K/W]
        0.0f,           // th_tau_s [s]
        31.6875f,       // t_amb_C [C]
        kEffects,       // effects
    },
    {hpddo_model_default::kScalerMean, hpddo_model_default::kScalerScale},
    {kInExp, kW0, kB0, kW1, kB1, kWOut, kBOut, kOutScale},
    {hpddo_model_default::kEnvLo, hpddo_model_default::kEnvHi},
    {kInExp, kGateCentreQ, kGateShiftQ, kGateMultQ, kGatePrototypesQ, 64266, 257065, 5.18674869e-06f, 0},
    23.7774677f,
    {40.0f, 10.0f, -55.0f, 125.0f},
};

}  // namespace hpddo_model_default_q8

#endif  // HPDDO_MODEL_DEFAULT_Q8_H
