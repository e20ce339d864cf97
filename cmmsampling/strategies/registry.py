"""The strategies' records: what the project knows of each strategy, said once, and the table
:data:`STRATEGIES` that sample(), the studies, the command line and both panels read.

A strategy module declares its runner and its :class:`Strategy` record; ``sampling`` registers
the built-in ones, a user's module calls :func:`register_strategy`.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from ..geometry.validation import InputError, InputTypeError

if TYPE_CHECKING:   # for the annotations only
    from .problem import SamplingProblem


class OptionsCheck(Protocol):
    """A strategy's check of its options: the options (merged with the defaults) -> the cleaned
    options; InputError or InputTypeError naming the first bad one."""

    def __call__(self, options: dict[str, Any], /) -> dict[str, Any]: ...


class MemoryNeed(Protocol):
    """The bytes a strategy's run needs beyond every run's base: (n points, the substitute's
    poles (n_u, n_v), the evaluation grid's nodes, its options, worker processes) -> bytes."""

    def __call__(self, n: int, poles: tuple[int, int], nodes: int, options: dict[str, Any], workers: int, /) -> int: ...


@dataclass
class StrategyOutcome:
    """What a strategy returns.

    uv: (N, 2) parameters on the face; history: best maximum deviation (mm) per iteration for
    the optimisers, else None; evaluations: fitness evaluations spent; cancelled: stopped early;
    details: figures for the settings; notes: sentences for the user about what was done.
    """

    uv: np.ndarray
    history: np.ndarray | None = None
    evaluations: int = 0
    cancelled: bool = False
    details: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)


@dataclass(frozen=True)
class Setting:
    """An option of a strategy that the command line and the comparison panel offer.

    option: its keyword in sample(); kind: int or float; help: one line, with its unit.
    """

    option: str
    kind: type
    help: str


# A strategy's progress: (iteration, best maximum deviation mm) -> True to cancel.
Progress = Callable[[int, float], bool | None]
# A strategy's run: (problem: the SamplingProblem, progress: callable(iteration, best maximum mm)
# -> True to cancel, or None, **its options) -> StrategyOutcome. The options differ from strategy
# to strategy (part_error's prior, pso's population), so the type states what comes back.
Runner = Callable[..., StrategyOutcome]


@dataclass(frozen=True)
class Strategy:
    """Everything the project knows of one strategy, said once; every other module reads it here.

    name: the identifier sample() takes; run: (problem, progress, **options) -> StrategyOutcome;
    description: one line (tooltips, --help); label: its name in tables, figures and reports;
    options: its own options with their defaults; check: options (merged with the defaults) ->
    the cleaned options, raising InputError or InputTypeError, or None when any value goes;
    optimiser: it searches with the objective and reports progress (iteration, best max mm);
    progress_unit: what one of those progress steps is; progress_total: the option that says how
    many there will be (None: unknown in advance); seeded: its points depend on the seed, so a
    study runs it once per seed; figures: the report draws its deviation histogram; reference:
    a layout the others are drawn against in the convergence figures; baseline: the layout the
    studies' and tables' ratios divide by (one strategy has it);
    settings: the options the command line and the comparison panel offer (Setting);
    memory: (n, poles (n_u, n_v), grid nodes, options, workers) -> bytes it needs beyond every
    run's base (cmmsampling.runtime.memory), None for nothing that grows with N;
    requires: the options it cannot run without (part_error's prior): studies, plans and panels
    run it only where those are given (:func:`self_contained`).
    Every strategy keeps the same default minimum spacing (cmmsampling.strategies.settings.default_min_spacing).
    """

    name: str
    run: Runner
    description: str
    label: str
    options: dict[str, Any] = field(default_factory=dict)
    check: OptionsCheck | None = None
    optimiser: bool = False
    progress_unit: str = "step"
    progress_total: str | None = None
    seeded: bool = False
    figures: bool = False
    reference: bool = False
    baseline: bool = False
    settings: tuple[Setting, ...] = ()
    memory: MemoryNeed | None = None
    requires: tuple[str, ...] = ()

    def checked_options(self, options: dict[str, Any]) -> dict[str, Any]:
        """The defaults updated by ``options``, validated: TypeError for an option it does not take."""
        unknown = sorted(set(options) - set(self.options))
        if unknown:
            takes = ", ".join(self.options) or "no options"
            raise InputTypeError(f"strategy {self.name!r} does not take {', '.join(unknown)}; it takes {takes}")
        merged = {**self.options, **options}
        return self.check(merged) if self.check else merged

    def progress_steps(self, options: dict[str, Any]) -> int | None:
        """How many progress steps a run with ``options`` (given ones; the rest default) will
        report, or None when that is not known in advance."""
        if self.progress_total is None:
            return None
        return options.get(self.progress_total, self.options.get(self.progress_total))


STRATEGIES: dict[str, Strategy] = {}


def register_strategy(strategy: Strategy) -> Strategy:
    """Add a Strategy record (replacing one of the same name): sample(), compare(), the report, the
    command line and both panels offer it from then on. Returns the record."""
    if not isinstance(strategy, Strategy):
        raise InputTypeError(f"register takes a cmmsampling Strategy record, got {type(strategy).__name__}")
    STRATEGIES[strategy.name] = strategy
    return strategy


def unregister_strategy(name: str) -> None:
    """Remove the strategy named ``name`` (KeyError when there is none)."""
    del STRATEGIES[name]


def strategy_label(name: str) -> str:
    """The display name of a strategy (its record's label; the name itself for one not registered,
    e.g. a result of ``evaluate(strategy="given")``)."""
    return STRATEGIES[name].label if name in STRATEGIES else name


def baseline() -> str:
    """The name of the layout the studies' and tables' ratios divide by (its record says baseline)."""
    return next(name for name, entry in STRATEGIES.items() if entry.baseline)


def strategy_options(strategy: str, options: dict[str, Any]) -> dict[str, Any]:
    """The strategy's options: defaults updated by ``options``, validated.

    Raises TypeError for an option the strategy does not take (listing those it does).
    """
    return STRATEGIES[strategy].checked_options(options)


def self_contained() -> list[str]:
    """Names of the strategies that need nothing beyond the face (no ``requires``), in order:
    those a study, a plan or a panel runs without being told more."""
    return [name for name, entry in STRATEGIES.items() if not entry.requires]


def layouts(problem: SamplingProblem, required: Sequence[str] = (),
            optional: Sequence[str] = ()) -> dict[str, np.ndarray]:
    """{name: uv (N, 2)} of the named strategies' layouts with their default options, in the order
    given; a refusal (InputError) of a required one is raised, an optional one is left out."""
    found = {}
    for name in (*required, *optional):
        try:
            found[name] = STRATEGIES[name].run(problem, None, **STRATEGIES[name].options).uv
        except InputError:
            if name in required:
                raise
    return found
