"""CMM Sampling, application side (run by FreeCAD at start-up, with or without the GUI).

File > Export writes selected probe points for the CMM through cmmsampling.document.export, in
every registered point-file format (cmmsampling.formats.registry); File > Open and Import read a
QIF 3.0 MBD model (its part and characteristics) through cmmsampling.document.mbd_import.
"""
import FreeCAD

from cmmsampling.formats.pointfiles import export_filter

FreeCAD.addExportType(export_filter(), "cmmsampling.document")
FreeCAD.addImportType("QIF 3.0 MBD model (*.qif)", "cmmsampling.document.mbd_import")
