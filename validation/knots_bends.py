"""Two-rope bends (protocol 4.3, Patil et al. 2020): reef, granny, thief and grief bends ranked by
holding force, with a table of checks (resolution N, friction mu, contact stiffness scaler, pull
speed).

Run: ``python validation/knots_bends.py [--runs DIR] [--friction-model surface]`` (about 45 min on
one core with the centre-line law: 4 full-size
runs of 40 s, 24 check runs at N = 151, 2 full-size runs at other time steps). Writes
``validation/reports/knots_bends.md`` and the ``knots_bends*.png`` figures (with
``--friction-model surface``: ``validation/reports/surface/``; the default is the centre-line law,
with which the report was made). ``--runs DIR`` keeps
the run directories (trajectory, log, summary) in ``DIR`` and reuses a run whose ``summary.json``
has the same parameters, so the report can be regenerated without re-running.

Loading: displacement control (the protocol's ``mode="displacement"``), the pulled end moves at
10 mm/s for 40 s (400 mm). The bends are drawn loose (a ring of about 0.3 m of rope), so most of
the pull goes into closing the ring; the default 10 s of the protocol ends long before the bends
are tight (see the report).

Holding force (definition used here): ``F_hold`` = the largest value of the pull force ``F h^2/EI``
(axial reaction at the pulled end, 0.5 s centred moving average) over the pull after the start-up
transient (``t >= 2 s``): the peak force the bend carries before (or while) its tails are pulled
through. Slip onset: the first time after ``t >= 2 s`` at which the two free tails are drawn into the
knot together faster than ``SLIP_RATE`` x pull speed (tail lengths outside the knot, see
:func:`knotsim.protocols.two_rope_bend.tail_lengths`, 2 s centred average of the rate), sustained
for 2 s. A bend that never slips "held" and its ``F_hold`` is a lower bound of its holding force.
In the force-control check (``mode="force"``, a force ramp on the pulled end) ``F_hold`` is the
applied ``F h^2/EI`` when the pulled end runs away (its speed, 0.5 s average, above the protocol's
``runaway_speed`` for 0.5 s, after the first 0.2 s).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from knotsim.protocols import run_protocol  # noqa: E402
from knotsim.protocols.metrics import draw_in_onset, sustained_onset  # noqa: E402

OUT = Path(__file__).parent / "reports"
BENDS = ("reef_bend", "granny_bend", "thief_bend", "grief_bend")
SHORT = {b: b.split("_")[0] for b in BENDS}
#: Patil's firm pairwise orderings (stronger, weaker); granny vs thief is undecided.
PATIL = (("reef_bend", "granny_bend"), ("reef_bend", "thief_bend"), ("granny_bend", "grief_bend"),
         ("thief_bend", "grief_bend"))
T_SKIP = 2.0      # s, start-up transient excluded from F_hold and slip detection
SMOOTH = 0.5      # s, moving average of the pull force
SLIP_RATE = 0.25  # tails drawn in faster than this x pull speed = slipping
SLIP_HOLD = 2.0   # s, the fast draw-in must last this long
TIE = 0.05        # relative difference of F_hold below which two bends tie

#: the friction law of the runs (``--friction-model``)
LAW = "centreline"
BASE = {"mode": "displacement", "pull_speed": 0.01, "mu": 0.3, "dt": 2e-3, "duration": 40.0,
        "output_interval": 0.1, "contact.friction_model": LAW}
#: (tag, description, overrides on top of BASE). The first is the full-size run; the checks run at
#: N = 151 (half the cost) and are compared with the N = 151 reference ``n151``.
CASES = (
    ("base40", "N = 301 (full size), mu = 0.3, 10 mm/s", {}),
    ("n151", "N = 151 (resolution check; reference of the checks below)", {"n_nodes": 151}),
    ("n151_mu0.1", "N = 151, mu = 0.1", {"n_nodes": 151, "mu": 0.1}),
    ("n151_mu0.5", "N = 151, mu = 0.5", {"n_nodes": 151, "mu": 0.5}),
    ("n151_v20", "N = 151, pull speed 20 mm/s (400 mm in 20 s)", {"n_nodes": 151, "pull_speed": 0.02,
                                                                 "duration": 20.0}),
    ("n151_ks1000", "N = 151, contact stiffness scaler 1000 (default 500)",
     {"n_nodes": 151, "contact.stiffness_scaler": 1000.0}),
    ("n151_force", "N = 151, force control: ramp 0.2 mN/s (F h²/EI up to 0.014 in 40 s)",
     {"n_nodes": 151, "mode": "force", "force_rate": 2e-4}),
    ("n151_cinch", "N = 151, cinched first (all four ends pulled out by 0.11 m at 20 mm/s, then the tails "
     "released), then 400 mm of pull", {"n_nodes": 151, "pre_tighten": 0.11, "pre_tighten_speed": 0.02,
                                        "duration": 45.5}),
)
T_SKIP_FORCE = 0.2  # s, force control: the ramp starts from zero, only the first steps are skipped
#: Full-size runs at the time steps where the solver is known to stall (two_rope_bend docstring).
DT_RUNS = (("grief_bend", 2.5e-3), ("thief_bend", 1.5e-3))
#: Time steps tried in turn when a run stops early (Newton stall), after the default 2 ms.
DT_RETRY = (2.5e-3, 1.5e-3, 1e-3)


# ---------------------------------------------------------------------------------------- runs
def _matches(summary: dict, ov: dict) -> bool:
    p = summary.get("parameters", {})
    return all(k in p and p[k] == v for k, v in ov.items())


def run_one(runs: Path, knot: str, tag: str, ov: dict) -> dict:
    """Run (or reuse from ``runs``) one bend; returns the summary with the log attached."""
    d = runs / f"{knot}__{tag}"
    s = None
    if (d / "summary.json").exists():
        s = json.loads((d / "summary.json").read_text())
        if not _matches(s, ov):
            s = None
    if s is None:
        t0 = time.perf_counter()
        s = run_protocol("two-rope-bend", knot, out_dir=d, overrides=ov)
        s["wall_time"] = time.perf_counter() - t0
    s["log"] = pd.read_parquet(d / "log.parquet")
    s["dir"] = d
    return s


def run_with_retry(runs: Path, knot: str, tag: str, ov: dict) -> list[dict]:
    """The run at the default dt, then at the DT_RETRY steps in turn while runs stop early. All
    attempts are returned (the last one is used)."""
    out = [run_one(runs, knot, tag, ov)]
    for dt in DT_RETRY:
        if out[-1]["run_status"] == "completed":
            break
        out.append(run_one(runs, knot, f"{tag}_dt{dt * 1e3:g}ms", {**ov, "dt": dt}))
    return out


# ------------------------------------------------------------------------------------- metrics
def _smooth(t: np.ndarray, y: np.ndarray, width: float) -> np.ndarray:
    k = max(1, int(round(width / max(float(np.median(np.diff(t))), 1e-12))))
    return np.asarray(pd.Series(y).rolling(k, center=True, min_periods=1).mean(), float)


def bend_metrics(s: dict) -> dict:
    """Holding force, slip onset and draw-in of one run (definitions: module docstring)."""
    log = s["log"]
    p = s["parameters"]
    t_pre = float(s["metrics"].get("pre_tighten_time", 0.0) or 0.0)
    if t_pre > 0:  # measure the pull after the cinching stage, time from its end
        log = log[log["time"] >= t_pre - 1e-9].copy()
        log["time"] = log["time"] - t_pre
    t = log["time"].to_numpy()
    f = _smooth(t, log["F_norm"].to_numpy(), SMOOTH)
    u = log["u_pull"].to_numpy()
    tails = (log["tail_a"] + log["tail_b"]).to_numpy()
    v = float(p["pull_speed"])
    force_mode = p["mode"] == "force"
    if force_mode:  # runaway of the pulled end under the applied force ramp
        speed = np.gradient(_smooth(t, u, SMOOTH), t) if len(t) > 2 else np.zeros_like(t)
        slip = sustained_onset(t, (speed > float(p["runaway_speed"])) & (t >= T_SKIP_FORCE), 0.5)
    else:  # tails drawn into the knot (the protocol's own rule, here with this script's constants)
        onset = draw_in_onset(log, ["tail_a", "tail_b"], SLIP_RATE * v, smooth=SLIP_HOLD, hold=SLIP_HOLD, t0=T_SKIP)
        slip = None if onset is None else int(np.searchsorted(t, onset["time"]))
    if force_mode:  # the force at which the pulled end runs away (the applied ramp; end of run if never)
        f = log["F_norm"].to_numpy()
        k = slip if slip is not None else len(t) - 1
    else:
        sel = t >= T_SKIP
        k = int(np.flatnonzero(sel)[np.argmax(f[sel])]) if sel.any() else len(t) - 1
    topo = s.get("knot_status")
    if topo in ("untied", "changed knot type"):
        outcome = topo
    elif slip is not None:
        outcome = "slipped"
    else:
        outcome = "held"
    if s["run_status"] != "completed":
        outcome += " (run stopped early)"
    return {
        "F_hold": float(f[k]), "t_peak": float(t[k]), "u_peak": float(u[k]),
        "F_end": float(f[-1]), "u_end": float(u[-1]),
        "F_slide": None if slip is None or force_mode else float(np.mean(f[slip:])),
        "slip_t": None if slip is None else float(t[slip]),
        "slip_u": None if slip is None else float(u[slip]),
        "slip_F": None if slip is None else float(f[slip]),
        "draw_a": float(log["tail_a"].iloc[0] - log["tail_a"].iloc[-1]),
        "draw_b": float(log["tail_b"].iloc[0] - log["tail_b"].iloc[-1]),
        "outcome": outcome, "held": slip is None and outcome == "held",
        "protocol_outcome": s["outcome"], "run_status": s["run_status"],
        "pen": float(s["contact"]["worst_penetration_ratio"] or 0.0), "wall": float(s["wall_time"]),
        "sim_time": float(s["sim_time"]), "failed": int(s["failed_attempts"]), "dt": float(p["dt"]),
        "t": t, "f": f, "u": u, "tails": tails,
    }


def compare(a: dict, b: dict) -> str:
    """``">"``, ``"<"``, ``"="``, ``"?"`` (undetermined: both held, or the held one carried less
    than the other's peak) or ``"n/a"`` (a run stopped early) for the holding forces of two bends."""
    fa, fb = a["F_hold"], b["F_hold"]
    if a["run_status"] != "completed" or b["run_status"] != "completed":
        return "n/a"
    if a["held"] and b["held"]:
        return "?"
    if abs(fa - fb) <= TIE * max(fa, fb):
        return "=" if not (a["held"] or b["held"]) else "?"
    if fa > fb:
        return ">" if not b["held"] else "?"
    return "<" if not a["held"] else "?"


def ranking(ms: dict[str, dict]) -> str:
    order = sorted(ms, key=lambda k: -ms[k]["F_hold"])
    return " > ".join(f"{SHORT[k]} ({'≥' if ms[k]['held'] else ''}{ms[k]['F_hold']:.2e}"
                      f"{', run stopped early' if ms[k]['run_status'] != 'completed' else ''})" for k in order)


def patil_check(ms: dict[str, dict]) -> list[tuple[str, str, str]]:
    rows = []
    for strong, weak in PATIL:
        c = compare(ms[strong], ms[weak])
        verdict = {">": "agrees", "<": "DISAGREES", "=": "tie", "?": "undetermined", "n/a": "run failed"}[c]
        rows.append((f"{SHORT[strong]} > {SHORT[weak]}", c, verdict))
    c = compare(ms["granny_bend"], ms["thief_bend"])
    rows.append(("granny vs thief (undecided)", c, "-"))
    return rows


# ------------------------------------------------------------------------------------- figures
def _knot_center(a: np.ndarray, b: np.ndarray, cutoff: float) -> tuple[np.ndarray, float]:
    from scipy.spatial import cKDTree

    near = cKDTree(b).query(a, distance_upper_bound=cutoff)[0] < np.inf
    pts = a[near] if near.any() else a
    c = pts.mean(axis=0)
    return c, float(np.max(np.linalg.norm(pts - c, axis=1)))


def render_bend(s: dict, m: dict, png: Path) -> list[str]:
    """Top views of the knot (ropes cropped to the knot) at the start, at slip onset (if any) and at
    the end, side by side in one PNG. Returns the backend notes."""
    from PIL import Image

    from knotsim.io.trajectory import read_trajectory
    from knotsim.viz.render import render_frame

    tr = read_trajectory(s["dir"] / "trajectory.h5", lazy=True)
    notes = []
    imgs = []
    with tr:
        times = np.asarray(tr.time)
        frames = [("start", 0)]
        if m["slip_t"] is not None:
            frames.append(("slip onset", int(np.argmin(np.abs(times - m["slip_t"])))))
        frames.append(("end", tr.n_frames - 1))
        h = float(np.atleast_1d(tr.rod_radius)[0])
        for label, i in frames:
            cl = [np.asarray(x) for x in tr.centerlines(i)]
            c, r = _knot_center(cl[0], cl[1], 8 * h)
            crop = []
            for x in cl:
                idx = np.flatnonzero(np.linalg.norm(x - c, axis=1) < r + 0.015)
                crop.append(x[idx[0]:idx[-1] + 1] if idx.size else x)
            tmp = png.with_name(png.stem + f"_{i}.png")
            title = f"{SHORT[s['knot']]} {label}, t = {times[i]:.1f} s"
            try:
                render_frame(crop, h, tmp, view="top", size=(480, 360), backend="pyvista", title=title)
            except Exception as exc:  # headless OpenGL unavailable: matplotlib fallback
                notes.append(f"pyvista failed ({type(exc).__name__}); matplotlib used")
                render_frame(crop, h, tmp, view="top", size=(480, 360), backend="matplotlib", title=title)
            imgs.append(Image.open(tmp).convert("RGB"))
            tmp.unlink()
    w = sum(im.width for im in imgs)
    out = Image.new("RGB", (w, max(im.height for im in imgs)), "white")
    x = 0
    for im in imgs:
        out.paste(im, (x, 0))
        x += im.width
    out.save(png)
    return notes


def plot_base(ms: dict[str, dict], png: Path) -> None:
    fig, axs = plt.subplots(1, 2, figsize=(11, 4))
    for k, m in ms.items():
        ln, = axs[0].plot(m["u"] * 1e3, m["f"], label=SHORT[k])
        axs[0].plot(m["u_peak"] * 1e3, m["F_hold"], "o", color=ln.get_color())
        axs[1].plot(m["u"] * 1e3, m["tails"] * 1e3, color=ln.get_color(), label=SHORT[k])
        if m["slip_u"] is not None:
            axs[1].axvline(m["slip_u"] * 1e3, color=ln.get_color(), ls=":", lw=1)
    axs[0].set_xlabel("pulled-end displacement u (mm)")
    axs[0].set_ylabel("F h²/EI (0.5 s average)")
    axs[0].set_yscale("log")
    axs[0].set_title("pull force (dot: F_hold)")
    top = max(float(np.max(m["tails"][m["t"] >= 0.5])) for m in ms.values())
    axs[1].set_ylim(0.0, 1.1e3 * top)  # the first steps, before the loose drawing touches, read as whole ropes
    axs[1].set_xlabel("pulled-end displacement u (mm)")
    axs[1].set_ylabel("tail_a + tail_b (mm)")
    axs[1].set_title("free tails outside the knot (dotted: slip onset)")
    for ax in axs:
        ax.grid(True, alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def plot_checks(allm: dict[str, dict[str, dict]], png: Path) -> None:
    fig, ax = plt.subplots(figsize=(8, 4))
    tags = list(allm)
    w = 0.8 / len(BENDS)
    for j, k in enumerate(BENDS):
        vals = [allm[tag][k]["F_hold"] if k in allm[tag] else np.nan for tag in tags]
        bars = ax.bar(np.arange(len(tags)) + (j - 1.5) * w, vals, w, label=SHORT[k])
        for b, tag in zip(bars, tags, strict=True):
            if k in allm[tag] and allm[tag][k]["held"]:
                b.set_hatch("//")
    ax.set_xticks(np.arange(len(tags)), tags, rotation=20)
    ax.set_yscale("log")
    ax.set_ylabel("F_hold h²/EI")
    ax.set_title("holding force per check (hatched: held, lower bound)")
    ax.legend()
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


# -------------------------------------------------------------------------------------- report
def _f(x, fmt=".3g"):
    return "–" if x is None else format(x, fmt)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=Path, default=None, help="keep/reuse run directories here")
    ap.add_argument("--only-base", action="store_true", help="skip the checks")
    ap.add_argument("--friction-model", choices=["centreline", "surface"], default="centreline")
    args = ap.parse_args()
    global LAW, OUT
    LAW = args.friction_model
    BASE["contact.friction_model"] = LAW
    if LAW != "centreline":
        OUT = OUT / LAW
    OUT.mkdir(parents=True, exist_ok=True)
    tmp = None
    if args.runs is None:
        tmp = tempfile.TemporaryDirectory()
        runs = Path(tmp.name)
    else:
        runs = args.runs
        runs.mkdir(parents=True, exist_ok=True)
    cases = CASES[:1] if args.only_base else CASES
    allm: dict[str, dict[str, dict]] = {}
    attempts: list[tuple[str, str, dict]] = []
    base_summ = {}
    for tag, _, ov in cases:
        allm[tag] = {}
        for k in BENDS:
            tries = run_with_retry(runs, k, tag, {**BASE, **ov})
            for s in tries:
                attempts.append((tag, k, bend_metrics(s)))
            allm[tag][k] = bend_metrics(tries[-1])
            if tag == cases[0][0]:
                base_summ[k] = tries[-1]
    base = allm[cases[0][0]]
    plot_base(base, OUT / "knots_bends.png")
    if len(allm) > 1:
        plot_checks(allm, OUT / "knots_bends_checks.png")
    notes = []
    for k in BENDS:
        notes += render_bend(base_summ[k], base[k], OUT / f"knots_bends_{SHORT[k]}.png")

    L = ["# Two-rope bends: ranking by holding force", "",
         "Generated by `python validation/knots_bends.py" + ("" if LAW == "centreline" else f" --friction-model {LAW}")
         + f"` (friction law `{LAW}`; protocol `two-rope-bend`, docs/physics.md §4.3; "
         "Patil et al., Science 2020). Rope A held at one end, rope B pulled at its far end "
         "(displacement control, 10 mm/s), the two tails free; h = 2 mm, L = 1 m per rope, "
         "E = 0.18 MPa, ρ = 1180, η = 0.01 Pa s, δ = 0.5 mm, ν = 0.1 mm/s, adaptive contact "
         "stiffness (scaler 500), dt = 2 ms, 40 s (400 mm of pull).", "",
         "## Holding force (definition)", "",
         f"* **F_hold** = the largest pull force `F h²/EI` (axial reaction at the pulled end, {SMOOTH:g} s centred "
         f"moving average) over the pull after the start-up transient (t ≥ {T_SKIP:g} s): the peak force the "
         "bend carries before (or while) its tails are pulled through. In displacement control the force of "
         "a slipping bend stops rising (or drops) while its tails run into the knot, so the peak is the "
         "force at which it gives way.",
         f"* **slip onset** = first time (t ≥ {T_SKIP:g} s) from which the two free tails (length of each tail "
         "outside the knot, `tail_lengths` in `two_rope_bend.py`) are drawn into the knot together faster "
         f"than {SLIP_RATE:g} × the pull speed for at least {SLIP_HOLD:g} s (rate from a {SLIP_HOLD:g} s "
         "average).",
         "* **outcome**: `untied` / `changed knot type` from the knot type of the closed bend at the start "
         "and end (topology check of the protocol), else `slipped` when a slip onset was found, else `held`. "
         "A held bend's F_hold is a lower bound (marked ≥): it never gave way in the 400 mm pull.",
         "* **tail draw-in** = decrease of each tail's length outside the knot over the run (A: held rope's "
         "tail, B: pulled rope's tail); positive = drawn into the knot.",
         "* **mean F while slipping** = mean of the averaged pull force from slip onset to the end of the pull "
         "(the sliding resistance of a slipping bend).",
         "* Pairwise comparison: A > B when A's F_hold exceeds B's by more than "
         f"{TIE:.0%} and B slipped (if B held, B's F_hold is only a lower bound: undetermined); "
         "two held bends are undetermined.", "",
         "Force control (`mode=\"force\"`, a force ramp on the pulled end; F_hold = the applied force when the "
         "pulled end runs away) is run as one of the checks below with a slow ramp (0.2 mN/s); see the findings "
         "for the protocol's default ramp.", "",
         "## Full-size result (N = 301)", "",
         f"Ranking by F_hold: **{ranking(base)}**", "",
         "| bend | F_hold (F h²/EI) | at u (mm) | slip onset t (s) / u (mm) | F at slip onset | mean F while "
         "slipping | F at end | tail draw-in A / B (mm) | outcome | protocol outcome | worst penetration (h) | "
         "run | dt (ms) | wall time (s) |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for k in BENDS:
        m = base[k]
        slip = "–" if m["slip_t"] is None else f"{m['slip_t']:.1f} / {m['slip_u'] * 1e3:.0f}"
        L.append(f"| {SHORT[k]} | {'≥' if m['held'] else ''}{m['F_hold']:.3g} | {m['u_peak'] * 1e3:.0f} | {slip} | "
                 f"{_f(m['slip_F'])} | {_f(m['F_slide'])} | {m['F_end']:.3g} | {m['draw_a'] * 1e3:.0f} / {m['draw_b'] * 1e3:.0f} | "
                 f"{m['outcome']} | {m['protocol_outcome']} | {m['pen']:.3g} | {m['run_status'][:60]} | "
                 f"{m['dt'] * 1e3:g} | {m['wall']:.0f} |")
    L += ["", "Patil's firm pairwise orderings against F_hold:", "", "| ordering | simulated | verdict |",
          "|---|---|---|"]
    L += [f"| {a} | {b} | {c} |" for a, b, c in patil_check(base)]
    L += ["", "![force and tails](knots_bends.png)", "",
          "Knot at the start, at slip onset (slipping bends) and at the end (top view, ropes cropped to the "
          "knot; rope A red, rope B blue):", ""]
    L += [f"![{SHORT[k]}](knots_bends_{SHORT[k]}.png)" for k in BENDS]
    if notes:
        L += ["", "Rendering: " + "; ".join(sorted(set(notes)))]
    if len(allm) > 1:
        L += ["", "## Checks", "",
              "Each check changes one setting (N = 151 unless stated; compare with the `n151` row). The "
              "physics model (energies, contact, friction law) is the same in every run.", "",
              "| check | ranking by F_hold | reef>granny | reef>thief | granny>grief | thief>grief | "
              "granny vs thief | outcomes (reef, granny, thief, grief) | worst penetration (h) | "
              "wall time (s) |", "|---|---|---|---|---|---|---|---|---|---|"]
        for tag, desc, _ in cases:
            ms = allm[tag]
            pc = patil_check(ms)
            outs = ", ".join(ms[k]["outcome"] for k in BENDS)
            pen = max(ms[k]["pen"] for k in BENDS)
            wall = " / ".join(f"{ms[k]['wall']:.0f}" for k in BENDS)
            L.append(f"| {desc} | {ranking(ms)} | " + " | ".join(f"{c} ({v})" if v != "-" else c for _, c, v in pc)
                     + f" | {outs} | {pen:.3g} | {wall} |")
        L += ["", "![checks](knots_bends_checks.png)", "",
              "Every run of the checks (F_hold, slip onset u, tail draw-in A/B, worst penetration, wall time):", "",
              "| check | bend | dt (ms) | run | F_hold | slip u (mm) | draw-in A / B (mm) | outcome | "
              "worst penetration (h) | wall (s) |", "|---|---|---|---|---|---|---|---|---|---|"]
        for tag, k, m in attempts:
            slip = "–" if m["slip_u"] is None else f"{m['slip_u'] * 1e3:.0f}"
            L.append(f"| {tag} | {SHORT[k]} | {m['dt'] * 1e3:g} | {m['run_status'][:50]} | "
                     f"{'≥' if m['held'] else ''}{m['F_hold']:.3g} | {slip} | {m['draw_a'] * 1e3:.0f} / "
                     f"{m['draw_b'] * 1e3:.0f} | {m['outcome']} | {m['pen']:.3g} | {m['wall']:.0f} |")
    if not args.only_base:
        L += ["", "## Time step", "",
              "Full-size runs at the time steps where the solver was reported to stall (protocol docstring), "
              "against the 2 ms runs above:", "",
              "| bend | dt (ms) | run | sim time reached (s) | failed step attempts | F_hold | outcome | "
              "worst penetration (h) | wall (s) |", "|---|---|---|---|---|---|---|---|---|"]
        for k, dt in DT_RUNS:
            for m in (base[k], bend_metrics(run_one(runs, k, f"{cases[0][0]}_dt{dt * 1e3:g}ms",
                                                    {**BASE, "dt": dt}))):
                L.append(f"| {SHORT[k]} | {m['dt'] * 1e3:g} | {m['run_status']} | {m['sim_time']:.2f} | "
                         f"{m['failed']} | {'≥' if m['held'] else ''}{m['F_hold']:.3g} | {m['outcome']} | "
                         f"{m['pen']:.3g} | {m['wall']:.0f} |")
    extra = OUT / "knots_bends_notes.md"
    if extra.exists():
        L += ["", extra.read_text().strip()]
    elif LAW != "centreline":
        L += ["", "## Findings", "", f"These runs use `contact.friction_model = \"{LAW}\"`; the findings written "
              "for the centre-line runs (validation/reports/knots_bends.md) are not repeated here. The comparison "
              "of the two laws is in docs/validation.md §8."]
    (OUT / "knots_bends.md").write_text("\n".join(L) + "\n", encoding="utf-8")
    if tmp is not None:
        tmp.cleanup()


if __name__ == "__main__":
    main()
