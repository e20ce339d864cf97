"""A grammar checker for the DMIS subset cmmsampling writes: ``check(text) -> [error, ...]``.

Physical lines: at most 80 characters of printable ASCII; ``$$`` starts a comment line; a line
ending in ``$`` goes on in the next one. Statements, in this order::

    DMISMN/'name',NN.N                        first
    UNITS/MM,ANGDEC   MODE/[AUTO,]PROG,MAN   SNSET/(APPRCH|RETRCT|SEARCH),d
    D(label)=TRANS/XORIG,x,YORIG,y,ZORIG,z     after UNITS, before any FEAT or right after a DATSET
    D(label)=ROTAT/(XAXIS|YAXIS|ZAXIS),a      the datum's TRANS before it, as TRANS
    S(label)=SNSDEF/PROBE,INDEX,POL,a,b,i,j,k,l,d   label new, (i, j, k) the head's mounting
                                              vector (unit), l and d positive
    SNSLCT/S(label)                           label defined, not inside MEAS
    GOTO/x,y,z                                not inside MEAS, in a MODE/AUTO,PROG,MAN
                                              (DCC) program only, never the line before again
    DID(label)=DEVICE/STOR,'name'              after UNITS, before any FEAT
    OPEN/DID(label),FDATA,DMIS,OUTPUT          its DEVICE before it, before any FEAT
    F(label)=FEAT/POINT,CART,x,y,z,i,j,k      label new, after UNITS
    F(label)=FEAT/PLANE,CART,x,y,z,i,j,k      label new, after UNITS (a datum's nominal plane)
    F(label)=FEAT/CYLNDR,(INNER|OUTER),CART,x,y,z,i,j,k,d,l   label new, after UNITS (a datum's
                                              nominal cylinder, as NIST's IMTS program writes
                                              one: (i, j, k) its axis, d > 0 diameter, l > 0 length)
    F(label)=FEAT/PATERN,F(a),F(b),...        label new, its members defined
    CONST/PLANE,F(label),BF,FA(a),FA(b),...   a PLANE's feature, its members measured: measured
    CONST/CYLNDR,F(label),BF,FA(a),...        a CYLNDR's feature, at least 6 members measured (a
                                              least-squares cylinder: PC-DMIS asks 6 at least)
    CONST/PATERN,F(label),BUILD,FA(a),...     a PATERN's feature, its members measured: measured
    DATDEF/FA(label),DAT(x)                   a measured feature becomes datum x (new)
    D(label)=DATSET/DAT(x),[XYZ]DIR,[XYZ]ORIG,...  datums defined; each axis and origin once
    T(label)=TOL/PROFS,lo,up[,DAT(x)...]      label new, lo < up, its datums defined
    MEAS/POINT,F(label),n                     label defined, not inside another MEAS
    PTMEAS/CART,x,y,z,i,j,k                   only inside MEAS, n of them
    ENDMES                                    closes MEAS
    OUTPUT/FA(label)[,TA(t)...]               a measured feature's, its device open, not inside MEAS,
                                              its tolerances defined
    CLOSE/DID(label)                          an open device's, not inside MEAS
    ENDFIL                                    last

Numbers are fixed notation (-12.345), counts whole numbers, labels 1-64 characters of
[A-Za-z0-9_.-], (i, j, k) unit vectors to 1e-6.
"""
import re

LINE_LIMIT = 80
NUMBER = r"[+-]?\d+\.\d+"
LABEL = r"[A-Za-z0-9_.-]{1,64}"
VECTOR_TOLERANCE = 1e-6

