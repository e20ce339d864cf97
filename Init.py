"""CMM Sampling, application side (run by FreeCAD at start-up, with or without the GUI).

File > Export writes selected probe points for the CMM through cmmsampling.document.export.
"""
import FreeCAD

FreeCAD.addExportType("CMM probe points: DMIS, PC-DMIS XYZ, CSV (*.dmi *.dmis *.xyz *.csv)",
                      "cmmsampling.document")
