"""The plan() users call (``cmmsampling.plan``): a part's faces to a tolerance or a number of
points (:func:`cmmsampling.planning.part_plan.plan`), or a QIF MBD model's characteristics, each
with its own tolerance and datums (:func:`cmmsampling.planning.mbd_plan.plan_mbd`).
"""
from __future__ import annotations

from typing import Any

from ..geometry.validation import InputError
from ..strategies.sampling import BEST_STRATEGY
from .mbd_plan import plan_mbd
from .part_plan import PartPlan
from .part_plan import plan as plan_part

# What the model states, so that a model's plan refuses them.
FROM_THE_MODEL = ("faces", "datums", "resume", "part")


def plan(shape_or_faces: Any, tolerance: Any = None, n_total: int | None = None, strategy: str = BEST_STRATEGY,
         **options: Any) -> PartPlan:
    """Probe points for a whole part, or for the characteristics of a QIF MBD model.

    shape_or_faces: a Part.Shape or faces, planned as :func:`cmmsampling.planning.part_plan.plan`
    says (tolerance, n_total, strategy and options as it takes them; a PartPlan); or a QIF MBD
    model (cmmsampling.read_mbd): each characteristic it judges planned with its own tolerance
    and its datums' faces (an MbdPlan, a PartPlan that knows the model: see
    :mod:`cmmsampling.planning.mbd_plan`); strategy and the options but tolerance, n_total,
    faces, datums, resume and part as for a part (the model states those).
    """
    if not is_mbd(shape_or_faces):
        return plan_part(shape_or_faces, tolerance, n_total, strategy, **options)
    stated = {"tolerance": tolerance, "n_total": n_total, **{name: options.get(name) for name in FROM_THE_MODEL}}
    given = [name for name, value in stated.items() if value is not None]
    if given:
        raise InputError(f"a QIF MBD model's plan takes its tolerances, faces and datums from the model; leave "
                         f"{', '.join(name + '=' for name in given)} out")
    return plan_mbd(shape_or_faces, strategy, **options)


def is_mbd(source: object) -> bool:
    """True for a QIF MBD model (cmmsampling.read_mbd's MbdModel)."""
    return all(hasattr(source, name) for name in ("characteristics", "datums", "match_report"))
