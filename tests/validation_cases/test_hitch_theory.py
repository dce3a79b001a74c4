"""The string-limit theory of hitches (``knotsim.validation.hitch_theory``, ``docs/physics.md`` §4.5)
against exact values, brute-force computations and its own limits."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.integrate import quad
from scipy.optimize import linprog
from scipy.sparse.linalg import spsolve

from knotsim.errors import ConfigError
from knotsim.validation import hitch_theory as ht

TWO_PI = 2.0 * math.pi


# ----------------------------------------------------------------------------- helpers
def _helix(radius: float, wrap: float, pitch: float, n: int) -> np.ndarray:
    """Polyline on the cylinder whose n interior vertices each turn by wrap / n (total: wrap)."""
    d = wrap / n
    phi = (np.arange(n + 2) - 0.5) * d
    return np.column_stack([radius * np.cos(phi), radius * np.sin(phi), radius * math.tan(pitch) * phi])


def _vertex_coefficients(wrap: float, pitch: float, n: int) -> tuple[float, float]:
    """(q, m) of a uniform discrete helix: the friction cone at a vertex is
    ``q |T_k - T_{k-1}| <= mu m (T_k + T_{k-1})`` (in-plane edge component q, normal component m)."""
    x = _helix(1.0, wrap, pitch, n)
    t = np.diff(x, axis=0)
    t /= np.linalg.norm(t, axis=1)[:, None]
    nrm = np.array([x[1, 0], x[1, 1], 0.0]) / np.hypot(x[1, 0], x[1, 1])
    m = float(t[0] @ nrm)
    q = float(np.linalg.norm(t[0] - m * nrm))
    return q, m


class _Chain:
    """Linear feasibility problem in edge tensions (all >= 0), solved by linprog."""

    def __init__(self) -> None:
        self.n_var = 0
        self.rows: list[dict[int, float]] = []
        self.eq: list[tuple[dict[int, float], float]] = []

    def new(self, k: int = 1) -> list[int]:
        out = list(range(self.n_var, self.n_var + k))
        self.n_var += k
        return out

    def le(self, coefs: dict[int, float]) -> None:  # sum c_i T_i <= 0
        self.rows.append(coefs)

    def turn(self, edges: list[int], mu: float, q: float, m: float) -> None:
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            self.le({a: q - mu * m, b: -q - mu * m})
            self.le({a: -q - mu * m, b: q - mu * m})

    def feasible(self) -> bool:
        a = np.zeros((len(self.rows), self.n_var))
        for i, row in enumerate(self.rows):
            for j, c in row.items():
                a[i, j] += c
        aeq = np.zeros((len(self.eq), self.n_var))
        for i, (row, _) in enumerate(self.eq):
            for j, c in row.items():
                aeq[i, j] += c
        res = linprog(np.zeros(self.n_var), A_ub=a, b_ub=np.zeros(len(self.rows)), A_eq=aeq,
                      b_eq=[v for _, v in self.eq], bounds=[(0, None)] * self.n_var, method="highs")
        assert res.status in (0, 2), res.message
        return res.status == 0


def _clove_holds_lp(mu: float, pinch: float, wrap: float, pitch: float, r: float, n: int) -> bool:
    """Whole clove hitch, standing part included: load 1 -> nip under the rider -> turn 1 -> rider
    -> turn 2 -> nip under the rider -> tail 0."""
    q, m = _vertex_coefficients(wrap, pitch, n)
    c = _Chain()
    load = c.new()[0]
    turn1 = c.new(n + 1)
    turn2 = [turn1[-1], *c.new(n)]  # the rider is the last edge of turn 1 and the first of turn 2
    rider = turn1[-1]
    nip = (1.0 + r) * mu * pinch
    c.le({load: 1.0, turn1[0]: -1.0, rider: -nip})  # |T_load - T| <= nip T_r
    c.le({load: -1.0, turn1[0]: 1.0, rider: -nip})
    c.turn(turn1, mu, q, m)
    c.turn(turn2, mu, q, m)
    c.le({turn2[-1]: 1.0, rider: -nip})  # the tail's tension falls to 0 at the nip
    c.eq.append(({load: 1.0}, 1.0))
    return c.feasible()


def _constrictor_holds_lp(mu: float, p_rider: float, p_standing: float, wrap: float, r: float, n: int) -> bool:
    """Constrictor: standing part (continuous through the stack) -> turn 1 -> rider -> turn 2 -> tail,
    nipped under standing part and rider."""
    q, m = _vertex_coefficients(wrap, 0.0, n)
    c = _Chain()
    turn1 = c.new(n + 1)
    turn2 = [turn1[-1], *c.new(n)]
    rider, standing = turn1[-1], turn1[0]
    k = (1.0 + r) * mu
    c.turn(turn1, mu, q, m)
    c.turn(turn2, mu, q, m)
    c.le({turn2[-1]: 1.0, rider: -k * p_rider, standing: -k * p_standing})
    c.eq.append(({standing: 1.0}, 1.0))
    return c.feasible()


def _bisect(holds, lo: float = 0.0, hi: float = 1.0, tol: float = 1e-5) -> float:
    assert holds(hi) and not holds(lo)
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if holds(mid):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


# ----------------------------------------------------------------------------- capstan
@pytest.mark.parametrize("mu", [0.0, 0.1, 0.35, 1.2])
@pytest.mark.parametrize("angle", [0.0, 0.5 * math.pi, TWO_PI, 5.0 * math.pi])
def test_capstan_is_the_exponential(mu, angle):
    assert ht.capstan_ratio(mu, angle) == pytest.approx(math.exp(mu * angle), rel=1e-15)
    assert ht.capstan_ratio(mu, angle, pitch_angle=0.4) == pytest.approx(math.exp(mu * angle * math.cos(0.4)),
                                                                      rel=1e-15)


@pytest.mark.parametrize("pitch", [0.0, 0.3, -0.7])
def test_discrete_path_on_a_helix_gives_the_helical_capstan(pitch):
    mu, wrap = 0.25, 3.0 * math.pi
    ratio = ht.path_capstan_ratio(_helix(0.01, wrap, pitch, 3000), mu)
    assert ratio == pytest.approx(math.exp(mu * wrap * math.cos(pitch)), rel=2e-5)


def test_discrete_path_pays_for_geodesic_curvature():
    """A wavy path: the march equals exp(int sqrt(mu^2 kn^2 - kg^2) ds) and is below exp(mu int kn ds)."""
    radius, mu, amp, k, wrap = 0.02, 0.3, 0.05, 2.0, TWO_PI
    d = wrap / 6000
    phi = (np.arange(6002) - 0.5) * d
    pts = np.column_stack([radius * np.cos(phi), radius * np.sin(phi), amp * radius * np.sin(k * phi)])

    def slope(x):
        return amp * k * math.cos(k * x / radius)

    def kg(x):
        return -amp * k * k / radius * math.sin(k * x / radius) / (1.0 + slope(x) ** 2) ** 1.5

    def kn(x):
        return 1.0 / (radius * (1.0 + slope(x) ** 2))

    def ds(x):
        return math.sqrt(1.0 + slope(x) ** 2)

    log_cone = quad(lambda x: math.sqrt(mu**2 * kn(x) ** 2 - kg(x) ** 2) * ds(x), 0.0, radius * wrap, limit=200)[0]
    log_free = quad(lambda x: mu * kn(x) * ds(x), 0.0, radius * wrap, limit=200)[0]
    ratio = ht.path_capstan_ratio(pts, mu)
    assert math.log(ratio) == pytest.approx(log_cone, rel=1e-3)
    assert log_cone < log_free - 0.01  # the sideways friction is not free
    # a path that turns sideways more than friction can hold slides: nothing is held
    wild = pts.copy()
    wild[:, 2] = 0.6 * radius * np.sin(4.0 * phi)
    assert ht.path_capstan_ratio(wild, mu) == 0.0


# ----------------------------------------------------------------------------- crossings
@pytest.mark.parametrize("h_over_r", [1e-4, 0.01, 0.2, 1.0])
@pytest.mark.parametrize("pitch", [0.0, 0.5])
def test_pinch_factor_is_the_turning_of_the_lifted_string(h_over_r, pitch):
    """Build the tent: tangents from the top of the crossed strand to the normal section's circle."""
    post, h = 1.0, h_over_r
    rn = (post + h) / math.cos(pitch) ** 2
    apex = np.array([rn + 2.0 * h, 0.0])
    # tangent point P = rn (cos b, sin b) with (P - apex) . P = 0
    from scipy.optimize import brentq

    b = brentq(lambda s: (rn * math.cos(s) - apex[0]) * math.cos(s) + rn * math.sin(s) ** 2, 1e-12, 0.5 * math.pi)
    p_point = rn * np.array([math.cos(b), math.sin(b)])
    t_in = (apex - p_point) / np.linalg.norm(apex - p_point)
    t_out = t_in * np.array([-1.0, 1.0])  # down the mirror-image chord
    assert ht.pinch_factor(h, post, pitch_angle=pitch) == pytest.approx(np.linalg.norm(t_out - t_in), rel=1e-9)


