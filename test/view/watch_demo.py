"""Run the demo with the view and a headless Chromium watching it; save a screenshot of the page mid-run.

    .venv/bin/python test/view/watch_demo.py OUT_DIR [--shot-at S] [--browser-nice N] [demo arguments ...]

Used for docs/view.png and the view's cost on the planner's tick (docs/benchmark.md): the page stays open for
the whole run, so the view sends every frame to a browser as it would for a user. ``--browser-nice 19`` lowers the
browser's CPU priority (Chromium renders WebGL on the CPU here), standing in for a browser on another machine or
a GPU.
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


def main(argv: list[str]) -> int:
    out = Path(argv[0])
    shot_at, browser_nice = 20.0, 0
    rest = argv[1:]
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
