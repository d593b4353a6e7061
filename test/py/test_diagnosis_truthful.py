"""Issue 21: no verdict states a value outside what the data determine. Every fitted
quantity carries a 95 % interval from the data (diagnosis/intervals.py) or is reported as
"not determined by these recordings" with the measurement that would determine it; Ra is
said as the data alone put it (no prior around the reading). Twin tables (30 rows, Ra 10 %
off either way, a brush drop with Ra 10 % high) and the bundled recordings with a reading
ten times too low."""
import json
import dataclasses
import math
import pathlib
import re

import pytest

from conftest import ROOT
from twin_benches import RA_OHM, dyno_table

from hpddo.cli import diagnose as diagnose_cli
from hpddo.diagnosis import core, intervals, ranking
from hpddo.model import effects as fx

BUNDLED = [ROOT / "data" / "default" / f"{n}.csv" for n in ("load", "long", "sweep")]


def diagnose(paths, ra):
    return core.diagnose(paths, core.Options(bootstrap=0, hybrid=False, ra_ohm=ra))


def check_truthful(d):
    """What every diagnosis must hold to: no value stated as supported where the data do not
    determine it; every undetermined quantity said so, with what would determine it."""
    res = d.to_json()
    text = diagnose_cli.summary(d)
    assert "the data support" not in text, text
    for iv in res["intervals"] + [res["ra_fit"]["data_alone"]]:
        if iv is None:
            continue
        if iv["determined"]:
            assert iv["lo"] <= iv["value"] <= iv["hi"], iv
        else:
            assert "not determined by these recordings" in iv["text"] and iv["needs"], iv
    ra = res["ra_fit"]
    if not ra["determined"]:
        assert "Ra is not determined by these recordings" in text and intervals.RA_NEEDS in text, text
        assert not ra["mismatch"], ra
    return res, text


def test_a_reading_ten_times_too_low_is_said_with_the_ra_the_data_determine():
    """Before: "the data support 1.35 ohm, +40 x the tolerance: no mismatch" (the prior's bound
    at three times the reading). Now: the data alone put Ra at 5.29 ohm (5.26..5.33) with the
    plain model (measured), and the verdict says the reading is not what they show."""
    d = diagnose(BUNDLED, 0.45)
    res, text = check_truthful(d)
    alone = res["ra_fit"]["data_alone"]
    assert alone["determined"] and alone["lo"] > 3 * 0.45 * (1 + 3 * ranking.RA_TOLERANCE), alone
    assert res["verdict"].startswith("The Ra you gave (0.45 ohm) is not what these recordings show"), res["verdict"]
    # the value to pass only where the named effects leave no structured residual (the bundled recordings' heating
    # does at this reading: the data-alone Ra is then the warm winding's, not one to pass)
    if res["ra_fit"]["residual_left"]:
        assert "--ra-ohm" not in res["verdict"] and "re-measure it; these recordings give no Ra to pass" in res["verdict"]
    else:
        assert f"--ra-ohm {alone['value']:.3g}" in res["verdict"]
    assert "no mismatch" not in text
    assert res["ra_fit"]["supported_at_bound"]  # the prior's fit at 3x the reading is flagged as its edge


@pytest.mark.parametrize("seed", (3, 4))
@pytest.mark.parametrize("factor", (0.9, 1.1))
def test_a_30_row_table_with_ra_10_percent_off_says_only_what_it_determines(tmp_path, seed, factor):
    """A 30-row table cannot show a 10 % Ra error reliably (docs/diagnosis.md: reported in 1 of
    10 tables): the interval it gives for Ra holds the true 4.5 ohm, and a mismatch is said
    only where that interval excludes the reading's band."""
    d = diagnose([dyno_table(tmp_path / "dyno30.csv", 30, seed)], RA_OHM * factor)
    res, text = check_truthful(d)
    ra = res["ra_fit"]
    alone = ra["data_alone"]
    assert alone["lo"] <= RA_OHM <= alone["hi"], alone
    if not (alone["lo"] > ra["given_ohm"] * 1.05 or alone["hi"] < ra["given_ohm"] * 0.95):
        assert not ra["mismatch"] and "consistent with the reading" in ra["statement"], ra["statement"]
    assert all(iv["determined"] for iv in res["intervals"] if iv["quantity"] == "Ke")


@pytest.mark.parametrize("seed", (3, 4))
def test_a_brush_drop_with_ra_10_percent_high_is_never_a_bounded_fit_stated_as_fact(tmp_path, seed):
    """A 0.3 V brush drop on a table whose currents have one sign is a constant drop, a
    voltage offset, a current offset through Ra and (with the wrong reading) an Ra error
    alike: whatever is named is said with its interval and the confounding; a wrong Ra is
    never called right at a fit's bound."""
    d = diagnose([dyno_table(tmp_path / "brush30.csv", 30, seed, brush_V=0.3)], RA_OHM * 1.1)
    res, text = check_truthful(d)
    ra = res["ra_fit"]
    assert (res["missing_effects"] or ra["mismatch"] or ra["confounded_with"]
            or res["verdict"].startswith("No library effect is named. Whether anything is missing below")), \
        res["verdict"]
    if ra["confounded_with"]:
        assert "cannot tell a wrong Ra from" in res["verdict"] or "explains as well as" in res["verdict"]
    for e in res["ranking"]:  # a named coefficient is said with its interval, or as not determined
        if e["named"]:
            iv = e["intervals"][0]
            assert iv["quantity"] == e["effect"]
            assert (f"{e['effect']} ({e['shown']}, 95 % interval" in res["verdict"] if iv["determined"] else
                    "its size is not determined by these recordings" in res["verdict"]), res["verdict"]


def test_a_fit_at_its_bound_is_not_determined(tmp_path):
    """A table of a motor whose speed does not fall with the current (Ra 0 ohm behind a 4.5 ohm
    reading): Ra from the data alone goes to the edge of the range searched, which is said as
    "not determined", never as a value, and no mismatch is named from it."""
    path = _cells(dyno_table(tmp_path / "t.csv", 30, 3), tmp_path / "flat.csv", "rpm_ref",
                  lambda x, c: f"{float(c[2]) / 0.4 * 60 / (2 * math.pi):.2f}")  # the speed as if Ra were zero
    d = diagnose([path], RA_OHM)
    res, text = check_truthful(d)
    alone = res["ra_fit"]["data_alone"]
    assert not alone["determined"] and "edge of the range allowed" in alone["why"], alone


def test_intervals_cover_a_known_linear_fit():
    """The interval of a fit whose answer is known: y = 2 x + noise over 40 operating points
    of 10 rows, the 95 % interval of the slope holds 2 and is about 1.96 standard errors wide."""
    import numpy as np
    rng = np.random.default_rng(5)
    x = np.repeat(np.linspace(1, 4, 40), 10)
    e = rng.normal(0, 0.5, len(x))
    groups = np.repeat(np.arange(40), 10)
    cov, df, method = intervals.covariance(x[:, None], e - x * np.dot(x, e) / np.dot(x, x), groups)
    se = math.sqrt(cov[0, 0])
    se_ols = 0.5 / math.sqrt(np.dot(x, x))
    assert se == pytest.approx(se_ols, rel=0.3) and df == 39 and "cluster" in method


def _html(tmp_path, d):
    from hpddo.reports import diagnosis as report
    out = tmp_path / "report"
    out.mkdir()
    report.write(out, d.to_json(), d.plot())
    return (out / "index.html").read_text()


def test_a_declared_steady_state_table_has_no_lag_didt_or_whiteness_statistics(tmp_path):
    """`# kind=steady_state` (docs/bench-log.md): no whiteness test is printed (the page says
    why), the residual is correlated with the inputs at lag 0 only and never with dI/dt, and
    the header states the hold-out scheme actually used (cross-validation)."""
    log = dyno_table(tmp_path / "dyno40.csv", 40, 3, meta=("kind=steady_state", "sample_rate_hz=1"))
    d = diagnose([log], RA_OHM)
    res = d.to_json()
    assert res["recordings"][0]["kind"] == "steady_state" and res["recordings"][0]["kind_source"] == "declared"
    for key in ("residual_before", "residual_after"):
        w = res[key]["whiteness"]
        assert w["white"] is None and w["q"] is None and "no clock" in w["not_computed"]
        assert res[key]["correlates"] and all(len(c["ccf"]) == 1 and c["peak_lag"] == 0
                                              for c in res[key]["correlates"])
        assert "dI/dt" not in [c["input"] for c in res[key]["correlates"]]
    assert "inductance" in [u["effect"] for u in res["not_identifiable"]]  # dI/dt is 0 on settled rows
    html = _html(tmp_path, d)
    assert "Ljung-Box" not in html and "no whiteness test: a steady-state table has no clock" in html
    assert "Held-out rows: every row once, 5 folds of whole operating points (cross-validation)" in html
    assert "the last 20 %" not in html.split("<h2>")[0]


