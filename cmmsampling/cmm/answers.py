"""The answers of an I++ DME 1.4 server, read line by line.

:func:`parse_response` takes exactly the answer lines that NIST's response parser (the NIST
I++ DME test suite's ``parserRes``) takes and raises :class:`ResponseError` for the others, with
NIST's own message (e.g. "GetPropResponse: BAD SECOND KEYWORD"). The line may be given with or
without its CR LF. Grammar: the specification 1.4.3, section 6.1.4.2; errors: section 8.2, as
NIST's table has them (:data:`NIST_ERRORS`).
"""
from __future__ import annotations

import re
from collections import namedtuple
from dataclasses import dataclass, field

# Spec 8.2 "List of I++ predefined errors": code -> (default severity, text).
SPEC_ERRORS: dict[int, tuple[int, str]] = {
    0: (0, 'Buffer full'), 1: (2, 'Illegal tag'), 2: (2, 'No space at pos. 6'), 3: (2, 'Reserved'),
    4: (2, 'Reserved'), 5: (2, 'Reserved'),
    6: (2, 'Transaction aborted (Use ClearAllErrors To Continue)'), 7: (3, 'Illegal character'),
    8: (3, 'Protocol error'), 500: (3, 'Emergency stop'), 501: (3, 'Unsupported command'),
    502: (3, 'Incorrect arguments'), 503: (9, 'Controller communications failure'),
    504: (1, 'Argument out of range'), 505: (3, 'Argument not recognized'),
    506: (3, 'Argument not supported'), 507: (3, 'Illegal command'), 508: (3, 'Bad context'),
    509: (3, 'Bad argument'), 510: (3, 'Bad property'), 511: (3, 'Error processing method'),
    512: (1, 'No daemons are active'), 513: (2, 'Daemon does not exist'),
    514: (2, 'Use ClearAllErrors to continue'), 515: (2, 'Daemon already exists'),
    1000: (3, 'Machine in error state'), 1001: (2, 'Illegal touch'),
    1002: (9, 'Axis does not exist'), 1003: (2, 'No touch'),
    1004: (9, 'Number of angles not supported on current device'), 1005: (3, 'Error during home'),
    1006: (2, 'Surface not found'), 1007: (3, 'Theta out of range'),
    1008: (3, 'Target position out of machine volume'), 1009: (3, 'Air pressure out of range'),
    1010: (2, 'Vector has no norm'), 1011: (2, 'Unable to move'),
    1012: (2, 'Bad lock combinations'), 1500: (3, 'Failed to re-seat head'),
    1501: (3, 'Probe not armed'), 1502: (3, 'Tool not found'), 1503: (3, 'Tool not defined'),
    2000: (3, 'Tool not calibrated'), 2001: (2, 'Head error excessive force'),
    2002: (3, 'Type of probe does not allow this operation'),
    2500: (3, 'Machine limit encountered [Move Out Of Limits]'), 2501: (3, 'Axis not active'),
    2502: (3, 'Axis position error'), 2503: (9, 'Scale read head failure'), 2504: (3, 'Collision'),
    2505: (2, 'Specified angle out of range'), 2506: (2, 'Part not aligned'),
}
# NIST's table (IppCmdRes.h, Error0000..Error2506) differs from the spec in two
# ways: it has no 1011 and 1012, and 0006 reads "...ClearAllErrors to Continue".
NIST_ERRORS: dict[int, tuple[int, str]] = {
    **{c: v for c, v in SPEC_ERRORS.items() if c not in (1011, 1012)},
    6: (2, 'Transaction aborted (Use ClearAllErrors to Continue)')}
ERRORS = NIST_ERRORS  # the table error responses are checked against

# parserRes::parseKeyword's keywords; the first one the text starts with wins.
KEYWORDS = (
    'Accel', 'Act', 'Alignment', 'Approach', 'A', 'B', 'CenterPart', 'ChangeToolAction',
    'ChangeTool', 'CollisionVolume', 'CoordSystem', 'C', 'Def', 'DMEVersion', 'ER', 'Error',
    'ErrStatus', 'FoundTool', 'GetCsyTransformation', 'GetMachineClass', 'GoToPar', 'GoTo',
    'Id', 'IJK', 'IsHomed', 'IsUserEnabled', 'JogDisplayCsy', 'JogMoveCsy', 'KeyPress',
    'MachineCsy', 'Max', 'Min', 'MoveableMachineCsy', 'MoveAuto', 'MoveMan', 'MultipleArmCsy',
    'Name', 'OBB', 'PartCsy', 'Phi', 'PtMeasPar', 'PtMeas', 'Q', 'Retract', 'Rotate', 'R',
    'Search', 'SensorCsy', 'SetProp', 'Speed', 'Switch', 'TiltCenterPart', 'TiltPart', 'Tool',
    'X', 'Y', 'Z')
