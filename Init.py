"""CMM Sampling, application side (run by FreeCAD at start-up, with or without the GUI).

File > Export writes selected probe points for the CMM through cmmsampling.document.export, in
every registered point-file format (cmmsampling.formats.registry).
"""
import FreeCAD

from cmmsampling.formats.pointfiles import export_filter

FreeCAD.addExportType(export_filter(), "cmmsampling.document")
