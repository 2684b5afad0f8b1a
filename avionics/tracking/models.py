"""Motion models of the IMM mode filters: transition F and process noise Q for any step dt, vectorised over dt.

State layouts (Baek & Bang eq 1):

    horizontal  X_H = [x, y, vx, vy, ax, ay]      x = east, y = north (m, m/s, m/s^2)
    vertical    X_V = [z, vz]                     z = altitude in the intruder's datum

Every builder takes `dt` as a scalar or an array of shape (B,) and returns arrays of shape (B, n, n), so one call
serves all tracks of a batch whatever their report intervals. The papers define the discrete models for a
sampling period T; here T = dt of each step (an irregular ADS-B interval or a prediction horizon).

| mode | source | F | Q |
| --- | --- | --- | --- |
| CV  | Baek & Bang eq 5, Hwang eq 16 | position += T v; acceleration states zeroed | B Q_CV B^T, B = [T^2/2, T, 0] |
| CA  | Baek & Bang eq 6 with eq 31 | constant acceleration | B Q_CA(psi) B^T, B = [T^2/2, T, 1], eq 31 heading-rotated |
| CT  | Hwang eq 18 (Wiener-sequence acceleration) | constant acceleration | G G^T sigma^2, G = [T^2/2, T, 1] |
| CS  | Dai eqs 8-12 (Zhou's current statistical model) | eq 10 | 2 alpha sigma_a^2 q(T), eq 11-12 |
| turn | Bar-Shalom, Li & Kirubarajan 2001 eq 11.7.1-4 (coordinated turn at a known rate omega) | velocity rotated by omega T | as CV |
| CH  | Baek & Bang eq 7 | [[1, T], [0, 1]] | sigma^2 [T, 1][T, 1]^T |
| CAD | Baek & Bang eq 8 | [[1, T], [0, 1]] | sigma^2 [T^2, T][T^2, T]^T |

Each model is returned as (F_mean, F_cov, Q): the mean is propagated with F_mean, the covariance with F_cov.
They differ only for CS, whose mean acceleration a-bar is an input (Dai eq 8, 29), not a state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

H_DIM = 6  # [x, y, vx, vy, ax, ay]
V_DIM = 2  # [z, vz]
CV_ACCEL_FLOOR_MPS2 = 1e-3  # CV zeroes the acceleration states; this floor keeps the covariance positive definite

# Gauss-Legendre nodes on [0, 1] for the CS process-noise integral (exact to degree 15; the integrand is smooth)
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
_GL_X = 0.5 * (_GL_X + 1.0)
_GL_W = 0.5 * _GL_W


def _dt(dt) -> np.ndarray:
    return np.atleast_1d(np.asarray(dt, float))


def per_axis_to_horizontal(m3: np.ndarray) -> np.ndarray:
    """(..., 3, 3) per-axis [p, v, a] matrix -> (..., 6, 6) block on [x, y, vx, vy, ax, ay], same for x and y."""
    out = np.zeros(m3.shape[:-2] + (6, 6))
    out[..., 0::2, 0::2] = m3
    out[..., 1::2, 1::2] = m3
    return out


class _Poly:
    """A matrix whose entries are polynomials in T: M(T) = sum_p T^p C_p, evaluated for a batch of T by one
    matrix product (B, P) @ (P, n*n). Weighted terms (eq 31's cos^2 / sin^2) stack as extra columns."""

    def __init__(self, *coeffs: np.ndarray):
        # coeffs: one (P, n, n) tensor per weight group
        self.p = coeffs[0].shape[0]
        self.shape = coeffs[0].shape[1:]
        self.c = np.concatenate([c.reshape(self.p, -1) for c in coeffs], axis=0)

    def __call__(self, t: np.ndarray, *weights) -> np.ndarray:
        powers = t[:, None] ** np.arange(self.p)[None, :]
        if weights:
            powers = np.concatenate([powers * np.reshape(w, (-1, 1)) for w in weights], axis=1)
        return (powers @ self.c).reshape(t.shape + self.shape)


def _gain_outer(g: list, place) -> np.ndarray:
    """Coefficients of g(T) g(T)^T for a gain polynomial g(T) = sum_p T^p g[p], placed by `place`."""
    g = [np.asarray(v, float) for v in g]
    out = np.zeros((2 * len(g) - 1,) + place(np.outer(g[0], g[0])).shape)
    for i, gi in enumerate(g):
        for j, gj in enumerate(g):
            out[i + j] += place(np.outer(gi, gj))
    return out


def _x_block(m3):
    out = np.zeros((6, 6))
    out[0::2, 0::2] = m3
    return out


def _y_block(m3):
    out = np.zeros((6, 6))
    out[1::2, 1::2] = m3
    return out


_E = np.eye(3)
# Per-axis transitions as polynomials in T (coefficients of T^0, T^1, T^2)
_F_CV = _Poly(per_axis_to_horizontal(np.array([np.diag([1.0, 1.0, 0.0]), np.outer(_E[0], _E[1]), np.zeros((3, 3))])))
_F_CA = _Poly(per_axis_to_horizontal(np.array([np.eye(3), np.outer(_E[0], _E[1]) + np.outer(_E[1], _E[2]),
                                                0.5 * np.outer(_E[0], _E[2])])))
# White-acceleration gain B = [T^2/2, T, 0] (CV) and [T^2/2, T, 1] (CA, CT), per axis: g[p] = coefficient of T^p
_G_CV = [[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.5, 0.0, 0.0]]
_G_CA = [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.5, 0.0, 0.0]]
_Q_CV = _Poly(_gain_outer(_G_CV, _x_block) + _gain_outer(_G_CV, _y_block))
_Q_CA_XY = _Poly(_gain_outer(_G_CA, _x_block), _gain_outer(_G_CA, _y_block))
_CV_FLOOR = np.zeros((6, 6))
_CV_FLOOR[4, 4] = _CV_FLOOR[5, 5] = CV_ACCEL_FLOOR_MPS2**2
# Vertical [z, vz]
_F_V = _Poly(np.array([np.eye(2), [[0.0, 1.0], [0.0, 0.0]]]))
_Q_CH = _Poly(_gain_outer([[0.0, 1.0], [1.0, 0.0]], lambda m: m))  # B = [T, 1]
_Q_CAD = _Poly(_gain_outer([[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]], lambda m: m))  # B = [T^2, T]


