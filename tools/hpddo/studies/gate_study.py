"""The measurement behind the novelty gate (docs/gate.md): three bench twins, M2 with and
without the named effects, M3, and ten gate variants scored on the chronological split,
never-seen (duty, load) pairs and a hot motor; the gate's cost on the boards.

    python -m hpddo.studies.gate_study --measure OUT   # the twins' recordings, training, the tables
    python -m hpddo.studies.gate_study --table JSON    # the tables of a gate_measure.json
    python -m hpddo.studies.gate_study --cost OUT      # after --measure OUT: bytes and AVR cycles

The gate itself is hpddo.model.gate; the lookup column is hpddo.evaluation.baseline.Lookup, the RMSE
hpddo.evaluation.metrics.rmse and the residual train.correction, as everywhere else in the project.
"""
from __future__ import annotations

import dataclasses
import functools

import numpy as np

from ..model.gate import F32, GateData, _floats, cpp_data, fit, open_gate, weight

# --------------------------------------------------------------------------------------
# Measurement (docs/gate.md): python -m hpddo.studies.gate_study --measure OUT
# --------------------------------------------------------------------------------------

RATE_HZ = 2.0
UNSEEN_DUTIES = (0.1, 0.3, 0.5, 0.7, 0.9)
UNSEEN_LOADS = (0, 1, 2)
UNSEEN_DWELL_S = 20.0
HOT_AMBIENT_C = 55.0
HOT_PREHEAT_S = 900.0        # 80 % duty on the 0.01 ohm load: the case climbs to about 80 C
HOT_PAIRS = ((0.2, 0), (0.4, 0), (0.6, 0), (0.8, 0), (1.0, 0), (0.8, 1), (0.8, 2))  # training pairs
NAMED_EFFECTS = ("thermal_ra", "magnet_thermal", "current_offset")  # as tools/hpddo/pipeline.py's users
# Three twins: every effect (the bundled data's preset), the thermal and offset effects
# the named identification models, and effects it does not model (left to the residual).
TWINS = {
    "default": ("default", {}),
    "thermal": ("ideal", {"thermal_ra": 0.393, "magnet_thermal": -0.2, "current_offset": 8.0}),
    "hidden": ("ideal", {"brush_drop": 0.5, "saturation": 4.0, "v_gain": 0.8}),
}
VARIANTS = [  # (name, dims with temperature?, prototypes, placement, in-quantile[, core quantile, default the in-quantile])
    ("x/fps16/q99", False, 16, "fps", 0.99),
    ("x/fps32/q99", False, 32, "fps", 0.99),
    ("x/fps64/q99", False, 64, "fps", 0.99),
    ("xT/fps16/q99", True, 16, "fps", 0.99),
    ("xT/fps32/q99", True, 32, "fps", 0.99),
    ("xT/fps64/q99", True, 64, "fps", 0.99),
    ("xT/fps32/q90", True, 32, "fps", 0.90),
    ("xT/fps32/max", True, 32, "fps", 1.0),
    ("xT/km32/q99", True, 32, "kmeans", 0.99),
    ("x/km32/q99", False, 32, "kmeans", 0.99),
    ("x/fps32/q99/all", False, 32, "fps", 0.99, 1.0),  # prototypes on every row: the gate before the core
]


def _write_custom(bench, segments, seed: int, out_dir, condition: str):
    """A recording of a custom schedule [(duration_s, duty, load)], as twin.generate does."""
    import pathlib

    import pandas as pd

    from ..logs import benchlog
    from ..twin import plant, protocols, sensors

    duty, load = protocols.per_sample(segments, RATE_HZ)
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 7]))
    res = plant.simulate(bench, duty, load, RATE_HZ)
    cols, _ = sensors.measure(bench, res, duty, load, rng)
    meta = {"condition": condition, "sample_rate_hz": f"{RATE_HZ:g}", "motor": "25GA371 1:4.4 (bench twin)",
            "ra_ohm": f"{bench.ra_ohm:.2f}", "note": f"hpddo.studies.gate_study measurement, seed={seed}"}
    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = benchlog.write_log(out / f"{condition}.csv", pd.DataFrame(cols), meta)
    pd.DataFrame({"case_C": res.tc, "winding_C": res.tw}).to_csv(out / f"{condition}.truth.csv", index=False)
    return path


