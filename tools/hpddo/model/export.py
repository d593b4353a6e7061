"""Writes generated C++ headers for lib/hpddo_core: a model header and golden vectors.

Both carry a DO-NOT-EDIT banner with their provenance. The model header carries a CRC-32
over the float32 little-endian bytes of everything it stores, in the order of
`checksum_floats`; hpddo::model_checksum() recomputes it on any target. The physics
parameters are written one labelled value per field, in the order of their declaration
(schema.FIELDS, the generated hpddo::PhysicsParams and hpddo::for_each_param), and the
header asserts that it was written for the core's parameter layout (kParamsSchema). Floats are written
with %.9g, which round-trips every float32 exactly.
"""
from __future__ import annotations

import hashlib
import pathlib
import zlib

import numpy as np

from . import physics as ph
from .. import schema
from .gate import DEFAULT_PROTOTYPES
from .observer_ref import ModelData, ReferenceObserver

GENERATOR = "hpddo.model.export 2"
GATE_PROTOTYPES = DEFAULT_PROTOTYPES  # hpddo::kGatePrototypes; the header asserts they agree


def c_float(x, allow_nonfinite: bool = False) -> str:
    """A float32 as a C++ literal that parses back to the same float."""
    x = np.float32(x)
    if allow_nonfinite and np.isnan(x):
        return '__builtin_nanf("")'
    if allow_nonfinite and np.isinf(x):
        return "__builtin_inff()" if x > 0 else "-__builtin_inff()"
    if not np.isfinite(x):
        raise ValueError(f"non-finite value {x} cannot be exported")
    s = "%.9g" % float(x)
    if not any(c in s for c in ".en"):
        s += ".0"
    return s + "f"


def c_array(name: str, values, per_line: int = 6, flash: bool = True, allow_nonfinite: bool = False) -> str:
    vals = [c_float(v, allow_nonfinite) for v in np.asarray(values, np.float32).ravel()]
    lines = [", ".join(vals[k:k + per_line]) for k in range(0, len(vals), per_line)]
    attr = "HPDDO_FLASH " if flash else ""
    body = ",\n    ".join(lines)
    return f"{attr}static const float {name}[{len(vals)}] = {{\n    {body}}};\n"


def sha256_of_files(paths) -> str:
    h = hashlib.sha256()
    for p in sorted(str(p) for p in paths):
        h.update(pathlib.Path(p).read_bytes())
    return h.hexdigest()


def network_arrays(model: ModelData):
    """(name, array) of the network in the C++ MlpWeights order w0 b0 w1 b1 [w2 b2]."""
    out = []
    for k, (w, b) in enumerate(model.layers):
        out += [(f"kW{k}", np.asarray(w, np.float32)), (f"kB{k}", np.asarray(b, np.float32))]
    return out


def checksum_floats(model: ModelData) -> np.ndarray:
    """The float32 sequence the model checksum covers (must match hpddo::model_checksum)."""
    p = model.physics
    parts = [np.array([float(getattr(p, f)) for f in schema.FIELDS], np.float32),
             np.asarray(model.scaler_mean, np.float32), np.asarray(model.scaler_scale, np.float32)]
    parts += [a.ravel() for _, a in network_arrays(model)]
    lim = model.limits
    g = model.gate
    parts += [np.asarray(model.env_lo, np.float32), np.asarray(model.env_hi, np.float32),
              np.asarray(g.centre, np.float32), np.asarray(g.scale, np.float32),
              np.asarray(g.prototypes, np.float32).ravel(), np.array([g.r_in_sq, g.r_out_sq], np.float32),
              np.array([model.clamp_rpm, lim.v_max_V, lim.i_max_A, lim.temp_min_C, lim.temp_max_C], np.float32)]
    parts += [dynamics_floats(model)]
    return np.concatenate(parts).astype("<f4")


# BEGIN the dynamic family (issue 21, item 8): kDynamics, in a header only where the model names it


def dynamics_floats(model: ModelData) -> np.ndarray:
    """The dynamic family's floats the checksum covers, last (hpddo::model_checksum(m, d)):
    the DynamicsParams fields in the schema's order where named, none otherwise (a model
    without the family keeps its checksum)."""
    if not model.dynamics_named:
        return np.zeros(0, np.float32)
    return np.array([model.dynamics[d.field] for d in schema.DYNAMICS], np.float32)


