"""The diagnosis on bench-twin recordings: an effect hidden alone is named (or shown in a
confounded group with the separating recording), no hidden effect gives an empty verdict,
two hidden effects are both named, and adding the named effects brings the physics RMSE at
least half way down to the same bench without the effect. Two seeds each; a family of cases takes
them in turn (twin_benches.alternating)."""
import json
import pathlib
import shutil
import subprocess

import pytest

from conftest import ROOT

import diagnose
from hpddo.diagnosis import core
import twin_benches

SEEDS = (3, 4)
# typical magnitudes (twin units); current_offset and v_gain at the top of their typical range,
# below it their speed error (~1 RPM) is smaller than the bench's measurement noise.
SINGLE = {
    "thermal_ra": {"thermal_ra": 0.393},
    "magnet_thermal": {"magnet_thermal": -0.2},
    "saturation": {"saturation": 4.0},
    # with La = 0 no current freewheels, the brush drop acts during the on-time only and
    # looks like a voltage gain error; every real armature has inductance
    "brush_drop": {"brush_drop": 0.5, "inductance": 2.5},
    "current_offset": {"current_offset": 20.0},
    "v_gain": {"v_gain": 2.0},
}
PAIR = {"magnet_thermal": -0.2, "saturation": 4.0}


def bench_dir(tmp_root: pathlib.Path, key: str, effects: dict, seed: int) -> list:
    return twin_benches.recordings(tmp_root / f"{key}_{seed}", twin_benches.bench(effects), seed)


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    return tmp_path_factory.mktemp("twin")


run = twin_benches.diagnosed


@pytest.mark.parametrize("seed", SEEDS)
def test_nothing_hidden_nothing_named(root, seed):
    res = run(bench_dir(root, "ideal", {}, seed))
    assert res["missing_effects"] == []
    assert res["verdict"].startswith("Nothing missing")


def _named_or_confounded(res, name):
    if name in res["missing_effects"]:
        return True
    return any(name in g for g in res["confounded"]) and bool(res["separating_recordings"])


def _halfway(res, ideal):
    before = res["rmse_rpm"]["before"]["average"]
    after = res["rmse_rpm"]["after"]["average"]
    floor = ideal["rmse_rpm"]["before"]["average"]
    return after <= before - 0.5 * (before - floor), (before, after, floor)


@pytest.mark.parametrize("name,seed", twin_benches.alternating(sorted(SINGLE), SEEDS))
def test_single_effect_is_named_and_the_error_falls(root, name, seed):
    """Each effect named (or in a stated group) and the error at least halfway to the ideal bench's;
    a voltage gain error of 2 % may instead be selected with an interval that holds zero: with Ra
    held, the current channel's default 2 % calibration tolerance is an Ra error, which the sensors'
    part of its budget carries (docs/diagnosis-limits.md), and then nothing is named."""
    res = run(bench_dir(root, name, SINGLE[name], seed))
    if name == "v_gain" and not res["missing_effects"]:
        assert "v_gain was selected" in res["verdict"] and "holds zero" in res["verdict"], res["verdict"]
        return
    assert _named_or_confounded(res, name), (res["missing_effects"], res["confounded"], res["verdict"])
    ideal = run(bench_dir(root, "ideal", {}, seed))
    ok, nums = _halfway(res, ideal)
    assert ok, nums


@pytest.mark.parametrize("seed", SEEDS)
def test_inductance_at_2hz_is_reported_unseen_with_the_recording_that_shows_it(root, seed):
    res = run(bench_dir(root, "inductance", {"inductance": 2.5}, seed))
    unseen = {u["effect"]: u["needs"] for u in res["not_identifiable"]}
    assert "inductance" in unseen and "kHz" in unseen["inductance"]
    assert res["missing_effects"] == []


@pytest.mark.parametrize("seed", SEEDS)
def test_two_hidden_effects_are_both_named(root, seed):
    res = run(bench_dir(root, "pair", PAIR, seed))
    for name in PAIR:
        assert _named_or_confounded(res, name), (res["missing_effects"], res["confounded"])
    ok, nums = _halfway(res, run(bench_dir(root, "ideal", {}, seed)))
    assert ok, nums


