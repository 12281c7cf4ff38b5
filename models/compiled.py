"""The compiled core's common ground: how a kernel is compiled, where its machine code is cached,
how many threads run a batch, and how a batch is launched in bounded chunks.

Every hot stage is one numba kernel written as scalar loops over one row (MuJoCo's collider
style); the same row function serves N = 1 and a million rows:

* :func:`jit` compiles a function with ``cache=True, nogil=True`` and NumPy's error model
  (a division by zero gives inf, as the NumPy code it replaces did), no fast-math: the
  kernels must round as the golden answers were rounded. :func:`parallel_jit` adds
  ``parallel=True`` for the ``prange`` loops over rows of a batch.
* **Cache**: compiled code is cached on disk, so a process loads it instead of compiling
  (``IMPACTNET_KERNEL_CACHE_DIR``; default: ``__pycache__/kernels`` beside these sources where
  they are writable, else ``$XDG_CACHE_HOME/impactnet/kernels`` or
  ``~/.cache/impactnet/kernels``, else a folder in the temporary directory), each kernel
  stamped with the :func:`fingerprint` of the files it may inline, so that editing a module
  recompiles the kernels that depend on it (numba alone notices a kernel's own file only).
  The cache is keyed by contents, not by where the sources lie: a cache built by one install
  loads in another install of the same sources (the tree's in a wheel's; a moved virtualenv).
  numba keys the cache by CPU: an image built on one machine and run on another sets
  ``NUMBA_CPU_NAME=generic`` for both (docker/Dockerfile).
* **Threads**: ``IMPACTNET_KERNEL_THREADS`` (default: the cores this process may use) threads
  run a parallel kernel (:func:`set_threads`).
* **Launches**: parallel kernels are launched one at a time (:func:`launch`, one lock), so any
  numba threading layer is safe with concurrent callers (the ``workqueue`` layer aborts on
  concurrent parallel launches), and batch workers times kernel threads never oversubscribe
  the cores. Serial kernels (N = 1, small batches: fewer than :data:`PARALLEL_MIN_ROWS` rows)
  run without the lock, in the caller's thread.
* **Chunks**: a batch is launched :data:`CHUNK_ROWS` rows at a time with a
  :func:`impactnet.models.work.checkpoint` between chunks (:func:`chunks`), so the service's
  deadlines and cancellations stop compiled work too.
* **Warm-up**: a module of kernels registers a function that compiles (or loads) them on small
  inputs (:func:`on_warm_up`); :func:`warm_up` runs them: a server those a request may call,
  before it says ready; the install (``python -m impactnet.models.compiled``) all of them, one
  process per core (``--serving``: the server's only, as an image builds them).
"""
from __future__ import annotations

import hashlib
import os
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

#: Environment variables of the compiled core.
CACHE_ENV = "IMPACTNET_KERNEL_CACHE_DIR"
THREADS_ENV = "IMPACTNET_KERNEL_THREADS"
#: Rows of a batch per launch of a kernel: a few milliseconds of work at most between two
#: checkpoints, and arrays that stay in the CPU caches.
CHUNK_ROWS = 16384
#: Below this many rows a batch runs on the serial kernel: starting the kernel threads costs
#: more (~10-20 us) than the rows.
PARALLEL_MIN_ROWS = 256


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = tempfile.NamedTemporaryFile(dir=folder, prefix=".write-test-")
        probe.close()
        return True
    except OSError:
        return False


def cache_folder() -> Path | None:
    """Where compiled code is cached (module docstring), before the sources' fingerprint: the
    setting, else a folder beside the sources where they are writable, else the first writable
    user or temporary folder (None: nowhere, numba compiles in memory)."""
    given = os.environ.get(CACHE_ENV)
    if given:
        return Path(given)
    beside = Path(__file__).resolve().parent / "__pycache__" / "kernels"
    home = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    for folder in (beside, Path(home) / "impactnet" / "kernels",
                   Path(tempfile.gettempdir()) / f"impactnet-kernels-{os.getuid()}"):
        if _writable(folder):
            return folder
    return None


#: The folders of ``impactnet.models`` whose kernels inline functions of other folders: a
#: kernel's cache is stale when any file of its own folder or of these changes.
DEPENDS_ON = {"box": ("box",), "compound": ("compound", "box"),
              "distance": ("distance", "compound", "box"), "frame": ("frame",),
              "learned": ("learned", "box"), "dispatch": ("dispatch", "compound", "box")}
