"""GUI tests run only inside the FreeCAD GUI (scripts/run-gui-tests.sh); a plain pytest skips
collecting them. Fixtures: the workbench, documents with the reference face, the screenshot folder."""
import os
import re

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

    from .helpers import dock_text, document_with, process_events

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

    @pytest.fixture(autouse=True)
    def no_qt_warnings():
        """No test's work writes a Qt warning ('QPainter::begin: ...', 'QObject::...') to the
        Report view, where FreeCAD routes Qt's messages; FreeCAD 1.x raises each one as a
        notification too (1.1 users saw dozens a command, over the 3D view)."""
        report = len(dock_text("Report view"))
        yield
        process_events(0.1)
        written = qt_warnings(dock_text("Report view")[report:].splitlines())
        assert not written, f"Qt warnings in the Report view: {written[:3]}"

    QT_WARNING = re.compile(r"\bQ[A-Z]\w*::\w+|QPainter|QPixmap|QWidget::|QLayout|QObject::")

    def qt_warnings(lines):
        """The lines that hold a Qt warning."""
        return [line for line in lines if QT_WARNING.search(line)]
