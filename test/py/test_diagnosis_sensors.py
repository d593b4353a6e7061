"""Issue 21, item 3: the noise floor includes what the sensors themselves limit, from the log
header (docs/bench-log.md: encoder_counts_per_rev, encoder_window_s, v_lsb_V, i_lsb_A), and
the report shows each part. A twin recording at 50 Hz with a coarse encoder (1 pulse per
motor revolution: 17.6 counts per output-shaft revolution, one count per 20 ms window is
170 RPM)."""
import math

import pytest

from conftest import ROOT
import twin_benches

from hpddo.cli import diagnose as diagnose_cli
from hpddo.diagnosis import core, noise
from hpddo.twin import generate

RATE_HZ = 50.0


@pytest.fixture(scope="module")
def coarse(tmp_path_factory):
    """(log without the sensor keys, log with them, counts per output revolution, bench)."""
    d = tmp_path_factory.mktemp("coarse50")
    b = twin_benches.bench({}, encoder_ppr=1)
    generate.generate(b, "sweep", RATE_HZ, 3, out_dir=d, preset_name="ideal")
    plain = d / "sweep.csv"
    # the twin declares its encoder at 50 Hz and up (the scale of its enc_period_s column): the plain
    # log here is one without the sensor keys
    text = plain.read_text()
    assert f"# encoder_counts_per_rev={4 * b.encoder_ppr * b.gear_ratio:g}\n" in text
    plain.write_text("".join(line for line in text.splitlines(keepends=True)
                             if not line.startswith("# encoder_counts_per_rev=")))
    cpr = 4 * b.encoder_ppr * b.gear_ratio  # quadrature
    n_conv = int(b.adc_conv_per_s / 2.0 / RATE_HZ)  # conversions averaged per logged value
    v_lsb = b.adc_vref_V / 2 ** b.adc_bits / b.v_div_gain / n_conv
    i_lsb = b.adc_vref_V / 2 ** b.adc_bits / b.i_gain_V_per_A / n_conv
    meta = d / "meta" / "sweep.csv"
    meta.parent.mkdir()
    meta.write_text(f"# encoder_counts_per_rev={cpr:g}\n# v_lsb_V={v_lsb:.6g}\n# i_lsb_A={i_lsb:.6g}\n"
                    + plain.read_text())
    return plain, meta, cpr, (v_lsb, i_lsb)


def run(paths):
    return core.diagnose(paths, core.Options(bootstrap=0, hybrid=False))


def test_a_coarse_encoder_sets_the_noise_floor_and_each_part_is_shown(coarse, tmp_path):
    plain, meta, cpr, (v_lsb, i_lsb) = coarse
    before = run([plain]).to_json()["noise_floor"]
    # undeclared, the speed's step is read off its rows, as a rounding (q^2 / 12): the declared encoder's two
    # window ends (q^2 / 6) below
    q = 60.0 / (cpr / RATE_HZ)  # one count per window, RPM
    assert list(before["sensors_rpm"]) == [noise.SPEED_GRID_PART]
    assert before["sensors_rpm"][noise.SPEED_GRID_PART] == pytest.approx(
        q / math.sqrt(12.0), rel=0.02)
    d = run([meta])
    res = d.to_json()
    nf = res["noise_floor"]
    assert nf["encoder_step_rpm"] == pytest.approx(q)
    assert nf["sensors_rpm"]["encoder quantisation"] == pytest.approx(q / math.sqrt(6.0))
    ke, ra = res["model"]["ke_vs_per_rad"], res["model"]["ra_ohm"]
    per_v = 60.0 / (2 * math.pi * ke)
    assert nf["sensors_rpm"]["voltage resolution"] == pytest.approx(v_lsb * per_v / math.sqrt(12.0), rel=1e-5)
    assert nf["sensors_rpm"]["current resolution"] == pytest.approx(i_lsb * ra * per_v / math.sqrt(12.0), rel=1e-5)
    # the measured floor (from row-to-row differences) is far below the encoder's own
    assert nf["measured_rpm2"] == pytest.approx(before["measured_rpm2"])
    assert nf["limited_by_sensors"] and nf["rpm"] == pytest.approx(math.sqrt(sum(nf["sensors_rpm2"].values())))
    assert nf["rpm"] > 4 * math.sqrt(before["measured_rpm2"])
    # the verdict: no effect on this ideal bench, and what the sensors leave unseen
    assert res["missing_effects"] == [], res["verdict"]
    assert "The sensors set the noise floor (encoder quantisation" in res["verdict"], res["verdict"]
    # rows that read 0 RPM while driven fall out of every fit: Ke and Ra not determined
    assert nf["truncated_share"] > 0.02 and nf["truncated"]
    assert not res["ra_fit"]["determined"] and not res["ra_fit"]["mismatch"]
    assert not next(iv for iv in res["intervals"] if iv["quantity"] == "Ke")["determined"]
    text = diagnose_cli.summary(d)
    for part in ("encoder quantisation", "voltage resolution", "current resolution", "set by the sensors"):
        assert part in text, text
    from hpddo.reports import diagnosis as report
    (tmp_path / "r").mkdir()
    report.write(tmp_path / "r", res, d.plot())
    html = (tmp_path / "r" / "index.html").read_text()
    assert "encoder quantisation" in html and "current resolution" in html


