"""A case temperature reading stands for the case until it is TEMP_MAX_AGE_S old, as the acquisition board
passes it on (hpddo/limits.h kTempMaxAge_ms, uno_acq's TempSchedule): dataset.temp_read_C holds it so, and the
native replay (host/bench_log.h held_temperatures, test/host/test_bench_log.cpp) the same way."""
import re

import numpy as np
import pandas as pd

from conftest import ROOT

from hpddo.logs import dataset
from hpddo.model import effects as fx


def test_the_hold_is_the_boards():
    text = (ROOT / "lib" / "hpddo_core" / "src" / "hpddo" / "limits.h").read_text()
    ms = int(re.search(r"kTempMaxAge_ms\s*=\s*(\d+)", text).group(1))
    assert ms == round(dataset.TEMP_MAX_AGE_S * 1000)
    onewire = (ROOT / "uno_acq" / "acq_onewire.h").read_text()
    assert re.search(r"kMaxAgeMs\s*=\s*hpddo::kTempMaxAge_ms", onewire)


def _rec(temp, meta=None, t=None):
    n = len(temp)
    df = pd.DataFrame({"t_s": np.arange(n) * 0.25 if t is None else t, "duty": np.full(n, 0.5),
                       "v_V": np.full(n, 6.0), "i_A": np.full(n, 0.3), "rpm_ref": np.full(n, 100.0),
                       "temp_C": temp})
    return dataset.Recording(name="x", source=ROOT / "x.csv", meta=dict(meta or {}), df=df, removed=[],
                             n_train=n)


def test_a_reading_is_held_until_it_is_too_old():
    nan = np.nan
    # 4 Hz: a reading at 0.25 s, one outside the sensor's range at 1.25 s; held up to 2.75 s (2.5 s after it)
    temp = [nan, 30.0, nan, nan, nan, 200.0, nan, nan, nan, nan, nan, nan, nan, 31.0]
    got = dataset.temp_read_C(_rec(temp))
    want = [nan, 30.0, 30.0, 30.0, 30.0, 30.0, 30.0, 30.0, 30.0, 30.0, 30.0, 30.0, nan, 31.0]
    np.testing.assert_array_equal(got, want)
    # read on every row: as read; a steady-state table (rows points apart): no hold
    np.testing.assert_array_equal(dataset.temp_read_C(_rec([30.0, 31.0, 32.0])), [30.0, 31.0, 32.0])
    table = dataset.temp_read_C(_rec(temp, {"kind": "steady_state"}))
    assert np.isnan(table[2]) and table[1] == 30.0


def test_a_log_read_once_a_second_is_read_on_the_case_path():
    """An independent simulator's 10 Hz bench with its case temperature once a second (test/fixtures/independent/
    other17): nine rows in ten read no temperature, so the winding node ran along the ambient path with its reference
    jumping from the ambient to the case at every tenth row. Held, every row after the first reading has one."""
    for path in sorted((ROOT / "test" / "fixtures" / "independent" / "other17").glob("*.csv")):
        rec = dataset.load_recording(path)
        raw = rec.df["temp_C"].to_numpy(float)
        assert np.isfinite(raw).mean() < 0.2
        rows = fx.rows_of(rec)
        first = int(np.flatnonzero(np.isfinite(raw))[0])
        assert rows.has_temp[first:].all() and not rows.has_temp[:first].any()
