"""A headless Chromium (Debian's chromium and chromium-driver) driven by Selenium, for the view's tests.

Also a script: ``.venv/bin/python test/view/browser.py URL OUT.png [WAIT_S]`` saves a screenshot of a page
(docs/view.png is made this way from a running ``launch --view``).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")


def chromium(width: int = 1280, height: int = 800):
    """A headless Chromium WebDriver (WebGL through SwiftShader, as on a machine without a GPU)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = str(CHROMIUM)
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", f"--window-size={width},{height}"):
        options.add_argument(arg)
    options.add_argument("--enable-unsafe-swiftshader")
    return webdriver.Chrome(service=Service(str(CHROMEDRIVER)), options=options)


def scene_nodes(driver) -> dict:
    """{scene node name: {visible, points (for point clouds), position (posed nodes)}} as the page holds them."""
    return driver.execute_script(
        """
        const tree = window.__viserSceneTree, mutable = window.__viserMutable;
        if (!tree || !mutable) return null;
        const out = {};
        for (const [name, node] of Object.entries(tree.getState())) {
            const msg = node.message || {}, props = msg.props || {};
            const pose = mutable.nodePoseData[name];
            out[name] = {
                type: msg.type || null,
                visible: node.effectiveVisibility !== false,
                points: props.points ? props.points.byteLength / (props.precision === "float16" ? 6 : 12) : null,
                position: pose ? pose.position : null,
            };
        }
        return out;
        """
    )


def dismiss_notifications(driver) -> None:
    """Close viser's toasts (e.g. "Software WebGL rendering detected") so they do not cover a screenshot."""
    driver.execute_script(
        "document.querySelectorAll('.mantine-Notification-closeButton, .mantine-Notifications-root button')"
        ".forEach(b => b.click());"
    )


def main(argv: list[str]) -> int:
    url, out = argv[0], Path(argv[1])
    wait_s = float(argv[2]) if len(argv) > 2 else 8.0
    driver = chromium()
    try:
        driver.get(url)
        time.sleep(wait_s)
        dismiss_notifications(driver)
        time.sleep(0.5)
        driver.save_screenshot(str(out))
    finally:
        driver.quit()
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