def constant_acceleration_f(dt) -> np.ndarray:
    """Baek & Bang eq 6 A_CA (= Hwang eq 18 transition): [[I, T I, T^2/2 I], [0, I, T I], [0, 0, I]]."""
    return _F_CA(_dt(dt))


def cv(dt, sigma_mps2: float):
    """Constant velocity. Baek & Bang eq 5 (A_CV, B_CV = [Omega_2; Omega_1; 0], Q_CV = sigma^2 I), the same as
    Hwang eq 16: the acceleration states are zeroed by F and get no noise (beyond a numerical floor)."""
    t = _dt(dt)
    f = _F_CV(t)
    q = sigma_mps2**2 * _Q_CV(t) + _CV_FLOOR  # the floor keeps P positive definite
    return f, f, q


def ca(dt, sigma_mps2: float, heading_rad=None):
    """Constant acceleration, Baek & Bang eq 6 (B_CA = [Omega_2; Omega_1; I]) with the process noise of eq 31:
    Q_CA(k) = diag(sigma^2 cos^2 psi, sigma^2 sin^2 psi), psi the heading (clockwise from north, so that a
    flight along +x, psi = 90 deg, gets its acceleration noise across track, along y). heading None: eq 6's
    isotropic sigma^2 I."""
    t = _dt(dt)
    f = _F_CA(t)
    var = sigma_mps2**2
    if heading_rad is None:
        var_x = var_y = np.full(t.shape, var)
    else:
        psi = np.broadcast_to(np.asarray(heading_rad, float), t.shape)
        var_x, var_y = var * np.cos(psi) ** 2, var * np.sin(psi) ** 2  # Baek & Bang eq 31
    return f, f, _Q_CA_XY(t, var_x, var_y)


def ct(dt, sigma_mps2: float):
    """Coordinated turn as the Wiener-sequence acceleration model, Hwang eq 18: a(k) - a(k-1) = w(k),
    G = [T^2/2, T, 1] per axis, Q = G G^T sigma^2 (sigma: acceleration increment per step, m/s^2)."""
    t = _dt(dt)
    f = _F_CA(t)
    var = np.full(t.shape, sigma_mps2**2)
    return f, f, _Q_CA_XY(t, var, var)


def _cs_phi_column(s: np.ndarray, alpha: float) -> np.ndarray:
    """Third column of Dai eq 10 Phi at time s: [(-1 + a s + e^-as)/a^2, (1 - e^-as)/a, e^-as] (cancellation-safe)."""
    u = alpha * s
    em1 = np.expm1(-u)  # e^-u - 1
    return np.stack([(u + em1) / alpha**2, -em1 / alpha, em1 + 1.0], axis=-1)


