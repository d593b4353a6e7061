"""Cost of the observer on the boards and the host, float against fixed point (issue 14).

    hpddo bench --observer [--write-docs]

1. AVR, cycle-exact (simavr, ATmega328P at 16 MHz; test/bench/avr_step.cpp run by
   test/bench/cycles_sim.c): one full Observer::step per golden row of models/default,
   float and fixed point (16, 8), median and maximum over the rows, and each stage alone
   (prepare, residual, finish; physics, envelope, gate, scaler, thermal node). The peer:
   emlearn's predict on the same network in the same run (emlearn 0.23.2, method
   'loadable', from a Python that has it: --peer-python, default .venv-bench/bin/python;
   without it the row says so). Flash and RAM of a program that runs one step and
   nothing else (avr-size), and of emlearn's predict alone.
2. Host, one thread (test/bench/host_step.cpp, g++ -O2): Observer::step samples per
   second over every row of the bundled recordings, float and fixed, (16, 8) and a
   (128, 64) timing model (the default model's physics, scaler, envelope and gate with
   random weights: speed does not depend on their values); scikit-learn's predict
   (scaler + network, features precomputed, one BLAS thread) on the same rows.
3. ESP8266 (Xtensa lx106) in QEMU, exact instruction counts (installed on demand): the full
   step (test/bench/lx106_step.cpp), and the ESP8266's JSON with ArduinoJson 7.2.0 from
   ../shared/vendor (test/bench/lx106_line.cpp): one telemetry line, and an uploaded
   model's parse and checks.
4. The UNO's 100 Hz main loop in simavr (uno_acq as built for the board, test/firmware/
   check_uno_sim.py), and the same with the ripple counter (the counting build,
   check_uno_ripple.py --count on a 100 Hz twin): the work per window against the window and
   the ADC interrupt's share of the CPU, from the same runs as the ctests
   firmware.uno.sim_100hz and firmware.uno.sim_ripple_count_100hz.
5. `hpddo upload` of the default model to the board's logic built for the host
   (host/esp_host.cpp) over a pseudo-terminal at an emulated 460800 baud, seconds.

Prints the table; with --write-docs writes it into docs/performance.md (between the
bench markers), with the command, and the figures into docs/figures/bench_observer.json.
"""
from __future__ import annotations

import glob
import json
import os
import pathlib
import shutil
import statistics
import subprocess
import sys
import time

import numpy as np

from .. import resource_root

ROOT = resource_root()
STAGES = {1: "step", 2: "prepare", 3: "residual", 4: "finish", 5: "physics", 6: "envelope", 7: "gate",
          8: "thermal_off", 9: "scaler", 10: "peer_predict", 11: "physics_all_effects", 12: "thermal_on",
          13: "gate_hinted"}
AVR_FLAGS = ["-std=gnu++11", "-mmcu=atmega328p", "-DF_CPU=16000000L", "-Os", "-ffunction-sections",
             "-fdata-sections", "-fno-exceptions", "-fno-threadsafe-statics", "-Wall", "-Wextra"]
GOAL_AVR_STEP = 8000          # cycles, the int8 (16, 8) full step (issue 24)
GOAL_AVR_STEP_STRETCH = 6000  # cycles, the same, stretch
GOAL_UNO_LOOP = 0.5           # the UNO's 100 Hz main loop: its work per window within half the window (issue 24)
GOAL_HOST_PER_S = 5e6         # samples/s per core, (16, 8)
CPU_HZ = 16e6
DOC = ROOT / "docs" / "performance.md"
FIGURES = ROOT / "docs" / "figures" / "bench_observer.json"
BEGIN, END = "<!-- bench_observer:begin (generated) -->", "<!-- bench_observer:end -->"
COMMAND = "hpddo bench --observer --write-docs"

PEER_SCRIPT = r"""
import sys, numpy as np
from sklearn.neural_network import MLPRegressor
import emlearn
d = np.load(sys.argv[1])
n = int(d["n"])
est = MLPRegressor(hidden_layer_sizes=tuple(d[f"w{k}"].shape[0] for k in range(n - 1)), max_iter=1)
est.partial_fit(np.zeros((2, d["w0"].shape[1])), np.zeros(2))
est.coefs_ = [d[f"w{k}"].T.astype(np.float64) for k in range(n)]
est.intercepts_ = [d[f"b{k}"].astype(np.float64) for k in range(n)]
emlearn.convert(est, method="loadable").save(file=sys.argv[2], name="hpddo_peer")
print(emlearn.__version__, emlearn.includedir)
"""


def _run(cmd, **kw) -> str:
    res = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kw)
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))} failed ({res.returncode}):\n{res.stdout[-2000:]}{res.stderr[-2000:]}")
    return res.stdout


def _avr_includes():
    return [f"-I{ROOT / 'lib' / 'hpddo_core' / 'src'}", f"-I{ROOT / 'models' / 'default'}",
            f"-I{ROOT / 'test' / 'fixtures'}"]


def avr_size(elf: pathlib.Path) -> dict:
    """Flash (.text + .data) and static RAM (.data + .bss + .noinit) of an ELF, bytes."""
    sec = {}
    for line in _run(["avr-size", "-A", elf]).splitlines():
        p = line.split()
        if len(p) >= 2 and p[0].startswith(".") and p[1].isdigit():
            sec[p[0]] = int(p[1])
    return {"flash_B": sec.get(".text", 0) + sec.get(".data", 0),
            "ram_B": sec.get(".data", 0) + sec.get(".bss", 0) + sec.get(".noinit", 0)}


def cycles(harness: pathlib.Path, elf: pathlib.Path) -> tuple[dict, int]:
    """{stage: [cycles per region]} and the program's result byte (golden misses)."""
    out = _run([harness, elf, "120"])
    regions, result = {}, None
    for line in out.splitlines():
        p = line.split()
        if len(p) == 2 and p[0] == "done":
            result = int(p[1])
        elif len(p) == 2 and p[0].isdigit():
            regions.setdefault(STAGES[int(p[0])], []).append(int(p[1]))
    if result is None:
        raise RuntimeError(f"{elf.name}: no end marker")
    return regions, result


