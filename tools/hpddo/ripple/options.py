"""The ripple estimator's settings (`Options`: the user's ripples per revolution and gear ratio, and
every threshold of the count) and the reasons for no confident speed, by key (`REASONS`)."""
from __future__ import annotations

import dataclasses

from . import sync


#: the largest error in a count that a wrong ripples per revolution may leave unsaid (relative): a speed range checks
#: the figure given only where it is no wider than this (hi / lo - 1; speed_range.range_checks_figure), and a Ke
#: given is at odds with it only where the figure the back-EMF speeds imply moves the count by more
#: (line.prior_checks_figure). A count under a wrong figure is the true speed times N_true / N_given, inside any
#: range wide enough to hold both (a 14-ripple motor given 7 under 500..3000 RPM was counted at twice its 900 RPM,
#: 12 of 12 windows confident, no comb in the recording to check the figure; given 19 for 18 under 500..1500 RPM,
#: 5.3 % low): only a range this narrow leaves no room for a count more than this off the truth it holds
FIGURE_CHECK_REL = 0.05

#: the reasons for no confident speed, by key (the texts of `Estimate.reason`)
REASONS = {
    "coasting": "coasting: the drive is off (duty 0), no armature current to ripple",
    "floor": "mean current under the floor",
    "few_cycles": "too few ripple cycles in the window for a count",
    "not_found": "the ripple line not found (no line above the noise near the prior: the back-EMF's, or the speed range given)",
    "far": "the strongest line is too far from the back-EMF prior to be the ripple (a fixed line: interference, "
           "while the shaft stands or turns too slowly for its ripple)",
    "ambiguous": "sub-harmonic ambiguity unresolved: another line of the family fits the data as well "
                 "and the back-EMF prior cannot tell them apart",
    "multiple": "the data show another ripples per revolution than the one given",
    "unchecked": "the ripples per revolution given is not checked by the data: nothing but the ripple under that "
                 "figure sets the speed's scale (the back-EMF prior's Ke calibrated from the ripple, no prior, a "
                 "speed range wide enough to hold a count under another figure, or a Ke given whose back-EMF speeds "
                 "hold another figure as well), so the counts scale with it, and the "
                 "recording's rotation combs do not confirm it; give Ke (--ke-vs-per-rad) or a model (--model), a "
                 f"speed range (--rpm-range) no more than {FIGURE_CHECK_REL:.0%} wide, or find the figure with --calibrate",
    "ke_or_figure": "the Ke given and the ripples per revolution given disagree: the back-EMF speeds under that Ke "
                    "put the ripple at another number per revolution, and without a rotation comb in the recording "
                    "the data cannot tell which of the two is wrong",
    "rival": "another line inside the prior's spread may be the ripple as well (as strong; or any resolved line "
             "where no rotation comb places the chosen one; or, under a free-running PWM, the chosen line's sideband "
             "partner), and the data do not place it on the rotation comb: unresolved",
    "damaged": "a damaged commutator: the rotation lines between the commutation line and its second harmonic (a "
               "fault's edges), or those at once or twice the rotation frequency, are too strong against the "
               "commutation line (a worn or burnt bar, a shorted coil, a badly eccentric rotor); the ripple is not "
               "counted through it",
    "changing": "the speed changed inside the window (inrush, spin-up or a load step)",
    "creep": "creep: the drive on and current flowing, a ripple line over a span of steady windows but none fast "
             "enough for a window's count, and the back-EMF prior under the speed floor: the shaft creeps "
             "(|n| within rpm_bound, not counted)",
    "stall": "stall: the drive on and current flowing, but no ripple line over a span of steady windows, and the "
             "back-EMF prior too low for a window's count: the shaft stands (0 RPM within rpm_bound)",
    sync.KEY: sync.REASON,
    sync.KEY_FOLD: sync.REASON_FOLD,
    sync.KEY_UNSEEN: sync.REASON_UNSEEN,
}


