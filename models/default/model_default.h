// GENERATED model header: DO NOT EDIT. Regenerate with the command below.
// command: tools/gen_weights.py data/default/load.csv data/default/long.csv data/default/sweep.csv --name default --seed 1 --out <the folder of this file>
// seed: 1
// data: load.csv, long.csv, sweep.csv
// data_sha256: 6135cd48ac08b5160f3d9723ffd8aabe88a9e64df719dd4cdaa72b9c7e136f93
// ra_ohm: 4.5 (log metadata ra_ohm)
// ke_fit: eq20
// effects: none
// training: Adam lr=0.001 batch=200 iterations=2000, 6759 rows, chronological 80% of each recording
// generator: hpddo.model.export 2
// shapes: 5-16-8-1
// checksum: crc32 0x60e31fc0
// parameter_layout: crc32 0x432e337e (hpddo::kParamsSchema, hpddo.schema 1)
#ifndef HPDDO_MODEL_DEFAULT_H
#define HPDDO_MODEL_DEFAULT_H

#include <stdint.h>

#include "hpddo_core.h"

namespace hpddo_model_default {

typedef hpddo::Mlp<5, 16, 8> Net;

/// CRC-32 over the stored floats (see hpddo::model_checksum).
static const uint32_t kChecksum = 0x60e31fc0u;

/// Effects in the physics model: none (kModel.physics.effects).
static const uint16_t kEffects = 0x0000u;

HPDDO_FLASH static const float kScalerMean[5] = {
    8.92886639f, 0.898876548f, 112.300865f, 0.898771822f, 112.295921f};
HPDDO_FLASH static const float kScalerScale[5] = {
    1.16664481f, 0.160939991f, 21.7214413f, 0.161255181f, 21.7784653f};
HPDDO_FLASH static const float kW0[80] = {
    0.0153502645f, -0.797592402f, 0.356934994f, -0.156475812f, 0.646635473f, 0.985815048f,
    -0.0953454375f, 0.633842289f, 0.848893166f, -0.276547819f, -1.07558191f, -0.515054822f,
    -0.128980488f, -0.290924072f, -0.218243018f, 0.994276464f, -0.96268189f, 1.18293357f,
    -0.103052244f, 0.45843491f, -0.317713976f, 0.418180168f, -0.666988552f, -0.344496846f,
    0.54069829f, 0.499851018f, -0.681319892f, 0.777114153f, -0.371299982f, 0.717104018f,
    -0.11246714f, -0.125651658f, -0.254594088f, -0.399287015f, -0.462821275f, -0.863016784f,
    0.10524594f, -1.33581233f, -0.569939673f, 0.34679243f, -0.176915094f, 0.345147073f,
    -0.142179966f, 0.480755806f, 0.952803671f, 0.712479174f, 0.148619711f, 0.960045218f,
    0.287525028f, 0.25656876f, 1.52913427f, 0.556287527f, 0.785148442f, 1.10129118f,
    0.0553822517f, 0.402871579f, -0.729778588f, 0.793441951f, 0.275303781f, -1.14940274f,
    0.14607735f, -0.818140745f, 1.11239111f, -0.726494312f, 0.20922111f, 0.738100111f,
    -0.237735316f, 0.700295866f, -0.458388537f, 0.772149503f, -0.412251055f, 0.211008132f,
    -0.279904723f, 0.0835965872f, 0.547835946f, 0.490596861f, -0.637163758f, 1.15543449f,
    -0.752259076f, 1.02117157f};
HPDDO_FLASH static const float kB0[16] = {
    0.391940683f, -0.662607133f, 0.647252262f, -0.153263465f, 1.02377808f, -0.332341552f,
    1.13778079f, -0.514916837f, 0.439349145f, -0.762885034f, 0.209734321f, -0.341976911f,
    0.16255416f, 0.202422693f, 0.228806004f, 0.319388717f};
HPDDO_FLASH static const float kW1[128] = {
    0.0f, 0.0f, 0.0f, -0.0f, -0.0f, -0.0f,
    0.0f, -0.0f, 0.0f, 0.0f, 0.0f, 0.0f,
    -0.0f, 0.0f, -0.0f, -0.0f, -0.0992353633f, 1.49448931f,
    0.254556596f, 0.909029305f, 0.376182914f, -0.155661672f, 0.415520996f, 0.219026521f,
    0.387453586f, 1.54794025f, -0.720451117f, -0.948108494f, -0.0520779528f, 0.0508295f,
    0.316411346f, -0.655730724f, -0.0640745088f, 1.56883156f, 1.44648933f, 0.199721351f,
    -0.294429868f, 0.064576067f, 0.880391181f, -3.33526897f, -0.974545658f, 1.31132126f,
    -2.97893763f, 0.531199574f, -0.441435993f, 0.359128207f, -0.282311201f, 0.269118547f,
    0.272831827f, -0.551944792f, -0.149962798f, 0.487252742f, 0.803542018f, -0.577634096f,
    0.558205307f, 0.00150287873f, 0.110575736f, 0.536605477f, -0.71514976f, -1.94512558f,
    -0.194279179f, 0.220902264f, 0.670538068f, -0.139533922f, 0.350084841f, 2.48029232f,
    0.463130683f, 0.684649169f, 1.21668983f, -1.08276653f, 0.376644909f, -1.14929402f,
    -0.122474097f, 1.31946838f, -0.407574058f, -0.961234987f, -0.164702088f, 0.456693172f,
    0.10405945f, -0.395949602f, 0.147669584f, 1.45007372f, 0.578402102f, -0.452871621f,
    1.04992497f, -0.469536275f, 0.0745848268f, -1.82224858f, -0.0240381155f, 1.16496933f,
    -0.380119562f, -1.22387457f, -0.0298879836f, -0.211371183f, 0.306974828f, 0.438313693f,
    0.410467803f, 0.422183305f, 0.153698042f, 0.598433137f, 0.988501132f, -0.793334723f,
    0.802063406f, -0.41341579f, -0.251109123f, 1.11024976f, -1.0397799f, -0.292983741f,
    -0.377403378f, 0.554109573f, 0.552173674f, -0.444880933f, -1.24244821f, -1.51643896f,
    0.525638998f, -3.33778882f, 0.128700003f, -0.0f, 0.783800781f, -0.00426651631f,
    1.72356951f, 0.0f, 1.13612247f, 1.40090859f, -4.70064211f, 1.49505806f,
    -0.332556069f, -2.15576029f};
HPDDO_FLASH static const float kB1[8] = {
    -0.355997115f, 0.326771766f, -0.0373344533f, 0.0252850484f, 0.0886943117f, 0.176482379f,
    0.167653292f, 0.842790544f};
HPDDO_FLASH static const float kW2[8] = {
    -0.0f, 1.17938054f, 2.2630868f, 1.0534147f, 1.48358595f, 1.15387809f,
    1.70380676f, -2.12500238f};
HPDDO_FLASH static const float kB2[1] = {
    -0.687137663f};
HPDDO_FLASH static const float kEnvLo[5] = {
    -1.17775714f, -0.0900968984f, -22.1247311f, -0.0900968984f, -22.1247311f};
HPDDO_FLASH static const float kEnvHi[5] = {
    12.9499283f, 1.08284187f, 233.172928f, 1.08284187f, 233.172928f};
/// Novelty gate: 32 prototypes by fps over 6691 of 6759 training rows (nearest-row distance within the 0.99 quantile); r_in = 0.99 quantile of their distances (at least 0.1), r_out = 2 r_in.
HPDDO_FLASH static const float kGateCentre[5] = {
    8.92886639f, 0.898876548f, 112.300865f, 0.898771822f, 112.295921f};
HPDDO_FLASH static const float kGateScale[5] = {
    1.16664481f, 0.160939991f, 21.7214413f, 0.161255181f, 21.7784653f};
HPDDO_FLASH static const float kGatePrototypes[160] = {
    0.0120050767f, -0.077317901f, 0.0741027817f, -0.107443482f, 0.262223393f,
    -7.65359402f, -5.53668165f, -5.20738554f, -5.52617168f, -5.19262981f,
    2.43718362f, -2.03944039f, 4.5734601f, -2.05017781f, 4.57342577f,
    -2.5167706f, -3.08312154f, -0.744490266f, -3.03965306f, -0.746152341f,
    -0.247841984f, -2.5563848f, 1.65379298f, -2.59257293f, 1.64746523f,
    -5.46974707f, -3.58650804f, -4.0054698f, -3.61327195f, -4.06432915f,
    1.07622337f, -2.33222675f, 3.1171515f, -2.28075051f, 3.10854483f,
    -0.0388068259f, 0.445025682f, -0.389108419f, 0.424973547f, -0.38384515f,
    0.41307652f, 0.303364486f, 0.277570009f, 0.320840478f, -0.120148659f,
    0.0766351596f, 0.390030086f, -0.204376578f, 0.239106566f, 0.202405497f,
    0.324475497f, -0.166307479f, 0.528226376f, -0.13392964f, 0.355751008f,
    0.0916370153f, 0.191024482f, -0.033279445f, 0.326812208f, -0.264101803f,
    0.839884579f, -2.27824378f, 2.78388786f, -2.32616282f, 2.9095633f,
    -5.75158644f, -3.68445754f, -4.27844477f, -3.67277384f, -3.94215202f,
    -0.441513985f, -2.51764989f, 1.38491261f, -2.4927001f, 1.42823744f,
    -0.147965893f, 0.390887469f, -0.482413739f, 0.308158487f, 0.0137492921f,
    -2.24123096f, -2.96782398f, -0.492594719f, -2.96487737f, -0.698332548f,
    0.200882718f, 0.183170408f, 0.107659698f, 0.349217653f, 0.110027269f,
    0.263416857f, 0.465151429f, -0.0312945992f, 0.373055786f, -0.417477101f,
    0.0964902118f, 0.456160367f, -0.2305547f, 0.260203511f, -0.159499913f,
    0.222189575f, -0.126764879f, 0.371588677f, -0.0765173361f, 0.074135758f,
    0.993567705f, -2.35220289f, 3.03038716f, -2.25244761f, 2.7923789f,
    -0.0848464519f, 0.182058245f, -0.244360805f, 0.363326043f, 0.0430807397f,
    -2.36964774f, -2.85073662f, -0.740954697f, -2.92042613f, -0.876415431f,
    0.1984974f, -0.0217197351f, 0.26179415f, -0.0406052619f, 0.426361173f,
    0.269100606f, 0.407527417f, 0.019902898f, 0.334650934f, -0.0844393149f,
    -2.40526628f, -2.95424128f, -0.705590665f, -3.00399542f, -0.489552975f,
    -0.342753708f, -2.68996239f, 1.63898623f, -2.57468224f, 1.40761423f,
    0.249070615f, 0.237004206f, 0.125898778f, 0.15372625f, -0.270519644f,
    0.0990856215f, 0.302177489f, -0.109296821f, 0.48329109f, -0.0665440112f,
    -0.143280268f, 0.251400948f, -0.369688839f, 0.312220365f, -0.251263678f,
    0.921181619f, -2.30798793f, 2.90709281f, -2.41776919f, 3.12422347f};

static_assert(hpddo::kGatePrototypes == 32, "the core's gate size (model.h) is hpddo.model.gate.DEFAULT_PROTOTYPES");
static_assert(sizeof(kW0) / sizeof(float) == Net::kW0Count, "kW0 shape");
static_assert(sizeof(kW1) / sizeof(float) == Net::kW1Count, "kW1 shape");
static_assert(sizeof(kW2) / sizeof(float) == Net::kW2Count, "kW2 shape");

/// The physics initialisers are positional: this header holds for one parameter layout.
static_assert(hpddo::kParamsSchema == 0x432e337eu,
              "model_default.h was written for another parameter layout (tools/hpddo/schema.py): regenerate it");
static_assert(hpddo::kPhysicsParamCount == 19, "one initialiser per hpddo::PhysicsParams field");

/// The deployed model.
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
    {kScalerMean, kScalerScale},
    {kW0, kB0, kW1, kB1, kW2, kB2},
    {kEnvLo, kEnvHi},
    {kGateCentre, kGateScale, kGatePrototypes, 0.0612889752f, 0.245155901f},
    23.7774677f,
    {40.0f, 10.0f, -55.0f, 125.0f},
};

/// The nameplate model M1 (rated voltage over rated speed), for comparison only.
static const hpddo::PhysicsParams kNameplate = {
    4.5f,           // ra_ohm [ohm]
    0.114591561f,   // ke_vs_per_rad [V s/rad]
    25.0f,          // t_ref_C [C]
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
    25.0f,          // t_amb_C [C]
    0x0000u,        // effects
};

}  // namespace hpddo_model_default

#endif  // HPDDO_MODEL_DEFAULT_H
