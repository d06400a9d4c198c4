"""One model algebra for gas films: springs, dashpots and spring-pots composed in series and parallel.

An element's complex stiffness at the Laplace variable ``s`` (rad/s; ``s = jω`` for a steady-state FRF,
``s = σ + jω`` for an FRF measured through an exponential window of decay rate σ):

* spring ``k``:                ``Z = k``                 (N/m)
* dashpot ``eta``:             ``Z = eta * s``           (N·s/m)
* spring-pot ``eta, alpha``:   ``Z = eta * s**alpha``    (N·s^α/m; α = 0 is a spring, α = 1 a dashpot)

Parallel elements add their stiffnesses; series elements add their compliances. The nine models of the paper
(networks from ``shared/paper/ERRATA.md`` item 4) are named compositions in :data:`PAPER_MODELS`, and a user can
write a new one in the short text form parsed by :func:`parse_network`, e.g.
``"k3 || (k1 -- pot(eta1, alpha)) || (k2 -- pot(eta2, beta))"``.

Evaluation is vectorised: a parameter array of shape ``(..., n_parameters)`` gives stiffnesses of shape
``(..., n_frequencies)``. One evaluator, :meth:`Node.evaluate`, gives Z and, on request, its analytic derivative
with respect to every parameter (spring ``dZ/dk = 1``, dashpot ``dZ/dη = s``, spring-pot ``dZ/dη = s^α`` and
``dZ/dα = η s^α ln s``; parallel derivatives add, a series branch's derivative is scaled by ``(Z/Z_branch)²``).
"""

from __future__ import annotations

import abc
import functools
import re
from dataclasses import dataclass
from typing import Mapping, NamedTuple, Sequence

import numpy as np
from numpy.typing import ArrayLike

from gasfilm.drivers.errors import SettingError