@dataclasses.dataclass(frozen=True)
class Options:
    ripples_per_rev: int          # commutation ripples per motor revolution (2 brushes: 2 x odd segments, x1 even)
    gear_ratio: float             # motor revolutions per output revolution (the user's figure)
    floor_A: float = 0.10         # no estimate under this mean current
    prior_rel_sd: float = 0.15    # the back-EMF prior's relative uncertainty on a candidate's speed: Ke's error
    #                               (calibration, magnet temperature); beside it the voltages of m2_prior_sd_rpm
    prior_unmodelled_V: float = 0.5   # a voltage the prior (V - I Ra)/Ke does not know: of the order of a brush drop
    prior_ra_rel: float = 0.2     # Ra's relative error in the prior: the multimeter's value against a winding
    #                               up to ~50 K warmer (copper +0.39 %/K) or colder
    min_snr: float = 10.0         # the line's power over the local noise floor
    min_cycles: float = 5.0       # ripple cycles a window must hold
    max_spread: float = 0.03      # relative spread of the quarter-window speeds still counted as steady
    spread_noise_z: float = 4.0   # the quarters' spread allowed on top of max_spread for the count's own noise, in
    #                               sd of one quarter's speed (count.spread_noise): the range of four quarters of
    #                               independent normal errors exceeds 4 sd with probability ~3 %, 5 sd ~0.4 %
    spread_noise_snr: float = 30.0  # count.spread_noise: the allowance only where the line stands this many times
    #                               over a wide band's median power (as stall_snr: noise alone reaches it with
    #                               probability 2^-30 a bin); a weaker line (a standing shaft's noise) keeps max_spread
    spread_noise_res: int = 64    # count.wide_snr: that wide band's width in frequency resolutions (1 / T); a
    #                               window whose band holds fewer has no noise allowance
    band: float = 1.2             # the band-pass: f / band .. f * band
    ambiguity: float = 0.5        # an alternative with this share of the best's evidence (prior-weighted) is a rival
    max_prior_z: float = 3.0      # a line further than this many of the prior's sd from it is not the ripple
    #                               (a fixed line, interference, while the shaft stands or turns slowly)
    span_max_s: float = 10.0      # count_steady_spans: the longest span of steady windows counted as one (s);
    #                               0 turns the multi-window count off
    standing_V: float = 0.010     # standing(): with the drive off and no current the open terminals show the
    #                               back-EMF; under this |V| the shaft stands (|n| < standing_V / Ke, 0.25 RPM at
    #                               0.38 V s/rad); 0 turns the label off
    settled_tail: bool = False    # count_settled_tails: a `changing` window counted again over its part after the
    #                               step (the tail), its head's speed from the back-EMF; off by default (the
    #                               ripple pages' figures are without it, but docs/ripple-step-windows.md, "Settled
    #                               tails (off by default)", which measures it)
    tail_starts: tuple = (0.1, 0.2, 0.3, 0.4)   # count_settled_tails: where the tail may begin, shares of the window
    tail_min_cycles: float = 10.0  # count_settled_tails: ripple cycles a tail must hold; a tail has no margins, so
    #                               its count leaves a tenth out at each end and reads the phase at filter edges
    #                               (4 % off on a steady tail of 5.2 cycles, unseen x0.25 seed 2;
    #                               docs/ripple-step-windows.md, "Settled tails (off by default)")
    stall_max_rpm: float = 1.0    # count_stalls: the largest bound on |n| (RPM, output shaft) the data must give
    #                               for a stall (the drive on, current above the floor, the shaft standing);
    #                               0 turns the stall off
    stall_cycles: float = 3.0     # count_stalls: the ripple cycles a line is taken to need over a span to stand
    #                               out in its spectrum (Hann window, trend removed), so a span of S s bounds |n| to
    #                               stall_cycles / (N G S) revolutions per second; a margin: on synthetic bursts 1-2
    #                               cycles stood out too, a real current's slow drifts fill the lowest bins
    stall_snr: float = 30.0       # count_stalls: a bin of the span's spectrum this many times the band's median
    #                               power is a line; noise alone (exponential power per bin, median ln 2 of the
    #                               mean) reaches it with probability 2^-30 ~ 1e-9 a bin, a ripple of 1.5 mA at 3
    #                               cycles over 9.5 s stood 153x over it at the least (docs/ripple-counting.md,
    #                               "Speed from the ripple", step 6)
    creep_cycles: float = 3.0     # count_stalls: a span with a line, but none at this many ripples a window or
    #                               faster, and the prior under the speed floor, is a creep: |n| under creep_cycles
    #                               ripples a window (rpm_bound), never confident; 0 turns the creep off
    stall_prior_z: float = 1.0    # count_stalls: the back-EMF prior plus this many of its upper sd must lie under
    #                               the speed floor for a span to be a stall (stall.count_stalls, 1.)


