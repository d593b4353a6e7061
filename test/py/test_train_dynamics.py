"""hpddo train --dynamics (issue 21, item 8): the dynamic family named end to end on a short fast
twin run: identified from the training rows with intervals (metrics.json), carried by the model
header (kDynamics, covered by kChecksum), run by the board's observer in the native replay; a slow
log refused in one line; the diagnosis' next command names it. The header, the upload document
and the board bit for bit: test_upload.py; a model without the family byte-identical:
test_pipeline.py (models/default), test_fixtures.py (the core's fixtures)."""
from __future__ import annotations

import json
import types

import numpy as np
import pandas as pd
import pytest

from conftest import ROOT
from hpddo.cli import diagnose as diagnose_cli
from hpddo.cli import train as train_cli
from hpddo.cli import twin as twin_cli
from hpddo.logs import dataset
from hpddo.model import export, train

EPOCHS = "50"  # the network is not under test here: the family is


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """The fast twin's sweep (100 Hz, ideal bench with La, seed 3, 3 s steps), trained without and
    with the family."""
    tmp = tmp_path_factory.mktemp("dyn")
    assert twin_cli.main(["--protocol", "sweep", "--preset", "ideal", "--effects", "inductance", "--rate-hz", "100",
                          "--time-scale", "0.1", "--seed", "3", "--out", str(tmp / "fast"), "--quiet"]) == 0
    log = tmp / "fast" / "sweep.csv"
    for name, extra in (("off", []), ("on", ["--dynamics"])):
        assert train_cli.main([str(log), "--epochs", EPOCHS, "--out", str(tmp / name), "--quiet", *extra]) == 0
    return tmp


def estimates(folder) -> pd.DataFrame:
    return pd.read_csv(folder / "work" / "estimates" / "sweep.estimates.csv")


def test_the_family_is_identified_with_intervals_and_recorded(trained):
    ident = json.loads((trained / "on" / "metrics.json").read_text())["identification"]
    assert "dynamics" not in json.loads((trained / "off" / "metrics.json").read_text())["identification"]
    dyn = ident["dynamics"]
    q = {x["field"]: x for x in dyn["quantities"]}
    for field, truth in (("j_kgm2", 3.0e-4), ("b_nms_per_rad", 4.0e-3), ("tc_nm", 0.095)):  # the twin's shaft
        assert q[field]["determined"] and q[field]["lo"] < q[field]["value"] < q[field]["hi"], q[field]
        assert q[field]["lo"] < truth < q[field]["hi"], (field, q[field])
        assert dyn["model"][field] == pytest.approx(q[field]["value"], rel=1e-6)  # float32 of the value
    assert dyn["model"]["tau_obs_s"] > 0 and dyn["speed_from"] == "encoder periods"
    assert not q["la_H"]["determined"]  # at 100 Hz La is not seen (1 kHz would)


def test_the_header_carries_the_family_and_its_checksum_covers_it(trained):
    on = (trained / "on" / "model_default.h").read_text()
    off = (trained / "off" / "model_default.h").read_text()
    assert "kDynamics" in on and "kDynamics" not in off and "--dynamics" in on.splitlines()[1]
    assert "hpddo_model_default::kDynamics" in (trained / "on" / "model_default_q.h").read_text()
    model = export.read_model_header(on)  # raises unless the checksum, family included, agrees
    meta = json.loads((trained / "on" / "metrics.json").read_text())
    assert {k: float(v) for k, v in model.dynamics.items()} == meta["identification"]["dynamics"]["model"]
    assert f"0x{export.model_checksum(model):08x}" in on
    assert export.read_model_header(off).dynamics is None


def test_the_replay_runs_the_family_where_the_speed_changes(trained):
    on, off = estimates(trained / "on"), estimates(trained / "off")
    diff = (on["rpm_m2"] - off["rpm_m2"]).abs().to_numpy()
    rec = dataset.load_recordings([trained / "fast" / "sweep.csv"])[0]
    starts = np.flatnonzero(dataset.segment_starts(rec))  # the first row and the first test row
    assert list(starts) == [0, rec.n_train]
    assert (diff[starts] == 0).all()  # the observer starts settled on the back-EMF speed: M2 itself
    duty = rec.df["duty"].to_numpy()
    steps = np.flatnonzero(np.diff(duty) != 0) + 1
    after = np.concatenate([np.arange(s, s + 10) for s in steps if s + 10 < rec.n])
    assert np.median(diff[after]) > 5.0  # where the speed changes the family moves the estimate (RPM)
    # the board's float32 observer and the Python the network was trained on agree
    model = export.read_model_header((trained / "on" / "model_default.h").read_text())
    n2 = train.features(rec, model.physics, model.dynamics)[1]
    assert np.max(np.abs(n2 - on["rpm_m2"].to_numpy())) < 0.01
    # the family brings M2 closer to the encoder on the held-out rows
    test = on["part"] == "test"
    rmse = {k: float(np.sqrt(np.mean((e.loc[test, "rpm_m2"] - e.loc[test, "rpm_ref"]) ** 2)))
            for k, e in (("on", on), ("off", off))}
    assert rmse["on"] < 0.85 * rmse["off"], rmse