@dataclass(frozen=True)
class Parameter:
    """A model parameter with its unit, search bounds and the scale an optimiser should search it in."""

    name: str
    unit: str
    lower: float
    upper: float
    scale: str  # "log" for stiffnesses and coefficients, "linear" for orders

    def to_unit_interval(self, value: np.ndarray) -> np.ndarray:
        """Map a value inside the bounds to [0, 1] in the parameter's own scale."""
        if self.scale == "log":
            return (np.log(value) - np.log(self.lower)) / (np.log(self.upper) - np.log(self.lower))
        return (value - self.lower) / (self.upper - self.lower)

    def from_unit_interval(self, u: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`to_unit_interval`."""
        if self.scale == "log":
            return np.exp(np.log(self.lower) + u * (np.log(self.upper) - np.log(self.lower)))
        return self.lower + u * (self.upper - self.lower)


SPRING_BOUNDS_N_PER_M = (1e2, 1e12)
DASHPOT_BOUNDS_NS_PER_M = (1e-2, 1e10)
SPRINGPOT_BOUNDS = (1e-4, 1e13)
ORDER_BOUNDS = (0.0, 2.0)


#: derivatives of a node's stiffness, one array per parameter name (N/m per unit of the parameter)
Gradient = dict[str, np.ndarray]


class Node(abc.ABC):
    """A network of elements with a complex stiffness."""

    @abc.abstractmethod
    def parameters(self) -> list[Parameter]:
        """The parameters of this node and everything below it, in reading order."""

    @abc.abstractmethod
    def evaluate(
        self, s: np.ndarray, values: Mapping[str, np.ndarray], gradient: bool, log_s: LogLaplace | None = None
    ) -> tuple[np.ndarray, Gradient]:
        """Complex stiffness in N/m at the Laplace variable ``s`` and, when ``gradient``, its derivative with respect
        to each parameter below this node (an empty mapping otherwise). ``log_s`` is ``ln s`` precomputed by a caller
        that evaluates many parameter sets at the same ``s ≠ 0`` (a fitter, :func:`log_laplace`); without it
        spring-pots use ``s**α``.
        A spring's stiffness and derivative are its real value and 1, shaped like the value (broadcasting against
        ``s``): combined with other elements they take the frequencies' shape, and :meth:`stiffness` and
        :class:`FilmModel` give every result over the frequencies."""

    @abc.abstractmethod
    def text(self) -> str:
        """The node in the short text form."""

    def stiffness(
        self, s: np.ndarray, values: Mapping[str, np.ndarray], log_s: LogLaplace | None = None
    ) -> np.ndarray:
        """Complex stiffness in N/m at the Laplace variable ``s``."""
        return _over_frequencies(self.evaluate(s, values, False, log_s)[0], s)


@dataclass(frozen=True)
class Spring(Node):
    name: str

    def parameters(self) -> list[Parameter]:
        return [Parameter(self.name, "N/m", *SPRING_BOUNDS_N_PER_M, "log")]

    def evaluate(
        self, s: np.ndarray, values: Mapping[str, np.ndarray], gradient: bool, log_s: LogLaplace | None = None
    ) -> tuple[np.ndarray, Gradient]:
        z = values[self.name]
        return z, {self.name: np.ones_like(z)} if gradient else {}

    def text(self) -> str:
        return self.name


@dataclass(frozen=True)
class Dashpot(Node):
    name: str

    def parameters(self) -> list[Parameter]:
        return [Parameter(self.name, "N·s/m", *DASHPOT_BOUNDS_NS_PER_M, "log")]

    def evaluate(
        self, s: np.ndarray, values: Mapping[str, np.ndarray], gradient: bool, log_s: LogLaplace | None = None
    ) -> tuple[np.ndarray, Gradient]:
        z = values[self.name] * s
        return z, {self.name: s} if gradient else {}  # dZ/dη = s, broadcast by the caller

    def text(self) -> str:
        return f"dashpot({self.name})"


@dataclass(frozen=True)
class SpringPot(Node):
    coefficient: str
    order: str

    def parameters(self) -> list[Parameter]:
        return [
            Parameter(self.coefficient, f"N·s^{self.order}/m", *SPRINGPOT_BOUNDS, "log"),
            Parameter(self.order, "1", *ORDER_BOUNDS, "linear"),
        ]

    def evaluate(
        self, s: np.ndarray, values: Mapping[str, np.ndarray], gradient: bool, log_s: LogLaplace | None = None
    ) -> tuple[np.ndarray, Gradient]:
        # principal branch; exp(α ln s) is 2–4× faster than s**α when ln s is given, s**α also holds at s = 0
        order, coefficient = values[self.order], values[self.coefficient]
        if not gradient:
            return (coefficient * s**order if log_s is None else _power(order, log_s, coefficient)), {}
        power = s**order if log_s is None else _power(order, log_s)
        z = coefficient * power
        return z, {self.coefficient: power, self.order: z * (np.log(s) if log_s is None else log_s.value)}

    def text(self) -> str:
        return f"pot({self.coefficient}, {self.order})"


class LogLaplace(NamedTuple):
    """``ln s`` at the lines where a fitter evaluates a network many times: the complex value, its real part
    ``ln|s|``, and ``arg s`` when it is the same on every line (``s = jω``: an FRF without an exponential window),
    else None."""

    value: np.ndarray
    magnitude: np.ndarray
    phase: float | None


def log_laplace(s: ArrayLike) -> LogLaplace:
    """:class:`LogLaplace` of the Laplace variables ``s`` (all ≠ 0)."""
    value = np.log(np.asarray(s, dtype=complex))
    phase = value.imag
    uniform = phase.size > 0 and bool(np.all(phase == phase.flat[0]))
    return LogLaplace(value, np.ascontiguousarray(value.real), float(phase.flat[0]) if uniform else None)


def _power(order: np.ndarray, log_s: LogLaplace, coefficient: np.ndarray | None = None) -> np.ndarray:
    """``c·exp(α·ln s)`` (``c`` = 1 when None): on the imaginary axis (an FRF without an exponential window)
    ``arg s`` is the same at every frequency, so ``c·s^α = |s|^α·c·e^{jα·arg s}`` needs a real exponential per
    frequency and one complex factor per parameter set, a third of the cost of a complex exponential and its
    product with ``c``."""
    if log_s.phase is not None:
        angle = order * log_s.phase
        phasor = np.empty(np.shape(angle), dtype=complex)
        np.cos(angle, out=phasor.real)
        np.sin(angle, out=phasor.imag)
        return np.exp(order * log_s.magnitude) * (phasor if coefficient is None else coefficient * phasor)
    power = np.exp(order * log_s.value)
    return power if coefficient is None else coefficient * power


@dataclass(frozen=True)
class _Composite(Node, abc.ABC):
    """Elements combined: their parameters in reading order."""

    children: tuple[Node, ...]

    def parameters(self) -> list[Parameter]:
        return [p for child in self.children for p in child.parameters()]


@dataclass(frozen=True)
class Parallel(_Composite):
    def evaluate(
        self, s: np.ndarray, values: Mapping[str, np.ndarray], gradient: bool, log_s: LogLaplace | None = None
    ) -> tuple[np.ndarray, Gradient]:
        parts = [child.evaluate(s, values, gradient, log_s) for child in self.children]
        z = parts[0][0]
        for part, _ in parts[1:]:
            z = z + part
        return z, {name: g for _, grads in parts for name, g in grads.items()}

    def text(self) -> str:
        return " || ".join(_grouped(child) for child in self.children)


@dataclass(frozen=True)
class Series(_Composite):
    def evaluate(
        self, s: np.ndarray, values: Mapping[str, np.ndarray], gradient: bool, log_s: LogLaplace | None = None
    ) -> tuple[np.ndarray, Gradient]:
        parts = [child.evaluate(s, values, gradient, log_s) for child in self.children]
        compliances = [1.0 / part for part, _ in parts]
        compliance = compliances[0]
        for part_compliance in compliances[1:]:
            compliance = compliance + part_compliance
        z = 1.0 / compliance
        # compliances add: d(1/Z) = Σ d(1/Z_i), so dZ/dp = (Z/Z_i)² dZ_i/dp for a parameter of branch i
        gradients: Gradient = {}
        for child, (_, part_gradients), part_compliance in zip(self.children, parts, compliances):
            if part_gradients:
                factor = (z * part_compliance) ** 2
                if isinstance(child, Spring):  # dZ_i/dk = 1
                    gradients[child.name] = factor
                else:
                    gradients.update({name: factor * g for name, g in part_gradients.items()})
        return z, gradients

    def text(self) -> str:
        return " -- ".join(_grouped(child) for child in self.children)


def _shape(node: Node) -> tuple:
    """A network's structure without its parameter names: two parallel arms of one shape are interchangeable."""
    if isinstance(node, _Composite):
        return (type(node).__name__, tuple(_shape(child) for child in node.children))
    return (type(node).__name__,)


