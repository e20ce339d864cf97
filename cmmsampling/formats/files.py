"""Writing a point file so that it is whole or not there: a temporary file beside the target,
fsync, then a rename; the temporary files of writes killed midway are removed later. And the
checks of a path before a file is written there or read from it, and the one capped read of a
point file's text that every reader goes through (:func:`read_text`)."""
from __future__ import annotations

import errno
import os
import re
import stat
import tempfile
from dataclasses import dataclass

from ..geometry.validation import InputError, InputTypeError


class ExportError(OSError):
    """A point file could not be written; the message names the path and the reason."""


# The temporary files of write_atomically: .<file name>.<process id>.<random>.tmp
TEMPORARY = re.compile(r"^\..+\.(?P<pid>\d+)\.[A-Za-z0-9_]{8}\.tmp$")
# What FreeCAD writes a document to before it renames it over the file: <file name>.<uuid>
FREECAD_TEMPORARY = r"\.[0-9A-Fa-f]{8}-[0-9A-Fa-f]{4}-[0-9A-Fa-f]{4}-[0-9A-Fa-f]{4}-[0-9A-Fa-f]{12}"
# What a path that is neither a folder nor a regular file names, by the test of its mode: a reader
# would block on a pipe or socket with nothing written to it, and read a device without end.
NOT_REGULAR = ((stat.S_ISFIFO, "a named pipe (FIFO)"), (stat.S_ISCHR, "a character device"),
               (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


@dataclass(frozen=True)
class SizeLimit:
    """The most a kind of file may hold, in bytes, and the words of a refusal: what the limit
    amounts to (``hint``) and what to do with a larger file (``advice``)."""

    most: int
    hint: str
    advice: str


# Every point file read (read_points, inspect's measured files: DMIS, CSV, XYZIJK, QIF, tables of
# text): about a million points of DMIS output or QIF results, read in seconds and a few hundred MB.
POINT_FILES = SizeLimit(100 * 2 ** 20, "about a million points", "split the file by face or part and read each piece")
# A CAD file (STEP, IGES, BREP), which OCC reads by its path (only the stated size of a regular file
# can be checked): an assembly's STEP file runs to hundreds of MB, and OCC takes some ten times a
# file's size in memory, so a part exported alone is far below this.
CAD_FILES = SizeLimit(2 ** 30, "OCC takes some ten times that in memory",
                      "export the part alone, not its whole assembly")


def check_writable(path):
    """ExportError naming the path and the reason unless a file can be written at path: the
    folder exists and takes new files (a temporary file is created there and removed), and path
    is no folder. Returns the absolute path. For checking output paths before a long run."""
    target = os.path.abspath(os.fspath(path))
    if os.path.isdir(target):
        raise ExportError(f"could not write {target}: it is a folder; give a file name")
    descriptor, temporary = _temporary_file(target)
    os.close(descriptor)
    os.unlink(temporary)
    return target


def path_of(path, kind):
    """The path as a str; InputTypeError naming the type given when it is no str or os.PathLike
    of a str (a list, an array, bytes). kind: what the file should be ("point file")."""
    if not isinstance(path, (str, os.PathLike)) or isinstance(os.fspath(path), bytes):
        raise InputTypeError(f"a {kind} is given by its path, a str or pathlib.Path, got {type(path).__name__}")
    return os.fspath(path)


def check_readable(path, kind):
    """The path as a str when it names a regular file this process can read; else InputError in
    one line that names the path, the problem and what to give, before the file is opened: a
    folder, a named pipe, a device or a socket (:data:`NOT_REGULAR`), a missing file, a loop of
    symbolic links (or one that leads nowhere), no permission. kind: what the file should be
    ("point file", "CAD file"); a path of another type: see :func:`path_of`."""
    path = path_of(path, kind)
    try:
        mode = os.stat(path).st_mode
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise InputError(f"{path}: its symbolic links lead round in a loop; give the {kind}'s real path") from exc
        if os.path.islink(path):
            raise InputError(f"{path}: a symbolic link to nothing ({os.readlink(path)}); give the {kind}'s real path") from exc
        if exc.errno in (errno.EACCES, errno.EPERM):
            raise InputError(f"{path}: no permission to reach it; give a {kind} you may read") from exc
        raise InputError(f"{path}: no such file") from exc
    if stat.S_ISDIR(mode):
        raise InputError(f"{path}: is a folder, not a {kind}; give the file's path")
    check_regular(path, mode, kind)
    if not os.access(path, os.R_OK):
        raise InputError(f"{path}: no permission to read it; give a {kind} you may read (or change its permissions)")
    return path


def check_regular(path: str, mode: int, kind: str) -> None:
    """InputError naming path, what it is and what to give unless ``mode`` (its st_mode) is a
    regular file's."""
    if not stat.S_ISREG(mode):
        what = next((name for test, name in NOT_REGULAR if test(mode)), "no regular file")
        raise InputError(f"{path}: is {what}, not a {kind}; give a regular file's path (save what it delivers to a "
                         "file first)")


def check_size(path: str, kind: str, limit: SizeLimit) -> None:
    """InputError naming the file, its size and the limit when the regular file at path states
    more than ``limit.most`` bytes (its st_size); a size within 1 MB of the limit in bytes."""
    size = os.stat(path).st_size
    if size > limit.most:
        shown = _amount(size) if size - limit.most >= 2 ** 20 else f"{size} bytes"
        raise InputError(f"{path}: {shown} is more than a {kind} may hold ({_amount(limit.most)}, "
                         f"{limit.hint}); {limit.advice}")


def read_text(path: str | os.PathLike[str], kind: str) -> str:
    """The text of a point file: :func:`check_readable`, :func:`check_size` with
    :data:`POINT_FILES`, then at most ``POINT_FILES.most + 1`` bytes read (a file still being
    written, or one of /proc, states less than it holds), decoded as UTF-8 (a byte-order mark
    dropped, bytes that do not decode replaced, line ends as written). InputError in one line for
    each refusal; kind: what the file should be ("point file", "measured-points file")."""
    limit = POINT_FILES
    name = check_readable(path, kind)
    check_size(name, kind, limit)
    # O_NONBLOCK: a pipe put in the file's place since the check does not block the open.
    with os.fdopen(os.open(name, os.O_RDONLY | os.O_NONBLOCK), "rb") as stream:
        check_regular(name, os.fstat(stream.fileno()).st_mode, kind)
        data = stream.read(limit.most + 1)
    if len(data) > limit.most:
        raise InputError(f"{name}: holds more than a {kind} may ({_amount(limit.most)}, {limit.hint}) though it "
                         f"states {_amount(os.stat(name).st_size)}; {limit.advice}")
    return data.decode("utf-8-sig", errors="replace")


def _amount(size):
    """A number of bytes in words: whole MB from 1 MB up, else bytes."""
    return f"{size / 2 ** 20:.0f} MB" if size >= 2 ** 20 else f"{size} bytes"


def _temporary_file(target):
    """(descriptor, path) of a new temporary file beside target, named after it and this process;
    ExportError naming the reason when the folder takes no new file."""
    try:
        descriptor, temporary = tempfile.mkstemp(
            prefix=f".{os.path.basename(target)}.{os.getpid()}.", suffix=".tmp",
            dir=os.path.dirname(target))
    except OSError as exc:
        raise ExportError(f"could not write {target}: {_reason(exc, target)}") from exc
    return descriptor, temporary


def remove_stale_temporaries(folder):
    """Remove the temporary files that writes killed midway (kill -9, power loss) left in folder:
    those of write_atomically whose process is gone. Returns the paths removed."""
    removed = []
    for name in os.listdir(folder):
        match = TEMPORARY.match(name)
        if match and not _process_alive(int(match["pid"])):
            try:
                os.unlink(os.path.join(folder, name))
                removed.append(os.path.join(folder, name))
            except OSError:
                pass
    return removed


def _process_alive(pid):
    """True when a process with this id runs on this machine (or may: no permission to ask)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def write_atomically(path, text, encoding):
    """Write text to path through a temporary file in the same folder (fsync, then os.replace).

    On any failure the temporary file is removed and an existing file at path is untouched;
    temporary files of earlier writes that were killed midway are removed first
    (:func:`remove_stale_temporaries`). Returns the absolute path; ExportError naming the path
    and the reason when it cannot be written.
    """
    target = os.path.abspath(os.fspath(path))
    folder = os.path.dirname(target)
    data = text.encode(encoding)
    descriptor, temporary = _temporary_file(target)
    remove_stale_temporaries(folder)
    try:
        with os.fdopen(descriptor, "wb") as stream:
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(temporary, _file_mode(target))
        os.replace(temporary, target)
    except BaseException as exc:
        os.unlink(temporary)
        if isinstance(exc, OSError):
            raise ExportError(f"could not write {target}: {_reason(exc, target)}") from exc
        raise
    return target


def _reason(exc, target):
    """Why target could not be written, in words, from the OSError raised."""
    folder = os.path.dirname(target)
    if isinstance(exc, NotADirectoryError):
        blocker = folder
        while blocker and not os.path.exists(blocker):
            blocker = os.path.dirname(blocker)
        return f"{blocker} is a file, not a folder"
    if isinstance(exc, FileNotFoundError) and not os.path.isdir(folder):
        return f"the folder {folder} does not exist"
    if isinstance(exc, IsADirectoryError):
        return f"{target} is a folder"
    if isinstance(exc, PermissionError):
        return f"no permission to write in {folder} ({exc.strerror})"
    return f"the folder {folder} takes no new files ({exc.strerror or exc}); choose another folder"


def _file_mode(target):
    """Permission bits for the new file: those of the file it replaces, else 0o666 less the umask."""
    if os.path.exists(target):
        return os.stat(target).st_mode & 0o7777
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def remove_killed_saves(path):
    """Remove the temporary files that saves of the FreeCAD document ``path`` killed midway left
    beside it (``<name>.FCStd.<uuid>``, which FreeCAD renames over the file once it is whole):
    call it just before saving that document again. Returns the paths removed."""
    folder, name = os.path.split(os.path.abspath(os.fspath(path)))
    pattern = re.compile(re.escape(name) + FREECAD_TEMPORARY + "$")
    removed = [os.path.join(folder, entry) for entry in os.listdir(folder) if pattern.match(entry)]
    for leftover in removed:
        os.unlink(leftover)
    return removed
