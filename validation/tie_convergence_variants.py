"""Tied reef and granny for the numerical checks of ``validation/studies/convergence_tied``.

The committed tied states (``docs/studies/granny_vs_reef_mu_tied/tied_{reef,granny}``) come from
the shipped sequences ``knotsim tie reef`` / ``granny``, i.e.
:func:`knotsim.knots.tying.channel.channel_sequence` at its defaults (N = 209, final end pull
``pull = 0.22`` m per end: the tied slack). Two of the checks change the tie itself, so the knot is
tied again from the straight rope with one argument of ``channel_sequence`` changed and every other
one at its default:

* the tied slack ±20 %: ``pull`` = 0.176 m and 0.264 m per end (less pull leaves more rope in the
  knot);
* the resolution: ``n_nodes`` = 201, 301, 401, 601 (the rope is tied again at that N; a tied state
  is not resampled).

Each tie goes to ``validation/studies/convergence_tied/tied_<kind>_<tag>/`` with the files the pull
reads (``checkpoint.npz``, ``run.toml``) and the tie's ``summary.json`` (knot type, half-knot gap);
the trajectory, log and run.json are deleted to keep the repository small.

    python validation/tie_convergence_variants.py slack_m20 slack_p20 n201 n301 n401 n601
    python validation/tie_convergence_variants.py --kind reef n401

A tie whose directory already holds ``checkpoint.npz`` and ``summary.json`` is skipped.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

#: Variant tag -> keyword arguments of ``channel_sequence`` (everything else at its default).
VARIANTS = {
    "slack_m20": {"pull": 0.176},
    "slack_p20": {"pull": 0.264},
    "n201": {"n_nodes": 201},
    "n301": {"n_nodes": 301},
    "n401": {"n_nodes": 401},
    "n601": {"n_nodes": 601},
}

OUT = Path(__file__).resolve().parent / "studies" / "convergence_tied"
KEEP = ("checkpoint.npz", "run.toml", "summary.json")


def tie_variant(kind: str, tag: str, out_root: Path = OUT) -> dict:
    """Tie ``kind`` (``"reef"`` / ``"granny"``) with the variant ``tag`` of :data:`VARIANTS` into
    ``out_root/tied_<kind>_<tag>``; returns the tie's summary (as written to ``summary.json``)."""
    from knotsim._util.jsonio import read_json, write_json
    from knotsim.knots.tying.channel import channel_sequence
    from knotsim.knots.tying.run import tie_from_straight

    out = out_root / f"tied_{kind}_{tag}"
    if all((out / f).is_file() for f in ("checkpoint.npz", "summary.json")):
        return read_json(out / "summary.json")
    kw = VARIANTS[tag]
    cfg, _info = channel_sequence(kind, **kw)
    cfg.setdefault("provenance", {}).update({"channel_sequence_arguments": dict(kw)})
    out.mkdir(parents=True, exist_ok=True)
    tr = tie_from_straight(kind, out, progress=False, config=cfg)
    summary = {**tr.summary(), "channel_sequence_arguments": dict(kw)}
    write_json(out / "summary.json", summary)
    for p in out.iterdir():
        if p.name not in KEEP:
            if p.is_dir():
                import shutil

                shutil.rmtree(p)
            else:
                p.unlink()
    return summary


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tags", nargs="+", choices=sorted(VARIANTS))
    ap.add_argument("--kind", choices=("reef", "granny", "both"), default="both")
    a = ap.parse_args(argv)
    kinds = ("granny", "reef") if a.kind == "both" else (a.kind,)
    for tag in a.tags:
        for kind in kinds:
            s = tie_variant(kind, tag)
            print(f"{kind} {tag}: {s['knot_type']} ok={s['ok']} gap={s.get('half_knot_gap_diameters')} d "
                  f"wall={s['wall_time']:.0f} s pen={s['max_penetration_ratio']:.3f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
