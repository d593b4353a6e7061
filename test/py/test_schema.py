"""The one declaration of every physics parameter and effect (tools/hpddo/schema.py): the
generated files regenerate byte for byte, and everything that used to be kept in step by
hand (the C++ struct and bits, the checksum order, the Python dataclass, the library, the
twin's names and units, the separating recordings) is derived from it."""
import dataclasses
import re
import shutil
import subprocess
import zlib

import pytest

from conftest import ROOT
from hpddo.model import effects as fx
from hpddo.model import export, fixtures
from hpddo import regenerate, schema
from hpddo.model import physics as ph
from hpddo.diagnosis import ranking
from hpddo.twin import params as twin


def test_generated_files_regenerate_identically():
    files = regenerate.generated()
    assert {"lib/hpddo_core/src/hpddo/params_gen.h", "docs/core.md", "docs/twin.md", "docs/ripple-counting.md"} <= set(files)
    for rel, text in files.items():
        assert (ROOT / rel).read_bytes() == text.encode(), f"{rel} differs: run {regenerate.COMMAND}"


def test_check_mode_reports_a_stale_file(tmp_path, capsys):
    assert regenerate.main(["--check"]) == 0
    for rel in regenerate.generated():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
    # the document around its generated block is the user's: only the block is rewritten
    doc = (ROOT / regenerate.EFFECTS_DOC).read_text()
    what, source = "the effects table", "tools/hpddo/schema.py"
    begin = regenerate.DOC_BEGIN.format(what=what, source=source, command=regenerate.COMMAND)
    end = regenerate.DOC_END.format(what=what)
    (tmp_path / regenerate.EFFECTS_DOC).write_text("# prose\n" + begin + "\n| stale |\n" + end + "\nmore prose\n")
    twin = (ROOT / regenerate.TWIN_DOC).read_text()  # the twin's block: as committed (up to date)
    (tmp_path / regenerate.TWIN_DOC).write_text(twin)
    (tmp_path / regenerate.RIPPLE_DOC).write_text((ROOT / regenerate.RIPPLE_DOC).read_text())  # as committed
    (tmp_path / regenerate.CAPTURES_DOC).write_text((ROOT / regenerate.CAPTURES_DOC).read_text())  # as committed
    (tmp_path / regenerate.HEADER_DOC).write_text((ROOT / regenerate.HEADER_DOC).read_text())  # as committed
    assert regenerate.main(["--check", "--root", str(tmp_path)]) == 1
    assert regenerate.main(["--write", "--root", str(tmp_path)]) == 0
    assert regenerate.main(["--check", "--root", str(tmp_path)]) == 0
    text = (tmp_path / regenerate.EFFECTS_DOC).read_text()
    assert text.startswith("# prose\n") and text.endswith(end + "\nmore prose\n") and "| stale |" not in text
    for e in schema.EFFECTS:
        assert f"| {e.name} | `{e.field}` | {e.unit} | {e.show_unit} |" in text
    capsys.readouterr()


def test_the_model_header_page_names_every_symbol_and_field_of_a_committed_header():
    """docs/model-header.md lists, in the writer's order, every symbol of the committed
    headers (the tiny fixture, the deployed model), and every physics field with its unit."""
    page = (ROOT / regenerate.HEADER_DOC).read_text()
    for rel in ("test/fixtures/model_tiny.h", "models/default/model_default.h"):
        symbols = export.header_symbols((ROOT / rel).read_text())
        assert len(symbols) >= 17, rel
        for name, key, _ in symbols:
            assert key in export.HEADER_SYMBOLS, f"{rel}: {name} has no meaning in export.HEADER_SYMBOLS"
            assert f"| `{name}` |" in page, f"{regenerate.HEADER_DOC} does not list {name} of {rel}"
    rows = [ln for ln in page.splitlines() if ln.startswith("| `k") or ln.startswith("| `Net`")]
    assert [r.split("`")[1] for r in rows] == [n for n, _, _ in export.header_symbols(
        export.model_header(fixtures.with_dynamics(fixtures.tiny_model(*fixtures.FIXTURES["tiny"])), "tiny", {}))]
    for k, field in enumerate(schema.FIELDS):
        unit = schema.UNITS.get(field, "bits")
        assert f"| {k} | `{field}` | {unit} |" in page, field
    assert regenerate.HEADER_DOC.removeprefix("docs/") in (ROOT / "mkdocs.yml").read_text()
    assert "model-header.md" in (ROOT / "docs/core.md").read_text()