#: Files every kernel may inline, besides its folders': this module, the contact codes, the
#: input domain, the work limit, the geometry helpers.
SHARED = ("compiled.py", "contacts.py", "domain.py", "work.py", "geometry")


def fingerprint(folder: str | None = None) -> str:
    """A hash of the sources a kernel of ``folder`` (a sub-folder of ``impactnet.models``;
    None: all of them) may inline, and of numba's version. numba's own cache notices a change
    of a kernel's own file only, not of a module whose functions it inlines (a stale kernel
    once crashed), so each cached kernel is stamped with this hash too (:class:`_Locator`)."""
    from importlib.metadata import version

    root = Path(__file__).resolve().parent
    names = SHARED + (DEPENDS_ON.get(folder, (folder,)) if folder else ("",))
    paths = sorted({p for name in names for p in ((root / name).rglob("*.py")
                                                   if (root / name).is_dir() else
                                                   [root / name]) if p.exists()})
    digest = hashlib.sha1(version("numba").encode())
    for path in paths:
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _configure() -> None:
    """Install :class:`_Locator` first among numba's cache locators (before any kernel is
    compiled); a NUMBA_CACHE_DIR set by the caller keeps numba's own locator."""
    if "NUMBA_CACHE_DIR" in os.environ:
        return
    from numba.core.caching import CacheImpl, UserProvidedCacheLocator

    class _Locator(UserProvidedCacheLocator):
        """Kernels of ``impactnet.models`` cached under :func:`cache_folder` in a folder
        named by the package path, each stamped with the hash of its own file's contents
        and the :func:`fingerprint` of its folder's dependencies."""

        root = Path(__file__).resolve().parent
        base = cache_folder()
        stamps: dict[str, str] = {}

        def __init__(self, py_func, py_file):
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            relative = Path(py_file).resolve().relative_to(self.root).parts
            # The folder mirrors the file's place in the package, not its absolute path
            # (numba's own locator hashes that): a cache built by one install of the same
            # sources (the source tree, an image's build stage) loads in another, wherever
            # it lies, since the stamps compare contents.
            self._cache_path = str(self.base.joinpath("models", *relative[:-1]))
            self._folder = relative[0] if len(relative) > 1 else None

        def get_source_stamp(self):
            folder = self._folder or ""
            if folder not in self.stamps:
                self.stamps[folder] = fingerprint(self._folder)
            return super().get_source_stamp(), self.stamps[folder]

        @classmethod
        def from_function(cls, py_func, py_file):
            inside = Path(py_file).resolve().is_relative_to(cls.root)
            if cls.base is None or not inside:
                return None
            return super(UserProvidedCacheLocator, cls).from_function(py_func, py_file)

    CacheImpl._locator_classes.insert(0, _Locator)


import numba  # noqa: E402

_configure()

_LAUNCH = threading.Lock()
_WARM_UPS: list[Callable[[], None]] = []
_LIBRARY_ONLY: set[Callable[[], None]] = set()
#: Kernel signatures compiled by the compile workers of this process's warm-ups.
_COMPILED_BY_WORKERS = [0]


def jit(function):
    """A serial kernel (module docstring)."""
    return numba.njit(cache=True, nogil=True, error_model="numpy")(function)


def parallel_jit(function):
    """A kernel with ``prange`` loops over rows (module docstring)."""
    return numba.njit(cache=True, nogil=True, error_model="numpy", parallel=True)(function)


def available_cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def set_threads(count: int | None = None) -> int:
    """Threads of parallel kernels: ``count``, else ``IMPACTNET_KERNEL_THREADS``, else the
    available cores (at most numba's pool size); returns the number set."""
    wanted = count or int(os.environ.get(THREADS_ENV) or available_cores())
    wanted = max(1, min(wanted, numba.config.NUMBA_NUM_THREADS))
    numba.set_num_threads(wanted)
    return wanted


def launch(kernel, *args):
    """Run a parallel kernel, one launch at a time in the process (module docstring)."""
    with _LAUNCH:
        return kernel(*args)


