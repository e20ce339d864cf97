"""A model's characteristic is judged as its zone states it (an unequally disposed profile about
its centre) and never on part of its faces: one whose face has no measured point has no value,
says why, and the part has no verdict (NIST's ctc_01)."""
import dataclasses

import numpy as np
import pytest

import cmmsampling
from cmmsampling.formats.pointset import PointSet
from support.mbd import shared_mbd


@pytest.fixture(scope="module")
def ctc_01_measured(tmp_path_factory):
    model = cmmsampling.read_mbd(shared_mbd("nist_ctc_01_asme1_ap242.qif"))
    plan = cmmsampling.plan(model, strategy="hammersley", n_max=25)
    path = tmp_path_factory.mktemp("ctc_01") / "m.csv"
    cmmsampling.simulate_measurement(plan, path, form_error=0.05, seed=2)
    return model, plan, cmmsampling.read_points(str(path))


def test_a_profile_with_an_unequal_zone_is_judged_about_its_centre(ctc_01_measured):
    model, plan, measured = ctc_01_measured
    shifted = [dataclasses.replace(c, zone_offset=0.2) if c.id == "1462" else c for c in plan.characteristics]
    found = cmmsampling.inspect(dataclasses.replace(plan, characteristics=shifted), measured)
    centred = cmmsampling.inspect(plan, measured)
    there = next(r for r in found.characteristics if r.id == "1462")
    here = next(r for r in centred.characteristics if r.id == "1462")
    assert there.inspection.zone_offset == 0.2 and here.inspection.zone_offset == 0.0
    deviations = there.inspection.deviations
    assert there.value == pytest.approx(2 * np.abs(deviations - 0.2).max(), abs=1e-9)
    assert there.value > here.value and "UZ +0.2000" in there.row()["tolerance"]


def test_a_characteristic_with_a_face_left_unmeasured_has_no_value(ctc_01_measured):
    model, plan, measured = ctc_01_measured
    faces = measured.faces or [label.split("_P")[0] for label in measured.labels]
    keep = np.array([face != "Face25" for face in faces])
    fewer = PointSet([label for label, kept in zip(measured.labels, keep) if kept], measured.points[keep],
                     measured.normals[keep], metadata=measured.metadata)
    found = cmmsampling.inspect(plan, fewer)
    profile = next(r for r in found.characteristics if r.id == "1462")
    assert profile.value is None and profile.passed is None and "Face25 has no measured point" in profile.why
    assert profile.conforms == "not judged" and found.passed is None
    others = [r for r in found.characteristics if r.id != "1462"]
    assert all(r.value is not None for r in others)