def _stats(v) -> dict:
    return {"median": float(statistics.median(v)), "max": int(max(v)), "min": int(min(v)), "n": len(v)}


def _peer_python(arg) -> pathlib.Path | None:
    """The Python that runs emlearn's converter: the one given, else .venv-bench, else this
    one when it has emlearn (requirements-test.txt pins it into the project venv)."""
    import importlib.util
    if arg:
        cand = pathlib.Path(arg)
        return cand if cand.exists() else None
    cand = ROOT / ".venv-bench" / "bin" / "python"
    if cand.exists():
        return cand
    return pathlib.Path(sys.executable) if importlib.util.find_spec("emlearn") else None


def _network_npz(model, path: pathlib.Path) -> None:
    arrays = {"n": np.array(len(model.layers))}
    for k, (w, b) in enumerate(model.layers):
        arrays[f"w{k}"], arrays[f"b{k}"] = np.asarray(w, np.float32), np.asarray(b, np.float32)
    np.savez(path, **arrays)


def avr(build: pathlib.Path, model, peer_python) -> dict:
    """Builds and runs the AVR programs; the figures."""
    build.mkdir(parents=True, exist_ok=True)
    src = ROOT / "test" / "bench"
    harness = build / "cycles_sim"
    _run(["gcc", "-O2", "-I/usr/include/simavr", src / "cycles_sim.c", "-lsimavr", "-o", harness])
    fig = {"cpu_hz": CPU_HZ, "compiler": _run(["avr-g++", "--version"]).splitlines()[0], "flags": " ".join(AVR_FLAGS)}
    for kind, define in (("float", []), ("fixed", ["-DHPDDO_BENCH_FIXED"]), ("int8", ["-DHPDDO_BENCH_INT8"])):
        elf = build / f"step_{kind}.elf"
        _run(["avr-g++", *AVR_FLAGS, *define, *_avr_includes(), src / "avr_step.cpp", "-Wl,--gc-sections", "-o", elf])
        size_elf = build / f"size_{kind}.elf"
        _run(["avr-g++", *AVR_FLAGS, *define, "-DHPDDO_BENCH_SIZE", *_avr_includes(), src / "avr_step.cpp",
              "-Wl,--gc-sections", "-o", size_elf])
        regions, misses = cycles(harness, elf)
        fig[kind] = {"stages": {k: _stats(v) for k, v in regions.items()}, "golden_misses": misses,
                     "size": avr_size(size_elf)}
    py = _peer_python(peer_python)
    if py is None:
        fig["peer"] = {"status": "not run: no Python with emlearn (python3 -m venv .venv-bench && "
                                 ".venv-bench/bin/pip install emlearn==0.23.2 scikit-learn numpy)"}
        return fig
    peer_dir = build / "peer"
    peer_dir.mkdir(exist_ok=True)
    _network_npz(model, peer_dir / "net.npz")
    # emlearn's convert leaves scratch files in tmp/ of its working folder: the build folder.
    ver, inc = _run([py, "-c", PEER_SCRIPT, peer_dir / "net.npz", peer_dir / "peer_model.h"], cwd=peer_dir).split()
    (peer_dir / "hpddo_emlearn_model.h").write_text(
        '#include "peer_model.h"\nstatic inline float hpddo_emlearn_predict(const float* z) '
        "{ return hpddo_peer_regress1(z, 5); }\n")
    elf = build / "step_peer.elf"
    inc_flags = [f"-I{peer_dir}", f"-I{inc}"]
    _run(["avr-g++", *AVR_FLAGS, "-DHPDDO_BENCH_EMLEARN", *_avr_includes(), *inc_flags, src / "avr_step.cpp",
          "-Wl,--gc-sections", "-o", elf])
    size_elf = build / "size_peer.elf"
    _run(["avr-g++", *AVR_FLAGS, "-DHPDDO_BENCH_EMLEARN", "-DHPDDO_BENCH_SIZE", *_avr_includes(), *inc_flags,
          src / "avr_step.cpp", "-Wl,--gc-sections", "-o", size_elf])
    regions, misses = cycles(harness, elf)
    fig["peer"] = {"status": "run", "emlearn": ver, "stages": {k: _stats(v) for k, v in regions.items()},
                   "golden_misses": misses, "size": avr_size(size_elf)}
    return fig


# ESP8266 (Xtensa LX106) in QEMU's sim machine: instruction counts (docs/performance.md).
LX_CXX = "xtensa-lx106-elf-g++"
LX_CC = "xtensa-lx106-elf-gcc"
LX_SPECS = "-specs=/usr/lib/xtensa-lx106-elf/picolibc.specs"
LX_FLAGS = ["-std=c++11", LX_SPECS, "-O2", "-mlongcalls", "-mtext-section-literals", "-DESP8266", "-fno-exceptions",
            "-fno-rtti", "-ffunction-sections", "-ffp-contract=off"]
LX_QEMU = ["qemu-system-xtensa", "-M", "sim", "-cpu", "lx106", "-semihosting", "-display", "none", "-monitor", "none",
           "-serial", "none", "-icount", "shift=10"]