def _c_dynamics(model: ModelData, ns: str | None = None) -> str:
    """kDynamics of a header (ns: a reference to that namespace's), or "" where not named."""
    if not model.dynamics_named:
        return ""
    head = ("/// The dynamic family (dynamics.h; Observer(kModel, kDynamics)), covered by kChecksum: "
            + ", ".join(d.show(float(model.dynamics[d.field])) for d in schema.DYNAMICS) + ".\n")
    if ns is not None:
        return head + f"static constexpr const hpddo::DynamicsParams& kDynamics = {ns}::kDynamics;\n\n"
    body = "".join(f"    {(c_float(model.dynamics[d.field]) + ',').ljust(16)}  // {d.field} [{d.unit}]\n"
                   for d in schema.DYNAMICS)
    return (head + f"static_assert(hpddo::kDynamicsParamCount == {len(schema.DYNAMICS)}, "
            "\"one initialiser per hpddo::DynamicsParams field\");\n"
            f"static constexpr hpddo::DynamicsParams kDynamics = {{\n{body}}};\n\n")


def _read_dynamics(text: str) -> dict | None:
    """The kDynamics of a header written by model_header(), or None."""
    import re
    m = re.search(r"static constexpr hpddo::DynamicsParams kDynamics = \{([^}]*)\}", text)
    if m is None:
        return None
    vals = {lab: float(v.rstrip(",").rstrip("f")) for v, lab in re.findall(r"^\s+(\S+),?\s+// (\w+)", m.group(1), re.M)}
    from .dynamics_ref import dynamics_params
    return dynamics_params(**vals)

# END the dynamic family


def model_checksum(model: ModelData) -> int:
    return zlib.crc32(checksum_floats(model).tobytes()) & 0xFFFFFFFF


def _banner(kind: str, provenance: dict) -> str:
    lines = [f"// GENERATED {kind}: DO NOT EDIT. Regenerate with the command below."]
    lines += [f"// {k}: {v}" for k, v in provenance.items()]
    return "\n".join(lines) + "\n"


def _c_physics(p: ph.PhysicsParams, bits: str, indent: str = "    ") -> str:
    """A PhysicsParams initialiser: one value per field, in the schema's order, each
    labelled with its field and unit; `bits` is the expression of the effect bits."""
    vals = [c_float(getattr(p, f)) for f in schema.FLOAT_FIELDS] + [bits]
    labels = [f"{f} [{schema.UNITS[f]}]" for f in schema.FLOAT_FIELDS] + [schema.BITS_FIELD]
    width = max(len(v) for v in vals) + 1
    body = "".join(f"{indent}    {(v + ',').ljust(width)}  // {lab}\n" for v, lab in zip(vals, labels))
    return f"{{\n{body}{indent}}}"


def _c_layout_asserts(name: str) -> str:
    return (f"/// The physics initialisers are positional: this header holds for one parameter layout.\n"
            f"static_assert(hpddo::kParamsSchema == 0x{schema.layout_crc():08x}u,\n"
            f"              \"model_{name}.h was written for another parameter layout "
            f"(tools/hpddo/schema.py): regenerate it\");\n"
            f"static_assert(hpddo::kPhysicsParamCount == {len(schema.FIELDS)}, "
            f"\"one initialiser per hpddo::PhysicsParams field\");\n\n")


