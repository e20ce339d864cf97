"""The I++ DME answer reader against NIST's sample response files (../shared/reference/
ippdme-nist/commands, skipped where absent): it takes every line of allResOK.res,
errorResponses.res and allCmdOK.res and refuses each line of parserResErrors.res with NIST's own
message; spot checks of the values it reads and of NIST's quirks."""
import os
import re

import pytest
from support.ippdme import NIST

from cmmsampling.cmm.answers import ERRORS, NIST_ERRORS, SPEC_ERRORS, Response, ResponseError, parse_response

COMMANDS = os.path.join(NIST, "commands")


def records(name):
    """Split a NIST .res file as parserRes's main does: a record runs up to a line '\\\\';
    it keeps its CR LF (and any inner line breaks); two ':' lines end the file."""
    path = os.path.join(COMMANDS, name)
    if not os.path.isfile(path):
        return []
    data = open(path, 'rb').read().decode('latin-1')
    out, cur = [], ''
    for line in data.split('\r\n')[:-1]:
        if line == ':' and cur == '':
            break
        if line.endswith('\\\\'):
            out.append(cur + line[:-2])
            cur = ''
        else:
            cur += line + '\r\n'
    return out


def nist_messages():
    """NIST's message for each record of parserResErrors.res, from parserResErrors.txt."""
    path = os.path.join(COMMANDS, 'parserResErrors.txt')
    if not os.path.isfile(path):
        return []
    text = open(path, 'rb').read().decode('latin-1')
    pat = re.compile(r'(?:[A-Za-z]+Response: )?[A-Z][A-Z0-9 ]+')
    return [ln for ln in re.split(r'\r?\n', text) if pat.fullmatch(ln)]


OK_FILES = ['allResOK.res', 'errorResponses.res', 'allCmdOK.res']
BAD = records('parserResErrors.res')


def needs_nist():
    """Skip where NIST's sample files are not beside the checkout."""
    if not os.path.isdir(COMMANDS):
        pytest.skip("../shared/reference/ippdme-nist is not beside the checkout")


@pytest.mark.parametrize('name', OK_FILES)
def test_valid_files_parse(name):
    needs_nist()
    recs = records(name)
    assert recs
    for rec in recs:
        assert isinstance(parse_response(rec), Response), rec
        assert parse_response(rec[:-2]) == parse_response(rec)  # CR LF optional


@pytest.mark.parametrize('rec, message', list(zip(BAD, nist_messages())))
def test_parser_res_errors(rec, message):
    with pytest.raises(ResponseError) as err:
        parse_response(rec)
    assert str(err.value) == message
    with pytest.raises(ResponseError):
        parse_response(rec[:-2])


def test_error_message_count():
    needs_nist()
    assert len(BAD) == len(nist_messages()) == 126


def test_checker_output_with_wrong_case_text_is_refused():
    # NIST's checker writes "Incorrect Arguments"; its parser wants "Incorrect arguments"
    needs_nist()
    bad = []
    for rec in records('checkerCmdErrors.res'):
        try:
            parse_response(rec)
        except ResponseError as e:
            bad.append((rec, str(e)))
    assert len(bad) == 12
    assert all('"Incorrect Arguments"' in r and e == 'ErrorResponse: BAD TEXT' for r, e in bad)


def test_ptmeas_values():
    r = parse_response('00012 # X(1.5), Y(2), Z(-3.25), IJK(0,0,1)')
    assert (r.tag, r.kind, r.form) == ('00012', '#', 'PtMeasOrGet')
    assert r.props == {'X': (1.5,), 'Y': (2.0,), 'Z': (-3.25,), 'IJK': (0.0, 0.0, 1.0)}
    assert r.numbers == (1.5, 2.0, -3.25, 0.0, 0.0, 1.0)


def test_error_values():
    r = parse_response('00401 ! Error(2, 0513, "00401 StopDaemon(E1234)", "Daemon does not exist")\r\n')
    assert (r.kind, r.severity, r.code) == ('!', 2, 513)
    assert (r.method, r.text) == ('00401 StopDaemon(E1234)', 'Daemon does not exist')


