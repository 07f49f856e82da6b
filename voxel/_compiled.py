"""The one decorator of the project's compiled loops: :func:`kernel` (numba).

Every compiled kernel of :mod:`voxel`, :mod:`offset` and :mod:`pipeline` is made by
:func:`kernel`, with the same options (:data:`KERNEL_OPTIONS`):

- ``cache=True``: the machine code is kept on disk beside the module (or under
  ``NUMBA_CACHE_DIR``) and compiled again only when the module or numba changes;
- ``nogil=True``: a kernel releases the GIL while it runs, so the slab threads and the
  writers' threads run kernels side by side;
- ``error_model="numpy"``: a division by zero gives ``inf`` or ``nan`` as numpy's arrays
  do, with no check and no exception in every loop that divides (the kernels check their
  divisors where it matters).

Nothing else in the project calls :func:`numba.njit` (``tests/test_layout.py`` reads the
sources and the compiled dispatchers to hold to it).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Literal, TypeVar, overload

import numba

F = TypeVar("F", bound=Callable[..., Any])

#: The options every kernel is compiled with.
KERNEL_OPTIONS: dict[str, Any] = {"cache": True, "nogil": True, "error_model": "numpy"}


@overload
def kernel(function: F, /) -> F: ...


@overload
def kernel(*, inline: Literal["never", "always"] = "never") -> Callable[[F], F]: ...


def kernel(
    function: F | None = None, /, *, inline: Literal["never", "always"] = "never"
) -> F | Callable[[F], F]:
    """Compile `function` with numba's ``njit`` and :data:`KERNEL_OPTIONS`.

    Parameters
    ----------
    function : callable, optional
        Plain Python over numbers and arrays. Without it, a decorator is returned.
    inline : {"never", "always"}
        ``"always"``: numba inlines the kernel into the kernels that call it (small
        helpers of hot loops).

    Returns
    -------
    callable
        The compiled dispatcher (called as `function` is), or the decorator.

    Examples
    --------
    >>> from shellvox.offset.field.crease_geometry import plane_labels  # a kernel
    >>> plane_labels.targetoptions["nogil"], plane_labels.targetoptions["error_model"]
    (True, 'numpy')
    """
    options = dict(KERNEL_OPTIONS)
    if inline != "never":
        options["inline"] = inline

    def compile_(target: F) -> F:
        compiled: F = numba.njit(**options)(target)
        return compiled

    return compile_ if function is None else compile_(function)
