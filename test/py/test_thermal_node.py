"""The winding's thermal node: its parameters (th_r_K_per_W, th_tau_s) are declared once with
plausible and physical ranges per heat path (schema.NODE), the effect fits hold them within
the physical range, and their plausibility is reported beside the effects' (diagnosis.json,
the summary)."""
import dataclasses

import pytest

from conftest import ROOT

from hpddo.logs import dataset
from hpddo.model import identify
from hpddo import schema
from hpddo.model import effects as fx
from hpddo.cli import diagnose as diagnose_cli

DEFAULT = [ROOT / "data" / "default" / f"{c}.csv" for c in ("load", "long", "sweep")]
NAMES = ["thermal_ra", "current_offset", "magnet_thermal"]


def test_declared_once_per_path():
    for path in schema.NODE_PATHS:
        r, tau = fx.node_params(path == "ambient")
        assert (r.field, tau.field) == ("th_r_K_per_W", "th_tau_s")
        for n in (r, tau):
            lo, hi = n.plausible
            assert n.physical == (lo / 2, 2 * hi)
            assert lo <= n.start <= hi
    # the twin's own node lies within the plausible ranges: winding to case 6 J/K x 1.5 K/W,
    # winding to ambient 1.5 + 6.3 K/W with the slow mode at 1424 s
    case, amb = fx.node_params(False), fx.node_params(True)
    assert case[0].plausibility(1.5)[0] and case[1].plausibility(9.0)[0]
    assert amb[0].plausibility(7.8)[0] and amb[1].plausibility(1424.0)[0]
    # the fit's 3.3 s on data/default before the bound is not physical on the case path
    assert not case[1].physical[0] <= 3.3 <= case[1].physical[1]


def test_plausibility_text_and_bound():
    tau = schema.node_param("case", "th_tau_s")
    ok, text = tau.plausibility(30.0)
    assert ok and "within the plausible 8..300 s" in text and "edge" not in text
    ok, text = tau.plausibility(tau.physical[0])
    assert not ok and "outside the plausible" in text and "edge of the physical" in text


@pytest.fixture(scope="module")
def default_fit():
    recs = dataset.load_recordings(DEFAULT)
    ra, _ = identify.ra_from_logs(recs, None)
    m2 = identify.m2_params(recs, ra)
    return recs, m2, fx.identify(recs, m2, NAMES)


def test_default_fit_within_physical(default_fit):
    """data/default reads the case: the node is the winding-to-case path. Unbounded, its
    time constant came out at 3.27 s; the fit now stops at the physical edge, 4 s, and says so."""
    _, _, p = default_fit
    node = fx.node_plausibility(p, blind=False)
    assert [q["field"] for q in node] == ["th_r_K_per_W", "th_tau_s"]
    for q, n in zip(node, fx.node_params(False)):
        assert n.physical[0] <= q["value"] <= n.physical[1]
        assert q["physical"]
    r, tau = node
    assert r["plausible"] and not r["at_bound"]
    assert tau["at_bound"] and tau["value"] == pytest.approx(4.0) and not tau["plausible"]


def test_blind_fit_within_physical(default_fit):
    """Without any temperature reading the node runs above ambient and is bounded by the
    ambient path's ranges."""
    recs, m2, _ = default_fit
    blind = []
    for r in recs:
        rb = dataclasses.replace(r, df=r.df.drop(columns=["temp_C"]))
        blind.append(rb)
    p = fx.identify(blind, dataclasses.replace(m2), ["thermal_ra"])
    assert p.ra_tc_per_K == fx.COPPER_TC_PER_K  # held: the temperature scale is unknown
    for q, n in zip(fx.node_plausibility(p, blind=True), fx.node_params(True)):
        assert q["path"] == "ambient"
        assert n.physical[0] <= q["value"] <= n.physical[1]


def test_summary_shows_node():
    """The summary prints the winding node's plausibility under the named effects."""

    class D:
        def to_json(self):
            row = {"effect": "thermal_ra", "named": True, "inclusion": None, "shown": "+0.393 %/K", "score": 0.5,
                   "plausibility": "ok"}
            rm = {"before": {"a": 1.0, "average": 1.0}, "after": {"a": 0.5, "average": 0.5}}
            node = fx.node_plausibility(dataclasses.replace(default_model(), th_r_K_per_W=3.0, th_tau_s=4.0),
                                        blind=False)
            return {"verdict": "Missing: thermal_ra.", "ranking": [row], "rmse_rpm": rm,
                    "thermal_node": {"path": "case", "model": [], "after_model": node}}

    text = diagnose_cli.summary(D())
    assert "winding node (case path" in text
    assert "th_tau_s" in text and "edge of the physical 4..600 s" in text
    lo, hi = schema.node_param("case", "th_r_K_per_W").plausible
    assert "th_r_K_per_W" in text and f"within the plausible {lo:.3g}..{hi:.3g} K/W" in text


def default_model():
    return schema.PhysicsParams(ra_ohm=4.5, ke_vs_per_rad=0.37, effects=fx.LIBRARY["thermal_ra"].bit)
