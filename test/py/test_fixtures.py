"""The committed core fixtures regenerate byte for byte from their generator."""
import pathlib

from conftest import ROOT

import gen_fixtures


def test_fixtures_regenerate_identically(tmp_path: pathlib.Path):
    gen_fixtures.main(["--out", str(tmp_path)])
    committed = ROOT / "test" / "fixtures"
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names, "generator wrote nothing"
    for name in names:
        assert (tmp_path / name).read_bytes() == (committed / name).read_bytes(), f"{name} differs: run tools/gen_fixtures.py"
