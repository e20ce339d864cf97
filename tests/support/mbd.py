"""NIST's PMI test models as QIF 3.0 MBD (and two as STEP) in ../shared/reference/qif3/mbd: the
folder, the four models' names, and a file's path for a test (skipped where the folder is absent)."""
import os

import pytest

from .paths import ROOT

MBD = os.path.join(os.path.dirname(ROOT), "shared", "reference", "qif3", "mbd")
MODELS = ["nist_ctc_01_asme1_ap242", "nist_ctc_03_asme1_ap242", "nist_ftc_06_asme1_ap242", "nist_ftc_09_asme1_ap242"]


def shared_mbd(name):
    """The path of a file of the shared MBD folder (the test is skipped where it is absent)."""
    path = os.path.join(MBD, name)
    if not os.path.isfile(path):
        pytest.skip(f"{path} is not beside the checkout")
    return path
