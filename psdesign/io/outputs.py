"""Safe output folders: psdesign writes only where it may and replaces only what it wrote.

Every command that takes ``-o`` calls :func:`check_output_dir` before any work starts.  The
rules (also in ``docs/study-files.md`` and the README):

* ``/``, the home folder and any folder that contains the home folder are always refused.
* An existing file or a dangling symbolic link at ``-o`` is always refused.
* A new folder, an empty folder, or a folder psdesign created (it holds the marker file
  :data:`MARKER`) is used as it is.
* A non-empty folder without the marker is refused unless ``--force``.
* Even with ``--force`` nothing psdesign did not write is deleted or overwritten: the marker
  lists the files psdesign wrote, and a new output whose name is taken by any other file or
  folder stops the command with an error before anything is moved.

Temporary names all start with :data:`TEMP_PREFIX` and end in ``.tmp`` so that a clean-up can
never remove a user's own ``*.tmp`` files.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import shutil
import socket
import tempfile
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from psdesign.errors import SpecError

__all__ = [
    "MARKER",
    "TEMP_PREFIX",
    "OutputDir",
    "OutputError",
    "check_added_files",
    "check_output_dir",
    "claim_output_dir",
    "is_psdesign_temp",
    "remove_owned_files",
    "staged_output",
]

MARKER = ".psdesign-output.json"
"""Marker file psdesign writes into every output folder it creates or uses."""
TEMP_PREFIX = ".psdesign-"
"""Prefix of every temporary file or folder psdesign creates (suffix ``.tmp``)."""
_MARKER_FORMAT = 1


class OutputError(SpecError):
    """An output folder psdesign must not write into (exit status 2)."""


@dataclass(frozen=True)
class OutputDir:
    """A checked output folder.

    Attributes
    ----------
    path : Path
        The folder (resolved, symlinks followed).
    option : str
        Name of the command-line option, for messages (``-o``).
    command : str
        The command that made the folder, recorded in the marker: an existing marker's, else
        the one writing it now (a ``study run`` resuming a ``rev`` folder keeps ``rev``).
    owned : frozenset of str
        Relative POSIX paths psdesign wrote here earlier (from the marker); an entry ending in
        ``/`` owns a whole sub-folder.
    exists : bool
        The folder existed when checked.
    """

    path: Path
    option: str = "-o"
    command: str = ""
    owned: frozenset[str] = field(default_factory=frozenset)
    exists: bool = False

    def owns(self, rel: str) -> bool:
        """True if psdesign wrote ``rel`` (relative POSIX path) in this folder."""
        if rel in self.owned:
            return True
        parts = rel.split("/")
        return any("/".join(parts[:i]) + "/" in self.owned for i in range(1, len(parts)))

    def fail(self, message: str) -> OutputError:
        """An :class:`OutputError` for this folder's option."""
        return OutputError(self.option, message)


def is_psdesign_temp(path: str | Path) -> bool:
    """True for names psdesign uses for temporary files (``.psdesign-*.tmp``)."""
    name = Path(path).name
    return name.startswith(TEMP_PREFIX) and name.endswith(".tmp")


def _protected(p: Path) -> str | None:
    """Why ``p`` (resolved) may never be an output folder, or None."""
    if p == Path(p.anchor):
        return "the file-system root"
    try:
        home = Path.home().resolve()
    except (RuntimeError, KeyError, OSError):  # pragma: no cover - no home folder
        return None
    if p == home:
        return "the home folder"
    if p in home.parents:
        return "a folder that contains the home folder"
    return None


def read_marker(folder: Path) -> dict | None:
    """The marker of ``folder`` as a dict, or None if absent or not a valid psdesign marker."""
    try:
        data = json.loads((folder / MARKER).read_text())
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    if not isinstance(data, dict) or data.get("psdesign_output") != _MARKER_FORMAT:
        return None
    files = data.get("files")
    if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
        return None
    return data


def _is_lock_file(p: Path) -> bool:
    """A study lock file (``.lock`` holding ``{"pid": int, "host": str}``) psdesign wrote."""
    try:
        data = json.loads(p.read_text())
    except (OSError, ValueError, UnicodeDecodeError):
        return False
    return (
        isinstance(data, dict)
        and set(data) == {"pid", "host"}
        and isinstance(data["pid"], int)
        and isinstance(data["host"], str)
    )


