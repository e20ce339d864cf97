"""Measured files as CMM software writes them, written here by hand: tables whose header names the
columns, DMIS output in inches, files without labels, and a DMIS program that holds no measurement.
Each is judged as the same measurement written in the project's own DMIS output."""
import numpy as np
import pytest
from support.faces import rational_patch_face

import cmmsampling
from cmmsampling.geometry.validation import InputError

PLACED = {"x": 0.2, "y": -0.1, "z": 0.3}


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """(planned result, SimulatedMeasurement, the DMIS output's Inspection, folder): 25 Halton
    points on a rational patch, measured with a 5 um form error and misplaced."""
    folder = tmp_path_factory.mktemp("measured")
    planned = cmmsampling.sample(rational_patch_face(), 25, "halton", occ_check=False)
    made = cmmsampling.simulate_measurement(planned, folder / "measured.dmi", form_error=0.005, misplacement=PLACED)
    return planned, made, cmmsampling.inspect(planned, folder / "measured.dmi"), folder


def rows(made, order=None):
    """(label, x, y, z) text rows of the measurement, in ``order`` (default the planned one)."""
    order = range(len(made.labels)) if order is None else order
    return [[made.labels[k]] + [f"{c:.7f}" for c in made.actual[k]] for k in order]


def same_verdict(found, reference):
    """The same points judged alike: deviations to 1e-7 mm, the same labels."""
    assert found.labels == reference.labels
    np.testing.assert_allclose(found.deviations, reference.deviations, atol=1e-7)


@pytest.mark.parametrize("header, separator", [
    ("Name,X,Y,Z", ","), ("label,x,y,z", ","), ("label x y z", " "), ("Point ID\tX [mm]\tY [mm]\tZ [mm]", "\t"),
    ("NAME;X_MM;Y_MM;Z_MM", ";")], ids=["Name,X,Y,Z", "label,x,y,z", "blanks", "tabs and units", "semicolons"])
def test_a_header_names_the_columns(measured, header, separator):
    planned, made, reference, folder = measured
    path = folder / "header.txt"
    path.write_text("\n".join([header] + [separator.join(row) for row in rows(made)]) + "\n")
    same_verdict(cmmsampling.inspect(planned, path), reference)


@pytest.mark.parametrize("units, per_mm", [
    (("X [inch]", "Y [inch]", "Z [inch]"), 1 / 25.4), (("X (in)", "Y (IN)", "z (In)"), 1 / 25.4),
    (("X [um]", "Y [\u00b5m]", "Z [UM]"), 1000.0), (("X [mm]", "Y mm", "Z_MM"), 1.0),
    (("X act [in]", "Y act (inch)", "Z act inches"), 1 / 25.4), (("X [cm]", "Y [cm]", "Z [cm]"), 0.1)],
    ids=["[inch]", "(in)", "[um]", "[mm]", "act [in]", "[cm]"])
def test_units_in_a_header_are_read_and_stated(measured, units, per_mm):
    """A header's units convert the values to mm, and the inspection says so; before, inches and
    micrometres were read as mm: an absurd FAIL with no word about units."""
    planned, made, reference, folder = measured
    path = folder / "units.csv"
    path.write_text("\n".join([",".join(("Name",) + units)] + [
        ",".join([label] + [f"{c * per_mm:.10f}" for c in made.actual[k]]) for k, label in enumerate(made.labels)]))
    found = cmmsampling.inspect(planned, path)
    assert found.labels == reference.labels
    np.testing.assert_allclose(found.deviations, reference.deviations, atol=1e-6)   # 10 digits, not the DMIS 7
    assert any("converted to mm" in note for note in found.notes) == (per_mm != 1.0)


@pytest.mark.parametrize("header, words", [
    ("Name,X [furlong],Y [furlong],Z [furlong]", "column 'X [furlong]' gives its unit as 'furlong', which this "
                                                 "reader does not know"),
    ("Name,X [mm in],Y,Z", "column 'X [mm in]' names two units (mm, in)")])
def test_a_unit_word_that_is_not_understood_is_refused(measured, header, words):
    planned, made, _, folder = measured
    path = folder / "strange_units.csv"
    path.write_text("\n".join([header] + [",".join(row) for row in rows(made)]))
    with pytest.raises(InputError) as raised:
        cmmsampling.inspect(planned, path)
    assert words in str(raised.value) and "strange_units.csv, line 1" in str(raised.value)


def test_columns_in_another_order_and_a_report_of_nominal_and_measured_values(measured):
    """A report gives each coordinate nominal and measured (and a deviation): the measured columns
    are read, in whatever order; a report of nominal columns only holds no measurement."""
    planned, made, reference, folder = measured
    lines = ["Dev;Z act;X nom;Y nom;Z nom;X act;Y act;Point"]
    for k, label in enumerate(made.labels):
        nominal, actual = planned.points[k], made.actual[k]
        lines.append(";".join([f"{0.0:.4f}", f"{actual[2]:.7f}", *(f"{c:.7f}" for c in nominal),
                               f"{actual[0]:.7f}", f"{actual[1]:.7f}", label]))
    (folder / "report.csv").write_text("\n".join(lines) + "\n")
    same_verdict(cmmsampling.inspect(planned, folder / "report.csv"), reference)
    (folder / "nominal.csv").write_text("Point,X nom,Y nom,Z nom\n" + "\n".join(
        ",".join([label] + [f"{c:.7f}" for c in planned.points[k]]) for k, label in enumerate(made.labels)) + "\n")
    with pytest.raises(InputError, match=r"nominal.csv, line 1: the columns give nominal coordinates only"):
        cmmsampling.inspect(planned, folder / "nominal.csv")


