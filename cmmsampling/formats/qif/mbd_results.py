"""QIF 3.0 results of a QIF MBD model's characteristics (an MbdInspection:
:mod:`cmmsampling.inspection.characteristics`), written into the model's own document.

The results file is the MBD document as its owner wrote it (its product, features,
characteristics, datums and ids unchanged) with, added under fresh ids above its ``idMax``:

- ``Features/FeatureItems``: one item per feature nominal a judged characteristic applies to
  (``FeatureNominalId`` the MBD's id, its type the nominal's, e.g. PlaneFeatureItem);
- ``Characteristics/CharacteristicItems``: one item per characteristic judged
  (``CharacteristicNominalId`` the MBD's nominal id, its features' items);
- ``Results``: one measurement per characteristic judged (e.g. FlatnessCharacteristicMeasurement):
  its value in the file's length unit (with its combined uncertainty where one was given), and
  its status: PASS or FAIL, ISO 14253-1's decision with an uncertainty (undecided:
  INDETERMINATE), NOT_CALCULATED where it has no value; the part's status as the inspection's.

So the MBD's owner merges the results by the ids of the file they wrote. The document is
checked against the official schemas (as every QIF file written here).
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import Any

from .mbd import parsed_file
from .results import DECISION_STATUS, PART_DECISION_STATUS, status_of
from .xml import QIFWriter, decimal, tag

# The document's top-level elements after which Results may stand (the schema's order).
BEFORE_RESULTS = ("Characteristics", "Plan")


def write_mbd_results(found: Any) -> str:
    """The QIF 3.0 text of found's model document with its results (see the module's doc)."""
    model = found.plan.model
    doc = QIFWriter(parsed_file(model.path))
    nominals = _feature_nominals(doc.root)
    feature_items = _feature_items(doc, nominals, [result.characteristic for result in found.characteristics])
    items = _characteristic_items(doc, found.characteristics, feature_items)
    _results(doc, found, items, model.mm_per_unit.get(model.linear, 1.0))
    return doc.text()


def _placed_after(parent: ET.Element, name: str, after: tuple[str, ...]) -> ET.Element:
    """parent's child ``name``, made after the last of its children named in ``after`` where
    it has none."""
    found = parent.find(tag(name))
    if found is not None:
        return found
    children = list(parent)
    position = max((k + 1 for k, child in enumerate(children) if child.tag in {tag(a) for a in after}), default=0)
    element = ET.Element(tag(name))
    parent.insert(position, element)
    return element


def _feature_nominals(root: ET.Element) -> dict[str, ET.Element]:
    """{id: element} of the document's feature nominals."""
    holder = root.find(f"{tag('Features')}/{tag('FeatureNominals')}")
    return {} if holder is None else {element.get("id", ""): element for element in holder}


def _feature_items(doc: QIFWriter, nominals: dict[str, ET.Element], characteristics: list) -> dict[str, str]:
    """{feature nominal id: its new item's id} for the features the characteristics apply to."""
    wanted = list(dict.fromkeys(f for c in characteristics for f in c.features if f in nominals))
    if not wanted:
        return {}
    features = doc.root.find(tag("Features"))
    assert features is not None   # the nominals found lie in it
    holder = _placed_after(features, "FeatureItems", ("FeatureDefinitions", "FeatureNominals"))
    made = {}
    for nominal_id in wanted:
        nominal = nominals[nominal_id]
        kind = nominal.tag.split("}")[-1].replace("FeatureNominal", "FeatureItem")
        item, made[nominal_id] = doc.with_id(holder, kind)
        doc.add(item, "FeatureNominalId", nominal_id)
        doc.add(item, "FeatureName", (nominal.findtext(tag("Name")) or f"feature {nominal_id}").strip())
        if "NonShape" not in kind:
            doc.add(doc.add(doc.add(doc.add(item, "DeterminationMode"), "Checked"), "CheckDetails"), "Measured")
    holder.set("n", str(len(holder)))
    return made


