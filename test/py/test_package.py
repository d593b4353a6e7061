"""hpddo as a package: a wheel built from the tree installs into a fresh venv, and its
`hpddo` command works from outside the repository (the installed copy, not the tree).

Offline: the wheel is built with the project venv's pinned setuptools
(--no-build-isolation, --no-index) from a copy of the tree (so no build/ or egg-info lands
in the repository), installed with --no-deps, and the fresh venv finds numpy & co. in the
project venv's site-packages through a .pth file."""
import json
import os
import pathlib
import shutil
import subprocess
import sys
import sysconfig

import pytest

from conftest import ROOT

pytestmark = pytest.mark.slow  # runs tools for seconds to minutes: not in scripts/test.sh --quick

PY = sys.executable
TOP_LEVEL_SKIP = {".git", ".venv", "out", "models"}


def _copy_tree(dst: pathlib.Path) -> pathlib.Path:
    def ignore(folder, names):
        skip = {n for n in names if n == "__pycache__" or n.endswith(".egg-info")}
        if pathlib.Path(folder) == ROOT:
            skip |= {n for n in names if n in TOP_LEVEL_SKIP or n.startswith("build")}
        return skip
    shutil.copytree(ROOT, dst, ignore=ignore)
    return dst


def _env() -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env["PIP_NO_INDEX"] = "1"  # offline, whatever pip.conf says
    return env


