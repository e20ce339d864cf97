"""GUI tests run only inside the FreeCAD GUI (scripts/run-gui-tests.sh); a plain pytest skips
collecting them. Fixtures: the workbench, documents with the reference face, the screenshot folder."""
import os

try:
    import FreeCAD
except ImportError:
    FreeCAD = None

if FreeCAD is None or not FreeCAD.GuiUp:
    collect_ignore_glob = ["test_*.py"]
else:
    import FreeCADGui
    import pytest

    import cmmsampling
    from cmmsampling.document import settings

    from .helpers import document_with, process_events

    ARTIFACTS = os.environ.get(
        "CMMSAMPLING_ARTIFACTS",
        os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                     "artifacts", "gui"),
    )

    @pytest.fixture(scope="session")
    def artifacts():
        """Folder for screenshots."""
        os.makedirs(ARTIFACTS, exist_ok=True)
        return ARTIFACTS

    @pytest.fixture(scope="session")
    def workbench():
        FreeCADGui.activateWorkbench("CMMSamplingWorkbench")
        process_events(0.2)
        return FreeCADGui.activeWorkbench()

    @pytest.fixture(autouse=True)
    def panel_defaults():
        """Every test starts with the panel's defaults: the values stored by earlier runs go."""
        parent, name = settings.PARAMETER_GROUP.rsplit("/", 1)
        FreeCAD.ParamGet(parent).RemGroup(name)

    @pytest.fixture
    def doc(workbench):
        """A new active document holding the reference face as Part::Feature 'Body'."""
        yield from document_with("GuiTest", {"Body": cmmsampling.reference_face()})
