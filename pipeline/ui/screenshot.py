"""A picture of the page as a browser draws it: headless Chromium (Debian's ``chromium``) with software WebGL
(SwiftShader) opens the page's URL and saves a PNG. Used by ``python -m pipeline ui ... --screenshot FILE``
(the README's figure) and by the page's test.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import zlib
from pathlib import Path

from ..errors import OutputError
from ..files.atomic import WRITTEN_BY, prepare_file_target, write_bytes_atomic

#: Chromium's flags: headless, software WebGL, the window's size [px], and how long the page may load and
#: draw [ms of virtual time] before the picture is taken.
WINDOW_PX = (1400, 900)
LOAD_MS = 10000
FLAGS = ("--headless=new", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
         f"--window-size={WINDOW_PX[0]},{WINDOW_PX[1]}", f"--virtual-time-budget={LOAD_MS}", "--hide-scrollbars")
TIMEOUT_S = 120
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def chromium() -> str | None:
    """The Chromium executable on the PATH, or None."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


def take_screenshot(url: str, path, replace: bool = False) -> Path:
    """A PNG of the page at ``url`` saved to ``path`` (atomically, marked as ours: ``signed_png``; a file the
    package did not write is replaced only with ``replace``); OutputError when Chromium is missing or fails."""
    browser = chromium()
    if browser is None:
        raise OutputError("a screenshot needs Chromium (Debian: apt-get install chromium)")
    prepare_file_target(path, replace)
    with tempfile.TemporaryDirectory() as folder:
        shot = Path(folder) / "page.png"
        run = subprocess.run([browser, *FLAGS, f"--screenshot={shot}", url], capture_output=True, text=True,
                             timeout=TIMEOUT_S, check=False)
        if run.returncode != 0 or not shot.is_file():
            raise OutputError(f"{path}: Chromium could not take the screenshot (exit {run.returncode}): "
                              f"{run.stderr.strip()[-500:]}")
        data = shot.read_bytes()
    return write_bytes_atomic(path, signed_png(data), replace)


def signed_png(data: bytes) -> bytes:
    """The PNG ``data`` with a ``tEXt`` chunk ``Software: WRITTEN_BY`` right after its header chunk (IHDR), so
    the file names its writer within its first bytes."""
    if data[:8] != PNG_SIGNATURE:
        raise OutputError("Chromium's screenshot is not a PNG")
    end_of_header = 8 + 12 + int.from_bytes(data[8:12], "big")          # length, type, data, CRC
    body = b"tEXt" + b"Software\0" + WRITTEN_BY.encode()
    chunk = len(body[4:]).to_bytes(4, "big") + body + zlib.crc32(body).to_bytes(4, "big")
    return data[:end_of_header] + chunk + data[end_of_header:]