def _user_entries(folder: Path) -> list[str]:
    """Top-level names in ``folder`` that psdesign did not put there."""
    names = []
    for item in folder.iterdir():
        if item.name == MARKER or is_psdesign_temp(item):
            continue
        if item.name == ".lock" and _is_lock_file(item):
            continue
        names.append(item.name)
    return sorted(names)


def check_folder_name(path: object, option: str) -> None:
    """Refuse a folder argument that is not a name (``str`` or ``Path``): pathlib's TypeError
    named no option (:class:`OutputError` naming ``option``)."""
    if not isinstance(path, str | os.PathLike):
        raise OutputError(option, f"must be a folder name (str or Path), got {type(path).__name__}")


def check_output_dir(
    path: str | Path,
    *,
    force: bool = False,
    option: str = "-o",
    command: str = "",
    expected: Iterable[str] = (),
    legacy: Iterable[str] = (),
    force_option: str | None = "--force",
    legacy_owns: Callable[[Path], bool] | None = None,
) -> OutputDir:
    """Check that psdesign may write into ``path``; nothing is created or changed.

    Parameters
    ----------
    path : str or Path
        The ``-o`` argument.
    force : bool
        Accept a non-empty folder psdesign did not create (``--force``); files psdesign did not
        write are still never replaced.
    option, command : str
        Option name and command, for messages and the marker.
    expected : iterable of str
        Relative paths the command will write (a trailing ``/`` for a sub-folder); any that
        exists and was not written by psdesign is refused now, before the work starts.
    legacy : iterable of str
        Top-level names that identify an output folder written by an older psdesign without a
        marker (all must be present); such a folder is psdesign's and owns ``expected``...
    legacy_owns : callable, optional
        ...but for an existing file of ``expected`` this says is not recognisably psdesign's
        (e.g. a report.html without its title): refused as a file the marker does not list.
    force_option : str or None
        The command's option that accepts a non-empty folder, named in the refusal of one;
        None for a command without it (``--fields``, ``rev -o``): the message then names
        only what the user can do.

    Returns
    -------
    OutputDir

    Raises
    ------
    OutputError
        One line naming the option, the folder and the rule.
    """
    check_folder_name(path, option)
    if not str(path).strip():
        raise OutputError(option, "empty folder name; give a new folder name")
    raw = Path(path).expanduser()
    if raw.is_symlink() and not raw.exists():
        raise OutputError(
            option,
            f"{raw} is a dangling symbolic link; psdesign never replaces a link, "
            "give a new folder name",
        )
    resolved = raw.resolve()
    why = _protected(resolved)
    if why is not None:
        raise OutputError(
            option,
            f"refusing to write into {why} ({resolved})"
            # only a command that has the force option can be told it would not help
            + (f", even with {force_option}" if force_option else "")
            + "; give a new folder name",
        )
    for anc in [resolved, *resolved.parents]:
        if anc.exists():
            if not anc.is_dir():
                what = "an existing file" if anc == resolved else f"inside the file {anc}"
                raise OutputError(
                    option, f"{resolved} is {what}; {option} takes a folder, give a new folder name"
                )
            if not os.access(anc, os.W_OK | os.X_OK):
                raise OutputError(option, f"cannot write into {anc} (permission denied)")
            break
    if not resolved.exists():
        return OutputDir(resolved, option, command, frozenset(), False)
    marker = read_marker(resolved)
    legacy, expected = tuple(legacy), tuple(expected)
    owned: set[str] = set(marker["files"]) if marker else set()
    if marker is None and legacy and all((resolved / n).exists() for n in legacy):
        owned = _legacy_owned(resolved, expected, legacy_owns)
    foreign = _user_entries(resolved) if marker is None and not owned else []
    if foreign and not force:
        shown = ", ".join(foreign[:3]) + (", ..." if len(foreign) > 3 else "")
        raise OutputError(
            option,
            f"{resolved} is a non-empty folder psdesign did not create ({shown}); "
            "give a new or empty folder"
            + (f", or {force_option} to add psdesign's files beside them" if force_option else ""),
        )
    if marker and marker.get("command"):  # the marker names the command that made the folder
        command = str(marker["command"])
    out = OutputDir(resolved, option, command, frozenset(owned), True)
    for rel in expected:
        _refuse_foreign(out, rel.rstrip("/"))
    return out


