"""The clove hitch's sliding strength against its tying pre-tension (the question of Sabater, Park,
Crassous, Neukirch and Reis, JMPS 2026: superlinear in elastomer rods, wires and braids).

Run: ``python validation/hitch_pretension.py [--mu 0.3] [--out DIR]`` (default ``--out
docs/studies/hitch_pretension``), then ``--table`` writes ``pretension.md``. For each set tension
(5, 10, 20, 40 mN) one ``knot-security`` ramp run on the library's ``clove_hitch`` (its defaults: set
until still, relaxed to 1 mN, then the standing part loaded at 2 mN/s, the tail free) at a friction
below the hitch's critical friction (0.38 at 10 mN, docs/results/hitches.md), so that it slides: the
slip load (run-away) and the slow-slip load are its sliding strength. The exponent is the slope of
log(slip load) against log(set tension), least squares. Each case is written as soon as it is done
(``set_<mN>mN.json``: the run's summary).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parents[1]
SET_TENSIONS = (0.005, 0.01, 0.02, 0.04)  # N


def run(mu: float, out: Path) -> None:
    import knotsim as ks

    out.mkdir(parents=True, exist_ok=True)
    for t in SET_TENSIONS:
        path = out / f"set_{t * 1e3:g}mN.json"
        if path.is_file():
            continue
        res = ks.run_protocol("knot-security", "clove_hitch", overrides={"mu": mu, "set_tension": t})
        path.write_text(json.dumps(res.to_dict(), indent=1, default=str))
        sys.stdout.write(f"set {t * 1e3:g} mN: {res['outcome']}, slip load {res['metrics'].get('slip_load')}\n")
        sys.stdout.flush()


def _fit(xs: list[float], ys: list[float]) -> float:
    """Least-squares slope of log y against log x."""
    lx, ly = [math.log(x) for x in xs], [math.log(y) for y in ys]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly, strict=True)) / sum((a - mx) ** 2 for a in lx)


def table(out: Path) -> str:
    rows = []
    for t in SET_TENSIONS:
        path = out / f"set_{t * 1e3:g}mN.json"
        if path.is_file():
            s = json.loads(path.read_text())
            m = s["metrics"]
            rows.append((t, m.get("slip_load"), m.get("slow_slip_load"), s["outcome"], m.get("set_still"),
                         s["parameters"].get("mu")))
    lines = ["# Clove hitch: sliding strength against the set tension", "",
             "knot-security ramp (2 mN/s) on `clove_hitch`, its defaults but the set tension; "
             "regenerate: `python validation/hitch_pretension.py --table`.", "",
             "| set tension (mN) | slip load, run-away (mN) | slow-slip load (mN) | outcome | set still | μ |",
             "|---|---|---|---|---|---|"]
    for t, slip, slow, outcome, still, mu in rows:
        lines.append(f"| {t * 1e3:g} | {'—' if slip is None else f'{slip * 1e3:.2f}'} | "
                     f"{'—' if slow is None else f'{slow * 1e3:.2f}'} | {outcome} | {still} | {mu} |")
    fit = [(t, slip) for t, slip, *_ in rows if slip]
    if len(fit) >= 3:
        k = _fit([a for a, _ in fit], [b for _, b in fit])
        lines += ["", f"Exponent of the slip load against the set tension (least squares, {len(fit)} points): "
                      f"{k:.2f}."]
    text = "\n".join(lines) + "\n"
    (out / "pretension.md").write_text(text)
    return text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mu", type=float, default=0.3)
    ap.add_argument("--out", default=str(ROOT / "docs" / "studies" / "hitch_pretension"))
    ap.add_argument("--table", action="store_true")
    a = ap.parse_args(argv)
    out = Path(a.out)
    if not a.table:
        run(a.mu, out)
    sys.stdout.write(table(out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