def test_pinch_factor_limits_and_order():
    assert ht.pinch_factor(0.0, 1.0) == 0.0  # the strict string limit pinches nothing
    for h in (1e-6, 1e-4):
        assert ht.pinch_factor(h, 1.0) == pytest.approx(4.0 * math.sqrt(h / (1.0 + h)), rel=2e-2)
    assert ht.pinch_factor(1.0, 1.0) == pytest.approx(math.sqrt(3.0), rel=1e-12)  # equal radii: beta = 60 deg
    assert ht.pinch_factor(0.002, 0.01) == pytest.approx(math.sqrt(7.0) / 2.0, rel=1e-12)  # the library's post
    hs = [1e-3, 0.01, 0.1, 0.5, 2.0]
    assert np.all(np.diff([ht.pinch_factor(h, 1.0) for h in hs]) > 0)
    assert ht.pinch_factor(0.1, 1.0, layers=2) > ht.pinch_factor(0.1, 1.0)
    assert ht.pinch_factor(0.1, 1.0, pitch_angle=0.6) < ht.pinch_factor(0.1, 1.0)
    with pytest.raises(ConfigError):
        ht.pinch_factor(0.1, 1.0, layers=0)
    with pytest.raises(ConfigError):
        ht.pinch_factor(0.0, 0.0)


