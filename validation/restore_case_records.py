"""Recreate the case records (``cases/<case_id>/result.json``) of a committed study from its
``results.parquet``, so that ``knotsim study FILE -o DIR --resume`` runs only the cases added to
the study file since (the repository keeps the results table, not the case directories with their
logs and trajectories).

    python validation/restore_case_records.py validation/studies/convergence_tied.toml validation/studies/convergence_tied

Only rows whose ``case_id`` is a case of the study file are restored; an existing case directory
is left alone. The restored record holds the row's outcome, error, wall time and metrics (``metric.X``
columns back under their own name ``X``) and ``"restored_from": "results.parquet"``; it has no
``host``, so the rebuilt table's ``case_dir`` of a restored case is empty (there are no outputs).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path


def restore(study_file: str | Path, study_dir: str | Path) -> list[str]:
    """Write ``result.json`` for each finished case of ``study_dir/results.parquet`` that is a case of
    ``study_file`` and has no case directory; returns the restored case ids."""
    import pandas as pd

    from knotsim._util.jsonio import write_json
    from knotsim.study.spec import load_study_spec
    from knotsim.study.store import _RESERVED, CASES, RECORD

    cases = {c.case_id: c for c in load_study_spec(study_file).expand()}
    df = pd.read_parquet(Path(study_dir) / "results.parquet")
    params = {k for c in cases.values() for k in c.params}
    done = []
    for row in df.to_dict("records"):
        cid = row["case_id"]
        case = cases.get(cid)
        out = Path(study_dir) / CASES / cid
        if case is None or out.exists():
            continue
        metrics = {}
        for col, v in row.items():
            if col in _RESERVED or col in params:
                continue
            name = col[len("metric."):] if col.startswith("metric.") else col
            if isinstance(v, float) and math.isnan(v):
                v = None
            elif hasattr(v, "item"):
                v = v.item()
            metrics[name] = v
        rec = {"case_id": cid, "kind": case.kind, "params": case.params, "repeat": case.repeat,
               "outcome": row["outcome"], "error": row.get("error"), "traceback": row.get("traceback"),
               "wall_time": row.get("wall_time"), "metrics": metrics, "host": None,
               "restored_from": "results.parquet"}
        out.mkdir(parents=True)
        (out / "case.json").write_text("{}")
        write_json(out / "case.json", case.to_dict())
        write_json(out / RECORD, rec)
        done.append(cid)
    return done


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    ids = restore(sys.argv[1], sys.argv[2])
    print(f"restored {len(ids)} case records: {', '.join(ids)}")
