#!/usr/bin/env python3
"""After a ctest run: the tests it skipped, each with its reason, from the JUnit file ctest
writes (`ctest --output-junit FILE`, CMake 3.21 on). ctest's own summary names skipped tests
without a reason and counts them as passed ("100% tests passed"); scripts/test.sh prints
this after each ctest.

A skipped test's reason is the line it printed that starts with `hpddo-vendor-skip:`
(test/vendor_skip.cmake) or `skipped:` (a test that exits with its SKIP_RETURN_CODE, e.g.
test/embedded/lx106/run_unity.py). Exit status 1 where a skipped test printed no reason, or
where CI=true is in the environment and any test was skipped (CI never passes without a
test); else 0.

    ctest_skips.py JUNIT.xml
"""
import os
import re
import sys
import xml.etree.ElementTree as ET

REASON = re.compile(r"^(?:hpddo-vendor-skip|skipped):\s*(.+)$", re.M)


def skipped(junit: str) -> list:
    """(test name, its reason or None) for each test ctest skipped."""
    out = []
    for case in ET.parse(junit).getroot().iter("testcase"):
        if case.find("skipped") is None:
            continue
        m = REASON.search(case.findtext("system-out") or "")
        out.append((case.get("name"), m.group(1).strip() if m else None))
    return out


def main(argv) -> int:
    if len(argv) != 1:
        print("usage: ctest_skips.py JUNIT.xml", file=sys.stderr)
        return 2
    try:
        skips = skipped(argv[0])
    except (OSError, ET.ParseError) as exc:
        print(f"ctest_skips.py: {argv[0]}: cannot read ctest's JUnit file: {exc}", file=sys.stderr)
        return 1
    if not skips:
        print("ctest: no test skipped")
        return 0
    print(f"ctest: {len(skips)} test(s) skipped, counted as passed above:")
    for name, reason in skips:
        print(f"  {name}: {reason or 'NO REASON PRINTED (the test must print hpddo-vendor-skip: or skipped:)'}")
    if any(reason is None for _, reason in skips):
        return 1
    if os.environ.get("CI") == "true":
        print("ctest_skips.py: CI=true: a skipped test fails the run", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
