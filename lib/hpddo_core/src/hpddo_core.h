// hpddo_core: the header-only core of the hybrid physics-data-driven observer,
// shared by the UNO and ESP8266 sketches and compiled natively for tests.
#ifndef HPDDO_CORE_H
#define HPDDO_CORE_H

#include "hpddo/platform.h"
#include "hpddo/crc.h"
#include "hpddo/limits.h"
#include "hpddo/scaler.h"
#include "hpddo/mlp.h"
#include "hpddo/mlp_q.h"
#include "hpddo/physics.h"
#include "hpddo/thermal.h"
#include "hpddo/clamp.h"
#include "hpddo/envelope.h"
#include "hpddo/gate.h"
#include "hpddo/gate_q.h"
#include "hpddo/model.h"
#include "hpddo/observer.h"
#include "hpddo/frame.h"
#include "hpddo/text.h"
#include "hpddo/dynamics.h"

#endif  // HPDDO_CORE_H
