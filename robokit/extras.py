"""Optional parts of robokit and the modules each needs: one check, run before a command does any work.

A command that needs an optional library calls :func:`require` first, so a missing library is one line saying what
to install (``robokit: error: ... pip install 'robokit[EXTRA]'``, exit 2), never an internal error halfway through.
"""

from __future__ import annotations

import importlib

from robokit.errors import UserError

EXTRAS: dict[str, tuple[str, ...]] = {
    "video": ("matplotlib", "imageio_ffmpeg"),
    "server": ("django", "dj_database_url", "waitress", "whitenoise", "lxml", "django_q", "psutil"),
    "ray": ("ray",),
    "gym": ("gymnasium",),
    "rerun": ("rerun", "mcap"),
    "mujoco": ("mujoco",),
}
"""Extra -> the modules it makes importable. matplotlib and imageio-ffmpeg are in the base install too (the README's
first command gives video, plots and the run page); ``video`` stays as an extra for older install commands."""


def missing(extra: str, modules: tuple[str, ...] | None = None) -> list[str]:
    """The modules of ``extra`` (or just ``modules`` of it) that cannot be imported."""
    gone = []
    for module in modules or EXTRAS[extra]:
        try:
            importlib.import_module(module)
        except ImportError:
            gone.append(module)
    return gone


def require(extra: str, what: str, modules: tuple[str, ...] | None = None) -> None:
    """Raise a one-line :class:`UserError` when ``extra``'s modules (or ``modules`` of them) are missing; ``what``
    names the command that needs them."""
    gone = missing(extra, modules)
    if gone:
        verb = "is" if len(gone) == 1 else "are"
        raise UserError(f"{what} needs {', '.join(gone)}, which {verb} not installed: pip install 'robokit[{extra}]'")
