"""Headless Chromium for tests of the HTML reports: a screenshot, the rendered DOM and the
page's console errors, as a person opening the report would meet them."""
from __future__ import annotations

import pathlib
import re
import shutil
import subprocess
import tempfile

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars"]


def chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


def render(html_path, png_path, width: int = 1280, height: int = 2400, timeout: float = 120.0) -> dict:
    """Loads the page; writes a screenshot; returns {"dom": str, "console_errors": [str]}."""
    exe = chromium()
    if exe is None:
        raise RuntimeError("chromium is not installed: on Debian/Ubuntu, sudo apt-get install chromium (in a clone, scripts/bootstrap.sh --tests does)")
    url = pathlib.Path(html_path).resolve().as_uri()
    with tempfile.TemporaryDirectory() as profile:
        base = [exe, *FLAGS, f"--user-data-dir={profile}", f"--window-size={width},{height}"]
        shot = subprocess.run([*base, "--enable-logging=stderr", "--v=0", f"--screenshot={png_path}", url],
                              capture_output=True, text=True, timeout=timeout)
        dom = subprocess.run([*base, "--dump-dom", url], capture_output=True, text=True, timeout=timeout)
    errors = [ln for ln in shot.stderr.splitlines()
              if re.search(r"CONSOLE\(\d+\)|Uncaught|ERR_FILE_NOT_FOUND|Failed to load resource", ln)]
    return {"dom": dom.stdout, "console_errors": errors, "returncode": shot.returncode}