def model_header(model: ModelData, name: str, provenance: dict) -> str:
    """Text of the model header `model_<name>.h`; namespace hpddo_model_<name>."""
    hidden = model.hidden
    if len(hidden) not in (1, 2):
        raise ValueError(f"the core supports one or two hidden layers, got {hidden}")
    h2 = hidden[1] if len(hidden) == 2 else 0
    shape = "-".join(str(n) for n in (5, *hidden, 1))
    crc = model_checksum(model)
    prov = dict(provenance)
    prov.update(generator=GENERATOR, shapes=shape, checksum=f"crc32 0x{crc:08x}",
                parameter_layout=f"crc32 0x{schema.layout_crc():08x} (hpddo::kParamsSchema, {schema.GENERATOR})")
    guard = f"HPDDO_MODEL_{name.upper()}_H"
    p = model.physics
    out = [_banner("model header", prov), f"#ifndef {guard}\n#define {guard}\n\n#include <stdint.h>\n\n",
           '#include "hpddo_core.h"\n\n', f"namespace hpddo_model_{name} {{\n\n",
           f"typedef hpddo::Mlp<5, {hidden[0]}, {h2}> Net;\n\n",
           f"/// CRC-32 over the stored floats (see hpddo::model_checksum).\nstatic const uint32_t kChecksum = 0x{crc:08x}u;\n\n",
           f"/// Effects in the physics model: {', '.join(p.effect_names()) or 'none'} (kModel.physics.effects).\n",
           f"static const uint16_t kEffects = 0x{p.effects:04x}u;\n\n",
           c_array("kScalerMean", model.scaler_mean), c_array("kScalerScale", model.scaler_scale)]
    for cname, arr in network_arrays(model):
        out.append(c_array(cname, arr))
    g = model.gate
    if g.dims != 5 or g.count != GATE_PROTOTYPES:
        raise ValueError(f"the core's gate has 5 inputs and {GATE_PROTOTYPES} prototypes, got {g.dims} and {g.count}")
    out += [c_array("kEnvLo", model.env_lo), c_array("kEnvHi", model.env_hi),
            f"/// Novelty gate: {g.rule}.\n" if g.rule else "",
            c_array("kGateCentre", g.centre), c_array("kGateScale", g.scale),
            c_array("kGatePrototypes", g.prototypes, per_line=5), "\n",
            f"static_assert(hpddo::kGatePrototypes == {GATE_PROTOTYPES}, \"the core's gate size (model.h) is "
            f"hpddo.model.gate.DEFAULT_PROTOTYPES\");\n"]
    counts = ["kW0Count", "kW1Count", "kW2Count"]
    for k, (cname, arr) in enumerate(network_arrays(model)):
        if cname.startswith("kW"):
            out.append(f'static_assert(sizeof({cname}) / sizeof(float) == Net::{counts[k // 2]}, "{cname} shape");\n')
    nlayers = len(model.layers)
    ptr = lambda k: (f"kW{k}", f"kB{k}") if k < nlayers else ("nullptr", "nullptr")
    w_init = ", ".join(f"{a}, {b}" for a, b in (ptr(0), ptr(1), ptr(2)))
    phys = _c_physics(p, "kEffects")
    m1 = model.nameplate or ph.nameplate_params(p.ra_ohm)
    lim = model.limits
    out += ["\n", _c_layout_asserts(name), "/// The deployed model.\nstatic const hpddo::Model<Net> kModel = {\n",
            f"    {phys},\n", "    {kScalerMean, kScalerScale},\n", f"    {{{w_init}}},\n",
            "    {kEnvLo, kEnvHi},\n",
            f"    {{kGateCentre, kGateScale, kGatePrototypes, {c_float(g.r_in_sq)}, {c_float(g.r_out_sq)}}},\n",
            f"    {c_float(model.clamp_rpm)},\n",
            f"    {{{c_float(lim.v_max_V)}, {c_float(lim.i_max_A)}, {c_float(lim.temp_min_C)}, {c_float(lim.temp_max_C)}}},\n",
            "};\n\n",
            "/// The nameplate model M1 (rated voltage over rated speed), for comparison only.\n",
            f"static const hpddo::PhysicsParams kNameplate = {_c_physics(m1, f'0x{m1.effects:04x}u', '')};\n\n",
            _c_dynamics(model),
            f"}}  // namespace hpddo_model_{name}\n\n#endif  // {guard}\n"]
    return "".join(out)


# Columns of a golden row: inputs, then the expected output of every stage.
GOLDEN_INPUTS = ["v_V", "i_A", "temp_C", "dt_s", "seq", "has_seq"]
GOLDEN_STAGES = ["x0", "x1", "x2", "x3", "x4", "z0", "z1", "z2", "z3", "z4", "mlp_rpm",
                 "rpm_m2", "residual_rpm", "rpm", "temp_used_C", "confidence", "status"]


def golden_rows(model: ModelData, samples) -> np.ndarray:
    """Runs the float32 reference over samples (v, i, temp, dt, seq-or-None); one row each."""
    obs = ReferenceObserver(model)
    rows = []
    for v, i, t, dt, seq in samples:
        o = obs.step(v, i, t, dt, seq)
        rows.append([v, i, np.nan if t is None else t, dt, 0 if seq is None else seq, 0 if seq is None else 1,
                     *o["x"], *o["z"], o["mlp_rpm"], o["rpm_m2"], o["residual_rpm"], o["rpm"], o["temp_C"],
                     o["confidence"], o["status"]])
    return np.asarray(rows, np.float32)


