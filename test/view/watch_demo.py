"""Run the demo with the view and a headless Chromium watching it; save a screenshot of the page mid-run.

    .venv/bin/python test/view/watch_demo.py OUT_DIR [--shot-at S] [--browser-nice N] [demo arguments ...]
    .venv/bin/python test/view/watch_demo.py OUT_DIR --remote [demo arguments ...]

Used for docs/view.png and the view's cost on the planner's tick (docs/benchmark.md): the page stays open for
the whole run, so the view sends every frame to a browser as it would for a user. ``--browser-nice 19`` lowers the
browser's CPU priority (Chromium renders WebGL on the CPU here). ``--remote`` stands in for a browser on another
machine: instead of Chromium, a websocket client (viser's protocol, the `websockets` package viser itself uses)
receives every message the view sends for the whole run and renders nothing, so this machine pays for the view
and the sending only.
"""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from browser import chromium, dismiss_notifications  # noqa: E402


def _cpu_seconds(driver, port: int) -> tuple[float, float]:
    """CPU seconds (user + system) used so far by the view process and by the browser's processes."""
    import psutil

    def used(procs) -> float:
        total = 0.0
        for p in procs:
            try:
                t = p.cpu_times()
                total += t.user + t.system
            except psutil.Error:
                pass
        return total

    view = [
        p
        for p in psutil.process_iter(["cmdline"])
        if p.info["cmdline"] and "view" in p.info["cmdline"] and str(port) in p.info["cmdline"]
    ]
    browser = psutil.Process(driver.service.process.pid).children(recursive=True)
    return used(view), used(browser)


def _drain(port: int, stop: threading.Event, counts: dict) -> None:
    """Receive and drop everything the view at `port` sends until `stop` (the network end of a remote page)."""
    import msgspec
    import viser
    from viser._messages import ViewerCameraMessage
    from websockets.sync.client import connect

    camera = ViewerCameraMessage(  # a page counts as open once it has sent its camera (as a browser does)
        wxyz=(1.0, 0.0, 0.0, 0.0),
        position=(2.0, 0.0, 1.0),
        fov=1.0,
        near=0.01,
        far=100.0,
        image_height=800,
        image_width=1280,
        look_at=(0.0, 0.0, 0.3),
        up_direction=(0.0, 0.0, 1.0),
    )
    with connect(f"ws://localhost:{port}", subprotocols=[f"viser-v{viser.__version__}"], max_size=None) as ws:
        ws.send(msgspec.msgpack.encode(camera.as_serializable_dict()))
        while not stop.is_set():
            try:
                message = ws.recv(timeout=0.5)
            except TimeoutError:
                continue
            except Exception:  # the demo stopped the view
                return
            counts["messages"] += 1
            counts["bytes"] += len(message)


def _remote(proc: subprocess.Popen, port: int) -> int:
    """Keep a remote-page stand-in connected for the whole run; print what it received and the view's CPU share."""
    import psutil

    stop, counts = threading.Event(), {"messages": 0, "bytes": 0}
    thread = threading.Thread(target=_drain, args=(port, stop, counts), daemon=True)
    thread.start()
    view = [
        p
        for p in psutil.process_iter(["cmdline"])
        if p.info["cmdline"] and "view" in p.info["cmdline"] and str(port) in p.info["cmdline"]
    ]
    t0 = time.monotonic()
    cpu0 = sum(p.cpu_times().user + p.cpu_times().system for p in view)
    cpu1 = cpu0
    while proc.poll() is None:
        try:
            cpu1 = sum(p.cpu_times().user + p.cpu_times().system for p in view)
        except psutil.Error:
            break
        time.sleep(0.5)
    wall = time.monotonic() - t0
    stop.set()
    thread.join(2.0)
    print(
        f"[watch] remote client over {wall:.0f} s: {counts['messages']} messages, {counts['bytes'] / 1e6:.0f} MB; "
        f"view {(cpu1 - cpu0) / wall:.0%} of a core",
        flush=True,
    )
    return proc.returncode


def main(argv: list[str]) -> int:
    out = Path(argv[0])
    shot_at, browser_nice = 20.0, 0
    rest = argv[1:]
    remote = "--remote" in rest
    rest = [a for a in rest if a != "--remote"]
    while rest[:1] in (["--shot-at"], ["--browser-nice"]):
        if rest[0] == "--shot-at":
            shot_at = float(rest[1])
        else:
            browser_nice = int(rest[1])
        rest = rest[2:]
    port = 8097
    cmd = [sys.executable, "-m", "latent_planner_ros", "demo", "--out", str(out), "--view", "--view-port", str(port)]
    proc = subprocess.Popen(cmd + rest, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines: list[str] = []
    started = threading.Event()

    def pump():
        for line in proc.stdout:
            lines.append(line)
            sys.stdout.write(line)
            if "resetting the scene" in line:
                started.set()

    threading.Thread(target=pump, daemon=True).start()
    if not started.wait(180):
        proc.kill()
        return 1
    if remote:
        return _remote(proc, port)
    driver = chromium(1280, 800)
    try:
        driver.get(f"http://localhost:{port}")
        if browser_nice:  # after the page load: its renderer and GPU processes exist now
            import psutil

            for child in psutil.Process(driver.service.process.pid).children(recursive=True):
                child.nice(browser_nice)
        t0 = time.monotonic()
        cpu = _cpu_seconds(driver, port)
        while proc.poll() is None and time.monotonic() - t0 < shot_at:
            time.sleep(0.5)
        dismiss_notifications(driver)
        time.sleep(0.5)
        driver.save_screenshot(str(out / "view.png"))
        end, wall = _cpu_seconds(driver, port), time.monotonic() - t0
        print(
            f"[watch] CPU over {wall:.0f} s with the page open: view {(end[0] - cpu[0]) / wall:.0%} of a core, "
            f"browser {(end[1] - cpu[1]) / wall:.0%}",
            flush=True,
        )
        proc.wait()
    finally:
        driver.quit()
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