def test_a_header_symbol_without_a_meaning_stops_the_page(monkeypatch):
    declared = export.HEADER_SYMBOLS
    monkeypatch.setattr(export, "HEADER_SYMBOLS", {k: v for k, v in declared.items() if k != "kEnvHi"})
    with pytest.raises(ValueError, match="kEnvHi"):
        export.header_md()
    monkeypatch.setattr(export, "HEADER_SYMBOLS", dict(declared, kGone="never written"))
    with pytest.raises(ValueError, match="kGone"):
        export.header_md()


def test_banner_carries_provenance_and_the_checksum_of_the_text():
    text = (ROOT / "lib/hpddo_core/src/hpddo/params_gen.h").read_text()
    banner, body = text.split("#ifndef", 1)
    assert banner.startswith("// GENERATED") and "DO NOT EDIT" in banner
    assert f"// command: {regenerate.COMMAND}" in banner and "// source: tools/hpddo/schema.py" in banner
    crc = int(re.search(r"checksum: crc32 0x([0-9a-f]{8})", banner).group(1), 16)
    assert crc == zlib.crc32(("#ifndef" + body).encode())
    assert f"kParamsSchema = 0x{schema.layout_crc():08x}u" in body


def test_the_header_declares_every_field_and_bit_in_the_schema_order():
    body = (ROOT / "lib/hpddo_core/src/hpddo/params_gen.h").read_text()
    struct = body[body.index("struct PhysicsParams {"):body.index("};", body.index("struct PhysicsParams {"))]
    assert re.findall(r"(?:float|uint16_t) (\w+);", struct) == list(schema.FIELDS)
    visit = body[body.index("inline void for_each_param"):]
    assert re.findall(r"f\(p\.(\w+)\);", visit) == list(schema.FIELDS)
    for e in schema.EFFECTS:
        assert f"{e.cpp_name} = 1u << {e.bit_index}," in body
    # physics.h no longer declares them by hand
    physics_h = (ROOT / "lib/hpddo_core/src/hpddo/physics.h").read_text()
    assert "struct PhysicsParams" not in physics_h and "kEffectThermalRa" not in physics_h


def test_python_params_bits_library_and_separators_come_from_the_schema():
    assert ph.PhysicsParams is schema.PhysicsParams and ph.EFFECT_BITS is schema.EFFECT_BITS
    assert tuple(f.name for f in dataclasses.fields(ph.PhysicsParams)) == schema.FIELDS
    assert ph.PhysicsParams.FIELDS == schema.FLOAT_FIELDS
    p = ph.PhysicsParams(ra_ohm=4.5, ke_vs_per_rad=0.4)
    assert (p.t_ref_C, p.t_amb_C, p.effects) == (25.0, 25.0, 0)
    assert all(getattr(p, e.field) == 0.0 for e in schema.EFFECTS)
    assert list(fx.LIBRARY.values()) == list(schema.EFFECTS)
    assert ranking.SEPARATORS is schema.SEPARATORS
    for pair in schema.SEPARATORS:
        assert len(pair) == 2 and pair <= set(fx.LIBRARY)
    assert [e.bit for e in schema.EFFECTS] == [1 << k for k in range(len(schema.EFFECTS))]