# ----------------------------------------------------------------------------- the hitches
@pytest.mark.parametrize(("pinch", "pitch", "r"), [(1.0, 0.0, 1.0), (0.5, 0.3, 1.0), (1.5, 0.0, 0.5),
                                                   (math.sqrt(7.0) / 2.0, 0.0, 1.0)])
def test_clove_closed_form_against_the_whole_hitch_by_linear_programming(pinch, pitch, r):
    """Bisection on mu of the feasibility of the discretised hitch (standing part, both nips and
    both turns, no assumption on which part limits it) against W(c/((1+r)p))/c."""
    mu_c = _bisect(lambda mu: _clove_holds_lp(mu, pinch, TWO_PI, pitch, r, n=200))
    assert mu_c == pytest.approx(ht.clove_hitch_critical_mu(pinch=pinch, pitch_angle=pitch, rope_friction_ratio=r),
                                 rel=5e-4)


@pytest.mark.parametrize(("p_rider", "p_standing", "r"), [(1.0, 1.0, 1.0), (1.6, math.sqrt(7.0) / 2.0, 1.0),
                                                          (0.5, 1.5, 0.3)])
def test_constrictor_root_against_linear_programming(p_rider, p_standing, r):
    mu_c = _bisect(lambda mu: _constrictor_holds_lp(mu, p_rider, p_standing, TWO_PI, r, n=200))
    assert mu_c == pytest.approx(ht.constrictor_critical_mu(pinch_rider=p_rider, pinch_standing=p_standing,
                                                            rope_friction_ratio=r), rel=5e-4)


def test_clove_on_a_drawn_helical_path_is_the_closed_form():
    for pitch in (0.0, 0.4):
        pts = _helix(0.012, TWO_PI, pitch, 2000)
        got = ht.clove_hitch_critical_mu_on_path(pts, pinch=1.2)
        assert got == pytest.approx(ht.clove_hitch_critical_mu(pinch=1.2, pitch_angle=pitch), rel=1e-4)


def test_stated_numbers():
    """The numbers of the table in docs/physics.md §4.5."""
    assert ht.clove_hitch_critical_mu() == pytest.approx(0.1708780, abs=1e-7)
    w_pi = ht.clove_hitch_critical_mu() * TWO_PI  # W(pi): w e^w = pi
    assert w_pi * math.exp(w_pi) == pytest.approx(math.pi, rel=1e-12)
    assert ht.constrictor_critical_mu() == pytest.approx(0.0963629, abs=1e-7)
    assert ht.two_half_hitches_critical_mu() == pytest.approx(0.1286411, abs=1e-7)
    assert ht.round_turn_two_half_hitches_critical_mu() == ht.two_half_hitches_critical_mu()
    # the knot library's clove hitch: rope radius 2 mm on a 10 mm post
    p = ht.pinch_factor(0.002, 0.01)
    assert ht.clove_hitch_critical_mu(pinch=p) == pytest.approx(0.1485893, abs=1e-7)
    p2 = ht.pinch_factor(0.002, 0.01, layers=2)
    assert ht.constrictor_critical_mu(pinch_rider=p2, pinch_standing=p) == pytest.approx(0.0799283, abs=1e-7)
    # thin cord on a thick post: the strict string limit is approached only logarithmically
    assert ht.clove_hitch_critical_mu(pinch=ht.pinch_factor(1e-4, 1.0)) == pytest.approx(0.509, abs=1e-3)


