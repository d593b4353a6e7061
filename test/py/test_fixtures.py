"""The committed core fixtures regenerate byte for byte from their generator."""
import pathlib

from conftest import ROOT

import gen_fixtures


def test_fixtures_regenerate_identically(tmp_path: pathlib.Path):
    gen_fixtures.main(["--out", str(tmp_path)])
    committed = ROOT / "test" / "fixtures"
    names = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*") if p.is_file())
    assert names, "generator wrote nothing"
    assert sorted(str(p.relative_to(committed)) for p in committed.rglob("*") if p.is_file()
                  and p.parent.name == "dynamics") == [n for n in names if n.startswith("dynamics/")]
    for name in names:
        assert (tmp_path / name).read_bytes() == (committed / name).read_bytes(), f"{name} differs: run tools/gen_fixtures.py"


def test_golden_stream_reaches_the_bounds():
    """The tiny stream's last rows exercise the bounds of docs/core.md in the reference."""
    import numpy as np
    from hpddo.model import export, fixtures
    from hpddo.model import physics as ph

    model = fixtures.tiny_model()
    rows = export.golden_rows(model, fixtures.tiny_stream())
    col = {c: k for k, c in enumerate(export.GOLDEN_INPUTS + export.GOLDEN_STAGES)}
    dt, status, temp = rows[:, col["dt_s"]], rows[:, col["status"]], rows[:, col["temp_used_C"]]
    limit = ph.speed_limit_rpm(model.physics, model.limits.v_max_V, model.limits.i_max_A, np.float32)
    assert np.all(np.isfinite(rows[:, col["rpm"]]))
    assert np.all(np.abs(rows[:, col["rpm_m2"]]) <= limit)
    assert status[dt == np.float32(1e-40)][0] != 3          # a denormal period is no fault
    assert status[dt == np.float32(1.2e-5)][0] == 3         # la di/dt beyond the speed range
    assert temp.max() == np.float32(ph.WINDING_MAX_C)       # the winding stops at its limit
    assert temp[-1] < temp.max() and status[-1] != 3        # and decays once the current falls


def test_thermal_trajectory_is_bounded_in_float64_and_float32():
    import numpy as np
    from hpddo.model import fixtures
    from hpddo.model import physics as ph

    p = fixtures.tiny_model().physics
    n_hot, n_calm = 4 * 3600 * 2, 2 * 3600 * 2  # 4 h of full-scale current, 2 h normal, at 2 Hz
    i = np.r_[np.full(n_hot, 10.0), np.full(n_calm, 0.9)]
    dt = np.full(len(i), 0.5)
    ref = np.where(np.arange(len(i)) % 2 == 0, 40.0, 125.0)
    t64 = ph.thermal_trajectory(p, i, dt, ref_C=ref)
    t32 = ph.thermal_trajectory(p, i, dt, np.float32, ref_C=ref)
    for t in (t64, t32):
        assert np.all(np.isfinite(t)) and t.max() <= ph.WINDING_MAX_C and np.all(t >= ref - 1e-3)
    assert np.max(np.abs(t64 - t32)) < 0.05
    calm = ph.thermal_trajectory(p, np.full(n_calm, 0.9), np.full(n_calm, 0.5), ref_C=ref[n_hot:])
    assert abs(t64[-1] - calm[-1]) < 0.5  # recovered
