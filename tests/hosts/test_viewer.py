"""torsal.show in the OCP CAD viewer: the parts grouped by torsal family, connectors apart,
interfering parts in red; a clear message when the viewer is missing or not running.

The run folder is made here: five named box solids written with torsal's STEP writer, a parts
list and a report.json naming one part as interfering, so the groups are known exactly. The
real viewer test starts the standalone viewer (``python -m ocp_viewer``) on a loopback port,
opens it in headless chromium and counts the colours in a screenshot.
"""
import json
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import torsal
from torsal.fabrication.solids import write_step
from torsal.hosts import GROUP_COLORS, PartGroup, ViewerUnavailableError, fins_scene
from torsal.hosts.results import FinsFolderError

PARTS = [("F0-S000-P00", 0, "plate", (0, 0, 0)), ("F0-S000-P01", 0, "plate", (0, 0, 1200)),
         ("F1-S000-P00", 1, "plate", (1500, 0, 0)), ("F1-S001-P00", 1, "plate", (1500, 0, 1200)),
         ("C-N0001-0", 0, "butt-bracket", (800, 0, 600))]


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory):
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.gp import gp_Pnt

    out = tmp_path_factory.mktemp("fins-run")
    solids = []
    for name, family, kind, (x, y, z) in PARTS:
        size = (200, 200, 200) if kind != "plate" else (1000, 300, 1000)
        box = BRepPrimAPI_MakeBox(gp_Pnt(x, y, z), *size).Solid()
        solids.append((name, box, GROUP_COLORS[PartGroup.family_0]))
    write_step(solids, out / "fins.step")
    rows = ["part_id,family,strip,panels,area_m2,perimeter_m,cut_length_m,fold_count,mass_kg,sheet,kind"]
    rows += [f"{n},{f},0,1,1,4,4,0,1,1,{k}" for n, f, k, _ in PARTS]
    (out / "parts.csv").write_text("\n".join(rows) + "\n")
    (out / "report.json").write_text(json.dumps({"fabrication": {"assembly": {
        "interfering_parts": ["F1-S001-P00"], "blocked_parts": []}}}))
    return out


def test_the_scene_groups_parts_by_family_connectors_and_interference(run_folder):
    scene = fins_scene(run_folder)
    assert scene.groups == {PartGroup.family_0: ["F0-S000-P00", "F0-S000-P01"],
                            PartGroup.family_1: ["F1-S000-P00"],
                            PartGroup.connector: ["C-N0001-0"],
                            PartGroup.interfering: ["F1-S001-P00"]}
    assert scene.counts == {"family 0": 2, "family 1": 1, "connector": 1, "interfering": 1}
    assert set(scene.solids) == {p[0] for p in PARTS}
    assert GROUP_COLORS[PartGroup.interfering][0] > 0.8 > GROUP_COLORS[PartGroup.interfering][1]


def test_a_folder_without_fins_is_named(tmp_path):
    with pytest.raises(FinsFolderError, match="no fins.step here"):
        torsal.show(tmp_path)


def test_without_the_viewer_installed_show_says_how_to_get_it(run_folder, monkeypatch):
    monkeypatch.setitem(sys.modules, "ocp_vscode", None)     # import fails as if not installed
    with pytest.raises(ViewerUnavailableError, match=r"pip install 'torsal\[viewer\]'"):
        torsal.show(run_folder)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_without_a_running_viewer_show_says_how_to_start_one(run_folder):
    pytest.importorskip("ocp_vscode")
    port = _free_port()
    with pytest.raises(ViewerUnavailableError, match=f"python -m ocp_viewer --port {port}"):
        torsal.show(run_folder, port=port)


def _colour_share(png: bytes, rgb) -> float:
    """Share of the screenshot's pixels within a shading range of colour ``rgb`` (0..1): the
    same hue, lit darker or lighter."""
    import matplotlib.image as mpimg
    import io

    img = mpimg.imread(io.BytesIO(png), format="png")[..., :3].reshape(-1, 3)
    target = np.asarray(rgb) / np.linalg.norm(rgb)
    norm = np.linalg.norm(img, axis=1)
    lit = norm > 0.15
    cos = (img[lit] @ target) / norm[lit]
    return float((cos > 0.995).sum()) / len(img)


def test_show_puts_the_groups_in_the_standalone_viewer(run_folder, tmp_path):
    pytest.importorskip("ocp_viewer")
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from test_report_browser import Browser

    port = _free_port()
    viewer = subprocess.Popen([sys.executable, "-m", "ocp_viewer", "--host", "127.0.0.1",
                               "--port", str(port)], cwd=tmp_path, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, env={"HOME": str(tmp_path),
                                                               "PATH": "/usr/bin:/bin"})
    profile = tmp_path / "profile"
    profile.mkdir()
    browser = None
    try:
        t0 = time.monotonic()
        while not _listening(port):
            assert viewer.poll() is None and time.monotonic() - t0 < 60, "the viewer did not start"
            time.sleep(0.2)
        browser = Browser(profile, timeout=60)
        browser.open(f"http://127.0.0.1:{port}/viewer")
        browser.settle(3)
        scene = torsal.show(run_folder, port=port)
        assert scene.counts["interfering"] == 1
        shot = None
        for _ in range(40):                 # until the parts are drawn
            browser.settle(0.5)
            import base64
            shot = base64.b64decode(browser.call("Page.captureScreenshot", format="png")["data"])
            if _colour_share(shot, GROUP_COLORS[PartGroup.interfering]) > 1e-3:
                break
        (tmp_path / "viewer.png").write_bytes(shot)
        for group in (PartGroup.family_0, PartGroup.family_1, PartGroup.interfering):
            assert _colour_share(shot, GROUP_COLORS[group]) > 1e-3, group
        assert not browser.errors
    finally:
        if browser is not None:
            browser.close()
        viewer.terminate()
        viewer.wait(10)


def _listening(port: int) -> bool:
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=0.5):
            return True
    except OSError:
        return False