SIMPLE = {
    "DMISMN": re.compile(r"DMISMN/'[ -&(-~]*',\d\d\.\d\Z"),
    "UNITS": re.compile(r"UNITS/MM,ANGDEC\Z"),
    "MODE": re.compile(r"MODE/(AUTO,)?PROG,MAN\Z"),
    "SNSET": re.compile(rf"SNSET/(APPRCH|RETRCT|SEARCH),{NUMBER}\Z"),
    "ENDMES": re.compile(r"ENDMES\Z"),
    "ENDFIL": re.compile(r"ENDFIL\Z"),
}
FEATURE = re.compile(r"F\(([^()]*)\)=FEAT/(POINT|PLANE),CART,(.*)\Z")
CYLINDER = re.compile(rf"F\(([^()]*)\)=FEAT/(CYLNDR),(?:INNER|OUTER),CART,(.*),({NUMBER}),({NUMBER})\Z")
PATTERN = re.compile(rf"F\(([^()]*)\)=FEAT/PATERN((?:,F\({LABEL}\))+)\Z")
CONSTRUCT = re.compile(rf"CONST/(PLANE|CYLNDR|PATERN),F\(({LABEL})\),(BF|BUILD)((?:,FA\({LABEL}\))+)\Z")
DATDEF = re.compile(rf"DATDEF/FA\(({LABEL})\),DAT\(({LABEL})\)\Z")
DATSET = re.compile(rf"D\(({LABEL})\)=DATSET/((?:DAT\({LABEL}\)(?:,[XYZ](?:DIR|ORIG))+,?)+)\Z")
TOLERANCE = re.compile(rf"T\(({LABEL})\)=TOL/PROFS,({NUMBER}),({NUMBER})((?:,DAT\({LABEL}\))*)\Z")
MEMBERS = re.compile(rf"FA?\(({LABEL})\)")
OUTPUTS = {"DID": re.compile(rf"DID\(({LABEL})\)=DEVICE/STOR,'[ -&(-~]+'\Z"),
           "OPEN": re.compile(rf"OPEN/DID\(({LABEL})\),FDATA,DMIS,OUTPUT\Z"),
           "OUTPUT": re.compile(rf"OUTPUT/FA\(({LABEL})\)((?:,TA\({LABEL}\))*)\Z"),
           "CLOSE": re.compile(rf"CLOSE/DID\(({LABEL})\)\Z")}
MEASURE = re.compile(r"MEAS/POINT,F\(([^()]*)\),(.*)\Z")
POINT = re.compile(r"PTMEAS/CART,(.*)\Z")
SENSOR = re.compile(r"S\(([^()]*)\)=SNSDEF/PROBE,INDEX,POL,(.*)\Z")
SELECT = re.compile(r"SNSLCT/S\(([^()]*)\)\Z")
GOTO = re.compile(rf"GOTO/{NUMBER},{NUMBER},{NUMBER}\Z")
TRANSLATE = re.compile(rf"D\(([^()]*)\)=TRANS/XORIG,{NUMBER},YORIG,{NUMBER},ZORIG,{NUMBER}\Z")
ROTATE = re.compile(rf"D\(([^()]*)\)=ROTAT/[XYZ]AXIS,{NUMBER}\Z")


def check(text):
    """Errors (str, each naming its line) of DMIS text against the subset; [] when it conforms."""
    errors = [f"line {n}: {e}" for n, line in enumerate(text.split("\n"), 1) for e in line_errors(line)]
    statements, continued = statements_of(text)
    if continued:
        errors.append("the file ends inside a continued statement")
    if not statements:
        return errors + ["no statements"]
    if statements[0][0] != 1 or not statements[0][1].startswith("DMISMN/"):
        errors.append("line 1 must be the DMISMN statement")
    if statements[-1][1] != "ENDFIL":
        errors.append(f"line {statements[-1][0]}: the last statement must be ENDFIL")
    state = ProgramState()
    for number, statement in statements:
        errors += [f"line {number}: {e}" for e in state.take(statement)]
    if state.measuring:
        errors.append(f"MEAS of F({state.measuring}) has no ENDMES")
    return errors


def line_errors(line):
    """Errors of one physical line: length and characters."""
    errors = []
    if len(line) > LINE_LIMIT:
        errors.append(f"{len(line)} characters, more than {LINE_LIMIT}")
    if re.search(r"[^ -~]", line):
        errors.append("characters other than printable ASCII")
    return errors


def statements_of(text):
    """([(first line number, statement)], whether the text ends inside a continued statement)."""
    statements, pending, first = [], "", None
    for number, line in enumerate(text.split("\n"), 1):
        if line.startswith("$$") or not line.strip():
            continue
        first = first or number
        if line.endswith("$"):
            pending += line[:-1]
            continue
        statements.append((first, pending + line))
        pending, first = "", None
    return statements, bool(pending)