def test_a_table_that_repeats_its_points_measures_its_noise_there(tmp_path):
    """Every operating point logged twice (two draws of the same 40-row table, interleaved):
    the floor comes from the repeats (tachometer noise 2 RPM, the channels' noise through the
    model about 0.5 RPM more), not from what the model leaves."""
    first = dyno_table(tmp_path / "a.csv", 40, 3).read_text().splitlines()
    second = dyno_table(tmp_path / "b.csv", 40, 5).read_text().splitlines()
    head = [line for line in first if not line[0].isdigit()]
    rows = [r for pair in zip(first[len(head):], second[len(head):]) for r in pair]
    rows = [f"{k:.1f}," + r.split(",", 1)[1] for k, r in enumerate(rows)]  # t_s one second apart again
    log = tmp_path / "twice.csv"
    log.write_text("\n".join(head + rows) + "\n")
    res = diagnose([log], RA_OHM).to_json()
    nf = res["noise_floor"]
    assert "repeated operating points" in nf["source"] and not nf["from_model"], nf
    assert 1.5 < nf["rpm"] < 2.8, nf
    assert res["verdict"].startswith("Nothing missing"), res["verdict"]


def test_rows_copied_by_the_logger_are_no_repeats_of_their_point(tmp_path):
    """The same twice-measured table with most rows written two or three times over, every channel the same (a
    logger that flushed each point more than once): a copy paired with its original differs by exactly zero, and
    the copies had shrunk the repeats' spread below the tachometer's noise, so the residual of the right model
    was said to stand above the floor. Each copy is taken once, and said."""
    first = dyno_table(tmp_path / "a.csv", 40, 3).read_text().splitlines()
    second = dyno_table(tmp_path / "b.csv", 40, 5).read_text().splitlines()
    head = [line for line in first if not line[0].isdigit()]
    rows = [r for pair in zip(first[len(head):], second[len(head):]) for r in pair]
    rows = [r.split(",", 1)[1] for k, r in enumerate(rows) for _ in range(1 + (k % 3 != 0) + (k % 4 == 1))]
    log = tmp_path / "copied.csv"
    log.write_text("\n".join(head + [f"{k:.1f},{r}" for k, r in enumerate(rows)]) + "\n")
    res = diagnose([log], RA_OHM).to_json()
    nf = res["noise_floor"]
    assert "repeated operating points" in nf["source"] and "row(s) that copy an earlier row" in nf["source"], nf
    assert 1.5 < nf["rpm"] < 2.8, nf
    assert res["verdict"].startswith("Nothing missing"), res["verdict"]


def test_a_bad_kind_is_refused_with_its_file_and_line(tmp_path):
    from hpddo.logs import benchlog
    log = dyno_table(tmp_path / "dyno.csv", 20, 3, meta=("kind=table",))
    with pytest.raises(benchlog.BenchLogError) as exc:
        diagnose([log], RA_OHM)
    assert exc.value.line == 3 and "kind='table' is not one of time_series, steady_state" in str(exc.value)


def test_a_time_series_page_states_the_chronological_split_and_prints_only_computed_statistics(tmp_path):
    """The bundled recordings: the header says the last 20 % (chronological), the whiteness
    test is printed with its figures, the intervals and the noise floor are on the page."""
    d = diagnose(BUNDLED, None)
    html = _html(tmp_path, d)
    assert "Held-out rows: the last 20 % of each recording (chronological)" in html
    assert "Ljung-Box Q = " in html and "Q = –" not in html and "Q = -" not in html
    assert "What the recordings determine" in html and "Ke" in html and "Noise floor" in html


def _cells(src, dst, col, value):
    """src with the cell of column col of every row replaced by value(cell, the row's cells),
    written to dst."""
    lines = src.read_text().splitlines()
    hdr = next(k for k, line in enumerate(lines) if not line.startswith("#"))
    k = lines[hdr].split(",").index(col)
    out = lines[: hdr + 1]
    for line in lines[hdr + 1:]:
        c = line.split(",")
        c[k] = value(c[k], c)
        out.append(",".join(c))
    dst.write_text("\n".join(out) + "\n")
    return dst


def _scaled(src, dst, col, factor, where=lambda cells: True):
    """src with column col multiplied by factor on the rows where(cells) holds, written to dst."""
    return _cells(src, dst, col, lambda x, c: f"{float(x) * factor:.4f}" if x and where(c) else x)


def test_an_operating_group_that_contradicts_the_table_is_named_and_the_verdict_given_without_it(tmp_path):
    """A 48-row table of 6 voltages whose 6.6 V group reads 12 % slow, Ra given 10 % low: with
    the group, the wrong Ra is not seen; the group is named with its figure (the model
    identified without it misses it by 18.3 RPM, the others by 3.8, measured), and without it
    the verdict finds the wrong Ra."""
    log = _scaled(dyno_table(tmp_path / "t.csv", 48, 3), tmp_path / "dyno48.csv", "rpm_ref", 0.88,
                  lambda c: abs(float(c[1]) - 0.55) < 0.01)
    res = diagnose([log], RA_OHM * 0.9).to_json()
    odd = [u for u in res["consistency"]["units"] if u["inconsistent"]]
    assert [u["name"] for u in odd] == ["dyno48 duty 0.55"], res["consistency"]
    assert odd[0]["rmse_rpm"] > 3 * odd[0]["others_rpm"]
    assert "Checked before ranking: operating group dyno48 duty 0.55 disagrees with the rest" in res["verdict"]
    without = res["consistency"]["without"]
    # with the group, Ra is not questioned; without it, the wrong Ra is said (named, or not told
    # apart from an effect that would hold the reading)
    assert not res["ra_fit"]["mismatch"] and not res["ra_fit"]["confounded_with"], res["ra_fit"]
    assert without["unit"] == "dyno48 duty 0.55", without
    assert without["ra_fit"]["mismatch"] or without["ra_fit"]["confounded_with"], without
    assert "a wrong Ra" in without["verdict"] or "The Ra you gave (4.05 ohm)" in without["verdict"], without


def test_a_recording_whose_encoder_is_off_is_named(tmp_path):
    """Twin recordings of the ideal bench (seed 3), the load recording's speed 10 % low (a wrong
    gear ratio): load is named (15.5 RPM by the model identified without it, the others 6.2),
    and without it nothing is missing."""
    import twin_benches
    paths = twin_benches.recordings(tmp_path / "ideal", twin_benches.bench({}), 3)
    bad = _scaled(paths[1], tmp_path / "load.csv", "rpm_ref", 0.9)
    res = diagnose([paths[0], bad, paths[2]], RA_OHM).to_json()
    # a speed scale off on one recording: named before the ranking as another motor or another scale
    # (its own Ke 1.11 times the others'), and left out of it
    others = res["consistency"]["other_motors"]
    assert [o["recording"] for o in others] == ["load"], res["consistency"]
    assert "speed scale" in others[0]["text"] and others[0]["ke_ratio"] > 1.05
    assert "Checked before ranking: recording load behaves as another motor" in res["verdict"], res["verdict"]


def test_the_bundled_recordings_agree_with_each_other():
    res = diagnose(BUNDLED, None).to_json()
    assert len(res["consistency"]["units"]) == 3 and not any(u["inconsistent"] for u in res["consistency"]["units"])
    assert res["consistency"]["without"] is None and "Checked before ranking" not in res["verdict"]


def test_a_biased_ke_by_eq20_is_said_and_least_squares_trusted(tmp_path):
    """The 48-row table whose 3 V group reads 12 % slow: eq. 20's mean of ratios weighs that
    slow group as much as the fast ones; the model under test misses the held-out rows by
    5.85 RPM, with Ke by least squares by 3.42 (measured); its residual correlates with its own
    speed estimate (r = +0.80 against +0.51 with least squares). The verdict says so and which
    Ke to trust; with --ke-fit lsq the model under test is the better one and no advice is given."""
    log = _scaled(dyno_table(tmp_path / "t.csv", 48, 3), tmp_path / "dyno48.csv", "rpm_ref", 0.88,
                  lambda c: abs(float(c[1]) - 0.25) < 0.01)
    eq20 = core.diagnose([log], core.Options(bootstrap=0, hybrid=False)).to_json()
    k = eq20["ke_check"]
    assert k["disagree"] and k["biased"] and k["rmse_lsq_rpm"] < 0.7 * k["rmse_model_rpm"], k
    assert k["speed_r_lag0"] > k["speed_r_lag0_lsq"] + 0.2, k
    assert "the mark of a biased Ke" in eq20["verdict"] and "Trust least squares (--ke-fit lsq)" in eq20["verdict"]
    # each method's interval is its scatter under the model under test, not an interval of the motor's Ke: the
    # verdict prints the two values alone, the JSON says what its intervals are
    assert re.search(r"Ke by eq\. 20 \([0-9.e-]+ V s/rad\) and by least squares \([0-9.e-]+ V s/rad, [+-][0-9.]+%\) disagree",
                     eq20["verdict"]), eq20["verdict"]
    assert "not an interval of the motor's Ke" in k["scope"]
    from hpddo.cli import diagnose as cli
    args = cli.parser().parse_args([str(log), "--out", str(tmp_path / "o"), "--ke-fit", "lsq"])
    lsq = core.diagnose([log], dataclasses.replace(cli.options_of(args), bootstrap=0, hybrid=False)).to_json()
    assert lsq["ke_check"]["ke_fit"] == "lsq" and "Trust least squares" not in lsq["verdict"]
    assert lsq["rmse_rpm"]["before"]["average"] < eq20["rmse_rpm"]["before"]["average"]


