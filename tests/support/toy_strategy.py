"""A toy strategy, added the way a new strategy is: one module with its runner and one record.

tests/strategies/test_strategy_records.py and the GUI tests register it and see it offered everywhere."""
import cmmsampling
from cmmsampling.strategies.blind import halton


def mirrored_halton(problem, progress, flips):
    """A toy strategy: Halton's points with u mirrored ``flips`` times (an odd count mirrors it)."""
    uv = halton(problem).uv.copy()
    if flips % 2:
        uv[:, 0] = problem.domain.lower[0] + problem.domain.upper[0] - uv[:, 0]
    return cmmsampling.StrategyOutcome(uv)


def _check_flips(options):
    """The toy's options, checked: flips a whole number >= 0."""
    if not isinstance(options["flips"], int) or options["flips"] < 0:
        raise ValueError(f"flips must be a whole number >= 0, got {options['flips']!r}")
    return options


TOY = cmmsampling.Strategy(
    "mirrored_halton", mirrored_halton, "Halton's points mirrored along u (a toy for the tests)",
    "mirrored Halton", {"flips": 1}, _check_flips, seeded=True, figures=True,
    settings=(cmmsampling.Setting("flips", int, "how often the toy mirrors its points (default 1)"),))
