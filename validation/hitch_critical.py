"""Critical friction of hitches and loops: the least μ at which a set hitch (or a loop on its pin)
holds a steady load on its standing part.

Run: ``python validation/hitch_critical.py [KNOT ...] [--load 0.01] [--out DIR] [--set KEY=VALUE] [--jobs 2]``
(default: every library knot of kind ``hitch`` or ``loop``; ``--out docs/studies/hitch_critical``), then
``python validation/hitch_critical.py --table [--out DIR]`` writes ``critical.md`` from every JSON file
in the folder. For each knot, :func:`knotsim.critical_friction` bisects μ between 0.05 and 0.8 down
to a bracket 0.02 wide with hold runs of ``knot-security`` at the protocol's defaults (set at 10 mN
on the standing part and the tail until the knot is still, relaxed to 1 mN, the load reached over
1 s and held for 10 s; the post fixed, with the rope's μ). A run holds when its standing part never
ran away, the rope stayed on the post and less than 1 mm of rope passed through the knot over the
second half of the hold (the lesser of the standing part's outward drift and the tail's draw-in).
Each knot is written as soon as it is done (``<knot>_<load in mN>mN.json``: the bracket and every
run), so a cut session keeps what finished. Knots run side by side, one process per core.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parents[1]
MU_LOW, MU_HIGH, TOL = 0.05, 0.8, 0.02
DRIFT_LIMIT = 1e-3  # m of rope through the knot over the hold's second half (the library's default)


def on_post_knots() -> list[str]:
    """The library's hitches and loops."""
    import knotsim as ks

    return [n for n, _ in ks.list_knots() if ks.load_knot_spec(n).kind in ("hitch", "loop")]


def one(knot: str, load: float, out: str, overrides: dict, bracket: tuple[float, float] = (MU_LOW, MU_HIGH)) -> str:
    """One knot's bisection, written to ``out`` (skipped when its file exists)."""
    import knotsim as ks

    path = Path(out) / f"{knot}_{load * 1e3:g}mN.json"
    if path.is_file():
        return f"{knot}: kept {path.name}"
    t0 = time.time()
    res = ks.critical_friction(knot, load, mu_low=bracket[0], mu_high=bracket[1], tol=TOL, drift_limit=DRIFT_LIMIT,
                               overrides=overrides)
    path.write_text(json.dumps({"knot": knot, "kind": ks.load_knot_spec(knot).kind, "load": load,
                                "mu_slip": res.mu_slip, "mu_hold": res.mu_hold, "mu_c": res.mu_c, "runs": res.runs,
                                "overrides": overrides, "bracket": list(bracket), "tol": TOL,
                                "drift_limit": DRIFT_LIMIT, "hold_rule": "drift_through_late < drift_limit",
                                "knotsim_version": ks.__version__, "wall_time_s": round(time.time() - t0, 1)},
                               indent=1))
    return f"{knot}: mu_c in [{res.mu_slip}, {res.mu_hold}] ({time.time() - t0:.0f} s)"


def _fmt(v) -> str:
    return "—" if v is None else f"{v:.3f}"


def table(out: Path) -> str:
    """``critical.md``: one row per JSON file of ``out``."""
    rows = [json.loads(p.read_text()) for p in sorted(out.glob("*mN.json"))]
    lines = [f"# Critical friction of hitches and loops ({out.name})", "",
             "The least μ at which the set knot holds a steady load on its standing part (bisection, "
             f"bracket {TOL} wide; a hold lets less than {DRIFT_LIMIT * 1e3:g} mm through over its second half). "
             "Regenerate: `python validation/hitch_critical.py --table --out " + str(out.relative_to(ROOT)
                                                                                    if out.is_relative_to(ROOT)
                                                                                    else out) + "`.", ""]
    changed = sorted({f"{k} = {v}" for r in rows for k, v in r.get("overrides", {}).items()})
    if changed:
        lines += [f"Settings: {', '.join(changed)}.", ""]
    lines += ["| knot | kind | load (mN) | μ slips | μ holds | μ_c | largest drift of a hold (mm) | how the "
              "slipping runs failed | runs | wall (s) |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        held = [x for x in r["runs"] if x["holds"]]
        drift = max((x["drift_through_late"] or 0.0 for x in held), default=None)
        fails = sorted({x["outcome"].split(" (")[0] for x in r["runs"] if not x["holds"]})
        lines.append(f"| `{r['knot']}` | {r.get('kind', '')} | {r['load'] * 1e3:g} | {_fmt(r['mu_slip'])} | "
                     f"{_fmt(r['mu_hold'])} | {_fmt(r['mu_c'])} | "
                     f"{'—' if drift is None else f'{drift * 1e3:.2f}'} | {', '.join(fails) or '—'} | "
                     f"{len(r['runs'])} | {r.get('wall_time_s', '')} |")
    text = "\n".join(lines) + "\n"
    (out / "critical.md").write_text(text)
    return text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("knots", nargs="*", help="library hitches and loops (default: all of them)")
    ap.add_argument("--load", type=float, default=0.01, help="N held on the standing part")
    ap.add_argument("--out", default=str(ROOT / "docs" / "studies" / "hitch_critical"))
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a knot-security parameter")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--bracket", type=float, nargs=2, default=(MU_LOW, MU_HIGH), metavar=("MU_LOW", "MU_HIGH"),
                    help="the μ bracket bisected (a band around a known μ_c needs fewer runs)")
    ap.add_argument("--table", action="store_true", help="write critical.md from the JSON files")
    a = ap.parse_args(argv)
    out = Path(a.out)
    if a.table:
        sys.stdout.write(table(out))
        return 0
    out.mkdir(parents=True, exist_ok=True)
    overrides = {}
    for item in a.set:
        key, _, value = item.partition("=")
        try:
            overrides[key] = json.loads(value)
        except json.JSONDecodeError:
            overrides[key] = value
    knots = a.knots or on_post_knots()
    with ProcessPoolExecutor(max_workers=a.jobs) as pool:
        for line in pool.map(one, knots, [a.load] * len(knots), [str(out)] * len(knots),
                             [overrides] * len(knots), [tuple(a.bracket)] * len(knots)):
            sys.stdout.write(line + "\n")
            sys.stdout.flush()
    table(out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
