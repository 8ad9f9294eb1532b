"""Optional compiled kernels (numba): loading numba, its on-disk cache, and the switch between
the kernels and the numpy/Python code that gives the same answers.

numba is optional: without it, with DATA_ASSOCIATION_ROS_NO_JIT=1, or when a kernel module
fails to compile here, that module's `Kernels.available()` is False and the numpy/Python code
runs.  Importing this module does not import numba; a kernel module does, through `njit`.

JIT compilation is cached on disk (numba cache=True) in NUMBA_CACHE_DIR when set, else in the
package's __pycache__ when writable, else in ~/.cache/data_association_ros/numba (or
$XDG_CACHE_HOME), else in the temporary directory.
"""
from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator

_ENABLED = [True]
_NUMBA: list = []   # [numba module or None, import error or None] once loaded


def _writable(directory: Path) -> bool:
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=directory):
            pass
        return True
    except OSError:
        return False


def _choose_cache_dir() -> None:
    """Set NUMBA_CACHE_DIR to a writable user cache directory when it is unset and this
    package's directory is read-only (an installed package); numba reads it at import."""
    if os.environ.get('NUMBA_CACHE_DIR'):
        return
    if _writable(Path(__file__).resolve().parent / '__pycache__'):
        return
    base = Path(os.environ.get('XDG_CACHE_HOME') or Path.home() / '.cache')
    for directory in (base / 'data_association_ros' / 'numba',
                      Path(tempfile.gettempdir()) / f'data_association_ros_numba_{os.getuid()}'):
        if _writable(directory):
            os.environ['NUMBA_CACHE_DIR'] = str(directory)
            return


def load_numba():
    """The numba module, imported at the first call; None when it is missing, does not load, or
    DATA_ASSOCIATION_ROS_NO_JIT is set (import_error() says why)."""
    if not _NUMBA:
        if os.environ.get('DATA_ASSOCIATION_ROS_NO_JIT', '') not in ('', '0'):
            _NUMBA[:] = [None, RuntimeError('DATA_ASSOCIATION_ROS_NO_JIT is set')]
        else:
            try:
                _choose_cache_dir()
                import numba
                _NUMBA[:] = [numba, None]
            except Exception as error:  # ImportError, or a numba that does not load here
                _NUMBA[:] = [None, error]
    return _NUMBA[0]


def import_error() -> Exception | None:
    """Why numba is not loaded (None when it is)."""
    load_numba()
    return _NUMBA[1]


def njit(function: Callable) -> Callable:
    """numba.njit(cache=True, nogil=True) when numba loads, else `function` unchanged (a kernel
    module is then never used: its Kernels.available() is False)."""
    numba = load_numba()
    return numba.njit(cache=True, nogil=True)(function) if numba is not None else function


class Kernels:
    """Whether one module's kernels can be used: `warm` (running every kernel version on a tiny
    input, which compiles it or loads it from the disk cache) ran once without error."""

    def __init__(self, warm: Callable[[], None]) -> None:
        self._warm = warm
        self._ready = False
        self.error: Exception | None = None

    def available(self) -> bool:
        """True when numba loaded and `warm` succeeded (running it now if it has not run)."""
        if self._ready or self.error is not None:
            return self._ready
        if load_numba() is None:
            self.error = import_error()
            return False
        try:
            self._warm()
            self._ready = True
        except Exception as error:  # a numba/llvmlite that cannot compile here
            self.error = error
        return self._ready

    def unavailable_reason(self) -> str:
        """Why the kernels are not used ('' when they are)."""
        self.available()
        return '' if self.error is None else f'{type(self.error).__name__}: {self.error}'


_PROBLEM_KERNELS: list = []


def problem_kernels():
    """core.problem_kernels when the compiled kernels are on (compiled(True), the default) and
    available, else None (the numpy code answers).  Imports numba at the first call."""
    if not _ENABLED[0]:
        return None
    if not _PROBLEM_KERNELS:
        from . import problem_kernels as module
        _PROBLEM_KERNELS.append(module if module.KERNELS.available() else None)
    return _PROBLEM_KERNELS[0]


def enabled() -> bool:
    """False inside `compiled(False)`: the numpy/Python code answers."""
    return _ENABLED[0]


@contextmanager
def compiled(enabled: bool) -> Iterator[None]:
    """Within the block the compiled kernels are used (when available) or not (the numpy/Python
    code: the reference for tests and the benchmarks' baseline)."""
    previous = _ENABLED[0]
    _ENABLED[0] = enabled
    try:
        yield
    finally:
        _ENABLED[0] = previous