@dataclasses.dataclass(frozen=True)
class CoastOptions:
    """The coast probe's estimator (ripple/coast.py, docs/ripple-coast.md): Ke from the open terminals'
    back-EMF, then Ra and the winding's temperature from the driven rows around it."""

    decayed_A: float = 0.03       # the current has freewheeled out once every later sample of the probe reads under
    #                               this: 3 codes of the twin's shunt channel (9.8 mA), 6 of its noise's sd, a
    #                               thirtieth of a running current
    min_emf_samples: int = 8      # voltage samples a probe must hold after the decay for the back-EMF's curve
    #                               (a quadratic in time: the shaft slows at its mechanical time constant)
    count_s: float = 0.3          # the ripple counted over this much of the drive on each side of a probe: 13
    #                               cycles at 99 RPM on 26.4 ripples per output revolution (0.25 s left the
    #                               quarters' spread at 10 % there, so no count was confident)
    recovery_s: float = 0.05      # left out after a probe: the shaft regains its speed (mechanical time constant
    #                               16 ms on the twin under the heaviest load) and the current its level
    ke_window_s: float = 30.0     # Ke at a driven span: the median of the probes within this of it (the magnets
    #                               follow the case, minutes; a probe's Ke scatters by its count's resolution)
    ra_window_s: float = 30.0     # Ra at a probe: a straight line in time through the driven spans of its stretch
    #                               (one duty and load) whose middle lies within this of it, weighted by their
    #                               variance (the averaging ADC leaves ~75 mV / sqrt(s) on V under a 10 kHz PWM,
    #                               ~1 K per 16 s of spans). The copper cannot bend faster than its heat capacity
    #                               lets it: at one drive it relaxes to the case plus P R_wc at the winding's time
    #                               constant (C_w R_wc, 9 s on the twin), then follows the case (C_c R_ca, 23 min),
    #                               straight over a minute; the stretch's first ~3 winding time constants keep a
    #                               curvature the line misses (the cold start's first 6 s: up to 5.2 K with
    #                               the noise on one seed of four, docs/ripple-coast.md)
    max_ra_rel_sd: float = 0.008  # an Ra less certain than this (relative standard uncertainty) is not given:
    #                               0.8 % is 2 K of copper (0.393 %/K)
    winding_tolerance_K: float = 3.0  # a winding temperature is given only where its 99 % interval (WINDING_Z
    #                                   standard uncertainties, the reference's included) lies within this of it:
    #                                   the accuracy a stated temperature promises (issue 33's target)
    brush_drop_V: float = 0.0     # the brushes' contact drop while current flows, where the user declares it
    #                               (V - Ke n - drop = Ra I); 0: none declared, Ra then carries drop / I
    ra_ref_ohm: float | None = None  # the winding's Ra at ra_ref_C (a multimeter's); None: the first probe's Ra,
    ra_ref_C: float | None = None    # at the log's first temperature reading (the motor cold, at ambient)