def golden_header(rows: np.ndarray, name: str, provenance: dict) -> str:
    """Text of `golden_<name>.h`: one flat float table kRows[kCount * kWidth] in flash."""
    guard = f"HPDDO_GOLDEN_{name.upper()}_H"
    cols = GOLDEN_INPUTS + GOLDEN_STAGES
    prov = dict(provenance)
    prov.update(generator=GENERATOR, rows=len(rows), columns=" ".join(cols))
    enums = ",\n".join(f"  kCol_{c} = {k}" for k, c in enumerate(cols))
    return "".join([
        _banner("golden vectors", prov), f"#ifndef {guard}\n#define {guard}\n\n#include <stdint.h>\n\n",
        '#include "hpddo/observer.h"\n#include "hpddo/platform.h"\n\n', f"namespace hpddo_golden_{name} {{\n\n",
        f"enum Column : uint8_t {{\n{enums}\n}};\n\n",
        f"static const uint16_t kCount = {len(rows)};\nstatic const uint8_t kWidth = {len(cols)};\n\n",
        "/// Row r, column c is kRows[r * kWidth + c]; NaN marks an absent reading or an unreached stage.\n",
        c_array("kRows", rows, per_line=len(cols), allow_nonfinite=True),
        "\n/// Value of row r, column c.\n",
        "inline float at(uint16_t r, uint8_t c) { return hpddo::flash_float(kRows + static_cast<uint32_t>(r) * kWidth + c); }\n\n",
        "/// The observer input of row r.\n",
        "inline hpddo::Sample sample(uint16_t r) {\n",
        "  hpddo::Sample s;\n  s.v_V = at(r, kCol_v_V);\n  s.i_A = at(r, kCol_i_A);\n  s.temp_C = at(r, kCol_temp_C);\n",
        "  s.dt_s = at(r, kCol_dt_s);\n  s.seq = static_cast<uint16_t>(at(r, kCol_seq));\n",
        "  s.has_seq = at(r, kCol_has_seq) != 0.0f;\n  return s;\n}\n",
        f"\n}}  // namespace hpddo_golden_{name}\n\n#endif  // {guard}\n"])


def golden_csv(rows: np.ndarray) -> str:
    """The same golden rows as CSV, for Python tests and people."""
    cols = GOLDEN_INPUTS + GOLDEN_STAGES
    lines = [",".join(cols)] + [",".join("%.9g" % float(v) for v in r) for r in rows]
    return "\n".join(lines) + "\n"


# The fixed-point network (quant.py, mlp_q.h), exported beside the float one.
GOLDEN_Q_STAGES = ["x0", "x1", "x2", "x3", "x4", "mlp_rpm", "rpm_m2", "residual_rpm", "rpm", "temp_used_C",
                   "confidence", "status"]
GOLDEN_Q_INTS = ["xq0", "xq1", "xq2", "xq3", "xq4", "acc"]


def model_checksum_q(model: ModelData, q) -> int:
    """CRC-32 of a fixed-point model (hpddo::model_checksum over Model<MlpQ<...>>): as the
    float model's, with the network's and the gate's bytes (quant.weight_bytes,
    quant.gate_bytes) in place of their floats."""
    from . import quant
    f = checksum_floats(model)
    n_phys = len(schema.FIELDS) + 2 * len(model.scaler_mean)
    n_net = sum(np.asarray(a).size for _, a in network_arrays(model))
    n_env = 2 * len(model.env_lo)
    g = model.gate
    n_gate = 2 * g.dims + g.dims * g.count + 2
    data = (f[:n_phys].tobytes() + quant.weight_bytes(q) + f[n_phys + n_net:n_phys + n_net + n_env].tobytes()
            + quant.gate_bytes(q.gate) + f[n_phys + n_net + n_env + n_gate:].tobytes())
    return zlib.crc32(data) & 0xFFFFFFFF