def test_the_twin_takes_its_effect_names_and_units_from_the_schema():
    # every bench effect is declared (a model effect need not be on the bench)
    assert set(twin.EFFECT_NAMES) <= set(schema.ALL_EFFECTS)
    assert {b.name for b in schema.BENCH_EFFECTS} <= set(twin.EFFECT_NAMES)
    for name, e in twin.EFFECTS.items():
        decl = schema.effect(name)
        assert e.unit == decl.show_unit and e.si_unit == decl.unit
        assert e.to_si(e.default) == pytest.approx(e.default / decl.show_scale)
    bench = twin.preset()
    assert bench.effect_si("current_offset") == pytest.approx(0.008)
    assert bench.effect_si("thermal_ra") == pytest.approx(0.00393)


def test_the_checksum_covers_every_field_and_the_effect_bits_in_the_schema_order():
    model = fixtures.tiny_model()
    floats = export.checksum_floats(model)
    p = model.physics
    assert list(floats[:len(schema.FIELDS)]) == [float(getattr(p, f)) for f in schema.FIELDS]
    base = export.model_checksum(model)
    for f in schema.FIELDS:
        other = dataclasses.replace(model, physics=dataclasses.replace(p, **{f: getattr(p, f) + 1}))
        assert export.model_checksum(other) != base, f


@pytest.mark.parametrize("path", ["test/fixtures/model_tiny.h", "test/fixtures/model_tiny1.h",
                                  "models/default/model_default.h"])
def test_model_headers_label_every_physics_value(path):
    text = (ROOT / path).read_text()
    assert f"hpddo::kParamsSchema == 0x{schema.layout_crc():08x}u" in text
    assert f"hpddo::kPhysicsParamCount == {len(schema.FIELDS)}" in text
    model = text[text.index("kModel = {"):]
    labels = re.findall(r",\s+// (\w+)", model[:model.index("{kScalerMean")])
    assert labels == list(schema.FIELDS)
    assert re.search(r"kEffects,\s+// effects", model)  # the checksummed bits are kEffects


def test_the_struct_layout_follows_the_schema(tmp_path):
    """Compiled: the fields lie in memory in the schema's order and for_each_param visits
    them in it."""
    cxx = shutil.which("g++") or shutil.which("c++")
    if not cxx:
        pytest.skip("no C++ compiler (g++): run scripts/bootstrap.sh")
    offs = ", ".join(f"offsetof(hpddo::PhysicsParams, {f})" for f in schema.FIELDS)
    src = tmp_path / "layout.cpp"
    src.write_text(f"""#include <cstddef>
#include <cstdio>
#include "hpddo/params_gen.h"
struct Addr {{
  const char* base; int n;
  void operator()(const float& x) {{ std::printf("%d ", static_cast<int>(reinterpret_cast<const char*>(&x) - base)); ++n; }}
  void operator()(const uint16_t& x) {{ std::printf("%d ", static_cast<int>(reinterpret_cast<const char*>(&x) - base)); ++n; }}
}};
int main() {{
  const hpddo::PhysicsParams p = hpddo::PhysicsParams();
  Addr a = {{reinterpret_cast<const char*>(&p), 0}};
  hpddo::for_each_param(p, a);
  const size_t offs[] = {{{offs}}};
  std::printf("| ");
  for (size_t o : offs) std::printf("%d ", static_cast<int>(o));
  std::printf("| %d %d\\n", a.n, static_cast<int>(hpddo::kPhysicsParamCount));
}}
""")
    exe = tmp_path / "layout"
    subprocess.run([cxx, "-std=c++11", "-Wall", "-Wextra", "-Werror", f"-I{ROOT / 'lib/hpddo_core/src'}",
                    str(src), "-o", str(exe)], check=True)
    visited, offsets, counts = subprocess.run([str(exe)], capture_output=True, text=True,
                                              check=True).stdout.split("|")
    assert visited.split() == offsets.split()
    assert [int(o) for o in offsets.split()] == sorted(int(o) for o in offsets.split())
    assert counts.split() == [str(len(schema.FIELDS))] * 2


def test_the_worked_example_names_the_generator():
    example = (ROOT / "docs/add-effect.md").read_text()
    assert "python -m hpddo.regenerate --write" in example and "tools/hpddo/schema.py" in example