LX_CLOCK_HZ = 80e6             # the ESP8266's default CPU clock
PAPER_LX106_MS = 21.79         # the paper's (128, 64) float inference on the ESP8266
GOAL_LX106_WIDE_FIXED = 70000  # instructions, fixed-point (128, 64) full step
GOAL_LX106_LINE = 40000        # instructions, one telemetry line with ArduinoJson (issue 25)
# Third-party sources the benchmark builds against but the project does not copy (the
# ESP8266's ArduinoJson): ../shared/vendor beside the clone, or HPDDO_VENDOR_DIR.
VENDOR = pathlib.Path(os.environ.get("HPDDO_VENDOR_DIR", ROOT.parent / "shared" / "vendor"))
ARDUINOJSON = VENDOR / "ArduinoJson-7.2.0" / "src"
# The soft-float and division helpers that the ESP8266 has in ROM and Debian's lx106 libgcc
# lacks, assembled from GCC's own sources (Debian's gcc-12-source; libgcc/config/xtensa/t-xtensa).
LX_LIB1FUNCS = ("_mulsi3 _divsi3 _modsi3 _udivsi3 _umodsi3 _umulsidi3 _clz _clzsi2 _ctzsi2 _ffssi2 _ashldi3 _ashrdi3 "
                "_lshrdi3 _bswapsi2 _bswapdi2 _negsf2 _addsubsf3 _mulsf3 _divsf3 _cmpsf2 _fixsfsi _fixsfdi _fixunssfsi "
                "_fixunssfdi _floatsisf _floatunsisf _sqrtf _recipsf2 _rsqrtsf2 _floatdisf _floatundisf _negdf2 "
                "_addsubdf3 _muldf3 _divdf3 _cmpdf2 _fixdfsi _fixdfdi _fixunsdfsi _fixunsdfdi _floatsidf _floatunsidf "
                "_floatdidf _floatundidf _truncdfsf2 _extendsfdf2 _sqrt _recipdf2 _rsqrtdf2").split()
GCC_SOURCE_GLOB = "/usr/src/gcc-12/gcc-12*.tar.xz"
XTENSA_CONFIG_DIR = "/usr/lib/gcc/xtensa-lx106-elf/12.2.0/plugin/include"


def _debian_packages(probe, packages) -> str | None:
    """None when probe() holds, installing the Debian packages first when root (apt-get);
    otherwise what is missing and the command that installs it."""
    if probe():
        return None
    cmd = ["apt-get", "install", "-y", "-q", *packages]
    if os.geteuid() != 0:
        return f"not run: {' '.join(packages)} missing (as root: {' '.join(cmd)})"
    print(f"bench: installing {' '.join(packages)} (apt-get) for the lx106 figures", flush=True)
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    subprocess.run(cmd, check=False, env=env, stdout=subprocess.DEVNULL)
    return None if probe() else f"not run: apt-get install {' '.join(packages)} failed"


def _lx106_libgcc(build: pathlib.Path) -> pathlib.Path:
    """libgcc's xtensa soft-float and division helpers, assembled into build/libsoft.a."""
    import tarfile
    lib = build / "libsoft.a"
    if lib.exists():
        return lib
    src = build / "libgcc-xtensa"
    tar_path = sorted(glob.glob(GCC_SOURCE_GLOB))[0]
    with tarfile.open(tar_path) as tar:
        members = [m for m in tar.getmembers() if "/libgcc/config/xtensa/" in m.name and m.isfile()]
        for m in members:
            m.name = pathlib.Path(m.name).name
            tar.extract(m, src)
    objs = []
    for f in LX_LIB1FUNCS:
        o = build / f"lib1{f}.o"
        _run([LX_CC, "-c", "-mlongcalls", f"-DL{f}", "-xassembler-with-cpp", f"-I{XTENSA_CONFIG_DIR}", f"-I{src}",
              src / "lib1funcs.S", "-o", o])
        objs.append(o)
    _run(["xtensa-lx106-elf-ar", "rcs", lib, *objs])
    return lib


def bench_model_h(model: str, golden: str, check: bool = True) -> str:
    """bench_model.h of lx106_step.cpp: the model header and golden rows it includes (their
    file stems; the namespaces are hpddo_<stem>), and whether the estimates are checked."""
    return (("" if check else "#define BENCH_NO_CHECK\n") + f'#include "{model}.h"\n#include "{golden}.h"\n'
            f"namespace m = hpddo_{model};\nnamespace g = hpddo_{golden};\n")


def _lx106_build_run(d: pathlib.Path, source: str, inc_dirs, libsoft, extra=()) -> tuple[str, pathlib.Path]:
    """Builds test/bench/<source> (and the extra sources beside it) for the lx106, objects in
    d, runs it in QEMU; its output and the object file of source."""
    src = ROOT / "test" / "bench"
    objs = []
    for name in (source, *extra):
        objs.append(d / (pathlib.Path(name).stem + ".o"))
        _run([LX_CXX, *LX_FLAGS, f"-I{ROOT / 'lib' / 'hpddo_core' / 'src'}", f"-I{d}", f"-I{src}",
              *[f"-I{i}" for i in inc_dirs], "-c", src / name, "-o", objs[-1]])
    elf = d / (pathlib.Path(source).stem + ".elf")
    _run([LX_CC, LX_SPECS, "-nostartfiles", "-T", src / "lx106.ld", src / "lx106_start.S", *objs,
          "-Wl,--start-group", libsoft, "-lc", "-lm", "-Wl,--end-group", "-o", elf])
    out = subprocess.run([*LX_QEMU, "-kernel", str(elf)], check=True, capture_output=True, text=True,
                         timeout=600).stdout
    return out, objs[0]


def _lx106_counts(out: str, key: str) -> tuple[list, dict]:
    """The instruction counts of the lines "<key> N" of a benchmark's output (CCOUNT less
    the empty region, over the counts per instruction of the nop100 region), and the
    output's other "name N" values."""
    vals, raw = {}, []
    for line in out.splitlines():
        name, _, v = line.partition(" ")
        if name == key:
            raw.append(int(v))
        elif v.isdigit():
            vals.setdefault(name, []).append(int(v))
    empty, nop100 = vals.pop("empty")[0], vals.pop("nop100")[0]
    per_insn = (nop100 - empty) / 100.0
    vals["counts_per_instruction"] = per_insn
    return [round((c - empty) / per_insn) for c in raw], vals


def _lx106_run(build: pathlib.Path, name: str, includes: str, inc_dirs, libsoft) -> dict:
    """Builds lx106_step with bench_model.h = includes, runs it in QEMU; the counts."""
    d = build / name
    d.mkdir(parents=True, exist_ok=True)
    (d / "bench_model.h").write_text(includes)
    out, obj = _lx106_build_run(d, "lx106_step.cpp", inc_dirs, libsoft)
    insns, vals = _lx106_counts(out, "step")
    return {"step": _stats(insns), "counts_per_instruction": vals["counts_per_instruction"],
            "golden_misses": vals.get("bad", [None])[0],
            "code_B": int(_run(["xtensa-lx106-elf-size", "-A", obj]).split("Total")[1].split()[0])}