def known_rate_turn(dt, rate_rps: float, sigma_mps2: float):
    """A coordinated turn at the known rate omega (rad/s, positive counter-clockwise, i.e. to the left with x east
    and y north): Bar-Shalom, Li & Kirubarajan, Estimation with Applications to Tracking and Navigation (2001),
    eq 11.7.1-4 (Li & Jilkov, Survey of Maneuvering Target Tracking Part I, 2003, eq 58), per axis pair

        x' = x + sin(wT)/w vx - (1 - cos wT)/w vy      vx' = cos(wT) vx - sin(wT) vy
        y' = y + (1 - cos wT)/w vx + sin(wT)/w vy      vy' = sin(wT) vx + cos(wT) vy

    and the acceleration states set to the turn's own, a' = w x v' (ax' = -w vy', ay' = w vx'), so that the
    mixed and combined states carry it. Linear for a given omega, so an IMM holds one mode per rate (Blom's
    fixed-rate turn modes). Process noise: CV's white acceleration (Baek & Bang eq 5's B = [T^2/2, T, 0]) with
    its floor on the acceleration states: it absorbs a rate other than omega."""
    t = _dt(dt)
    w = float(rate_rps)
    if w == 0.0:
        raise ValueError("a known-rate turn needs a non-zero rate (the straight line is CV)")
    s, c = np.sin(w * t), np.cos(w * t)
    f = np.zeros(t.shape + (H_DIM, H_DIM))
    f[:, 0, 0] = f[:, 1, 1] = 1.0
    f[:, 0, 2], f[:, 0, 3] = s / w, -(1.0 - c) / w
    f[:, 1, 2], f[:, 1, 3] = (1.0 - c) / w, s / w
    f[:, 2, 2], f[:, 2, 3] = c, -s
    f[:, 3, 2], f[:, 3, 3] = s, c
    f[:, 4, 2], f[:, 4, 3] = -w * s, -w * c  # -w vy'
    f[:, 5, 2], f[:, 5, 3] = w * c, -w * s  # w vx'
    q = sigma_mps2**2 * _Q_CV(t) + _CV_FLOOR
    return f, f, q


def cs_transition(dt, alpha: float) -> np.ndarray:
    """Dai eq 10: Phi(k) of the current statistical model, per axis, interleaved on [x, y, vx, vy, ax, ay]."""
    t = _dt(dt)
    f3 = np.zeros(t.shape + (3, 3))
    f3[:, 0, 0] = f3[:, 1, 1] = 1.0
    f3[:, 0, 1] = t
    f3[:, :, 2] = _cs_phi_column(t, alpha)
    return per_axis_to_horizontal(f3)


def cs_q_unit(dt, alpha: float) -> np.ndarray:
    """Dai eq 11 Q matrix q_ij(T) (Singer 1970): q = int_0^T phi(s) phi(s)^T ds with phi the third column of
    Phi(s); the process noise is 2 alpha sigma_a^2 q. Gauss-Legendre, robust for any alpha T (no cancellation)."""
    t = _dt(dt)
    s = np.abs(t)[:, None] * _GL_X[None, :]  # (B, 8)
    phi = _cs_phi_column(s, alpha)  # (B, 8, 3)
    return np.einsum("k,bki,bkj->bij", _GL_W, phi, phi) * np.abs(t)[:, None, None]


def cs_accel_variance(a_hat: np.ndarray, a_max: float) -> np.ndarray:
    """Dai eq 12 (Zhou 1991): sigma_a^2 = (4 - pi)/pi (a_max - a_hat)^2 for a_hat >= 0, (4 - pi)/pi (a_hat - a_min)^2
    below, with a_min = -a_max. Dai prints the bracket without the square; Zhou's Rayleigh variance has it (the
    units demand it). The gap to the bound is floored at 5 % of a_max so that Q never vanishes."""
    gap = np.maximum(a_max - np.abs(a_hat), 0.05 * a_max)
    return (4.0 - math.pi) / math.pi * gap**2


