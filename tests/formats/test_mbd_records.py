"""The PMI of QIF 3.0 MBD documents as records: NIST's four PMI test models
(../shared/reference/qif3/mbd, skipped where absent) give every characteristic nominal and
datum the file holds, counted here from the file's text independently of the reader, with
lengths in mm from the file's units (inch included); every characteristic is judged or says
why not; a document that is no MBD or refers to what it does not hold is refused in one line."""
import os
import re
from collections import Counter

import pytest
from support.mbd import MBD, MODELS, shared_mbd

from cmmsampling.formats.qif.mbd import JUDGED, read_mbd_records
from cmmsampling.geometry.validation import InputError

@pytest.fixture(scope="module", params=[f"{name}.qif" for name in MODELS])
def read(request):
    """(the file's text, its records) for each shared model."""
    path = shared_mbd(request.param)
    with open(path, encoding="utf-8") as handle:
        return handle.read(), read_mbd_records(path)


def test_every_characteristic_and_datum_of_the_file_is_read(read):
    text, records = read
    in_file = Counter(re.findall(r"<(\w+)CharacteristicNominal\s+id=", text))
    assert records.counts() == in_file and sum(in_file.values()) > 10
    assert len({c.id for c in records.characteristics}) == len(records.characteristics)
    assert sorted(records.datums) == sorted(re.findall(r"<DatumLabel>(\w+)</DatumLabel>", text))
    assert len(records.face_ids) == len(re.findall(r"<Face\s[^>]*\bid=", text))


def test_every_characteristic_is_judged_or_says_why_not(read):
    _, records = read
    for c in records.characteristics:
        assert c.judged == (c.why_not == ""), c
        assert not c.judged or (c.kind in JUDGED and c.tolerance > 0 and c.face_ids), c
    assert records.judged(), "each model holds a profile or flatness this tool judges"
    assert len(records.not_judged()) == len(records.characteristics) - len(records.judged())
    print(f"{os.path.basename(records.path)}: {len(records.judged())} of {len(records.characteristics)} judged; "
          + "; ".join(records.not_judged()[:2]))


def test_ctc_01_in_mm_reads_its_profile_with_its_frame_and_faces():
    records = read_mbd_records(shared_mbd("nist_ctc_01_asme1_ap242.qif"))
    assert (records.linear, records.pmi, len(records.face_ids)) == ("mm", "mm", 117)
    profile = next(c for c in records.characteristics if c.id == "1457")
    assert (profile.kind, profile.tolerance, profile.tolerance_text, profile.datums) == \
        ("SurfaceProfile", 1.25, "1.25 mm", ("A", "B", "C"))
    assert profile.face_ids == ("1254", "1259") and profile.judged
    assert [records.datums[label].face_ids for label in "A"] == [("494",)]
    size = next(c for c in records.characteristics if c.name == "Linear Size.7")
    assert (size.target, size.limits, size.tolerance, size.judged) == (35.0, (34.8, 35.2), None, False)
    angle = next(c for c in records.characteristics if c.kind == "Angle")
    assert (angle.unit, angle.target, angle.limits) == ("degree", 60.0, (59.5, 60.5))


def test_ftc_06_in_inches_gives_mm_and_says_both():
    records = read_mbd_records(shared_mbd("nist_ftc_06_asme1_ap242.qif"))
    assert records.pmi == "inch" and records.mm_per_unit["inch"] == pytest.approx(25.4)
    flatness = next(c for c in records.characteristics if c.name == "Flatness.1")
    assert flatness.tolerance == pytest.approx(0.254, rel=1e-12) and flatness.tolerance_text == "0.01 inch (0.254 mm)"
    assert flatness.judged and flatness.datums == ()
    perpendicular = next(c for c in records.characteristics if c.name == "Perpendicularity.2")
    assert perpendicular.datums == ("A", "B") and perpendicular.zone == "planar" and perpendicular.judged
    position = next(c for c in records.characteristics if c.name == "Position.1")
    assert position.zone == "diametrical" and not position.judged and "feature of size" in position.why_not


def test_a_per_area_flatness_and_an_axis_orientation_are_not_judged():
    records = read_mbd_records(shared_mbd("nist_ctc_03_asme1_ap242.qif"))
    flatness = next(c for c in records.characteristics if c.kind == "Flatness")
    assert not flatness.judged and "per unit area" in flatness.why_not
    assert flatness.tolerance_text == "0.005 mm per unit area"
    axis = next(c for c in records.characteristics if c.name == "Perpendicularity.1")
    assert axis.zone == "diametrical" and not axis.judged and "axis" in axis.why_not


def test_a_qif_document_without_characteristics_is_refused_in_one_line():
    path = os.path.join(os.path.dirname(MBD), "samples", "mitutoyo_results_serialized_pass_fail_sample.QIF")
    if not os.path.isfile(path):
        pytest.skip(f"{path} is not beside the checkout")
    with pytest.raises(InputError, match="holds no characteristics") as refused:
        read_mbd_records(path)
    assert str(refused.value).startswith(path) and "\n" not in str(refused.value)


@pytest.mark.parametrize("change, problem", [
    (lambda text: text.replace('linearUnit="mm">1.25<', 'linearUnit="furlong">1.25<'), "'furlong'"),
    (lambda text: text.replace("<QIFDocument", "<QIFDoc", 1).replace("</QIFDocument>", "</QIFDoc>"),
     "not a QIF 3.0 document"),
])
def test_a_document_that_is_no_mbd_or_misreads_is_refused_in_one_line(tmp_path, change, problem):
    with open(shared_mbd("nist_ctc_01_asme1_ap242.qif"), encoding="utf-8") as handle:
        text = handle.read()
    path = tmp_path / "changed.qif"
    path.write_text(change(text), encoding="utf-8")
    with pytest.raises(InputError) as refused:
        read_mbd_records(str(path))
    message = str(refused.value)
    assert problem in message and "\n" not in message and message.startswith(str(path))


@pytest.mark.parametrize("disposition, offset", [("<UnequallyDisposedZone>0.1</UnequallyDisposedZone>", 0.1),
                                                 ("<OuterDisposition>0.5</OuterDisposition>", 0.5 - 0.5 * 1.25)])
def test_an_unequally_disposed_profile_zone_is_read_as_its_centre(tmp_path, disposition, offset):
    text = open(shared_mbd("nist_ctc_01_asme1_ap242.qif"), encoding="utf-8").read()
    changed, count = re.subn(r"(<SurfaceProfileCharacteristicDefinition id=\"\d+\">.*?</ToleranceValue>)",
                             lambda found: found.group(1) + disposition, text, flags=re.S)
    assert count == 2
    path = tmp_path / "uz.qif"
    path.write_text(changed, encoding="utf-8")
    profile = next(c for c in read_mbd_records(str(path)).characteristics if c.id == "1457")
    assert profile.tolerance == 1.25 and profile.zone_offset == pytest.approx(offset) and profile.judged


def test_an_offset_profile_zone_is_not_judged(tmp_path):
    text = open(shared_mbd("nist_ctc_01_asme1_ap242.qif"), encoding="utf-8").read()
    changed = re.sub(r"(<SurfaceProfileCharacteristicDefinition id=\"\d+\">.*?</ToleranceValue>)",
                     lambda found: found.group(1) + "<OffsetZone>true</OffsetZone>", text, count=2, flags=re.S)
    path = tmp_path / "offset.qif"
    path.write_text(changed, encoding="utf-8")
    profile = next(c for c in read_mbd_records(str(path)).characteristics if c.id == "1457")
    assert not profile.judged and "OffsetZone" in profile.why_not