def lx106_line(build: pathlib.Path, libsoft) -> dict:
    """Instruction counts of one telemetry line (infer::LineWriter::write, ArduinoJson 7.2.0
    from VENDOR) on the lx106 in QEMU, over the golden rows of models/default, and the
    lines' lengths in bytes."""
    if not (ARDUINOJSON / "ArduinoJson.h").is_file():
        return {"status": f"not run: ArduinoJson 7.2.0 not found at {ARDUINOJSON} (set HPDDO_VENDOR_DIR)"}
    d = build / "telemetry_line"
    d.mkdir(parents=True, exist_ok=True)
    doc = (ROOT / "test" / "fixtures" / "upload_default.json").read_text()
    (d / "upload_doc.h").write_text(f"static const char kUploadDoc[] = {json.dumps(doc)};\n")
    out, _ = _lx106_build_run(d, "lx106_line.cpp", [ROOT / "esp_infer", ROOT / "models" / "default",
                                                    ARDUINOJSON], libsoft, extra=["lx106_di.cpp"])
    insns, vals = _lx106_counts(out, "line")
    parse, _ = _lx106_counts(out, "parse")
    return {"status": "run", "line": _stats(insns), "bytes": _stats(vals["len"]),
            "counts_per_instruction": vals["counts_per_instruction"], "arduinojson": "7.2.0",
            "upload_parse": {"instructions": parse[0], "accepted": vals["parse_ok"][0] == 1,
                             "arena_peak_B": vals["arena"][0], "arena_capacity_B": vals["arena_capacity"][0],
                             "document_B": len(doc)}}


def lx106(build: pathlib.Path, model) -> dict:
    """Instruction counts of one full observer step on the lx106 in QEMU: (16, 8) float and
    fixed point on models/default and its goldens, and the (128, 64) timing model on the same
    rows. QEMU and GCC's sources are installed on demand (apt-get, as root)."""
    from ..model import export, quant
    for probe, pkgs in ((lambda: shutil.which("qemu-system-xtensa"), ["qemu-system-misc"]),
                        (lambda: glob.glob(GCC_SOURCE_GLOB), ["gcc-12-source"]),
                        (lambda: shutil.which(LX_CXX), ["gcc-xtensa-lx106", "binutils-xtensa-lx106",
                                                     "picolibc-xtensa-lx106-elf"])):
        missing = _debian_packages(probe, pkgs)
        if missing:
            return {"status": missing}
    build.mkdir(parents=True, exist_ok=True)
    libsoft = _lx106_libgcc(build)
    wide = wide_model(model)
    prov = {"command": "tools/hpddo/studies/perf.py (timing model: random (128, 64) weights, seed 14)"}
    (build / "model_wide.h").write_text(export.model_header(wide, "wide", prov))
    (build / "model_wide_q.h").write_text(export.model_header_q(wide, quant.quantise(wide), "wide", prov))
    default = ROOT / "models" / "default"
    fig = {"status": "run", "qemu": _run(["qemu-system-xtensa", "--version"]).splitlines()[0],
           "compiler": _run([LX_CXX, "--version"]).splitlines()[0], "flags": " ".join(LX_FLAGS)}
    cases = {"float_16_8": bench_model_h("model_default", "golden_default"),
             "fixed_16_8": bench_model_h("model_default_q", "golden_default_q"),
             "int8_16_8": bench_model_h("model_default_q8", "golden_default_q8"),
             "float_128_64": bench_model_h("model_wide", "golden_default", check=False),
             "fixed_128_64": bench_model_h("model_wide_q", "golden_default", check=False)}
    for name, inc in cases.items():
        fig[name] = _lx106_run(build, name, inc, [default, build], libsoft)
    fig["telemetry_line"] = lx106_line(build, libsoft)
    return fig


UNO_RATE_HZ = 100  # the UNO's main loop measured at this sample rate (firmware.uno.sim_100hz's run)
UNO_RIPPLE_HZ = 10000  # the counting build's ripple sample rate (firmware.uno.sim_ripple_count_100hz)


def _figures_line(out: str) -> dict:
    """The "figures: key=value ..." line test/firmware/check_uno_sim.py and check_uno_ripple.py
    print: the main loop's work on the recorded windows (median, max), the ADC interrupt's CPU
    share, the window's cycles."""
    line = [ln for ln in out.splitlines() if ln.startswith("figures: ")][-1]
    return {k: (float(v) if "." in v else int(v)) for k, v in (kv.split("=") for kv in line[9:].split())}


def _loop_figures(f: dict, rows: int) -> dict:
    out = {"window_cycles": f["window_cycles"], "adc_share_pct": f["adc_share_pct"],
           "window": {"median": f["loop_median"], "max": f["loop_max"], "n": rows}}
    for key, name in (("obs", "observer"), ("rip", "ripple")):
        if f"{key}_median" in f:
            out[name] = {"median": f[f"{key}_median"], "max": f[f"{key}_max"], "n": rows}
    return out


def _uno_tools(build: pathlib.Path) -> str | None:
    """Builds the simavr harness and frame_dump in build; None, or why not."""
    if not shutil.which("avr-g++") or not pathlib.Path("/usr/include/simavr/sim_avr.h").exists():
        return "not run: avr-g++ or simavr's headers (libsimavr-dev) missing"
    build.mkdir(parents=True, exist_ok=True)
    fw = ROOT / "test" / "firmware"
    _run(["gcc", "-O2", "-I/usr/include/simavr", f"-I{ROOT / 'uno_acq'}", fw / "uno_sim.c", "-lsimavr",
          "-o", build / "uno_sim"])
    _run(["g++", "-std=c++17", "-O2", f"-I{ROOT / 'lib' / 'hpddo_core' / 'src'}", fw / "frame_dump.cpp",
          "-o", build / "frame_dump"])
    return None