def cs(dt, alpha: float, a_max: float, a_hat: np.ndarray):
    """Current statistical model, Dai eqs 8-12. a_hat (B, 2): the mode's current acceleration estimate [ax, ay],
    used as the mean acceleration a-bar of eq 8 (Dai eq 29: a_j(k-1) of the CS filter).

    Mean: X(k+1) = Phi X + Gamma a-bar with a-bar = X's own acceleration; Phi + Gamma e_a^T is exactly the CA
    transition (eq 10: Phi_13 + Gamma_1 = T^2/2, Phi_23 + Gamma_2 = T, Phi_33 + Gamma_3 = 1), so F_mean = A_CA.
    Covariance: a-bar is an input, so P propagates with Phi alone plus Q = 2 alpha sigma_a^2 q (eqs 10-12),
    sigma_a^2 per axis from eq 12."""
    t = _dt(dt)
    f_mean = constant_acceleration_f(t)
    f_cov = cs_transition(t, alpha)
    q3 = cs_q_unit(t, alpha)  # (B, 3, 3)
    a_hat = np.reshape(np.asarray(a_hat, float), (-1, 2))
    var = cs_accel_variance(a_hat, a_max)  # (B, 2)
    q = np.zeros(t.shape + (6, 6))
    q[:, 0::2, 0::2] = q3 * (2.0 * alpha * var[:, 0])[:, None, None]
    q[:, 1::2, 1::2] = q3 * (2.0 * alpha * var[:, 1])[:, None, None]
    return f_mean, f_cov, q


def ch(dt, sigma_mps: float):
    """Constant altitude (level), Baek & Bang eq 7: A = [[1, T], [0, 1]], B = [T, 1], Q = sigma_CH^2
    (sigma in m/s: a vertical-speed increment per step)."""
    t = _dt(dt)
    f = _F_V(t)
    return f, f, sigma_mps**2 * _Q_CH(t)


def cad(dt, sigma_mps2: float):
    """Constant altitude change (climb/descent), Baek & Bang eq 8: A = [[1, T], [0, 1]], B = [T^2, T] as printed
    (the white-acceleration gain is usually [T^2/2, T]; ADS-B measures both altitude and rate, so the factor on
    the position term changes little), Q = sigma_CAD^2."""
    t = _dt(dt)
    f = _F_V(t)
    return f, f, sigma_mps2**2 * _Q_CAD(t)


# --- derived quantities ------------------------------------------------------------------------------------


def heading_rad(ve, vn) -> np.ndarray:
    """Heading clockwise from north (the psi of Baek & Bang eq 31)."""
    return np.arctan2(ve, vn)


def yaw_rate(state: np.ndarray) -> np.ndarray:
    """Hwang eq 20 from a CT-mode state [x, y, vx, vy, ax, ay]:
    omega = sign(vx ay - ax vy) sqrt((ax^2 + ay^2) / (vx^2 + vy^2)), rad/s, positive counter-clockwise.
    (|a|/|v| includes any along-track acceleration, as in the paper.)"""
    vx, vy, ax, ay = state[..., 2], state[..., 3], state[..., 4], state[..., 5]
    speed2 = np.maximum(vx * vx + vy * vy, 1.0)  # below 1 m/s the turn rate means nothing
    return np.sign(vx * ay - ax * vy) * np.sqrt((ax * ax + ay * ay) / speed2)


def smooth_yaw_rate(previous: np.ndarray, new: np.ndarray, dt, time_constant_s: float) -> np.ndarray:
    """Hwang's low-pass G(s) = 1 / (11.9 s + 1) on the eq 20 estimate, exact discretisation for any dt."""
    k = -np.expm1(-np.abs(np.asarray(dt, float)) / time_constant_s)
    return previous + k * (new - previous)


# --- mode transition probabilities ----------------------------------------------------------------------


def switching_matrix(n_modes: int, switch_probability: float) -> np.ndarray:
    """M[from, to] for one reference period: stay with 1 - p, switch to each other mode with p / (n - 1).
    (Hwang eq 21 and Baek & Bang eq 30 are this with n = 2, p = 0.05. Baek & Bang write pi_ij = P{to i | from j},
    the transpose; for these symmetric matrices it is the same.)"""
    if n_modes == 1:
        return np.ones((1, 1))
    m = np.full((n_modes, n_modes), switch_probability / (n_modes - 1))
    np.fill_diagonal(m, 1.0 - switch_probability)
    return m


