"""Screenshot of the demo's Meshcat recording (``recording.html``) in headless Chromium.

Runs one demo trial with Meshcat (as fast as possible), writes its recording, opens it in headless
Chromium (Debian's ``chromium`` and ``chromium-driver``; the ``selenium`` package of the test
extra), moves the recording to a moment of the trial, saves a PNG and prints what it measured:

- ``table_fraction``: the share of the picture covered by the table's projected bounding box
  (table top and legs, clipped to the picture); the view is meant to be filled by the workspace,
  so the script fails (exit 1) below 0.5;
- the colour of every goal's probability sphere next to its object's colour;
- the legend's text.

    python diagrams/recording_screenshot.py    # from the repository root: writes docs/recording.png
    python diagrams/recording_screenshot.py --task pouring --out out/pouring.png --at 0.3

No network: Chromium is started with its background services off and an empty profile.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

CHROMIUM_FLAGS = (
    "--headless=new",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
)

MEASURE = """
const THREE = MeshCat.THREE;
const at = arguments[0];
viewer.animator.pause();
viewer.animator.seek(at * viewer.animator.duration);
viewer.camera.updateMatrixWorld(true);
viewer.scene.updateMatrixWorld(true);
const table = viewer.scene_tree.find(["drake", "station", "table"]).object;
const box = new THREE.Box3().setFromObject(table);
let x0 = 1, x1 = -1, y0 = 1, y1 = -1;
for (const x of [box.min.x, box.max.x]) for (const y of [box.min.y, box.max.y])
  for (const z of [box.min.z, box.max.z]) {
    const p = new THREE.Vector3(x, y, z).project(viewer.camera);
    x0 = Math.min(x0, p.x); x1 = Math.max(x1, p.x); y0 = Math.min(y0, p.y); y1 = Math.max(y1, p.y);
  }
const clip = v => Math.max(-1, Math.min(1, v));
const fraction = (clip(x1) - clip(x0)) * (clip(y1) - clip(y0)) / 4;
const spheres = {};
for (let i = 0; ; i++) {
  const goal = viewer.scene_tree.find(["shared_control", "goals", "g" + i, "s"]);
  if (!goal || Object.keys(goal.children).length === 0) break;
  spheres["g" + i] = {};
  for (const c of Object.keys(goal.children)) {
    const node = goal.children[c].children["level4"];
    let color = null;
    node.object.traverse(o => { if (o.material) color = [o.material.color.r, o.material.color.g,
                                                         o.material.color.b]; });
    spheres["g" + i][c] = color;
  }
}
const legend = document.getElementById("drake-disamb-legend");
return JSON.stringify({table_fraction: fraction, spheres: spheres,
                       legend: legend ? legend.innerText : null,
                       duration: viewer.animator.duration});
"""
"""Seeks the animation to ``arguments[0]`` of its length and measures the view."""


def chromium_paths() -> tuple[str | None, str | None]:
    """``(chromium, chromedriver)`` executables, or ``None`` where missing."""
    return shutil.which("chromium") or shutil.which("chromium-browser"), shutil.which("chromedriver")


def record_demo(out_dir: Path, task: str = "reaching") -> Path:
    """Run one trial of ``task`` with Meshcat (as fast as possible); return its ``recording.html``."""
    from pydrake.geometry import Meshcat, MeshcatParams

    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.plotting import write_trial_figures
    from drake_disamb.trial import run_trial

    meshcat = Meshcat(MeshcatParams(host="localhost"))
    handles = build_shared_control_diagram(load_scenario(task), meshcat=meshcat)
    result = run_trial(handles, progress=False)
    write_trial_figures(result, handles, out_dir)
    return out_dir / "recording.html"


def linear_to_srgb(c: float) -> float:
    """three.js keeps colours in linear light: the sRGB value in [0, 1] of its linear value ``c``."""
    return 12.92 * c if c <= 0.0031308 else 1.055 * c ** (1 / 2.4) - 0.055


def screenshot(
    html: Path, png: Path, at: float = 0.6, size: tuple[int, int] = (1280, 720), settle: float = 2.0
) -> dict[str, Any]:
    """Open ``html`` in headless Chromium at ``size`` pixels, show the recording at ``at`` (a
    fraction of its length), save ``png`` and return the measurements (see the module docstring).

    Raises:
        RuntimeError: Chromium, ChromeDriver or selenium is missing.
    """
    chromium, driver_path = chromium_paths()
    if chromium is None or driver_path is None:
        raise RuntimeError("needs the chromium and chromedriver executables (Debian: chromium-driver)")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.options import Options
        from selenium.webdriver.chrome.service import Service
    except ImportError as exc:  # pragma: no cover - selenium is in the test extra
        raise RuntimeError("needs the selenium package (pip install -e '.[test]')") from exc

    with tempfile.TemporaryDirectory(prefix="chromium-profile-") as profile:
        options = Options()
        for flag in (*CHROMIUM_FLAGS, f"--user-data-dir={profile}"):
            options.add_argument(flag)
        options.binary_location = chromium
        driver = webdriver.Chrome(service=Service(driver_path), options=options)
        try:
            driver.execute_cdp_cmd(
                "Emulation.setDeviceMetricsOverride",
                {"width": size[0], "height": size[1], "deviceScaleFactor": 1, "mobile": False},
            )
            driver.get(Path(html).resolve().as_uri())
            deadline = time.monotonic() + 60.0
            while time.monotonic() < deadline:
                ready = driver.execute_script(
                    "return typeof viewer !== 'undefined' && viewer.animator.duration > 0 && "
                    "!!viewer.scene_tree.find(['drake', 'station', 'table']);"
                )
                if ready:
                    break
                time.sleep(0.2)
            else:
                raise RuntimeError(f"{html}: the recording never loaded in Chromium")
            measured = json.loads(driver.execute_script(MEASURE, float(at)))
            time.sleep(settle)  # let the renderer draw the seeked frame
            png.parent.mkdir(parents=True, exist_ok=True)
            driver.save_screenshot(str(png))
        finally:
            driver.quit()
    return measured


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="reaching", help="task name or scenario YAML (default: reaching)")
    parser.add_argument("--out", type=Path, default=Path("docs/recording.png"), help="PNG to write")
    parser.add_argument("--at", type=float, default=0.6, help="moment shown, as a fraction of the trial")
    args = parser.parse_args(argv)
    from drake_disamb.config import load_scenario
    from drake_disamb.display import goal_colors

    with tempfile.TemporaryDirectory(prefix="recording-") as tmp:
        html = record_demo(Path(tmp), args.task)
        measured = screenshot(html, args.out, at=args.at)
    print(f"wrote {args.out}")
    print(f"table covers {measured['table_fraction']:.0%} of the picture (its projected bounding box)")
    colors = goal_colors(load_scenario(args.task))
    for i, sets in sorted(measured["spheres"].items()):
        for c, rgb in sorted(sets.items()):
            k, goal = int(c[1:]), int(i[1:])
            shown = [round(linear_to_srgb(x), 3) for x in rgb]
            print(f"  sphere {i} (stage {k}): {shown}  object: {[round(x, 3) for x in colors[k][goal][:3]]}")
    print("legend:\n  " + "\n  ".join((measured["legend"] or "(none)").splitlines()))
    return 0 if measured["table_fraction"] >= 0.5 else 1


if __name__ == "__main__":
    sys.exit(main())