def uno_loop(build: pathlib.Path) -> dict:
    """The UNO's main loop at 100 Hz in simavr: uno_acq built as for the board
    (test/firmware/build_uno.sh, the observer on), driven with the test rows of
    data/default/long.csv by test/firmware/check_uno_sim.py (every estimate checked against
    the reference observer), and over the recorded windows the cycles of the loop's work per
    window and of the observer step in it (GPIOR1 markers, busy.csv), median and maximum, and
    the ADC interrupt's share of the CPU (adc_isr.csv)."""
    missing = _uno_tools(build)
    if missing:
        return {"status": missing}
    fw = ROOT / "test" / "firmware"
    _run(["bash", fw / "build_uno.sh", ROOT, build / "uno_acq"])
    rows = 300
    out = _run([sys.executable, fw / "check_uno_sim.py", "--harness", build / "uno_sim", "--elf",
                build / "uno_acq" / "uno_acq.elf", "--frame-dump", build / "frame_dump", "--workdir", build / "sim",
                "--pwm", "1000", "--rate", str(UNO_RATE_HZ), "--rows", str(rows), "--drive", "recording"],
               env=dict(os.environ, PYTHONPATH=str(ROOT / "tools")))
    fig = {"status": "run", "rate_hz": UNO_RATE_HZ, **_loop_figures(_figures_line(out), rows)}
    size = (build / "uno_acq" / "uno_acq.size").read_text().split()
    fig["flash_B"], fig["flash_max_B"], fig["ram_B"], fig["ram_max_B"] = map(int, size)
    fig["checked"] = [ln for ln in out.splitlines() if ln.startswith("observer (")]
    return fig


def uno_ripple_loop(build: pathlib.Path) -> dict:
    """The same 100 Hz main loop with the ripple counter (issue 23 item 5): uno_acq built with
    -DACQ_RIPPLE_HZ=10000 -DACQ_RIPPLE_COUNT=1 (the 10 kHz bursts counted in the ADC interrupt,
    Ra and the winding temperature tracked in the main loop), run by
    test/firmware/check_uno_ripple.py --count as firmware.uno.sim_ripple_count_100hz does: 300
    windows of a 100 Hz twin's load steps, the board's counts and Ra checked against the host's
    reference, the link's frames decoded. --measure: the figures also when the build does not
    keep up, and whether it passed (no window lost, no framing error, every window's work within
    the window, the counts equal to the reference)."""
    missing = _uno_tools(build)
    if missing:
        return {"status": missing}
    fw = ROOT / "test" / "firmware"
    _run(["bash", fw / "build_uno.sh", ROOT, build / "uno_acq_count"],
         env=dict(os.environ, ACQ_DEFINES=f"-DACQ_RIPPLE_HZ={UNO_RIPPLE_HZ} -DACQ_RIPPLE_COUNT=1"))
    rows = 300
    res = subprocess.run([sys.executable, str(fw / "check_uno_ripple.py"), "--harness", str(build / "uno_sim"),
                          "--elf", str(build / "uno_acq_count" / "uno_acq.elf"), "--frame-dump",
                          str(build / "frame_dump"), "--workdir", str(build / "sim_count"), "--hz", str(UNO_RIPPLE_HZ),
                          "--count", "--rows", str(rows), "--twin-rate", str(UNO_RATE_HZ), "--twin-time-scale", "0.02",
                          "--measure"], capture_output=True, text=True, env=dict(os.environ, PYTHONPATH=str(ROOT / "tools")))
    if not any(ln.startswith("figures: ") for ln in res.stdout.splitlines()):
        return {"status": f"failed: {(res.stdout + res.stderr).strip().splitlines()[-1:]}"}
    fig = {"status": "run", "rate_hz": UNO_RATE_HZ, "ripple_hz": UNO_RIPPLE_HZ,
           **_loop_figures(_figures_line(res.stdout), rows)}
    fig["passed"] = res.returncode == 0 and res.stdout.strip().splitlines()[-1] == "PASS"
    fig["verdict"] = res.stdout.strip().splitlines()[-1]
    size = (build / "uno_acq_count" / "uno_acq.size").read_text().split()
    fig["flash_B"], fig["flash_max_B"], fig["ram_B"], fig["ram_max_B"] = map(int, size)
    fig["checked"] = [ln for ln in res.stdout.splitlines() if ln.startswith(("counter: ", "link: "))]
    return fig


GOAL_UPLOAD_S = 5.0  # seconds, the default model to the ESP8266 at 460800 baud (issue 25)


def esp_upload(build: pathlib.Path, repeat: int = 5) -> dict:
    """Seconds `hpddo upload` takes to put the default model in force on the board's logic
    built for the host (host/esp_host.cpp: infer::App, ArduinoJson from VENDOR) over a
    pseudo-terminal whose every byte takes its time at 460800 baud (esp_host --baud):
    the line and the stop-and-wait replies, not a USB bridge's latency. Median of repeat."""
    from ..model import upload
    if not (ARDUINOJSON / "ArduinoJson.h").is_file():
        return {"status": f"not run: ArduinoJson 7.2.0 not found at {ARDUINOJSON} (set HPDDO_VENDOR_DIR)"}
    try:
        import serial
    except ImportError:  # pragma: no cover
        return {"status": "not run: pyserial is not installed"}
    build.mkdir(parents=True, exist_ok=True)
    exe = build / "esp_host"
    _run(["g++", "-std=c++17", "-O2", "-ffp-contract=off", f"-I{ROOT / 'host'}", f"-I{ROOT / 'esp_infer'}",
          f"-I{ROOT / 'models' / 'default'}", f"-I{ROOT / 'lib' / 'hpddo_core' / 'src'}", "-isystem", ARDUINOJSON,
          ROOT / "host" / "esp_host.cpp", "-o", exe])
    doc = upload.document(upload.read_model(ROOT / "models" / "default"))
    times = []
    for k in range(repeat):
        store = build / f"store{k}"
        shutil.rmtree(store, ignore_errors=True)
        proc = subprocess.Popen([str(exe), "--store", str(store), "--pty", "--baud", str(upload.BAUD)],
                                stdout=subprocess.PIPE, text=True)
        try:
            port_name = proc.stdout.readline().split()[1]
            with serial.Serial(port_name, upload.BAUD, timeout=0.2, exclusive=True) as port:
                done = upload.send(port, doc, log=None)
            times.append(done["seconds"])
        finally:
            proc.terminate()
            proc.wait(timeout=10)
    return {"status": "run", "seconds": {"median": float(statistics.median(times)), "max": max(times), "n": len(times)},
            "document_B": len(doc), "chunks": done["chunks"], "baud": upload.BAUD}


