"""Headless Chromium for tests of the HTML reports: a screenshot, the rendered DOM and the
page's console errors, as a person opening the report would meet them (render); for a live
page that draws from its server, the same over Chromium's DevTools protocol after some
seconds of real time, with values read from the page (live)."""
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
    profile = tempfile.mkdtemp(prefix="hpddo-chromium-")
    try:
        base = [exe, *FLAGS, f"--user-data-dir={profile}", f"--window-size={width},{height}"]
        shot = subprocess.run([*base, "--enable-logging=stderr", "--v=0", f"--screenshot={png_path}", url],
                              capture_output=True, text=True, timeout=timeout)
        dom = subprocess.run([*base, "--dump-dom", url], capture_output=True, text=True, timeout=timeout)
    finally:
        remove_profile(profile)  # as live(): its helpers may still write into it
    errors = [ln for ln in shot.stderr.splitlines()
              if re.search(r"CONSOLE\(\d+\)|Uncaught|ERR_FILE_NOT_FOUND|Failed to load resource", ln)]
    return {"dom": dom.stdout, "console_errors": errors, "returncode": shot.returncode}


def colour_pixels(png_path, colours: dict, tolerance: int = 24) -> dict:
    """How many pixels of a screenshot are within tolerance (per channel) of each named RGB colour."""
    import numpy as np
    from PIL import Image

    rgb = np.asarray(Image.open(png_path).convert("RGB"), dtype=int)
    return {name: int((np.abs(rgb - np.array(c)).max(axis=2) <= tolerance).sum()) for name, c in colours.items()}


def live(url: str, png_path, wait_s: float, expressions: dict, width: int = 1280, height: int = 1200,
         timeout: float = 120.0, ready: str | None = None) -> dict:
    """Opens a live page (one that draws from a server after it loads, as hpddo live's) in headless
    Chromium driven over its DevTools protocol: waits until the JavaScript expression ready is
    true (if given; polled, within timeout), lets it run wait_s seconds more of real time, then
    evaluates each JavaScript expression in the page and takes a screenshot. Returns
    {"values": {name: value}, "console_errors": [str]}: errors logged to the console, uncaught
    exceptions and failed loads while it ran."""
    import asyncio
    import json
    import os
    import time
    import urllib.request

    exe = chromium()
    if exe is None:
        raise RuntimeError("chromium is not installed: on Debian/Ubuntu, sudo apt-get install chromium (in a clone, scripts/bootstrap.sh --tests does)")
    profile = tempfile.mkdtemp(prefix="hpddo-chromium-")
    try:
        proc = subprocess.Popen([exe, *FLAGS, f"--user-data-dir={profile}", f"--window-size={width},{height}",
                                 "--remote-debugging-port=0", "about:blank"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
        try:
            active = pathlib.Path(profile) / "DevToolsActivePort"
            deadline = time.monotonic() + timeout
            while not (active.is_file() and len(active.read_text().split()) >= 2):
                if proc.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"chromium did not open its DevTools port (exit status {proc.poll()})")
                time.sleep(0.1)
            port = int(active.read_text().split()[0])
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10) as r:
                target = next(t for t in json.load(r) if t.get("type") == "page")
            return asyncio.run(asyncio.wait_for(
                _drive(target["webSocketDebuggerUrl"], url, png_path, wait_s, expressions, ready), timeout))
        finally:
            proc.terminate()
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                os.kill(proc.pid, 9)
                proc.wait()
    finally:
        remove_profile(profile)


def remove_profile(path, timeout: float = 10.0) -> None:
    """Removes a Chromium profile folder. Chromium's helper processes can still be writing into
    it for a moment after the browser has exited (a file appears while the tree is removed:
    "Directory not empty"), so the removal is tried again until the folder is gone or timeout
    seconds have passed; what is then left is left (a test's result is not a profile's)."""
    import time

    deadline = time.monotonic() + timeout
    while True:
        shutil.rmtree(path, ignore_errors=True)
        if not pathlib.Path(path).exists() or time.monotonic() > deadline:
            return
        time.sleep(0.1)


async def _drive(ws_url: str, url: str, png_path, wait_s: float, expressions: dict, ready: str | None) -> dict:
    import asyncio
    import base64
    import json

    from tornado.websocket import websocket_connect

    ws = await websocket_connect(ws_url, max_message_size=64 << 20)
    errors: list[str] = []
    state = {"id": 0}

    def note(msg: dict) -> None:
        method, p = msg.get("method"), msg.get("params", {})
        if method == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
            errors.append("console." + p["type"] + ": " + " ".join(str(a.get("value", a.get("description", "")))
                                                                 for a in p.get("args", [])))
        elif method == "Runtime.exceptionThrown":
            d = p.get("exceptionDetails", {})
            errors.append("uncaught: " + str(d.get("exception", {}).get("description") or d.get("text")))
        elif method == "Log.entryAdded" and p.get("entry", {}).get("level") == "error":
            errors.append("log: " + p["entry"].get("text", "") + " " + p["entry"].get("url", ""))

    async def call(method: str, **params):
        state["id"] += 1
        me = state["id"]
        await ws.write_message(json.dumps({"id": me, "method": method, "params": params}))
        while True:
            raw = await ws.read_message()
            if raw is None:
                raise RuntimeError("chromium closed its DevTools connection")
            msg = json.loads(raw)
            if msg.get("id") == me:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg.get("result", {})
            note(msg)

    try:
        for domain in ("Runtime", "Log", "Page"):
            await call(f"{domain}.enable")
        await call("Page.navigate", url=url)
        loop = asyncio.get_running_loop()
        while ready is not None:  # (the caller's timeout bounds this)
            res = await call("Runtime.evaluate", expression=f"(() => {{ try {{ return !!({ready}); }} "
                                                            f"catch (e) {{ return false; }} }})()", returnByValue=True)
            if res.get("result", {}).get("value") is True:
                break
            await asyncio.sleep(0.2)
        end = loop.time() + wait_s
        while (left := end - loop.time()) > 0:
            try:
                raw = await asyncio.wait_for(ws.read_message(), left)
            except asyncio.TimeoutError:
                break
            if raw is None:
                raise RuntimeError("chromium closed its DevTools connection")
            note(json.loads(raw))
        values = {}
        for name, expr in expressions.items():
            res = await call("Runtime.evaluate", expression=expr, returnByValue=True)
            if "exceptionDetails" in res:
                values[name] = None
                d = res["exceptionDetails"]
                errors.append(f"evaluating {name}: {d.get('exception', {}).get('description') or d.get('text')}")
            else:
                values[name] = res["result"].get("value")
        shot = await call("Page.captureScreenshot", format="png")
        pathlib.Path(png_path).write_bytes(base64.b64decode(shot["data"]))
    finally:
        ws.close()
    return {"values": values, "console_errors": errors}