def model_header_q(model: ModelData, q, name: str, provenance: dict, suffix: str = "q") -> str:
    """Text of `model_<name>_<suffix>.h`, namespace hpddo_model_<name>_<suffix>: the fixed-point
    network (quant.QuantNet of this model) with the float header's physics, scaler (folded into
    the network, kept for the record), envelope and gate; it includes model_<name>.h. suffix:
    "q" the int16 model, "q8" the int8 one."""
    from . import quant
    hidden = q.hidden
    h2 = hidden[1] if len(hidden) == 2 else 0
    shifts = list(q.shifts) + [0] * (2 - len(q.shifts))
    crc = model_checksum_q(model, q)
    prov = dict(provenance)
    prov.update(generator=GENERATOR, quantiser="hpddo.model.quant (tools/hpddo/model/quant.py)",
                shapes="-".join(str(n) for n in (5, *hidden, 1)),
                weights=f"layer 0 {q.first_type} (scaler folded in), hidden {q.hidden_type}, output int16; int32 sums",
                shifts=" ".join(map(str, q.shifts)), checksum=f"crc32 0x{crc:08x}")
    guard = f"HPDDO_MODEL_{name.upper()}_{suffix.upper()}_H"
    f = f"hpddo_model_{name}"
    wt = quant.C_TYPES[q.hidden_type]
    w0t = "" if q.first_type == "int16" else f", {quant.C_TYPES[q.first_type]}"  # MlpQ's default: int16_t
    out = [_banner("fixed-point model header", prov), f"#ifndef {guard}\n#define {guard}\n\n#include <stdint.h>\n\n",
           f'#include "model_{name}.h"\n\n', f"namespace hpddo_model_{name}_{suffix} {{\n\n",
           f"typedef hpddo::MlpQ<5, {hidden[0]}, {h2}, {wt}, {shifts[0]}, {shifts[1]}{w0t}> Net;\n\n",
           f"/// CRC-32 over the stored model (see hpddo::model_checksum).\nstatic const uint32_t kChecksum = 0x{crc:08x}u;\n\n",
           f"static const uint16_t kEffects = {f}::kEffects;\n\n",
           "/// Input exponents: xq_j = round(x_j 2^e_j).\n",
           quant.c_int_array("kInExp", "int8_t", q.in_exp)]
    names = [("kW0", "kB0")] + ([("kW1", "kB1")] if h2 else []) + [("kWOut", "kBOut")]
    for (wn, bn), w, b, t in zip(names, q.weights, q.biases, q.types):
        out.append(quant.c_int_array(wn, quant.C_TYPES[t], [v for row in w for v in row]))
        out.append(quant.c_int_array(bn, "int32_t", b, per_line=6))
    out.append("/// RPM per unit of the output accumulator.\n")
    out.append(c_array("kOutScale", [q.out_scale]))
    gq = q.gate
    out += ["/// Novelty gate in integers (gate_q.h), the float gate's prototypes and thresholds.\n",
            quant.c_int_array("kGateCentreQ", "int16_t", gq.centre), quant.c_int_array("kGateShiftQ", "int8_t", gq.shift),
            quant.c_int_array("kGateMultQ", "int16_t", gq.mult),
            quant.c_int_array("kGatePrototypesQ", "int16_t", [v for r in gq.prototypes for v in r], per_line=10)]
    g = model.gate
    lim = model.limits
    w1 = "kW1, kB1" if h2 else "nullptr, nullptr"
    out += ["\n", _c_layout_asserts(f"{name}_{suffix}"), "/// The deployed fixed-point model.\nstatic const hpddo::Model<Net> kModel = {\n",
            f"    {_c_physics(model.physics, 'kEffects')},\n",
            f"    {{{f}::kScalerMean, {f}::kScalerScale}},\n",
            f"    {{kInExp, kW0, kB0, {w1}, kWOut, kBOut, kOutScale}},\n",
            f"    {{{f}::kEnvLo, {f}::kEnvHi}},\n",
            f"    {{kInExp, kGateCentreQ, kGateShiftQ, kGateMultQ, kGatePrototypesQ, {gq.r_in_q}, {gq.r_out_q}, "
            f"{c_float(gq.fade)}, {gq.sort_dim}}},\n",
            f"    {c_float(model.clamp_rpm)},\n",
            f"    {{{c_float(lim.v_max_V)}, {c_float(lim.i_max_A)}, {c_float(lim.temp_min_C)}, {c_float(lim.temp_max_C)}}},\n",
            "};\n\n", _c_dynamics(model, f), f"}}  // namespace hpddo_model_{name}_{suffix}\n\n#endif  // {guard}\n"]
    return "".join(out)


def golden_rows_q(model: ModelData, q, samples):
    """The fixed-point observer over samples, from the references (observer_ref with
    quant.forward_int): (float rows in GOLDEN_INPUTS + GOLDEN_Q_STAGES, int rows in
    GOLDEN_Q_INTS). The network's columns hold its output on every row's features
    (a NaN feature counts as 0), evaluated or not by the observer."""
    from . import quant
    obs = quant.fixed_observer(model, q)
    rows, ints = [], []
    for v, i, t, dt, seq in samples:
        o = obs.step(v, i, t, dt, seq)
        xq, acc, y = quant.forward_int(q, o["x"])
        rows.append([v, i, np.nan if t is None else t, dt, 0 if seq is None else seq, 0 if seq is None else 1,
                     *o["x"], y, o["rpm_m2"], o["residual_rpm"], o["rpm"], o["temp_C"], o["confidence"], o["status"]])
        ints.append([*xq, acc])
    return np.asarray(rows, np.float32), ints