DIGITS = '0123456789'
IPPSIZE = 65536  # NIST's buffer; spec 6.2: a line "should not exceed 65536" characters
GOTOPAR = ('Speed', 'Accel')
PTMEASPAR = ('Speed', 'Accel', 'Approach', 'Retract', 'Search')
_01 = (0.0, 1.0)  # CenterPart(0|1), IsHomed(0|1), ...: the value is one character
METHODS = {  # first keyword -> (NIST form, item types, allowed values of the first
    #          argument, message when not allowed), as in parserRes::make*Response
    'CenterPart': ('CenterPart', 'K(D)', _01, 'VALUE MUST BE 0 OR 1'),
    'ErrStatus': ('GetErrStatusE', 'K(D)', _01, 'VALUE MUST BE 0 OR 1'),
    'IsHomed': ('IsHomed', 'K(D)', _01, 'VALUE MUST BE 0 OR 1'),
    'IsUserEnabled': ('IsUserEnabled', 'K(D)', _01, 'VALUE MUST BE 0 OR 1'),
    'TiltCenterPart': ('TiltCenterPart', 'K(D)', _01, 'VALUE MUST BE 0 OR 1'),
    'TiltPart': ('TiltPart', 'K(D)', _01, 'VALUE MUST BE 0 OR 1'),
    'ChangeToolAction': ('ChangeToolAction', 'K(K,K(D),K(D),K(D))', (
        'Switch', 'Rotate', 'MoveAuto', 'MoveMan'),
        'FIRST ARGUMENT MUST BE SWITCH ROTATE MOVEAUTO OR MOVEMAN'),
    'CoordSystem': ('GetCoordSystem', 'K(K)', (
        'MachineCsy', 'MoveableMachineCsy', 'MultipleArmCsy', 'PartCsy'), 'BAD COORDINATE SYSTEM'),
    'GetCsyTransformation': ('GetCsyTransformation', 'K(D,D,D,D,D,D)', None, ''),
    'DMEVersion': ('GetDMEVersion', 'K(S)', None, ''),
    'GetMachineClass': ('GetMachineClass', 'K(S)', ('CartCMM', 'CartCMMWithRotaryTable'),
                        'BAD MACHINE CLASS')}
EVENT_METHODS = {'ChangeTool': ('ChangeToolE', 'K(S)', None, ''),  # tag E0000 only
                 'KeyPress': ('KeyPressE', 'K(S)', None, '')}
_STRING = re.compile('"([ !#-~]*)"')  # parseString: printable ASCII up to the next quote
_DIGIT_RUN = re.compile('[0-9]*')
BAD = 'BAD RESPONSE ITEMS'


class ResponseError(ValueError):
    """A malformed response line; str() is NIST's message for it."""


@dataclass(frozen=True)
class Response:
    """One parsed response line.

    kind: '&' ack, '%' complete, '#' data, '!' error.  form: NIST's response
    class without 'Response' ('PtMeasOrGet', 'GetProp', 'Scan', 'Error', ...).
    method: the data's method name ('CenterPart', 'GoTo', ...), or for '!' the
    error-causing method text (F3).  args: positional values (floats, strings,
    names).  props: property name -> tuple of values, e.g. {'X': (1.5,),
    'IJK': (0.0, 0.0, 1.0), 'Tool.PtMeasPar.Accel.Max': (2000.0,)}.
    severity, code, text: the error's F1, F2 and Text for '!'.  (props is a plain dict,
    so a Response compares by value but is not hashable.)
    """
    tag: str
    kind: str
    form: str = ''
    method: str = ''
    args: tuple = ()
    props: dict = field(default_factory=dict)
    severity: int | None = None
    code: int | None = None
    text: str = ''

    @property
    def numbers(self) -> tuple[float, ...]:
        """All numbers of args and props, in order (e.g. PtMeas: X, Y, Z, I, J, K)."""
        vals = list(self.args) + [v for vs in self.props.values() for v in vs]
        return tuple(v for v in vals if isinstance(v, float))


