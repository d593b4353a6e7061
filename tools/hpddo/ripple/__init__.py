"""The speed counted from the commutation ripple in the current bursts (docs/ripple.md,
docs/ripple-counting.md): the settings and reasons (options), the back-EMF prior and a trained
model's M2 as prior (prior), which line is the ripple (line; comb: the rotation comb, the line's
identity, rivals, the commutator's health; sync: the PWM-synchronous average, the PWM and mains
lines), one window counted (count), spans of steady windows (spans), a standing or stalled shaft
(stall), the ratio against an encoder (encoder), the ripples per revolution and Ke from the data
(calibrate), the ripple speed of a bench log (log) and of a capture without one (capture, with the
user's speed range: speed_range), the board counter's reference (board, uno_acq/acq_ripple_count.h)
and the speed the fits take as rpm_ref: the encoder's or the ripple's (reference).

May import: the foundations (hpddo.schema, hpddo.bench, hpddo.interrupt), hpddo.logs and
hpddo.model (the physics of the board's Ra tracker, a trained model's M2 as the prior).
"""
