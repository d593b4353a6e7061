"""Ra as a nuisance parameter of the diagnosis (ranking.RA_MISMATCH): a multimeter reading
10 % off with nothing hidden names no effect and reports the mismatch with the value the
data support; with thermal_ra hidden, thermal_ra is still named; with the reading right,
nothing changes (the bundled recordings still name thermal_ra and magnet_thermal; the
bench's brush drop is selected at +0.1 V, but its interval holds zero: not named). Twin recordings of the ideal bench (Ra 4.5 ohm), seeds 3 and 4."""
import pytest

from conftest import ROOT

from hpddo.diagnosis import core, ranking
import twin_benches

pytestmark = pytest.mark.slow  # runs tools for seconds to minutes: not in scripts/test.sh --quick

SEEDS = (3, 4)
RA_TRUE = 4.5  # the ideal bench's Ra (twin.params.Bench.ra_ohm)


def bench_dir(tmp_root, key, effects, seed):
    bench = twin_benches.bench(effects)
    assert bench.ra_ohm == RA_TRUE
    return twin_benches.recordings(tmp_root / f"{key}_{seed}", bench, seed)


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    return tmp_path_factory.mktemp("twin_ra")


def run(paths, ra):
    return core.diagnose(paths, core.Options(bootstrap=0, hybrid=False, ra_ohm=ra)).to_json()


@pytest.mark.parametrize("factor,seed", twin_benches.alternating((1.1, 0.9), SEEDS))
def test_wrong_ra_alone_names_no_effect_and_reports_the_supported_ra(root, seed, factor):
    res = run(bench_dir(root, "ideal", {}, seed), RA_TRUE * factor)
    fit = res["ra_fit"]
    assert res["missing_effects"] == [], (res["missing_effects"], res["verdict"])
    assert fit["mismatch"] is True, fit
    assert fit["given_ohm"] == pytest.approx(RA_TRUE * factor)
    assert fit["supported_ohm"] == pytest.approx(RA_TRUE, rel=0.03), fit
    assert fit["tolerance"] == ranking.RA_TOLERANCE
    assert res["verdict"].startswith("The Ra you gave"), res["verdict"]
    # the instruction only where it holds across the models that explain the rows about as well (issue
    # 31, item 5): where an effect with Ra at the reading does too, the verdict names the two and what
    # separates them instead
    if fit["confounded_with"]:
        assert "--ra-ohm" not in res["verdict"] and "cannot tell a wrong Ra from" in res["verdict"], res["verdict"]
    else:
        assert f"--ra-ohm {fit['supported_ohm']:.3g}" in res["verdict"], res["verdict"]
    assert "ra_mismatch" in [s["effect"] for s in res["steps"]]
    # Ke's check is made at the Ra the data support, where the wrong reading's held-out errors say nothing of eq. 20
    # (an independent bench, Ra 12 % high: "Ke by eq. 20 (0.4) and by least squares (0.4, -0.01 %) disagree ... a
    # biased Ke"): a disagreement only where the two Ke themselves are apart
    ke = res["ke_check"]
    assert ke["at_reading"] is False and ke["ra_ohm"] == pytest.approx(fit["supported_ohm"]), ke
    assert ke["biased"] is False and ke["disagree"] == (ke["apart"] and abs(ke["eq20"][0] / ke["lsq"][0] - 1) >= 0.02)
    # the corrected Ra brings the physics error down to the effect-free bench's
    ok = run(bench_dir(root, "ideal", {}, seed), RA_TRUE)
    assert res["rmse_rpm"]["after"]["average"] <= 1.05 * ok["rmse_rpm"]["before"]["average"]


@pytest.mark.parametrize("factor,seed", twin_benches.alternating((0.9, 1.1), SEEDS))
def test_wrong_ra_with_thermal_ra_hidden_still_names_thermal_ra(root, seed, factor):
    res = run(bench_dir(root, "thermal_ra", {"thermal_ra": 0.393}, seed), RA_TRUE * factor)
    assert "thermal_ra" in res["missing_effects"], (res["missing_effects"], res["verdict"])
    assert res["ra_fit"]["mismatch"] is True, res["ra_fit"]
    assert res["ra_fit"]["supported_ohm"] == pytest.approx(RA_TRUE, rel=0.05), res["ra_fit"]
    # what it cannot tell from a wrong Ra (an offset, a gain) is said, not named
    assert res["missing_effects"] == ["thermal_ra"], (res["missing_effects"], res["verdict"])
    # its coefficient held at copper's is said as held, not as a fitted result (verdict._size)
    assert "thermal_ra (+0.393 %/K, held at its material's coefficient (copper), not fitted" in res["verdict"], \
        res["verdict"]


@pytest.mark.parametrize("seed", SEEDS)
def test_right_ra_is_no_mismatch(root, seed):
    res = run(bench_dir(root, "ideal", {}, seed), RA_TRUE)
    assert res["missing_effects"] == [] and res["verdict"].startswith("Nothing missing")
    assert res["ra_fit"]["mismatch"] is False
    res = run(bench_dir(root, "thermal_ra", {"thermal_ra": 0.393}, seed), RA_TRUE)
    assert res["missing_effects"] == ["thermal_ra"] and res["ra_fit"]["mismatch"] is False


def test_bundled_recordings_unchanged_with_the_reading_right():
    paths = [ROOT / "data" / "default" / f"{p}.csv" for p in ("load", "long", "sweep")]
    res = core.diagnose(paths, core.Options(bootstrap=0, hybrid=False)).to_json()
    assert res["missing_effects"] == ["thermal_ra", "magnet_thermal"], res["verdict"]
    brush = next(e for e in res["ranking"] if e["effect"] == "brush_drop")
    assert not brush["named"] and "holds zero" in brush["note"], brush
    assert res["ra_fit"]["mismatch"] is False and res["ra_fit"]["confounded_with"] == []
    assert "The Ra you gave" not in res["verdict"]