def test_the_bundled_ke_needs_no_remark():
    """eq. 20 and least squares on the bundled recordings: 9.29 against 8.75 RPM held out, within
    KE_DISAGREE_REL; the residual's correlation with speed (+0.37) is the missing thermal
    effects', which least squares leaves (+0.33): no remark on Ke."""
    k = diagnose(BUNDLED, None).to_json()["ke_check"]
    assert not k["disagree"] and not k["biased"] and k["text"] == "", k


CURRENT_CANNOT = "Ra and every effect that acts through the current"


@pytest.mark.parametrize("fault, value, figure", [
    ("stuck", lambda x, c: "0.15", "1 distinct values over 30 driven rows at 6 duties"),
    ("saturated", lambda x, c: f"{min(float(x), 0.16):.4f}", "8 of 30 driven rows read exactly 0.16 (top of its range) over 6 different commands"),
    ("too coarse", lambda x, c: f"{round(float(x) / 0.05) * 0.05:.4f}", "steps of 0.05 over a range of 0.1: 2 levels"),
])
def test_a_faulty_current_channel_of_a_table_is_named_with_what_cannot_be_concluded(tmp_path, fault, value, figure):
    log = _cells(dyno_table(tmp_path / "t.csv", 30, 3), tmp_path / "dyno30.csv", "i_A", value)
    res = diagnose([log], RA_OHM * 0.9).to_json()
    assert [(f["channel"], f["fault"], f["figure"]) for f in res["channels"]] == [("current", fault, figure)]
    assert f"Channel health: the current channel of dyno30 is {fault} ({figure}): {CURRENT_CANNOT}" in res["verdict"]


def test_a_current_channel_that_explains_nothing_of_the_load_is_named(tmp_path):
    """Twin recordings of the ideal bench, the load recording's current replaced by 0.3 A and
    10 mA of noise: at each duty the speed varies with the load by 3.8 RPM RMS beyond the
    voltage (measured), of which the current takes nothing."""
    import numpy as np
    import twin_benches
    rng = np.random.default_rng(1)
    paths = twin_benches.recordings(tmp_path / "ideal", twin_benches.bench({}), 3)
    dead = _cells(paths[1], tmp_path / "load.csv", "i_A", lambda x, c: f"{0.3 + rng.normal(0, 0.01):.6f}")
    res = diagnose([paths[0], dead, paths[2]], RA_OHM).to_json()
    faults = [(f["recording"], f["channel"], f["fault"]) for f in res["channels"]]
    assert faults == [("load", "current", "explains nothing of the load")], res["channels"]
    assert "the current channel of load explains nothing of the load" in res["verdict"]
    assert diagnose(BUNDLED, None).to_json()["channels"] == []


def test_a_current_that_moves_with_the_voltage_is_no_dead_channel(tmp_path):
    """Dyno tables at one supply each, the terminal voltage sagging with the load through the driver's 0.8 ohm (V and
    I a straight line of each other, r = -0.9999): the voltage carries the load as the current does, and the speed's
    variation beyond it (the winding's heating, i^2) is nobody's to explain linearly; the current channel is no
    fault (an independent simulator's table: "the current channel ... explains nothing of the load", with Ra and every
    effect through the current set aside). The check still names the dead channel of the test above."""
    import numpy as np

    rng = np.random.default_rng(3)
    paths = []
    for vs in (8.0, 10.0, 12.0):
        rows = []
        for k in range(25):
            i = 0.1 + 1.9 * k / 24 * vs / 12
            v = vs - 0.8 * i
            ra_hot = 3.0 * (1 + 0.00393 * 8.0 * i * i * 3.0)
            rpm = (v - i * ra_hot) / 0.05 * 60 / (2 * math.pi) + rng.normal(0, 1.0)
            rows.append(f"{k:.1f},1.0,{v + rng.normal(0, 0.002):.4f},{i + rng.normal(0, 0.0005):.5f},{rpm:.1f}")
        p = tmp_path / f"dyno{int(vs)}V.csv"
        p.write_text(f"# condition=dyno{int(vs)}V\n# kind=steady_state\nt_s,duty,v_V,i_A,rpm_ref\n" + "\n".join(rows) + "\n")
        paths.append(p)
    res = diagnose(paths, 3.0).to_json()
    assert not [f for f in res["channels"] if f["channel"] == "current"], res["channels"]
    assert CURRENT_CANNOT not in res["verdict"], res["verdict"]


@pytest.mark.slow
def test_an_independent_sagging_supply_table_keeps_its_current_channel():
    """An independent simulator's dyno tables, one supply each, the voltage sagging with the load through the
    driver (test/fixtures/independent/sagsupply08, its README; Ra given 7.8 % high): no channel fault, nothing named
    that the bench does not have, and any Ra the verdict says the data support within 10 % of the truth (it said
    3.93 ohm against the true 3.95, with saturation and the copper's heating named)."""
    d = ROOT / "test" / "fixtures" / "independent" / "sagsupply08"
    truth = json.loads((d / "truth.json").read_text())
    res = diagnose(sorted(d.glob("dyno*.csv")), truth["bench"]["ra_given"]).to_json()
    assert res["channels"] == [], res["channels"]
    assert set(res["missing_effects"]) <= set(truth["effects_present"]), res["verdict"]
    ra = res["ra_fit"]
    if ra.get("mismatch"):
        assert abs(ra["supported_ohm"] / truth["Ra_true_at_ref"] - 1.0) < 0.10, ra


def test_what_ke_absorbs_is_said_when_nothing_is_named(tmp_path):
    """A 60-row table of a motor with saturation of the wrong sign (Ke rising 3 %/A): at the
    noise floor, nothing is named; the verdict says that these recordings would not show a
    saturation up to 6.5 %/A (measured: 2.5 standard errors with Ke fitted alongside, which
    takes up more than 90 % of its speed error), so the hidden one stays Ke's."""
    log = _cells(dyno_table(tmp_path / "t.csv", 60, 3), tmp_path / "sat.csv", "rpm_ref",
                 lambda x, c: f"{float(x) / (1 + 0.03 * float(c[3])):.2f}")
    res = diagnose([log], RA_OHM).to_json()
    assert res["missing_effects"] == [], res["verdict"]
    m = re.search(r"these recordings would not show .*saturation up to ([0-9.]+) %/A", res["verdict"])
    assert m and float(m.group(1)) > 3.0, res["verdict"]


def _supply_per_log_table(folder, seed=5):
    """A dyno table as users convert one: a log per supply voltage (5-12 V, fixed), 20 settled load
    points each at a made-up 1 s clock, no kind line; a 10.5 ohm winding that heats with i^2 at each
    point (copper, 6 K/W), a 0.6 V brush drop, Ke 0.95 V s/rad, a 0.8 RPM tachometer."""
    import numpy as np

    rng = np.random.default_rng(seed)
    paths = []
    for v in (5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0):
        rows = []
        for k in range(20):
            i = 0.05 + 0.6 * k / 19 * v / 12
            ra_hot = 10.5 * (1 + 0.00393 * 6.0 * i * i * 10.5)
            rpm = (v - i * ra_hot - 0.6) / 0.95 * 60 / (2 * math.pi) + rng.normal(0, 0.8)
            rows.append(f"{k},{k:.1f},1.0,{v + rng.normal(0, 0.005):.4f},{i + rng.normal(0, 0.002):.4f},{rpm:.2f},25.0")
        p = folder / f"v{int(v)}.csv"
        p.write_text(f"# condition=v{int(v)}\nseq,t_s,duty,v_V,i_A,rpm_ref,temp_C\n" + "\n".join(rows) + "\n")
        paths.append(p)
    return paths


def test_ke_reaches_over_the_models_the_data_did_not_exclude(tmp_path):
    """Where the verdict says a wrong Ra explains the rows as well as other effects, so that none of them is
    named, Ke is Ke of one of the models that explain the rows: its interval reaches over theirs
    (core.alternative_models, the model part of its budget) and covers the true 0.95 V s/rad (it was 0.967..1.154
    about 1.061, the model part 0). (With the table's floor bounded by the model with every library effect, 0.7 RPM
    against the tachometer's 0.8, the brush drop is named; before, under the plain model's own out-of-fold floor,
    it was one of the effects a wrong Ra stood in for.)"""
    d = diagnose(_supply_per_log_table(tmp_path), 10.5)
    res, _ = check_truthful(d)
    assert res["ra_fit"]["confounded_with"], res["verdict"]
    assert set(res["missing_effects"]) <= {"brush_drop", "thermal_ra"}, res["verdict"]
    ke = next(iv for iv in res["intervals"] if iv["field"] == "ke_vs_per_rad")
    assert ke["determined"] and ke["budget"]["model"] > 0, ke
    assert ke["lo"] <= 0.95 <= ke["hi"], ke


def _settled_log(folder, name, v, currents, rpm_of, rng):
    """A steady-state dyno log (kind declared) at supply v: one settled row a current of currents, the speed
    rpm_of(i) and a 1 RPM tachometer, the channels read to 2 mV and 0.5 mA. Built without the twin."""
    rows = [f"{k:.1f},0.75,{v + rng.normal(0, 0.002):.4f},{i + rng.normal(0, 0.0005):.5f},"
            f"{rpm_of(i) + rng.normal(0, 1.0):.1f}" for k, i in enumerate(currents)]
    p = folder / f"{name}.csv"
    p.write_text(f"# condition={name}\n# kind=steady_state\nt_s,duty,v_V,i_A,rpm_ref\n" + "\n".join(rows) + "\n")
    return p