def chunks(n: int, rows: int = CHUNK_ROWS) -> Iterator[tuple[int, int]]:
    """``(start, stop)`` of consecutive chunks of ``n`` rows, checking the calling context's
    work limit before each (:func:`impactnet.models.work.checkpoint`)."""
    from impactnet.models.work import checkpoint

    for start in range(0, n, rows):
        checkpoint()
        yield start, min(n, start + rows)


def on_warm_up(function: Callable[[], None] | None = None, *, serving: bool = True):
    """Register ``function`` (no arguments: compiles or loads a module's kernels); as
    ``@on_warm_up(serving=False)``, a warm-up of library entries that no request calls (the
    install compiles them, a server's start does not wait for them)."""
    def register(warm: Callable[[], None]) -> Callable[[], None]:
        _WARM_UPS.append(warm)
        if not serving:
            _LIBRARY_ONLY.add(warm)
        return warm

    return register(function) if function is not None else register


def _import_kernels() -> None:
    """Import every module of kernels, so that their warm-ups register."""
    import importlib

    for module in KERNEL_MODULES:
        try:
            importlib.import_module(module)
        except ModuleNotFoundError as exc:  # a wing without kernels yet
            if exc.name != module:
                raise


def signature_counts() -> tuple[int, int]:
    """``(loaded, compiled)``: kernel signatures this process loaded from the cache, and
    those compiled for it (here, or by the compile workers of its :func:`warm_up`)."""
    import sys

    from numba.core.registry import CPUDispatcher

    kernels = {id(value): value for name, module in list(sys.modules.items())
               if name.startswith("impactnet.models") and module is not None
               for value in list(vars(module).values()) if isinstance(value, CPUDispatcher)}
    loaded = sum(sum(k.stats.cache_hits.values()) for k in kernels.values())
    compiled_here = sum(sum(k.stats.cache_misses.values()) for k in kernels.values())
    return loaded, compiled_here + _COMPILED_BY_WORKERS[0]


def _warm_one(index: int) -> int:
    """Warm-up ``index`` in this process (a compile worker of :func:`warm_up`); the kernel
    signatures it compiled."""
    _import_kernels()
    _WARM_UPS[index]()
    return signature_counts()[1]


def warm_up(processes: int = 1, serving: bool = False) -> int:
    """Compile or load every registered kernel (importing the modules that hold them), or with
    ``serving`` those a request may call; returns how many warm-ups ran. With ``processes`` > 1
    the warm-ups first compile into the cache in that many fresh processes (numba compiles in
    one thread; a cold cache of every kernel takes minutes), then this process loads them."""
    _import_kernels()
    chosen = [k for k, f in enumerate(_WARM_UPS) if not (serving and f in _LIBRARY_ONLY)]
    if processes > 1 and len(chosen) > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        context = multiprocessing.get_context("spawn")  # no numba state copied by a fork
        with ProcessPoolExecutor(min(processes, len(chosen)), mp_context=context) as pool:
            _COMPILED_BY_WORKERS[0] += sum(pool.map(_warm_one, chosen))
    for k in chosen:
        _WARM_UPS[k]()
    return len(chosen)


#: The modules that hold kernels (imported by :func:`warm_up`, which runs their warm-ups): each
#: registers its warm-up with :func:`on_warm_up` when imported.
KERNEL_MODULES = ("impactnet.models.box.warm_up", "impactnet.models.compound.kernels",
                  "impactnet.models.learned.kernels", "impactnet.models.frame.broadphase",
                  "impactnet.models.distance.query", "impactnet.models.distance.bodies")


def main(argv: list[str] | None = None) -> int:
    """``python -m impactnet.models.compiled [--serving]``: compile every kernel into the
    cache, one process per core, or with ``--serving`` those a server calls (an image's build
    step), and say where they went."""
    import argparse

    from impactnet.models import compiled  # the module the kernels register with (not __main__)

    parser = argparse.ArgumentParser(prog="python -m impactnet.models.compiled")
    parser.add_argument("--serving", action="store_true",
                        help="only the kernels a request may call (not the library's own)")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    count = compiled.warm_up(processes=available_cores(), serving=args.serving)
    loaded, compiled_count = compiled.signature_counts()
    folder = os.environ.get("NUMBA_CACHE_DIR") or compiled.cache_folder() or "none (in memory)"
    print(f"impactnet kernels: {count} warm-ups in {time.perf_counter() - started:.1f} s "
          f"({compiled_count} signatures compiled, {loaded} loaded); cache: {folder}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