def mode_switching(modes, switch_probability: float, turn_exit_probability: float) -> np.ndarray:
    """switching_matrix for these modes, except that a fixed-rate turn (KnownRateTurn) is left with
    turn_exit_probability per second, spread evenly over the other modes: a turn has an end, so its mean sojourn
    (1 / turn_exit_probability) is short beside a straight line's, and a track that stops seeing its aircraft (a
    radar's blind zone near the closest approach) drifts back to straight flight instead of coasting round the
    circle (docs/tracking.md, "Turns seen by a radar"). Without turn modes this is switching_matrix."""
    m = switching_matrix(len(modes), switch_probability)
    if len(modes) > 1:
        for i, mode in enumerate(modes):
            if isinstance(mode, KnownRateTurn):
                m[i, :] = turn_exit_probability / (len(modes) - 1)
                m[i, i] = 1.0 - turn_exit_probability
    return m


def bank_switching(h_modes, v_modes, switch_probability: float,
                   turn_exit_probability: float) -> tuple[np.ndarray, np.ndarray]:
    """The switching matrices of a track's horizontal bank (mode_switching: its turns left at
    turn_exit_probability) and its vertical bank, both leaving every other mode at switch_probability: the one
    place the trackers (ADS-B, sensor) and the fusion report's local filters build them."""
    return (mode_switching(h_modes, switch_probability, turn_exit_probability),
            switching_matrix(len(v_modes), switch_probability))


class MarkovChain:
    """Mode transition matrix M[from, to] for any interval dt, from the matrix M1 of one reference period T0:
    M(dt) = expm(dt / T0 * logm(M1)), the continuous-time chain that M1 samples (so coasting over 3 s is three
    steps of M1, exactly, and an irregular 1.3 s interval is consistent with it). Vectorised over dt through
    one eigendecomposition of the generator."""

    def __init__(self, m1: np.ndarray, period_s: float = 1.0):
        m1 = np.asarray(m1, float)
        if m1.ndim != 2 or m1.shape[0] != m1.shape[1] or not np.allclose(m1.sum(axis=1), 1.0) or (m1 < 0).any():
            raise ValueError("mode transition matrix must be square, non-negative, rows summing to 1 (M[from, to])")
        self.m1 = m1
        self.period_s = period_s
        n = m1.shape[0]
        if n == 1:
            self._v = self._vinv = np.ones((1, 1))
            self._lam = np.zeros(1)
            return
        # A symmetric M1 (the uniform switching built from tracking.imm_switch_probability) has a repeated
        # eigenvalue from 3 modes on; eig may then return dependent eigenvectors (4 modes at 0.23 did: "Singular
        # matrix"), eigh always returns an orthonormal basis.
        w, v = np.linalg.eigh(m1) if np.allclose(m1, m1.T) else np.linalg.eig(m1)
        if np.iscomplexobj(w) and np.abs(w.imag).max() > 1e-12 or (w.real <= 0).any():
            raise ValueError("mode transition matrix has no real logarithm (make it diagonally dominant)")
        self._v = v.real
        self._vinv = np.linalg.inv(self._v)
        self._lam = np.log(w.real) / period_s  # eigenvalues of the generator
        generator = self._v @ np.diag(self._lam) @ self._vinv
        off = generator - np.diag(np.diag(generator))
        if (off < -1e-12).any():
            raise ValueError("mode transition matrix is not embeddable in a continuous-time chain")

    def at(self, dt) -> np.ndarray:
        """(B, n, n) transition matrices M(dt)[from, to]."""
        t = np.abs(_dt(dt))
        e = np.exp(self._lam[None, :] * t[:, None])  # (B, n)
        k = len(self._lam)
        m = ((self._v[None, :, :] * e[:, None, :]).reshape(-1, k) @ self._vinv).reshape(len(t), k, k)
        m = np.clip(m, 0.0, 1.0)
        return m / m.sum(axis=2, keepdims=True)


# --- the models as objects (what an IMM bank and the trajectory prediction are given) ---------------------


@runtime_checkable
class MotionModel(Protocol):
    """One mode's motion model on a stacked state (B, n): its transition and process noise for any step dt.

    name: the mode's label in the outputs; dim: n (H_DIM or V_DIM); accelerates: False when the model zeroes the
    acceleration states (CV: the bank then starts them at the floor); estimates_turn: its state gives the Hwang
    eq 20 yaw rate (CT, CA, CS). matrices(dt, x, heading) -> (F_mean, F_cov, Q), each (B, n, n): x the mode's
    mixed state (Baek & Bang eq 12), heading the combined heading (eq 31; None: the model's own state's)."""

    name: str
    dim: int
    accelerates: bool
    estimates_turn: bool

    def F(self, dt) -> np.ndarray: ...

    def Q(self, dt, x: np.ndarray | None = None, heading=None) -> np.ndarray: ...

    def matrices(self, dt, x: np.ndarray | None, heading=None) -> tuple: ...