class ProgramState:
    """What the statements so far have defined: units, feature labels, an open MEAS."""

    def __init__(self):
        self.units = False
        self.features = set()
        self.sensors = set()
        self.datums = set()
        self.devices = {}
        self.measured = set()
        self.measuring = None
        self.expected = 0
        self.points = 0
        self.ended = False
        self.automatic = False
        self.previous = ""
        self.kinds = {}
        self.datum_features = set()
        self.tolerances = set()
        self.frame_set = False

    def take(self, statement):
        """Errors of the next statement, given the state; updates the state."""
        if self.ended:
            return ["statement after ENDFIL"]
        previous, self.previous = self.previous, statement
        keyword = re.match(r"[A-Z]*", statement).group()
        if keyword == "GOTO" and statement == previous:
            return [f"{statement} repeats the move before it"]
        if keyword == "MODE":
            self.automatic = statement.startswith("MODE/AUTO")
        if keyword == "F" and statement.startswith("F("):
            return self.feature(statement)
        if keyword == "S" and statement.startswith("S("):
            return self.sensor(statement)
        if keyword == "D" and statement.startswith("D("):
            return self.datum_set(statement) if "=DATSET/" in statement else self.datum(statement)
        if keyword == "T" and statement.startswith("T("):
            return self.tolerance(statement)
        if keyword in ("CONST", "DATDEF"):
            return self.construct(keyword, statement)
        if keyword in ("SNSLCT", "GOTO"):
            return self.move(keyword, statement)
        if keyword in ("DID", "OPEN", "OUTPUT", "CLOSE"):
            return self.output(keyword, statement)
        if keyword == "MEAS":
            return self.measure(statement)
        if keyword == "PTMEAS":
            return self.point(statement)
        if keyword not in SIMPLE:
            return [f"unknown statement {statement[:30]!r}"]
        if not SIMPLE[keyword].match(statement):
            return [f"malformed {keyword}: {statement!r}"]
        return self.simple(keyword)

    def simple(self, keyword):
        """State changes and errors of the statements without labels or numbers."""
        if keyword == "UNITS":
            self.units = True
        if keyword == "ENDMES":
            if not self.measuring:
                return ["ENDMES without MEAS"]
            errors = [] if self.points == self.expected else [
                f"MEAS of F({self.measuring}) announced {self.expected} points, got {self.points}"]
            self.measured.add(self.measuring)
            self.measuring = None
            return errors
        if keyword == "ENDFIL":
            self.ended = True
            return ["ENDFIL inside MEAS"] if self.measuring else []
        return ["statement inside MEAS"] if self.measuring else []

    def sensor(self, statement):
        """S(label)=SNSDEF/PROBE,INDEX,POL,a,b,i,j,k,length,diameter."""
        match = SENSOR.match(statement)
        if match is None:
            return [f"malformed SNSDEF: {statement!r}"]
        label, fields = match.groups()
        values = fields.split(",")
        errors = label_errors(label)
        if len(values) != 7 or not all(re.fullmatch(NUMBER, v) for v in values):
            return errors + [f"expected 7 fixed-notation numbers a,b,i,j,k,length,diameter, got {fields!r}"]
        length = sum(float(v) ** 2 for v in values[2:5]) ** 0.5
        if abs(length - 1.0) > VECTOR_TOLERANCE:
            errors.append(f"the head's mounting vector has length {length:.9f}, not 1")
        if float(values[5]) <= 0 or float(values[6]) <= 0:
            errors.append("the stylus length and ball diameter must be positive")
        if label in self.sensors:
            errors.append(f"S({label}) defined twice")
        self.sensors.add(label)
        return errors + (["SNSDEF inside MEAS"] if self.measuring else [])

    def datum(self, statement):
        """D(label)=TRANS/XORIG,x,YORIG,y,ZORIG,z, then D(label)=ROTAT/axis,a: the frame the
        points are written in, set before the first feature."""
        translated, rotated = TRANSLATE.match(statement), ROTATE.match(statement)
        if translated is None and rotated is None:
            return [f"malformed datum statement: {statement!r}"]
        label = (translated or rotated).group(1)
        errors = label_errors(label)
        if rotated is not None and label not in self.datums:
            errors.append(f"ROTAT of D({label}) before its TRANS")
        if not self.units or (self.features and not self.frame_set) or self.measuring:
            errors.append("a datum statement belongs after UNITS and before the first FEAT, or after a DATSET")
        self.datums.add(label)
        return errors

    def datum_set(self, statement):
        """D(label)=DATSET/DAT(x),words,...: its datums defined, each axis direction and origin
        word at most once; the frame statements may follow."""
        match = DATSET.match(statement)
        if match is None:
            return [f"malformed DATSET: {statement!r}"]
        errors = ["statement inside MEAS"] if self.measuring else []
        used = re.findall(r"DAT\(([^()]*)\)", match.group(2))
        errors += [f"DATSET of DAT({label}) before its DATDEF" for label in used if label not in self.datum_features]
        words = re.findall(r"[XYZ](?:DIR|ORIG)", match.group(2))
        errors += [f"{word} given twice" for word in set(words) if words.count(word) > 1]
        self.frame_set = True
        return errors

    def construct(self, keyword, statement):
        """CONST/PLANE,F(l),BF,FA(..).. and CONST/PATERN,F(l),BUILD,FA(..).. of measured members
        (the feature measured after it); DATDEF/FA(l),DAT(x) of a measured feature."""
        if keyword == "DATDEF":
            match = DATDEF.match(statement)
            if match is None:
                return [f"malformed DATDEF: {statement!r}"]
            feature, datum = match.groups()
            errors = [] if feature in self.measured else [f"DATDEF of FA({feature}) before it was measured"]
            errors += [f"DAT({datum}) defined twice"] if datum in self.datum_features else []
            self.datum_features.add(datum)
            return errors
        match = CONSTRUCT.match(statement)
        if match is None:
            return [f"malformed CONST: {statement!r}"]
        kind, label, method, members = match.groups()
        errors = [] if self.kinds.get(label) == kind else [f"CONST/{kind} of F({label}), which is no {kind} feature"]
        errors += [] if (kind, method) in (("PLANE", "BF"), ("CYLNDR", "BF"), ("PATERN", "BUILD")) else [
            f"CONST/{kind} by {method}"]
        if kind == "CYLNDR" and len(MEMBERS.findall(members)) < 6:
            errors.append(f"CONST/CYLNDR of F({label}) through fewer than 6 points")
        errors += [f"CONST of FA({member}) before it was measured" for member in MEMBERS.findall(members)
                   if member not in self.measured]
        self.measured.add(label)
        return errors + (["statement inside MEAS"] if self.measuring else [])

    def tolerance(self, statement):
        """T(label)=TOL/PROFS,lo,up[,DAT(x)...]."""
        match = TOLERANCE.match(statement)
        if match is None:
            return [f"malformed TOL: {statement!r}"]
        label, low, high, datums = match.groups()
        errors = label_errors(label) + ([] if float(low) < float(high) else [f"TOL/PROFS {low} is not below {high}"])
        errors += [f"TOL of DAT({datum}) before its DATDEF" for datum in re.findall(r"DAT\(([^()]*)\)", datums)
                   if datum not in self.datum_features]
        errors += [f"T({label}) defined twice"] if label in self.tolerances else []
        self.tolerances.add(label)
        return errors

    def output(self, keyword, statement):
        """DID(label)=DEVICE/STOR,'name', OPEN/DID(label),FDATA,DMIS,OUTPUT (both before the
        first FEAT), OUTPUT/FA(label) of a measured feature to the open device, CLOSE/DID(label)."""
        pattern = OUTPUTS[keyword]
        match = pattern.match(statement)
        if match is None:
            return [f"malformed {keyword}: {statement!r}"]
        label = match.group(1)
        errors = ["statement inside MEAS"] if self.measuring else []
        if keyword in ("DID", "OPEN") and (not self.units or self.features):
            errors.append(f"{keyword} belongs after UNITS and before the first FEAT")
        if keyword == "DID":
            self.devices[label] = False
        elif keyword == "OPEN":
            errors += [] if label in self.devices else [f"OPEN of DID({label}) before its DEVICE"]
            self.devices[label] = True
        elif keyword == "OUTPUT":
            errors += [] if label in self.measured else [f"OUTPUT of FA({label}) before it was measured"]
            errors += [f"TA({tolerance}) before its TOL" for tolerance in re.findall(r"TA\(([^()]*)\)", match.group(2))
                       if tolerance not in self.tolerances]
            errors += [] if any(self.devices.values()) else ["OUTPUT with no output device open"]
        elif not self.devices.get(label):
            errors.append(f"CLOSE of DID({label}), which is not open")
        else:
            self.devices[label] = False
        return errors

    def move(self, keyword, statement):
        """SNSLCT/S(label) of a defined sensor, GOTO/x,y,z; neither inside MEAS."""
        errors = ["statement inside MEAS"] if self.measuring else []
        if keyword == "GOTO":
            errors += [] if self.automatic else ["GOTO in a program not in MODE/AUTO,PROG,MAN (DCC)"]
            return errors + ([] if GOTO.match(statement) else [f"malformed GOTO: {statement!r}"])
        match = SELECT.match(statement)
        if match is None:
            return errors + [f"malformed SNSLCT: {statement!r}"]
        return errors + ([] if match.group(1) in self.sensors else [f"SNSLCT of S({match.group(1)}) before its SNSDEF"])

    def feature(self, statement):
        """F(label)=FEAT/POINT or PLANE,CART,x,y,z,i,j,k; FEAT/CYLNDR,INNER|OUTER,CART,x,y,z,i,j,k,d,l;
        F(label)=FEAT/PATERN,F(..),..."""
        pattern = PATTERN.match(statement)
        if pattern is not None:
            label, members = pattern.groups()
            errors = label_errors(label) + [f"PATERN of F({member}) before its FEAT"
                                            for member in MEMBERS.findall(members) if member not in self.features]
            kind = "PATERN"
        else:
            match = FEATURE.match(statement) or CYLINDER.match(statement)
            if match is None:
                return [f"malformed FEAT: {statement!r}"]
            label, kind, fields = match.groups()[:3]
            errors = label_errors(label) + numbers_errors(fields)
            errors += [f"CYLNDR size {size} is not positive" for size in match.groups()[3:] if float(size) <= 0]
        self.kinds[label] = kind
        if label in self.features:
            errors.append(f"F({label}) defined twice")
        if not self.units:
            errors.append("FEAT before UNITS")
        if self.measuring:
            errors.append("FEAT inside MEAS")
        self.features.add(label)
        return errors

    def measure(self, statement):
        """MEAS/POINT,F(label),n."""
        match = MEASURE.match(statement)
        if match is None:
            return [f"malformed MEAS: {statement!r}"]
        label, count = match.groups()
        errors = label_errors(label)
        if label not in self.features:
            errors.append(f"MEAS of F({label}) before its FEAT")
        if self.measuring:
            errors.append(f"MEAS inside the MEAS of F({self.measuring})")
        if not re.fullmatch(r"[1-9]\d*", count):
            errors.append(f"the point count {count!r} is not a positive whole number")
        self.measuring, self.expected, self.points = label, int(count) if count.isdigit() else 0, 0
        return errors

    def point(self, statement):
        """PTMEAS/CART,x,y,z,i,j,k inside MEAS."""
        match = POINT.match(statement)
        if match is None:
            return [f"malformed PTMEAS: {statement!r}"]
        self.points += 1
        errors = numbers_errors(match.group(1))
        return errors if self.measuring else errors + ["PTMEAS outside MEAS"]


def label_errors(label):
    """Errors of a feature label."""
    return [] if re.fullmatch(LABEL, label) else [f"label {label!r} is not 1-64 characters of [A-Za-z0-9_.-]"]


def numbers_errors(fields):
    """Errors of 'x,y,z,i,j,k': six fixed-notation numbers, (i, j, k) a unit vector."""
    values = fields.split(",")
    if len(values) != 6:
        return [f"expected 6 numbers x,y,z,i,j,k, got {len(values)}"]
    bad = [v for v in values if not re.fullmatch(NUMBER, v)]
    if bad:
        return [f"not fixed-notation numbers: {bad}"]
    length = sum(float(v) ** 2 for v in values[3:]) ** 0.5
    return [] if abs(length - 1.0) <= VECTOR_TOLERANCE else [f"(i, j, k) has length {length:.9f}, not 1"]