def wide_model(model, seed: int = 14):
    """The default model with random (128, 64) layers: a timing model, not a trained one."""
    import copy
    rng = np.random.default_rng(seed)
    m = copy.deepcopy(model)
    sizes = (5, 128, 64, 1)
    m.layers = [(rng.normal(0, (2.0 / i) ** 0.5, (o, i)).astype(np.float32), rng.normal(0, 0.1, o).astype(np.float32))
                for i, o in zip(sizes[:-1], sizes[1:])]
    return m


def host(build: pathlib.Path, model, repeat: int) -> dict:
    """Builds and runs host_step; scikit-learn's predict on the same rows."""
    from ..logs import dataset
    from ..model import export, quant
    build.mkdir(parents=True, exist_ok=True)
    wide = wide_model(model)
    prov = {"command": "tools/hpddo/studies/perf.py (timing model: random (128, 64) weights, seed 14)"}
    (build / "model_wide.h").write_text(export.model_header(wide, "wide", prov))
    (build / "model_wide_q.h").write_text(export.model_header_q(wide, quant.quantise(wide), "wide", prov))
    exe = build / "host_step"
    _run(["g++", "-std=c++17", "-O2", "-ffp-contract=off", f"-I{ROOT / 'lib' / 'hpddo_core' / 'src'}",
          f"-I{ROOT / 'models' / 'default'}", f"-I{ROOT / 'host'}", f"-I{build}", ROOT / "test" / "bench" / "host_step.cpp",
          "-o", exe])
    logs = [ROOT / "data" / "default" / f"{n}.csv" for n in ("load", "long", "sweep")]
    fig = json.loads(_run([exe, repeat, *logs]).strip().splitlines()[-1])
    fig["compiler"] = _run(["g++", "--version"]).splitlines()[0]
    # scikit-learn on the same rows: features from the float reference's definition (train.features).
    from ..model import train
    recs = dataset.load_recordings(logs)
    x = np.concatenate([train.features(r, model.physics)[0] for r in recs]).astype(np.float64)
    fig["sklearn_rows"] = int(len(x))
    for key, m in (("16_8", model), ("128_64", wide)):
        fig[f"sklearn_{key}"] = len(x) / _sklearn_best(m, x, repeat)
    return fig


PEER_MIN_S = 1.0  # scikit-learn's predict timed over at least this long (a call lasts 1-10 ms)


def _sklearn_best(model, x, repeat: int) -> float:
    from sklearn.neural_network import MLPRegressor
    from sklearn.preprocessing import StandardScaler
    hidden = model.hidden
    peer = MLPRegressor(hidden_layer_sizes=hidden, max_iter=1)
    peer.partial_fit(np.zeros((2, 5)), np.zeros(2))
    peer.coefs_ = [np.asarray(w, np.float64).T for w, _ in model.layers]
    peer.intercepts_ = [np.asarray(b, np.float64) for _, b in model.layers]
    sc = StandardScaler()
    sc.mean_ = np.asarray(model.scaler_mean, np.float64)
    sc.scale_ = np.asarray(model.scaler_scale, np.float64)
    sc.var_ = sc.scale_ ** 2
    sc.n_features_in_ = 5
    best, total, n = 1e30, 0.0, 0
    while n < repeat or total < PEER_MIN_S:  # as host_step: at least repeat calls and PEER_MIN_S of them
        t0 = time.perf_counter()
        peer.predict(sc.transform(x))
        dt = time.perf_counter() - t0
        best, total, n = min(best, dt), total + dt, n + 1
    return best