def golden_header_q(rows: np.ndarray, ints, name: str, provenance: dict, suffix: str = "q") -> str:
    """Text of `golden_<name>_<suffix>.h`: the float table kRows and the integer table kInts."""
    from . import quant
    guard = f"HPDDO_GOLDEN_{name.upper()}_{suffix.upper()}_H"
    cols = GOLDEN_INPUTS + GOLDEN_Q_STAGES
    prov = dict(provenance)
    prov.update(generator=GENERATOR, reference="hpddo.model.quant.forward_int (Python integers) in hpddo.model.observer_ref",
                rows=len(rows), columns=" ".join(cols), int_columns=" ".join(GOLDEN_Q_INTS))
    enums = ",\n".join(f"  kCol_{c} = {k}" for k, c in enumerate(cols))
    ienums = ",\n".join(f"  kInt_{c} = {k}" for k, c in enumerate(GOLDEN_Q_INTS))
    return "".join([
        _banner("fixed-point golden vectors", prov), f"#ifndef {guard}\n#define {guard}\n\n#include <stdint.h>\n\n",
        '#include "hpddo/observer.h"\n#include "hpddo/platform.h"\n\n', f"namespace hpddo_golden_{name}_{suffix} {{\n\n",
        f"enum Column : uint8_t {{\n{enums}\n}};\n\n", f"enum IntColumn : uint8_t {{\n{ienums}\n}};\n\n",
        f"static const uint16_t kCount = {len(rows)};\nstatic const uint8_t kWidth = {len(cols)};\n",
        f"static const uint8_t kIntWidth = {len(GOLDEN_Q_INTS)};\n\n",
        "/// Row r, column c is kRows[r * kWidth + c]; NaN marks an absent reading or an unreached stage.\n",
        c_array("kRows", rows, per_line=len(cols), allow_nonfinite=True),
        "/// Row r, integer column c is kInts[r * kIntWidth + c].\n",
        quant.c_int_array("kInts", "int32_t", [v for r in ints for v in r], per_line=len(GOLDEN_Q_INTS)),
        "\n/// Value of row r, column c.\n",
        "inline float at(uint16_t r, uint8_t c) { return hpddo::flash_float(kRows + static_cast<uint32_t>(r) * kWidth + c); }\n\n",
        "/// Integer of row r, integer column c.\n",
        "inline int32_t int_at(uint16_t r, uint8_t c) {\n"
        "  return hpddo::flash_int32(kInts + static_cast<uint32_t>(r) * kIntWidth + c);\n}\n\n",
        "/// The observer input of row r.\n",
        "inline hpddo::Sample sample(uint16_t r) {\n",
        "  hpddo::Sample s;\n  s.v_V = at(r, kCol_v_V);\n  s.i_A = at(r, kCol_i_A);\n  s.temp_C = at(r, kCol_temp_C);\n",
        "  s.dt_s = at(r, kCol_dt_s);\n  s.seq = static_cast<uint16_t>(at(r, kCol_seq));\n",
        "  s.has_seq = at(r, kCol_has_seq) != 0.0f;\n  return s;\n}\n",
        f"\n}}  // namespace hpddo_golden_{name}_{suffix}\n\n#endif  // {guard}\n"])


def golden_csv_q(rows: np.ndarray, ints) -> str:
    """The fixed-point golden rows as CSV: float columns, then the integer columns."""
    cols = GOLDEN_INPUTS + GOLDEN_Q_STAGES + GOLDEN_Q_INTS
    lines = [",".join(cols)] + [",".join(["%.9g" % float(v) for v in r] + [str(int(v)) for v in iv])
                                for r, iv in zip(rows, ints)]
    return "\n".join(lines) + "\n"


def write_fixed_point(folder: pathlib.Path, model: ModelData, name: str, prov: dict, samples, hidden_type=None):
    """Writes model_<name>_q.h, golden_<name>_q.h and golden_<name>_q.csv into folder;
    the QuantNet."""
    from . import quant
    q = quant.quantise(model, hidden_type or quant.DEFAULT_HIDDEN_TYPE)
    _write_q(folder, model, q, name, prov, samples, "q")
    return q


def quantise_int8(model: ModelData, calibration=None):
    """The int8 network of a model (quant.INT8_TYPES, the shifts from the envelope), its
    weights rounded for the calibration rows (the training features) where given."""
    from . import quant
    return quant.quantise(model, quant.INT8_TYPES[1], quant.INT8_TYPES[0], envelope_shifts=True,
                          calibration=calibration)


def write_int8(folder: pathlib.Path, model: ModelData, name: str, prov: dict, samples, calibration=None):
    """Writes model_<name>_q8.h, golden_<name>_q8.h and golden_<name>_q8.csv into folder (the
    int8 model, quantise_int8); the QuantNet."""
    q = quantise_int8(model, calibration)
    prov = dict(prov, rounding=("data-aware, for the training rows' features (quant.quantise calibration)"
                                if calibration is not None else "to nearest"))
    _write_q(folder, model, q, name, prov, samples, "q8")
    return q