def test_monotone_in_the_geometry():
    wraps = [math.pi, TWO_PI, 3 * math.pi, 4 * math.pi]
    pinches = [0.2, 0.5, 1.0, 1.9]
    pitches = [0.0, 0.3, 0.6, 1.0]
    ratios = [0.0, 0.5, 1.0, 2.0]
    for f in (ht.clove_hitch_critical_mu, ht.constrictor_critical_mu):
        assert np.all(np.diff([f(wrap=w) for w in wraps]) < 0)
        assert np.all(np.diff([f(pitch_angle=a) for a in pitches]) > 0)
        assert np.all(np.diff([f(rope_friction_ratio=r) for r in ratios]) < 0)
    assert np.all(np.diff([ht.clove_hitch_critical_mu(pinch=p) for p in pinches]) < 0)
    assert np.all(np.diff([ht.constrictor_critical_mu(pinch_rider=p) for p in pinches]) < 0)
    assert np.all(np.diff([ht.constrictor_critical_mu(pinch_standing=p) for p in pinches]) < 0)
    # thicker rope (relative to the post) pinches harder, so holds with less friction
    hs = [1e-3, 0.01, 0.05, 0.2, 1.0]
    assert np.all(np.diff([ht.clove_hitch_critical_mu(pinch=ht.pinch_factor(h, 1.0)) for h in hs]) < 0)
    # the loaded standing part nips the tail of the constrictor: it needs less than the clove hitch
    for p in pinches:
        assert ht.constrictor_critical_mu(pinch_rider=p, pinch_standing=p) < ht.clove_hitch_critical_mu(pinch=p)


def test_holds_and_never_holds():
    mu_c = ht.clove_hitch_critical_mu()
    assert ht.holds("clove_hitch", mu_c * 1.001)
    assert not ht.holds("clove_hitch", mu_c * 0.999)
    assert ht.holds("constrictor", 0.1) and not ht.holds("clove_hitch", 0.1)
    assert ht.holds("two_half_hitches", 0.2, pinch=1.0)
    # no pinch (the strict string limit): never holds, whatever the friction
    assert ht.clove_hitch_critical_mu(pinch=0.0) == math.inf
    assert ht.constrictor_critical_mu(pinch_rider=0.0, pinch_standing=0.0) == math.inf
    assert not ht.holds("clove_hitch", 1e3, pinch=0.0)
    assert set(ht.HITCHES) == {"clove_hitch", "constrictor", "two_half_hitches", "round_turn_two_half_hitches"}
    with pytest.raises(ConfigError):
        ht.holds("cow_hitch", 0.5)
    with pytest.raises(ConfigError):
        ht.holds("clove_hitch", 0.5, turns=2)
    with pytest.raises(ConfigError):
        ht.holds("clove_hitch", -0.1)
    with pytest.raises(ConfigError):
        ht.clove_hitch_critical_mu(pitch_angle=0.5 * math.pi)


