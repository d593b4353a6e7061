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
// checksum: crc32 0x71a88aca
#ifndef HPDDO_MODEL_DEFAULT_Q_H
#define HPDDO_MODEL_DEFAULT_Q_H

#include <stdint.h>

#include "model_default.h"

namespace hpddo_model_default_q {

typedef hpddo::MlpQ<5, 16, 8, int16_t, 16, 16> Net;

/// CRC-32 over the stored model (see hpddo::model_checksum).
static const uint32_t kChecksum = 0x71a88acau;

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
    -5697, -3652, -4235, -5656, -5319, -7837, -5670, -5332, -5659, -5317,
    -5601, -3673, -4102, -3700, -4162, -2676, -2912, -1072, -3734, -4011,
    -2674, -3084, -939, -2906, -1069, -2378, -3227, -463, -3002, -941,
    -2632, -3009, -944, -3154, -609, -387, -2528, 1460, -3136, -603,
    -2318, -3058, -518, -3220, -462, 191, 213, 72, 454, -408,
    -40, 456, -398, 435, -393, 1092, -2324, 3131, 357, -233,
    161, 470, -162, 428, -66, 437, 429, 211, 374, -9,
    333, -19, 425, -50, 37, 202, 380, -42, -95, 57,
    -18, -118, 69, -126, 140, -67, 274, -293, 216, 169,
    933, -2260, 2885, -155, 337, 403, -170, 628, -220, 470,
    -360, -2666, 1599, -2578, 1298, -2400, -3160, -541, -2639, 1537,
    977, -2324, 2988, -2696, 1625, -301, -2613, 1631, -2599, 1790,
    1186, -2410, 3313, -2391, 2884, 32, 404, -270, -2378, 3010,
    2493, -2052, 4651, -2388, 3019, -346, -2722, 1660, -2379, 3041,
    125, -142, 263, -2362, 3045, 870, -2377, 2897, -2345, 3147,
    1075, -2415, 3179, -2058, 4652, 2496, -2088, 4683, -2099, 4683};

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
    {kInExp, kGateCentreQ, kGateShiftQ, kGateMultQ, kGatePrototypesQ, 131949, 527797, 2.52622226e-06f, 4},
    23.7774677f,
    {40.0f, 10.0f, -55.0f, 125.0f},
};

}  // namespace hpddo_model_default_q

#endif  // HPDDO_MODEL_DEFAULT_Q_H
