"""Regenerate the README's images in docs/images/ with the commands the README shows
under them (`python -m benchmarks.docgen.make_images [NAME ...]`, from the repository root).

Each entry is the README caption's command without `-o`; the image is written to
docs/images/NAME. tests/contracts/test_readme_images.py checks the captions quote these commands
and that docs/images/robot.png is what its command renders today.
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
IMAGES = ROOT / "docs" / "images"

# image name → the clshade command (arguments relative to the repository root)
COMMANDS: dict[str, list[str]] = {
    "robot.png": ["render", "scenes/robot.toml"],
    "robot_sheet.png": ["compare", "scenes/robot.toml", "-m", "all"],
    "sweep.png": ["sweep"],
}


def main(names: list[str]) -> int:
    import os
    from clshade.cli import main as clshade
    os.chdir(ROOT)
    for name in names or list(COMMANDS):
        status = clshade([*COMMANDS[name], "-o", str(IMAGES / name)])
        if status:
            return status
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