def table(fig: dict) -> str:
    """The Markdown table of the figures: float, fixed point int16 and int8 side by side."""
    a, h = fig["avr"], fig["host"]
    fs, qs, es = a["float"]["stages"], a["fixed"]["stages"], a["int8"]["stages"]
    rows = ["| What | Float | Fixed point int16 | int8 | Goal / peer |", "|---|---:|---:|---:|---|"]
    e_step = es["step"]
    met = lambda goal: e_step["median"] <= goal and e_step["max"] <= goal
    goal = (f"goal {GOAL_AVR_STEP:,} (int8): {'met' if met(GOAL_AVR_STEP) else '**missed**'}; stretch "
            f"{GOAL_AVR_STEP_STRETCH:,}: {'met' if met(GOAL_AVR_STEP_STRETCH) else '**missed**'}")
    mm = lambda st: f"{st['median']:,.0f} / {st['max']:,}"
    rows.append(f"| AVR full step (16, 8), cycles, median / max over {qs['step']['n']} golden rows | "
                f"{mm(fs['step'])} | {mm(qs['step'])} | {mm(e_step)} | {goal} |")
    ms = lambda st: f"{st['median'] / CPU_HZ * 1e3:.2f}"
    rows.append(f"| AVR full step, ms at 16 MHz (median) | {ms(fs['step'])} | {ms(qs['step'])} | {ms(e_step)} | |")
    rows.append(f"| AVR network (residual: scaler + MLP), cycles, median | {fs['residual']['median']:,.0f} | "
                f"{qs['residual']['median']:,.0f} | {es['residual']['median']:,.0f} | float / int16 "
                f"{fs['residual']['median'] / qs['residual']['median']:.2f}x, float / int8 "
                f"{fs['residual']['median'] / es['residual']['median']:.2f}x |")
    p = a["peer"]
    if p["status"] == "run":
        pm = p["stages"]["peer_predict"]["median"]
        rows.append(f"| emlearn {p['emlearn']} predict, same network (peer), cycles, median / max | "
                    f"{pm:,.0f} / {p['stages']['peer_predict']['max']:,} | | | peer / int8 network "
                    f"{pm / es['residual']['median']:.2f}x; peer / int16 network {pm / qs['residual']['median']:.2f}x; "
                    f"peer / float network {pm / fs['residual']['median']:.2f}x |")
        rows.append(f"| emlearn predict alone: flash / RAM, bytes | {p['size']['flash_B']:,} / {p['size']['ram_B']:,} "
                    "| | | weights in RAM |")
    else:
        rows.append(f"| emlearn predict (peer) | {p['status']} | | | |")
    fr = lambda k: f"{a[k]['size']['flash_B']:,} / {a[k]['size']['ram_B']:,}"
    rows.append(f"| AVR one-step program: flash / RAM, bytes | {fr('float')} | {fr('fixed')} | {fr('int8')} | |")
    rows.append(f"| AVR steps off the golden estimate (1e-4 rel.) | {a['float']['golden_misses']} | "
                f"{a['fixed']['golden_misses']} | {a['int8']['golden_misses']} | 0 |")
    u = fig.get("uno_loop", {"status": "not run"})
    pct = lambda st, wc: f"{100.0 * st['median'] / wc:.1f} % median, {100.0 * st['max'] / wc:.1f} % at most"  # noqa: E731
    if u.get("status") == "run":
        wc = u["window_cycles"]
        w, o = u["window"], u["observer"]
        ok = w["max"] <= GOAL_UNO_LOOP * wc
        rows.append(f"| UNO main loop at {u['rate_hz']} Hz (uno_acq in simavr, int16 model), work per window, "
                    f"cycles, median / max over {w['n']} windows of {wc:,} | | {mm(w)} "
                    f"({pct(w, wc)}) | | goal {GOAL_UNO_LOOP:.0%} of the window: "
                    f"{'met' if ok else '**missed**'} |")
        rows.append(f"| the observer step in it (the interrupts run during it), cycles, median / max | | {mm(o)} "
                    f"({100.0 * o['max'] / wc:.1f} %) | | uno_acq flash {u['flash_B']:,} of {u['flash_max_B']:,} bytes |")
        if "adc_share_pct" in u:
            rows.append(f"| the ADC interrupt in that run (free-running V/I conversions), share of the CPU | | "
                        f"{u['adc_share_pct']:.1f} % | | |")
    else:
        rows.append(f"| UNO main loop at 100 Hz | | {u.get('status')} | | |")
    r = fig.get("uno_ripple_loop", {"status": "not run"})
    if r.get("status") == "run":
        wc = r["window_cycles"]
        w = r["window"]
        verdict = ("fits: no window lost, no framing error on the link, every window's work within it, the counts "
                   "and Ra equal to the reference" if r["passed"] else f"**does not fit**: {r['verdict']}")
        rows.append(f"| UNO main loop at {r['rate_hz']} Hz with the ripple counter (counting build: "
                    f"{r['ripple_hz'] // 1000} kHz bursts counted in the ADC interrupt, Ra tracked; twin load steps), "
                    f"work per window, cycles, median / max over {w['n']} windows of {wc:,} | | {mm(w)} "
                    f"({pct(w, wc)}) | | {verdict} (the {GOAL_UNO_LOOP:.0%} goal is the loop's without the "
                    f"counter) |")
        if "ripple" in r:
            rows.append(f"| the counter's window step in it (`on_window`: the ripple speed, Ra, the next band), "
                        f"cycles, median / max | | {mm(r['ripple'])} ({100.0 * r['ripple']['max'] / wc:.1f} %) | | "
                        f"counting build flash {r['flash_B']:,} of {r['flash_max_B']:,} bytes |")
        rows.append(f"| the ADC interrupt in that run (10 kHz triggered conversions counted, and the V/I ones), "
                    f"share of the CPU | | {r['adc_share_pct']:.1f} % | | without the counter: "
                    f"{u.get('adc_share_pct', float('nan')):.1f} % |")
    else:
        rows.append(f"| UNO main loop at 100 Hz with the ripple counter | | {r.get('status')} | | |")
    for key, label in (("16_8", "(16, 8)"), ("128_64", "(128, 64) timing model")):
        f, q, sk = h[f"float_{key}"], h[f"fixed_{key}"], h[f"sklearn_{key}"]
        e = h.get(f"int8_{key}")
        g = ""
        if key == "16_8":
            g = f"goal {GOAL_HOST_PER_S:.0e}: {'met' if max(f, q) >= GOAL_HOST_PER_S else '**missed**'}; "
        ratio = f", {e / sk:.1f}x (int8)" if e else ""
        rows.append(f"| Host Observer::step {label}, samples/s, one core | {f:,.0f} | {q:,.0f} | "
                    f"{f'{e:,.0f}' if e else ''} | {g}scikit-learn predict {sk:,.0f}/s: ratio {f / sk:.1f}x (float), "
                    f"{q / sk:.1f}x (int16){ratio} |")
    ns = lambda per_s: 1e9 / per_s
    rows.append(f"| Host (16, 8) per sample, ns: prepare + finish (physics, envelope, gate, clamp) / network "
                f"| {ns(h['prepare_finish_float_16_8']):.0f} / {ns(h['network_float_16_8']):.0f} "
                f"| {ns(h['prepare_finish_fixed_16_8']):.0f} / {ns(h['network_fixed_16_8']):.0f} | | each alone, best of "
                "the passes |")
    lx = fig.get("lx106", {"status": "not run"})
    if lx.get("status") == "run":
        for key, label in (("16_8", "(16, 8)"), ("128_64", "(128, 64) timing model")):
            f, q = lx[f"float_{key}"]["step"], lx[f"fixed_{key}"]["step"]
            e = lx[f"int8_{key}"]["step"] if f"int8_{key}" in lx else None
            note = ""
            if key == "128_64":
                ok = q["median"] <= GOAL_LX106_WIDE_FIXED and q["max"] <= GOAL_LX106_WIDE_FIXED
                note = (f"goal {GOAL_LX106_WIDE_FIXED:,} (int16): {'met' if ok else '**missed**'}; the paper's float "
                        f"(128, 64): {PAPER_LX106_MS} ms")
            rows.append(f"| ESP8266 (QEMU lx106) full step {label}, instructions, median / max | "
                        f"{mm(f)} | {mm(q)} | {mm(e) if e else ''} | {note} |")
            lms = lambda st: f"{st['median'] / LX_CLOCK_HZ * 1e3:.3f}"
            rows.append(f"| the same, ms at 80 MHz, one instruction a cycle (a lower bound), median | "
                        f"{lms(f)} | {lms(q)} | {lms(e) if e else ''} | |")
        e_miss = lx["int8_16_8"]["golden_misses"] if "int8_16_8" in lx else ""
        rows.append(f"| ESP8266 steps off the golden estimate (1e-4 rel.), (16, 8) | "
                    f"{lx['float_16_8']['golden_misses']} | {lx['fixed_16_8']['golden_misses']} | {e_miss} | 0 |")
        tl = lx.get("telemetry_line", {"status": "not run"})
        if tl.get("status") == "run":
            ln = tl["line"]
            ok = ln["median"] <= GOAL_LX106_LINE and ln["max"] <= GOAL_LX106_LINE
            rows.append(f"| ESP8266 (QEMU lx106) telemetry line, ArduinoJson {tl['arduinojson']}, instructions, median / max "
                        f"over {ln['n']} golden rows ({tl['bytes']['median']:.0f} bytes) | {mm(ln)} "
                        f"| | | goal {GOAL_LX106_LINE:,}: {'met' if ok else '**missed**'}; "
                        f"{ln['median'] / (LX_CLOCK_HZ / 100) * 100:.1f} % of a 100 Hz sample at 80 MHz |")
            up = tl["upload_parse"]
            rows.append(f"| ESP8266 (QEMU lx106) model upload: parse and checks of the default model's document "
                        f"({up['document_B']:,} bytes; accepted: {'yes' if up['accepted'] else '**no**'}), instructions | "
                        f"{up['instructions']:,} | | | {up['instructions'] / LX_CLOCK_HZ * 1e3:.1f} ms at 80 MHz (a lower "
                        f"bound); ArduinoJson arena peak {up['arena_peak_B']:,} of {up['arena_capacity_B']:,} bytes |")
        else:
            rows.append(f"| ESP8266 (QEMU lx106) telemetry line | {tl.get('status')} | | | |")
    else:
        rows.append(f"| ESP8266 (QEMU lx106) instruction counts | {lx.get('status')} | | | |")
    up = fig.get("esp_upload", {"status": "not run"})
    if up.get("status") == "run":
        t = up["seconds"]
        ok = t["max"] <= GOAL_UPLOAD_S
        rows.append(f"| ESP8266 model upload (`hpddo upload`), default model, {up['document_B']:,} bytes in {up['chunks']} "
                    f"chunks, to the board's logic built for the host over a pseudo-terminal at an emulated "
                    f"{up['baud']:,} baud, s, median / max of {t['n']} | {t['median']:.3f} / {t['max']:.3f} | | | "
                    f"goal {GOAL_UPLOAD_S:g} s: {'met' if ok else '**missed**'}; no USB bridge latency, no flash writes |")
    else:
        rows.append(f"| ESP8266 model upload | {up.get('status')} | | | |")
    prof = ["", "Profile per stage on the AVR (cycles, median over the golden rows; each stage timed alone; "
            "gate: the search from prototype 0, gate_hinted: from the previous row's nearest, as in the step):", "",
            "| Stage | Float | Fixed point int16 | int8 |", "|---|---:|---:|---:|"]
    for k in ("prepare", "residual", "finish", "gate", "gate_hinted", "physics", "physics_all_effects", "thermal_on",
              "scaler", "envelope"):
        if k in fs:
            q = f"{qs[k]['median']:,.0f}" if k in qs else "folded into layer 0"
            e = f"{es[k]['median']:,.0f}" if k in es else "folded into layer 0"
            prof.append(f"| {k} | {fs[k]['median']:,.0f} | {q} | {e} |")
    return "\n".join(rows + prof) + "\n"