def test_other_values():
    assert parse_response('00001 &') == Response('00001', '&', 'Ack')
    assert parse_response('00001 %\r\n').form == 'Complete'
    r = parse_response('01102 # Tool.PtMeasPar.Accel(100), Tool.PtMeasPar.Accel.Max(2000)')
    assert r.props == {'Tool.PtMeasPar.Accel': (100.0,), 'Tool.PtMeasPar.Accel.Max': (2000.0,)}
    r = parse_response('00501 # ChangeToolAction(Switch, X(0), Y(0), Z(-8))')
    assert (r.method, r.args, r.props['Z']) == ('ChangeToolAction', ('Switch',), (-8.0,))
    assert parse_response('00201 # CenterPart(1)').args == (1.0,)
    assert parse_response('00601 # CoordSystem(PartCsy)').args == ('PartCsy',)
    assert parse_response('02001 # 1,2.5,-3e2').args == (1.0, 2.5, -300.0)
    assert parse_response('00101 # (0.6, 0, 0.8)').numbers == (0.6, 0.0, 0.8)
    assert parse_response('00301 # "Speed", "Number"').args == ('Speed', 'Number')
    r = parse_response('E0000 # GoTo(Tool.A(45),Z(-4.003E-01), X(+1.245E01) )')
    assert (r.form, r.props) == ('GoToE', {'Tool.A': (45.0,), 'Z': (-0.4003,), 'X': (12.45,)})
    r = parse_response('E0000 # SetProp(FoundTool.PtMeasPar.Speed.Act(0.55))')
    assert r.props == {'FoundTool.PtMeasPar.Speed.Act': (0.55,)}
    r = parse_response('01501 # Tool.CollisionVolume(OBB,' + ','.join('123456789012345') + ')')
    assert r.props['Tool.CollisionVolume'] == ('OBB',) + tuple(float(c) for c in '123456789012345')


@pytest.mark.parametrize('line, message', [
    ('00012 # X(1)\n', 'BAD RESPONSE ITEMS'),                       # bare LF
    ('00012 # X(1)\r\n\r\n', 'BAD CHARACTER AFTER RESPONSE END'),
    ('00012 # ', 'BAD RESPONSE ITEMS'),                              # no data
    ('00012 & \x00', 'NUL CHARACTER IN RESPONSE'),
    ('E0000 &', 'ZERO TAG MUST BE SERVER INITIATED RESPONSE'),
    ('00012 # CoordSystem(RotaryTableVarCsy)', 'BAD CHARACTER AFTER KEYWORD'),
    ('00012 # GetMachineClass(CartCMM)', 'BAD CHARACTER AFTER KEYWORD'),  # spec 6.3.2.8 form
    ('00012 ! Error(2, 1011, "m", "Unable to move")', 'ErrorResponse: BAD ERROR CODE'),
    ('00012 ! Error(2, 0006, "m", "Transaction aborted (Use ClearAllErrors To Continue)")',
     'ErrorResponse: BAD TEXT'),
    ('00012 # "a" "b"', 'ILLEGAL SPACE'),
    ('00012 # ' + '1,' * 40000 + '1', 'RESPONSE TOO LONG'),
])
def test_refused(line, message):
    with pytest.raises(ResponseError, match=re.escape(message)):
        parse_response(line)


@pytest.mark.parametrize('line', [
    '00012 # X(3),',                       # trailing comma (NIST quirk)
    '00012 # Tool.Name("a"),',             # trailing comma (NIST quirk)
    'E0000 # PtMeas(',                     # empty, unclosed (NIST quirk)
    '00012 # X(1) , Y(2) ',                # space after ')' (NIST, not spec 6.1.4.2)
    '00012 # ""',                          # empty string (NIST, not spec)
    '00012 # 1e999',                       # overflows to inf, like sscanf
])
def test_nist_quirks_accepted(line):
    parse_response(line)


def test_error_tables():
    assert set(SPEC_ERRORS) - set(NIST_ERRORS) == {1011, 1012}
    assert {c for c in NIST_ERRORS if NIST_ERRORS[c] != SPEC_ERRORS[c]} == {6}
    assert ERRORS is NIST_ERRORS and len(NIST_ERRORS) == 50
