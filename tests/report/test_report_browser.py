"""The report as a person sees it: opened in a real headless browser (Debian's chromium).

The browser loads report.html from disk; a script added to a copy of the page records, after
the load event, whether every image decoded (``naturalWidth > 0``) and what each step section
holds. Chromium is installed with apt-get when it is missing and we are root (CI); elsewhere
the test is skipped with the reason.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from asmplan.pipeline import RunSettings, run_product, write_outputs
from tests.conftest import example_path

pytestmark = pytest.mark.slow

_CHECK_SCRIPT = """
<script>
window.addEventListener('load', () => {
  const imgs = [...document.images].map(i => ({src: i.getAttribute('src'),
      ok: i.complete && i.naturalWidth > 0, width: i.naturalWidth}));
  const steps = [...document.querySelectorAll('div.step')].map(d => ({
      id: d.id,
      path: !!d.querySelector('figure[data-kind=path] img'),
      section: !!d.querySelector('figure[data-kind=section] img'),
      animation: !!d.querySelector('figure[data-kind=animation] img'),
      margins: d.querySelectorAll('table.margins tr').length - 1,
      sheet: d.querySelectorAll('table.sheet tr').length - 1,
      cycle: ((d.querySelector('h3').textContent.match(/cycle ([0-9.]+) s/)) || [null, null])[1]}));
  const pre = document.createElement('pre');
  pre.id = 'asmplan-check';
  pre.textContent = JSON.stringify({imgs, steps});
  document.body.appendChild(pre);
});
</script>
"""


def _find_chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


@pytest.fixture(scope="module")
def chromium() -> str:
    """Path of a headless-capable Chromium; installed from Debian when missing (as root)."""
    found = _find_chromium()
    if found:
        return found
    if os.geteuid() != 0 or shutil.which("apt-get") is None:
        pytest.skip("chromium is not installed and cannot be installed here (needs root and "
                    "apt-get: apt-get install chromium)")
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    for cmd in (["apt-get", "update", "-qq"], ["apt-get", "install", "-y", "-qq", "chromium"]):
        done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=900)
        if done.returncode != 0 and cmd[1] == "install":
            pytest.skip(f"apt-get install chromium failed: {done.stderr.strip()[-300:]}")
    found = _find_chromium()
    if not found:
        pytest.skip("apt-get install chromium succeeded but no chromium binary was found")
    return found


def _headless(chromium: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu",
                           "--hide-scrollbars", "--allow-file-access-from-files", *args],
                          capture_output=True, text=True, timeout=180)


@pytest.fixture(scope="module")
def report_folder(tmp_path_factory) -> Path:
    result = run_product(example_path("pinhole_station"), RunSettings(fidelity="fast"))
    return write_outputs(result, tmp_path_factory.mktemp("browser") / "out")


def test_every_image_and_animation_loads_and_every_step_shows_path_margins_and_cycle(
        chromium, report_folder) -> None:
    html = (report_folder / "report.html").read_text()
    check = report_folder / "check.html"
    check.write_text(html.replace("</body>", _CHECK_SCRIPT + "</body>"))
    done = _headless(chromium, "--virtual-time-budget=20000", "--dump-dom", check.as_uri())
    assert done.returncode == 0, done.stderr[-2000:]
    found = re.search(r'<pre id="asmplan-check">(.*?)</pre>', done.stdout, re.S)
    assert found, f"the check script did not run; chromium said: {done.stderr[-1000:]}"
    data = json.loads(found.group(1).replace("&amp;", "&").replace("&lt;", "<")
                      .replace("&gt;", ">").replace("&quot;", '"'))
    images = data["imgs"]
    assert len(images) >= 2 + 3 * 5, images  # product views, then per robot step 5 images
    broken = [i["src"] for i in images if not i["ok"]]
    assert not broken, f"images that did not load in chromium: {broken}"
    animations = [i["src"] for i in images if i["src"].endswith("-animation.png")]
    assert len(animations) == 3
    for name in animations:  # an animated PNG: an acTL chunk announcing more than one frame
        data_bytes = (report_folder / name).read_bytes()
        at = data_bytes.find(b"acTL")
        assert at > 0, name
        assert int.from_bytes(data_bytes[at + 4:at + 8], "big") > 1, name
    steps = data["steps"]
    assert [s["id"] for s in steps] == ["step2", "step3", "step4"]  # step 1 is the fixture
    for s in steps:
        assert s["path"] and s["section"] and s["animation"], s
        assert s["margins"] >= 8, s  # every criterion plus the clamp force rows
        assert s["sheet"] >= 6, s
        assert s["cycle"] is not None and float(s["cycle"]) > 0, s


def test_report_screenshot_renders(chromium, report_folder, tmp_path) -> None:
    shot = tmp_path / "report.png"
    done = _headless(chromium, "--virtual-time-budget=20000", "--window-size=1200,1600",
                     f"--screenshot={shot}", (report_folder / "report.html").as_uri())
    assert done.returncode == 0, done.stderr[-2000:]
    import numpy as np
    from PIL import Image

    pixels = np.asarray(Image.open(shot).convert("RGB"))
    assert pixels.shape[:2] == (1600, 1200)
    # the page is drawn: text and pictures, not a blank or an error page
    assert (pixels < 200).any(axis=2).mean() > 0.02