def network_shape(node: Node) -> tuple:
    """A network's structure without its parameter names and without the order of its branches (parallel and series
    combinations commute): two networks of one shape describe the same family of films."""
    if isinstance(node, _Composite):
        return (type(node).__name__, tuple(sorted((network_shape(child) for child in node.children), key=repr)))
    return (type(node).__name__,)


def _arm_sort_names(node: Node) -> tuple[list[str], list[str]]:
    """An arm's fractional orders and its springs' stiffnesses (parameter names), in reading order."""
    if isinstance(node, _Composite):
        parts = [_arm_sort_names(child) for child in node.children]
        return [n for orders, _ in parts for n in orders], [n for _, springs in parts for n in springs]
    if isinstance(node, SpringPot):
        return [node.order], []
    if isinstance(node, Spring):
        return [], [node.name]
    return [], []


def _grouped(node: Node) -> str:
    return f"({node.text()})" if isinstance(node, _Composite) else node.text()


class FilmModel:
    """A named network with an ordered parameter list; evaluates Z(s) for one or many parameter sets."""

    def __init__(self, name: str, network: Node, description: str = "") -> None:
        self.name = name
        self.network = network
        self.description = description
        parameters = network.parameters()
        names = [p.name for p in parameters]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise SettingError(f"model {name}: parameter names used twice: {', '.join(duplicates)}")
        self.parameters: tuple[Parameter, ...] = tuple(parameters)

    def __repr__(self) -> str:
        return f"FilmModel({self.name!r}, {self.network.text()!r})"

    def canonical(self, vector: Sequence[float], s_ref: complex | None = None) -> np.ndarray:
        """The same film with its interchangeable parallel arms (two arms of one shape, as FOMGF's and Maxwell's) in
        one order. Either assignment gives the same Z(s); a fitter may land on either, and sessions of a campaign
        must name the same arm alike. With ``s_ref`` (a fit's reference, its resonance) the arm that carries more
        of the film there comes first — a spare arm that fits little (an order near 2 beside a stiff film) comes
        last in every session; without it, the higher fractional order first, then the stiffer spring."""
        values = np.array(vector, dtype=float)
        network = self.network
        if not isinstance(network, Parallel):
            return values
        index = {name: i for i, name in enumerate(self.parameter_names)}
        shapes: dict[tuple, list[Node]] = {}
        for child in network.children:
            shapes.setdefault(_shape(child), []).append(child)
        for arms in (group for group in shapes.values() if len(group) > 1):
            slots = [[index[p.name] for p in arm.parameters()] for arm in arms]

            def key(arm: Node) -> tuple[float, ...]:
                orders, springs = _arm_sort_names(arm)
                order_key = tuple(-values[index[name]] for name in orders + springs)
                if s_ref is None:
                    return order_key
                own = {p.name: np.array([values[index[p.name]]]) for p in arm.parameters()}
                with np.errstate(all="ignore"):
                    magnitude = float(np.abs(arm.stiffness(np.array([s_ref]), own))[0])
                return (-magnitude if np.isfinite(magnitude) else 0.0,) + order_key

            ordered = sorted(arms, key=key)
            taken = [values[[index[p.name] for p in arm.parameters()]] for arm in ordered]
            for slot, arm_values in zip(slots, taken):
                values[slot] = arm_values
        return values

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def text(self) -> str:
        return self.network.text()

    def vector(self, values: Mapping[str, float]) -> np.ndarray:
        """Parameter vector in this model's order from a name → value mapping."""
        missing = [n for n in self.parameter_names if n not in values]
        if missing:
            raise SettingError(f"model {self.name}: missing parameter(s) {', '.join(missing)}")
        return np.array([float(values[n]) for n in self.parameter_names])

    def mapping(self, vector: Sequence[float]) -> dict[str, float]:
        """Name → value mapping from a parameter vector."""
        return {n: float(v) for n, v in zip(self.parameter_names, vector)}

    def stiffness(
        self, s: ArrayLike, params: ArrayLike | Mapping[str, float], log_s: LogLaplace | None = None
    ) -> np.ndarray:
        """Complex stiffness Z(s) in N/m; ``params`` of shape (..., P) gives a result of shape (..., len(s)).
        ``log_s``: ``ln s`` (:func:`log_laplace`), precomputed by a caller evaluating many parameter sets at the
        same ``s ≠ 0``."""
        s, values = self._arguments(s, params)
        return _over_frequencies(self.network.evaluate(s, values, False, log_s)[0], s)

    def resonance_omega_rad_s(self, params: Mapping[str, float], mass_kg: float) -> float:
        """Undamped natural frequency (rad/s) of a mass on this film: the fixed point ``ω = √(Re Z(jω)/M)``, iterated
        from ``√(|Z(j)|/M)`` with Steffensen's acceleration (Aitken's Δ² on each pair of plain steps): a fractional
        film takes ten plain steps, a few accelerated ones."""

        def step(omega: float) -> float:
            stiffness = self.stiffness(np.array([1j * omega]), params)[0].real
            return float(np.sqrt(max(stiffness, 1e-9) / mass_kg))

        omega = float(np.sqrt(abs(self.stiffness(np.array([1j]), params)[0]) / mass_kg))
        for _ in range(20):
            first = step(omega)
            if abs(first - omega) <= 1e-12 * first:
                return first
            second = step(first)
            curvature = second - 2 * first + omega
            accelerated = omega - (first - omega) ** 2 / curvature if curvature != 0 else second
            # an accelerated step that leaves the neighbourhood (or runs negative) is not taken: the plain one is
            omega = accelerated if 0.5 * second < accelerated < 2 * second else second
        return omega

    def stiffness_and_gradient(
        self,
        s: ArrayLike,
        params: ArrayLike | Mapping[str, float],
        log_s: LogLaplace | None = None,
        parameters_first: bool = False,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Z(s) in N/m, shape (..., len(s)), and its analytic derivative dZ/dθ with respect to the parameters in
        :attr:`parameter_names` order, shape (..., len(s), P), in N/m per unit of each parameter; with
        ``parameters_first`` shape (..., P, len(s)), each parameter's derivative contiguous (a fitter's Jacobian)."""
        s, values = self._arguments(s, params)
        z, grads = self.network.evaluate(s, values, True, log_s)
        z = _over_frequencies(z, s)
        count = len(self.parameters)
        if parameters_first:
            gradient = np.empty(z.shape[:-1] + (count,) + z.shape[-1:], dtype=complex)
            for i, name in enumerate(self.parameter_names):
                gradient[..., i, :] = grads[name]
            return z, gradient
        gradient = np.empty(z.shape + (count,), dtype=complex)
        for i, name in enumerate(self.parameter_names):
            gradient[..., i] = grads[name]
        return z, gradient

    def _arguments(
        self, s: ArrayLike, params: ArrayLike | Mapping[str, float]
    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """``s`` as a complex array and the name → value (..., 1) mapping the network evaluates."""
        vector = (params if isinstance(params, np.ndarray) and params.dtype == float
                  else self.vector(params) if isinstance(params, Mapping) else np.asarray(params, dtype=float))
        if vector.shape[-1] != len(self.parameters):
            raise SettingError(
                f"model {self.name}: expected {len(self.parameters)} parameters "
                f"({', '.join(self.parameter_names)}), got {vector.shape[-1]}"
            )
        values = {n: vector[..., i, np.newaxis] for i, n in enumerate(self.parameter_names)}
        return np.asarray(s, dtype=complex), values


def _over_frequencies(z: np.ndarray, s: np.ndarray) -> np.ndarray:
    """A network's stiffness as a complex array over the frequencies (a network of springs alone has one real value
    per parameter set)."""
    if getattr(z, "dtype", None) == complex or np.iscomplexobj(z):
        return z
    return z + np.zeros(np.shape(s), dtype=complex)  # broadcast, as complex


def laplace_variable(freq_hz: ArrayLike, decay_rate_1_s: float = 0.0) -> np.ndarray:
    """``s = σ + j·2πf``: σ is the decay rate of an exponential window applied to force and response alike."""
    return decay_rate_1_s + 2j * np.pi * np.asarray(freq_hz, dtype=float)


def accelerance_from_stiffness(s: ArrayLike, stiffness_n_per_m: ArrayLike, mass_kg: ArrayLike) -> np.ndarray:
    """Accelerance A/F in (m/s²)/N of a mass on a film: ``s² / (Z(s) + m s²)``; at s = jω, ``-ω²/(Z - mω²)``."""
    s = np.asarray(s, dtype=complex)
    mass = np.asarray(mass_kg, dtype=float)
    if mass.ndim:
        mass = mass[..., np.newaxis]
    return s**2 / (np.asarray(stiffness_n_per_m) + mass * s**2)


def accelerance(
    model: FilmModel,
    params: ArrayLike | Mapping[str, float],
    freq_hz: ArrayLike,
    mass_kg: ArrayLike,
    decay_rate_1_s: float = 0.0,
) -> np.ndarray:
    """Accelerance of ``mass_kg`` on the film ``model``; with ``decay_rate_1_s`` > 0 the exponentially windowed one."""
    s = laplace_variable(freq_hz, decay_rate_1_s)
    return accelerance_from_stiffness(s, model.stiffness(s, params), mass_kg)


# --- the short text form -------------------------------------------------------------------------------------------

_TOKEN = re.compile(r"\s*(\|\||--|\(|\)|,|[A-Za-z_][A-Za-z_0-9]*)")


def parse_network(text: str, name: str = "custom", description: str = "") -> FilmModel:
    """Parse the short text form into a model.

    Grammar: ``a || b`` is parallel, ``a -- b`` is series (series binds tighter), parentheses group; a bare name is a
    spring, ``dashpot(c)`` a dashpot and ``pot(eta, alpha)`` a spring-pot. Example (the paper's FOMGF):
    ``k3 || (k1 -- pot(eta1, alpha)) || (k2 -- pot(eta2, beta))``.
    """
    return FilmModel(name, _parsed_node(text), description)


@functools.lru_cache(maxsize=256)
def _parsed_node(text: str) -> Node:
    """The network of ``text`` (nodes are immutable: one parse per text serves every model made of it)."""
    tokens: list[str] = []
    position = 0
    stripped = text.strip()
    while position < len(stripped):
        match = _TOKEN.match(stripped, position)
        if not match:
            raise SettingError(f"model '{text}': cannot read '{stripped[position:]}'")
        tokens.append(match.group(1))
        position = match.end()
    if not tokens:
        raise SettingError("model: the network text is empty")
    parser = _Parser(tokens, text)
    node = parser.parallel()
    if parser.index != len(tokens):
        raise SettingError(f"model '{text}': unexpected '{tokens[parser.index]}'")
    return node


class _Parser:
    def __init__(self, tokens: list[str], text: str) -> None:
        self.tokens = tokens
        self.text = text
        self.index = 0

    def _peek(self) -> str | None:
        return self.tokens[self.index] if self.index < len(self.tokens) else None

    def _take(self, expected: str | None = None) -> str:
        token = self._peek()
        if token is None or (expected is not None and token != expected):
            raise SettingError(f"model '{self.text}': expected '{expected or 'a name'}' but found '{token or 'the end'}'")
        self.index += 1
        return token

    def parallel(self) -> Node:
        nodes = [self.series()]
        while self._peek() == "||":
            self._take("||")
            nodes.append(self.series())
        return nodes[0] if len(nodes) == 1 else Parallel(tuple(nodes))

    def series(self) -> Node:
        nodes = [self.atom()]
        while self._peek() == "--":
            self._take("--")
            nodes.append(self.atom())
        return nodes[0] if len(nodes) == 1 else Series(tuple(nodes))

    def atom(self) -> Node:
        token = self._take()
        if token == "(":
            node = self.parallel()
            self._take(")")
            return node
        if not re.fullmatch(r"[A-Za-z_][A-Za-z_0-9]*", token):
            raise SettingError(f"model '{self.text}': expected an element but found '{token}'")
        if token == "dashpot":
            self._take("(")
            coefficient = self._take()
            self._take(")")
            return Dashpot(coefficient)
        if token == "pot":
            self._take("(")
            coefficient = self._take()
            self._take(",")
            order = self._take()
            self._take(")")
            return SpringPot(coefficient, order)
        return Spring(token)


# --- the paper's nine models (ERRATA.md item 4) --------------------------------------------------------------------

PAPER_MODEL_TEXT: dict[str, tuple[str, str]] = {
    "SD": ("k || dashpot(eta)", "spring-damper"),
    "Zener": ("k2 || (k1 -- dashpot(eta1))", "Zener (standard linear solid)"),
    "Maxwell": ("k3 || (k1 -- dashpot(eta1)) || (k2 -- dashpot(eta2))", "generalised Maxwell, two arms"),
    "TGF": ("(k1 || dashpot(eta1)) -- dashpot(eta2)", "three-parameter gas film"),
    "BGF": ("k1 -- dashpot(eta1) -- (k2 || dashpot(eta2))", "Burgers gas film"),
    "FOZGF": ("k2 || (k1 -- pot(eta1, alpha))", "fractional-order Zener gas film"),
    "FOMGF": ("k3 || (k1 -- pot(eta1, alpha)) || (k2 -- pot(eta2, beta))", "fractional-order Maxwell gas film"),
    "FOTGF": ("(k1 || pot(eta1, alpha)) -- pot(eta2, beta)", "fractional-order three-parameter gas film"),
    "FOBGF": ("k1 -- pot(eta1, alpha) -- (k2 || pot(eta2, beta))", "fractional-order Burgers gas film"),
}

#: The nine models in the order of the paper's Table 2.
PAPER_MODEL_ORDER = ("SD", "FOZGF", "Zener", "FOMGF", "Maxwell", "FOTGF", "FOBGF", "TGF", "BGF")

PAPER_MODELS: dict[str, FilmModel] = {
    name: parse_network(text, name, description) for name, (text, description) in PAPER_MODEL_TEXT.items()
}

#: Table 1 of the paper (identified parameters, SI units). ERRATA item 5: the Zener and FOZGF rows contain errors.
PAPER_TABLE1: dict[str, dict[str, float]] = {
    "SD": {"k": 3.78e7, "eta": 3.45e3},
    "FOZGF": {"k1": 3.20e5, "k2": 4.61e9, "eta1": 4.33e8, "alpha": 1.9186},
    "Zener": {"k1": 4.85e4, "k2": 3.81e7, "eta1": 2.75e5},
    "FOMGF": {"k1": 2.91e6, "k2": 4.89e8, "k3": 3.27e7, "eta1": 16.14, "eta2": 101.81, "alpha": 1.7472, "beta": 0.1621},
    "Maxwell": {"k1": 3.53e7, "k2": 2.93e6, "k3": 1.09e5, "eta1": 2.57e5, "eta2": 5.19e6},
    "FOTGF": {"k1": 2.00e6, "eta1": 3.86e7, "eta2": 1.14e6, "alpha": 0.0036, "beta": 0.80},
    "FOBGF": {"k1": 4.05e7, "k2": 3.01e8, "eta1": 1.75e4, "eta2": 1.21e5, "alpha": 1.3641, "beta": 0.0773},
    "TGF": {"k1": 2.13e10, "eta1": 2.12e4, "eta2": 4.259e10},
    "BGF": {"k1": 9.95e6, "k2": 4.898e10, "eta1": 4.84e8, "eta2": 1.8e8},
}

PAPER_MASS_KG = 25.05


def get_model(name_or_text: str) -> FilmModel:
    """A paper model by name (case-insensitive), or a new network written in the short text form."""
    wanted = name_or_text.strip()
    for name, model in PAPER_MODELS.items():
        if name.lower() == wanted.lower():
            return model
    if not any(operator in wanted for operator in ("||", "--", "(")):
        raise SettingError(
            f"model '{name_or_text}': unknown; choose one of {', '.join(PAPER_MODEL_ORDER)} or write a network "
            f"such as 'k || dashpot(eta)'"
        )
    return parse_network(wanted)
