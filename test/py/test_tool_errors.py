"""Bad or unusual input gives a named error (no traceback, nothing written), and fast
recordings are cleaned and identified as well as slow ones."""
import json
import pathlib

import numpy as np
import pytest

from conftest import ROOT

import demo
import diagnose
import gen_weights
import twin
from hpddo.logs import benchlog, dataset
from hpddo.model import identify

DATA = sorted(p for p in (ROOT / "data" / "default").glob("*.csv") if not p.name.endswith(".truth.csv"))
LONG = ROOT / "data" / "default" / "long.csv"


def _head(src: pathlib.Path, dst: pathlib.Path, rows: int, meta_extra: str = "") -> pathlib.Path:
    lines = src.read_text().splitlines(keepends=True)
    meta = [ln for ln in lines if ln.startswith("#")]
    body = [ln for ln in lines if not ln.startswith("#")]
    dst.write_text("".join(meta) + meta_extra + "".join(body[: rows + 1]))
    return dst


def _no_traceback(err: str):
    assert "Traceback" not in err


def test_two_logs_with_the_same_name_are_refused(tmp_path, capsys):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a = tmp_path / "a" / "sweep.csv"
    b = tmp_path / "b" / "sweep.csv"
    a.write_bytes(DATA[-1].read_bytes())
    b.write_bytes(DATA[-1].read_bytes())
    out = tmp_path / "out"
    assert gen_weights.main([str(a), str(b), "--out", str(out), "--quiet", "--epochs", "1"]) == 1
    err = capsys.readouterr().err
    assert str(a) in err and str(b) in err and "condition" in err
    assert not out.exists()