def test_a_dmis_program_with_nominal_points_only_is_no_measurement(measured):
    """The program as exported (F(label) nominals, no FA(label) actuals) passed at profile 0 before."""
    planned, _, _, folder = measured
    cmmsampling.export(planned, folder / "program.dmi")
    with pytest.raises(InputError, match=r"program.dmi: holds the program's nominal points only .* give the DMIS "
                                         "output file the CMM wrote after measuring"):
        cmmsampling.inspect(planned, folder / "program.dmi", tolerance=0.05)


@pytest.mark.parametrize("units, per_mm", [("INCH", 1 / 25.4), ("CM", 0.1)])
def test_dmis_output_in_other_units_is_read_in_mm(measured, units, per_mm):
    """The same output written by hand in inches (or cm): read in inches as mm before, the points
    moved 22.8 mm and a good part failed."""
    planned, _, reference, folder = measured
    output = cmmsampling.read_points(folder / "measured.dmi")
    lines = ["DMISMN/'MEASURED',05.2", f"UNITS/{units},ANGDEC"] + [
        f"FA({label})=FEAT/POINT,CART," + ",".join(f"{c:.9f}" for c in np.r_[point * per_mm, normal])
        for label, point, normal in zip(output.labels, output.points, output.normals)] + ["ENDFIL"]
    (folder / "other_units.dmi").write_text("\n".join(lines) + "\n")
    same_verdict(cmmsampling.inspect(planned, folder / "other_units.dmi"), reference)
    (folder / "unknown.dmi").write_text("\n".join(lines).replace(f"UNITS/{units}", "UNITS/PARSEC") + "\n")
    with pytest.raises(InputError, match="unknown.dmi, line 2: UNITS/PARSEC is not a DMIS length unit"):
        cmmsampling.inspect(planned, folder / "unknown.dmi")


def test_unlabelled_points_pair_by_order_only_when_every_point_is_there(measured):
    """x y z lines got labels P1..PN by order, which then paired with the planned P1..P24 when one
    line was missing: points paired with nominals far away. Now a missing line is refused with the
    counts, and all of them pair by order with a note."""
    planned, made, reference, folder = measured
    lines = [" ".join(row[1:]) for row in rows(made)]
    (folder / "all.xyz.txt").write_text("\n".join(lines) + "\n")
    found = cmmsampling.inspect(planned, folder / "all.xyz.txt")
    same_verdict(found, reference)
    assert "paired by order: the file has no labels" in found.notes
    (folder / "one_missing.txt").write_text("\n".join(lines[:12] + lines[13:]) + "\n")
    with pytest.raises(InputError, match="the 24 measured points carry no planned label and there are 25 planned "
                                         "points, so they cannot be paired by order"):
        cmmsampling.inspect(planned, folder / "one_missing.txt")


def test_a_file_too_large_is_refused_before_it_is_read(measured):
    """A 200 MB file (sparse: no disk used) is refused at once, naming its size."""
    planned, _, _, folder = measured
    path = folder / "huge.txt"
    with open(path, "wb") as stream:
        stream.truncate(200 * 2 ** 20)
    with pytest.raises(InputError, match=r"huge.txt: 200 MB is more than a measured-points file may hold \(100 MB"):
        cmmsampling.inspect(planned, path)



def test_a_text_report_of_point_locations(measured):
    """A PC-DMIS-style text report (a block a point: DIM ... LOCATION OF POINT, AX rows with
    NOMINAL and MEAS columns, the last block in inches), with a flatness dimension between:
    "line 1: x 'X' is not a number" before."""
    planned, made, reference, folder = measured
    lines = ["PART NAME  : FAN BLADE", "DIM FLT1= FLATNESS OF PLANE PLN1  UNITS=MM", "AX   MEAS    DEV", "M    0.012"]
    for k, label in enumerate(made.labels):
        inches = k == len(made.labels) - 1
        scale = 1 / 25.4 if inches else 1.0
        lines += [f"DIM LOC{k + 1}= LOCATION OF POINT {label}  UNITS={'IN' if inches else 'MM'}",
                  "AX    NOMINAL       +TOL       -TOL       MEAS        DEV     OUTTOL"]
        lines += [f"{axis}  {nominal * scale:10.6f}  0.0100  0.0100  {actual * scale:.{9 if inches else 7}f}  0.0000  "
                  "0.0000" for axis, nominal, actual in zip("XYZ", planned.points[k], made.actual[k])]
    (folder / "report.txt").write_text("\n".join(lines) + "\n")
    same_verdict(cmmsampling.inspect(planned, folder / "report.txt"), reference)
    (folder / "no_z.txt").write_text("\n".join(lines[:8] + lines[9:]) + "\n")
    with pytest.raises(InputError, match=r"no_z.txt, line 5: point P1 has no measured Z"):
        cmmsampling.inspect(planned, folder / "no_z.txt")
