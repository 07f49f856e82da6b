"""Files a model refers to (MTL, textures, glTF buffers and images): the path policy.

A model may only refer to files inside its own folder (the folder of the model file, or
below it). The check is made on the resolved path, so ``..``, absolute paths and
symbolic links that lead out of the folder are all outside. A reference outside is
refused with an :class:`~shellvox.errors.InputError`, unless the user passes ``--force``
(:attr:`~shellvox.config.LoadOptions.force`): then the file is read, with a warning.
A model downloaded from elsewhere thus cannot make shellvox read (and print into
colours) an arbitrary file of the user's, such as ``map_Kd ../../secret/x.png``.
``data:`` URIs (glTF) and entries inside a 3MF package are not files and always allowed.
"""

from __future__ import annotations

from pathlib import Path

from shellvox.errors import InputError, opt, warn


def is_file(candidate: Path) -> bool:
    """Return whether a referenced ``candidate`` is a file.

    A name too long for the system to look up (``ENAMETOOLONG``, for which
    ``Path.is_file`` raises) is no file.
    """
    try:
        return candidate.is_file()
    except OSError:
        return False


def is_inside(folder: Path, candidate: Path) -> bool:
    """Return whether ``candidate`` resolves to a path inside ``folder`` (symlinks followed)."""
    try:
        return candidate.resolve().is_relative_to(folder.resolve())
    except (OSError, RuntimeError):  # a symlink loop or an unreadable component
        return False


def check_inside(
    model: Path, candidate: Path, what: str, *, force: bool, alternative: str = ""
) -> Path:
    """Apply the path policy to one referenced file that exists.

    Parameters
    ----------
    model : Path
        The model file; its folder is the only place references may point into.
    candidate : Path
        The referenced file, as the model's folder joined with the name in the file.
    what : str
        What the file is, for messages (e.g. ``"texture 'x.png' of material 'skin'"``).
    force : bool
        Read a file outside the folder (with a warning) instead of refusing it.
    alternative : str
        Another fix to offer, e.g. ``"pass --texture FILE"``.

    Returns
    -------
    Path
        ``candidate``, when it may be read.

    Raises
    ------
    InputError
        The file lies outside the model's folder and ``force`` is false.
    """
    if is_inside(model.parent, candidate):
        return candidate
    shown = _resolved(candidate)
    if not force:
        raise InputError(
            model,
            f"{what} is outside the model's folder ({shown})",
            "copy it into the model's folder and refer to it by a relative name, "
            + (f"{alternative}, " if alternative else "")
            + f"or pass {opt('force')} to read it anyway",
        )
    warn(
        f"{model}: reading {what} from outside the model's folder ({shown}) because of "
        f"{opt('force')}",
    )
    return candidate


def _resolved(candidate: Path) -> Path:
    try:
        return candidate.resolve()
    except (OSError, RuntimeError):
        return candidate