def _legacy_owned(folder: Path, expected: tuple[str, ...], legacy_owns) -> set[str]:
    """What a folder of an older psdesign (no marker) owns of ``expected``: every file but one
    that ``legacy_owns`` says is not recognisably psdesign's (a ``cp -r out/*`` copy drops the
    marker, and its user's own report.html was replaced: review s52)."""
    return {
        n
        for n in expected
        if legacy_owns is None or not (folder / n).is_file() or legacy_owns(folder / n)
    }


def _refuse_foreign(out: OutputDir, rel: str) -> None:
    """Raise if writing ``rel`` in ``out`` would replace something psdesign did not write."""
    parts = rel.split("/")
    for i in range(1, len(parts) + 1):
        sub = "/".join(parts[:i])
        p = out.path / sub
        if not (p.exists() or p.is_symlink()):
            return
        last = i == len(parts)
        if p.is_symlink() or (not last and not p.is_dir()):
            raise out.fail(
                f"{p} is in the way and was not written by psdesign; nothing was changed"
            )
        if last and not out.owns(sub) and not (p.is_dir() and out.owns(sub + "/")):
            even = ", even with --force" if out.option[:1] == "-" else ""
            raise out.fail(
                f"{p} exists and was not written by psdesign; it is never replaced{even}; "
                "move it away or choose another folder"
            )


def check_added_files(
    folder: str | Path,
    files: Iterable[str],
    *,
    command: str,
    option: str = "out_dir",
    legacy: Iterable[str] = (),
    legacy_files: Iterable[str] = (),
    legacy_owns: Callable[[Path], bool] | None = None,
) -> OutputDir:
    """Check that psdesign may add ``files`` to ``folder``, an existing folder given as input
    (a study folder for ``study fit`` / ``study report``); nothing is created or changed.

    The folder is the user's choice, so it need not be psdesign's (as with ``--force``), but a
    file among ``files`` that exists and was not written by psdesign (the marker does not list
    it) is refused, as by :func:`check_output_dir`.  Record the files with
    :func:`claim_output_dir` just before writing them, so that the next run may replace them.
    The marker keeps the command that made the folder (``study run``), else ``command``.

    Parameters
    ----------
    legacy : iterable of str
        As for :func:`check_output_dir`: names that identify a folder of an older psdesign
        without a marker, which then owns ``files``.
    legacy_files : iterable of str
        The other files such a folder owns; they are recorded with ``files`` when the marker
        is first written, so that the folder stays the older command's (a study resumes).
    legacy_owns : callable, optional
        As for :func:`check_output_dir`.

    Raises
    ------
    OutputError
        One line naming the file and the rule.
    """
    files = tuple(files)
    out = check_output_dir(
        folder,
        force=True,
        option=option,
        command=command,
        expected=files,
        legacy=legacy,
        legacy_owns=legacy_owns,
    )
    owned = out.owned
    if out.exists and owned and read_marker(out.path) is None:  # an older psdesign's folder
        # its files as _legacy_owned judges them: a user's report.html in a cp -r copy stays
        # the user's, also once study fit wrote the marker first (review F, session 52)
        owned = owned | _legacy_owned(out.path, tuple(legacy_files), legacy_owns)
    return OutputDir(out.path, out.option, out.command, frozenset(owned), out.exists)


def _write_marker(folder: Path, command: str, files: Iterable[str]) -> None:
    data = {
        "psdesign_output": _MARKER_FORMAT,
        "command": command,
        "files": sorted(set(files)),
        "note": "written by psdesign: the files listed here may be replaced by psdesign",
    }
    tmp = folder / f"{TEMP_PREFIX}marker.{os.getpid()}.tmp"
    tmp.write_text(json.dumps(data, indent=1))
    os.replace(tmp, folder / MARKER)


