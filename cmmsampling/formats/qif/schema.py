"""The official QIF 3.0 XML schemas (ISO 23952), shipped in ``resources/qif3/schema`` with their
Boost licence, and the check of a document against them.

lxml (Debian's ``python3-lxml``) validates: without it no QIF file is read or written, and
:func:`schema_errors` refuses in one line (MissingPackage) naming how to install it. The schema
set takes about 0.3 s to load and is loaded once per process.
"""
from __future__ import annotations

import functools
import os

from ...geometry.validation import InputError
from ...runtime.packages import require
from ..registry import formats_without

ADDON_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
SCHEMA_PATH = os.path.join(ADDON_DIR, "resources", "qif3", "schema", "QIFDocument.xsd")
# The first errors a refusal names; a document the writers produce has none.
ERRORS_SHOWN = 3


class SchemaUnavailable(InputError):
    """The schema files are missing, so a document cannot be checked."""


class UncheckedDocument(ValueError):
    """The schemas cannot judge a document: it uses an entity declared in its DOCTYPE (which lxml
    keeps unexpanded here, so that no entity reaches outside the file), or lxml's validator fails
    inside; the message says where and what to do."""


@functools.lru_cache(maxsize=1)
def qif_schema():
    """The QIF 3.0 schema set as an lxml XMLSchema (loaded once); MissingPackage without lxml,
    SchemaUnavailable without the schema files."""
    require_lxml()
    from lxml import etree

    if not os.path.isfile(SCHEMA_PATH):
        raise SchemaUnavailable(f"the QIF 3.0 schemas are missing ({SCHEMA_PATH}); reinstall the workbench")
    return etree.XMLSchema(etree.parse(SCHEMA_PATH))


def require_lxml() -> None:
    """MissingPackage, in one line, where lxml cannot be imported: no QIF file is then read or
    written."""
    require("lxml", "QIF 3.0 files", formats_without("lxml"))


def schema_errors(text: str | bytes) -> list[str]:
    """The QIF 3.0 schemas' complaints about a document's text ('line 12: ...'), [] when they
    accept it; MissingPackage or SchemaUnavailable when they cannot be loaded, UncheckedDocument
    when they cannot judge it."""
    schema = qif_schema()
    from lxml import etree

    data = text.encode("utf-8") if isinstance(text, str) else text
    try:
        document = etree.fromstring(data, etree.XMLParser(resolve_entities=False, huge_tree=True))
    except etree.XMLSyntaxError as exc:
        return [f"not well-formed XML: {exc}"]
    entity = next(document.iter(etree.Entity), None)
    if entity is not None:
        raise UncheckedDocument(f"line {entity.sourceline} uses the XML entity {entity.text} (declared in its "
                                "DOCTYPE), which the QIF 3.0 schema check does not expand; write the entity's text "
                                "in its place, or export the file again")
    try:
        if schema.validate(etree.ElementTree(document)):
            return []
    except etree.XMLSchemaValidateError as exc:
        raise UncheckedDocument(f"lxml's QIF 3.0 schema check failed inside ({exc}); export the file again") from None
    return [f"line {error.line}: {error.message}" for error in schema.error_log]
