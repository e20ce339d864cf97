"""The workbench's values kept between uses in FreeCAD's parameter group: its panels' and dialogs',
and the export options File > Export takes as the Export command would start."""
import FreeCAD

PARAMETER_GROUP = "User parameter:BaseApp/Preferences/Mod/CMMSampling"

_ACCESS = {
    bool: ("GetBool", "SetBool"),
    int: ("GetInt", "SetInt"),
    float: ("GetFloat", "SetFloat"),
    str: ("GetString", "SetString"),
}


def load(defaults):
    """The stored values for the keys of ``defaults`` (a dict of bool/int/float/str), falling
    back to the defaults; each value has its default's type."""
    group = FreeCAD.ParamGet(PARAMETER_GROUP)
    return {key: getattr(group, _ACCESS[type(value)][0])(key, value) for key, value in defaults.items()}


def save(values):
    """Store a dict of bool/int/float/str values."""
    group = FreeCAD.ParamGet(PARAMETER_GROUP)
    for key, value in values.items():
        getattr(group, _ACCESS[type(value)][1])(key, value)
