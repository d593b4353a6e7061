"""The picture of docs/ripple.md, "Which line is the ripple": the current spectrum of one burst
with the lines the ripple code finds, the rotation comb they form and the ripple line on it, drawn
from the committed burst (docs/figures/ripple_spectrum.ripple.csv, in the burst file format of
docs/bench-log.md) by the code that counts the ripple: the spectrum of hpddo.ripple.line, the
lines and the comb of hpddo.ripple.comb as hpddo.ripple.calibrate.window_comb takes them.

    cd tools && ../.venv/bin/python -m hpddo.studies.ripple_spectrum --write      # or --check

--write-burst writes the burst again from the twin first (one window of the ripple study's healthy
sweep, hpddo.studies.ripple_line: the default bench, seed 1). test/py/test_ripple_spectrum.py
regenerates both and compares them byte for byte; the SVG carries the command and the burst's
sha256 in its <desc>, and is written without a date or random ids (svg.hashsalt fixed).
"""
from __future__ import annotations

import hashlib
import sys

import numpy as np

from .. import resource_root
from ..logs import ripple as burst_file
from ..logs.errors import InputError
from ..regenerate import write_or_check
from ..ripple import calibrate as rcal
from ..ripple import comb as rc
from ..ripple.line import spectrum
from ..ripple.options import Options
from . import figures

ROOT = resource_root()
COMMAND = "cd tools && ../.venv/bin/python -m hpddo.studies.ripple_spectrum --write"
BURST = "docs/figures/ripple_spectrum.ripple.csv"
SVG = "docs/figures/ripple_spectrum.svg"
PROTOCOL = "sweep"
WINDOW = 79  # a window of the sweep at about 1050 RPM (the motor's), whose lines form a comb of five
#: the burst file's metadata that say how the twin was run (besides the format's own keys)
RIPPLES_KEY, GEAR_KEY = "ripples_per_rev", "gear_ratio"


def burst_text() -> str:
    """The text of the committed burst: window WINDOW of the ripple study's healthy sweep."""
    import tempfile
    import pathlib
    from . import ripple_line
    bench, g, b = ripple_line._record(PROTOCOL, {})
    meta = dict(b.meta, **{RIPPLES_KEY: bench.ripples_per_rev, GEAR_KEY: bench.gear_ratio,
                          "source": f"hpddo twin, preset default, {PROTOCOL}, seed {ripple_line.SEED}, time_scale "
                                    f"{ripple_line.TIME_SCALE:g}, window {WINDOW} (hpddo.studies.ripple_line)",
                          "command": COMMAND + " --write-burst"})
    meta.pop("format", None)
    with tempfile.TemporaryDirectory() as tmp:
        path = burst_file.write(pathlib.Path(tmp) / "b.ripple.csv", meta, b.seq[WINDOW:WINDOW + 1],
                                b.t_s[WINDOW:WINDOW + 1], [b.codes[WINDOW]])
        return path.read_text(encoding="utf-8")


def measure(path=None) -> dict:
    """The spectrum, lines and comb of the burst file's first window, as the ripple code takes them.
    Raises InputError naming the file where it cannot be read or its lines form no comb."""
    path = path or ROOT / BURST
    b = burst_file.read(path)
    if len(b) == 0:
        raise InputError(f"{path}: no burst")
    try:
        opts = Options(int(b.meta[RIPPLES_KEY]), float(b.meta[GEAR_KEY]))
    except (KeyError, ValueError):
        raise InputError(f"{path}: metadata {RIPPLES_KEY} and {GEAR_KEY} (whole and > 0) are needed") from None
    found, comb, res, bad = rcal.window_comb(b, 0, opts)
    if comb is None:
        raise InputError(f"{path}:{len(b.meta) + 2}: the lines of this burst form no rotation comb; nothing to mark")
    f, p = spectrum(b.current_A(0), b.sample_hz)
    return dict(f=f, p=p, found=found, comb=comb, res=res, damaged=bad, opts=opts, sample_hz=b.sample_hz,
                n=len(b.codes[0]))