def test_a_fine_encoder_leaves_the_bundled_verdict_as_it_was(tmp_path):
    """The bundled recordings' encoder (44 counts per motor revolution, gear 4.4, 2 Hz: one
    count is 0.31 RPM) declared in their headers: the sensors' floor is far below the measured
    one, and the verdict is the same word for word."""
    paths = []
    for n in ("load", "long", "sweep"):
        p = tmp_path / f"{n}.csv"
        p.write_text("# encoder_counts_per_rev=193.6\n" + (ROOT / "data" / "default" / f"{n}.csv").read_text())
        paths.append(p)
    res = run(paths).to_json()
    ref = run([ROOT / "data" / "default" / f"{n}.csv" for n in ("load", "long", "sweep")]).to_json()
    assert not res["noise_floor"]["limited_by_sensors"]
    assert res["noise_floor"]["sensors_rpm"]["encoder quantisation"] == pytest.approx(60 / (193.6 * 0.5) / 6 ** 0.5)
    assert res["verdict"] == ref["verdict"] and res["noise_rpm"] == ref["noise_rpm"]


def test_a_fast_recording_whose_residual_follows_the_dynamics_says_so(tmp_path):
    """The ideal twin bench's sweep at 50 Hz (the default encoder): the speed lags the voltage
    through inertia and inductance, and the residual follows dI/dt (r = -0.52 one row, 20 ms,
    apart: measured); the verdict names the dynamics with the lag and does not call the
    residual measurement noise. At 2 Hz (the bundled recordings, r = -0.36 with dV/dt) it does
    not."""
    generate.generate(twin_benches.bench({}), "sweep", RATE_HZ, 3, out_dir=tmp_path, preset_name="ideal")
    res = run([tmp_path / "sweep.csv"]).to_json()
    rates = [c for c in res["residual_before"]["correlates"] if c["input"] in ("dI/dt", "dV/dt")]
    assert max(abs(c["peak"]) for c in rates) >= core.DYNAMICS_R, rates
    assert res["verdict"].startswith("The residual follows d"), res["verdict"]
    # at 50 Hz the dynamic family is identified (test_diagnosis_dynamics.py) and named
    assert "ms). Named: dynamics (inertia and friction, the winding's inductance)" in res["verdict"]
    assert "The speed lags the duty steps by" in res["verdict"]
    assert core.NOTHING not in res["verdict"] and "No library effect explains" not in res["verdict"]
    bundled = run([ROOT / "data" / "default" / f"{n}.csv" for n in ("load", "long", "sweep")]).to_json()
    assert "motor's dynamics" not in bundled["verdict"]


def test_a_channel_held_at_one_level_in_every_recording_has_its_zero_said_as_not_counted():
    """A dyno table as users convert one, a log per supply voltage with the voltage fixed in each: no recording
    shows the voltage's step, so no error of its zero is counted; the sentence said "the voltage's zero within 0 V
    (2 of its steps ...)", a tolerance that reads as measured. It says what is taken and why, and asks for it."""
    from hpddo.diagnosis import intervals

    cal = dict(intervals.DEFAULT_CAL_REL)
    said = intervals.sensors_text(cal, [], {"v": (0.0, "steps"), "i": (2e-4, "steps")}, False)
    assert "within 0 V" not in said and "the voltage's zero as exact (no recording shows two levels of it" in said
    assert "the current's zero within 0.0002 A (2 of its steps" in said and "v_zero_V" in said, said
