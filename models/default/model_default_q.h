// GENERATED fixed-point model header: DO NOT EDIT. Regenerate with the command below.
// command: tools/gen_weights.py data/default/load.csv data/default/long.csv data/default/sweep.csv --name default --seed 1 --out <the folder of this file>
// seed: 1
// data: load.csv, long.csv, sweep.csv
// data_sha256: 6135cd48ac08b5160f3d9723ffd8aabe88a9e64df719dd4cdaa72b9c7e136f93
// ra_ohm: 4.5 (log metadata ra_ohm)
// ke_fit: eq20
// effects: none
// training: Adam lr=0.001 batch=200 iterations=2000, 6759 rows, chronological 80% of each recording
// generator: hpddo.model.export 2
// quantiser: hpddo.model.quant (tools/hpddo/model/quant.py)
// shapes: 5-16-8-1
// weights: layer 0 int16 (scaler folded in), hidden int16, output int16; int32 sums
// shifts: 16 16
// checksum: crc32 0x20ae203c
#ifndef HPDDO_MODEL_DEFAULT_Q_H
#define HPDDO_MODEL_DEFAULT_Q_H

#include <stdint.h>

#include "model_default.h"

namespace hpddo_model_default_q {

typedef hpddo::MlpQ<5, 16, 8, int16_t, 16, 16> Net;

/// CRC-32 over the stored model (see hpddo::model_checksum).
static const uint32_t kChecksum = 0x20ae203cu;

static const uint16_t kEffects = hpddo_model_default::kEffects;

/// Input exponents: xq_j = round(x_j 2^e_j).
HPDDO_FLASH static const int8_t kInExp[5] = {
    11, 14, 7, 14, 7};
HPDDO_FLASH static const int16_t kW0[80] = {
    568, -26740, 11349, -5236, 20506, 17646, -1546, 9750, 13742, -4243, -21964, -9530,
    -2263, -5372, -3820, 15817, -13877, 16171, -1483, 6251, -8996, 10729, -16229, -8821,
    13122, 10325, -12752, 13794, -6936, 12695, -4023, -4073, -7826, -12917, -14190, -14410,
    1592, -19167, -8606, 4963, -4886, 8637, -3374, 12007, 22553, 14406, 2723, 16682,
    5258, 4447, 17958, 5920, 7924, 11697, 557, 8660, -14215, 14657, 5352, -21177,
    3493, -17729, 22861, -15712, 4288, 14658, -4278, 11951, -8233, 13143, -19087, 8852,
    -11136, 3500, 21739, 7802, -9181, 15790, -10818, 13918};
HPDDO_FLASH static const int32_t kB0[16] = {
    37277012, -609770716, 740113509, -391167013, 250327821, -296034451,
    737482563, 550428071, -461346590, -721530849, -703844586, 48314805,
    47613262, -434925528, 40025375, -263040746};
HPDDO_FLASH static const int16_t kW1[128] = {
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    0, 0, 0, 0, -390, 12145, 1813, 8312, 1933, -1096, 1690, 1908,
    2041, 11136, -8923, -6416, -317, 372, 994, -5998, -134, 6767, 5470, 969,
    -803, 241, 1900, -15423, -2725, 5008, -19586, 1908, -1425, 1396, -471, 1307,
    1297, -5422, -1291, 5386, 4991, -4918, 2744, 16, 704, 4667, -10709, -15912,
    -1429, 1956, 2547, -1543, 1043, 15269, 2499, 4743, 4735, -5776, 1160, -7585,
    -489, 7191, -3824, -4927, -759, 2534, 248, -2744, 516, 10473, 3662, -3680,
    4794, -2939, 270, -14109, -113, 7449, -4185, -7361, -162, -1376, 857, 3563,
    1615, 3433, 1096, 5475, 5081, -5590, 3263, -3604, -1323, 7992, -12887, -1984,
    -2297, 4061, 1736, -4072, -2157, -5441, 1653, -13476, 292, 0, 1407, -16,
    4008, 0, 6213, 4186, -12624, 4835, -461, -8707};
HPDDO_FLASH static const int32_t kB1[8] = {
    -16777216, 1732946, -105098, 162110, 356325, 831838,
    889657, 1973409};
HPDDO_FLASH static const int16_t kWOut[8] = {
    0, 4804, 17368, 3550, 7978, 5289, 6936, -19606};
HPDDO_FLASH static const int32_t kBOut[1] = {
    -226512};
/// RPM per unit of the output accumulator.
HPDDO_FLASH static const float kOutScale[1] = {
    3.03355637e-06f};
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
              "model_default_q.h was written for another parameter layout (tools/hpddo/schema.py): regenerate it");
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

}  // namespace hpddo_model_default_q

#endif  // HPDDO_MODEL_DEFAULT_Q_H
