"""Pictures of every library hitch and loop, set on its post: ``knotsim pull KNOT`` (``knot-security``,
its defaults, μ = 0.6, a 10 mN hold for 3 s) into a temporary folder, keeping the key frames framed on
the knot (``render/*.png``) and ``summary.json`` in ``docs/studies/hitch_pictures/<knot>/``.

Run: ``python validation/hitch_pictures.py [KNOT ...]`` (default: every hitch and loop; about a minute
each on one core).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "studies" / "hitch_pictures"
SETTINGS = ["mu=0.6", "load=hold", "hold_load=0.01", "load_time=3"]


def main(argv: list[str]) -> int:
    import knotsim as ks

    knots = argv or [n for n, _ in ks.list_knots() if ks.load_knot_spec(n).kind in ("hitch", "loop")]
    for knot in knots:
        dest = OUT / knot
        if (dest / "summary.json").is_file():
            continue
        with tempfile.TemporaryDirectory() as tmp:
            cmd = [sys.executable, "-m", "knotsim.cli", "pull", knot, "-o", tmp, "--overwrite"]
            for s in SETTINGS:
                cmd += ["--set", s]
            subprocess.run(cmd, check=True)
            dest.mkdir(parents=True, exist_ok=True)
            for png in Path(tmp, "render").glob("*.png"):
                shutil.copy(png, dest / png.name)
            shutil.copy(Path(tmp, "summary.json"), dest / "summary.json")
        sys.stdout.write(f"{knot}: {dest}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
