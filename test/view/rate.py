"""How often the page's cloud changes: the view fed a 30k-point cloud at 20 Hz, watched in headless Chromium.

    .venv/bin/python test/view/rate.py [SECONDS]

Prints the cloud updates per second the page received (counted in the page, each animation frame comparing the
first points of the cloud with the last ones, every 5 ms) and the view process's CPU share. docs/benchmark.md quotes it.
"""

from __future__ import annotations

import os
import random
import subprocess
import sys
import time
from pathlib import Path

import psutil

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
sys.path[:0] = [str(HERE), str(REPO)]

from browser import FakeSuite, chromium, free_port, scene_nodes, wait_for, wait_http  # noqa: E402

COUNT_JS = """
window.__cloudUpdates = 0;
window.__frames = 0;
(function frame() { window.__frames += 1; requestAnimationFrame(frame); })();
let last = null;
setInterval(() => {
    const node = window.__viserSceneTree.getState()['/clouds/camera/points'];
    const points = node && node.message.props.points;
    const head = points ? Array.from(points.subarray(0, 6)).join(',') + points.byteLength : null;
    if (head !== null && head !== last) { window.__cloudUpdates += 1; last = head; }
}, 5);
"""


def main(argv: list[str]) -> int:
    seconds = float(argv[0]) if argv else 10.0
    domain, port = random.SystemRandom().randint(1, 100), free_port()
    suite = FakeSuite(domain, cloud_hz=20.0)
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    cmd = [sys.executable, "-m", "latent_planner_ros", "view", "--port", str(port)]
    proc = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    driver = None
    try:
        url = f"http://localhost:{port}"
        wait_http(url, proc)
        driver = chromium()
        driver.get(url)
        wait_for(lambda: (scene_nodes(driver) or {}).get("/clouds/camera/points"), 60.0, "the cloud")
        driver.execute_script(COUNT_JS)
        view = psutil.Process(proc.pid)
        view.cpu_percent()
        time.sleep(seconds)
        updates, frames = driver.execute_script("return [window.__cloudUpdates, window.__frames];")
        sent = driver.execute_script(
            "return [...document.querySelectorAll('p')].map(p => p.textContent).find(t => t.includes('clouds/s'));"
        )
        cpu = view.cpu_percent()
        print(
            f"30k-point cloud published at 20 Hz: {updates / seconds:.1f} updates/s in the page, which drew "
            f"{frames / seconds:.1f} frames/s; view CPU {cpu:.0f}%"
        )
        print(f"the view says: {sent}")
    finally:
        if driver is not None:
            driver.quit()
        proc.terminate()
        proc.wait(timeout=10)
        suite.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
