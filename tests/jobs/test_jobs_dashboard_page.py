"""The farm's page on a real scheduler's dashboard, seen by a real browser (issue 48).

`dask scheduler --preload jobs.dashboard` and two `dask worker` processes, as
docker-compose.yml runs them; a sweep on them; while it runs, Debian's chromium loads
``/farm`` headless: the page names the study, the running load case and how far its ccx
has got. The screenshot goes to ``$FARM_SCREENSHOT_DIR`` when set (docs/figures/ holds
one made this way).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import pytest

from jobs.progress import Progress
from jobs.study import load_study
from jobs.sweep import run_sweep

pytestmark = [pytest.mark.ccx, pytest.mark.e2e]
DASK = str(Path(sys.executable).with_name("dask"))
ROOT = Path(__file__).resolve().parents[2]


def _chromium() -> str:
    found = shutil.which("chromium") or shutil.which("chromium-browser")
    if found is None:
        if os.environ.get("FARM_REQUIRE_CHROMIUM"):
            pytest.fail("chromium is required here (FARM_REQUIRE_CHROMIUM): apt-get install "
                        "chromium, or run bash scripts/test.sh --e2e, which does")
        pytest.skip("no chromium (Debian: apt-get install chromium)")
    return found


def _spawn(folder: Path, name: str, argv: list[str]) -> subprocess.Popen:
    log = open(folder / f"{name}.log", "ab")  # noqa: SIM115 (closed with the process)
    return subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, env=os.environ.copy())


@pytest.fixture
def scheduler_with_page(tmp_path):
    file = tmp_path / "scheduler.json"
    procs = [_spawn(tmp_path, "scheduler", [
        DASK, "scheduler", "--host", "127.0.0.1", "--port", "0", "--dashboard-address",
        "127.0.0.1:0", "--scheduler-file", str(file), "--preload", "jobs.dashboard"])]
    deadline = time.monotonic() + 60
    while not file.exists() and time.monotonic() < deadline:
        time.sleep(0.2)
    info = json.loads(file.read_text())
    for name in ("w1", "w2"):
        procs.append(_spawn(tmp_path, name, [
            DASK, "worker", info["address"], "--nthreads", "1", "--no-nanny",
            "--no-dashboard", "--name", name]))
    yield info["address"], f"http://127.0.0.1:{info['services']['dashboard']}"
    for proc in procs:
        proc.terminate()
    for proc in procs:
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()


def _json(url: str) -> dict:
    return json.loads(urllib.request.urlopen(url, timeout=5).read())


def test_the_farm_page_shows_a_running_sweep_in_a_real_browser(scheduler_with_page, tmp_path):
    chromium = _chromium()
    address, dashboard = scheduler_with_page
    text = (ROOT / "examples/combined_tree_quick.toml").read_text()
    study_file = tmp_path / "study.toml"
    study_file.write_text(text.replace('store = "results/combined_tree_quick.zarr"',
                                       f'store = "{tmp_path / "store.zarr"}"'))
    from jobs.cluster import DaskCluster

    reports: list = []
    feed: list[str] = []  # what the sweep's own progress lines append (farm sweep submit)

    class Seen(Progress):
        def started(self, session, state):
            self.session = session

        def advanced(self, state):
            feed.append(self.session.ccx())

    sweep = threading.Thread(target=lambda: reports.append(run_sweep(
        load_study(study_file), cluster=DaskCluster(address, 2), progress=Seen())))
    sweep.start()
    seen = None
    deadline = time.monotonic() + 300
    while sweep.is_alive() and time.monotonic() < deadline:
        state = _json(f"{dashboard}/farm.json")
        running = [r for r in state["running"] if r["fraction"] is not None]
        if running and state["studies"]:
            seen = (state, running[0])
            break
        time.sleep(0.2)
    assert seen is not None, "no running task with ccx progress seen during the sweep"
    state, task = seen
    assert state["studies"][0]["study"] == "combined-tree-quick"
    assert task["key"].split("-")[0] in ("trunk", "slide")
    assert "kPa" in task["key"] and "mm" in task["key"]  # the key names the load case

    shot = Path(os.environ.get("FARM_SCREENSHOT_DIR", tmp_path)) / "farm_page.png"
    browser = [chromium, "--headless", "--no-sandbox", "--disable-gpu",
               "--disable-dev-shm-usage", f"--user-data-dir={tmp_path / 'chromium'}"]
    dom = subprocess.run([*browser, "--dump-dom", f"{dashboard}/farm"], capture_output=True,
                         text=True, timeout=120)
    subprocess.run([*browser, f"--screenshot={shot}", "--window-size=1280,900",
                    f"{dashboard}/farm"], capture_output=True, timeout=120, check=True)
    sweep.join(timeout=600)
    assert reports and reports[0].ok, "the sweep itself failed"
    assert dom.returncode == 0, dom.stderr[-2000:]
    for words in ("Studies in flight", "combined-tree-quick", "Running", "<progress",
                  "Recent solves"):
        assert words in dom.stdout, words
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    after = _json(f"{dashboard}/farm.json")  # every solve reported, none failed
    assert after["recent"] and not after["failures"]
    assert all(r["status"] == "done" for r in after["recent"])
    assert any(f.startswith("ccx ") and "%" in f for f in feed), feed[-5:]
