"""Write the README's picture of an inspection: Halton points on the reference face, measured on
a virtual CMM (a part with a smooth form error, misplaced on the table), read back, aligned by
best fit and judged against a profile tolerance; the measured face's colour map goes to
docs/images/inspection-reference-face.png and the summary to the terminal.

Run with Debian's Python from the checkout: /usr/bin/python3 scripts/inspection_figure.py
"""
import os
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import cmmsampling  # noqa: E402
from cmmsampling.inspection.figure import write_inspection_figure  # noqa: E402

FIGURE = os.path.join(ROOT, "docs", "images", "inspection-reference-face.png")
MEASUREMENT = {"form_error": 0.03, "noise": 0.001, "misplacement": {"rz": 0.9, "rx": -0.3, "x": 1.5, "y": -0.8},
               "seed": 7}
TOLERANCE = 0.015


def main():
    """Plan, measure, inspect and draw; prints the inspection's summary and the figure's path."""
    face = cmmsampling.reference_face()
    result = cmmsampling.sample(face, 49, "halton", occ_check=False)
    with tempfile.TemporaryDirectory() as folder:
        measured = os.path.join(folder, "measured.dmi")
        cmmsampling.simulate_measurement(result, measured, **MEASUREMENT)
        found = cmmsampling.inspect(result, measured, tolerance=TOLERANCE)
    os.makedirs(os.path.dirname(FIGURE), exist_ok=True)
    print(found.summary())
    print(write_inspection_figure(found, face, FIGURE, title="Reference face, 49 Halton points measured"))


if __name__ == "__main__":
    main()