def make_twin_data(name: str, out, seed: int = 1) -> dict:
    """Training (sweep, load, long), never-seen pairs and the hot motor of one twin."""
    import dataclasses as dc
    import pathlib

    from ..twin import generate
    from ..twin.params import preset, with_effects

    pre, eff = TWINS[name]
    bench = with_effects(preset(pre), **eff)
    base = pathlib.Path(out) / name
    paths = {"train": [], "unseen": [], "hot": []}
    for prot in ("sweep", "load", "long"):
        p = base / "train" / f"{prot}.csv"
        if not p.exists():
            generate.generate(bench, prot, RATE_HZ, seed, out_dir=base / "train", preset_name=pre)
        paths["train"].append(p)
    segs = [(UNSEEN_DWELL_S, d, ld) for ld in UNSEEN_LOADS for d in UNSEEN_DUTIES]
    p = base / "unseen" / "unseen.csv"
    paths["unseen"].append(p if p.exists() else _write_custom(bench, segs, seed + 10, base / "unseen", "unseen"))
    hot = dc.replace(bench, ambient_C=HOT_AMBIENT_C)
    segs = [(HOT_PREHEAT_S, 0.8, 2)] + [(UNSEEN_DWELL_S, d, ld) for d, ld in HOT_PAIRS]
    p = base / "hot" / "hot.csv"
    paths["hot"].append(p if p.exists() else _write_custom(hot, segs, seed + 20, base / "hot", "hot"))
    return paths