def _run(cmd, cwd, check=True, **kw):
    res = subprocess.run([str(c) for c in cmd], cwd=cwd, env=_env(), capture_output=True, text=True,
                         timeout=300, **kw)
    if check:
        assert res.returncode == 0, f"{cmd}: exit {res.returncode}\n{res.stdout}\n{res.stderr}"
    return res


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(venv bin folder, a folder outside the repository to run in)."""
    tmp = tmp_path_factory.mktemp("package")
    src = _copy_tree(tmp / "src")
    wheels = tmp / "wheels"
    _run([PY, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-index", "-q",
          "-w", wheels, src], cwd=tmp)
    wheel, = wheels.glob("hpddo-0.2.0-*.whl")
    venv = tmp / "venv"
    _run([PY, "-m", "venv", "--without-pip", venv], cwd=tmp)
    vpy = venv / "bin" / "python"
    site = pathlib.Path(_run([vpy, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                             cwd=tmp).stdout.strip())
    (site / "project_deps.pth").write_text(sysconfig.get_path("purelib") + "\n")  # numpy & co.
    _run([PY, "-m", "pip", "--python", vpy, "install", "--no-deps", "--no-index", "-q", wheel], cwd=tmp)
    run_dir = tmp / "elsewhere"
    run_dir.mkdir()
    return venv / "bin", run_dir


def test_the_installed_package_is_not_the_tree(installed):
    bin_dir, cwd = installed
    where = _run([bin_dir / "python", "-c", "import hpddo; print(hpddo.__file__, hpddo.__version__)"],
                 cwd=cwd).stdout.split()
    assert pathlib.Path(where[0]).is_relative_to(bin_dir.parent) and where[1] == "0.2.0"
    assert not str(ROOT) in where[0]
    # the dependencies satisfy pyproject.toml's ranges (they are the pinned ones)
    _run([PY, "-m", "pip", "--python", bin_dir / "python", "check"], cwd=cwd)


def test_help_of_the_command_and_every_subcommand(installed):
    bin_dir, cwd = installed
    top = _run([bin_dir / "hpddo", "--help"], cwd=cwd).stdout
    for sub in ("train", "evaluate", "diagnose", "compare", "twin", "capture", "demo", "bench", "fixtures"):
        assert sub in top
    train = _run([bin_dir / "hpddo", "train", "--help"], cwd=cwd).stdout
    for flag in ("--out", "--effects", "--ra-ohm", "--seed", "--no-glitch-filter", "--quiet"):
        assert flag in train
    assert _run([bin_dir / "python", "-m", "hpddo", "--version"], cwd=cwd).stdout.strip() == "hpddo 0.2.0"
    usage = _run([bin_dir / "hpddo", "train"], cwd=cwd, check=False)
    assert usage.returncode == 2 and "usage: hpddo train" in usage.stderr


def test_twin_writes_a_bench_log_outside_the_repository(installed):
    bin_dir, cwd = installed
    _run([bin_dir / "hpddo", "twin", "--protocol", "sweep", "--time-scale", "0.05", "--out", "X", "--quiet"],
         cwd=cwd)
    out = cwd / "X"
    assert sorted(p.name for p in out.iterdir()) == [".hpddo-output.json", "sweep.csv", "sweep.truth.csv",
                                                     "sweep.truth.json"]
    assert json.loads((out / ".hpddo-output.json").read_text())["tool"] == "twin"
    lines = (out / "sweep.csv").read_text().splitlines()
    assert "# condition=sweep" in lines and len(lines) > 20
    # a user error: one line `hpddo twin: ...`, status 1, nothing touched
    (cwd / "afile").write_text("keep\n")
    bad = _run([bin_dir / "hpddo", "twin", "--protocol", "sweep", "--out", "afile", "--quiet"], cwd=cwd,
               check=False)
    assert bad.returncode == 1 and bad.stderr.startswith("hpddo twin: ") and bad.stderr.count("\n") == 1
    assert (cwd / "afile").read_text() == "keep\n"


def test_the_demo_of_a_pip_install_has_its_recordings_never_seen(installed):
    """hpddo demo's step 4 scores data/validation: the wheel carries it (it skipped the step
    without a word when it did not)."""
    bin_dir, _ = installed
    share = bin_dir.parent / "share" / "hpddo"
    assert {"hot.csv", "unseen.csv"} <= {p.name for p in (share / "data" / "validation").glob("*.csv")}
    res = _run([bin_dir / "hpddo", "demo", "--help"], cwd=bin_dir)
    assert str(share / "data" / "validation") in "".join(res.stdout.split())  # argparse wraps the path


def test_train_builds_the_native_replay_from_the_installed_sources(installed):
    """The wheel carries the replay's CMake project, the core headers and the bundled
    recordings (<venv>/share/hpddo): a short training run builds and replays natively."""
    bin_dir, cwd = installed
    share = bin_dir.parent / "share" / "hpddo"
    log = share / "data" / "default" / "sweep.csv"
    assert log.is_file() and (share / "host" / "CMakeLists.txt").is_file()
    res = _run([bin_dir / "hpddo", "train", log, "--out", "m", "--epochs", "1"], cwd=cwd)
    assert "wrote m/" in res.stdout and (cwd / "m" / "report" / "index.html").is_file()
    metrics = json.loads((cwd / "m" / "metrics.json").read_text())
    assert metrics["source"].startswith("native replay") and "sweep" in metrics["rmse_rpm"]["M2"]
    assert (cwd / "m" / "model_default.h").read_text().startswith("// GENERATED model header")


# In process, against the tree: one set of flag names and one error convention.

RIPPLE = {"--ripples-per-rev", "--gear-ratio", "--ke-vs-per-rad", "--floor-a", "--prior-model", "--prior-name"}
REFERENCE = {"--reference"} | RIPPLE  # options.reference
SHARED = {  # subcommand -> the shared options it takes
    "train": {"--out", "--quiet", "--seed", "--ra-ohm", "--ke-fit", "--effects", "--no-glitch-filter", "--epochs"}
    | REFERENCE,
    "diagnose": {"--out", "--quiet", "--seed", "--ra-ohm", "--ke-fit", "--effects", "--no-glitch-filter", "--epochs"}
    | REFERENCE,
    "evaluate": {"--out", "--no-glitch-filter", "--quiet"} | REFERENCE,
    "ripple": {"--out", "--quiet", "--ra-ohm"} | RIPPLE,
    "compare": {"--out", "--quiet", "--seed", "--ra-ohm", "--effects", "--no-glitch-filter", "--epochs"} | RIPPLE,
    "twin": {"--out", "--quiet", "--seed", "--effects", "--rate-hz"},
    "capture": {"--out", "--quiet", "--rate-hz"},
    "live": {"--out", "--quiet", "--rate-hz"},
    "demo": {"--out", "--quiet", "--seed", "--ra-ohm", "--no-glitch-filter"},
    "bench": set(),
    "fixtures": {"--out", "--quiet"},
}


@pytest.mark.parametrize("sub", sorted(SHARED))
def test_every_subcommand_uses_the_shared_flag_names_with_help_on_every_option(sub):
    from hpddo import cli
    p = cli.parser(sub)
    flags = {s for a in p._actions for s in a.option_strings}
    assert SHARED[sub] <= flags
    assert not flags & {"--no-progress", "--effect", "--no-effect", "--output"}, "the former names are gone"
    assert all(a.help for a in p._actions), [a.dest for a in p._actions if not a.help]
    assert p.prog == f"hpddo {sub}"


# One word per concept: the spellings a subcommand must not use for what another calls by the
# shared name (the left side), and what the shared option must mean everywhere.
SYNONYMS = {"--epochs": {"--max-iter", "--hybrid-iter", "--iterations", "--iter", "--epoch"},
            "--rate-hz": {"--rate", "--hz", "--sample-rate", "--rate_hz"},
            "--quiet": {"-q", "--silent", "--no-progress", "--verbose"},
            "--out": {"--output", "--out-dir", "--outdir"},
            "--effects": {"--effect", "--with-effects"}}


@pytest.mark.parametrize("sub", sorted(SHARED))
def test_one_vocabulary_of_options_across_subcommands(sub):
    from hpddo import cli
    from hpddo.cli import options
    p = cli.parser(sub)
    for a in p._actions:
        for shared, other in SYNONYMS.items():
            assert not set(a.option_strings) & other, f"hpddo {sub}: {a.option_strings} where others say {shared}"
        if "--quiet" in a.option_strings:
            assert a.help == options.QUIET_HELP, f"hpddo {sub} --quiet means something of its own: {a.help}"
        if a.help and "epochs" in a.help.lower() and a.option_strings and a.option_strings[0].startswith("--"):
            assert a.option_strings[0] in ("--epochs", "--quick"), (sub, a.option_strings, a.help)
        if a.metavar == "HZ" and "sample rate" in (a.help or ""):
            assert a.option_strings == ["--rate-hz"], (sub, a.option_strings)


def test_user_errors_are_one_line_named_after_the_subcommand_with_status_1(tmp_path, capsys):
    from hpddo import cli
    missing = tmp_path / "nope.csv"
    empty = tmp_path / "empty"
    empty.mkdir()
    cases = {"train": [str(missing), "--out", str(tmp_path / "t"), "--quiet"],
             "diagnose": [str(missing), "--out", str(tmp_path / "d"), "--quiet"],
             "demo": ["--data", str(empty), "--out", str(tmp_path / "o")],
             "bench": ["--data", str(empty)],
             "capture": ["--port", str(tmp_path / "no-such-port"), "--out", str(tmp_path / "c.csv"), "--quiet"],
             "live": ["--port", str(tmp_path / "no-such-port"), "--out", str(tmp_path / "l.csv"), "--quiet",
                      "--http-port", "0"]}
    for sub, argv in cases.items():
        assert cli.main([sub, *argv]) == 1, sub
        err = capsys.readouterr().err
        assert err.startswith(f"hpddo {sub}: ") and err.count("\n") == 1 and "Traceback" not in err, err
    with pytest.raises(SystemExit) as usage:  # a bad command line: argparse's status 2
        cli.main(["twin", "--effects", "nonsense", "--out", str(tmp_path / "w")])
    assert usage.value.code == 2 and "unknown effect 'nonsense'" in capsys.readouterr().err
