"""DMIS programs give their results back: ours open an output device, OUTPUT each measured
point and close it (a CMM running one writes a DMIS output file our reader takes), state the part
alignment they assume, and pass our DMIS grammar; NIST's DMIS programs for the I++ DME test parts
are read for the points they hold, the other features named."""
import os
import re

import numpy as np
import pytest
from support.ippdme import NIST

from support import dmis_syntax

import cmmsampling
from cmmsampling.geometry.validation import InputError
from cmmsampling.inspection.simulate import Misplacement, form_field


@pytest.fixture(scope="module")
def result(reference):
    return cmmsampling.sample(reference, 16, "halton", grid=16, occ_check=False)


def as_a_cmm_fills_it(program, nominal, actual):
    """The DMIS output a CMM writes running program: for each OUTPUT/FA(label), in order, the
    label's actual point (actual: {label: (x, y, z)} mm) with its nominal vector, in the layout
    of NIST's output.dms."""
    vectors = dict(zip(nominal.labels, nominal.normals))
    lines = ["FILNAM/'RESULTS'", "UNITS/MM,ANGDEC"]
    for label in re.findall(r"^OUTPUT/FA\(([^()]+)\)$", program, re.M):
        values = ",".join(f"{v:.6f}" for v in [*actual[label], *vectors[label]])
        lines += [f"OUTPUT/FA({label})", f"FA({label})=FEAT/POINT,CART,{values}"]
    return "\n".join(lines + ["ENDFIL"]) + "\n"


def test_our_programs_output_comes_back_as_measured_points(result, tmp_path):
    cmmsampling.export(result, tmp_path / "face.dmi", probe_radius=1.0)
    program = (tmp_path / "face.dmi").read_text()
    assert dmis_syntax.check(program) == []
    assert "DID(RESULTS)=DEVICE/STOR,'face.dmo'" in program and "OPEN/DID(RESULTS),FDATA,DMIS,OUTPUT" in program
    assert program.count("OUTPUT/FA(") == 16 and program.rstrip().endswith("CLOSE/DID(RESULTS)\nENDFIL")
    assert "$$ part alignment: the part's frame must be set" in program
    nominal = cmmsampling.PointSet.from_result(result)
    form = form_field(nominal.points, 0.01, seed=4)
    moved = Misplacement(rz=0.4, x=0.7).matrix(nominal.points.mean(axis=0))
    touched = (nominal.points + form[:, None] * nominal.normals) @ moved[:3, :3].T + moved[:3, 3]
    (tmp_path / "face.dmo").write_text(as_a_cmm_fills_it(program, nominal, dict(zip(nominal.labels, touched))))
    found = cmmsampling.inspect(result, tmp_path / "face.dmo", tolerance=0.05)
    assert found.labels == result.labels and not found.notes
    assert found.profile <= 2 * 0.01 + 1e-5 and found.passed


def test_a_plans_program_passes_the_grammar_with_its_path_and_output(tmp_path):
    from support.faces import FreeCAD, Part
    from cmmsampling.access.probe import Probe

    part = Part.makeBox(60, 40, 10).fuse(Part.makeBox(10, 40, 60, FreeCAD.Vector(0, 0, 10))).removeSplitter()
    plan = cmmsampling.plan(part, n_total=16, strategy="uniform_parametric", faces=[6], probe=Probe(), processes=1)
    cmmsampling.export(plan, tmp_path / "part.dmi", order="probe_path")
    program = (tmp_path / "part.dmi").read_text()
    assert dmis_syntax.check(program) == [] and "GOTO/" in program and program.count("OUTPUT/FA(") == plan.n_total


def nist_program(name):
    """A DMIS program of NIST's I++ DME test suite (skipped where ../shared is absent)."""
    path = os.path.join(NIST, "dmis", name)
    if not os.path.isfile(path):
        pytest.skip(f"{path} is not beside the checkout")
    return path


