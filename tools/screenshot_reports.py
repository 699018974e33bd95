"""Make each kind of report, screenshot it in a headless browser and check its figures.

Run from the repository root (the package importable, e.g. installed)::

    python tools/screenshot_reports.py --out report-check

It writes, under ``--out``:

* the reports: ``analyze-movers`` (Scene 1, two movers), ``analyze-no-movers`` (the
  one-target ``hyperbola`` scene), ``track-no-roads`` and ``track-roads`` (Scene 1's
  movers over 3 degrees, five 1-degree sub-apertures; the roads run through the movers'
  true paths), ``paper`` (``sarmotion paper --quick``: its index; the GOTCHA data from
  ``$SARMOTION_GOTCHA_DIR`` or ``shared/data/gotcha`` beside the repository);
* ``screenshots/NAME.png``: each ``report.html`` (``index.html`` for the paper) as a
  1400-px-wide browser window shows it, the whole page down to ``--height`` pixels;
* ``screenshots/checks.txt``: for every figure embedded in a page, its size in pixels,
  its resolution, the scale the page shows it at in a 1400-px window (the 1294-px
  column of the analyze and track reports, 1055 px for the paper's index) and the size
  its smallest text then has on the screen in CSS points (a legend of ``LEGEND_PT``
  points; for the paper's figures, their smallest text as the index records it in
  ``data-text-pt``); a line ``LOW`` marks a figure whose text would show below 8 pt.

The browser is Chromium or Chrome in headless mode (``--browser``, default the first of
``chromium``, ``chromium-browser``, ``google-chrome`` on the PATH; Debian's package is
``chromium``). Without one, the reports and ``checks.txt`` are still made and the
screenshots are skipped, with a line saying so. Look at the screenshots: the checks
cannot tell whether a figure says what it shows.

Runs for several minutes (the paper's figures take most of it); ``--skip-paper`` leaves
the paper out.
"""

from __future__ import annotations

import argparse
import base64
import html
import io
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from sarmotion.cli.main import run
from sarmotion.paper.figures.build import INDEX_COLUMN_PX
from sarmotion.report.plotting import LEGEND_PT, LEGIBLE_PT, displayed_pt

#: The analyze and track reports' column (CSS px): main's 1400 px less its padding
#: (2 x 32) and a section's padding and border (2 x 20 + 2).
COLUMN_PX = 1400 - 64 - 42

#: The paper index's column in a 1400-px window (CSS px).
PAPER_COLUMN_PX = INDEX_COLUMN_PX

#: Window of the screenshots (CSS px).
WIDTH_PX = 1400

BROWSERS = ("chromium", "chromium-browser", "google-chrome")


def _scene_over(out: Path, degrees: float) -> Path:
    """Scene 1 as a scene file with a ``degrees``-wide aperture (for tracking)."""
    from sarmotion.simulation import load_scene

    scene = load_scene("scene1")
    lines = [
        'schema = "sarmotion.scene/1"',
        'name = "scene1-wide"',
        f'description = """Scene 1 over {degrees:g} degrees (screenshot check)."""',
        "reference_point_m = [0.0, 0.0]",
        "",
        "[radar]",
        'pulse = "gaussian"',
        "",
        "[trajectory]",
        'kind = "circular"',
        f"aperture_deg = {degrees!r}",
    ]
    for t in scene.targets:
        x, y = (float(v) for v in t.position_m[:2])
        lines += ["", "[[targets]]", f"position_m = [{x!r}, {y!r}]"]
        if np.any(t.velocity_mps):
            ux, uy = (float(v) for v in t.velocity_mps)
            lines.append(f"velocity_mps = [{ux!r}, {uy!r}]")
    path = out / "scene1-wide.toml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _roads(out: Path) -> Path:
    """A straight road through each of Scene 1's movers' true paths (GeoJSON)."""
    from sarmotion.simulation import load_scene

    features = []
    for t in load_scene("scene1").targets:
        if not np.any(t.velocity_mps):
            continue
        p, v = np.asarray(t.position_m[:2], dtype=float), np.asarray(t.velocity_mps, dtype=float)
        line = [(p - 3.0 * v).tolist(), (p + 3.0 * v).tolist()]
        features.append(
            {
                "type": "Feature",
                "properties": {"name": t.label or "road"},
                "geometry": {"type": "LineString", "coordinates": line},
            }
        )
    path = out / "roads.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection", "features": features}))
    return path


