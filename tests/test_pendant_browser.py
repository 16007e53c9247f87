"""The pendant in a real browser: headless Chromium (the system's, driven by Playwright) loads the
page, the status panel shows what the register reads answer, the buttons act through the protocol,
and the drawn arm's pixels follow the pose.

The fixture installs what it needs: Debian's ``chromium`` (apt-get) when ``/usr/bin/chromium`` is
missing, and Playwright's Python package (the driver only; no browser download) when it is not
importable. The tests skip only when Chromium cannot be installed.
"""

from __future__ import annotations

import io
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from helpers import wait_for

from xarm_emu.client.sync import Client

pytest.importorskip("viser")

CHROMIUM = "/usr/bin/chromium"
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]
VIEWPORT = {"width": 1280, "height": 800}
SCENE_WIDTH = 860  # px: the scene left of the GUI panel


def _install_chromium() -> str | None:
    """Install Debian's chromium if it is missing; returns why it could not be, or None."""
    if os.path.exists(CHROMIUM):
        return None
    if shutil.which("apt-get") is None or os.geteuid() != 0:
        return "Chromium is missing and cannot be installed here (needs apt-get as root)"
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    for cmd in (["apt-get", "update", "-qq"], ["apt-get", "install", "-y", "-qq", "chromium"]):
        r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
        if r.returncode != 0:
            return f"Chromium could not be installed: {' '.join(cmd)}: {r.stderr.strip()[-300:]}"
    return None if os.path.exists(CHROMIUM) else "Chromium could not be installed (no /usr/bin/chromium)"


def _playwright() -> Any:
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        subprocess.run([sys.executable, "-m", "pip", "install", "-q", "playwright"], check=True, timeout=600)
        from playwright.sync_api import sync_playwright
    return sync_playwright


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    why = _install_chromium()
    if why is not None:
        pytest.skip(why)
    sync_playwright = _playwright()
    profile = tempfile.mkdtemp(prefix="pendant-chromium-")
    with sync_playwright() as p:
        ctx = p.chromium.launch_persistent_context(profile, executable_path=CHROMIUM, headless=True,
                                                   args=FLAGS, viewport=VIEWPORT)
        try:
            yield ctx
        finally:
            ctx.close()
    shutil.rmtree(profile, ignore_errors=True)


@pytest.fixture
def pendant(make_server, browser):  # type: ignore[no-untyped-def]
    """A server with the view and the admin channel, its pendant page loaded, and a client."""
    st = make_server(view=True, view_port=0, admin=True, admin_port=0)
    page = browser.new_page()
    page.goto(f"http://127.0.0.1:{st.ports['view']}/")
    page.get_by_text("Last action").wait_for(timeout=30000)
    with Client("127.0.0.1", st.ports["command"]) as client:
        yield st, page, client
    page.close()


def status(page: Any) -> str:
    return str(page.locator("body").inner_text())


def shows(page: Any, text: str, timeout: float = 5.0) -> bool:
    return wait_for(lambda: text in status(page), timeout)


def arm_pixels(page: Any) -> np.ndarray:
    """The scene part of a screenshot as an RGB array."""
    from PIL import Image

    png = page.screenshot(clip={"x": 0, "y": 150, "width": SCENE_WIDTH, "height": 650})
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def changed(a: np.ndarray, b: np.ndarray) -> int:
    """Pixels that differ visibly between two screenshots."""
    return int((np.abs(a - b).max(axis=2) > 40).sum())


def settled_pixels(page: Any, timeout: float = 15.0) -> np.ndarray:
    """The scene once two screenshots half a second apart agree (a loaded machine renders the
    software-GL scene late); fails if it never settles while nothing moves."""
    end = time.monotonic() + timeout
    last = arm_pixels(page)
    while True:
        time.sleep(0.5)
        now = arm_pixels(page)
        if changed(last, now) < 200:
            return now
        assert time.monotonic() < end, "the drawn scene never settles while the arm is still"
        last = now


def settled(st: Any, joint0: float) -> bool:
    return wait_for(lambda: st.call(lambda: abs(st.emulator.controller.q[0] - joint0) < 1e-4
                                    and st.emulator.controller.state != 1), 10.0)


def test_status_shows_the_register_reads_and_the_injected_c35(pendant) -> None:  # type: ignore[no-untyped-def]
    st, page, client = pendant
    assert client.get_state() == 4  # powered, not enabled (register 13)
    assert shows(page, "State: 4 stopped")
    page.get_by_role("button", name="Inject error").click()  # the admin action, default C35
    assert wait_for(lambda: client.get_err_warn()[0] == 35)
    assert shows(page, "Error: C35")
    assert "Error: no error" not in status(page)
    page.get_by_role("button", name="Clear error").click()  # register 16
    assert wait_for(lambda: client.get_err_warn()[0] == 0)
    assert shows(page, "Error: no error")


def test_enable_and_jog_act_through_the_protocol(pendant) -> None:  # type: ignore[no-untyped-def]
    st, page, client = pendant
    page.get_by_role("button", name="Enable").click()  # register 11, then 12 state 0
    assert wait_for(lambda: client.get_state() == 2)
    assert shows(page, "State: 2 sleeping")
    page.get_by_role("button", name="J1 +", exact=True).click()  # register 23: J1 by the step, 5 deg
    assert settled(st, math.radians(5.0))
    assert client.get_joints()[0] == pytest.approx(math.radians(5.0), abs=1e-4)
    assert shows(page, "Joints: 5.00, 0.00")


def test_the_drawn_arm_follows_the_pose(pendant) -> None:  # type: ignore[no-untyped-def]
    st, page, client = pendant
    client.motion_enable(True)
    client.set_mode(0)
    client.set_state(0)
    assert client.get_state() == 2 and client.get_err_warn() == (0, 0)
    home = settled_pixels(page)  # nothing moves: the picture stays
    client.call(23, joints=(1.2, -0.5, -0.4, 0.0, 0.0, 0.0, 0.0), speed=1.5, acc=10.0, mvtime=0.0)
    assert settled(st, 1.2)
    moved = settled_pixels(page)
    assert changed(home, moved) > 2000  # the arm is drawn elsewhere
    client.call(23, joints=(0.0,) * 7, speed=1.5, acc=10.0, mvtime=0.0)
    assert settled(st, 0.0)
    assert changed(home, settled_pixels(page)) < 200  # back at the pose: back in the picture


def test_admin_actions_appear_only_with_admin(make_server, browser) -> None:  # type: ignore[no-untyped-def]
    st = make_server(view=True, view_port=0)
    page = browser.new_page()
    try:
        page.goto(f"http://127.0.0.1:{st.ports['view']}/")
        page.get_by_text("Last action").wait_for(timeout=30000)
        assert page.get_by_role("button", name="Enable").count() == 1
        assert page.get_by_role("button", name="Inject error").count() == 0
        assert "Admin (--admin)" not in status(page)
    finally:
        page.close()
