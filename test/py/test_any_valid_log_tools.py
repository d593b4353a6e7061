"""Any valid bench log through the tools that train and score (the calibration issue, item 1):
Hypothesis writes valid logs of every shape (valid_logs.py) and `hpddo train` (identification,
M3, the export and the native replay), then `hpddo evaluate` of its model and `hpddo compare
--quick` must each end in a result (status 0) or a user error (status 1, one line naming the
fault); any other exception propagates from the command and fails the test. Each example
builds the native replay (about 18 s), so the examples are few; test_any_valid_log.py covers
the reader and the diagnosis over many more."""
import json

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from valid_logs import RA_OHM, log_spec, write_log

from hpddo.cli import compare as compare_cli
from hpddo.cli import evaluate as evaluate_cli
from hpddo.cli import train as train_cli

pytestmark = pytest.mark.slow


@settings(max_examples=8, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
@given(specs=st.lists(log_spec(), min_size=1, max_size=2), size=st.sampled_from((1e-3, 1.0, 1e2)),
       ra_given=st.sampled_from((None, 1.0, 1.15)))
def test_train_evaluate_and_compare_end_in_a_result_or_a_user_error(tmp_path_factory, specs, size, ra_given, capsys):
    d = tmp_path_factory.mktemp("logs")
    paths = [str(write_log(d / f"rec{k}.csv", s, size)) for k, s in enumerate(specs)]
    ra = [] if ra_given is None else ["--ra-ohm", f"{ra_given * RA_OHM * size:.6g}"]
    out = d / "model"
    rc = train_cli.main([*paths, "--out", str(out), "--epochs", "20", "--quiet", *ra])
    err = capsys.readouterr().err
    assert rc in (0, 1), (rc, err)
    if rc == 1:
        event("train: a user error")
        assert err.strip() and "Traceback" not in err, err
        assert not out.exists() or not any(out.glob("model_*.h")), "a refused train left a model"
        return
    event("train: a model")
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics, "train wrote an empty metrics.json"
    rc = evaluate_cli.main([*paths, "--model", str(out), "--out", str(d / "eval"), "--quiet"])
    err = capsys.readouterr().err
    assert rc in (0, 1) and "Traceback" not in err, (rc, err)
    event(f"evaluate: status {rc}")
    rc = compare_cli.main([*paths, "--out", str(d / "cmp"), "--quick", "--epochs", "5", "--workers", "1", "--quiet", *ra])
    err = capsys.readouterr().err
    assert rc in (0, 1) and "Traceback" not in err, (rc, err)
    event(f"compare --quick: status {rc}")