# ----------------------------------------------------------------------------- stiffness
def _discrete_lift_over_gain(lam: float, n: int = 400) -> float:
    """Pinch of a beam under tension lifted over a point on a rigid cylinder, by minimising its
    discrete energy EI/2 int w''^2 + T/2 int w'^2 + T/R int w (lift w >= 0, w(0) = delta) with an
    active-set scan over the lift-off node; the pinch is dE/d(delta) at node 0 (both halves)."""
    radius, delta, tension = 1.0, 1e-4, 1.0
    a_s = math.sqrt(2.0 * radius * delta)
    ei = tension * (lam * a_s) ** 2
    x = np.linspace(0.0, a_s * (3.0 + 4.0 * math.sqrt(lam) + 2.0 * lam), n)
    dx = x[1] - x[0]
    d2 = sp.lil_matrix((n - 1, n))
    d2[0, 0], d2[0, 1] = -2.0, 2.0  # symmetric: ghost node w_{-1} = w_1
    for j in range(1, n - 1):
        d2[j, j - 1], d2[j, j], d2[j, j + 1] = 1.0, -2.0, 1.0
    d2 = d2.tocsr() / dx**2
    d1 = sp.diags([-np.ones(n - 1), np.ones(n - 1)], [0, 1], shape=(n - 1, n)).tocsr() / dx
    w2 = np.ones(n - 1)
    w2[0] = 0.5
    w0 = np.ones(n)
    w0[0] = 0.5
    k = (ei * dx * d2.T @ sp.diags(w2) @ d2 + tension * dx * d1.T @ d1).tocsc()
    f = tension / radius * dx * w0
    best = None
    for m in range(3, n - 2):
        free = np.arange(1, m)
        w = np.zeros(n)
        w[0] = delta
        w[free] = spsolve(k[free][:, free], -(f[free] + k[free][:, [0]].toarray().ravel() * delta))
        if w[free].min() < -1e-9 * delta:
            continue
        energy = 0.5 * w @ (k @ w) + f @ w
        if best is None or energy < best[0]:
            best = (energy, w)
    assert best is not None
    w = best[1]
    pinch = 2.0 * (k @ w + f)[0]
    return pinch / (2.0 * tension * a_s / radius)


@pytest.mark.parametrize("lam", [0.3, 1.0])
def test_stiff_pinch_gain_against_the_discrete_obstacle_problem(lam):
    assert ht.stiff_pinch_gain(lam) == pytest.approx(_discrete_lift_over_gain(lam), rel=2e-3)


def test_stiff_pinch_gain_limits():
    assert ht.stiff_pinch_gain(0.0) == 1.0
    for lam in (1e-3, 1e-2):
        assert ht.stiff_pinch_gain(lam) == pytest.approx(1.0 + lam, rel=1e-6)
    assert ht.stiff_pinch_gain(1e4) == pytest.approx(math.sqrt(8e4 / 3.0), rel=1e-3)
    lams = [0.0, 0.01, 0.1, 1.0, 10.0]
    assert np.all(np.diff([ht.stiff_pinch_gain(v) for v in lams]) > 0)


def test_stiff_capstan():
    mu, angle, radius = 0.3, TWO_PI, 0.01
    assert ht.stiff_capstan_ratio(mu, angle, 2.0, 0.0, radius) == pytest.approx(math.exp(mu * angle), rel=1e-14)
    errors = []
    for eps in (1e-2, 1e-3):
        ei = eps * 1.0 * radius**2
        b = (1.0 + mu * mu) * ei / (2.0 * radius**2)
        first_order = b + (1.0 - b) * math.exp(mu * angle)
        got = ht.stiff_capstan_ratio(mu, angle, 1.0, ei, radius)
        errors.append(abs(got - first_order) / first_order)
        assert got < math.exp(mu * angle)  # bending costs holding power
    assert errors[1] < errors[0] / 20.0  # the error is of higher order (eps^1.5)
    eis = [0.0, 1e-8, 1e-7, 1e-6]
    assert np.all(np.diff([ht.stiff_capstan_ratio(mu, angle, 1.0, e, radius) for e in eis]) < 0)
    with pytest.raises(ConfigError):
        ht.stiff_capstan_ratio(mu, angle, 1e-3, 1e-6, radius)  # eps > 4: it cannot wrap


def test_stiffness_correction_numbers():
    ei, t, post, h = 2.26e-6, 0.1, 0.01, 0.002
    s = ht.stiffness_correction(ei, t, post, h)
    rc = post + h
    assert s.bending_number == pytest.approx(ei / (t * rc**2))
    assert s.tension_offset == pytest.approx(ei / (2 * rc**2))
    assert math.cos(s.liftoff_angle) == pytest.approx(1.0 - s.bending_number / 2.0, rel=1e-12)
    assert s.pinch_number == pytest.approx(math.sqrt(ei / t) / (2 * math.sqrt(h * rc)))
    assert s.pinch_gain == pytest.approx(ht.stiff_pinch_gain(s.pinch_number))
    # the string limit is the large-load limit
    big = ht.stiffness_correction(ei, 1e6, post, h)
    assert big.bending_number < 1e-7 and big.pinch_gain == pytest.approx(1.0, abs=1e-3)
    assert ht.stiffness_correction(1.0, 1e-3, post, h).liftoff_angle == math.pi
    assert math.isnan(ht.stiffness_correction(ei, t, post, 0.0).pinch_number)