# One response item: typ is '(', ')', ',', '.', 'D' (number), 'K' (keyword) or 'S'
# (string); val is the float, keyword or string; src is a number's text.
_Tok = namedtuple('_Tok', 'typ val src', defaults=(None, ''))


def _need(ok: bool, form: str, msg: str = BAD) -> None:
    """Raise NIST's message (prefixed by the response class once it is known) unless ok."""
    if not ok:
        raise ResponseError(f'{form}Response: {msg}' if form else msg)


def _matched(found: re.Match[str] | None, msg: str) -> re.Match[str]:
    """found, or NIST's message ``msg`` raised where the pattern did not match."""
    if found is None:
        raise ResponseError(msg)
    return found


def _check_tag(buf: str) -> None:
    """parserRes::parseTag: Num UnsInt or E UnsInt, then a space; 00000 never, E0000 only for ! #."""
    _need(len(buf) > 5 and all(c in DIGITS for c in buf[1:5]), '', 'BAD TAG CHARACTER')
    _need(buf[5] == ' ', '', 'SPACE MISSING AFTER TAG')
    if buf[0] == 'E':
        _need(buf[1:5] != '0000' or buf[6] in ('!', '#'), '', 'ZERO TAG MUST BE SERVER INITIATED RESPONSE')
    else:
        _need(buf[0] in DIGITS, '', 'BAD TAG CHARACTER')
        _need(buf[:5] != '00000', '', 'TAG NUMBER OUT OF RANGE FOR COMMAND TAG')


def _unspace(s: str) -> str:
    """parserRes::unSpaceInputArray: drop spaces outside strings; a space must touch ( ) or ,
    (the last non-space before it, or the next character after the spaces)."""
    out, stringing, space_before, punc_before = [], False, False, False
    for c in s + '\0':
        if stringing:
            stringing = c != '"'
        elif c == ' ':
            space_before = space_before or not punc_before
            continue
        elif space_before:
            _need(c in '(),', '', 'ILLEGAL SPACE')
            space_before, punc_before = False, True
        elif c in '(),':
            punc_before = True
        else:
            punc_before, stringing = False, c == '"'
        out.append(c)
    return ''.join(out[:-1])


def _number(u: str, i: int) -> tuple[_Tok, int]:
    """parserRes::parseNumber: [+-] digits with at most one '.', 1..16 digits, optional
    exponent E|e [+-] 1..3 digits.  Returns the token and the index after it."""
    k = start = i + (u[i] in '+-')
    dot = 0
    while k < len(u) and (u[k] == '.' or u[k] in DIGITS):
        _need(not (dot and u[k] == '.'), '', 'BAD NUMBER TWO DECIMAL POINTS')
        dot, k = dot or u[k] == '.', k + 1
    _need(k - start - dot > 0, '', 'BAD NUMBER NO DIGITS')
    _need(k - start - dot <= 16, '', 'BAD NUMBER MORE THAN 16 DIGITS')
    if u[k:k + 1] in ('E', 'e'):
        k += 1 + (u[k + 1:k + 2] in ('+', '-'))
        j = _matched(_DIGIT_RUN.match(u, k), BAD).end() - k
        _need(1 <= j <= 3, '', 'BAD E NUMBER EXPONENT MUST HAVE ONE TWO OR THREE DIGITS')
        k += j
    return _Tok('D', float(u[i:k]), u[i:k]), k


def _tokenize(u: str) -> list[_Tok]:
    """parserRes::parseResItems (+ parseString, parseKeyword): split the unspaced data into
    items up to the first CR, which must be followed by LF and the end of the line."""
    toks, i = [], 0
    while i < len(u) and u[i] != '\r':
        c = u[i]
        if c in '(),' or (c == '.' and 'A' <= u[i + 1:i + 2] <= 'Z'):
            toks.append(_Tok(c))
            i += 1
        elif c == '"':
            m = _matched(_STRING.match(u, i), 'BAD STRING')
            toks.append(_Tok('S', m.group(1)))
            i = m.end()
        elif c in '+-.' or c in DIGITS:
            tok, i = _number(u, i)
            toks.append(tok)
        else:
            _need('A' <= c <= 'Z', '')
            kw = next((k for k in KEYWORDS if u.startswith(k, i)), '')
            _need(kw != '', '', 'BAD KEYWORD')
            i += len(kw)
            _need(u[i:i + 1] in ('.', ',', '(', ')'), '', 'BAD CHARACTER AFTER KEYWORD')
            toks.append(_Tok('K', kw))
    _need(u[i:] == '\r\n', '', 'BAD CHARACTER AFTER RESPONSE END')
    return toks