def test_cli_writes_report_and_json_and_refuses_bad_logs(root, tmp_path, capsys):
    paths = bench_dir(root, "saturation", SINGLE["saturation"], SEEDS[0])
    out = tmp_path / "diag"
    rc = diagnose.main([str(p) for p in paths] + ["--out", str(out), "--bootstrap", "4", "--epochs", "30"])
    assert rc == 0
    res = json.loads((out / "diagnosis.json").read_text())
    for key in ("model_effects", "missing_effects", "confounded", "ranking", "rmse_rpm"):
        assert key in res
    assert {"before", "after"} <= set(res["rmse_rpm"]) and "average" in res["rmse_rpm"]["before"]
    for e in res["ranking"]:
        assert 0.0 <= e["score"] <= 1.0 and "params" in e
    assert "saturation" in res["missing_effects"]
    assert "rmse_rpm_hybrid" in res and res["rmse_rpm_hybrid"]["iterations"] == 30  # --epochs given: exactly
    assert "<img" in (out / "index.html").read_text()
    bad = tmp_path / "bad.csv"
    bad.write_text("# condition=x\n# ra_ohm=4.5\nt_s,duty,v_V,i_A,rpm_ref\n0.0,0.1,1.0,0.1,2\n0.5,1.5,1.0,0.1,2\n")
    out2 = tmp_path / "diag2"
    rc = diagnose.main([str(paths[0]), str(bad), "--out", str(out2)])
    err = capsys.readouterr().err
    assert rc == 1 and "bad.csv:5:" in err and "duty" in err
    assert not out2.exists()


def test_report_renders_in_headless_chromium(root, tmp_path):
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if not chromium:
        pytest.skip("chromium is not installed (scripts/bootstrap.sh --tests installs it)")
    paths = bench_dir(root, "pair", PAIR, SEEDS[0])
    out = tmp_path / "diag"
    assert diagnose.main([str(p) for p in paths] + ["--out", str(out), "--bootstrap", "0", "--no-hybrid"]) == 0
    url = (out / "index.html").resolve().as_uri()
    common = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
              "--disable-background-networking", "--disable-component-update", "--disable-sync",
              f"--user-data-dir={tmp_path / 'profile'}"]
    dom = subprocess.run(common + ["--dump-dom", url], capture_output=True, text=True, timeout=120)
    assert "Verdict" in dom.stdout and dom.stdout.count("<img") >= 4
    shot = tmp_path / "shot.png"
    r = subprocess.run(common + ["--enable-logging=stderr", "--v=0", f"--screenshot={shot}", "--window-size=1280,2000",
                        url], capture_output=True, text=True, timeout=120)
    assert shot.exists() and shot.stat().st_size > 20000
    errors = [ln for ln in r.stderr.splitlines() if "CONSOLE" in ln and "rror" in ln]
    assert not errors, errors


def test_structured_residual_outside_the_library_is_not_forced_onto_a_name(root):
    """A disturbance no library effect has (a slow sinusoidal drift of the voltage channel,
    97 s period, while the motor is driven): nothing is named, and the verdict says the
    residual is structured and shows its strongest correlates."""
    import numpy as np

    from hpddo.logs import benchlog
    src = bench_dir(root, "ideal", {}, SEEDS[0])
    out = root / "unexplained"
    out.mkdir(exist_ok=True)
    paths = []
    for p in src:
        log = benchlog.read_log(p)
        df = log.df.copy()
        df["v_V"] = df["v_V"] + 0.25 * np.sin(2 * np.pi * df["t_s"] / 97.0) * (df["duty"] > 0)
        paths.append(benchlog.write_log(out / p.name, df, log.meta))
    res = run(paths)
    assert res["missing_effects"] == [], res["verdict"]
    assert "No library effect explains" in res["verdict"]
    assert "strongest correlates" in res["verdict"]