def test_same_file_name_with_distinct_conditions_is_two_recordings(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    text = LONG.read_text()
    a = tmp_path / "a" / "long.csv"
    b = tmp_path / "b" / "long.csv"
    a.write_text(text.replace("# condition=long", "# condition=bench_a"))
    b.write_text(text.replace("# condition=long", "# condition=bench_b"))
    recs = dataset.load_recordings([a, b])
    assert [r.name for r in recs] == ["bench_a", "bench_b"]


def test_condition_with_quote_and_backslash_reaches_valid_metrics(tmp_path):
    log = tmp_path / "odd.csv"
    log.write_text(LONG.read_text().replace("# condition=long", '# condition=run "7" \\ hot'))
    out = tmp_path / "out"
    assert gen_weights.main([str(log), "--out", str(out), "--quiet", "--epochs", "1"]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert 'run "7" \\ hot' in metrics["rmse_rpm"]["M2"]


def test_no_rpm_ref_column_is_a_named_error(tmp_path, capsys):
    src = LONG.read_text().splitlines()
    head = next(k for k, ln in enumerate(src) if not ln.startswith("#"))
    cols = src[head].split(",")
    j = cols.index("rpm_ref")
    rows = [",".join(c for k, c in enumerate(ln.split(",")) if k != j) for ln in src[head:]]
    log = tmp_path / "unlabelled.csv"
    log.write_text("\n".join(src[:head] + rows) + "\n")
    for tool in (gen_weights, diagnose):
        out = tmp_path / f"out_{tool.__name__}"
        assert tool.main([str(log), "--out", str(out)]) == 1
        err = capsys.readouterr().err
        _no_traceback(err)
        assert "rpm_ref" in err and str(log) in err
        assert not out.exists()


@pytest.mark.parametrize("rows", [12, 50, 150])
def test_short_logs_give_a_named_error_or_a_result(tmp_path, capsys, rows):
    log = _head(LONG, tmp_path / f"short{rows}.csv", rows)
    out = tmp_path / "gw"
    # too few rows for the network: a physics-only model (M3 = M2), said in metrics.json
    # (test_small_tables.py covers it)
    assert gen_weights.main([str(log), "--out", str(out), "--quiet"]) == 0
    _no_traceback(capsys.readouterr().err)
    ident = json.loads((out / "metrics.json").read_text())["identification"]
    assert ident["residual"].startswith(f"not trained: {int(rows * dataset.TRAIN_FRACTION)} labelled training rows")
    # the diagnosis needs no network: it runs, and says the hybrid was left out, or (with
    # too few held-out rows to rank anything) says that
    dout = tmp_path / "dg"
    rc = diagnose.main([str(log), "--out", str(dout), "--bootstrap", "0"])
    err = capsys.readouterr().err
    _no_traceback(err)
    if rows * (1 - dataset.TRAIN_FRACTION) < 8:
        assert rc == 1 and "held-out rows" in err and not dout.exists()
        return
    assert rc == 0
    assert "hybrid before/after not computed" in err
    assert json.loads((dout / "diagnosis.json").read_text())["warnings"]


def test_too_few_rows_to_split_names_the_file(tmp_path, capsys):
    log = _head(LONG, tmp_path / "tiny.csv", 6)
    assert gen_weights.main([str(log), "--out", str(tmp_path / "o"), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "tiny.csv" in err and "only 6 usable rows" in err
    assert "one log per supply voltage" not in err  # a recording of the bench, not a table


def test_a_table_split_one_log_per_voltage_too_short_says_to_put_its_rows_into_one_log(tmp_path, capsys):
    """An independent probe's dyno tables, 7 settled points per supply voltage in a log each, were refused with "at
    least 10 are needed to split train/test" and no word of what to do: the refusal says to merge them."""
    log = tmp_path / "dyno12V.csv"
    log.write_text("# condition=dyno12V\n# kind=steady_state\n# ra_ohm=2\nt_s,duty,v_V,i_A,rpm_ref\n"
                   + "".join(f"{k}.0,1.000,12.00,{0.2 + 0.1 * k:.3f},{300 - 5 * k}\n" for k in range(7)))
    assert gen_weights.main([str(log), "--out", str(tmp_path / "o"), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "dyno12V.csv" in err and "only 7 usable rows" in err and "put its rows into one log" in err
    assert not (tmp_path / "o").exists()
    # ... and where the table declares no kind but a made-up clock, read as a table from its rows (dataset.kind)
    log.write_text("# condition=dyno12V\n# sample_rate_hz=1\n# ra_ohm=2\nt_s,duty,v_V,i_A,rpm_ref\n"
                   + "".join(f"{k}.0,1.000,12.00,{0.2 + 0.1 * k:.3f},{300 - 5 * k}\n" for k in range(7)))
    assert gen_weights.main([str(log), "--out", str(tmp_path / "o"), "--quiet"]) == 1
    assert "put its rows into one log" in capsys.readouterr().err


def _dyno_48v(path, declared: str = ""):
    """A dyno table of a 48 V motor (Ra 2 ohm, Ke 0.12 V s/rad): settled points at 47 V, beyond the board's
    40 V full scale."""
    lines = ["# condition=dyno47V", "# kind=steady_state"] + ([declared] if declared else []) + [
        "t_s,duty,v_V,i_A,rpm_ref"]
    for k in range(30):
        i = 0.2 + 0.1 * k
        lines.append(f"{k},1,47.0,{i:.3f},{(47.0 - 2.0 * i) / 0.12 * 60 / (2 * np.pi):.2f}")
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_bench_declares_its_channels_full_scale(tmp_path, capsys):
    """The board reads 40 V; a 48 V motor's bench reads further with its own divider. Undeclared, its rows are
    beyond the channel's full scale and the refusal says which key declares the bench's; declared
    (v_full_scale_V), they are readings: diagnosed, and a model trained on them accepts as far on the board."""
    log = _dyno_48v(tmp_path / "d.csv")
    assert diagnose.main([str(log), "--ra-ohm", "2", "--out", str(tmp_path / "o1"), "--quiet"]) == 1
    err = capsys.readouterr().err
    _no_traceback(err)
    assert "v_V=47 is beyond the channel's full scale (|v_V| <= 40, the board's" in err and "# v_full_scale_V=" in err
    log = _dyno_48v(tmp_path / "d.csv", "# v_full_scale_V=60")
    assert diagnose.main([str(log), "--ra-ohm", "2", "--out", str(tmp_path / "o2"), "--quiet"]) == 0
    capsys.readouterr()
    from hpddo import pipeline
    recs = dataset.load_recordings([log])
    assert pipeline.limits_of(recs).v_max_V == 60.0 and pipeline.limits_of(recs).i_max_A == dataset.LIMITS.i_max_A


def test_rows_beyond_full_scale_are_named_not_called_glitches(tmp_path, capsys):
    """A log whose current is beyond the channel's full scale on every row (a motor larger than the
    board reads, or a wrong scale) is refused for that, with the first row's line, not as a log
    of glitches."""
    log = _head(LONG, tmp_path / "big.csv", 40)
    lines = log.read_text().splitlines(keepends=True)
    head = [ln for ln in lines if ln.startswith("#")]
    body = [ln for ln in lines if not ln.startswith("#")]
    cols = body[0].strip().split(",")
    k = cols.index("i_A")
    rows = []
    for ln in body[1:]:
        f = ln.rstrip("\n").split(",")
        f[k] = "250"
        rows.append(",".join(f) + "\n")
    log.write_text("".join(head) + body[0] + "".join(rows))
    assert gen_weights.main([str(log), "--out", str(tmp_path / "o"), "--quiet"]) == 1
    err = capsys.readouterr().err
    _no_traceback(err)
    first = len(head) + 2  # the header line, then the first row
    assert "big.csv" in err and "40 beyond a channel's full scale" in err and f"line {first}: i_A=250" in err, err
    assert "departing" not in err, err


def test_a_wrong_ra_is_named_as_such(tmp_path, capsys):
    out = tmp_path / "o"
    assert gen_weights.main([*map(str, DATA), "--out", str(out), "--ra-ohm", "34", "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "Ra = 34 ohm" in err and "too large" in err and "--ra-ohm" in err
    assert not out.exists()


def test_demo_on_logs_without_ra_says_which_option_to_use(tmp_path, capsys):
    data = tmp_path / "data"
    data.mkdir()
    for p in DATA:
        (data / p.name).write_text("".join(ln for ln in p.read_text().splitlines(keepends=True)
                                           if not ln.startswith("# ra_ohm=")))
    out = tmp_path / "out"
    assert demo.main(["--data", str(data), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    _no_traceback(err)
    assert "--ra-ohm" in err
    assert not out.exists()
    assert "--ra-ohm" in demo.parser().format_help()


@pytest.mark.parametrize("tool", [gen_weights.parser(), diagnose.parser(), demo.parser()])
def test_every_tool_that_filters_can_keep_every_row(tool):
    assert "--no-glitch-filter" in tool.format_help()


def test_glitch_lines_are_file_lines_with_bom_and_crlf(tmp_path):
    src = DATA[-1]
    text = src.read_text()
    crlf = tmp_path / "crlf.csv"
    crlf.write_bytes(b"\xef\xbb\xbf" + text.replace("\n", "\r\n").encode())
    want = [ln for ln, _ in dataset.load_recording(src).removed]
    assert [ln for ln, _ in dataset.load_recording(crlf).removed] == want
    lines = text.splitlines()
    for ln in want:  # each named line holds a glitch value the filter's reason quotes
        cells = lines[ln - 1].split(",")
        assert len(cells) > 4


@pytest.fixture(scope="module")
def fast_logs(tmp_path_factory):
    out = tmp_path_factory.mktemp("fast")
    assert twin.main(["--protocol", "load", "--rate-hz", "1000", "--time-scale", "0.05",
                      "--out", str(out / "1k"), "--quiet"]) == 0
    assert twin.main(["--protocol", "all", "--rate-hz", "100", "--time-scale", "0.1",
                      "--out", str(out / "100"), "--quiet"]) == 0
    return out


def test_glitch_filter_is_scale_aware_at_100_hz_and_1_khz(fast_logs):
    for log in sorted(fast_logs.glob("*/*.csv")):
        if log.name.endswith(".truth.csv"):
            continue
        rec = dataset.load_recording(log)
        truth = json.loads(log.with_suffix(".truth.json").read_text())
        assert len(rec.removed) <= len(truth["glitches"]) + 0.002 * rec.rows_in_file, (log, rec.removed[:5])
        assert not rec.warnings
        if "100" in log.parent.name:  # at 100 Hz the injected glitches stand out of the noise
            lines = benchlog.read_log(log).lines
            injected = {int(lines[g["row"]]) for g in truth["glitches"]}
            assert injected <= {ln for ln, _ in rec.removed}


def test_ke_is_recovered_from_a_quantised_encoder_at_1_khz(fast_logs):
    """At 1 kHz the encoder moves in steps of about 310 RPM; window means recover the Ke
    that the true speeds give, per row."""
    import pandas as pd
    log = fast_logs / "1k" / "load.csv"
    rec = dataset.load_recording(log)
    truth = pd.read_csv(log.with_suffix(".truth.csv"))
    assert len(np.unique(rec.df["rpm_ref"].round(1))) < 10  # it is coarse
    ke = identify.m2_params([rec], 4.5).ke_vs_per_rad
    part = rec.part("train").copy()
    part["rpm_ref"] = truth["rpm_true"].to_numpy()[: rec.n_train]
    v, i, n = identify.window_means(part, window_s=0.0)
    keep = n > identify.MIN_RPM
    ke_true_speed = identify.ke_eq20(v[keep], i[keep], n[keep], 4.5)
    assert ke == pytest.approx(ke_true_speed, rel=0.01)


def test_a_loud_warning_when_the_filter_removes_many_rows(tmp_path, capsys):
    text = DATA[-1].read_text().splitlines()
    head = next(k for k, ln in enumerate(text) if not ln.startswith("#"))
    cols = text[head].split(",")
    jv, jn = cols.index("v_V"), cols.index("rpm_ref")
    out = text[: head + 1]
    for k, ln in enumerate(text[head + 1:]):
        cells = ln.split(",")
        if k % 120 == 10:  # a spike on V in one row of 120, another on the encoder
            cells[jv] = f"{float(cells[jv]) + 9.0:.6f}"
        if k % 120 == 70:
            cells[jn] = f"{float(cells[jn]) + 900.0:.3f}"
        out.append(",".join(cells))
    log = tmp_path / "spiky.csv"
    log.write_text("\n".join(out) + "\n")
    rec = dataset.load_recording(log)
    assert len(rec.removed) >= 10
    assert rec.warnings and "--no-glitch-filter" in rec.warnings[0]
    assert gen_weights.main([str(log), *map(str, DATA[:2]), "--out", str(tmp_path / "o"), "--quiet",
                             "--epochs", "1"]) == 0
    assert "WARNING" in capsys.readouterr().err
    assert len(dataset.load_recording(log, glitch_filter=False).removed) == 0


def _set_column(src: pathlib.Path, dst: pathlib.Path, col: str, value, rows: int = 600) -> pathlib.Path:
    lines = src.read_text().splitlines()
    head = next(k for k, ln in enumerate(lines) if not ln.startswith("#"))
    j = lines[head].split(",").index(col)
    out = lines[: head + 1]
    for ln in lines[head + 1: head + 1 + rows]:
        cells = ln.split(",")
        cells[j] = value
        out.append(",".join(cells))
    dst.write_text("\n".join(out) + "\n")
    return dst


def test_absurd_speeds_and_two_test_rows_give_named_errors_or_results(tmp_path, capsys):
    """Probe cases: an encoder reading 1e9 RPM (Ke of 1e-8 V s/rad) and a 10-row log (two
    held-out rows) once ended the diagnosis in a traceback."""
    huge = _set_column(LONG, tmp_path / "huge.csv", "rpm_ref", "1e9")
    assert diagnose.main([str(huge), "--out", str(tmp_path / "d1"), "--bootstrap", "0", "--no-hybrid"]) in (0, 1)
    _no_traceback(capsys.readouterr().err)
    ten = _head(LONG, tmp_path / "ten.csv", 10)
    assert diagnose.main([str(ten), "--out", str(tmp_path / "d2"), "--bootstrap", "0", "--no-hybrid"]) == 1
    err = capsys.readouterr().err
    assert "held-out rows" in err and "ten.csv" in err
    assert not (tmp_path / "d2").exists()


def test_temperatures_outside_the_sensor_range_cost_no_rows(tmp_path):
    log = _set_column(LONG, tmp_path / "hot.csv", "temp_C", "300")
    rec = dataset.load_recording(log)
    assert rec.n == 600 and not rec.removed
    assert rec.warnings and "not read" in rec.warnings[0]
    assert np.isnan(dataset.temp_read_C(rec)).all()


@pytest.mark.parametrize("value", ["0", "-4", "nan", "abc"])
def test_a_bad_ra_in_the_metadata_names_the_file(tmp_path, capsys, value):
    log = tmp_path / "r.csv"
    log.write_text(LONG.read_text().replace("# ra_ohm=4.50", f"# ra_ohm={value}"))
    assert gen_weights.main([str(log), "--out", str(tmp_path / "o"), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "r.csv" in err and "ra_ohm" in err


# What a spreadsheet's export does to a log, named as such (the fault keyword stays the
# format's, which the C++ reader shares).
EXPORTS = {
    "semicolons": ("t_s;duty;v_V;i_A;rpm_ref\n0,0;0,2;2,3;0,1;40\n", 1, "separated by semicolons"),
    "tabs": ("t_s\tduty\tv_V\ti_A\n0\t0.2\t2.3\t0.1\n", 1, "separated by tabs"),
    "quoted header": ('"t_s","duty","v_V","i_A"\n0.0,0.2,2.3,0.1\n', 1, "in quotes"),
    "decimal commas": ('t_s,duty,v_V,i_A\n"0,0","0,2","2,3","0,1"\n', 2, "decimal commas"),
}


@pytest.mark.parametrize("case", sorted(EXPORTS))
def test_a_spreadsheet_export_is_named_for_what_it_is(case, tmp_path, capsys):
    text, line, words = EXPORTS[case]
    log = tmp_path / "export.csv"
    log.write_text(text)
    out = tmp_path / "o"
    assert gen_weights.main([str(log), "--out", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err
    _no_traceback(err)
    assert f"{log}:{line}:" in err and words in err, err
    assert not out.exists()


def test_a_reading_beyond_full_scale_is_refused_without_the_glitch_filter(tmp_path, capsys):
    """One voltage of 1e30 kept by --no-glitch-filter identified Ke of about 8e25 V s/rad and
    exported the model; now it is refused with its line, and the filter removes it."""
    lines = DATA[-1].read_text().splitlines(keepends=True)
    head = next(k for k, ln in enumerate(lines) if ln.startswith("t_s"))
    cols = lines[head].strip().split(",")
    row = lines[head + 50].rstrip("\n").split(",")
    row[cols.index("v_V")] = "1e30"
    lines[head + 50] = ",".join(row) + "\n"
    log = tmp_path / "big.csv"
    log.write_text("".join(lines))
    out = tmp_path / "o"
    assert gen_weights.main([str(log), "--out", str(out), "--quiet", "--no-glitch-filter", "--epochs", "1"]) == 1
    err = capsys.readouterr().err
    _no_traceback(err)
    assert f"{log}:{head + 51}:" in err and "v_V=1e+30" in err and "full scale" in err, err
    assert not out.exists()
    rec = dataset.load_recording(log)
    assert (head + 51) in [ln for ln, _ in rec.removed]
    assert float(np.abs(rec.df["v_V"]).max()) <= dataset.LIMITS.v_max_V


@pytest.mark.slow
def test_no_progress_bar_goes_into_a_redirected_log(tmp_path):
    """Off a terminal (a log file, a pipe, CI) the progress bars stay quiet: a training run's
    stderr holds lines, not hundreds of carriage-return updates."""
    import subprocess
    import sys
    res = subprocess.run([sys.executable, "-m", "hpddo", "train", str(DATA[-1]), "--out", str(tmp_path / "m"),
                          "--epochs", "400"], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    assert "\r" not in res.stderr and "epoch/s" not in res.stderr, res.stderr[:500]
    assert "RMSE" in res.stdout


def test_a_reader_that_leaves_the_pipe_ends_the_command_without_a_traceback(monkeypatch, capsys):
    """`hpddo diagnose ... | head`: the reader left after the first line, and the next print raised BrokenPipeError
    out of the command as a traceback (its files were whole). It ends with 141, as a shell reports it, and no text."""
    import argparse
    import types

    from hpddo import cli

    def run(args):
        raise BrokenPipeError(32, "Broken pipe")

    fake = types.SimpleNamespace(parser=lambda prog: argparse.ArgumentParser(prog=prog), run=run)
    monkeypatch.setattr(cli, "_module", lambda name: fake)
    assert cli.run("diagnose", []) == cli.BROKEN_PIPE_STATUS
    out = capsys.readouterr()
    assert "Traceback" not in out.err + out.out