def _rpm(v, ra, ke, drop=0.0):
    """The law the independent tables are written with: (v - i ra - drop) / ke in RPM, a function of i."""
    return lambda i: (v - i * ra - drop) / ke * 60 / (2 * math.pi)


def _constant_drop_table(folder, seed=1):
    """A dyno table at three supplies (6, 9, 12 V), 30 settled points each (0.09-0.9 A at 12 V), every current
    far above a brush's knee: Ra 2 ohm, Ke 0.03 V s/rad, a constant 0.6 V brush drop."""
    import numpy as np

    rng = np.random.default_rng(seed)
    return [_settled_log(folder, f"dyno{int(v)}V", v, 0.09 + 0.81 * np.arange(30) / 29 * v / 12,
                         _rpm(v, 2.0, 0.03, 0.6), rng) for v in (6.0, 9.0, 12.0)]


def test_between_effects_the_data_cannot_tell_apart_the_plausible_one_is_named(tmp_path):
    """ranking.plausible_first: a constant 0.6 V brush drop, every current far above the knee, is a 0.6 V
    voltage offset too. The offset won the selection's step by the knee's last digits, was then left unnamed
    as beyond what a bench's electronics hold, and the verdict said nothing was named, "nothing to add",
    with the residual 12x the floor (an independent simulator's dyno table). Now the brush drop is named,
    its interval and Ke's holding the truth.""" 
    d = diagnose(_constant_drop_table(tmp_path), 2.0)
    res, text = check_truthful(d)
    assert res["missing_effects"] == ["brush_drop"], res["verdict"]
    brush = next(iv for iv in res["intervals"] if iv["field"] == "brush_V")
    assert brush["lo"] <= 0.6 <= brush["hi"], brush
    ke = next(iv for iv in res["intervals"] if iv["field"] == "ke_vs_per_rad")
    assert ke["lo"] <= 0.03 <= ke["hi"], ke


def _two_motors_table(folder, seed=21):
    """Dyno tables of 30 settled points (0.09-0.9 A): one motor (Ra 2 ohm, Ke 0.03 V s/rad) at 6 and 12 V,
    and at 9 V one whose Ke is 13 % lower."""
    import numpy as np

    rng = np.random.default_rng(seed)
    return [_settled_log(folder, name, v, 0.09 + 0.81 * np.arange(30) / 29, _rpm(v, 2.0, ke), rng)
            for v, ke, name in ((12.0, 0.03, "dyno12V"), (6.0, 0.03, "dyno6V"), (9.0, 0.0261, "dyno9V_b"))]


def test_a_recording_of_another_motor_among_three_is_named_where_the_others_agree(tmp_path):
    """core.other_motors: with three recordings, each other's left-out miss is scored by a model that holds the
    odd one, so one of another motor spoiled the others' misses as much as its own (357 RPM against 262) and
    nothing was named, Ke read between the two motors (an independent simulator's table). The two of the first
    motor agree among themselves to a few RPM: the third is named, left out, and Ke is the first motor's."""
    d = diagnose(_two_motors_table(tmp_path), 2.0)
    res, text = check_truthful(d)
    assert [o["recording"] for o in res["consistency"]["other_motors"]] == ["dyno9V_b"], text
    ke = next(iv for iv in res["intervals"] if iv["field"] == "ke_vs_per_rad")
    assert ke["lo"] <= 0.03 <= ke["hi"], ke