@pytest.mark.parametrize("seed", SEEDS)
def test_thermal_ra_and_magnet_thermal_together_are_named_as_a_confounded_pair(root, seed):
    """The issue's example: copper and magnets both follow the temperature. Fitted freely,
    thermal_ra lands far from copper's coefficient; held at copper's, the rest is the magnets'.
    Both are named, reported as confounded, and the separating recording is named."""
    res = run(bench_dir(root, "thermal_pair", {"thermal_ra": 0.393, "magnet_thermal": -0.2}, seed))
    assert set(res["missing_effects"]) >= {"thermal_ra", "magnet_thermal"}, res["verdict"]
    assert ["thermal_ra", "magnet_thermal"] in res["confounded"]
    sep = [s for s in res["separating_recordings"] if set(s["effects"]) == {"thermal_ra", "magnet_thermal"}]
    assert sep and sep[0]["recording"]
    named = {e["effect"]: e for e in res["ranking"] if e["named"]}
    assert named["thermal_ra"]["params"]["ra_tc_per_K"] == pytest.approx(0.00393)
    assert -0.0025 < named["magnet_thermal"]["params"]["ke_tc_per_K"] < -0.0015  # the bench: -0.2 %/K
    ideal = run(bench_dir(root, "ideal", {}, seed))
    ok, info = _halfway(res, ideal)
    assert ok, info


@pytest.mark.parametrize("names", [("sweep", "load"), ("load", "sweep")])
def test_two_bundled_recordings_are_diagnosed(names):
    """The bundled sweep and load alone (no long run): the forward selection took a wrong
    Ra, then an effect that a wrong Ra cannot be told from; refitting Ra with it (once, not
    twice: it crashed with KeyError 'ra_mismatch') gave a verdict about Ra (5.0 ohm, +11 %).
    With the brush drop's widened family (docs/diagnosis-forms.md, Forms outside the library) the
    bench's brush drop (0.5 V) is selected instead, at 0.84 V, its form at the edge of those
    allowed, and Ra is not called wrong (the bench's is 4.5 ohm cold). With the sensors' part of
    its budget (the channels' gain errors and steps through the fit) its interval holds zero: it
    is said and not named."""
    res = run([ROOT / "data" / "default" / f"{n}.csv" for n in names])
    if res["ra_fit"]["mismatch"]:
        assert "Ra" in res["verdict"]
    else:
        assert res["missing_effects"] == [], res["verdict"]
        assert "brush_drop was selected" in res["verdict"] and "holds zero" in res["verdict"], res["verdict"]
    assert all(v == v for v in res["rmse_rpm"]["after"].values())  # no NaN


def test_the_diagnosis_prints_the_train_command_that_adds_what_it_named(tmp_path, capsys):
    import shlex
    from hpddo import cli
    logs = [str(ROOT / "data" / "default" / f"{n}.csv") for n in ("sweep", "load")]
    assert diagnose.main([*logs, "--out", str(tmp_path / "d"), "--bootstrap", "0", "--no-hybrid"]) == 0
    out = capsys.readouterr().out.splitlines()
    k = next(i for i, ln in enumerate(out) if ln.startswith("next ("))
    words = shlex.split(next(ln for ln in out[k + 1:] if ln.strip().startswith("hpddo train")))
    assert words[:2] == ["hpddo", "train"] and words[2:4] == logs
    res = json.loads((tmp_path / "d" / "diagnosis.json").read_text())
    args = cli.parser("train").parse_args(words[2:])  # it is a command train takes, as printed
    assert tuple(args.effects) == tuple(res["missing_effects"])
    if res["ra_fit"]["mismatch"] and not res["ra_fit"]["residual_left"]:  # the Ra the data support (first)
        assert args.ra_ohm == pytest.approx(res["ra_fit"]["supported_ohm"], rel=1e-3)
    else:  # the reading kept
        assert args.ra_ohm is None


