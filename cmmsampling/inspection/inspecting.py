"""The inspect() users call (``cmmsampling.inspect``): measured points judged against what they
were planned on (:func:`cmmsampling.inspection.judge.inspect`), or, for the plan of a QIF MBD
model, each of its characteristics with its own tolerance and datums
(:func:`cmmsampling.inspection.characteristics.inspect_mbd`).
"""
from __future__ import annotations

import os
from typing import Any

from ..formats.pointset import PointSet
from ..geometry.validation import InputError
from ..planning.mbd_plan import MbdPlan
from .characteristics import MbdInspection, inspect_mbd, inspect_model_group
from .judge import inspect as inspect_points
from .result import Inspection

# inspect()'s options a model's plan takes (the rest come from the model).
MODEL_OPTIONS = ("uncertainty", "probe_radius", "seed", "progress")


def inspect(source: object, measured: str | os.PathLike | PointSet, *arguments: Any,
            **options: Any) -> Inspection | MbdInspection:
    """Judge measured points against the CAD model they were planned on.

    source, measured, arguments and options as :func:`cmmsampling.inspection.judge.inspect`
    takes them (an Inspection); or source the plan of a QIF MBD model (``plan(read_mbd(path))``,
    an MbdPlan, or its group in a document: its MbdFile set): each of its characteristics judged
    with its own tolerance and datums (an MbdInspection,
    :mod:`cmmsampling.inspection.characteristics`), taking uncertainty,
    probe_radius, seed and progress; InputError for any other option (the model states them).
    """
    model_group = bool(getattr(source, "MbdFile", "")) and hasattr(source, "Proxy")
    if not isinstance(source, MbdPlan) and not model_group:
        return inspect_points(source, measured, *arguments, **options)
    other = sorted(set(options) - set(MODEL_OPTIONS))
    if arguments or other:
        named = ", ".join(f"{name}=" for name in other) or "the positional options"
        raise InputError(f"a QIF MBD model's plan is judged by each characteristic's own tolerance and datums; "
                         f"leave {named} out (it takes {', '.join(MODEL_OPTIONS)})")
    if model_group:
        return inspect_model_group(source, measured, **options)
    return inspect_mbd(source, measured, **options)