def _characteristic_items(doc: QIFWriter, results: list, feature_items: dict[str, str]) -> dict[str, str]:
    """{characteristic nominal id: its new item's id}, one per result."""
    characteristics = doc.root.find(tag("Characteristics"))
    assert characteristics is not None   # the model's characteristics come from it
    holder = _placed_after(characteristics, "CharacteristicItems",
                           ("FormalStandardId", "CharacteristicDefinitions", "CharacteristicNominals"))
    made = {}
    for result in results:
        c = result.characteristic
        item, made[c.id] = doc.with_id(holder, f"{c.kind}CharacteristicItem")
        doc.add(item, "Name", c.name or f"{c.kind} {c.id}")
        features = [feature_items[f] for f in c.features if f in feature_items]
        if features:
            doc.id_list(item, "FeatureItemIds", features)
        doc.add(item, "CharacteristicNominalId", c.id)
    holder.set("n", str(len(holder)))
    return made


def _results(doc: QIFWriter, found: Any, items: dict[str, str], per_unit: float) -> None:
    """Results: the characteristics' measurements (values in the file's length unit: per_unit
    mm each) and the part's status."""
    top = _placed_after(doc.root, "Results", BEFORE_RESULTS)
    results = doc.with_id(doc.add(top, "MeasurementResultsSet", n=1), "MeasurementResults")[0]
    holder = doc.add(doc.add(results, "MeasuredCharacteristics"), "CharacteristicMeasurements",
                     n=len(found.characteristics))
    for result in found.characteristics:
        element = doc.with_id(holder, f"{result.kind}CharacteristicMeasurement")[0]
        status = status_of(result.passed)
        if result.decision is not None:
            status = DECISION_STATUS[result.decision]
        doc.add(doc.add(element, "Status"), "CharacteristicStatusEnum", status)
        doc.add(element, "CharacteristicItemId", items[result.id])
        if result.value is not None:
            value = doc.add(element, "Value", decimal(result.value / per_unit))
            if result.inspection is not None and result.inspection.uncertainty is not None:
                found_u = result.inspection.uncertainty
                value.set("combinedUncertainty", decimal(found_u.expanded / found_u.coverage / per_unit))
    part = status_of(found.passed)
    decisions = {result.decision for result in found.characteristics}
    if found.passed is None and None not in decisions:
        part = PART_DECISION_STATUS["undecided"]
    doc.add(doc.add(results, "InspectionStatus"), "InspectionStatusEnum", part)
    component, component_id = doc.with_id(doc.add(doc.add(top, "ActualComponentSets", n=1), "ActualComponentSet",
                                                   n=1), "ActualComponent")
    doc.add(doc.add(component, "Status"), "InspectionStatusEnum", part)
    doc.id_list(results, "ActualComponentIds", [component_id])


def read_mbd_results(path: str) -> dict[str, tuple[str, float | None]]:
    """{characteristic nominal id: (status, value in mm or None)} of a results file written by
    :func:`write_mbd_results` (or any QIF document whose characteristic measurements refer to
    items of its nominals), values converted from the file's length unit."""
    from .mbd import records_of

    root = parsed_file(path)
    records = records_of(root, path)
    scale = records.mm_per_unit.get(records.linear, 1.0)
    items = {item.get("id", ""): item.findtext(tag("CharacteristicNominalId"), "").strip()
             for item in root.iterfind(f"{tag('Characteristics')}/{tag('CharacteristicItems')}/*")}
    found = {}
    measurements = f"{tag('Results')}/{tag('MeasurementResultsSet')}/{tag('MeasurementResults')}/" \
                   f"{tag('MeasuredCharacteristics')}/{tag('CharacteristicMeasurements')}/*"
    for measurement in root.iterfind(measurements):
        nominal = items.get(measurement.findtext(tag("CharacteristicItemId"), "").strip(), "")
        value = measurement.findtext(tag("Value"))
        status = measurement.findtext(f"{tag('Status')}/{tag('CharacteristicStatusEnum')}", "").strip()
        found[nominal] = (status, None if value is None else float(value) * scale)
    return found