def write_doc(fig: dict, text: str) -> None:
    doc = DOC.read_text() if DOC.exists() else ""
    block = (f"{BEGIN}\nMeasured by `{COMMAND}` on {fig['when']} ({fig['machine']}); figures in "
             f"`docs/figures/bench_observer.json`.\n\n{text}{END}")
    if BEGIN in doc and END in doc:
        doc = doc[:doc.index(BEGIN)] + block + doc[doc.index(END) + len(END):]
    else:
        doc = doc + ("\n" if doc else "") + block + "\n"
    DOC.write_text(doc)
    FIGURES.parent.mkdir(parents=True, exist_ok=True)
    FIGURES.write_text(json.dumps(fig, indent=1, sort_keys=True) + "\n")


def run(build: pathlib.Path, repeat: int = 20, peer_python=None, write: bool = False, lx: bool = True) -> dict:
    from ..model import export
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    model = export.read_model_header((ROOT / "models" / "default" / "model_default.h").read_text())
    fig = {"command": COMMAND, "when": time.strftime("%Y-%m-%d", time.gmtime()),
           "machine": f"{os.uname().machine}, {os.cpu_count()} cores",
           "avr": avr(build / "avr", model, peer_python), "uno_loop": uno_loop(build / "uno"),
           "uno_ripple_loop": uno_ripple_loop(build / "uno"),
           "host": host(build / "host", model, repeat),
           "lx106": lx106(build / "lx106", model) if lx else {"status": "not run (--no-lx106)"},
           "esp_upload": esp_upload(build / "esp_upload")}
    text = table(fig)
    print(text, end="")
    if write:
        write_doc(fig, text)
        print(f"wrote {DOC.relative_to(ROOT)} and {FIGURES.relative_to(ROOT)}")
    return fig


if __name__ == "__main__":
    sys.exit(0 if run(ROOT / "build-bench") else 1)
