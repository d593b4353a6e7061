// Wiring, calibration and defaults of the acquisition board (Arduino UNO).
// The bench's numbers (gains, encoder, PWM, protocols) come from bench_gen.h,
// generated from tools/hpddo/bench.py, the one description of the bench shared
// with the twin and the simavr harness; docs/firmware.md explains how to measure
// each one on your own bench (edit bench.py, regenerate).
#ifndef HPDDO_ACQ_CONFIG_H
#define HPDDO_ACQ_CONFIG_H

#include <stdint.h>

#include "bench_gen.h"  // the bench, generated from tools/hpddo/bench.py

namespace acq {

// ---------------------------------------------------------------- pins (UNO numbering)
static const uint8_t kPinEncoderA = 2;   ///< encoder channel A, INT0 (PD2)
static const uint8_t kPinEncoderB = 3;   ///< encoder channel B, INT1 (PD3)
static const uint8_t kPinOneWire = 4;    ///< DS18B20 data (PD4), 4k7 pull-up to 5 V
static const uint8_t kPinRelay1 = 7;     ///< relay of load 1, the 0.5 ohm resistor (PD7)
static const uint8_t kPinRelay2 = 8;     ///< relay of load 2, the 0.01 ohm resistor (PB0)
static const uint8_t kPinPwm = 9;        ///< OC1A (PB1): TLP250 input, drives the IRFZ24N gate
static const uint8_t kPinLinkTx = 11;    ///< OC2A (PB3): link to the ESP8266 RX (GPIO14), via 1k/2k divider
static const uint8_t kAdcChannelV = 0;   ///< A0: terminal voltage through the divider
static const uint8_t kAdcChannelI = 1;   ///< A1: shunt voltage (low side)

/// Relay modules with opto inputs switch on with a LOW input.
static const bool kRelayActiveLow = true;

// ---------------------------------------------------------------- calibration
/// Gains and offsets from pin voltages to motor quantities. Measure them on your
/// bench (docs/firmware.md, "Calibration") and edit this one place.
struct Calibration {
  float adc_ref_V;      ///< ADC reference: AVcc, measured at the AREF pin, V
  float divider_ratio;  ///< motor terminal voltage / A0 pin voltage ((R_top + R_bottom) / R_bottom)
  float shunt_ohm;      ///< shunt resistance, ohm
  float shunt_gain;     ///< A1 pin voltage / shunt voltage (1 without an amplifier)
  float v_offset_V;     ///< subtracted from the terminal voltage, V
  float i_offset_A;     ///< subtracted from the current, A
};

/// The paper's bench: divider 20k (2 x 10k) over 10k, shunt 0.5 ohm 10 W, AVcc 5.0 V.
static const Calibration kCalibration = {HPDDO_BENCH_ADC_REF_V, HPDDO_BENCH_DIVIDER_RATIO, HPDDO_BENCH_SHUNT_OHM,
                                         HPDDO_BENCH_SHUNT_GAIN, 0.0f, 0.0f};

/// Encoder counts per output-shaft revolution after x4 quadrature decoding:
/// 11 pulses per motor revolution x 4 x the 1:4.4 gearbox = 193.6.
static const float kEncoderCountsPerRev = HPDDO_BENCH_ENCODER_COUNTS_PER_REV;

// ---------------------------------------------------------------- defaults
static const uint32_t kHostBaud = 115200;   ///< USB serial to the host (bench log lines)
static const uint32_t kLinkBaud = 38400;    ///< link to the ESP8266 (38462 exact: Timer2 /8, 52 ticks a bit)
static const uint32_t kDefaultPwmHz = HPDDO_BENCH_PWM_HZ;  ///< PWM frequency at power-up, Hz
static const float kDefaultRateHz = HPDDO_BENCH_SAMPLE_RATE_HZ;  ///< sample rate at power-up (the paper's 2 Hz)
/// Step length of the sweep and load protocols, s; 0 = the bench's own
/// (HPDDO_BENCH_SWEEP_STEP_S, HPDDO_BENCH_LOAD_STEP_S).
static const float kDefaultHoldS = 0.0f;
static const float kDefaultLongS = HPDDO_BENCH_LONG_S;  ///< length of the long protocol, s
static const char kMotor[] = "25GA371 1:4.4";  ///< written to the log metadata

}  // namespace acq

#endif  // HPDDO_ACQ_CONFIG_H
