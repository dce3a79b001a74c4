"""Holding conditions of hitches on a rigid post: the string limit (after Bayman 1977) and the
leading-order effect of the rope's bending stiffness (the question of Maddocks & Keller 1987).

The derivations are in ``docs/physics.md`` §4.5; this module evaluates them. SI units throughout:
lengths in m, angles in rad, tensions in N, bending stiffness ``EI`` in N m^2; friction
coefficients and pinch factors are dimensionless.

The model (string limit)
------------------------
* The post is a rigid circular cylinder, its axis the ``z`` axis. The rope is a perfectly flexible,
  inextensible string lying on it; ``R_c`` is the radius of its centre line (post radius plus rope
  radius; the post radius itself in the strict limit).
* Along the post the string presses with ``T kappa_n`` per length and Coulomb friction bounds the
  tangential force: ``sqrt((dT/ds)^2 + (T kappa_g)^2) <= mu T kappa_n`` (normal and geodesic
  curvature of the path on the cylinder). A helix of pitch angle ``alpha`` (angle between the
  string and the post's circumference) has ``kappa_g = 0`` and ``kappa_n = cos(alpha)^2 / R_c``, so
  over an azimuth ``theta`` the tension changes at most by ``exp(mu theta cos(alpha))``.
* At a crossing the upper strand (tension ``T_u``, continuous through the crossing) presses the
  lower one against what lies under it with the pinch force ``N = p T_u``; ``p`` is the *pinch
  factor*, the upper strand's turning there: lifted over the lower strand (height ``2 h`` per
  strand) it runs straight from where it leaves the post to the top of the lower strand and back, a
  kink of ``2 beta`` with ``cos(beta) = R_n / (R_n + 2 h)``, ``R_n = R_c / cos(alpha)^2``, so
  ``p = 2 sin(beta)`` (:func:`pinch_factor`). The lower strand's tension may jump by at most
  ``(mu_below + mu_above) N``: friction on both of its faces (post or rope below, rope above).
* A hitch *holds* if a statically admissible tension field exists with the standing part loaded and
  the tail free (tension 0). All relations are homogeneous of degree one in the forces, so a hitch
  that holds one load holds every load (it is self-locking): the condition is an inequality in
  ``mu`` and the geometry only.

The same coefficient ``mu`` acts between rope and post; rope on rope is ``mu_rope = r mu`` with
``r = rope_friction_ratio`` (1 by default). The critical ``mu`` is where the inequality becomes an
equality; ``math.inf`` means the hitch never holds in the model (no pinch).
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq
from scipy.special import lambertw

from knotsim.errors import ConfigError

__all__ = [
    "HITCHES",
    "StiffnessCorrection",
    "capstan_ratio",
    "clove_hitch_critical_mu",
    "clove_hitch_critical_mu_on_path",
    "constrictor_critical_mu",
    "holds",
    "path_capstan_ratio",
    "pinch_factor",
    "round_turn_two_half_hitches_critical_mu",
    "stiff_capstan_ratio",
    "stiff_pinch_gain",
    "stiffness_correction",
    "two_half_hitches_critical_mu",
]

TWO_PI = 2.0 * math.pi
#: pinch factor of a rope lifted over a rope of its own radius lying on a "post" that is a third
#: rope of that radius (centre-line radius 2 h, lift 2 h): ``2 sin(60 deg)``
EQUAL_RADII_PINCH = math.sqrt(3.0)
#: beyond this the critical-mu search gives up and reports that the hitch never holds
_MU_MAX = 1.0e6


# ----------------------------------------------------------------------------- argument checks
def _finite(name: str, value: float) -> float:
    v = float(value)
    if not math.isfinite(v):
        raise ConfigError(name, f"must be a finite number, got {value!r}")
    return v


def _nonneg(name: str, value: float) -> float:
    v = _finite(name, value)
    if v < 0.0:
        raise ConfigError(name, f"must be >= 0, got {value!r}")
    return v


def _positive(name: str, value: float) -> float:
    v = _finite(name, value)
    if v <= 0.0:
        raise ConfigError(name, f"must be > 0, got {value!r}")
    return v


def _pitch(value: float) -> float:
    v = _finite("pitch_angle", value)
    if abs(v) >= 0.5 * math.pi:
        raise ConfigError("pitch_angle", f"must lie strictly between -pi/2 and pi/2 (rad), got {value!r}")
    return v


# ----------------------------------------------------------------------------- capstan
def capstan_ratio(mu: float, angle: float, pitch_angle: float = 0.0) -> float:
    """Largest tension ratio ``T_out / T_in`` a string on a post holds by friction alone.

    ``exp(mu angle cos(pitch_angle))`` (Euler–Eytelwein; with a pitch, the helical capstan).

    Parameters
    ----------
    mu:
        Friction coefficient between string and post (dimensionless, >= 0).
    angle:
        Azimuth the string wraps round the post (rad, >= 0), e.g. ``2 pi`` for one turn.
    pitch_angle:
        Angle between the helical string and the post's circumference (rad, ``|pitch| < pi/2``);
        0 for a circle. A helix is a geodesic of the cylinder (``kappa_g = 0``), and its normal
        curvature ``cos(pitch)^2 / R`` over the arc length ``R angle / cos(pitch)`` gives the
        exponent.

    Returns
    -------
    float
        ``T_out / T_in >= 1`` (the high-tension side over the low-tension side).
    """
    mu = _nonneg("mu", mu)
    angle = _nonneg("angle", angle)
    return math.exp(mu * angle * math.cos(_pitch(pitch_angle)))


def path_capstan_ratio(points: np.ndarray, mu: float) -> float:
    """Largest ratio ``T_first / T_last`` a string along a polyline on a post holds by friction.

    The discrete form of ``sqrt((dT/ds)^2 + (T kappa_g)^2) <= mu T kappa_n``: at each interior
    vertex ``k`` the post's force ``F = T_{k-1} t_{k-1} - T_k t_k`` (``t`` the unit edge vectors,
    ``T`` the edge tensions) must lie in the friction cone about the outward radial normal ``n`` of
    the post at the vertex: ``F.n >= 0`` and ``|F - (F.n) n| <= mu F.n``. Marching from the first
    edge, each vertex lets the tension fall to the smallest value the cone allows; the cone
    condition is homogeneous in the tensions, so this greedy march gives the largest ratio. The
    part of ``F`` in the post's tangent plane includes the geodesic kink of the path, so a path
    that is not a helix holds less than the helix of the same turning (and if it turns sideways
    by more than friction can hold it slides: the ratio is then 0).

    Parameters
    ----------
    points:
        ``(N, 3)`` vertices (m) on the post's surface (or on the cylinder of the rope's centre line),
        the post's axis being the ``z`` axis; ``N >= 3``. Edges should turn by well under a radian.
    mu:
        Friction coefficient between string and post (dimensionless, >= 0).

    Returns
    -------
    float
        ``T_first_edge / T_last_edge >= 1``; ``math.inf`` if the tension can fall to zero on the
        path; ``0.0`` if the path cannot rest on the post at this ``mu``.
    """
    mu = _nonneg("mu", mu)
    x = np.asarray(points, dtype=float)
    if x.ndim != 2 or x.shape[1] != 3 or x.shape[0] < 3:
        raise ConfigError("points", f"must be an (N, 3) array with N >= 3, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ConfigError("points", "must be finite")
    e = np.diff(x, axis=0)
    length = np.linalg.norm(e, axis=1)
    if np.any(length <= 0.0):
        raise ConfigError("points", "has repeated consecutive points (an edge of zero length)")
    t = e / length[:, None]
    r_xy = np.hypot(x[1:-1, 0], x[1:-1, 1])
    if np.any(r_xy <= 0.0):
        raise ConfigError("points", "has a vertex on the post's axis (the z axis)")
    nrm = np.zeros((x.shape[0] - 2, 3))
    nrm[:, 0] = x[1:-1, 0] / r_xy
    nrm[:, 1] = x[1:-1, 1] / r_xy
    log_ratio = 0.0
    for k in range(nrm.shape[0]):
        a, b, n = t[k], t[k + 1], nrm[k]
        an, bn = float(a @ n), float(b @ n)
        pa, pb = a - an * n, b - bn * n
        # F(c) = a - c b for T_k = c T_{k-1};  f(c) = |P F|^2 - mu^2 (F.n)^2 <= 0,  F.n >= 0
        qa = float(pb @ pb) - mu * mu * bn * bn
        qb = float(pa @ pb) - mu * mu * an * bn
        qc = float(pa @ pa) - mu * mu * an * an
        if qa <= 0.0:
            raise ConfigError("points", f"is too coarse at vertex {k + 1}: an edge turns by more than the "
                                        f"friction cone's half-angle atan(1/mu); refine the polyline")
        disc = qb * qb - qa * qc
        if disc < 0.0:
            return 0.0
        lo = (qb - math.sqrt(disc)) / qa
        hi = (qb + math.sqrt(disc)) / qa
        if bn < 0.0:  # F.n = an - c bn >= 0  <=>  c >= an / bn
            lo = max(lo, an / bn)
        elif bn > 0.0:
            hi = min(hi, an / bn)
        elif an < 0.0:
            return 0.0
        if hi < max(lo, 0.0):
            return 0.0
        c = max(lo, 0.0)
        if c <= 0.0:
            return math.inf
        log_ratio -= math.log(c)
    return math.exp(log_ratio)


# ----------------------------------------------------------------------------- crossings
def pinch_factor(rope_radius: float, post_radius: float, pitch_angle: float = 0.0, layers: int = 1) -> float:
    """Pinch factor ``p = N / T_upper`` of a taut string lifted over the strand(s) it crosses.

    The upper strand's centre line runs on the cylinder of radius ``R_c = post_radius +
    rope_radius``; where it crosses it must climb over ``layers`` strands of diameter ``2 h``
    stacked under it. Taut and perfectly flexible, it leaves the post along two straight tangents
    that meet on top of the crossed strand, a kink of ``2 beta`` in the plane of its normal section,
    whose radius is ``R_n = R_c / cos(pitch)^2`` (Euler). ``cos(beta) = R_n / (R_n + 2 h layers)``
    and the force on the crossed strand is ``N = 2 T sin(beta)``. This is the point-crossing
    (isolated crossing) value: the crossed strand's width is neglected against the lift-off span
    ``2 R_n sin(beta)``, which also makes ``p`` independent of the crossing angle. For a thin rope
    ``p ~ 4 sqrt(layers h cos(pitch)^2 / R_c)``: in the strict string limit ``h / R -> 0`` the pinch
    vanishes (see :func:`clove_hitch_critical_mu`).

    Parameters
    ----------
    rope_radius:
        Rope radius ``h`` (m, >= 0).
    post_radius:
        Post radius ``R`` (m, >= 0; 0 is allowed only with ``rope_radius > 0``).
    pitch_angle:
        Angle between the upper strand and the post's circumference at the crossing (rad).
    layers:
        Number of strands stacked under the upper strand at the crossing (>= 1).

    Returns
    -------
    float
        ``p`` in ``[0, 2)``.
    """
    h = _nonneg("rope_radius", rope_radius)
    r = _nonneg("post_radius", post_radius)
    alpha = _pitch(pitch_angle)
    if int(layers) != layers or layers < 1:
        raise ConfigError("layers", f"must be an integer >= 1, got {layers!r}")
    rc = r + h
    if rc <= 0.0:
        raise ConfigError("post_radius", "post_radius + rope_radius must be > 0")
    rn = rc / math.cos(alpha) ** 2
    c = rn / (rn + 2.0 * h * int(layers))
    return 2.0 * math.sqrt(max(0.0, 1.0 - c * c))


# ----------------------------------------------------------------------------- hitches
def _wrap_exponent(wrap: float, pitch_angle: float) -> float:
    return _positive("wrap", wrap) * math.cos(_pitch(pitch_angle))


def clove_hitch_critical_mu(pinch: float = 1.0, wrap: float = TWO_PI, pitch_angle: float = 0.0,
                            rope_friction_ratio: float = 1.0) -> float:
    """Smallest friction coefficient with which a clove hitch holds any pull with its tail free.

    Clove hitch: the standing part passes under the diagonal (the *rider*), turns once round the
    post, becomes the rider, turns once more the same way and passes under the rider again as the
    tail. Walking back from the free tail (tension 0): the tail's tension on the hitch side of the
    rider may be at most ``(mu + mu_rope) p T_r`` (the nip), and the last turn, from the rider's
    crossing over the tail round to the nip, multiplies by at most ``exp(mu wrap cos(pitch))``; the
    rider's own tension ``T_r`` must come back, which needs

        ``(1 + r) mu p exp(mu c) >= 1``,   ``c = wrap cos(pitch)``,   ``r = mu_rope / mu``,

    i.e. ``mu_c = W(c / ((1 + r) p)) / c`` (``W`` the principal Lambert function). The standing part,
    its nip and the first turn do not enter: whatever the load, they can pass on to the rider any
    tension the self-locking loop rider -> last turn -> nipped tail can hold.

    Parameters
    ----------
    pinch:
        Pinch factor ``p = N / T_r`` of the rider on the tail (>= 0). The string limit fixes the path
        (one turn, no pitch, point crossings) but not the crossing's strength; the default 1 is the
        unit pinch ``N = T_r``. For a rope of radius ``h`` on a post of radius ``R`` use
        :func:`pinch_factor` ``(h, R)``; in the strict string limit ``h / R -> 0``, ``p -> 0``.
    wrap:
        Azimuth of the last turn, from the rider's crossing over the tail to the tail's nip (rad).
    pitch_angle:
        Pitch angle of that turn, a helix (rad).
    rope_friction_ratio:
        ``r = mu_rope / mu`` (>= 0); the tail is nipped between post (``mu``) and rider (``mu_rope``).

    Returns
    -------
    float
        The critical ``mu``; ``math.inf`` if ``pinch == 0`` (no nip: the hitch never holds).
    """
    p = _nonneg("pinch", pinch)
    r = _nonneg("rope_friction_ratio", rope_friction_ratio)
    c = _wrap_exponent(wrap, pitch_angle)
    if p == 0.0:
        return math.inf
    return float(lambertw(c / ((1.0 + r) * p)).real) / c


def _increasing_root(f: Callable[[float], float]) -> float:
    """Root in ``mu > 0`` of an increasing ``f`` with ``f(0) < 0``; ``math.inf`` if none below _MU_MAX."""
    hi = 1.0
    while f(hi) < 0.0:
        hi *= 4.0
        if hi > _MU_MAX:
            return math.inf
    return float(brentq(f, 0.0, hi, xtol=1e-14, rtol=1e-13))


def clove_hitch_critical_mu_on_path(points: np.ndarray, pinch: float,
                                    rope_friction_ratio: float = 1.0) -> float:
    """Critical ``mu`` of a clove hitch whose last turn follows a given path on the post.

    As :func:`clove_hitch_critical_mu`, with the helix's ``exp(mu c)`` replaced by
    :func:`path_capstan_ratio` of the path: solves ``(1 + r) mu p ratio(mu) = 1``. For a simulated
    or drawn hitch, ``points`` is the rope's centre line from the rider's crossing over the tail to
    the tail's nip, the post's axis along ``z``.

    Parameters
    ----------
    points:
        ``(N, 3)`` path (m) on the post, post axis = ``z`` axis.
    pinch:
        Pinch factor of the rider on the tail (:func:`pinch_factor`).
    rope_friction_ratio:
        ``mu_rope / mu``.

    Returns
    -------
    float
        The critical ``mu`` (``math.inf`` if it never holds).
    """
    p = _nonneg("pinch", pinch)
    r = _nonneg("rope_friction_ratio", rope_friction_ratio)
    pts = np.asarray(points, dtype=float)
    if p == 0.0:
        return math.inf

    def f(mu: float) -> float:
        ratio = path_capstan_ratio(pts, mu)
        return 1.0 if math.isinf(ratio) else (1.0 + r) * mu * p * ratio - 1.0

    return _increasing_root(f)


def constrictor_critical_mu(pinch_rider: float = 1.0, pinch_standing: float = 1.0, wrap: float = TWO_PI,
                            pitch_angle: float = 0.0, rope_friction_ratio: float = 1.0) -> float:
    """Smallest friction coefficient with which a constrictor knot holds any pull, tail free.

    Constrictor: a clove hitch whose tail, under the rider, also passes under the standing part
    (the two ends form an overhand knot under the riding turn). At the crossing the stack is rider
    over standing part over tail over post. The tail is pressed by the rider's pinch, passed on
    through the standing part, plus the standing part's own pinch:
    ``N_tail = p_r T_r + p_s T_s``, and the standing part's tension at the crossing can be as large as
    ``T_r exp(mu c)`` (the first turn, read backwards from the rider). The standing part's tension
    is taken continuous through the crossing (its faces' friction is not used: it is not needed,
    and the tail uses the friction between them). The loop condition is

        ``(1 + r) mu (p_r + p_s exp(mu c)) exp(mu c) >= 1``,   ``c = wrap cos(pitch)``,

    increasing in ``mu``; the root is found numerically. The loaded standing part nips the tail, so
    the constrictor holds at a lower ``mu`` than the clove hitch with the same pinch factors.

    Parameters
    ----------
    pinch_rider:
        Pinch factor of the rider on the stack (its lift is two strands: :func:`pinch_factor` with
        ``layers=2``); default 1 (unit pinch).
    pinch_standing:
        Pinch factor of the standing part on the tail (``layers=1``); default 1.
    wrap:
        Azimuth of each turn between crossing and crossing (rad); one turn by default.
    pitch_angle:
        Pitch angle of the turns (rad).
    rope_friction_ratio:
        ``mu_rope / mu``.

    Returns
    -------
    float
        The critical ``mu``; ``math.inf`` if both pinch factors are 0.
    """
    pr = _nonneg("pinch_rider", pinch_rider)
    ps = _nonneg("pinch_standing", pinch_standing)
    r = _nonneg("rope_friction_ratio", rope_friction_ratio)
    c = _wrap_exponent(wrap, pitch_angle)
    if pr == 0.0 and ps == 0.0:
        return math.inf

    def f(mu: float) -> float:
        g = math.exp(min(c * mu, 700.0))
        return (1.0 + r) * mu * (pr + ps * g) * g - 1.0

    return _increasing_root(f)


def two_half_hitches_critical_mu(pinch: float = EQUAL_RADII_PINCH, wrap: float = TWO_PI,
                                 pitch_angle: float = 0.0) -> float:
    """Critical rope-on-rope friction coefficient of two half hitches (tail free).

    Two half hitches made the same way round the standing part are a clove hitch tied round the
    standing part, which is then the "post": the self-locking loop is that of
    :func:`clove_hitch_critical_mu` with rope on rope on both faces of the nipped tail (``r = 1``,
    ``mu`` is the rope–rope coefficient). The turn round the post (or ring) before the half hitches
    only lowers the tension that reaches them, so it does not enter. Outside the string limit: the
    "post" has the rope's own radius and is soft, so the default pinch is the lift-over value for
    equal radii, ``p = sqrt(3)`` (centre-line radius ``2 h``, lift ``2 h``, ``beta = 60 deg``).

    Parameters
    ----------
    pinch:
        Pinch factor of the rider on the tail (default ``sqrt(3)``).
    wrap:
        Azimuth of the last turn round the standing part (rad).
    pitch_angle:
        Pitch angle of that turn (rad).

    Returns
    -------
    float
        The critical rope–rope ``mu``.
    """
    return clove_hitch_critical_mu(pinch=pinch, wrap=wrap, pitch_angle=pitch_angle, rope_friction_ratio=1.0)


def round_turn_two_half_hitches_critical_mu(pinch: float = EQUAL_RADII_PINCH, wrap: float = TWO_PI,
                                            pitch_angle: float = 0.0) -> float:
    """Critical rope-on-rope ``mu`` of a round turn and two half hitches (tail free).

    The round turn divides the tension that reaches the half hitches by up to
    ``exp(mu_post 4 pi)``, which makes the knot hold a load while it is being finished and eases
    the half hitches, but the self-locking condition is independent of the load, hence the same as
    for :func:`two_half_hitches_critical_mu`. Parameters and return value as there.
    """
    return two_half_hitches_critical_mu(pinch=pinch, wrap=wrap, pitch_angle=pitch_angle)


#: hitch name (as in the knot library) -> function giving its critical friction coefficient
HITCHES: dict[str, Callable[..., float]] = {
    "clove_hitch": clove_hitch_critical_mu,
    "constrictor": constrictor_critical_mu,
    "two_half_hitches": two_half_hitches_critical_mu,
    "round_turn_two_half_hitches": round_turn_two_half_hitches_critical_mu,
}


def holds(hitch: str, mu: float, **geometry: float) -> bool:
    """Whether a hitch holds any pull on its standing part, tail free, in the string-limit model.

    Parameters
    ----------
    hitch:
        A name of :data:`HITCHES` (``"clove_hitch"``, ``"constrictor"``, ``"two_half_hitches"``,
        ``"round_turn_two_half_hitches"``).
    mu:
        Friction coefficient (dimensionless, >= 0): rope on post, or rope on rope for the half
        hitches.
    **geometry:
        Keyword arguments of that hitch's critical-mu function (pinch factors, wrap, pitch angle,
        friction ratio).

    Returns
    -------
    bool
        ``mu >= critical mu`` (at equality it holds, just).
    """
    if hitch not in HITCHES:
        raise ConfigError("hitch", f"unknown hitch {hitch!r}; known: {', '.join(sorted(HITCHES))}")
    mu = _nonneg("mu", mu)
    accepted = inspect.signature(HITCHES[hitch]).parameters
    unknown = sorted(set(geometry) - set(accepted))
    if unknown:
        raise ConfigError("geometry", f"{hitch} takes {', '.join(accepted)}; not {', '.join(unknown)}")
    return mu >= HITCHES[hitch](**geometry)


# ----------------------------------------------------------------------------- stiffness
def stiff_pinch_gain(pinch_number: float) -> float:
    """Ratio of a stiff rope's pinch to the string's, ``g = N_stiff / N_string >= 1``.

    Linearised (small slopes) beam of bending stiffness ``EI`` under tension ``T``, lying on the
    cylinder of radius ``R_c`` and lifted at one point by ``delta`` (the crossed strand, ``2 h``).
    Off the post it obeys ``EI w'''' - T w'' = -T / R_c`` (``w`` its lift off the cylinder); it
    leaves the post with continuous curvature (``w = w' = w'' = 0``) at ``|x| = a`` and is smooth over
    the point support. The string's tent has ``a_s = sqrt(2 R_c delta)`` and pinch
    ``N_s = 2 T a_s / R_c``; with ``Lambda = sqrt(EI / T) / a_s`` (:attr:`StiffnessCorrection.pinch_number`)
    the ratio depends on ``Lambda`` only: ``g = 1 + Lambda + O(Lambda^3)`` for a nearly flexible rope
    and ``g ~ sqrt(8 Lambda / 3)`` for a stiff one (it bridges a longer span, so more of its load on
    the post goes onto the crossing). A leading-order result (linear theory, a point crossing).

    Parameters
    ----------
    pinch_number:
        ``Lambda >= 0`` (0: the string, ``g = 1``).

    Returns
    -------
    float
        ``g``.
    """
    lam = _nonneg("pinch_number", pinch_number)
    if lam < 1e-6:
        return 1.0 + lam

    def coefficients(a: float) -> tuple[float, float, float, float, float]:
        # w / delta = X^2 + C0 + C1 X + D1 exp((X - A)/L) + D2 exp(-X/L),  X = x / a_s
        e = math.exp(-a / lam)
        m = np.array([[1.0, 0.0, e, 1.0],                        # W(0) = 1
                      [0.0, 1.0, e / lam, -1.0 / lam],           # W'(0) = 0
                      [0.0, 1.0, 1.0 / lam, -e / lam],           # W'(A) = 0 (with 2A)
                      [0.0, 0.0, 1.0 / lam**2, e / lam**2]])     # W''(A) = 0 (with 2)
        c0, c1, d1, d2 = np.linalg.solve(m, np.array([1.0, 0.0, -2.0 * a, -2.0]))
        return float(c0), float(c1), float(d1), float(d2), e

    def residual(a: float) -> float:
        c0, c1, d1, d2, e = coefficients(a)
        return a * a + c0 + c1 * a + d1 + d2 * e  # W(A) = 0

    lo, hi = 1.0, 2.0 + 3.0 * lam + 3.0 * math.sqrt(lam)
    a = float(brentq(residual, lo, hi, xtol=1e-13, rtol=1e-13))
    _, _, d1, d2, e = coefficients(a)
    return 0.5 * abs(d1 * e - d2) / lam


@dataclass(frozen=True)
class StiffnessCorrection:
    """How far a stiff rope is from the string limit, at one tension (leading-order trends).

    Attributes
    ----------
    bending_number:
        ``eps = EI / (T R_c^2)``: bending against tension at the post's scale.
    tension_offset:
        ``B = EI / (2 R_c^2)`` (N): a rope leaving the post into a straight free part loses ``B`` of
        axial force on the post (``T + EI kappa^2 / 2`` is constant along a free span); a free tail
        (far tension 0) would be in compression ``-B`` on the post, so it springs off, and the wraps
        carry ``T - B`` (:func:`stiff_capstan_ratio`).
    liftoff_angle:
        ``theta_0 = 2 asin(sqrt(eps) / 2)`` (rad): wrap lost at each free end (the rope leaves the post
        early, with its curvature ``1 / R_c``; a concentrated contact force there makes up for it to
        first order); ``pi`` if ``eps >= 4`` (the rope cannot wrap).
    pinch_number:
        ``Lambda = sqrt(EI / T) / (2 sqrt(h R_c))``: bending length over the string's lift-off span at a
        crossing (``nan`` for ``h = 0``).
    pinch_gain:
        ``g(Lambda) >= 1`` (:func:`stiff_pinch_gain`): the crossing's pinch factor is ``g`` times the
        string's.
    """

    bending_number: float
    tension_offset: float
    liftoff_angle: float
    pinch_number: float
    pinch_gain: float


def stiffness_correction(bending_stiffness: float, tension: float, post_radius: float,
                         rope_radius: float) -> StiffnessCorrection:
    """Dimensionless measures of bending stiffness for a hitch under a given tension.

    The string-limit conditions of this module are the large-load limit: every correction vanishes
    as ``T -> inf`` at fixed ``EI``, ``h``, ``R``. To leading order the crossing's pinch grows by
    ``g - 1 ~ Lambda ~ sqrt(EI / (T h R_c)) / 2`` (helps holding), while the free tail and the ends
    cost ``B / T = eps / 2 ~ EI / (2 T R_c^2)`` (hurts); with ``Lambda^2 = eps R_c / (4 h)`` the
    first is the larger at small ``eps``, the more so for a thin rope. Not included: the moment
    ``EI / R_c`` with which the nip must clamp a tail that leaves straight, and the contact's width
    (it is not a line for ``h`` comparable with ``R``). These are trends for comparing simulations,
    not a full theory.

    Parameters
    ----------
    bending_stiffness:
        ``EI`` (N m^2, >= 0).
    tension:
        Tension ``T`` (N, > 0) at which to evaluate (e.g. the rider's).
    post_radius:
        ``R`` (m, > 0).
    rope_radius:
        ``h`` (m, >= 0); ``R_c = R + h``.

    Returns
    -------
    StiffnessCorrection
    """
    ei = _nonneg("bending_stiffness", bending_stiffness)
    t = _positive("tension", tension)
    r = _positive("post_radius", post_radius)
    h = _nonneg("rope_radius", rope_radius)
    rc = r + h
    eps = ei / (t * rc * rc)
    theta0 = math.pi if eps >= 4.0 else 2.0 * math.asin(math.sqrt(eps) / 2.0)
    if h > 0.0:
        lam = math.sqrt(ei / t) / (2.0 * math.sqrt(h * rc))
        gain = stiff_pinch_gain(lam)
    else:
        lam, gain = math.nan, math.nan
    return StiffnessCorrection(bending_number=eps, tension_offset=ei / (2.0 * rc * rc), liftoff_angle=theta0,
                               pinch_number=lam, pinch_gain=gain)


def stiff_capstan_ratio(mu: float, angle: float, tension_in: float, bending_stiffness: float,
                        radius: float) -> float:
    """Largest ``T_out / T_in`` for an elastic rope (planar elastica) wrapped on a post.

    ``T_in``, ``T_out``: tensions of the straight far parts; ``angle``: their total turning. Each free
    part meets the post with curvature ``1 / R`` at the angle ``theta_0`` of
    :class:`StiffnessCorrection` (``cos(theta_0) = 1 - eps / 2``, ``eps = EI / (T R^2)``), with a
    concentrated contact force ``T sin(theta_0)`` that allows a friction jump; in between the contact
    arc ``angle - theta_0,in - theta_0,out`` obeys the capstan law for the axial force:

        ``T_a = T_in (cos th_in + mu sin th_in)``,  ``T_b = T_a exp(mu (angle - th_in - th_out))``,
        ``T_out (cos th_out - mu sin th_out) = T_b``,

    solved for ``T_out`` (``th_out`` depends on it). To first order in ``eps``:
    ``T_out - B' = (T_in - B') exp(mu angle)``, ``B' = (1 + mu^2) EI / (2 R^2)``. Planar (no pitch).

    Parameters
    ----------
    mu:
        Friction coefficient (>= 0).
    angle:
        Total turning of the rope between its straight parts (rad); must exceed the two lift-off
        angles.
    tension_in:
        Low-side tension (N); must be at least ``EI / (4 R^2)`` (``eps <= 4``).
    bending_stiffness:
        ``EI`` (N m^2, >= 0).
    radius:
        Radius of the rope's centre line on the post, ``R + h`` (m, > 0).

    Returns
    -------
    float
        ``T_out / T_in`` (``exp(mu angle)`` for ``EI = 0``).
    """
    mu = _nonneg("mu", mu)
    angle = _nonneg("angle", angle)
    t_in = _positive("tension_in", tension_in)
    ei = _nonneg("bending_stiffness", bending_stiffness)
    rc = _positive("radius", radius)
    if ei == 0.0:
        return math.exp(mu * angle)

    def lift(t: float) -> float:
        eps = ei / (t * rc * rc)
        if eps > 4.0:
            raise ConfigError("tension_in", f"a tension {t:.3g} N is below EI/(4 R^2) = {ei / (4 * rc * rc):.3g} N: "
                                            f"the rope cannot wrap the post")
        return 2.0 * math.asin(math.sqrt(eps) / 2.0)

    th_in = lift(t_in)
    t_a = t_in * (math.cos(th_in) + mu * math.sin(th_in))

    def residual(t_out: float) -> float:
        th_out = lift(t_out)
        arc = angle - th_in - th_out
        if arc < 0.0:
            raise ConfigError("angle", f"{angle:.3g} rad is less than the lift-off angles {th_in + th_out:.3g} rad")
        return t_out * (math.cos(th_out) - mu * math.sin(th_out)) - t_a * math.exp(mu * arc)

    lo = max(t_in, ei / (4.0 * rc * rc))
    hi = 2.0 * lo
    while residual(hi) < 0.0:
        hi *= 2.0
    return float(brentq(residual, lo, hi, xtol=1e-15, rtol=1e-13)) / t_in
