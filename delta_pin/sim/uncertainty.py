"""Time-varying uncertain parameters of the plant (Section V): the truth that a controller does not know.

The paper's uncertain parameter is ζ = [Δm_o, ΔF_n1, ΔF_n2, ΔF_n3, ΔF_1, ΔF_2, ΔF_3]ᵀ with

    m_o(t) = m̄_o + Δm_o(t)     platform mass [kg]                        (enters M, C, G: eqs. 7-9)
    F_n(t) = F̄_n + ΔF_n(t)     normal force of the joint friction [N]    (enters M_f: eq. 12)
    F(t)   = F̄   + ΔF(t)       joint disturbance torque [N m]            (enters eq. 13 on the left:
                                                     M α̈ + C α̇ + G + F + M_f = τ)

An :class:`Uncertainty` gives the plant m_o(t), F_n(t) and F(t); a controller may only use the
nominal parts m̄_o, F̄_n (from the robot description and the friction settings) and
:attr:`Uncertainty.nominal_disturbance` F̄ (C1, eq. 23, uses F̄).

Every method takes a time t [s] as a float, giving shape () or (3,), or as an array (N,), giving
(N,) or (N, 3); the evaluation is vectorised.

Magnitudes follow the paper's definition: Δ_m = max_t |Δm_o(t)| / m̄_o,
Δ_fc = max_t |ΔF_ni(t)| / F̄_ni and Δ_f = max_t |ΔF_i(t)| / F̄_i.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any

import numpy as np

from delta_pin.errors import InvalidParameterError, NonFiniteError

__all__ = [
    "PAPER_NOMINAL_DISTURBANCE",
    "PAPER_NOMINAL_NORMAL_FORCE",
    "PAPER_NOMINAL_PLATFORM_MASS",
    "FunctionUncertainty",
    "NoUncertainty",
    "PaperUncertainty",
    "RandomUncertainty",
    "Uncertainty",
    "make_uncertainty",
]

PAPER_NOMINAL_PLATFORM_MASS = 0.3  # m̄_o [kg] (Section V; the default URDF's m_o)
PAPER_NOMINAL_NORMAL_FORCE = 15.0  # F̄_ni [N], each joint (Section V)
PAPER_NOMINAL_DISTURBANCE = (2.0, 4.0, 6.0)  # F̄ [N m] (Section V)

TimeLike = float | np.ndarray


def _as_times(t: TimeLike) -> tuple[np.ndarray, bool]:
    """Times as a finite (N,) array [s] and whether ``t`` was a scalar."""
    times = np.asarray(t, dtype=float)
    if times.ndim > 1:
        raise InvalidParameterError(f"time must be a float or a 1-D array, got shape {times.shape}")
    if not np.all(np.isfinite(times)):
        bad = times[~np.isfinite(times)].ravel()[0]
        raise NonFiniteError(f"time must be finite, got t={bad}")
    return np.atleast_1d(times), times.ndim == 0


def _check_magnitude(name: str, value: float) -> float:
    """A magnitude Δ [-]: finite and >= 0."""
    value = float(value)
    if not math.isfinite(value) or value < 0.0:
        raise InvalidParameterError(f"{name} must be finite and >= 0, got {name}={value!r}")
    return value


def _check_magnitudes(delta_m: float, delta_fc: float, delta_f: float) -> tuple[float, float, float]:
    """Δ_m in [0, 1) (the mass must stay > 0), Δ_fc in [0, 1] (the normal force must stay >= 0)
    and Δ_f >= 0, all finite."""
    delta_m = _check_magnitude("delta_m", delta_m)
    if delta_m >= 1.0:
        raise InvalidParameterError(f"delta_m must be < 1 (the mass must stay > 0), got delta_m={delta_m!r}")
    delta_fc = _check_magnitude("delta_fc", delta_fc)
    if delta_fc > 1.0:
        raise InvalidParameterError(
            f"delta_fc must be <= 1 (the normal force must stay >= 0), got delta_fc={delta_fc!r}"
        )
    return delta_m, delta_fc, _check_magnitude("delta_f", delta_f)


def _check_vector3(name: str, value: Any, nonnegative: bool = False) -> np.ndarray:
    """A float or (3,) of finite numbers, as a new (3,) array."""
    vector = np.asarray(value, dtype=float)
    if vector.shape not in ((), (3,)):
        raise InvalidParameterError(f"{name} must be a float or have shape (3,), got shape {vector.shape}")
    vector = np.broadcast_to(vector, (3,)).copy()
    if not np.all(np.isfinite(vector)):
        raise NonFiniteError(f"{name} must be finite, got {name}={vector.tolist()}")
    if nonnegative and np.any(vector < 0.0):
        raise InvalidParameterError(f"{name} must be >= 0, got {name}={vector.tolist()}")
    return vector


def _check_nominal_mass(nominal: float) -> float:
    nominal = float(nominal)
    if not math.isfinite(nominal) or nominal <= 0.0:
        raise InvalidParameterError(f"the nominal platform mass must be finite and > 0, got {nominal!r} kg")
    return nominal


class Uncertainty(ABC):
    """Base of the uncertainty profiles: m_o(t), F_n(t), F(t) of Section V (SI units).

    Subclasses implement the ``_``-prefixed methods on a (N,) array of times; the public methods
    validate the arguments and handle scalar times.
    """

    def __init__(self, nominal_disturbance: Any = (0.0, 0.0, 0.0)) -> None:
        self._nominal_disturbance = _check_vector3("nominal_disturbance", nominal_disturbance)
        self._nominal_disturbance.flags.writeable = False

    @property
    def nominal_disturbance(self) -> np.ndarray:
        """F̄ (3,) [N m]: the known part of the joint disturbance, which C1 (eq. 23) may use."""
        return self._nominal_disturbance

    def platform_mass(self, t: TimeLike, nominal: float) -> np.ndarray:
        """Platform mass m_o(t) = m̄_o + Δm_o(t) [kg], shape () or (N,).

        Args:
            t: time [s], a float or (N,).
            nominal: the nominal platform mass m̄_o [kg] (the robot's URDF value, ``params.m_o``).
        """
        times, scalar = _as_times(t)
        mass = self._platform_mass(times, _check_nominal_mass(nominal))
        return mass[0] if scalar else mass

    def normal_force(self, t: TimeLike, nominal: float | np.ndarray) -> np.ndarray:
        """Normal force F_n(t) = F̄_n + ΔF_n(t) of the joints' Stribeck friction (eq. 12) [N].

        Args:
            t: time [s], a float or (N,).
            nominal: the nominal normal force F̄_n [N], a float (every joint) or (3,).

        Returns:
            (3,) for a float time, (N, 3) for an array.
        """
        times, scalar = _as_times(t)
        force = self._normal_force(times, _check_vector3("nominal normal force", nominal, nonnegative=True))
        return force[0] if scalar else force

    def disturbance(self, t: TimeLike) -> np.ndarray:
        """Joint disturbance torque F(t) = F̄ + ΔF(t) of eq. 13 [N m], nominal part included.

        Returns:
            (3,) for a float time t [s], (N, 3) for an array (N,).
        """
        times, scalar = _as_times(t)
        torque = self._disturbance(times)
        return torque[0] if scalar else torque

    def at(
        self, t: float, nominal_mass: float, nominal_normal_force: np.ndarray
    ) -> tuple[float, np.ndarray, np.ndarray]:
        """(m_o [kg], F_n (3,) [N], F (3,) [N m]) at one time t [s] for validated nominal values
        (a plant's hot path: no argument checks)."""
        times = np.array([float(t)])
        return (
            float(self._platform_mass(times, nominal_mass)[0]),
            self._normal_force(times, nominal_normal_force)[0],
            self._disturbance(times)[0],
        )

    @abstractmethod
    def _platform_mass(self, t: np.ndarray, nominal: float) -> np.ndarray:
        """m_o [kg] (N,) at times t (N,) [s]."""

    @abstractmethod
    def _normal_force(self, t: np.ndarray, nominal: np.ndarray) -> np.ndarray:
        """F_n [N] (N, 3) at times t (N,) [s] for a nominal (3,) [N]."""

    @abstractmethod
    def _disturbance(self, t: np.ndarray) -> np.ndarray:
        """F [N m] (N, 3) at times t (N,) [s]."""

    @abstractmethod
    def metadata(self) -> dict[str, Any]:
        """JSON-serialisable description: ``kind`` and the parameters (``make_uncertainty(**meta)``)."""

    def __repr__(self) -> str:
        items = ", ".join(f"{key}={value!r}" for key, value in self.metadata().items() if key != "kind")
        return f"{type(self).__name__}({items})"


class NoUncertainty(Uncertainty):
    """The nominal plant: m_o = m̄_o, F_n = F̄_n and no disturbance (F = F̄ = 0)."""

    def __init__(self) -> None:
        super().__init__((0.0, 0.0, 0.0))

    def _platform_mass(self, t: np.ndarray, nominal: float) -> np.ndarray:
        return np.full(t.shape, nominal)

    def _normal_force(self, t: np.ndarray, nominal: np.ndarray) -> np.ndarray:
        return np.tile(nominal, (t.size, 1))

    def _disturbance(self, t: np.ndarray) -> np.ndarray:
        return np.zeros((t.size, 3))

    def metadata(self) -> dict[str, Any]:
        return {"kind": "none"}


class PaperUncertainty(Uncertainty):
    """The profiles of Section V, for any nominal m̄_o and F̄_n:

        Δm_o(t) = Δ_m m̄_o sin(πt),   ΔF_ni(t) = Δ_fc F̄_ni sin(πt),   ΔF_i(t) = Δ_f F̄_i cos(2πt).

    Args:
        delta_m: Δ_m [-], in [0, 1) so that the mass stays positive (the paper: 0.3).
        delta_fc: Δ_fc [-], in [0, 1] (the paper: 0.3): the normal force stays >= 0.
        delta_f: Δ_f [-], >= 0 (the paper: 0.3).
        nominal_disturbance: F̄ (3,) [N m] (the paper: [2, 4, 6]).
    """

    def __init__(
        self,
        delta_m: float = 0.3,
        delta_fc: float = 0.3,
        delta_f: float = 0.3,
        nominal_disturbance: Any = PAPER_NOMINAL_DISTURBANCE,
    ) -> None:
        super().__init__(nominal_disturbance)
        self.delta_m, self.delta_fc, self.delta_f = _check_magnitudes(delta_m, delta_fc, delta_f)

    def _platform_mass(self, t: np.ndarray, nominal: float) -> np.ndarray:
        return nominal + self.delta_m * nominal * np.sin(np.pi * t)

    def _normal_force(self, t: np.ndarray, nominal: np.ndarray) -> np.ndarray:
        return nominal + self.delta_fc * nominal * np.sin(np.pi * t)[:, None]

    def _disturbance(self, t: np.ndarray) -> np.ndarray:
        nominal = self.nominal_disturbance
        return nominal + self.delta_f * nominal * np.cos(2.0 * np.pi * t)[:, None]

    def metadata(self) -> dict[str, Any]:
        return {
            "kind": "paper",
            "delta_m": self.delta_m,
            "delta_fc": self.delta_fc,
            "delta_f": self.delta_f,
            "nominal_disturbance": self.nominal_disturbance.tolist(),
        }


class FunctionUncertainty(Uncertainty):
    """User-given profiles: functions of a scalar time t [s] (``None``: nominal mass/force, no disturbance).

    Args:
        platform_mass: t -> m_o(t) [kg], the whole mass (finite, > 0).
        normal_force: t -> F_n(t) [N], a float or (3,) (finite, >= 0).
        disturbance: t -> F(t) [N m], a float or (3,), the whole disturbance, F̄ included (finite).
        nominal_disturbance: F̄ (3,) [N m], the part a controller may know.

    The functions are called once per time (arrays are evaluated element by element); a value that
    is not finite, out of its domain or of the wrong shape raises an error naming the time.
    """

    def __init__(
        self,
        platform_mass: Callable[[float], float] | None = None,
        normal_force: Callable[[float], Any] | None = None,
        disturbance: Callable[[float], Any] | None = None,
        nominal_disturbance: Any = (0.0, 0.0, 0.0),
    ) -> None:
        super().__init__(nominal_disturbance)
        for name, function in (
            ("platform_mass", platform_mass),
            ("normal_force", normal_force),
            ("disturbance", disturbance),
        ):
            if function is not None and not callable(function):
                raise InvalidParameterError(f"{name} must be a function of time or None, got {function!r}")
        self.platform_mass_function = platform_mass
        self.normal_force_function = normal_force
        self.disturbance_function = disturbance

    @staticmethod
    def _evaluate(
        name: str, function: Callable[[float], Any], t: float, shape: tuple[int, ...]
    ) -> np.ndarray:
        """``function(t)`` checked: finite, shape () or ``shape``; broadcast to ``shape``."""
        value = np.asarray(function(float(t)), dtype=float)
        if value.shape not in ((), shape):
            raise InvalidParameterError(f"{name}(t={t}) must have shape () or {shape}, got {value.shape}")
        if not np.all(np.isfinite(value)):
            raise NonFiniteError(f"{name}(t={t}) is not finite: {value.tolist()}")
        return np.broadcast_to(value, shape)

    def _platform_mass(self, t: np.ndarray, nominal: float) -> np.ndarray:
        if self.platform_mass_function is None:
            return np.full(t.shape, nominal)
        mass = np.array([self._evaluate("platform_mass", self.platform_mass_function, ti, ()) for ti in t])
        if np.any(mass <= 0.0):
            k = int(np.argmax(mass <= 0.0))
            raise InvalidParameterError(f"platform_mass(t={t[k]}) must be > 0, got {mass[k]} kg")
        return mass

    def _normal_force(self, t: np.ndarray, nominal: np.ndarray) -> np.ndarray:
        if self.normal_force_function is None:
            return np.tile(nominal, (t.size, 1))
        force = np.array([self._evaluate("normal_force", self.normal_force_function, ti, (3,)) for ti in t])
        if np.any(force < 0.0):
            k = int(np.argmax(np.any(force < 0.0, axis=1)))
            raise InvalidParameterError(f"normal_force(t={t[k]}) must be >= 0, got {force[k].tolist()} N")
        return force

    def _disturbance(self, t: np.ndarray) -> np.ndarray:
        if self.disturbance_function is None:
            return np.zeros((t.size, 3))
        return np.array([self._evaluate("disturbance", self.disturbance_function, ti, (3,)) for ti in t])

    def metadata(self) -> dict[str, Any]:
        def name(function: Callable[..., Any] | None) -> str | None:
            if function is None:
                return None
            return getattr(function, "__qualname__", None) or repr(function)

        return {
            "kind": "function",
            "platform_mass": name(self.platform_mass_function),
            "normal_force": name(self.normal_force_function),
            "disturbance": name(self.disturbance_function),
            "nominal_disturbance": self.nominal_disturbance.tolist(),
        }


class RandomUncertainty(Uncertainty):
    """Seeded random band-limited profiles with the paper's magnitudes as bounds.

    Each of the seven signals s(t) (mass, three normal forces, three disturbances) is

        s(t) = Σ_k a_k sin(2π f_k t + φ_k) / Σ_k a_k,   f_k ~ U(0, bandwidth], φ_k ~ U[0, 2π), a_k ~ U(0, 1],

    so |s(t)| <= 1 for all t and its spectrum lies at or below ``bandwidth``. Then

        m_o = m̄_o (1 + Δ_m s_m(t)),   F_n,i = F̄_n,i (1 + Δ_fc s_n,i(t)),   F_i = F̄_i (1 + Δ_f s_f,i(t)),

    hence max_t |Δ(t)| <= Δ · nominal: Δ is a bound, approached but not always reached in a finite run.

    Args:
        delta_m, delta_fc, delta_f: magnitudes Δ_m (< 1), Δ_fc, Δ_f [-], as in :class:`PaperUncertainty`.
        bandwidth: highest frequency of the profiles [Hz], > 0.
        seed: seed of the random generator (same seed, same profile); ``None`` draws one, which
            :meth:`metadata` then records.
        nominal_disturbance: F̄ (3,) [N m].
        components: number of sinusoids per signal, >= 1.
    """

    _SIGNALS = 7  # m_o, F_n1..3, F_1..3

    def __init__(
        self,
        delta_m: float = 0.3,
        delta_fc: float = 0.3,
        delta_f: float = 0.3,
        bandwidth: float = 2.0,
        seed: int | None = 0,
        nominal_disturbance: Any = PAPER_NOMINAL_DISTURBANCE,
        components: int = 8,
    ) -> None:
        super().__init__(nominal_disturbance)
        self.delta_m, self.delta_fc, self.delta_f = _check_magnitudes(delta_m, delta_fc, delta_f)
        self.bandwidth = float(bandwidth)
        if not math.isfinite(self.bandwidth) or self.bandwidth <= 0.0:
            raise InvalidParameterError(f"bandwidth must be finite and > 0 Hz, got bandwidth={bandwidth!r}")
        if isinstance(components, bool) or int(components) != components or components < 1:
            raise InvalidParameterError(f"components must be an integer >= 1, got components={components!r}")
        self.components = int(components)
        if seed is None:
            seed = int(np.random.SeedSequence().entropy % 2**63)
        if isinstance(seed, bool) or int(seed) != seed or seed < 0:
            raise InvalidParameterError(f"seed must be an integer >= 0 or None, got seed={seed!r}")
        self.seed = int(seed)

        rng = np.random.default_rng(self.seed)
        size = (self._SIGNALS, self.components)
        self._frequencies = self.bandwidth * (1.0 - rng.random(size))  # (0, bandwidth] [Hz]
        self._phases = 2.0 * np.pi * rng.random(size)  # [rad]
        amplitudes = 1.0 - rng.random(size)  # (0, 1]
        self._weights = amplitudes / amplitudes.sum(axis=1, keepdims=True)  # Σ_k |a_k| = 1 per signal

    def signals(self, t: TimeLike) -> np.ndarray:
        """The normalised signals [s_m, s_n1, s_n2, s_n3, s_f1, s_f2, s_f3] [-], |s| <= 1: (7,) or (N, 7)."""
        times, scalar = _as_times(t)
        values = self._signals(times)
        return values[0] if scalar else values

    def _signals(self, t: np.ndarray) -> np.ndarray:
        angles = 2.0 * np.pi * self._frequencies * t[:, None, None] + self._phases  # (N, 7, K)
        return np.einsum("nsk,sk->ns", np.sin(angles), self._weights)

    def _platform_mass(self, t: np.ndarray, nominal: float) -> np.ndarray:
        return nominal * (1.0 + self.delta_m * self._signals(t)[:, 0])

    def _normal_force(self, t: np.ndarray, nominal: np.ndarray) -> np.ndarray:
        return nominal * (1.0 + self.delta_fc * self._signals(t)[:, 1:4])

    def _disturbance(self, t: np.ndarray) -> np.ndarray:
        return self.nominal_disturbance * (1.0 + self.delta_f * self._signals(t)[:, 4:7])

    def metadata(self) -> dict[str, Any]:
        return {
            "kind": "random",
            "delta_m": self.delta_m,
            "delta_fc": self.delta_fc,
            "delta_f": self.delta_f,
            "bandwidth": self.bandwidth,
            "seed": self.seed,
            "nominal_disturbance": self.nominal_disturbance.tolist(),
            "components": self.components,
        }


_KINDS: dict[str, type[Uncertainty]] = {
    "none": NoUncertainty,
    "paper": PaperUncertainty,
    "random": RandomUncertainty,
}


def make_uncertainty(kind: str, **kwargs: Any) -> Uncertainty:
    """An uncertainty by name: ``"none"``, ``"paper"`` or ``"random"``, with its keyword arguments.

    ``make_uncertainty(**u.metadata())`` rebuilds ``u`` (not for ``"function"``, whose functions
    cannot be serialised).

        >>> make_uncertainty("random", seed=3, bandwidth=1.0).metadata()["seed"]
        3
    """
    if kind not in _KINDS:
        raise InvalidParameterError(f"unknown uncertainty kind {kind!r}; choose one of {sorted(_KINDS)}")
    try:
        return _KINDS[kind](**kwargs)
    except TypeError as error:
        raise InvalidParameterError(f"bad arguments for uncertainty kind {kind!r}: {error}") from error