def _write_q(folder, model, q, name, prov, samples, suffix):
    folder = pathlib.Path(folder)
    (folder / f"model_{name}_{suffix}.h").write_text(model_header_q(model, q, name, prov, suffix))
    rows, ints = golden_rows_q(model, q, samples)
    (folder / f"golden_{name}_{suffix}.h").write_text(golden_header_q(rows, ints, name, prov, suffix))
    (folder / f"golden_{name}_{suffix}.csv").write_text(golden_csv_q(rows, ints))


def read_model_header(text: str) -> ModelData:
    """The ModelData of a float model header written by model_header() (arrays, physics
    initialiser, gate thresholds, clamp, limits); raises ValueError unless the CRC-32 of
    what was read equals the header's kChecksum. For the benchmarks and the accuracy
    check of the fixed-point network, which start from the committed model."""
    import re
    from . import gate as gate_mod
    arrays = {m.group(1): np.array([float(v.rstrip("f")) for v in m.group(2).replace("\n", " ").split(",") if v.strip()],
                                   np.float32)
              for m in re.finditer(r"static const float (k\w+)\[\d+\] = \{([^}]*)\}", text)}
    model_block = text[text.index("static const hpddo::Model<Net> kModel"):]
    phys = {lab: float(v.rstrip(",").rstrip("f").replace("kEffects", "nan"))
            for v, lab in re.findall(r"^\s+(\S+),?\s+// (\w+)", model_block.split("};")[0], re.M)}
    bits = int(re.search(r"kEffects = 0x([0-9a-f]+)u", text).group(1), 16)
    kwargs = {f: phys[f] for f in schema.FLOAT_FIELDS}
    p = ph.PhysicsParams(**kwargs, effects=bits)
    gm = re.search(r"\{kGateCentre, kGateScale, kGatePrototypes, (\S+)f, (\S+)f\},\n\s+(\S+)f,\n\s+\{([^}]*)\}",
                   model_block)
    lim = [float(v.strip().rstrip("f")) for v in gm.group(4).split(",")]
    shape = re.search(r"typedef hpddo::Mlp<5, (\d+), (\d+)> Net;", text)
    h1, h2 = int(shape.group(1)), int(shape.group(2))
    layers = [(arrays["kW0"].reshape(h1, 5), arrays["kB0"])]
    if h2:
        layers += [(arrays["kW1"].reshape(h2, h1), arrays["kB1"]), (arrays["kW2"].reshape(1, h2), arrays["kB2"])]
    else:
        layers += [(arrays["kW1"].reshape(1, h1), arrays["kB1"])]
    protos = arrays["kGatePrototypes"]
    g = gate_mod.GateData(centre=arrays["kGateCentre"], scale=arrays["kGateScale"],
                          prototypes=protos.reshape(-1, len(arrays["kGateCentre"])),
                          r_in_sq=np.float32(gm.group(1)), r_out_sq=np.float32(gm.group(2)))
    from .observer_ref import Limits
    model = ModelData(physics=p, scaler_mean=arrays["kScalerMean"], scaler_scale=arrays["kScalerScale"],
                      layers=layers, env_lo=arrays["kEnvLo"], env_hi=arrays["kEnvHi"],
                      clamp_rpm=float(np.float32(gm.group(3))), gate=g, limits=Limits(*lim),
                      dynamics=_read_dynamics(text))
    want = int(re.search(r"kChecksum = 0x([0-9a-f]+)u", text).group(1), 16)
    if model_checksum(model) != want:
        raise ValueError("the model read back does not have the header's checksum")
    return model


