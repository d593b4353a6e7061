"""The ripple counted over a span of steady windows where one window holds too few cycles or too
little evidence (a slow shaft): the spans, and their count (`count_steady_spans`)."""
from __future__ import annotations

import math

import numpy as np

from .count import estimate_window, part_means
from .options import Options


#: the single-window reasons that a count over several steady windows may lift: the window held too few
#: cycles or too little evidence for its line; not `changing` (the speed moved), `far`, `floor`, `coasting`
SPAN_KEYS = ("few_cycles", "not_found", "ambiguous", "rival")


def _contiguous(bursts, k) -> bool:
    """Whether burst k + 1 starts where burst k ends (one sample period apart at most)."""
    fs = bursts.sample_hz
    return abs(bursts.t_s[k] + len(bursts.codes[k]) / fs - bursts.t_s[k + 1]) < 1.5 / fs


def steady_spans(bursts, duty, keys, opts: Options, span_keys=SPAN_KEYS) -> list:
    """The spans (first, end) of consecutive windows that count_steady_spans counts as one: runs of
    windows at the same nonzero duty whose own count failed for a reason in span_keys (SPAN_KEYS;
    count_stalls: STALL_KEYS), each burst
    contiguous with the next (so the current is one record over the span), not the first window
    after a change of duty (the inrush); a run longer than opts.span_max_s is cut into equal spans
    no longer than it, each of two windows at least. A run of one window is no span."""
    n = len(bursts)
    if opts.span_max_s <= 0 or n < 2 or duty is None:
        return []
    duty = np.asarray(duty, float)
    lengths = np.array([len(c) for c in bursts.codes]) / bursts.sample_hz
    ok = np.array([keys[k] in span_keys and np.isfinite(duty[k]) and duty[k] > 0
                   and (k > 0 and duty[k - 1] == duty[k]) for k in range(n)])
    spans, k = [], 0
    while k < n:
        if not ok[k]:
            k += 1
            continue
        e = k + 1
        while e < n and ok[e] and duty[e] == duty[k] and _contiguous(bursts, e - 1):
            e += 1
        if e - k >= 2:
            n_cut = min(int(math.ceil(float(lengths[k:e].sum()) / opts.span_max_s - 1e-9)), (e - k) // 2)
            cuts = np.linspace(k, e, max(n_cut, 1) + 1).round().astype(int)
            spans += [(int(a), int(b)) for a, b in zip(cuts[:-1], cuts[1:]) if b - a >= 2]
        k = e
    return spans


def _windows_apart(joined, bursts, a: int, e: int, r, rpm_per_A, opts: Options) -> bool:
    """Whether the current says that a window of the windows a..e of a span counted as one (r: its estimate_window)
    turned at another speed than the span's count gives it: a window's mean current (count.part_means: the ripple's
    lines fitted out) further from the median of the span's windows than opts.max_spread of the speed allows (Ra /
    Ke in RPM per A, rpm_per_A) and than the current's own noise explains (opts.spread_noise_z standard errors of
    a window's mean, from the scatter of its quarters about it, pooled over the span). The quarters of a long span
    average a step at its edge away: a load step between the first window of a 14-window span and the second (116.5
    and 127.3 RPM) left the first window in the span, confident and 9 % off, where the quarters' spread stayed within
    the allowance. A span whose speed drifts by a few % over its 10 s is counted: each window is given the span's
    mean, within max_spread of its own; and at a creep of 3 RPM the windows' currents scatter by a few mA, which the
    noise explains. False without Ra / Ke (rpm_per_A)."""
    if rpm_per_A is None or not np.isfinite(rpm_per_A) or not rpm_per_A > 0 or not r["f_Hz"] > 0:
        return False
    edges = np.concatenate([[0], np.cumsum([len(c) for c in bursts.codes[a:e]])])
    # each window's quarters: where they begin inside the span, but the first (part_means' parts)
    cuts = np.round(np.concatenate([np.linspace(s0, s1, 5)[:-1] for s0, s1 in zip(edges[:-1], edges[1:])])[1:])
    cuts = cuts.astype(int)
    quarters = np.array(part_means(joined.current_A(0), joined.sample_hz, float(r["f_Hz"]), cuts)).reshape(e - a, 4)
    means = quarters.mean(axis=1)
    noise = float(np.sqrt(np.sum((quarters - means[:, None]) ** 2) / (3 * (e - a)))) / 2.0  # sd of a window's mean
    allowed = opts.max_spread * abs(float(r["rpm"])) / rpm_per_A + opts.spread_noise_z * noise
    return bool(np.max(np.abs(means - np.median(means))) > allowed)


#: a span whose count fails for these reasons (or whose windows' currents part: _windows_apart, key "") is counted
#: again as two, either side of its largest step of current (_step): a load step at one duty inside a run of slow
#: windows otherwise left the whole run uncounted (the twin's unseen run: 17 windows at 9.4 and 10.7 RPM, whose two
#: lines 0.55 Hz apart over the span's 9.5 s were each the other's rival)
SPLIT_KEYS = ("", "changing", "rival")


def _step(bursts, a: int, e: int) -> int:
    """Where the windows a..e (e - a >= 4) part best in two of two windows at least: the split s that leaves the least
    sum of squares of the windows' mean currents about the mean of their side (one step of load)."""
    means = np.array([float(np.mean(bursts.current_A(k))) for k in range(a, e)])
    cost = [float(np.sum((means[:j] - means[:j].mean()) ** 2) + np.sum((means[j:] - means[j:].mean()) ** 2))
            for j in range(2, e - a - 1)]
    return a + 2 + int(np.argmin(cost))


def count_steady_spans(bursts, duty, est, opts: Options, rpm_per_A=None):
    """The ripple counted over several consecutive windows where one window holds too few cycles or
    too little evidence (a slow shaft: at duty 0.2 the bench turns at 4-6 RPM, about one ripple
    cycle in a 0.5 s window). Over a span of steady windows (steady_spans: the same duty, the bursts
    contiguous) the speed is constant, so the bursts are one record of the current, counted as one
    window (estimate_window) with every honesty check of a single one: the prior (the median of the
    span's priors and of their sd, the window before the span as the speed before it), `far`,
    `ambiguous`, the line above the noise, at least opts.min_cycles cycles over the span, and the
    steadiness across the span (the counted quarters and the current's quarters, Ra dI / Ke, within
    opts.max_spread); a span that fails the steadiness is counted again as two parts (SPLIT_KEYS, _step). Where the span's count is confident, each of its windows takes its speed and
    confidence (`span`: the number of windows counted together); elsewhere each window keeps its
    own estimate and reason. est: estimate()'s DataFrame for these bursts. Returns a copy."""
    est = est.copy()
    est["span"] = 1
    est["span_first"] = np.arange(len(est))  # the first window of the row's span (its own where no span)
    keys = est["key"].to_numpy()
    prior = est["rpm_prior_used"].to_numpy(float)
    sd = est[["prior_sd_below", "prior_sd_above"]].to_numpy(float)
    glitch = est["prior_glitch"].to_numpy(float) if "prior_glitch" in est else np.zeros(len(est))
    todo = steady_spans(bursts, duty, keys, opts)[::-1]
    while todo:
        a, e = todo.pop()
        joined = bursts.one(a, np.concatenate(bursts.codes[a:e]))
        has_prior = bool(np.isfinite(prior[a:e]).any())
        pr = float(np.nanmedian(prior[a:e])) if has_prior else None
        psd = np.nanmedian(sd[a:e], axis=0) if has_prior else None
        pgl = float(np.nanmedian(glitch[a:e])) if has_prior else 0.0
        before = float(prior[a - 1]) if has_prior and a > 0 and np.isfinite(prior[a - 1]) else None
        r = estimate_window(joined, 0, float(np.asarray(duty, float)[a]), pr, opts, before, psd, rpm_per_A, pgl)
        if r["key"] or _windows_apart(joined, bursts, a, e, r, rpm_per_A, opts):
            if r["key"] in SPLIT_KEYS and e - a >= 4:  # the speed moved inside: the two sides of its largest step
                s = _step(bursts, a, e)
                todo += [(s, e), (a, s)]
            continue
        idx = est.index[a:e]
        for c in ("rpm", "rpm_fft", "f_Hz", "f_strongest_Hz", "snr", "snr_wide", "spread", "spread_current", "spread_allowed",
                  "confidence"):
            est.loc[idx, c] = r[c]
        est.loc[idx, "cycles"] = r["cycles"] / (e - a)  # the window's share of the span's cycles
        est.loc[idx, ["key", "reason"]] = ""
        est.loc[idx, "confident"] = True
        est.loc[idx, "span"] = e - a
        est.loc[idx, "span_first"] = a
    return est