def parse_response(line: str) -> Response:
    """Parse one response line (CR LF optional) as NIST's parserRes::parseResponse does."""
    _need('\0' not in line, '', 'NUL CHARACTER IN RESPONSE')  # NIST's C string would end there
    buf = line if line.endswith('\r\n') else line + '\r\n'
    _need(len(buf) < IPPSIZE, '', 'RESPONSE TOO LONG')
    _check_tag(buf)
    tag, kind = buf[:5], buf[6]
    if kind in '&%':
        _need(buf[7:] == '\r\n', '', 'BAD CHARACTER AFTER RESPONSE END')
        return Response(tag, kind, 'Ack' if kind == '&' else 'Complete')
    _need(kind in '!#', '', 'BAD SEVENTH CHARACTER IN RESPONSE')
    _need(buf[7] == ' ', '', 'SPACE MISSING AT EIGHTH CHARACTER OF RESPONSE')
    toks = _tokenize(_unspace(buf[8:]))
    ts = ''.join(t.typ for t in toks)  # the item types, e.g. 'K(D),K(D)' for X(1), Y(2)
    if kind == '!':
        return _error(tag, toks, ts)
    _need(bool(toks), '')  # NIST would read items left over from the previous response
    return (_server_initiated if tag == 'E0000' else _data)(tag, toks, ts)


def _error(tag: str, toks: list[_Tok], ts: str) -> Response:
    """makeErrorResponse: Error(F1, F2, "F3", "Text"), F1 one digit, F2 four digits, and
    (code, severity, text) as in NIST_ERRORS (text compared exactly)."""
    _need(ts == 'K(D,D,S,S)', 'Error')
    _need(toks[0].val == 'Error', 'Error', 'RESPONSE NAME MUST BE ERROR')
    _need(len(toks[2].src) == 1, 'Error', 'SEVERITY MUST HAVE ONE DIGIT')
    _need(re.fullmatch('[0-9]{4}', toks[4].src) is not None, 'Error', 'ERROR CODE MUST HAVE FOUR DIGITS')
    severity, code, text = int(toks[2].val), int(toks[4].val), toks[8].val
    _need(code in ERRORS, 'Error', 'BAD ERROR CODE')
    _need(text == ERRORS[code][1], 'Error', 'BAD TEXT')
    _need(severity == ERRORS[code][0], 'Error', 'BAD SEVERITY')
    return Response(tag, '!', 'Error', toks[6].val, severity=severity, code=code, text=text)


def _method(tag: str, toks: list[_Tok], ts: str, spec: tuple) -> Response:
    """A data response shaped like one method call (see METHODS)."""
    form, shape, allowed, message = spec
    vals = tuple(t.val for t in toks if t.typ in 'DSK')
    _need(ts == shape and (allowed is not _01 or len(toks[2].src) == 1) and (
        form != 'ChangeToolAction' or vals[2:7:2] == ('X', 'Y', 'Z')), form)
    _need(allowed is None or vals[1] in allowed, form, message)
    if form == 'ChangeToolAction':  # ChangeToolAction(Switch, X(x), Y(y), Z(z))
        return Response(tag, '#', form, vals[0], vals[1:2], dict(zip('XYZ', zip(vals[3::2]))))
    return Response(tag, '#', form, vals[0], vals[1:])