def test_a_slow_log_is_refused_in_one_line_naming_it(tmp_path, capsys):
    log = ROOT / "data" / "default" / "sweep.csv"
    assert train_cli.main([str(log), "--dynamics", "--out", str(tmp_path / "m"), "--quiet"]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "sweep.csv" in err and "--dynamics needs a recording at 50 Hz or faster" in err and "2 Hz" in err, err
    assert "enc_period_s" in err  # what recording would determine it
    assert not (tmp_path / "m").exists()


def test_the_diagnosis_next_command_names_the_family_only_when_it_is_named():
    q = [{"field": f, "determined": True} for f in ("j_kgm2", "b_nms_per_rad", "tc_nm")]
    named = {"verdict": "The residual follows dV/dt ... Named: dynamics (inertia and friction ...", "dynamics":
             {"quantities": q + [{"field": "la_H", "determined": False}]}, "missing_effects": [], "ra_fit": {}}
    args = types.SimpleNamespace(effects=(), logs=["FAST/sweep.csv"], ra_ohm=None, rated_v=None, rated_rpm=None,
                                 ke_fit="eq20", no_glitch_filter=False, reference="encoder")
    text = diagnose_cli.next_steps(types.SimpleNamespace(to_json=lambda: named), args)
    assert "hpddo train FAST/sweep.csv --out MODEL --dynamics" in text and "add what the diagnosis named" in text
    for res in (dict(named, verdict="Nothing missing."),
                dict(named, dynamics={"quantities": [dict(q[0], determined=False)] + q[1:]})):
        assert "--dynamics" not in diagnose_cli.next_steps(types.SimpleNamespace(to_json=lambda r=res: r), args)


def test_a_fast_log_that_does_not_determine_j_is_refused_naming_it_and_why(monkeypatch):
    """A fast recording whose steps do not hold J (here the identification says so): train names the
    file, the quantity, why and what would determine it, before anything is trained or written."""
    from hpddo import pipeline
    from hpddo.model import dynamics as family
    from hpddo.diagnosis.intervals import Interval
    from hpddo.logs.errors import InputError
    rec = types.SimpleNamespace(name="fast", source=ROOT / "x" / "fast.csv")
    j = Interval("J", "j_kgm2", "kg m^2", 3e-4, None, None, False, why="1 usable duty step(s) (two or more needed)",
                 needs=family.NEEDS)
    monkeypatch.setattr(family, "identify", lambda *a, **k: family.Dynamics(
        rate_hz=100.0, fast=["fast"], speed_from="encoder periods", quantities=[j]))
    monkeypatch.setattr("hpddo.model.train.physics_rpm", lambda r, p: np.zeros(3))
    m2 = types.SimpleNamespace(ra_ohm=4.5, ke_vs_per_rad=0.355, la_H=0.0)
    with pytest.raises(InputError) as err:
        pipeline.identify_dynamics([rec], m2)
    text = str(err.value)
    assert "\n" not in text and text.startswith(str(rec.source)), text
    assert "J not determined by these recordings (1 usable duty step(s)" in text and family.NEEDS in text, text


def test_an_effect_fitted_outside_its_physical_range_is_refused(trained, tmp_path, capsys):
    """The inductance fitted on a 100 Hz log comes out negative (the current's rise is over
    within a row): train refuses to put it on the board, in one line, writing nothing."""
    out = tmp_path / "m"
    code = train_cli.main([str(trained / "fast" / "sweep.csv"), "--effects", "inductance", "--out", str(out),
                           "--quiet"])
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1, err
    assert "--effects inductance: fitted -" in err and "outside its physical range 0.25..40 mH" in err, err
    assert "a recording at 1 kHz or faster" in err and not out.exists()