@pytest.mark.parametrize("left", [False, True])
@pytest.mark.parametrize("confounded", [[], ["v_gain"], ["saturation", "v_gain"]])
def test_the_next_command_passes_the_supported_ra_only_where_the_verdict_does(confounded, left):
    """A mismatch that effects explain as well (RaFit.confounded_with) is no instruction: the verdict says these
    recordings cannot tell which, and the printed commands are one for each model that fits, the Ra the data
    support and the reading with each such effect, to be chosen by a new reading (a fuzzing helper's bench, Ra given
    10 % high: the reading alone was printed, 83 RPM on an unseen run against 5.5 with the true Ra). No such
    effect: the supported Ra alone."""
    import shlex
    from types import SimpleNamespace

    from hpddo import cli
    from hpddo.cli.diagnose import next_steps
    args = cli.parser("diagnose").parse_args(["a.csv", "--out", "d", "--ra-ohm", "8.8"])
    res = {"missing_effects": [], "verdict": "",
           "ra_fit": {"mismatch": True, "supported_ohm": 8.0, "confounded_with": confounded, "residual_left": left}}
    lines = next_steps(SimpleNamespace(to_json=lambda: res), args).splitlines()
    commands = [shlex.split(ln)[2:] for ln in lines if ln.strip().startswith("hpddo train")]
    trained = [cli.parser("train").parse_args(c) for c in commands]
    if left and not confounded:  # the verdict: re-measure Ra, no value to pass (a structured residual is left)
        assert [t.ra_ohm for t in trained] == [pytest.approx(8.8)], lines
        return
    # with a residual left the verdict still promises one command for each model that fits (a fuzzing round's
    # bench: the rejected reading alone was printed under that promise)
    assert [t.ra_ohm for t in trained] == [pytest.approx(8.0)] + [pytest.approx(8.8)] * len(confounded), lines
    assert [list(t.effects) for t in trained[1:]] == [[e] for e in confounded], lines
    if confounded:
        assert lines[0].startswith("next (these recordings cannot tell a wrong Ra from"), lines[0]
    else:
        assert lines[0].startswith("next (add what"), lines[0]


@pytest.mark.parametrize("left", [False, True])
@pytest.mark.parametrize("confounded", [[], ["v_gain"], ["current_offset", "v_gain"]])
def test_without_a_mismatch_a_residual_a_wrong_ra_explains_gets_a_command_for_each_model(confounded, left):
    """No mismatch concluded, but a wrong Ra explains as well as effects (RaFit.confounded_with) and a residual is
    left above the floor: the reading alone is one of the models that fit, not the instruction (a fuzzing round's
    tiny motor, its reading 10 % high: the reading alone was printed, 113 RPM on an unseen run against 32 at the
    true Ra). One command per model, the supported Ra first; no residual left or nothing confounded: the reading."""
    import shlex
    from types import SimpleNamespace

    from hpddo import cli
    from hpddo.cli.diagnose import next_steps
    from hpddo.diagnosis.verdict import ABOVE_SHARE
    args = cli.parser("diagnose").parse_args(["a.csv", "--out", "d", "--ra-ohm", "44"])
    res = {"missing_effects": [], "verdict": "",
           "ra_fit": {"mismatch": False, "supported_ohm": 40.75, "confounded_with": confounded, "residual_left": left},
           "residual_after": {"excess": 2.0 * ABOVE_SHARE if left else 0.0, "noise_var": 1.0}}
    lines = next_steps(SimpleNamespace(to_json=lambda: res), args).splitlines()
    trained = [cli.parser("train").parse_args(shlex.split(ln)[2:]) for ln in lines if ln.strip().startswith("hpddo train")]
    if not (left and confounded):
        assert [t.ra_ohm for t in trained] == [pytest.approx(44)], lines
        return
    assert [t.ra_ohm for t in trained] == [pytest.approx(40.75)] + [pytest.approx(44)] * len(confounded), lines
    assert [list(t.effects) for t in trained[1:]] == [[e] for e in confounded], lines
    assert lines[0].startswith("next (these recordings cannot tell a wrong Ra from"), lines[0]
    assert not any("'after' row" in ln for ln in lines), lines  # that row is the reading's model here


@pytest.mark.parametrize("given", [
    ["--ra-ohm", "4.5", "--rated-v", "12", "--rated-rpm", "240"],
    ["--rated-v", "24.5", "--ke-fit", "lsq", "--no-glitch-filter", "--effects", "brush_drop"],
    ["--reference", "ripple", "--ripples-per-rev", "12", "--gear-ratio", "30", "--rated-rpm", "110"]])
