"""A run made elsewhere in this process, handed over to the one call that would make it again.

The task panels run sample() and compare() in a worker thread (progress, cancel) and then echo
the call in FreeCAD's Python console, where it must not run a second time (nor the comparison's
write_report()); replayed as a macro in another session, the same line runs it. The echoed call takes what was handed over when its
face and its arguments are exactly those of the run (the face and any shape, such as the part,
the same shape), and only once.
"""
import inspect

_HANDED = {}


def give(function, face, arguments, value):
    """Let the next ``function(face, **arguments)`` in this process return ``value`` at once.

    function: the API function (sample or compare); face: the Part.Face it ran on (the same
    shape, ``isSame``); arguments: its keyword arguments other than face and progress.
    """
    _HANDED[function.__qualname__] = (face, full_call(function, arguments), value)


def take(function, face, arguments):
    """What was handed over to exactly this call (face and arguments), or None; what was handed
    over to ``function`` is dropped either way, so that a later call computes."""
    handed = _HANDED.pop(function.__qualname__, None)
    if handed is None:
        return None
    handed_face, handed_call, value = handed
    return value if same_value(face, handed_face) and same_value(full_call(function, arguments), handed_call) else None


def same_value(a, b):
    """True when two arguments are the same: shapes (anything with ``isSame``, e.g. the part a
    face belongs to) when they are the same shape, dicts key by key, other values (a study) when
    they are the same object or by repr."""
    if a is b:
        return True
    if hasattr(a, "isSame"):
        return isinstance(b, type(a)) and a.isSame(b)
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same_value(a[k], b[k]) for k in a)
    return repr(a) == repr(b)


def full_call(function, arguments):
    """function's keyword arguments (a dict, without the face and progress) with the defaults
    filled in and a ``**options`` catch-all flattened, sorted, for comparing two calls."""
    signature = inspect.signature(function)
    bound = signature.bind(None, **arguments)
    bound.apply_defaults()
    call = dict(bound.arguments)
    first = next(iter(signature.parameters))
    call.pop(first)
    call.pop("progress", None)
    for name, parameter in signature.parameters.items():
        if parameter.kind is inspect.Parameter.VAR_KEYWORD:
            call.update(call.pop(name))
    return dict(sorted(call.items()))
