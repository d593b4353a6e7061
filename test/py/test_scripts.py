"""scripts/*.sh: every `scripts/NAME.sh --flag` that the documents, the tests and the sources
name is a flag the script accepts (issue 32: docs/firmware.md and two skip messages named
`scripts/bootstrap.sh --with-browser`, which the script refuses with status 2)."""
import re
import subprocess

from conftest import ROOT

MENTION = re.compile(r"scripts/(\w+\.sh)[ \t]+(-[-\w]*)")
ARM = re.compile(r"^\s*(-[-\w]*)\)", re.M)  # a `case "$1" in` arm: `  --tests) ...`
TEXT = {".md", ".py", ".sh", ".cmake", ".txt", ".toml", ".ini", ".yml", ".yaml", ".h", ".cpp", ".ino", ".json"}


def accepted(script: str) -> set:
    """The flags a script's own argument parsing takes (its case arms)."""
    return set(ARM.findall((ROOT / "scripts" / script).read_text(encoding="utf-8")))


def mentions() -> list:
    files = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    out = []
    for name in files:
        path = ROOT / name
        if path.suffix not in TEXT or name == "test/py/test_scripts.py" or not path.is_file():
            continue
        for n, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            out += [(f"{name}:{n}", script, flag) for script, flag in MENTION.findall(line)]
    return out


def test_the_scripts_parse_their_flags_in_case_arms():
    assert accepted("bootstrap.sh") == {"--tests"}
    assert accepted("test.sh") == {"--quick"}


def test_every_flag_named_for_a_script_is_one_it_accepts():
    found = mentions()
    assert {s for _, s, _ in found} >= {"bootstrap.sh", "test.sh"}
    wrong = [f"{where}: scripts/{script} {flag} (it accepts {sorted(accepted(script)) or 'no flag'})"
             for where, script, flag in found
             if not (ROOT / "scripts" / script).is_file() or flag not in accepted(script)]
    assert not wrong, "\n".join(wrong)
