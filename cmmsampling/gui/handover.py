"""A run made in a panel's worker thread, handed over to the console line that echoes it.

The panels and commands run sample(), compare(), write_report(), plan(), inspect() and measure()
in a worker thread (progress, Cancel), then echo the call in FreeCAD's Python console, e.g.
``result = cmmsampling.sample(face, n=49, ...)``, where it must not run a second time; replayed
as a macro in another session, the same line runs it. :func:`handed` stands in for the
``cmmsampling`` function for the one echoed line: the call whose source and arguments are
exactly those of the run (the source and any shape, such as the part, the same shape) returns
the run, once; any other call runs the function. The engines know nothing of this.

Pure Python (no FreeCADGui): tested headless.
"""
from __future__ import annotations

import contextlib
import functools
import inspect
from collections.abc import Callable, Iterator
from typing import Any

import cmmsampling


@contextlib.contextmanager
def handed(name: str, source: Any, arguments: dict[str, Any], value: Any) -> Iterator[None]:
    """Within the block, ``cmmsampling.<name>(source, ...)`` with exactly ``arguments`` (however
    given: by position or by name, defaults left out) returns ``value`` at once, the first time.

    name: the function's name in the cmmsampling package (e.g. "sample"); source: its first
    argument as the run had it (the face, the study, the document object); arguments: the run's
    other arguments by name, without progress.
    """
    function = getattr(cmmsampling, name)
    expected = full_call(function, source, (), arguments)
    left = [value]

    @functools.wraps(function)
    def replay(*args: Any, **kwargs: Any) -> Any:
        if left and args and same_value(full_call(function, args[0], args[1:], kwargs), expected):
            return left.pop()
        return function(*args, **kwargs)

    setattr(cmmsampling, name, replay)
    try:
        yield
    finally:
        setattr(cmmsampling, name, function)


def full_call(function: Callable[..., Any], source: Any, args: tuple, kwargs: dict[str, Any]) -> dict[str, Any]:
    """A call of function as one dict for comparing two calls: its first parameter's name bound to
    source, every other one by name with the defaults filled in, ``progress`` left out and a
    ``**options`` catch-all flattened, sorted by name."""
    signature = inspect.signature(function)
    bound = signature.bind(source, *args, **kwargs)
    bound.apply_defaults()
    call = dict(bound.arguments)
    call.pop("progress", None)
    for parameter_name, parameter in signature.parameters.items():
        if parameter.kind is inspect.Parameter.VAR_KEYWORD:
            call.update(call.pop(parameter_name))
    return dict(sorted(call.items()))


def same_value(a: Any, b: Any) -> bool:
    """True when two arguments are the same: shapes (anything with ``isSame``, e.g. the part a
    face belongs to) when they are the same shape, dicts key by key, lists and tuples item by
    item, other values (a study) when they are the same object or by repr."""
    if a is b:
        return True
    if hasattr(a, "isSame"):
        return isinstance(b, type(a)) and a.isSame(b)
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same_value(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return isinstance(b, (list, tuple)) and len(a) == len(b) and all(map(same_value, a, b))
    return repr(a) == repr(b)