def gate_inputs(rec, p) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Features x (N, 5), the temperature the observer uses (N,) and n_M2 of a recording."""
    from ..model import train

    x, n2 = train.features(rec, p)
    temp = np.asarray(train.temperature_used(rec, p).winding_C, float)
    return x, temp, n2


def training_inputs(recs, p, with_temp: bool) -> np.ndarray:
    """The gate's training rows: the rows the network was trained on (train.train_residual:
    the training part, labelled, finite features), with the temperature as a last column."""
    out = []
    for r in recs:
        x, temp, _ = gate_inputs(r, p)
        ref = r.df["rpm_ref"].to_numpy(float)
        keep = np.isfinite(ref) & np.isfinite(x).all(axis=1)
        keep[r.n_train:] = False
        out.append(np.column_stack([x, temp])[keep] if with_temp else x[keep])
    return np.concatenate(out)


def m3_residual(res, x: np.ndarray) -> np.ndarray:
    """The clamped residual the observer adds (0 outside the envelope), vectorised, as if
    there were no gate (the gate's weight is applied by the caller, per variant)."""
    from ..model import train
    return train.correction(dataclasses.replace(res, gate=open_gate(x.shape[1])), x)[0]


def measure(out, progress: bool = True, max_iter: int | None = None) -> dict:
    """Every twin, with and without the named effects, every variant: RMSE per split."""
    import json
    import pathlib
    import pickle

    from ..logs import dataset
    from ..model import effects, identify, train
    from ..evaluation.baseline import Lookup
    from ..evaluation.metrics import rmse

    out = pathlib.Path(out)
    results = {}
    for twin in TWINS:
        paths = make_twin_data(twin, out / "data")
        recs = dataset.load_recordings(paths["train"])
        evals = {"unseen": dataset.load_recordings(paths["unseen"]), "hot": dataset.load_recordings(paths["hot"])}
        lookup = Lookup.fit(recs)  # the training rows of the training recordings
        ra, _ = identify.ra_from_logs(recs, None)
        m2_plain = identify.m2_params(recs, ra, "eq20")
        for eff_name, names in (("none", ()), ("named", NAMED_EFFECTS)):
            key = f"{twin}/{eff_name}"
            cache = out / "cache" / f"{twin}_{eff_name}.pkl"
            if cache.exists():
                m2, res = pickle.loads(cache.read_bytes())
            else:
                m2 = effects.identify(recs, m2_plain, names) if names else m2_plain
                cfg = train.TrainConfig(progress=progress)
                if max_iter:
                    cfg.max_iter = max_iter
                res = train.train_residual(recs, m2, cfg)
                cache.parent.mkdir(parents=True, exist_ok=True)
                cache.write_bytes(pickle.dumps((m2, res)))
            g_train = {False: training_inputs(recs, m2, False), True: training_inputs(recs, m2, True)}
            splits = {"chrono": [(r, slice(r.n_train, r.n)) for r in recs],
                      "unseen": [(r, slice(0, r.n)) for r in evals["unseen"]],
                      "hot": [(r, slice(int(HOT_PREHEAT_S * RATE_HZ), r.n)) for r in evals["hot"]]}
            gates = {v[0]: fit(g_train[v[1]], k=v[2], method=v[3], in_quantile=v[4], core_quantile=(v[5:] or (None,))[0])
                     for v in VARIANTS}
            row = {}
            for split, parts in splits.items():
                ref, est = [], {"lookup": [], "M2": [], "M3": []}
                west = {v[0]: [] for v in VARIANTS}
                wmean = {v[0]: [] for v in VARIANTS}
                for r, sl in parts:
                    x, temp, n2 = gate_inputs(r, m2)
                    resid = m3_residual(res, x)
                    df = r.df.iloc[sl]
                    ref.append(df["rpm_ref"].to_numpy(float))
                    est["lookup"].append(lookup.predict_rows(r)[sl])
                    est["M2"].append(n2[sl])
                    est["M3"].append((n2 + resid)[sl])
                    for v in VARIANTS:
                        g = np.column_stack([x, temp]) if v[1] else x
                        w = weight(gates[v[0]], g[sl]).astype(float)
                        west[v[0]].append(n2[sl] + w * resid[sl])
                        wmean[v[0]].append(w)
                ref = np.concatenate(ref)
                cell = {m: rmse(np.concatenate(e) - ref) for m, e in est.items()}
                for v in VARIANTS:
                    cell[v[0]] = rmse(np.concatenate(west[v[0]]) - ref)
                    cell[v[0] + ":w"] = float(np.mean(np.concatenate(wmean[v[0]])))
                cell["rows"] = int(len(ref))
                if split == "hot":
                    tr = pd_read_truth(parts[0][0])
                    cell["case_C"] = [float(tr[int(HOT_PREHEAT_S * RATE_HZ):].min()), float(tr.max())]
                row[split] = cell
            row["gates"] = {v[0]: {"r_in": float(np.sqrt(gates[v[0]].r_in_sq)), "flash_bytes": gates[v[0]].flash_bytes()}
                            for v in VARIANTS}
            results[key] = row
            if progress:
                print(key, json.dumps({s: {m: round(c[m], 2) for m in ("lookup", "M2", "M3", "xT/fps32/q99")}
                                       for s, c in row.items() if s != "gates"}))
    (out / "gate_measure.json").write_text(json.dumps(results, indent=1) + "\n")
    return results


def pd_read_truth(rec) -> np.ndarray:
    import pandas as pd

    return pd.read_csv(rec.source.with_suffix(".truth.csv"))["case_C"].to_numpy(float)


def table(results: dict) -> str:
    """Markdown: per twin and effects, per split, lookup / M2 / M3 / every gated variant."""
    names = [v[0] for v in VARIANTS]
    lines = ["| twin / M2 effects | split | rows | lookup | M2 | M3 | " + " | ".join(names) + " |",
             "|---|---|---|---|---|---|" + "---|" * len(names)]
    for key, row in results.items():
        for split in ("chrono", "unseen", "hot"):
            c = row[split]
            cells = [f"{c[n]:.2f} ({c[n + ':w']:.2f})" for n in names]
            lines.append(f"| {key} | {split} | {c['rows']} | {c['lookup']:.2f} | {c['M2']:.2f} | {c['M3']:.2f} | "
                         + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def verdict(results: dict) -> str:
    """Per variant: the goals (never-seen gated RMSE <= 1.05 M2's or better than M3 where M3
    already beats M2; chronological gain kept within 10 %), counted over the settings."""
    lines = ["| variant | never-seen splits with gated RMSE <= 1.05 M2 | chronological gain kept >= 90 % | "
             "mean chrono gain kept |", "|---|---|---|---|"]
    for name, *_ in VARIANTS:
        ok_unseen = ok_chrono = n_unseen = n_chrono = 0
        kept = []
        for row in results.values():
            for split in ("unseen", "hot"):
                c = row[split]
                n_unseen += 1
                ok_unseen += c[name] <= 1.05 * c["M2"]
            c = row["chrono"]
            gain = c["M2"] - c["M3"]
            n_chrono += 1
            k = (c["M2"] - c[name]) / gain if gain > 0 else 1.0
            kept.append(k)
            ok_chrono += k >= 0.9
        lines.append(f"| {name} | {ok_unseen}/{n_unseen} | {ok_chrono}/{n_chrono} | {100 * np.mean(kept):.0f} % |")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------
# Cost on the boards (docs/gate.md): python -m hpddo.studies.gate_study --cost OUT
# --------------------------------------------------------------------------------------

_AVR_PROGRAM = r"""
#include <avr/io.h>
#include "hpddo/gate.h"
#include "gate_data.h"
volatile float g_sink;
__attribute__((noinline)) float gate_call(const float (&g)[kGateDims]) { return kGate.weight(g); }
int main() {
  for (uint8_t n = 0; n < kVectorCount; ++n) {
    float g[kGateDims];
    for (uint8_t j = 0; j < kGateDims; ++j) g[j] = kVectors[n][j];
    GPIOR0 = 1;
    g_sink = gate_call(g);
    GPIOR0 = 2;
  }
  GPIOR0 = 3;
  for (;;) {}
}
"""

_SIM_HARNESS = r"""
#include <stdio.h>
#include <stdlib.h>
#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_io.h"
static avr_cycle_count_t start;
static int done;
static void on_marker(struct avr_t* avr, avr_io_addr_t addr, uint8_t v, void* param) {
  (void)addr; (void)param;
  if (v == 1) start = avr->cycle;
  else if (v == 2) printf("cycles %llu\n", (unsigned long long)(avr->cycle - start));
  else if (v == 3) done = 1;
}
int main(int argc, char** argv) {
  elf_firmware_t f = {{0}};
  if (argc < 2 || elf_read_firmware(argv[1], &f)) return 2;
  avr_t* avr = avr_make_mcu_by_name("atmega328p");
  avr_init(avr);
  avr_load_firmware(avr, &f);
  avr->frequency = 16000000;
  avr_register_io_write(avr, 0x3E, on_marker, NULL);
  for (long k = 0; !done && k < 200000000L; ++k) {
    int st = avr_run(avr);
    if (st == cpu_Done || st == cpu_Crashed) break;
  }
  return done ? 0 : 1;
}
"""


def cost(gd: GateData, vectors: np.ndarray, out) -> dict:
    """Flash/RAM bytes of the gate's data, code bytes of one weight() call on the ATmega328P
    (avr-g++ -Os) and the ESP8266 (xtensa-lx106-elf-g++ -O2), and AVR cycles per call in
    simavr for each of `vectors` (cycle-exact; the call is bracketed by GPIOR0 writes)."""
    import pathlib
    import subprocess

    root = pathlib.Path(__file__).resolve().parents[3]
    src = root / "lib" / "hpddo_core" / "src"
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    vec = np.asarray(vectors, F32)
    rows = ",\n".join("{" + _floats(v) + "}" for v in vec)
    (out / "gate_data.h").write_text(
        "#include \"hpddo/platform.h\"\n#include \"hpddo/gate.h\"\n"
        f"static const uint8_t kGateDims = {gd.dims};\nstatic const uint8_t kVectorCount = {len(vec)};\n"
        + cpp_data(gd) + f"static const float kVectors[{len(vec)}][{gd.dims}] = {{\n{rows}}};\n")
    (out / "gate_avr.cpp").write_text(_AVR_PROGRAM)
    (out / "sim.c").write_text(_SIM_HARNESS)
    inc = [f"-I{src}", f"-I{out}"]
    run = functools.partial(subprocess.run, check=True, capture_output=True, text=True)
    run(["avr-g++", "-std=gnu++11", "-mmcu=atmega328p", "-Os", "-DF_CPU=16000000L", *inc,
         str(out / "gate_avr.cpp"), "-o", str(out / "gate_avr.elf")])
    esp_src = out / "gate_esp.cpp"
    esp_src.write_text(_AVR_PROGRAM.replace("#include <avr/io.h>\n", "").replace("GPIOR0 = ", "g_marker = ")
                       .replace("volatile float g_sink;", "volatile float g_sink;\nvolatile unsigned char g_marker;"))
    run(["xtensa-lx106-elf-g++", "-std=c++11", "-specs=/usr/lib/xtensa-lx106-elf/picolibc.specs", "-mlongcalls",
         "-O2", "-DESP8266", *inc, "-c", str(esp_src), "-o", str(out / "gate_esp.o")])
    run(["gcc", "-O2", "-I/usr/include/simavr", "-I/usr/include/simavr/avr", str(out / "sim.c"), "-lsimavr",
         "-o", str(out / "sim")])
    sim = run([str(out / "sim"), str(out / "gate_avr.elf")]).stdout.splitlines()
    cycles = [int(line.split()[1]) for line in sim if line.startswith("cycles ")]

    def code_bytes(nm, obj):
        """Text bytes of the call and of Gate::weight where it is not inlined."""
        total = 0
        for line in run([nm, "-S", "-C", str(obj)]).stdout.splitlines():
            f = line.split()
            if len(f) >= 4 and f[2] in "TtWw" and ("gate_call" in line or "::weight(" in line):
                total += int(f[1], 16)
        return total

    return {"flash_data_bytes": gd.flash_bytes(), "struct_bytes_avr": 3 * 2 + 2 * 4, "struct_bytes_esp": 3 * 4 + 2 * 4,
            "code_bytes_avr": code_bytes("avr-nm", out / "gate_avr.elf"),
            "code_bytes_esp": code_bytes("xtensa-lx106-elf-nm", out / "gate_esp.o"),
            "avr_cycles": cycles}


def measure_cost(out) -> dict:
    """cost() of the chosen gate (x, fps, q99) at 16, 32 and 64 prototypes and of its xT
    form at 32, fitted on the default twin with the named effects (the model cached by
    --measure OUT); vectors: 8 training rows, 8 never-seen rows and a NaN row."""
    import pathlib
    import pickle

    from ..logs import dataset

    out = pathlib.Path(out)
    m2, _ = pickle.loads((out / "cache" / "default_named.pkl").read_bytes())
    paths = make_twin_data("default", out / "data")
    recs = dataset.load_recordings(paths["train"])
    unseen = dataset.load_recordings(paths["unseen"])
    result = {}
    for dims, k in (("x", 16), ("x", 32), ("x", 64), ("xT", 32)):
        with_temp = dims == "xT"
        g = training_inputs(recs, m2, with_temp)
        x, temp, _ = gate_inputs(unseen[0], m2)
        g_unseen = np.column_stack([x, temp]) if with_temp else x
        rows = np.concatenate([g[:: len(g) // 8][:8], g_unseen[:: len(g_unseen) // 8][:8],
                               np.full((1, g.shape[1]), np.nan)])
        gd = fit(g, k=k)
        c = cost(gd, rows, out / f"cost_{dims}{k}")
        c["weights"] = [round(float(w), 4) for w in weight(gd, rows)]
        result[f"{dims}/fps{k}/q99"] = c
    return result


def main(argv=None) -> int:
    import argparse
    import json
    import pathlib

    ap = argparse.ArgumentParser(prog="python -m hpddo.studies.gate_study", description=__doc__.split("\n\n")[0])
    ap.add_argument("--measure", metavar="OUT", help="make the twins' data under OUT/data, train, measure, "
                    "write OUT/gate_measure.json and print the tables of docs/gate.md")
    ap.add_argument("--table", metavar="JSON", help="print the tables of a gate_measure.json")
    ap.add_argument("--cost", metavar="OUT", help="after --measure OUT: the chosen gate (x, fps, q99; 16, 32, 64 "
                    "prototypes; and xT at 32) of the default twin with the named effects on the AVR (simavr "
                    "cycles, bytes) and the ESP8266 (bytes)")
    ap.add_argument("--epochs", type=int, default=None, help="epochs of M3 (default: TrainConfig's)")
    ap.add_argument("--quiet", action="store_true")
    a = ap.parse_args(argv)
    if a.measure:
        res = measure(a.measure, progress=not a.quiet, max_iter=a.epochs)
    elif a.table:
        res = json.loads(pathlib.Path(a.table).read_text())
    elif a.cost:
        print(json.dumps(measure_cost(a.cost), indent=1))
        return 0
    else:
        ap.error("give --measure OUT, --table JSON or --cost OUT")
    print(table(res))
    print(verdict(res))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
