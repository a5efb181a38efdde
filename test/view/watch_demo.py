"""Run the demo with the view and a headless Chromium watching it; save a screenshot of the page mid-run.

    .venv/bin/python test/view/watch_demo.py OUT_DIR [--shot-at S] [demo arguments ...]

Used for docs/view.png and the view's cost on the planner's tick (docs/benchmark.md): the page stays open for
the whole run, so the view sends every frame to a browser as it would for a user.
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


def main(argv: list[str]) -> int:
    out = Path(argv[0])
    shot_at = 20.0
    rest = argv[1:]
    if rest[:1] == ["--shot-at"]:
        shot_at, rest = float(rest[1]), rest[2:]
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
        t0 = time.monotonic()
        while proc.poll() is None and time.monotonic() - t0 < shot_at:
            time.sleep(0.5)
        dismiss_notifications(driver)
        time.sleep(0.5)
        driver.save_screenshot(str(out / "view.png"))
        proc.wait()
    finally:
        driver.quit()
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