def _data(tag: str, toks: list[_Tok], ts: str) -> Response:
    """makeDataResponse: choose the response form by the first item(s), then check its shape."""
    n, kw = len(toks), toks[0].val if ts[0] == 'K' else None
    vals = tuple(t.val for t in toks if t.typ in 'DS')
    if ts[0] == '(':  # AlignTool / AlignPart: (i, j, k) or (i1, j1, k1, i2, j2, k2)
        _need(ts in ('(D,D,D)', '(D,D,D,D,D,D)'), 'Align')
        return Response(tag, '#', 'Align', args=vals)
    if kw in METHODS:
        return _method(tag, toks, ts, METHODS[kw])
    if ts[0] == 'S' and n in (1, 3):  # "text" (GetErrorInfo, EnumTools) or "name", "type"
        _need(n == 1 or ts == 'S,S', 'EnumProp')
        return Response(tag, '#', 'EnumProp' if n == 3 else 'String', args=vals)
    if kw == 'FoundTool' or kw == 'Tool' and not (ts[2:3] == 'K' and toks[2].val in ('A', 'B', 'C')):
        return Response(tag, '#', 'GetProp', props=_get_prop(toks, ts))
    if kw in ('ER', 'IJK', 'R', 'X', 'Y', 'Z', 'Tool'):
        return Response(tag, '#', 'PtMeasOrGet', props=_targets(toks, ts, 0, 'PtMeasOrGet'))
    _need(ts[0] == 'D', '')
    _need(ts == 'D' + ',D' * (n // 2), 'Scan')  # scan data: numbers, comma separated
    return Response(tag, '#', 'Scan', args=vals)


def _server_initiated(tag: str, toks: list[_Tok], ts: str) -> Response:
    """makeServerInitiatedResponse (tag E0000): ChangeTool("s"), KeyPress("s"),
    GoTo(targets), PtMeas(targets) or SetProp(one tool parameter)."""
    kw = toks[0].val if ts[0] == 'K' else None
    if kw in EVENT_METHODS:
        return _method(tag, toks, ts, EVENT_METHODS[kw])
    if kw in ('GoTo', 'PtMeas'):
        _need(ts[1:2] == '(', kw + 'E')
        return Response(tag, '#', kw + 'E', kw, props=_targets(toks, ts, 2, kw + 'E'))
    _need(kw == 'SetProp', '')
    return Response(tag, '#', 'SetPropE', kw, props=_set_prop(toks, ts))


def _targets(toks: list[_Tok], ts: str, n: int, form: str) -> dict:
    """makePtMeasOrGetResponse / makePtMeasEResponse / makeGoToEResponse: X(d) Y(d) Z(d)
    R(d) ER(d) IJK(d,d,d) Tool.A|B|C(d), each at most once, comma separated.  Inside
    GoTo( / PtMeas( the last must be followed by ')'; GoTo's IJK must be (0,0,0).
    NIST quirks kept: a top-level list may end with ','; 'GoTo(' alone passes."""
    end, inner, props = len(toks), n > 0, {}
    while n < end:
        kw = toks[n].val if ts[n] == 'K' else None
        size = {'ER': 4, 'R': 4, 'X': 4, 'Y': 4, 'Z': 4, 'Tool': 6, 'IJK': 8}.get(kw, 0)
        follow = ts[n + size:n + size + 1]  # what must come after the item
        _need(size > 0 and end >= n + size + inner and ts[n + 1:n + size] == {
            4: '(D)', 6: '.K(D)', 8: '(D,D,D)'}.get(size) and (
            follow == (')' if end == n + size + 1 else ',') if inner
            else end == n + size or follow == ','), form)
        name = 'Tool.' + toks[n + 2].val if kw == 'Tool' else kw
        _need(kw != 'Tool' or name in ('Tool.A', 'Tool.B', 'Tool.C'), form)
        _need(name not in props, form, name.replace('.', ' ').upper() + ' USED TWICE')
        props[name] = tuple(t.val for t in toks[n + 1:n + size] if t.typ == 'D')
        _need(form != 'GoToE' or kw != 'IJK' or not any(props[name]), form, 'IJK VALUES MUST BE ZERO')
        n += size + 1
    return props


def _get_prop(toks: list[_Tok], ts: str) -> dict:
    """makeGetPropResponse + makeOneProperty*: a comma list of Tool./FoundTool. properties:
    GoToPar.Speed|Accel[.Act|Def|Max|Min](d), PtMeasPar.<Speed|Accel|Approach|Retract|
    Search>[...](d), Name("s"), Id("s"), and (Tool only) Alignment(3|6 d),
    CollisionVolume({OBB,15 d}).  NIST quirk kept: the list may end with ','."""
    end, n, props = len(toks), 0, {}

    def nxt(i):  # NIST: an item ends at the end of the response or before a comma
        return end == i or (end > i and ts[i] == ',')
    while n < end:
        _need(end >= n + 5 and ts[n:n + 3] == 'K.K' and toks[n].val in ('Tool', 'FoundTool'), 'GetProp')
        first, second, m, ok = toks[n].val, toks[n + 2].val, n, False
        _need(second in ('GoToPar', 'PtMeasPar', 'Name', 'Id') or second in (
            'Alignment', 'CollisionVolume') and first == 'Tool', 'GetProp', 'BAD SECOND KEYWORD')
        if second in ('GoToPar', 'PtMeasPar'):  # [Found]Tool.GoToPar.Speed[.Max](d)
            if ts[m + 3:m + 4] == '.' and nxt(m + 10):
                ok, n = ts[m + 5:m + 10] == '.K(D)' and toks[m + 6].val in ('Act', 'Def', 'Max', 'Min'), m + 11
            elif ts[m + 3:m + 4] == '.' and nxt(m + 8):
                ok, n = ts[m + 5:m + 8] == '(D)', m + 9
            params, what = (GOTOPAR, 'GOTOPAR') if second == 'GoToPar' else (PTMEASPAR, 'PTMEASPAR')
            _need(not ok or ts[m + 4] == 'K' and toks[m + 4].val in params, 'GetProp', f'BAD {what} PROPERTY')
        elif second == 'Alignment' and end >= m + 10 and ts[m + 3:m + 9] == '(D,D,D':
            if nxt(m + 10):
                ok, n = ts[m + 9] == ')', m + 11
            elif nxt(m + 16):
                ok, n = ts[m + 9:m + 16] == ',D,D,D)', m + 17
        elif second == 'CollisionVolume':
            ok, n = _collision_volume(toks, ts, m)
        elif second in ('Name', 'Id'):
            ok, n = end >= m + 6 and ts[m + 3:m + 6] == '(S)' and nxt(m + 6), m + 7
        _need(ok, 'GetProp')
        name = '.'.join(t.val for t in toks[m:ts.index('(', m + 3)] if t.typ == 'K')
        props[name] = tuple(t.val for t in toks[ts.index('(', m + 3) + 1:n - 2] if t.typ in 'DSK')
    return props


def _collision_volume(toks: list[_Tok], ts: str, n: int) -> tuple[bool, int]:
    """makeOnePropertyCollisionVolume: Tool.CollisionVolume() or one or more boxes
    OBB,Cx,Cy,Cz,Ex,Ey,Ez,Ix,Iy,Iz,Jx,Jy,Jz,Kx,Ky,Kz (comma separated).
    Returns (shape ok, index of the next property)."""
    k, end, boxes = n + 3, len(toks), 0
    if ts[k:k + 2] == '()':
        return end == k + 2 or ts[k + 2:k + 3] == ',', n + 6
    while ts[k:k + 1] == ('(' if boxes == 0 else ','):  # k: the item before the next box
        boxes += 1
        if end < k + 32 or ts[k + 1] != 'K' or toks[k + 1].val != 'OBB' or ts[k + 2:k + 32] != ',D' * 15:
            return False, n
        if ts[k + 32:k + 33] == ')':
            return end == k + 33 or ts[k + 33:k + 34] == ',', n + 5 + 32 * boxes
        k += 32
    return False, n


def _set_prop(toks: list[_Tok], ts: str) -> dict:
    """makeSetPropEResponse: SetProp(Tool|FoundTool.GoToPar|PtMeasPar.<param>[.Act](d))."""
    _need(len(toks) >= 11 and ts[1:7] == '(K.K.K', 'SetPropE')
    first, second, third = toks[2].val, toks[4].val, toks[6].val
    _need(first in ('Tool', 'FoundTool') and second in ('GoToPar', 'PtMeasPar') and (
        third in (GOTOPAR if second == 'GoToPar' else PTMEASPAR)), 'SetPropE', 'BAD KEYWORD')
    _need(ts[7:] in ('(D))', '.K(D))'), 'SetPropE')
    _need(len(toks) == 11 or toks[8].val == 'Act', 'SetPropE', 'BAD KEYWORD')
    return {'.'.join(t.val for t in toks[2:-4] if t.typ == 'K'): (toks[-3].val,)}