def caption(m: dict) -> str:
    """The figures the picture shows, one line (docs/ripple.md quotes it)."""
    c = m["comb"]
    return (f"f_rot {c.rot_hz:.2f} Hz ({c.rot_hz * 60:.0f} RPM, motor), ripple line {c.commutation.hz:.1f} Hz "
            f"= {c.multiple} x f_rot; {len(c.lines)} of the {len(m['found'])} lines found (to "
            f"{m['sample_hz'] / 2.0 / 2.2:.0f} Hz) on the comb")


def svg(path=None) -> str:
    """docs/figures/ripple_spectrum.svg's text."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = path or ROOT / BURST
    m = measure(path)
    f, p, c, res = m["f"], m["p"], m["comb"], m["res"]
    f_hi = (rc.COMB_SPAN + 0.3) * c.commutation.hz
    f_lo = max(2.0 * res, 0.5)  # the band the lines are searched in (count.estimate_window, calibrate.window_comb)
    sel = (f >= f_lo) & (f <= f_hi)
    ref = c.commutation.power
    db = lambda x: 10.0 * np.log10(np.maximum(np.asarray(x, float) / ref, 1e-30))
    sha = hashlib.sha256(path.read_bytes()).hexdigest()[:16]
    on = {id(ln) for ln, _ in c.lines}
    with matplotlib.rc_context(figures.SVG_RC):
        fig, ax = plt.subplots(figsize=(7.4, 3.8))
        ax.plot(f[sel], db(p[sel]), color="#7f8c8d", lw=0.7, label="current spectrum (Hann, 8x zero-padded)")
        for k in range(1, int(f_hi / c.rot_hz) + 1):
            ax.axvline(k * c.rot_hz, color="#2e86c1", lw=0.6, ls=":", zorder=0)
        other = [ln for ln in m["found"] if id(ln) not in on and ln.hz <= f_hi]
        if other:
            ax.plot([ln.hz for ln in other], db([ln.power for ln in other]), "x", color="#555", ms=5,
                    label="other lines found (off the comb)")
        comb_lines = [(ln, k) for ln, k in c.lines if ln is not c.commutation]
        ax.plot([ln.hz for ln, _ in comb_lines], db([ln.power for ln, _ in comb_lines]), "o", color="#2e86c1",
                ms=5, mfc="none", label=f"rotation comb: k x f_rot, f_rot = {c.rot_hz:.2f} Hz")
        for ln, k in c.lines:
            ax.annotate(f"{k}", (ln.hz, db(ln.power)), textcoords="offset points", xytext=(0, 6), ha="center",
                        fontsize=7.5, color="#1b4f72")
        ax.plot([c.commutation.hz], db([ref]), "o", color="#c0392b", ms=6,
                label=f"ripple line: {c.multiple} x f_rot = {c.commutation.hz:.1f} Hz")
        ax.set_xlim(0, f_hi)
        ax.set_ylim(max(float(db(p[sel]).min()), -110.0), 32)  # room for the legend above the lines
        ax.set_xlabel("frequency, Hz (motor)")
        ax.set_ylabel("power, dB from the ripple line")
        ax.set_title(f"One burst of the twin, {m['n']} samples at {m['sample_hz']:g} S/s: the lines, the rotation "
                     f"comb and the ripple line\n{caption(m)}", fontsize=8, loc="left")
        ax.legend(fontsize=7, frameon=False, loc="upper center", ncols=2)
        return figures.svg_of(fig, ax, f"GENERATED by `{COMMAND}` from {BURST} (sha256 {sha}); do not edit.")


def main(argv=None) -> int:
    ap = write_or_check("python -m hpddo.studies.ripple_spectrum", __doc__, "the picture (and with --write-burst, "
                                                                           "its burst)")
    ap.add_argument("--write-burst", action="store_true", help="write the burst from the twin first (with --write)")
    args = ap.parse_args(argv)
    try:
        want = {}
        if args.write_burst:
            want[BURST] = burst_text()
            if args.write and (not (ROOT / BURST).exists() or (ROOT / BURST).read_text(encoding="utf-8") != want[BURST]):
                (ROOT / BURST).write_text(want[BURST], encoding="utf-8")
                print(f"wrote {BURST}")
        want[SVG] = svg()
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    status = figures.write_or_check_texts(want, args.check, COMMAND, "picture")
    if status == 0 and not args.check:
        print(caption(measure()))
    return status


if __name__ == "__main__":
    sys.exit(main())
