"""A skipped ctest says why, in scripts/test.sh's own output (issue 32: without ../shared, 17
tests showed "Skipped" with no reason and the run ended "100% tests passed"). ctest 3.25's
summary has no reasons; its JUnit file has each skipped test's output, and
test/ctest_skips.py prints them. Proven here on a small CMake project whose tests skip the
project's two ways: test/vendor_skip.cmake (SKIP_REGULAR_EXPRESSION) and an exit status 77
(SKIP_RETURN_CODE, as test/embedded/lx106/run_unity.py)."""
import os
import re
import shutil
import subprocess
import sys

import pytest

from conftest import ROOT

SCRIPT = ROOT / "test" / "ctest_skips.py"


def _project(tmp_path, no_reason=False):
    src = tmp_path / "src"
    src.mkdir()
    (src / "CMakeLists.txt").write_text(f"""cmake_minimum_required(VERSION 3.21)
project(skips NONE)
enable_testing()
add_test(NAME vendor COMMAND ${{CMAKE_COMMAND}} "-DREASON=Unity 2.6.1 not found at /nowhere"
         -P {ROOT / 'test' / 'vendor_skip.cmake'})
set_tests_properties(vendor PROPERTIES SKIP_REGULAR_EXPRESSION "hpddo-vendor-skip:")
add_test(NAME qemu COMMAND sh -c "echo 'skipped: qemu-system-misc not installed'; exit 77")
set_tests_properties(qemu PROPERTIES SKIP_RETURN_CODE 77)
add_test(NAME runs COMMAND sh -c "echo fine")
""" + ('add_test(NAME mute COMMAND sh -c "exit 77")\nset_tests_properties(mute PROPERTIES SKIP_RETURN_CODE 77)\n'
       if no_reason else ""))
    subprocess.run(["cmake", "-S", src, "-B", tmp_path / "b"], check=True, capture_output=True)
    return tmp_path / "b"


def _run(build, ci: bool):
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    if ci:
        env["CI"] = "true"
    ct = subprocess.run(["ctest", "--test-dir", build, "--output-on-failure", "--output-junit", "ctest-junit.xml"],
                        env=env, capture_output=True, text=True)
    sk = subprocess.run([sys.executable, SCRIPT, build / "ctest-junit.xml"], env=env, capture_output=True, text=True)
    return ct, sk


needs_cmake = pytest.mark.skipif(not shutil.which("ctest"), reason="cmake not installed (scripts/bootstrap.sh)")


@needs_cmake
def test_each_skipped_test_is_listed_with_its_reason(tmp_path):
    ct, sk = _run(_project(tmp_path), ci=False)
    assert ct.returncode == 0 and "100% tests passed" in ct.stdout, ct.stdout  # what ctest alone says
    assert "Unity 2.6.1 not found" not in ct.stdout  # ... with no reason in sight
    assert sk.returncode == 0, sk.stdout + sk.stderr
    assert sk.stdout.splitlines() == ["ctest: 2 test(s) skipped, counted as passed above:",
                                      "  vendor: Unity 2.6.1 not found at /nowhere",
                                      "  qemu: qemu-system-misc not installed"], sk.stdout


@needs_cmake
def test_a_skip_without_a_reason_fails(tmp_path):
    _, sk = _run(_project(tmp_path, no_reason=True), ci=False)
    assert sk.returncode == 1
    assert "  mute: NO REASON PRINTED" in sk.stdout, sk.stdout


@needs_cmake
def test_under_ci_a_skip_fails_the_run(tmp_path):
    ct, sk = _run(_project(tmp_path), ci=True)
    assert ct.returncode != 0 and re.search(r"vendor \(Failed\)", ct.stdout), ct.stdout  # vendor_skip.cmake's own
    assert "CI=true and a vendored dependency is missing" in ct.stdout
    assert sk.returncode == 1 and "qemu: qemu-system-misc not installed" in sk.stdout, sk.stdout + sk.stderr


def test_scripts_test_sh_lists_the_skips_after_every_ctest():
    text = (ROOT / "scripts" / "test.sh").read_text()
    body = text[text.index("run_ctest() {"):text.index("\n}\n", text.index("run_ctest() {"))]
    calls = [ln.strip() for ln in text.replace(body, "").splitlines() if re.match(r"\s*(run_)?ctest\b", ln)]
    assert calls and all(c.startswith("run_ctest ") for c in calls), calls  # every ctest of the run
    assert re.search(r"ctest --test-dir \"\$dir\".*--output-junit ctest-junit.xml", body)
    assert 'test/ctest_skips.py "$dir/ctest-junit.xml"' in body


def test_the_lx106_suites_fail_rather_than_skip_under_ci(tmp_path):
    """run_unity.py where QEMU is not on the PATH: skipped with the reason, or under CI=true failed."""
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    env["PATH"] = str(tmp_path)  # nothing: no qemu-system-xtensa, no lx106 GCC
    args = [sys.executable, ROOT / "test" / "embedded" / "lx106" / "run_unity.py", "test_acq", "--root", ROOT,
            "--unity", tmp_path, "--build", tmp_path / "b"]
    skip = subprocess.run(args, env=env, capture_output=True, text=True)
    assert skip.returncode == 77 and skip.stdout.startswith("skipped: qemu-system-misc"), skip.stdout
    assert "scripts/bootstrap.sh --tests installs them" in skip.stdout
    fail = subprocess.run(args, env=dict(env, CI="true"), capture_output=True, text=True)
    assert fail.returncode == 1 and "CI=true and qemu-system-misc" in fail.stdout, fail.stdout