def claim_output_dir(out: OutputDir, files: Iterable[str]) -> OutputDir:
    """Create ``out.path`` if needed and record ``files`` (relative paths) as psdesign's.

    Raises
    ------
    OutputError
        If one of ``files`` exists and was not written by psdesign (checked again here).
    """
    files = list(files)
    for rel in files:
        _refuse_foreign(out, rel.rstrip("/"))
    try:
        out.path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise out.fail(f"cannot create {out.path}: {exc.strerror or exc}") from None
    owned = out.owned | set(files)
    _write_marker(out.path, out.command, owned)
    return OutputDir(out.path, out.option, out.command, frozenset(owned), True)


def remove_owned_files(folder: Path, names: Iterable[str]) -> list[str]:
    """Remove the files ``names`` (relative POSIX paths in ``folder``: ``pore.msh``,
    ``openfoam/0/p``) that psdesign wrote, as its marker lists them, drop them from the
    marker and remove the sub-folders they leave empty; returns the paths removed.

    Anything the marker does not list, a symbolic link (or a path through one), a folder, an
    absolute path or one with ``..`` is left alone: a file is only removed if psdesign wrote
    it, and a folder only if it held nothing else. Until session 53 plain names only, and
    ``psdesign mesh`` dropped its stale ``openfoam/`` case by a second function of its own.
    """
    marker = read_marker(folder)
    if marker is None:
        return []
    rels = sorted(n for n in set(names) if _inside(n))
    removed = _remove_owned(folder, marker, rels)
    for d in sorted({(folder / r).parent for r in removed}, key=lambda q: -len(q.parts)):
        while d != folder and d.is_dir() and not d.is_symlink() and not any(d.iterdir()):
            d.rmdir()
            d = d.parent
    return removed


def _inside(rel: str) -> bool:
    """Whether ``rel`` is a plain relative POSIX path below a folder (no ``..``, ``.`` or
    empty part, not absolute): a path :func:`remove_owned_files` may remove."""
    parts = rel.split("/")
    return bool(rel) and all(p not in ("", ".", "..") for p in parts)


def _remove_owned(folder: Path, marker: dict, rels: list[str]) -> list[str]:
    """Remove the files ``rels`` (relative paths) that the ``marker`` lists as psdesign's and
    that are regular files reached through no symbolic link; drop them from the marker."""
    owned = set(marker["files"])
    removed = []
    for rel in rels:
        p = folder / rel
        links = [folder / q for q in Path(rel).parents if q != Path(".")]
        if (
            rel not in owned
            or p.is_symlink()
            or not p.is_file()
            or any(q.is_symlink() for q in links)
        ):
            continue
        p.unlink()
        removed.append(rel)
    if removed:
        _write_marker(folder, marker.get("command", ""), owned - set(removed))
    return removed


def _files_under(root: Path) -> list[str]:
    rels = []
    for dirpath, _dirs, names in os.walk(root):
        for n in names:
            rels.append((Path(dirpath) / n).relative_to(root).as_posix())
    return sorted(rels)


def _host_tag() -> str:
    """8 hex digits naming this machine in staging-folder names (folders may be shared)."""
    return hashlib.sha256(socket.gethostname().encode()).hexdigest()[:8]


def _staging_prefix(name: str) -> str:
    """``.psdesign-NAME.HOST-PID.``: whose staging folder it is, so that a later run can remove
    it once that process is gone (killed with SIGKILL, power cut); a very long NAME keeps the
    older ``.psdesign-NAME.`` (never removed by a later run) to stay within the name limit."""
    if len(name) > 200:
        return f"{TEMP_PREFIX}{name}."
    return f"{TEMP_PREFIX}{name}.{_host_tag()}-{os.getpid()}."


def _pid_gone(pid: int) -> bool:
    if pid <= 0 or pid == os.getpid():
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except OSError:  # another user's process (EPERM): alive
        return False
    return False


