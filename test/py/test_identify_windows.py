"""model/identify.py: the rows M2 is identified on (ke_rows, window_means). A time series is averaged over
windows of IDENT_WINDOW_S of its clock; a table of settled points has no clock, so its rows are taken as they
are, whatever steps its t_s makes (a converted dyno table's made-up milliseconds, or 1e-20 s), and a part
shorter than one window is one window, never a reshape of more rows than it holds."""
import numpy as np
import pytest

from hpddo.logs import dataset
from hpddo.model import identify
from twin_benches import dyno_table


def _retimed(src, dst, step_s: float):
    """The table at src with t_s = row x step_s, written to dst."""
    lines = src.read_text().splitlines()
    head = [ln for ln in lines if ln.startswith("#")] + [lines[len([ln for ln in lines if ln.startswith("#")])]]
    rows = lines[len(head):]
    out = [f"{k * step_s!r}," + r.split(",", 1)[1] for k, r in enumerate(rows)]
    dst.write_text("\n".join(head + out) + "\n")
    return dst


@pytest.mark.parametrize("step_s", [1e-3, 0.1, 1e-20, 1e-300])
def test_a_settled_tables_rows_are_its_points_whatever_its_clock(tmp_path, step_s):
    """A steady-state table declared so, with t_s one second apart, and the same rows at step_s: the same rows
    and the same Ke (0.1 s gave 4 windows, 1 ms none: "only 0 training rows ... M2 needs a labelled recording of
    the motor turning"; 1e-20 s a ValueError from the reshape)."""
    base = dyno_table(tmp_path / "d.csv", 30, meta=("kind=steady_state",))
    fast = _retimed(base, tmp_path / "f.csv", step_s)
    want = identify.ke_rows(dataset.load_recordings([base]))
    got = identify.ke_rows(dataset.load_recordings([fast]))
    assert len(got[0]) == len(want[0]) == 24  # the training part's 24 rows
    for a, b in zip(got, want):
        assert np.array_equal(np.asarray(a), np.asarray(b))


def test_a_time_series_shorter_than_its_windows_is_refused_with_the_reason(tmp_path):
    """A time series (no kind, rows 1 ms apart, so not read as a table) whose training part spans under five
    windows: the refusal says that the rows are there and the windows are not, and how to declare a table."""
    base = dyno_table(tmp_path / "d.csv", 30)
    lines = base.read_text().splitlines()
    n_head = len([ln for ln in lines if ln.startswith("#")]) + 1
    # one operating point held, rows 1 ms apart: a time series by every test of detect_kind
    rows = [f"{k * 1e-3:.4f},0.500,6.0000,0.2000,{700 + (k % 3):.2f}" for k in range(600)]
    short = tmp_path / "s.csv"
    short.write_text("\n".join(lines[:n_head] + rows) + "\n")
    recs = dataset.load_recordings([short])
    assert dataset.kind(recs[0])[0] == "time_series"
    with pytest.raises(identify.IdentificationError) as e:
        identify.ke_rows(recs)
    said = str(e.value)
    assert "only 1 training window(s)" in said and "480 turning rows" in said and "kind=steady_state" in said, said


def test_a_window_holds_the_parts_rows_at_the_most():
    import pandas as pd
    part = pd.DataFrame({"t_s": np.arange(7) * 1e-20, "v_V": np.arange(7.0), "i_A": np.ones(7),
                         "rpm_ref": np.full(7, 100.0)})
    v, i, n = identify.window_means(part)
    assert list(v) == [3.0] and list(n) == [100.0]
