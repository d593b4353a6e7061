"""The training and evaluation report's plot on a long, noisy recording (issue 32, item 4): 7 200
rows whose M2 is noisy must not paint over M3 and the encoder. The page is rendered in headless
Chromium, as a person opens it, and the screenshot's pixels say what is visible: inside the
panels under M1's (the speed panels and the error panel), the encoder's colour and M3's.
Before the redraw, M2's 7 200 points (drawn last) left 42 encoder and 18 M3 pixels there (the
legend keys); now thousands of each."""
import numpy as np
import pandas as pd
import pytest
from PIL import Image

from hpddo.reports import browser
from hpddo.reports import training as report

ENCODER, M1, M3 = (0x22, 0x22, 0x22), (0xd6, 0x27, 0x28), (0x2c, 0xa0, 0x2c)


def long_noisy(n: int = 7200) -> pd.DataFrame:
    """An estimates file of the replay for a long recording: load steps, M2 off by 12 RPM with
    40 RPM of noise, M3 within 2 RPM of the encoder."""
    rng = np.random.default_rng(3)
    t = np.arange(n) * 0.5
    ref = 150 + 60 * np.sign(np.sin(t / 300)) + 3 * rng.standard_normal(n)
    return pd.DataFrame({"t_s": t, "rpm_ref": ref, "rpm_m1": 2.5 * ref,
                         "rpm_m2": ref + 12 + 40 * rng.standard_normal(n), "rpm_m3": ref + 2 * rng.standard_normal(n),
                         "part": ["train"] * (n - n // 5) + ["test"] * (n // 5)})


def near(rgb, colour, tol: int = 24):
    return np.abs(rgb - np.array(colour)).max(axis=2) <= tol


def panels_under_m1(rgb):
    """The screenshot's region of the panels under M1's: M1's red line gives the data's x range
    (every panel shares it); the axes' frames are the rows dark across it; from the bottom of the
    second frame row (M1's panel's bottom) to the top of the last (the last panel's bottom)."""
    ys, xs = np.nonzero(near(rgb, M1))
    x0, x1 = xs.min() + 5, xs.max() - 5
    rule = np.flatnonzero((rgb[:, x0:x1].max(axis=2) < 120).mean(axis=1) > 0.6)
    runs = np.split(rule, np.flatnonzero(np.diff(rule) > 1) + 1)
    assert len(runs) >= 4, "fewer than two panels found in the screenshot"
    return slice(runs[1][-1] + 1, runs[-1][0]), slice(x0, x1)


def test_binned_means_keep_every_row_and_short_recordings_raw():
    est = long_noisy()
    t, mean, lo, hi = report.binned(est["t_s"], est["rpm_m2"])
    assert len(t) == report.BINS and np.all(lo <= mean) and np.all(mean <= hi)
    assert np.mean(mean) == pytest.approx(est["rpm_m2"].mean(), abs=0.5)  # equal bins: the same mean
    short = est.iloc[:report.MAX_POINTS]
    t, mean, lo, hi = report.binned(short["t_s"], short["rpm_m3"])
    assert np.array_equal(mean, short["rpm_m3"].to_numpy()) and np.array_equal(lo, hi)
    tb, rms = report.binned_rms(est["t_s"], est["rpm_m2"] - est["rpm_ref"])
    assert np.sqrt(np.mean(rms ** 2)) == pytest.approx(np.sqrt(np.mean((est["rpm_m2"] - est["rpm_ref"]) ** 2)), rel=0.02)


def test_on_a_long_noisy_recording_the_encoder_and_m3_are_visible_over_m2(tmp_path):
    if browser.chromium() is None:
        pytest.skip("chromium not installed (scripts/bootstrap.sh --tests installs it)")
    (tmp_path / "estimates").mkdir()
    long_noisy().to_csv(tmp_path / "estimates" / "long.estimates.csv", index=False)
    metrics = {"rmse_rpm": {m: {"long": 1.0, "average": 1.0} for m in ("M1", "M2", "M3")}}
    page = report.write(metrics, tmp_path / "estimates", tmp_path / "report", "long", [])
    shot = tmp_path / "shot.png"
    seen = browser.render(page, shot, height=1600)
    assert seen["console_errors"] == [], seen["console_errors"]
    rgb = np.asarray(Image.open(shot).convert("RGB"), dtype=int)
    box = panels_under_m1(rgb)
    encoder, m3 = int(near(rgb, ENCODER)[box].sum()), int(near(rgb, M3)[box].sum())
    print(f"pixels in the panels under M1's: encoder {encoder}, M3 {m3}")
    assert encoder >= 600, f"the encoder is hidden: {encoder} pixels of its colour in the speed and error panels"
    assert m3 >= 400, f"M3 is hidden: {m3} pixels of its colour in the speed and error panels"