def _remove_orphaned_staging(parent: Path, name: str) -> list[Path]:
    """Remove the staging folders for output ``name`` in ``parent`` that a process of this
    machine left when it was killed without a chance to clean up; returns them.

    Only folders named exactly as :func:`staged_output` names them for ``name``, by this host,
    whose process no longer exists; a live process's folder (or one from another machine, or
    without a process id) is left alone.
    """
    pattern = re.compile(
        re.escape(f"{TEMP_PREFIX}{name}.{_host_tag()}-") + r"([0-9]{1,10})\.[a-z0-9_]+\.tmp"
    )
    removed = []
    with contextlib.suppress(OSError):
        for p in parent.iterdir():
            m = pattern.fullmatch(p.name)
            if m and not p.is_symlink() and p.is_dir() and _pid_gone(int(m.group(1))):
                shutil.rmtree(p, ignore_errors=True)
                removed.append(p)
    return removed


def _named_as_final(exc: OSError, tmp: Path, final: Path) -> OSError:
    """``exc`` naming the file where it would have gone (``final / rel``) rather than inside the
    staging folder ``tmp``, which is removed on the way out: the one line said
    ``OUT/../.psdesign-out.HOST-PID.xyz.tmp/field.vti: No space left on device``, a path that no
    longer exists (failure audits s35-s36).  Other errors are returned unchanged.

    >>> import errno
    >>> e = _named_as_final(OSError(errno.ENOSPC, "No space left on device", "/a/.s.tmp/f.vti"),
    ...                     Path("/a/.s.tmp"), Path("/a/out"))
    >>> (type(e).__name__, e.filename, e.strerror)
    ('OSError', '/a/out/f.vti', 'No space left on device; nothing written')
    """
    if exc.filename is None:
        return exc
    try:
        rel = Path(os.fsdecode(exc.filename)).relative_to(tmp)
    except (TypeError, ValueError):  # a file outside the staging folder (an input, a cache)
        return exc
    reason = f"{exc.strerror or exc}; nothing written"
    return OSError(exc.errno, reason, str(final / rel))


@contextlib.contextmanager
def staged_output(out: OutputDir, replaces: Iterable[str] = ()) -> Iterator[Path]:
    """Yield a temporary folder; on success move its files into ``out.path``.

    ``replaces``: every file the command can write there (its optional ones too; relative
    paths, ``openfoam/0/p`` too since session 53). Those of them an earlier run wrote (the
    marker lists them) that this run did not write are removed once the new files are in
    place (:func:`remove_owned_files`), so that a rerun with fewer outputs (``generate
    --no-preview``, ``forcefield --no-pictures``, ``mesh`` with fewer ``--format``) leaves no
    old file beside the new ones (walk-cli finding 3, session 52).

    A new folder appears with all its files at once.  Into an existing folder the files are
    moved one by one after checking that none of them would replace a file psdesign did not
    write (if one would, nothing is moved and :class:`OutputError` is raised).  On any
    exception the temporary folder is removed and ``out.path`` is left as it was.  A staging
    folder for the same output that a killed process (SIGKILL) of this machine left behind is
    removed first (:func:`_remove_orphaned_staging`).
    """
    parent = out.path.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise out.fail(f"cannot create {parent}: {exc.strerror or exc}") from None
    _remove_orphaned_staging(parent, out.path.name)
    tmp = Path(tempfile.mkdtemp(prefix=_staging_prefix(out.path.name), suffix=".tmp", dir=parent))
    tmp.chmod(0o755)
    try:
        try:
            yield tmp
        except OSError as exc:
            raise _named_as_final(exc, tmp, out.path) from exc
        files = _files_under(tmp)
        if not out.path.exists() and not out.path.is_symlink():
            _write_marker(tmp, out.command, files)
            os.replace(tmp, out.path)
            return
        # re-read the marker: the folder may have changed while the command worked
        now = check_output_dir(out.path, force=True, option=out.option, command=out.command)
        merged = OutputDir(now.path, now.option, now.command, now.owned | out.owned, True)
        claimed = claim_output_dir(merged, files)
        for rel in files:
            target = claimed.path / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            os.replace(tmp / rel, target)
        # only after the new set is in place: a failed run leaves the previous set whole
        remove_owned_files(out.path, set(replaces) - set(files))
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