# The reference page of the model header (docs/model-header.md, a block hpddo.regenerate writes):
# every symbol model_header() writes, with its meaning, declared here beside the writer. The page
# lists the symbols of a header written by model_header() itself (the tiny fixture with the dynamic
# family named), so a symbol added to the writer and not here fails the regeneration.
#: symbol (kW<k>/kB<k> for every layer) -> what it holds
HEADER_SYMBOLS = {
    "Net": "the network's type: hpddo::Mlp<5, h1, h2> (h2 0 for one hidden layer)",
    "kChecksum": "CRC-32 over the float32 little-endian bytes of everything stored, in the order of "
                 "hpddo::model_checksum (physics fields, scaler, network, envelope, gate, clamp, limits, "
                 "then kDynamics where named)",
    "kEffects": "the effect bits that are on (hpddo::Effect); the physics initialiser's last field",
    "kScalerMean": "the mean of each of the 5 network inputs (v_V, i_A, n_M2 and the previous sample's i_A and n_M2), subtracted before the network",
    "kScalerScale": "the scale of each of the 5 network inputs, divided by before the network",
    "kW<k>": "layer k's weights, row-major (outputs x inputs); a static_assert ties the size to Net",
    "kB<k>": "layer k's biases",
    "kEnvLo": "the training envelope's lower bound of each input (outside the box the observer gives M2 alone: fallback)",
    "kEnvHi": "the training envelope's upper bound of each input",
    "kGateCentre": "the novelty gate's centre of each input",
    "kGateScale": "the novelty gate's scale of each input",
    "kGatePrototypes": "the novelty gate's prototypes (hpddo::kGatePrototypes rows of 5 inputs)",
    "kModel": "the deployed model, hpddo::Model<Net>: the physics initialiser (below), the scaler, the "
              "network, the envelope, the gate with its squared radii r_in and r_out, the residual "
              "clamp in RPM and the readings' limits (v_max_V, i_max_A, temp_min_C, temp_max_C)",
    "kNameplate": "the nameplate model M1 (rated voltage over rated speed) as PhysicsParams, for comparison only",
    "kDynamics": "only where the model names the dynamic family: hpddo::DynamicsParams (J, B, Tc, the "
                 "observer's tau), covered by kChecksum last",
}
HEADER_DECLARATION = __import__("re").compile(
    r"^(?:HPDDO_FLASH )?(?:typedef (?P<tdef>[^;]+) (?P<tname>\w+);|static (?:constexpr|const) "
    r"(?P<type>[\w:<>, ]+?) (?P<name>k\w+)(?P<size>\[\d+\])? =)", __import__("re").M)


def header_symbols(text: str) -> list[tuple[str, str, str]]:
    """(symbol, its key in HEADER_SYMBOLS, its C++ type as written) of every declaration of a
    model header's text, in order."""
    import re
    out = []
    for m in HEADER_DECLARATION.finditer(text):
        name = m.group("tname") or m.group("name")
        ctype = m.group("tdef") if m.group("tname") else m.group("type") + (m.group("size") or "")
        out.append((name, re.sub(r"^k([WB])\d+$", r"k\1<k>", name), ctype))
    return out


def header_md() -> str:
    """The block of docs/model-header.md: the banner's lines, the symbols of a model header and the
    fields of its physics initialiser, from a header model_header() writes (the tiny fixture with
    the dynamic family named) and the schema."""
    from . import fixtures
    hidden, seed, gain = fixtures.FIXTURES["tiny"]
    model = fixtures.with_dynamics(fixtures.tiny_model(hidden, seed, gain))
    text = model_header(model, "tiny", {})
    banner = [ln[3:].split(": ", 1) for ln in text.splitlines()[1:] if ln.startswith("// ")]
    rows = ["The lines the export adds to the banner (`// key: value`) after the writer's provenance, "
            "for the tiny fixture (`test/fixtures`) with the dynamic family named:", "",
            "| key | value for the tiny fixture |", "|---|---|"]
    rows += [f"| `{k}` | {schema.md_cell(v)} |" for k, v in banner]
    rows += ["", "The symbols, in the order the header declares them (namespace `hpddo_model_<name>`):", "",
             "| symbol | C++ type in model_tiny.h (5-4-3-1) | holds |", "|---|---|---|"]
    symbols = header_symbols(text)
    missing = sorted({key for _, key, _ in symbols} - set(HEADER_SYMBOLS))
    if missing:
        raise ValueError(f"tools/hpddo/model/export.py: HEADER_SYMBOLS has no meaning for {', '.join(missing)}")
    unwritten = sorted(set(HEADER_SYMBOLS) - {key for _, key, _ in symbols})
    if unwritten:
        raise ValueError(f"tools/hpddo/model/export.py: HEADER_SYMBOLS names {', '.join(unwritten)}, "
                         "which model_header() does not write")
    rows += [f"| `{name}` | `{ctype}` | {schema.md_cell(HEADER_SYMBOLS[key].replace('layer k', 'layer ' + name[2:]))} |"
             for name, key, ctype in symbols]
    rows += ["", "The physics initialiser of `kModel` and `kNameplate` (hpddo::PhysicsParams, positional: "
                 "one value per line, labelled with its field and SI unit, in the schema's order):", "",
             "| # | field | SI unit | meaning |", "|---|---|---|---|"]
    rows += [f"| {k} | `{p.field}` | {p.unit} | {schema.md_cell(p.meaning)} |" for k, p in enumerate(schema.PARAMS)]
    rows.append(f"| {len(schema.PARAMS)} | `{schema.BITS_FIELD}` | bits | {schema.md_cell(schema.BITS_MEANING)} "
                "(`kEffects`) |")
    return "\n".join(rows) + "\n"