def test_the_printed_next_command_carries_the_options_train_needs(given):
    """Issue 32: the next command dropped --rated-v and --rated-rpm. Every option given to the diagnosis
    that hpddo train also takes, and that shapes the model, is in the command it prints, with the same value."""
    import shlex
    from types import SimpleNamespace

    from hpddo import cli
    logs = ["a.csv", "b.csv"]
    args = cli.parser("diagnose").parse_args([*logs, "--out", "d", "--bootstrap", "3", "--seed", "4", *given])
    res = {"missing_effects": ["thermal_ra"], "ra_fit": {"mismatch": False}, "verdict": ""}
    from hpddo.cli.diagnose import next_steps
    lines = next_steps(SimpleNamespace(to_json=lambda: res), args).splitlines()
    words = shlex.split(lines[1])
    assert words[:2] == ["hpddo", "train"] and words[2:4] == logs
    trained = cli.parser("train").parse_args(words[2:])  # a command train takes, as printed
    for key in ("ra_ohm", "rated_v", "rated_rpm", "ke_fit", "no_glitch_filter", "reference", "ripples_per_rev",
                "gear_ratio"):
        assert getattr(trained, key) == getattr(args, key), (key, lines[1])
    assert list(trained.effects) == [*args.effects, *(e for e in res["missing_effects"] if e not in args.effects)]
    for own in ("--bootstrap", "--seed"):  # the diagnosis' own options are not train's to repeat
        assert own not in words


def test_a_recording_without_encoder_speeds_is_not_scored_and_nothing_reads_nan(tmp_path, capsys):
    """The bundled load beside its sweep and a copy of the sweep whose rpm_ref is empty: the copy has no
    RMSE ('-' in the printed tables, null in diagnosis.json) and no part in the averages; leave one out
    says why it is not scored, where its average was a traceback (None in np.mean) and the tables nan."""
    src = ROOT / "data" / "default" / "sweep.csv"
    lines = src.read_text().splitlines(keepends=True)
    body = [ln for ln in lines if not ln.startswith("#")]
    k = body[0].strip().split(",").index("rpm_ref")
    blank = [body[0]] + [",".join("" if j == k else f for j, f in enumerate(ln.rstrip("\n").split(","))) + "\n"
                         for ln in body[1:]]
    noref = tmp_path / "noref.csv"
    noref.write_text("".join(ln.replace("condition=sweep", "condition=noref") for ln in lines if ln.startswith("#"))
                     + "".join(blank))
    logs = [str(ROOT / "data" / "default" / "load.csv"), str(src), str(noref)]
    out = tmp_path / "d"
    assert diagnose.main([*logs, "--out", str(out), "--bootstrap", "0", "--no-hybrid", "--leave-one-out"]) == 0
    text = capsys.readouterr().out
    assert "nan" not in text.split("RMSE on the test parts")[1], text
    assert "(noref: not scored: no encoder speeds (rpm_ref) to score it against)" in text, text
    res = json.loads((out / "diagnosis.json").read_text(), parse_constant=lambda c: pytest.fail(c))
    before = res["rmse_rpm"]["before"]
    assert before["noref"] is None and before["average"] == pytest.approx((before["load"] + before["sweep"]) / 2)
    loo = res["leave_one_out"]
    assert loo["recordings"]["noref"]["before"] is None
    assert loo["average"]["before"] == pytest.approx(
        (loo["recordings"]["load"]["before"] + loo["recordings"]["sweep"]["before"]) / 2, rel=1e-5)


@pytest.mark.parametrize("check, fit", [({"disagree": True, "biased": False, "ke_fit": "eq20"}, "lsq"),
                                        ({"disagree": False, "biased": True, "ke_fit": "eq20"}, "lsq"),
                                        ({"disagree": False, "biased": False, "ke_fit": "eq20"}, "eq20"),
                                        ({}, "eq20")])
def test_the_next_command_takes_the_ke_fit_the_report_advises(check, fit):
    """A fuzzing round: "Trust least squares (--ke-fit lsq)" in seven reports whose next command kept eq. 20. Where
    the Ke check advises least squares (core.ke_check: the two disagree, or eq. 20's Ke is biased), the command
    carries it."""
    import shlex
    from types import SimpleNamespace

    from hpddo import cli
    from hpddo.cli.diagnose import next_steps
    args = cli.parser("diagnose").parse_args(["a.csv", "--out", "d"])
    res = {"missing_effects": ["brush_drop"], "verdict": "", "ra_fit": {"mismatch": False}, "ke_check": check}
    lines = next_steps(SimpleNamespace(to_json=lambda: res), args).splitlines()
    trained = cli.parser("train").parse_args(shlex.split(lines[1])[2:])
    assert trained.ke_fit == fit, lines[1]
