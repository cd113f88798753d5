"""A picture of the page as a browser draws it: headless Chromium (Debian's ``chromium``) with software WebGL
(SwiftShader) opens the page's URL and saves a PNG. Used by ``python -m pipeline ui ... --screenshot FILE``
(the README's figure) and by the page's test.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

from ..errors import OutputError

#: Chromium's flags: headless, software WebGL, the window's size [px], and how long the page may load and
#: draw [ms of virtual time] before the picture is taken.
WINDOW_PX = (1400, 900)
LOAD_MS = 10000
FLAGS = ("--headless=new", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
         f"--window-size={WINDOW_PX[0]},{WINDOW_PX[1]}", f"--virtual-time-budget={LOAD_MS}", "--hide-scrollbars")
TIMEOUT_S = 120


def chromium() -> str | None:
    """The Chromium executable on the PATH, or None."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


def take_screenshot(url: str, path) -> Path:
    """A PNG of the page at ``url`` saved to ``path``; OutputError when Chromium is missing or fails."""
    browser = chromium()
    if browser is None:
        raise OutputError("a screenshot needs Chromium (Debian: apt-get install chromium)")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    run = subprocess.run([browser, *FLAGS, f"--screenshot={path.resolve()}", url], capture_output=True, text=True,
                         timeout=TIMEOUT_S, check=False)
    if run.returncode != 0 or not path.is_file():
        raise OutputError(f"{path}: Chromium could not take the screenshot (exit {run.returncode}): "
                          f"{run.stderr.strip()[-500:]}")
    return path
