"""docs/figures/ripple_spectrum.svg is what hpddo.studies.ripple_spectrum draws from the committed
burst, the burst is what the twin writes, and docs/ripple.md quotes the picture's figures."""
from conftest import ROOT

import pytest

from hpddo.logs.errors import InputError
from hpddo.ripple import comb as rc
from hpddo.studies import ripple_spectrum as rs


def test_the_picture_is_what_its_code_draws_from_the_committed_burst():
    assert (ROOT / rs.SVG).read_text(encoding="utf-8") == rs.svg(), f"{rs.SVG} is out of date: {rs.COMMAND}"
    assert rs.svg() == rs.svg()  # drawn twice, the same bytes


def test_the_committed_burst_is_what_the_twin_writes():
    assert (ROOT / rs.BURST).read_text(encoding="utf-8") == rs.burst_text(), \
        f"{rs.BURST} is out of date: {rs.COMMAND} --write-burst"


def test_the_picture_marks_a_comb_the_ripple_code_finds_and_the_page_quotes_it():
    m = rs.measure()
    c = m["comb"]
    assert c.multiple == m["opts"].ripples_per_rev and not m["damaged"]
    assert c.commutation.hz == pytest.approx(c.multiple * c.rot_hz, rel=rc.COMB_REL_TOL)
    assert len(c.lines) >= rc.COMB_MIN_LINES + 1
    page = (ROOT / "docs/ripple.md").read_text(encoding="utf-8")
    assert "figures/ripple_spectrum.svg" in page and rs.COMMAND in page
    assert rs.caption(m) in page.replace("\n", " "), f"docs/ripple.md does not quote: {rs.caption(m)}"
    assert rs.caption(m) in rs.svg()


def test_a_burst_without_a_comb_or_its_motor_is_refused_naming_the_file(tmp_path):
    text = (ROOT / rs.BURST).read_text(encoding="utf-8")
    head, rows = text.split("seq,t_s,n,codes\n")
    flat = tmp_path / "flat.ripple.csv"  # a constant current: no line, no comb
    flat.write_text(head + "seq,t_s,n,codes\n1,0.5,5000," + " ".join(["80"] * 5000) + "\n")
    with pytest.raises(InputError, match="flat.ripple.csv.*no rotation comb"):
        rs.measure(flat)
    bare = tmp_path / "bare.ripple.csv"
    bare.write_text("".join(ln + "\n" for ln in head.splitlines() if not ln.startswith("# ripples_per_rev"))
                    + "seq,t_s,n,codes\n" + rows)
    with pytest.raises(InputError, match="bare.ripple.csv.*ripples_per_rev"):
        rs.measure(bare)