def test_nists_programs_give_their_probed_points_and_name_the_other_features():
    imts = cmmsampling.read_points(nist_program("IMTS_M_clean.dmi"))
    assert len(imts) == 4 + 4 + 4 + 8 + 8 + 1 and imts.labels[:2] == ["PLN1_P1", "PLN1_P2"]
    assert imts.labels[12] == "CPNT1" and imts.metadata["dmis_features"] == "nominal", "in the program's order"
    assert imts.points[0].tolist() == [-43.0, 15.0, 30.0] and imts.normals[0].tolist() == [0.0, 0.0, 1.0]
    assert imts.metadata["dmis_other_features"] == ("F(PLN1) PLANE, F(PLN2) PLANE, F(PLN3) PLANE, F(CLIN1) LINE, "
                                                    "F(CYL1) CYLNDR, F(CYL2) CYLNDR")
    simple = cmmsampling.read_points(nist_program("simple_in.dms"))
    assert simple.labels == [f"A_CIRCLE_P{k}" for k in range(1, 5)]
    assert np.array_equal(simple.points[1], [25.0, 50.0, 40.0]) and np.array_equal(simple.normals[1], [1, 0, 0])


def test_nists_output_of_a_circle_is_named_not_dropped(reference):
    with pytest.raises(InputError, match=r"no point to read .* it holds FA\(A_CIRCLE\) CIRCLE"):
        cmmsampling.read_points(nist_program("output.dms"))
    with pytest.raises(InputError, match=r"FA\(A_CIRCLE\) CIRCLE"):
        cmmsampling.inspect(reference, nist_program("output.dms"))


# The statement kinds we write that NIST's program uses too (SNSDEF: the indexed head's form we
# write), each with how to tell it and the pattern of our grammar.
SHARED_FORMS = {
    "SNSDEF": (lambda c: "=SNSDEF/PROBE,INDEX," in c, dmis_syntax.SENSOR),
    "SNSLCT": (lambda c: c.startswith("SNSLCT/"), dmis_syntax.SELECT),
    "FEAT/PLANE": (lambda c: "=FEAT/PLANE," in c, dmis_syntax.FEATURE),
    "FEAT/CYLNDR": (lambda c: "=FEAT/CYLNDR," in c, dmis_syntax.CYLINDER),
    "DATDEF": (lambda c: c.startswith("DATDEF/"), dmis_syntax.DATDEF),
    "DATSET": (lambda c: "=DATSET/DAT(" in c, dmis_syntax.DATSET),
    "OUTPUT": (lambda c: c.startswith("OUTPUT/"), dmis_syntax.OUTPUTS["OUTPUT"]),
    "OPEN": (lambda c: c.startswith("OPEN/"), dmis_syntax.OUTPUTS["OPEN"]),
    "DEVICE": (lambda c: "=DEVICE/STOR," in c, dmis_syntax.OUTPUTS["DID"]),
    "PTMEAS": (lambda c: c.startswith("PTMEAS/"), dmis_syntax.POINT),
    "TRANS": (lambda c: "=TRANS/XORIG," in c and "YORIG" in c, dmis_syntax.TRANSLATE),
}


def as_we_write(statement):
    """A NIST statement in our spelling: no blanks, whole numbers with a decimal point."""
    compact = statement.replace(" ", "")
    return re.sub(r"(?<![\w.])([+-]?\d+)(?![\d.])(?=,|$)", r"\1.0", compact)


def test_the_statement_forms_we_write_are_nists():
    statements, _ = cmmsampling.formats.dmis.dmis_statements(open(nist_program("IMTS_M_clean.dmi")).read())
    seen = set()
    for _, statement in statements:
        compact = as_we_write(statement)
        for kind, (is_kind, pattern) in SHARED_FORMS.items():
            if is_kind(compact):
                seen.add(kind)
                assert pattern.match(compact), f"NIST's {statement!r} is not in our form {pattern.pattern!r}"
    assert seen == set(SHARED_FORMS), f"NIST's program lacks {set(SHARED_FORMS) - seen}"