class _Model:
    accelerates = True
    estimates_turn = False

    def F(self, dt) -> np.ndarray:
        """The mean transition (Baek & Bang eq 18's A_j)."""
        return self.matrices(dt, None)[0]

    def Q(self, dt, x: np.ndarray | None = None, heading=None) -> np.ndarray:
        """The process noise (Baek & Bang eq 19's B_j Q_j B_j^T)."""
        return self.matrices(dt, x, heading)[2]


def _per_state(dt, x: np.ndarray | None, heading=None) -> np.ndarray:
    """dt as one step per stacked state when the noise depends on the state (a scalar dt otherwise)."""
    b = len(heading) if heading is not None and np.ndim(heading) else x.shape[0] if x is not None else None
    dt = np.asarray(dt, float)
    return dt if b is None or dt.ndim else np.full(b, float(dt))


@dataclass(frozen=True)
class ConstantVelocity(_Model):
    """CV, Baek & Bang eq 5 (= Hwang eq 16); sigma in m/s^2."""

    sigma_mps2: float
    name = "cv"
    dim = H_DIM
    accelerates = False

    def matrices(self, dt, x=None, heading=None):
        return cv(dt, self.sigma_mps2)


@dataclass(frozen=True)
class ConstantAcceleration(_Model):
    """CA, Baek & Bang eq 6 with eq 31's heading-rotated noise (heading_noise False: eq 6's isotropic noise)."""

    sigma_mps2: float
    heading_noise: bool = True
    name = "ca"
    dim = H_DIM
    estimates_turn = True

    def matrices(self, dt, x=None, heading=None):
        if heading is None and x is not None:  # the mode's own velocity (Baek & Bang eq 31 per mode)
            heading = heading_rad(x[:, 2], x[:, 3])
        if not self.heading_noise or heading is None:  # eq 6's isotropic noise
            return ca(dt, self.sigma_mps2)
        return ca(_per_state(dt, x, heading), self.sigma_mps2, heading)


@dataclass(frozen=True)
class CoordinatedTurn(_Model):
    """CT as Hwang eq 18's Wiener-sequence acceleration; sigma in m/s^2 per step."""

    sigma_mps2: float
    name = "ct"
    dim = H_DIM
    estimates_turn = True

    def matrices(self, dt, x=None, heading=None):
        return ct(dt, self.sigma_mps2)


@dataclass(frozen=True)
class KnownRateTurn(_Model):
    """A coordinated turn at a known rate (known_rate_turn): rate in rad/s, positive to the left (counter-clockwise
    seen from above); sigma in m/s^2 (white acceleration, as CV's)."""

    rate_rps: float
    sigma_mps2: float
    dim = H_DIM

    @property
    def name(self) -> str:
        return "turn_left" if self.rate_rps > 0.0 else "turn_right"

    def matrices(self, dt, x=None, heading=None):
        return known_rate_turn(dt, self.rate_rps, self.sigma_mps2)


@dataclass(frozen=True)
class CurrentStatistical(_Model):
    """CS, Dai eqs 8-12: alpha the manoeuvre frequency (1/s), a_max the acceleration bound (m/s^2)."""

    alpha_per_s: float
    a_max_mps2: float
    name = "cs"
    dim = H_DIM
    estimates_turn = True

    def matrices(self, dt, x=None, heading=None):
        a_hat = np.zeros((1, 2)) if x is None else x[:, 4:6]  # Dai eq 29: the mode's own acceleration
        return cs(_per_state(dt, x), self.alpha_per_s, self.a_max_mps2, a_hat)


@dataclass(frozen=True)
class ConstantHeight(_Model):
    """CH, Baek & Bang eq 7; sigma in m/s (a vertical-speed increment per step)."""

    sigma_mps: float
    name = "ch"
    dim = V_DIM

    def matrices(self, dt, x=None, heading=None):
        return ch(dt, self.sigma_mps)


@dataclass(frozen=True)
class ConstantAltitudeChange(_Model):
    """CAD, Baek & Bang eq 8; sigma in m/s^2."""

    sigma_mps2: float
    name = "cad"
    dim = V_DIM

    def matrices(self, dt, x=None, heading=None):
        return cad(dt, self.sigma_mps2)
