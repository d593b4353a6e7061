// hpddo acquisition board (Arduino UNO). The sketch lives in uno_acq.cpp, next
// to this file, so that the Arduino IDE and PlatformIO build the same source;
// see docs/firmware.md for wiring, commands and calibration.
