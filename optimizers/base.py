"""The optimiser interface: Protocol, result, bounds and the budgeted objective (optimizers.md §1).

Every optimiser in this package is a frozen dataclass of hyper-parameters with one method,
``minimize(fun, bounds, *, rng=None, max_evals=10_000, x0=None) -> OptimizeResult``. The objective is
a *batch* objective: it receives an ``(n, d)`` array of candidate points and returns ``(n,)`` costs.
:class:`BudgetedObjective` is the only caller of ``fun``: it enforces the evaluation budget, checks
the returned shape, maps NaN to ``+inf``, keeps the best evaluated point and records the history.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, TypeAlias, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import Bounds

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BatchObjective: TypeAlias = Callable[[FloatArray], ArrayLike]
"""A batch objective: ``(n, d)`` float64 points -> ``(n,)`` costs."""
BoundsLike: TypeAlias = tuple[ArrayLike, ArrayLike] | Sequence[tuple[float, float]] | Bounds
"""``scipy.optimize.Bounds``, ``(d, 2)`` pairs, or a ``(lower, upper)`` pair of arrays (D29)."""
RNGLike: TypeAlias = np.random.Generator | np.random.SeedSequence | int
"""Anything :func:`numpy.random.default_rng` accepts (besides ``None``)."""

MESSAGE_MAX_EVALS = "max_evals reached"
MESSAGE_INIT_EXHAUSTED = "budget exhausted during initialisation"
NO_FINITE_SUFFIX = "; no finite cost found"


class ReadOnlyMapping(Mapping[str, Any]):
    """A read-only mapping that pickles and deep-copies (``OptimizeResult.trace``).

    ``types.MappingProxyType`` would be read-only too, but it cannot be pickled, and results travel
    between worker processes.

    Args:
        data: The items (copied).
    """

    __slots__ = ("_data",)

    def __init__(self, data: Mapping[str, Any] | None = None) -> None:
        self._data = dict(data or {})

    def __getitem__(self, key: str) -> Any:
        return self._data[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._data!r})"


@dataclass(frozen=True, eq=False)
class OptimizeResult:
    """What an optimiser returns (scipy's names; optimizers.md §1).

    Compare results field by field (``np.array_equal`` for the arrays); ``==`` is identity, because
    element-wise array comparison has no single truth value.

    Attributes:
        x: (d,) best point ever evaluated (the first evaluated point if no cost was finite).
        fun: Its cost; ``+inf`` if no finite cost was ever returned.
        nfev: Objective rows evaluated, ``<= max_evals``.
        nit: Iterations after initialisation (a truncated last iteration counts).
        history: (nit + 1,) best-so-far cost after initialisation and after each iteration.
        history_nfev: (nit + 1,) evaluations spent at each history entry.
        message: Why the optimiser stopped.
        trace: A read-only record of the run's state machine, for optimisers with phases (empty for the
            others). Keys per optimiser (docs/swarm.md §6): HPSO ``stage1_iterations``,
            ``stage2_start``, ``regroup_iterations``; IHPSO ``mode``, ``switch_iterations``,
            ``reverse_switch_iterations``, ``termination_tests``, ``locked_at``, ``stopped_by``; PS2O
            ``extinctions``; LPSO ``global_best_from``. Sequences are tuples; iterations count from 1.
    """

    x: FloatArray
    fun: float
    nfev: int
    nit: int
    history: FloatArray
    history_nfev: IntArray
    message: str
    trace: Mapping[str, Any] = field(default_factory=ReadOnlyMapping)

    def __post_init__(self) -> None:
        if not isinstance(self.trace, ReadOnlyMapping):
            object.__setattr__(self, "trace", ReadOnlyMapping(self.trace))


@runtime_checkable
class Optimizer(Protocol):
    """A black-box batch minimiser (optimizers.md §1)."""

    def minimize(
        self,
        fun: BatchObjective,
        bounds: BoundsLike,
        *,
        rng: RNGLike | None = None,
        max_evals: int = 10_000,
        x0: ArrayLike | None = None,
    ) -> OptimizeResult:
        """Minimise ``fun`` inside ``bounds`` with at most ``max_evals`` objective rows.

        Args:
            fun: Batch objective, ``(n, d) -> (n,)``.
            bounds: Box constraints in any form accepted by :func:`normalize_bounds`.
            rng: Seed or Generator; the only source of randomness.
            max_evals: Hard cap on the number of objective rows.
            x0: Optional ``(d,)`` warm start (clipped into the bounds).

        Returns:
            The best point evaluated and the run's statistics.
        """
        ...


def require(condition: bool, owner: str, field: str, value: object, rule: str) -> None:
    """Raise a ``ValueError`` naming the field, the value and the rule unless ``condition`` holds.

    Args:
        condition: What must hold.
        owner: Class name, used as the prefix of the field path.
        field: The hyper-parameter's name.
        value: The offending value.
        rule: What was expected, in words.

    Raises:
        ValueError: ``"<owner>.<field>: got <value>, expected <rule>"``.
    """
    if not condition:
        raise ValueError(f"{owner}.{field}: got {value!r}, expected {rule}")


def require_integer(owner: object, field: str, minimum: int, why: str = "") -> None:
    """:func:`require` of an integer hyper-parameter: ``owner.<field>`` must be an integer >= ``minimum``.

    Args:
        owner: The optimiser instance; its class name prefixes the field path.
        field: The hyper-parameter's name.
        minimum: Its smallest allowed value.
        why: The reason for the minimum, added to the rule in parentheses (``""``: none).

    Raises:
        ValueError: ``"<owner>.<field>: got <value>, expected an integer >= <minimum>[ (<why>)]"``.
    """
    value = getattr(owner, field)
    rule = f"an integer >= {minimum}" + (f" ({why})" if why else "")
    require(is_int(value) and value >= minimum, type(owner).__name__, field, value, rule)


def coerce_pair(obj: object, field: str) -> tuple:
    """Store a two-element hyper-parameter of a frozen dataclass as a tuple and return it.

    Lists and arrays are accepted (``get_optimizer("pso", inertia=[0.9, 0.3])``) and kept as tuples,
    so that instances stay hashable and comparable.

    Raises:
        ValueError: If the value is not a sequence of two elements.
    """
    value = getattr(obj, field)
    try:
        pair = tuple(value)  # type: ignore[call-overload]
    except TypeError:
        pair = ()
    require(len(pair) == 2, type(obj).__name__, field, value, "a pair of two values")
    object.__setattr__(obj, field, pair)
    return pair


def is_int(value: object) -> bool:
    """Whether ``value`` is an integer (Python or numpy), excluding ``bool``."""
    return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))


def is_real(value: object) -> bool:
    """Whether ``value`` is a finite real number (Python or numpy), excluding ``bool``."""
    return (
        isinstance(value, numbers.Real)
        and not isinstance(value, (bool, np.bool_))
        and math.isfinite(float(value))
    )


def normalize_bounds(bounds: BoundsLike) -> tuple[FloatArray, FloatArray]:
    """Convert any accepted bounds form into fresh ``lo, hi`` float64 arrays of shape ``(d,)``.

    Accepted forms (D29): ``scipy.optimize.Bounds``; an array-like of shape ``(d, 2)`` (scipy pairs);
    an array-like of shape ``(2, d)`` (``(lower, upper)``). Shape ``(2, 2)`` is read as pairs, as scipy
    does; a two-dimensional ``(lower, upper)`` must be passed as ``Bounds``.

    Args:
        bounds: The bounds in one of the forms above.

    Returns:
        ``(lo, hi)``, new arrays (the input is never mutated or aliased).

    Raises:
        ValueError: If the form is not recognised, or a component is not finite or has ``lo >= hi``;
            the message names the index, the values and the rule.
    """
    if isinstance(bounds, Bounds):
        try:
            lo, hi = np.broadcast_arrays(
                np.asarray(bounds.lb, dtype=np.float64), np.asarray(bounds.ub, dtype=np.float64)
            )
        except ValueError as exc:
            raise ValueError(f"bounds: Bounds.lb and Bounds.ub have incompatible shapes ({exc})") from None
        if lo.ndim != 1:
            raise ValueError(
                f"bounds: got Bounds with lb/ub of shape {lo.shape}, expected one-dimensional arrays "
                "(scalar Bounds do not define the dimension)"
            )
        lo, hi = lo.copy(), hi.copy()
    else:
        try:
            arr = np.array(bounds, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"bounds: could not read {bounds!r} as numbers ({exc}); expected (d, 2) pairs, "
                "a (lower, upper) pair of arrays, or scipy.optimize.Bounds"
            ) from None
        if arr.ndim == 2 and arr.shape[1] == 2:
            lo, hi = arr[:, 0].copy(), arr[:, 1].copy()
        elif arr.ndim == 2 and arr.shape[0] == 2:
            lo, hi = arr[0].copy(), arr[1].copy()
        else:
            raise ValueError(
                f"bounds: got an array of shape {arr.shape}, expected (d, 2) pairs, a (lower, upper) "
                "pair of shape (2, d), or scipy.optimize.Bounds"
            )
    if lo.size == 0:
        raise ValueError("bounds: got zero dimensions, expected at least one (lower, upper) pair")
    with np.errstate(over="ignore", invalid="ignore"):  # the width check below reports it
        width = hi - lo
    bad = ~(np.isfinite(lo) & np.isfinite(hi) & (lo < hi) & np.isfinite(width))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"bounds[{i}]: got lower={float(lo[i])!r}, upper={float(hi[i])!r}, "
            "expected finite values with lower < upper and a finite width upper - lower"
        )
    return lo, hi


def check_x0(x0: ArrayLike | None, lo: FloatArray, hi: FloatArray) -> FloatArray | None:
    """Validate a warm start and clip it into the bounds (D1).

    Args:
        x0: ``None`` or a ``(d,)`` array-like of finite numbers.
        lo: (d,) lower bounds.
        hi: (d,) upper bounds.

    Returns:
        ``None``, or a new ``(d,)`` array ``clip(x0, lo, hi)``.

    Raises:
        ValueError: If ``x0`` has the wrong shape or a non-finite component.
    """
    if x0 is None:
        return None
    try:
        arr = np.array(x0, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"x0: could not read {x0!r} as numbers ({exc}); expected {lo.size} finite numbers, one per bound"
        ) from None
    if arr.shape != lo.shape:
        raise ValueError(f"x0: got shape {arr.shape}, expected {lo.shape} (one value per bound)")
    if not np.all(np.isfinite(arr)):
        i = int(np.flatnonzero(~np.isfinite(arr))[0])
        raise ValueError(f"x0[{i}]: got {float(arr[i])!r}, expected a finite value")
    return np.minimum(np.maximum(arr, lo), hi)


def make_rng(rng: object) -> np.random.Generator:
    """The run's Generator from ``rng`` (:func:`numpy.random.default_rng`), refusing what it should not take.

    Raises:
        ValueError: ``rng`` is a bool, a negative integer, a float, a string or anything else
            numpy cannot seed from, naming the argument, the value and what is accepted.
    """
    expected = "expected None, an integer >= 0, a sequence of them, a numpy SeedSequence or Generator"
    if isinstance(rng, (bool, np.bool_)):  # numpy would seed from True == 1: surely a mistake
        raise ValueError(f"rng: got {rng!r}, {expected}")
    try:
        return np.random.default_rng(rng)  # type: ignore[arg-type]
    except (TypeError, ValueError) as error:
        raise ValueError(f"rng: got {rng!r}, {expected} ({error})") from None


def check_max_evals(max_evals: object) -> int:
    """Return ``max_evals`` as an ``int`` after checking that it is an integer ``>= 1``.

    Raises:
        ValueError: If it is not an integer ``>= 1``.
    """
    if not is_int(max_evals) or int(max_evals) < 1:  # type: ignore[call-overload]
        raise ValueError(f"max_evals: got {max_evals!r}, expected an integer >= 1")
    return int(max_evals)  # type: ignore[call-overload]


class BudgetedObjective:
    """The only caller of the user's objective: budget, checks, best tracker and history (§1).

    ``__call__(X)`` follows the four rules of optimizers.md §1:

    1. ``X`` must be 2-D with ``d`` columns and at least one row; if the budget is already spent
       (``remaining == 0``) it raises ``RuntimeError``: optimisers check :attr:`remaining` first.
    2. Only the first ``m = min(n, remaining)`` rows are passed to ``fun`` (as a fresh copy, in one
       call); the result must have shape ``(m,)``; it is cast to float64, NaN becomes ``+inf`` (D30)
       and ``-inf`` raises ``ValueError``.
    3. ``nfev`` grows by ``m``; the returned ``(n,)`` array holds the ``m`` costs followed by ``+inf``.
    4. The best evaluated row is tracked with a strict ``<`` (the first of equal costs wins, D7).

    The optimiser appends to the history with :meth:`record` and builds its result with
    :meth:`result`.

    Args:
        fun: The user's batch objective.
        dim: Number of columns ``d``.
        max_evals: Hard cap on evaluated rows (an integer ``>= 1``).
    """

    def __init__(self, fun: BatchObjective, dim: int, max_evals: int) -> None:
        self.fun = fun
        self.dim = int(dim)
        self.max_evals = check_max_evals(max_evals)
        self.nfev = 0
        self.best_x: FloatArray | None = None
        self.best_f = math.inf
        self.first_x: FloatArray | None = None
        self.max_finite = -math.inf  # largest finite cost seen (for the finite stand-in, §3b)
        self._history: list[float] = []
        self._history_nfev: list[int] = []

    @property
    def remaining(self) -> int:
        """Evaluations left in the budget."""
        return self.max_evals - self.nfev

    def __call__(self, X: FloatArray) -> FloatArray:
        """Evaluate the rows of ``X`` within the budget.

        Args:
            X: (n, d) points, ``n >= 1``.

        Returns:
            (n,) costs; rows beyond the budget get ``+inf``.

        Raises:
            ValueError: If ``X`` has the wrong shape, or ``fun`` returns a wrong shape or ``-inf``.
            RuntimeError: If the budget is already spent.
        """
        if X.ndim != 2 or X.shape[1] != self.dim or X.shape[0] < 1:
            raise ValueError(f"candidate batch has shape {X.shape}, expected (n >= 1, {self.dim})")
        n = X.shape[0]
        r = self.max_evals - self.nfev
        if r == 0:
            raise RuntimeError("the evaluation budget is spent; check BudgetedObjective.remaining first")
        m = n if n <= r else r
        raw = self.fun(np.array(X[:m], dtype=np.float64))  # a fresh copy: fun may mutate or keep it
        if np.iscomplexobj(raw):  # numpy would drop the imaginary part with only a warning
            raise ValueError(f"objective returned complex values, expected an ({m},) array of real costs")
        try:
            f = np.array(raw, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"objective returned {type(raw).__name__}, expected an ({m},) array ({exc})"
            ) from None
        if f.shape != (m,):
            raise ValueError(f"objective returned shape {f.shape}, expected ({m},)")
        nan = np.isnan(f)
        if nan.any():
            f[nan] = np.inf  # DECISION: optimizers.md D30 (NaN is never a best)
        i = int(np.argmin(f))
        if f[i] == -np.inf:
            raise ValueError(
                f"objective returned -inf for row {i}; the objective would be unbounded below "
                "(return a finite cost, +inf or NaN instead)"
            )
        if self.nfev == 0:
            self.first_x = np.array(X[0], dtype=np.float64)
        self.nfev += m
        if f[i] < self.best_f:
            self.best_f = float(f[i])
            self.best_x = np.array(X[i], dtype=np.float64)
        top = f.max()
        if top < np.inf:
            if top > self.max_finite:
                self.max_finite = float(top)
        else:
            finite = f[np.isfinite(f)]
            if finite.size and finite.max() > self.max_finite:
                self.max_finite = float(finite.max())
        if m == n:
            return f
        out = np.full(n, np.inf)
        out[:m] = f
        return out

    def finite_stand_in(self) -> float:
        """A finite cost that is worse than every finite cost seen so far (§3b).

        External libraries never see ``+inf`` (or NaN): the adapters replace it by ten times the largest
        finite cost seen, or ``1e30`` before any.

        DECISION: "ten times the largest" is not worse than the largest when that cost is ``<= 0``
        (or below 1/9), so the stand-in is ``m + max(9 |m|, 1)``, which equals ``10 m`` for ``m >= 1/9``
        and stays above ``m`` otherwise; it is capped at 1e300 so that libraries' statistics cannot
        overflow.
        """
        m = self.max_finite
        if m == -math.inf:
            return 1e30
        return min(m + max(9.0 * abs(m), 1.0), 1e300)

    def finite_costs(self, f: FloatArray) -> FloatArray:
        """Return a copy of ``f`` with every non-finite entry replaced by :meth:`finite_stand_in`."""
        out = np.array(f, dtype=np.float64)
        bad = ~np.isfinite(out)
        if bad.any():
            out[bad] = self.finite_stand_in()
        return out

    def record(self) -> None:
        """Append the current best-so-far cost and evaluation count to the history."""
        self._history.append(self.best_f)
        self._history_nfev.append(self.nfev)

    def result(self, nit: int, message: str, trace: Mapping[str, Any] | None = None) -> OptimizeResult:
        """Build the :class:`OptimizeResult` from the tracker and the recorded history.

        Args:
            nit: Iterations after initialisation; the history must hold ``nit + 1`` entries.
            message: Why the run stopped; ``"; no finite cost found"`` is appended when no cost was
                finite.
            trace: The run's state-machine trace (see :class:`OptimizeResult`); empty if ``None``.

        Returns:
            The result, with ``x`` the best evaluated row (or the first evaluated row if none was finite).

        Raises:
            RuntimeError: If nothing was evaluated or the history length does not match ``nit``
                (a bug in the calling optimiser).
        """
        if self.first_x is None:
            raise RuntimeError("no point was evaluated")
        if len(self._history) != nit + 1:
            raise RuntimeError(f"history has {len(self._history)} entries, expected nit + 1 = {nit + 1}")
        if self.best_x is None:
            x = self.first_x.copy()
            message += NO_FINITE_SUFFIX
        else:
            x = self.best_x.copy()
        return OptimizeResult(
            x=x,
            fun=float(self.best_f),
            nfev=int(self.nfev),
            nit=int(nit),
            history=np.array(self._history, dtype=np.float64),
            history_nfev=np.array(self._history_nfev, dtype=np.int64),
            message=message,
            trace=ReadOnlyMapping(trace),
        )


@dataclass(frozen=True)
class Problem:
    """A validated minimisation problem: bounds, warm start and the budgeted objective.

    Attributes:
        lo: (d,) lower bounds.
        hi: (d,) upper bounds.
        x0: ``None`` or the (d,) warm start clipped into the bounds.
        objective: The budgeted objective wrapping the user's ``fun``.
    """

    lo: FloatArray
    hi: FloatArray
    x0: FloatArray | None
    objective: BudgetedObjective

    @property
    def dim(self) -> int:
        """Number of decision variables ``d``."""
        return int(self.lo.shape[0])

    @property
    def span(self) -> FloatArray:
        """(d,) ``hi - lo``."""
        return self.hi - self.lo


def prepare(fun: BatchObjective, bounds: BoundsLike, max_evals: int, x0: ArrayLike | None) -> Problem:
    """Validate the arguments every ``minimize`` shares (§1) and wrap ``fun`` in the budget.

    Args:
        fun: The user's batch objective.
        bounds: Bounds in any accepted form.
        max_evals: Integer ``>= 1``.
        x0: Optional warm start.

    Returns:
        The validated :class:`Problem`.

    Raises:
        ValueError: For bad bounds, ``max_evals`` or ``x0``.
        TypeError: If ``fun`` is not callable.
    """
    if not callable(fun):
        raise TypeError(f"fun: got {type(fun).__name__}, expected a callable batch objective")
    lo, hi = normalize_bounds(bounds)
    budget = check_max_evals(max_evals)
    start = check_x0(x0, lo, hi)
    return Problem(lo=lo, hi=hi, x0=start, objective=BudgetedObjective(fun, lo.shape[0], budget))


def replace_params(instance: object, **overrides: object) -> object:
    """``dataclasses.replace`` with an error that lists the valid parameter names.

    Raises:
        TypeError: If ``instance`` is not a dataclass or a name is not one of its fields.
    """
    if not dataclasses.is_dataclass(instance) or isinstance(instance, type):
        raise TypeError(f"{type(instance).__name__} is not a dataclass; it takes no parameter overrides")
    names = [f.name for f in dataclasses.fields(instance) if f.init]
    unknown = sorted(set(overrides) - set(names))
    if unknown:
        raise TypeError(
            f"{type(instance).__name__} has no parameter {unknown[0]!r}; parameters: {', '.join(names)}"
        )
    return dataclasses.replace(instance, **overrides)


class OptimizerBase:
    """The ``minimize`` every optimiser of this package shares: validate, then :meth:`solve` (§1).

    A subclass (usually a frozen dataclass of hyper-parameters) implements only :meth:`solve`, which
    receives the validated :class:`Problem` (bounds, clipped warm start, budgeted objective) and the
    run's Generator. The swarms implement it once, in :class:`optimizers.swarm.SwarmOptimizer`.
    """

    def minimize(
        self,
        fun: BatchObjective,
        bounds: BoundsLike,
        *,
        rng: RNGLike | None = None,
        max_evals: int = 10_000,
        x0: ArrayLike | None = None,
    ) -> OptimizeResult:
        """Minimise ``fun`` inside ``bounds`` (see :class:`Optimizer`; the details are in :meth:`solve`).

        Raises:
            ValueError: For bad bounds, ``max_evals``, ``x0`` or ``rng`` (and the optimiser's own
                checks), naming the argument, the value and the domain.
            TypeError: If ``fun`` is not callable.
        """
        generator = make_rng(rng)
        return self.solve(prepare(fun, bounds, max_evals, x0), generator)

    def solve(self, problem: Problem, rng: np.random.Generator) -> OptimizeResult:
        """Run the optimiser on a validated problem; the only source of randomness is ``rng``."""
        raise NotImplementedError
