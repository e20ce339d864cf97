"""Building a QIF 3.0 document: the namespace, ids, numbers and the parts every document the
project writes shares (version, units, standard, product).

The writers build :mod:`xml.etree.ElementTree` trees (the standard library: no lxml needed to
write); elements are appended in the order the schema's sequences require.
"""
from __future__ import annotations

import uuid
import xml.etree.ElementTree as ET

import numpy as np

QIF_NS = "http://qifstandards.org/xsd/qif3"
# Our own structures inside QIF's UserDataXML (the schema takes any other namespace there).
EXTENSION_NS = "urn:cmmsampling:qif:1"
QIF_VERSION = "3.0.0"
# The most digits of an xs:decimal that libxml2 (lxml) validates.
DECIMAL_DIGITS = 24
ET.register_namespace("", QIF_NS)
ET.register_namespace("cmms", EXTENSION_NS)


def tag(name):
    """The qualified tag of a QIF element."""
    return f"{{{QIF_NS}}}{name}"


def decimal(value):
    """A float as xs:decimal takes it: positional (no exponent), the shortest digits that read
    back as the same double, cut to DECIMAL_DIGITS digits (a value below 1e-7 rounds at the
    24th decimal place)."""
    value = float(value)
    text = np.format_float_positional(value, unique=True, trim="-")
    whole = len(str(int(abs(value)))) if abs(value) >= 1 else 0
    if len(text.lstrip("-").replace(".", "")) - (whole == 0) > DECIMAL_DIGITS:
        text = np.format_float_positional(value, precision=DECIMAL_DIGITS - whole, unique=True, trim="-")
    return text


def numbers(values):
    """Floats as QIF lists them: separated by blanks, each as :func:`decimal`."""
    return " ".join(decimal(value) for value in np.asarray(values, dtype=float).ravel())


class QIFWriter:
    """A QIF document under construction: the root, the next free id and the helpers that add
    elements. Ids are the positive integers the schema's QIFIdUnique asks for, counted from 1."""

    def __init__(self, root=None):
        """A new document, or one read (root: its QIFDocument element), whose new ids follow its
        idMax."""
        if root is not None:
            self.root, self.last_id = root, int(root.get("idMax", "0"))
            return
        self.root = ET.Element(tag("QIFDocument"), {"versionQIF": QIF_VERSION, "idMax": "0"})
        self.last_id = 0
        self.add(self.root, "QPId", new_qpid())

    def new_id(self):
        """The next unused id (str)."""
        self.last_id += 1
        return str(self.last_id)

    def add(self, parent, element_name, text=None, **attributes):
        """A new child element of parent with text and attributes (str values)."""
        element = ET.SubElement(parent, tag(element_name), {key: str(value) for key, value in attributes.items()})
        if text is not None:
            element.text = str(text)
        return element

    def with_id(self, parent, element_name, **attributes):
        """A new child element carrying the next id; returns (element, id)."""
        identifier = self.new_id()
        return self.add(parent, element_name, id=identifier, **attributes), identifier

    def id_list(self, parent, element_name, ids, item="Id"):
        """A list element with n and one ``item`` child per id."""
        element = self.add(parent, element_name, n=len(ids))
        for identifier in ids:
            self.add(element, item, identifier)
        return element

    def attributes(self, parent, entries):
        """QIF Attributes: entries (kind, name, value), kind 'Str', 'D1' or 'I1' (value as written)
        or 'User' (value an Element in EXTENSION_NS, written inside UserDataXML)."""
        element = self.add(parent, "Attributes", n=len(entries))
        for kind, name, value in entries:
            if kind == "User":
                user = self.add(element, "AttributeUser", name=name, nameUserAttribute=name)
                self.add(user, "UserDataXML").append(value)
            else:
                self.add(element, f"Attribute{kind}", name=name, value=value)
        return element

    def text(self):
        """The document as UTF-8 XML text (idMax set to the last id used)."""
        self.root.set("idMax", str(self.last_id))
        ET.indent(self.root)
        return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(self.root, encoding="unicode") + "\n"

    def units(self):
        """FileUnits: mm and degrees (every length in the document is mm)."""
        primary = self.add(self.add(self.root, "FileUnits"), "PrimaryUnits")
        for kind, si, name, factor in (("AngularUnit", "radian", "degree", np.pi / 180.0),
                                       ("LinearUnit", "meter", "mm", 0.001)):
            unit = self.add(primary, kind)
            self.add(unit, "SIUnitName", si)
            self.add(unit, "UnitName", name)
            self.add(self.add(unit, "UnitConversion"), "Factor", decimal(factor))

    def standard(self):
        """StandardsDefinitions with ISO 1101 (the profile tolerance's standard); returns its id."""
        standards = self.add(self.root, "StandardsDefinitions", n=1)
        standard, identifier = self.with_id(standards, "Standard")
        self.add(self.add(standard, "Organization"), "StandardsOrganizationEnum", "ISO")
        self.add(standard, "Designator", "1101")
        return identifier


def extension(name, **attributes):
    """An element of our own namespace (for UserDataXML)."""
    return ET.Element(f"{{{EXTENSION_NS}}}{name}", {key: str(value) for key, value in attributes.items()})


def extension_child(parent, name, text=None, **attributes):
    """A child element of our own namespace."""
    element = ET.SubElement(parent, f"{{{EXTENSION_NS}}}{name}", {k: str(v) for k, v in attributes.items()})
    if text is not None:
        element.text = str(text)
    return element


def new_qpid():
    """A fresh QIF persistent id (a random UUID, 8-4-4-4-12 hex)."""
    return str(uuid.uuid4())
