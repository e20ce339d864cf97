"""The CMM Sampling workbench (run by FreeCAD at start-up; the commands load on activation).

FreeCAD runs this file with exec() inside a function: names imported at its top level are not
visible in the class body or the methods, so each method imports what it needs.
"""
import FreeCADGui


class CMMSamplingWorkbench(FreeCADGui.Workbench):
    """CMM Sampling: place probe points on a free-form face, fit the substitute surface and
    report its deviation from the CAD model."""

    MenuText = "CMM Sampling"
    ToolTip = ("Place CMM probe points on a free-form face and judge them by the substitute "
               "surface's deviation")

    def __init__(self):
        import importlib.util
        import os

        package = importlib.util.find_spec("cmmsampling").submodule_search_locations[0]
        self.__class__.Icon = os.path.join(os.path.dirname(package), "icons", "Workbench.svg")

    def Initialize(self):
        import os

        from cmmsampling.gui import commands, resource
        from cmmsampling.runtime.parallel import ignore_broken_pipes

        ignore_broken_pipes()   # FreeCAD 1.0 and 1.1 would end on a write to a stopped process's pipe
        toolbar, menu = commands.register()
        FreeCADGui.addIconPath(os.path.dirname(self.Icon))   # the preferences group's icon
        FreeCADGui.addPreferencePage(resource("preferences.ui"), "CMM sampling")
        self.appendToolbar("CMM Sampling", toolbar)
        self.appendMenu("CMM Sampling", menu)

    def GetClassName(self):
        return "Gui::PythonWorkbench"


FreeCADGui.addWorkbench(CMMSamplingWorkbench())