def _one_supply_table(folder, seed=15):
    """A clean dyno table at 12 V: 40 load points (0.09-0.9 A), each settled five times; Ra 2 ohm, Ke 0.03
    V s/rad, no effect."""
    import numpy as np

    rng = np.random.default_rng(seed)
    return [_settled_log(folder, "dyno12V", 12.0, 0.09 + 0.81 * (np.arange(200) // 5) / 39, _rpm(12.0, 2.0, 0.03),
                         rng)]


@pytest.mark.parametrize("factor", [1.05, 0.95])
def test_an_effect_a_wrong_ra_within_its_tolerance_explains_is_not_named(tmp_path, factor):
    """core.through_zero: at one supply a wrong Ra is a voltage offset or gain (V - I Ra: Ke and the intercept
    trade), so on a clean table with Ra given 5 % off an independent simulator's run named a v_offset of -583 mV
    and, another, a v_gain of +4.9 %, which no channel had. Their intervals held zero once the reading's tolerance
    was counted: now they are not named, and the verdict says a wrong Ra explains the rows as well."""
    d = diagnose(_one_supply_table(tmp_path), 2.0 * factor)
    res, text = check_truthful(d)
    assert not res["missing_effects"], res["verdict"]


def _saturated_drop_table(folder, seed=7):
    """Dyno tables at 6, 10 and 14 V, 20 settled points each (0.1-2 A), no point repeated: Ra 2 ohm, Ke 0.03 V
    s/rad weakened 3 % per ampere (saturation), a constant 0.5 V brush drop."""
    import numpy as np

    rng = np.random.default_rng(seed)

    def law(v):
        return lambda i: (v - i * 2.0 - 0.5) / (0.03 * (1 - 0.03 * i)) * 60 / (2 * math.pi)

    return [_settled_log(folder, f"dyno{int(v)}V", v, 0.1 + 1.9 * np.arange(20) / 19, law(v), rng)
            for v in (6.0, 10.0, 14.0)]


def test_a_table_without_repeats_has_no_floor_made_of_the_effects_it_holds(tmp_path):
    """noise.floor's cap (core.all_effects_floor): a table that repeats no point has no floor but a model's
    out-of-fold residual. The plain model's held 73 RPM of saturation and brush drop (an independent simulator's
    table, Ra given 5 % high), and the verdict called the residual 0.5x the noise above that floor. The model with
    every library effect leaves a few RPM out of fold: the floor is that (the tachometer's 1 RPM and the readings'
    steps beneath it), and the residual the plain model leaves is said to be far above it. Since the selection
    tries pairs where the library explains most of what is left (ranking._look_ahead), it names the saturation and
    the brush drop the table holds, and the floor is what that model leaves out of fold, the tachometer's 1 RPM."""
    d = diagnose(_saturated_drop_table(tmp_path), 2.1)
    res, text = check_truthful(d)
    floor = res["noise_floor"]
    assert floor["from_model"], floor
    assert "every library effect" in floor["source"] or {"saturation", "brush_drop"} <= set(res["missing_effects"])
    assert floor["rpm"] < 10.0, floor
    before = res["rmse_rpm"]["before"]["average"]
    assert before > 5 * floor["rpm"], (before, floor)
    assert "consistent with measurement noise" not in res["verdict"]


def _warm_among_cold(folder, seed=3):
    """Three cold 2 Hz recordings stepping the duty (0.4-0.9) at 25 C, and one at duty 0.9 whose case warms by
    80 K in a minute: Ra 2 ohm of copper (0.393 %/K), Ke 0.03 V s/rad, a 1 RPM tachometer."""
    import numpy as np

    rng = np.random.default_rng(seed)
    paths = []
    for name, n, warm in (("cold_a", 600, False), ("cold_b", 600, False), ("cold_c", 600, False), ("warm", 300, True)):
        k = np.arange(n)
        duty = np.full(n, 0.9) if warm else 0.4 + 0.5 * ((k // 40) % 4) / 3
        v, i = 12.0 * duty, 0.3 + 0.6 * duty + 0.05 * np.sin(k / 7.0)
        temp = 25.0 + (80.0 * (1 - np.exp(-k / 60.0)) if warm else 0.0 * k)
        rpm = (v - i * 2.0 * (1 + 0.00393 * (temp - 25.0))) / 0.03 * 60 / (2 * math.pi)
        rows = [f"{j * 0.5:.1f},{d:.3f},{a:.4f},{b:.5f},{r:.2f},{t:.2f}" for j, (d, a, b, r, t) in enumerate(zip(
            duty, v + rng.normal(0, 0.005, n), i + rng.normal(0, 0.001, n), rpm + rng.normal(0, 1.0, n), temp))]
        p = folder / f"{name}.csv"
        p.write_text(f"# condition={name}\n# sample_rate_hz=2\n# ra_ohm=2.0\nt_s,duty,v_V,i_A,rpm_ref,temp_C\n"
                     + "\n".join(rows) + "\n")
        paths.append(p)
    return paths


def test_a_recording_that_alone_shows_an_effect_is_no_disagreement_where_nothing_is_named(tmp_path, monkeypatch):
    """core.consistency where nothing is named: the only warm-up, missed by every model fitted without it, is
    judged by the joint model with every library effect, which fits it with the rest (the copper's heating).
    On an independent simulator's 2 Hz bench whose transients kept every effect from helping the held-out rows,
    the only warm-up was called a recording that disagrees with the rest. Here every alternative is made to miss
    (as there), so the joint fit alone decides."""
    inp = core.load(_warm_among_cold(tmp_path), core.Options(bootstrap=0, hybrid=False))
    mf = core.fit_model(inp)
    monkeypatch.setattr(core, "alternative_misses", lambda *a, **k: iter([(math.inf, 1.0)]))
    units = {u.name: u for u in core.consistency(inp, mf.sigma2, names=[])}
    assert units["warm"].rmse_rpm > 3 * units["warm"].others_rpm  # missed when left out
    assert not any(u.inconsistent for u in units.values())
    # ... and without the joint model (other_motors asks so: a scale sets another motor apart) it is flagged
    assert {u.name for u in core.consistency(inp, mf.sigma2, names=[], alternatives=False) if u.inconsistent} == {"warm"}


def test_a_channels_gain_left_out_for_the_ras_doubt_leaves_the_ra_given_inside_the_data_alone_interval(tmp_path):
    """A voltage channel 3 % high rescales V - I Ra: the rows fit Ra 3 % high without it as well as the Ra given with
    it. core.through_zero leaves the gain out (its interval holds zero once the reading's tolerance is counted); the
    data-alone Ra then reaches over the Ra given too (ra_alone's rivals_ohm): on an independent simulator's four
    tables (test/fixtures/independent/vgain3, its README) it was 2.06 ohm (2.007..2.115) against the 2.0 that was
    right."""
    d = diagnose(sorted((ROOT / "test" / "fixtures" / "independent" / "vgain3").glob("*.csv")), 2.0)
    res, text = check_truthful(d)
    assert "v_gain" not in res["missing_effects"], res["verdict"]
    da = res["ra_fit"]["data_alone"]
    assert da["determined"] and da["value"] > 2.03, da
    assert da["lo"] <= 2.0 <= da["hi"], da


@pytest.mark.slow
def test_where_a_wrong_ra_explains_as_well_as_an_effect_the_data_alone_ra_reaches_over_the_reading():
    """An independent simulator's bench (test/fixtures/independent/bd098: a 0.98 V brush drop, Ra given right):
    the verdict says a wrong Ra explains the rows as well as the brush drop, so the models with the reading
    and the drop explain them as well, and the data-alone Ra's interval reaches over the reading
    (core.reading_a_rival). It was 3.61..3.93 against the 3.51 given and true."""
    d = ROOT / "test" / "fixtures" / "independent" / "bd098"
    truth = json.loads((d / "truth.json").read_text())
    res = core.diagnose(sorted(str(p) for p in d.glob("r*.csv")),
                        core.Options(ra_ohm=truth["ra_given"], bootstrap=0, hybrid=False))
    fit = res.ra_fit
    assert fit.confounded_with and "explains as well as" in res.verdict, res.verdict
    assert fit.data.determined and fit.data.lo <= truth["Ra"] <= fit.data.hi, (fit.data.lo, fit.data.hi)


@pytest.mark.slow
def test_where_a_structured_residual_remains_no_ra_is_given_to_pass_and_a_right_reading_is_not_called_wrong():
    """An independent simulator's bench (test/fixtures/independent/satlevel: saturation that levels off, Ra given
    right, a voltage offset of -0.45 V): with the library's linear saturation the data alone put Ra at 0.61 times
    the reading, and a structured residual remains. A missing effect can stand in for a wrong Ra, so the verdict
    neither says the reading is wrong nor gives an Ra to pass (it said "is not what these recordings show ... pass
    --ra-ohm 1.1"), and the next command keeps the reading. (With the voltage's zero as its rows at rest read it,
    0.45 V, in the sensors' budget, the data-alone interval, 0.59..1.62, reaches within what a reading's error
    explains, and the verdict says nothing of the reading; the sentence for an interval beyond it is
    test_diagnosis_confidence -k residual_left.)"""
    d = ROOT / "test" / "fixtures" / "independent" / "satlevel"
    truth = json.loads((d / "truth.json").read_text())
    res = core.diagnose(sorted(str(p) for p in d.glob("r*.csv")),
                        core.Options(ra_ohm=truth["ra_given"], bootstrap=0, hybrid=False))
    assert res.ra_fit.residual_left and "A structured residual remains" in res.verdict, res.verdict
    assert "--ra-ohm" not in res.verdict and "is not what these recordings show" not in res.verdict, res.verdict
    assert "The Ra you gave" not in res.verdict or "whether the reading is wrong cannot be told" in res.verdict


@pytest.mark.slow
def test_a_confounded_group_none_of_them_named_is_not_said():
    """An independent simulator's tables (test/fixtures/independent/offsetdrop: a brush drop and a voltage offset,
    Ra given 4.5 % low): v_gain is selected, then not named (its interval holds zero with the Ra given's
    tolerance), and the group it made with magnet_thermal, neither on the bench, was still said ("v_gain and
    magnet_thermal cannot be told apart"). Groups and pairs whose effects are none of them named are left out
    (core.of_the_named)."""
    d = ROOT / "test" / "fixtures" / "independent" / "offsetdrop"
    truth = json.loads((d / "truth.json").read_text())
    res = core.diagnose(sorted(str(p) for p in d.glob("r*.csv")),
                        core.Options(ra_ohm=truth["ra_given"], bootstrap=0, hybrid=False))
    named = set(res.missing_effects) | {ranking.RA_MISMATCH}
    assert all(named & set(g) for g in res.confounded), (res.confounded, res.missing_effects)
    assert "cannot be told apart" not in res.verdict or any(
        f"{e} and" in res.verdict or f"and {e}" in res.verdict for e in res.missing_effects), res.verdict


@pytest.mark.slow
def test_the_stages_that_leave_effects_out_run_again_until_every_named_interval_is_clear_of_zero():
    """An independent simulator's warm-up (test/fixtures/independent/heat33, Ra given right): the stages that leave
    an effect out (unphysical, through_zero, beyond_plausible) fit the rest again, which moves the others' intervals;
    run once, thermal_ra was named at -0.27..+1.06 %/K (and on another bench v_gain at -13.2..+5.35 %, once
    thermal_ra was left out as implausible). Now they run again until none leaves an effect out."""
    d = ROOT / "test" / "fixtures" / "independent" / "heat33"
    truth = json.loads((d / "truth.json").read_text())
    res = core.diagnose(sorted(str(p) for p in d.glob("*.csv")),
                        core.Options(ra_ohm=round(truth["ra25_ohm"], 2), bootstrap=0, hybrid=False))
    fields = {fx.LIBRARY[e].field: e for e in res.missing_effects}
    for iv in res.intervals:
        if iv.field in fields and iv.lo is not None and iv.hi is not None:
            assert not (iv.lo <= 0.0 <= iv.hi), (fields[iv.field], iv.lo, iv.hi, res.verdict)
    assert "holds zero" in res.verdict or not res.missing_effects


@pytest.mark.slow
def test_ra_from_the_data_alone_is_not_stated_where_the_winding_node_stops_beyond_the_nodes_range():
    """An independent simulator's large motor (test/fixtures/independent/heat02: 0.34 K/W from winding to ambient,
    below the node's range): the winding node stopped at an edge, and Ra from the data alone was stated as 0.702 ohm
    (0.659..0.746) against 1.29. An Ra at the reference temperature resting on an edge's temperature is not
    determined (intervals._thermal_needs_its_node); where it is stated, it holds the truth."""
    d = ROOT / "test" / "fixtures" / "independent" / "heat02"
    truth = json.loads((d / "truth.json").read_text())
    for given in (1.0, 0.9):
        res = core.diagnose(sorted(str(p) for p in d.glob("*.csv")),
                            core.Options(ra_ohm=round(truth["ra25_ohm"] * given, 3), bootstrap=0, hybrid=False))
        iv = res.ra_fit.data
        assert iv is not None
        assert not iv.determined or iv.lo <= truth["ra25_ohm"] <= iv.hi, (iv, res.verdict)
        assert "pass --ra-ohm" not in res.verdict or abs(float(re.search(r"pass --ra-ohm ([0-9.]+)", res.verdict)
                                                           .group(1)) / truth["ra25_ohm"] - 1) <= 0.10, res.verdict


def test_a_pure_numbers_range_is_written_without_a_unit_of_1():
    """brush_order (unit 1) at the edge of its range printed "the range allowed, 1..2 1:" (a fuzzing helper's); a
    quantity with a unit keeps it."""
    from hpddo.diagnosis import intervals

    assert intervals._rng((1.0, 2.0), 1.0, "1") == "1..2"
    assert intervals._rng((0.05, 2.5), 1.0, "V") == "0.05..2.5 V"
    assert intervals._rng((0.0, math.inf), 1.0, "ohm") == "above 0 ohm"


def test_the_winding_nodes_interval_is_judged_by_the_range_of_its_heat_path(tmp_path):
    """A recording without a temperature column fits the winding node along the ambient path (30..7200 s,
    schema.NODE), yet its intervals were judged against the case path's (4..600 s): an
    independent 10 Hz bench's "-3.77..112 s reaches outside the physical 4..600 s", and a node of 1200 s would
    have been called outside what is physical for it. Each node interval carries its path's range, and says it."""
    from hpddo import schema

    src = ROOT / "data" / "default" / "long.csv"
    lines = src.read_text().splitlines()
    head = [ln for ln in lines if ln.startswith("#")]
    cols = lines[len(head)].split(",")
    k = cols.index("temp_C")
    body = [",".join(c for j, c in enumerate(ln.split(",")) if j != k) for ln in lines[len(head):]]
    log = tmp_path / "long.csv"
    log.write_text("\n".join(head + body) + "\n")
    inp = core.load([log], core.Options())
    assert all(r.needs_state for r in inp.rows)
    p = fx.fit(inp.rows, inp.m2, ["thermal_ra"])
    node = {n.field: n for n in schema.NODE if n.path == "ambient"}
    ivs = {iv.field: iv for iv in intervals.of_fit(inp.data, p, ["thermal_ra"])}
    for field, n in node.items():
        iv = ivs[field]
        assert iv.physical == n.physical, iv
        lo, hi = n.physical
        assert not iv.determined or lo < iv.lo and iv.hi < hi, iv
        if "physical" in iv.why:
            assert intervals._rng(n.physical, 1.0, n.show_unit) in iv.why, iv.why
    # an interval inside the ambient path's range and outside the case path's stays determined
    tau = node["th_tau_s"]
    iv = dataclasses.replace(ivs["th_tau_s"], value=1200.0, lo=1000.0, hi=1400.0, determined=True, why="")
    assert intervals._inside_physical(iv, dataclasses.replace(iv, lo=900.0, hi=1500.0)).determined
    assert not intervals._inside_physical(iv, dataclasses.replace(iv, lo=0.5 * tau.physical[0], hi=1500.0)).determined


@pytest.mark.slow
def test_an_effect_whose_size_rests_on_a_reading_the_data_do_not_bear_out_is_not_named():
    """The hot and unseen validation recordings with Ra given 3.15 ohm (a fuzzing helper's; the data alone put Ra at
    4.1-7.3 ohm): "Missing: brush_drop (fitted +3.21 V ... 95 % interval -3.78..+10.2 V)", the interval through zero
    once the doubt on the reading is counted, and the drop outside what brushes take. Where the data alone put Ra
    outside the reading, a named effect's interval, that doubt counted, is clear of zero."""
    val = ROOT / "data" / "validation"
    res = diagnose([val / "hot.csv", val / "unseen.csv"], 3.15)
    d = res.ra_fit.data
    assert d is not None and d.determined and not d.lo <= 3.15 <= d.hi, d
    fields = {fx.LIBRARY[e].field: e for e in res.missing_effects}
    for iv in res.intervals:
        if iv.field in fields and iv.lo is not None and iv.hi is not None:
            assert not (iv.lo <= 0.0 <= iv.hi), (fields[iv.field], iv.lo, iv.hi, res.verdict)
    assert "brush_drop" not in res.missing_effects, res.verdict
    assert "brush_drop was selected" in res.verdict and "doubt on the Ra given" in res.verdict, res.verdict


@pytest.mark.slow
def test_a_plain_heating_is_named_with_the_copper_held_where_its_free_coefficient_is_not_determined():
    """An independent simulator's bench (test/fixtures/independent/copper100: a winding 100 K over its case, Ra given
    right): thermal_ra took 99.5 % of the error but its free coefficient's interval, -2.15..+2.57 %/K, held zero (it
    trades with the node's resistance), and nothing was named. Held at copper's 0.393 %/K (the model explains the
    held-out rows as well), it is named (core.copper_held); the effects left out are still left out."""
    d = ROOT / "test" / "fixtures" / "independent" / "copper100"
    truth = json.loads((d / "truth.json").read_text())
    res = diagnose([d / "thermal.csv"], truth["Ra"])
    assert res.missing_effects == ["thermal_ra"], res.verdict
    assert "held at its material's coefficient (copper)" in res.verdict, res.verdict
    row = next(e for e in res.ranking if e.effect == "thermal_ra")
    assert row.named and row.params["ra_tc_per_K"] == pytest.approx(0.00393), row
    assert res.to_json()["held_effects"] == {"thermal_ra": 0.00393}  # the next command holds it (--hold)
    ke = next(iv for iv in res.intervals if iv.field == "ke_vs_per_rad")
    assert ke.lo <= truth["Ke"] <= ke.hi, ke
    check_truthful(res)


@pytest.mark.slow
def test_a_reading_ten_percent_low_that_effects_explain_as_well_gets_the_supported_ra_among_the_commands():
    """The lagcase bench (a brush drop and copper heating, true Ra 4.0 ohm) diagnosed with Ra 3.6: no mismatch is
    concluded, a wrong Ra explains the residual left as well as v_gain or current_offset (RaFit.confounded_with), and
    the single command printed kept 3.6 ohm. Now one command per model that fits (cli.diagnose.next_steps), the Ra the
    data support first, within 5 % of the truth; the data-alone Ra and Ke intervals hold the truth."""
    import shlex

    from hpddo import cli
    d = ROOT / "test" / "fixtures" / "independent" / "lagcase"
    truth = json.loads((d / "truth.json").read_text())
    logs = [str(d / f"{n}.csv") for n in ("sweep", "load", "long")]
    res, _ = check_truthful(diagnose(logs, 3.6))
    ra = res["ra_fit"]
    alone = ra["data_alone"]
    assert alone["lo"] <= truth["Ra"] <= alone["hi"], alone
    ke = next(iv for iv in res["intervals"] if iv["field"] == "ke_vs_per_rad")
    assert ke["lo"] <= truth["Ke"] <= ke["hi"], ke
    args = cli.parser("diagnose").parse_args([*logs, "--out", "d", "--ra-ohm", "3.6"])
    from types import SimpleNamespace
    lines = diagnose_cli.next_steps(SimpleNamespace(to_json=lambda: res), args).splitlines()
    ras = [cli.parser("train").parse_args(shlex.split(ln)[2:]).ra_ohm for ln in lines
           if ln.strip().startswith("hpddo train")]
    if ra["confounded_with"]:
        assert len(ras) == 1 + len(ra["confounded_with"]), lines
    assert abs(ras[0] / truth["Ra"] - 1.0) < 0.05, lines  # the first command: the Ra the data support


@pytest.mark.slow
def test_the_data_alone_ra_reaches_over_each_model_a_confounded_pair_leaves_open():
    """core.ra_over_rivals: where the recordings cannot tell a named effect from another, the model with the other in
    its place explains the rows as well, and the data-alone Ra's interval holds that model's Ra (where its effects are
    plausible and its Ra determined); Ke's holds that model's Ke (core.rivals_fitted). The independent bd098 bench
    (Ra 3.513 ohm given 10 % low): the interval was 2.80..3.90 ohm without the swapped models."""
    d = ROOT / "test" / "fixtures" / "independent" / "bd098"
    truth = json.loads((d / "truth.json").read_text())
    opt = core.Options(bootstrap=0, hybrid=False, ra_ohm=round(0.9 * truth["Ra"], 4))
    inp0 = core.load(sorted(d.glob("*.csv")), opt)
    inp, mf, _, sel, conf = core.physics_selection(inp0, opt)
    swaps = core._swaps(sel, conf, inp.given + sel.missing)
    assert swaps, (sel.missing, conf.pairs)  # the bench's pair (the case's premise)
    alone, checked = sel.ra_fit.data, 0
    for swap in swaps:
        a = core.ra_alone(inp, swap, mf.sigma2, physical=True, alternative=True)
        if a is not None and a.determined:
            assert alone.lo <= a.value <= alone.hi, (swap, a.value, alone)
            checked += 1
    assert checked, swaps
    assert alone.lo <= truth["Ra"] <= alone.hi, alone


@pytest.mark.slow
def test_a_lagging_case_sensor_names_no_magnet_heating_and_the_copper_stays_within_the_interval():
    """An independent simulator's bench (test/fixtures/independent/lagcase: a brush drop and copper heating, the
    case read 0.7 of the winding's rise and 300 s late, Ke independent of temperature; Ra given right). The node
    cannot read the winding exactly from that case, and magnet_thermal, beside copper held, took up the misfit: it
    was named at -0.129 %/K with an interval excluding zero for a held-out gain of 0.05 % of the starting error.
    The material check names it only past the selection's bar (ranking.a_step), and the copper model it tried is
    kept as a model that fits (Selection.also_fit), so thermal_ra's interval reaches the copper's coefficient."""
    d = ROOT / "test" / "fixtures" / "independent" / "lagcase"
    truth = json.loads((d / "truth.json").read_text())
    res = diagnose([d / f"{n}.csv" for n in ("sweep", "load", "long")], truth["Ra"])
    assert "magnet_thermal" not in res.missing_effects, res.verdict
    row = next(e for e in res.ranking if e.effect == "magnet_thermal")
    assert not row.named, row
    tra = next((iv for iv in res.intervals if iv.field == "ra_tc_per_K"), None)
    if tra is not None and tra.determined:
        assert tra.lo <= truth["alpha"] <= tra.hi, tra
    ke = next(iv for iv in res.intervals if iv.field == "ke_vs_per_rad")
    assert ke.lo <= truth["Ke"] <= ke.hi, ke
    check_truthful(res)


def _fixture(name):
    d = ROOT / "test" / "fixtures" / "independent" / name
    return d, sorted(d.glob("*.csv")), json.loads((d / "truth.json").read_text())


def test_a_channels_offset_that_no_ra_within_its_doubt_stands_in_for_is_named():
    """ioff30 (an independent simulator's current channel 30 mA high, Ra given right): the offset was left out as
    "a wrong Ra within that tolerance explains these recordings as well", which a fit of Ra within that tolerance
    without it contradicts (core.ra_stands_in); it is named, its interval saying what takes it through zero, and
    the next command adds it."""
    d, logs, truth = _fixture("ioff30")
    res = diagnose(logs, truth["ra_given"])
    assert "current_offset" in res.missing_effects, res.verdict
    assert "explains these recordings as well" not in res.verdict, res.verdict
    iv = next(iv for iv in res.intervals if iv.field == "i_offset_A")
    assert iv.lo <= truth["effects"]["ioff"] <= iv.hi, iv
    rm = res.to_json()["rmse_rpm"]
    assert rm["after"]["average"] < 0.5 < rm["before"]["average"], rm
    check_truthful(res)


def test_named_effects_that_do_not_lower_the_test_parts_error_are_said_so():
    """copper10hz (an independent simulator's 10 Hz warm-up, the copper's heating, no temperature column, Ra given
    right): thermal_ra is named by its gain over the model with Ke by least squares, yet the model under test (Ke by
    eq. 20) misses the test part by less than the model with it; the verdict says so with the figures of the
    report's table, and the winding node's intervals are judged by the ambient path's physical range."""
    from hpddo import schema

    d, logs, truth = _fixture("copper10hz")
    res = diagnose(logs, truth["ra_given"])
    assert "thermal_ra" in res.missing_effects, res.verdict
    rm = res.to_json()["rmse_rpm"]
    before, after = rm["before"]["average"], rm["after"]["average"]
    assert after > before, rm
    assert f"misses by {after:.3g} RPM, the model under test (eq20) by {before:.3g} RPM: not lower here" in res.verdict
    ambient = {n.field: n.physical for n in schema.NODE if n.path == "ambient"}
    for iv in res.intervals:
        if iv.field in ambient:
            assert iv.physical == ambient[iv.field], iv
            assert "physical" not in iv.why or intervals._rng(ambient[iv.field], 1.0, iv.show_unit) in iv.why, iv.why
    check_truthful(res)
    # where the named effects do lower it, nothing is said (ioff30: 1.16 -> 0.34 RPM)
    d, logs, truth = _fixture("ioff30")
    assert "not lower here" not in diagnose(logs, truth["ra_given"]).verdict


def test_a_gain_that_an_ra_within_its_doubt_stands_in_for_gets_a_command_for_each():
    """vgainm3 (a voltage channel 3 % low, Ra given right): a gain rescales Ke and Ra together, so the reading 3 %
    lower without it fits as well, and the gain is not named; the next commands are the two models that fit, not
    the model as it is, which fits neither."""
    import shlex
    from hpddo import cli
    from hpddo.cli.diagnose import next_steps
    d, logs, truth = _fixture("vgainm3")
    res = diagnose(logs, truth["ra_given"])
    assert "v_gain" not in res.missing_effects and "explains these recordings as well" in res.verdict
    stand = res.to_json()["ra_fit"]["stand_ins"]
    assert list(stand) == ["v_gain"] and stand["v_gain"] == pytest.approx(truth["ra_true"] * 0.97, rel=0.02), stand
    args = cli.parser("diagnose").parse_args([*map(str, logs), "--out", "d", "--ra-ohm", str(truth["ra_given"])])
    text = next_steps(res, args)
    trains = [cli.parser("train").parse_args(shlex.split(line.strip())[2:]) for line in text.splitlines()
              if line.strip().startswith("hpddo train")]
    assert [(list(t.effects), t.ra_ohm) for t in trains] == [([], float(f"{stand['v_gain']:.4g}")),
                                                      (["v_gain"], truth["ra_given"])], text


def test_a_table_with_nothing_missing_is_not_said_to_miss_something():
    """viscous (an independent dyno table, viscous friction alone: the plain model is the truth): the floor was the
    out-of-fold residual of the model with every library effect, below the simulated noise, and the verdict said
    "something these recordings hold is missing"; that model does not beat the final one, so a residual above its
    floor is no evidence, and whether anything is missing below that floor cannot be told."""
    d, logs, truth = _fixture("viscous")
    res = diagnose(logs, truth["ra_given"])
    assert not res.missing_effects and "is missing from the model" not in res.verdict, res.verdict
    assert "cannot be told" in res.verdict, res.verdict
    check_truthful(res)


def test_two_effects_that_help_only_together_are_found_as_a_pair():
    """drop04hi20 (an independent 20 Hz bench: a 0.4 V brush drop, Ra given 10 % high): the brush drop with Ra held
    at the reading and a corrected Ra without the brush drop each raise the held-out error; together they take it
    from 1.8 to 0.75 RPM. The selection added one effect at a time and said "No library effect explains the
    residual"; the look-ahead now tries each candidate first where the residual stays above the floor
    (ranking._look_ahead), and the pair's first carries the pair's score with a note. Since the glitch filter keeps
    a step's transient (dataset.step_rows), two more held-out rows (the inrush of a step to full duty and the dip of
    a step down) are scored, a current offset of -89 mA (the drop over Ra above its knee) helps alone, and the brush
    drop is named in its place as the plausible one of two the rows cannot tell apart (ranking.plausible_first):
    either way the drop is named with its size and the Ra the rows support."""
    d, logs, truth = _fixture("drop04hi20")
    res = diagnose(logs, truth["ra_given"])
    assert "No library effect" not in res.verdict, res.verdict
    assert res.missing_effects == ["brush_drop"], res.verdict
    iv = next(iv for iv in res.intervals if iv.field == "brush_V")
    assert iv.lo <= truth["effects"]["drop"] <= iv.hi, iv
    ra = res.to_json()["ra_fit"]
    assert ra["mismatch"] and ra["supported_ohm"] == pytest.approx(truth["ra_true"], rel=0.02), ra
    row = next(e for e in res.ranking if e.effect == "brush_drop")
    assert row.score > 0.5 and ("as a pair" in row.note or "in place of current_offset" in row.note), row
    rm = res.to_json()["rmse_rpm"]
    assert rm["after"]["average"] < 1.0 < rm["before"]["average"], rm
    assert all(iv.lo <= iv.value <= iv.hi for iv in res.intervals if iv.determined), res.intervals


def test_an_effect_beyond_plausible_gives_way_to_the_rival_it_cannot_be_told_from():
    """drop04hi (an independent 2 Hz bench: a 0.4 V brush drop, Ra given 10 % high): a voltage offset was named at
    +402 mV, beyond the 300 mV a bench's electronics hold, plausible at its step beside a saturation later left
    out; a brush drop in its place with Ra corrected fits at +0.40 V and explains the held-out rows as well
    (core.plausible_rival)."""
    d, logs, truth = _fixture("drop04hi")
    res = diagnose(logs, truth["ra_given"])
    assert res.missing_effects == ["brush_drop"], res.verdict
    row = next(e for e in res.ranking if e.effect == "brush_drop")
    assert row.plausible and "in place of v_offset" in row.note, row
    assert all(e.plausible for e in res.ranking if e.named), res.ranking
    iv = next(iv for iv in res.intervals if iv.field == "brush_V")
    assert iv.lo <= truth["effects"]["drop"] <= iv.hi, iv
    assert "brush_drop and v_offset cannot be told apart" in res.verdict, res.verdict
    assert all(iv.lo <= iv.value <= iv.hi for iv in res.intervals if iv.determined), res.intervals


def test_a_warm_up_pair_of_copper_and_magnets_is_found_after_other_steps():
    """warmup (an independent 900 s warm-up, copper and magnets losing 0.15 %/K, Ra given right): after a wrong Ra
    and an offset's drift were taken, neither thermal effect alone lowered the held-out error and the two together
    did, by more than half of what was left above the floor; the verdict offered a wrong Ra, a brush drop or a voltage
    gain. The model with every library effect removes most of that excess, so the pair is tried and named."""
    d, logs, truth = _fixture("warmup")
    res = diagnose(logs, truth["ra_given"])
    assert set(res.missing_effects) == {"thermal_ra", "magnet_thermal"}, res.verdict
    magnets = next(e for e in res.ranking if e.effect == "magnet_thermal")
    assert magnets.params["ke_tc_per_K"] == pytest.approx(truth["effects"]["magnet"], abs=0.0004), magnets
    rm = res.to_json()["rmse_rpm"]
    assert rm["after"]["average"] < 0.5 < rm["before"]["average"], rm


@pytest.mark.parametrize("x,said", [(1.08, "about 1.1 times"), (3.456, "about 3.5 times"), (10.2, "about 10 times"),
                                    (123.4, "about 123 times")])
def test_how_much_more_data_would_separate_a_pair_is_written_with_its_digits(x, said):
    """"about 1 times as much of it would tell them apart" (z = 2.4 against 2.5, a fuzzing round's table)."""
    from hpddo.diagnosis import verdict
    from hpddo.diagnosis.result import ConfoundedPair

    pair = ConfoundedPair(["brush_drop", "v_offset"], "coasting", 0.9, z_apart=2.4, more_data_x=x)
    assert said in verdict._pair_sentence(pair), verdict._pair_sentence(pair)


def test_a_channel_is_the_boards_so_a_recording_that_holds_it_still_is_no_fault_of_it():
    """ideal5mA (fuzz round 8's S04: nothing missing, the current in 4.9 mA steps): the no-load sweep moves the
    current over 16 steps, the load steps beside it over hundreds; "the current channel of sweep is too coarse ...
    Ra and every effect that acts through the current cannot be concluded from it" was said of a channel that
    resolves the motor. Alone, the sweep's channel is still too coarse for what it shows."""
    from hpddo.diagnosis import channels

    d, logs, truth = _fixture("ideal5mA")
    res = diagnose(logs, truth["ra_given"])
    assert not [f for f in res.to_json()["channels"] if f["fault"] == "too coarse"], res.verdict
    assert res.missing_effects == [] and res.verdict.startswith("Nothing missing"), res.verdict
    assert not res.ra_fit.mismatch
    check_truthful(res)
    inp = core.load([d / "sweep.csv"], core.Options(ra_ohm=truth["ra_given"]))
    alone = channels.check(inp.recs, inp.rows, 1.0)
    assert [(f.channel, f.fault) for f in alone] == [("current", "too coarse")], alone


def test_the_ra_sentence_says_which_of_the_effects_a_wrong_ra_stands_in_for_are_named_all_the_same():
    """Fuzz round 8's S07: "a wrong Ra explains as well as magnet_thermal or v_gain or current_offset_drift, so none
    of them is named" beside "Missing: magnet_thermal"."""
    from hpddo.diagnosis import verdict

    said = verdict._so_named(["magnet_thermal", "v_gain", "current_offset_drift"], ["magnet_thermal"])
    assert "none of them is named" not in said and said.startswith("and magnet_thermal is named below"), said
    assert said.endswith("v_gain and current_offset_drift not"), said
    assert verdict._so_named(["v_gain"], []) == "so neither is named"
    assert verdict._so_named(["v_gain", "v_offset"], ["brush_drop"]) == "so none of them is named"


def test_an_interval_outside_the_physical_range_says_so_with_the_interval_it_states():
    """Fuzz round 8's S07: the reason quoted the statistical interval (-0.778..-0.305 %/K) where the report stated
    the interval with its whole budget (-1.16..+0.617 %/K)."""
    iv = intervals.Interval("magnet_thermal", "ke_tc_per_K", "1/K", -0.0054, -0.0078, -0.0031, False,
                            why="its interval -0.778..-0.305 %/K reaches outside the physical -0.7..0 %/K",
                            show_scale=100.0, show_unit="%/K", physical=(-0.007, 0.0))
    out = intervals._inside_physical(iv, dataclasses.replace(iv, lo=-0.0116, hi=0.00617))
    assert not out.determined and "-1.16..0.617 %/K" in out.why and "-0.778" not in out.why, out.why
    edge = dataclasses.replace(iv, why=intervals.EDGE_WHY + " of the range allowed")  # another reason: kept
    assert intervals._inside_physical(edge, dataclasses.replace(edge, lo=-0.0116)).why == edge.why



def _other_motors(folder: str, ra_ohm: float) -> tuple:
    paths = sorted((ROOT / "test" / "fixtures" / "independent" / folder).glob("*.csv"))
    inp = core.load(paths, core.Options(ra_ohm=ra_ohm))
    return inp, core.fit_model(inp).sigma2


def test_a_warm_up_of_the_same_motor_is_not_another_motor(monkeypatch):
    """core.other_motors on an independent simulator's bench (test/fixtures/independent/warm05, its README): the long
    run's winding 30 K warmer than the others', no temperature column, so its rows lie within the others' range; its
    own Ke, 1.07 times theirs, takes up most of the others' model's miss, and it was called another motor and left
    out of the ranking. One motor with the copper's heating, fitted on every recording, leaves less on all of them
    than the others' model with the long run's own Ke (core.same_motor_explains)."""
    inp, sigma2 = _other_motors("warm05", 13.26)
    assert core.other_motors(inp, sigma2) == []
    monkeypatch.setattr(core, "same_motor_explains", lambda *a, **k: False)
    assert [o.unit.name for o in core.other_motors(inp, sigma2)] == ["long"]  # what it was without the check


def test_another_motors_sweep_is_named_against_the_model_its_ke_is_fitted_beside():
    """core.other_motors on an independent simulator's bench (test/fixtures/independent/other17, its README): the
    sweep is of another motor (Ke +9 %). Its own Ke leaves 5.1 RPM of the others' model's (Ra free) 52.6, but the
    share was judged against consistency's miss with Ra held (9.4 RPM) and it went unnamed."""
    inp, sigma2 = _other_motors("other17", 9.079)
    named = core.other_motors(inp, sigma2)
    assert [o.unit.name for o in named] == ["sweep"]
    assert 1.05 < named[0].ke_ratio < 1.15, named[0].ke_ratio
    assert pathlib.Path(named[0].to_json()["file"]).name == "sweep.csv"


def test_the_next_command_trains_without_a_recording_named_another_motor():
    """The diagnosis leaves a recording named another motor out of its ranking, but the command it printed next
    trained on every log given, the other motor's too (fuzzing round 9): Ke pulled between two motors."""
    import shlex
    from types import SimpleNamespace

    from hpddo import cli
    logs = ["a.csv", "b.csv", "c.csv"]
    args = cli.parser("diagnose").parse_args([*logs, "--out", "d", "--ra-ohm", "4.5"])
    res = {"missing_effects": ["thermal_ra"], "ra_fit": {"mismatch": False}, "verdict": "",
           "consistency": {"other_motors": [{"recording": "bee", "file": "b.csv"}]}}
    lines = diagnose_cli.next_steps(SimpleNamespace(to_json=lambda: res), args).splitlines()
    trains = [shlex.split(ln) for ln in lines if ln.strip().startswith("hpddo train")]
    assert len(trains) == 1 and cli.parser("train").parse_args(trains[0][2:]).logs == [pathlib.Path("a.csv"), pathlib.Path("c.csv")], lines
    assert any("without bee: named another motor" in ln for ln in lines), lines
    res["consistency"]["other_motors"] = []
    lines = diagnose_cli.next_steps(SimpleNamespace(to_json=lambda: res), args).splitlines()
    assert [ln for ln in lines if "hpddo train" in ln][0].split()[2:5] == logs


def test_close_loads_without_a_load_column_are_no_repeats():
    """noise._points: without a load column the current is the only mark of the load. Sixteen loads 12 mA apart read
    through 5 mA of noise put neighbouring loads within the 2 mA tolerance by chance, and an independent simulator's
    tables (fuzzing round 9, d12) read a floor of 13.7 RPM from such pairs against about 5 from the model with every
    effect; they are no repeats. Points logged twice, 50 mA from the next, are; with a load column, as before."""
    import types

    import numpy as np
    from hpddo.diagnosis import noise

    rng = np.random.default_rng(4)
    i = 0.02 + 0.012 * np.arange(16) + rng.normal(0, 0.005, 16)
    r = types.SimpleNamespace(duty=np.full(16, 0.5), i=i)
    key = sorted(range(16), key=lambda k: i[k])
    close = noise._points(key, r, np.zeros(16), False)
    assert close == [], close
    twice = np.repeat(0.1 + 0.05 * np.arange(8), 2) + rng.normal(0, 0.0005, 16)
    r = types.SimpleNamespace(duty=np.full(16, 0.5), i=twice)
    key = sorted(range(16), key=lambda k: twice[k])
    assert len(noise._points(key, r, np.zeros(16), False)) == 8
    r = types.SimpleNamespace(duty=np.full(16, 0.5), i=i)
    load = np.arange(16) // 2  # the load column says which rows repeat
    key = sorted(range(16), key=lambda k: (load[k], i[k]))
    assert all(load[g[0]] == load[g[-1]] for g in noise._points(key, r, load, True))


def test_a_large_motors_warm_up_is_fitted_from_a_node_its_currents_allow(monkeypatch):
    """core.other_motors on an independent simulator's bench of a 24 V, 0.48 ohm motor (test/fixtures/independent/
    large02, its README): its node to ambient is 0.46 K/W, below a small motor's range, and the fit started at 10
    K/W, where 17 A hold the winding at the insulation limit on most rows: the fit of one motor with the copper's
    heating stayed there (80 K/W, Ra 0.27 ohm) and the warm-up was called another motor. Started where the
    currents leave the winding below that limit (effects.node_start), it finds Ra within 2 % and the same motor."""
    from hpddo.diagnosis import ranking

    truth = json.loads((ROOT / "test" / "fixtures" / "independent" / "large02" / "truth.json").read_text())
    inp, sigma2 = _other_motors("large02", 0.4791)
    r0, _ = fx.node_start(inp.rows, [r.train | r.test for r in inp.rows], inp.m2, True)
    assert r0 * 17.7 ** 2 * inp.m2.ra_ohm < 0.6 * (250.0 - inp.m2.t_amb_C)
    p = ranking.fit_ra_free(inp.rows, inp.m2, ["thermal_ra"])
    assert p.ra_ohm == pytest.approx(truth["Ra_true"], rel=0.02)
    node = fx.node_params(True)[0]
    assert node.physical[0] < p.th_r_K_per_W < 2 * (truth["motor"]["Rwc"] + truth["motor"]["Rca"])
    assert core.other_motors(inp, sigma2) == []
    declared = fx.node_params(True)
    monkeypatch.setattr(fx, "node_start", lambda *a, **k: (declared[0].start, declared[1].start))
    fx._fit_memo.clear()
    assert [o.unit.name for o in core.other_motors(inp, sigma2)] == ["long"]  # what it was from the declared start