def make_reports(out: Path, *, paper: bool) -> dict[str, Path]:
    """Run the commands; return each report's HTML page by name."""
    out.mkdir(parents=True, exist_ok=True)
    scene = _scene_over(out, 3.0)
    roads = _roads(out)
    track = ["track", str(scene), "--sub-aperture", "1", "--overlap", "0.5", "--size", "60"]
    commands = {
        "analyze-movers": ["analyze", "scene1"],
        "analyze-no-movers": ["analyze", "hyperbola"],
        "track-no-roads": track,
        "track-roads": [*track, "--roads", str(roads)],
    }
    if paper:
        commands["paper"] = ["paper", "--quick"]
        data = Path(__file__).resolve().parents[2] / "shared" / "data" / "gotcha"
        if data.is_dir() and "SARMOTION_GOTCHA_DIR" not in os.environ:
            commands["paper"] += ["--gotcha", str(data)]
    pages = {}
    for name, args in commands.items():
        target = out / name
        print(f"sarmotion {' '.join(args)} --out {target}", flush=True)
        if run(["-q", *args, "--out", str(target), "--force"]) != 0:
            raise SystemExit(f"{name}: the command failed")
        pages[name] = target / ("index.html" if name == "paper" else "report.html")
    return pages


def figure_checks(pages: dict[str, Path]) -> list[str]:
    """One line per embedded figure: size, dpi, displayed scale, legend size on screen."""
    from PIL import Image

    lines = []
    for name, page in pages.items():
        text = page.read_text(encoding="utf-8")
        found = []
        for tag in re.findall(r"<img [^>]*>", text):
            src = re.search(r'src="([^"]+)"', tag)
            alt = re.search(r'alt="([^"]*)"', tag)
            where = src[1] if src else ""
            if where.startswith("data:image/png;base64,"):
                png = Image.open(io.BytesIO(base64.b64decode(where.split(",", 1)[1])))
            elif where.endswith(".png"):
                png = Image.open(page.parent / where)
            else:  # no figure (the paper's zoom placeholder)
                continue
            text_pt = re.search(r'data-text-pt="([^"]+)"', tag)
            size = float(text_pt[1]) if text_pt else LEGEND_PT
            found.append((alt[1] if alt and alt[1] else where[:40], png, size))
        for alt, png, size in found:
            dpi = float(png.info.get("dpi", (72.0, 72.0))[0])
            column = PAPER_COLUMN_PX if name == "paper" else COLUMN_PX
            scale = min(1.0, column / png.width)
            legend_pt = displayed_pt(size, dpi=dpi, width_px=png.width, column_px=column)
            flag = "LOW " if legend_pt < LEGIBLE_PT - 0.05 else "ok  "
            lines.append(
                f"{flag}{name}: {html.unescape(alt)[:60]!r}: {png.width} x {png.height} px "
                f"at {dpi:.0f} dpi, shown x{scale:.2f}: {size:g}-pt text shows at "
                f"{legend_pt:.1f} pt"
            )
    return lines


def screenshot(browser: str, page: Path, png: Path, height: int) -> None:
    """The page in a headless browser window of WIDTH_PX x ``height`` CSS px."""
    subprocess.run(
        [
            browser,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            f"--window-size={WIDTH_PX},{height}",
            f"--screenshot={png}",
            page.resolve().as_uri(),
        ],
        check=True,
        capture_output=True,
        timeout=300,
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="Output directory.")
    parser.add_argument("--browser", default=None, help="Headless Chromium or Chrome.")
    parser.add_argument("--height", type=int, default=9000, help="Window height (CSS px).")
    parser.add_argument("--skip-paper", action="store_true", help="Leave the paper out.")
    args = parser.parse_args(argv)
    pages = make_reports(args.out, paper=not args.skip_paper)
    shots = args.out / "screenshots"
    shots.mkdir(exist_ok=True)
    lines = figure_checks(pages)
    browser = args.browser or next((b for b in BROWSERS if shutil.which(b)), None)
    if browser is None:
        lines.append(f"no headless browser ({', '.join(BROWSERS)}): no screenshots")
    else:
        for name, page in pages.items():
            screenshot(browser, page, shots / f"{name}.png", args.height)
            lines.append(f"screenshot {shots / (name + '.png')}")
    (shots / "checks.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))
    return 1 if any(line.startswith("LOW") for line in lines) else 0


if __name__ == "__main__":
    sys.exit(main())
