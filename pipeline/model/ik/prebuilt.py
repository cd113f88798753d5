"""The IK kernels as machine code built at install: the first IK call of a process then compiles nothing.

Compiling the closed form's kernel takes Numba about 15 s on this machine kind (most of it Numba's own typing
and lowering, in Python: LLVM's optimisation level barely changes it), and a fresh install or an empty Numba
cache paid it on the first IK call. ``make`` builds the kernels of ``KERNELS`` once, at install, into one
extension module beside this file (Numba's ahead-of-time compiler, ``numba.pycc``, for this CPU) with a
record of what it was built from (``RECORD``: the sources of the compiled model, the versions of Python,
NumPy, Numba and llvmlite, the CPU). A process uses the extension only when that record matches what it runs
on; otherwise (no extension, sources edited, another CPU, ``NUMBA_CPU_NAME`` set to another, or
``DH_PIPELINE_PREBUILT=0``) the kernels compile just in time as before.

Python calls a kernel through ``python_entry(kernel)``: the prebuilt function for arguments of exactly the
kernel's signature (float64 arrays of its dimensions, C-contiguous where it asks, writable where it writes;
integers within int64), the Numba dispatcher otherwise (which converts what it can and raises TypeError on
the rest): the machine code never sees an argument it was not built for.

Build: ``python -m pipeline build-kernels`` (``make`` runs it; it prints why when it cannot, e.g. without
a C compiler, and the package then works just in time).
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import json
import os
import platform
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import llvmlite
import llvmlite.binding as llvm
import numba
import numpy as np
from numba.core import config, sigutils, types
from numba.core.errors import NumbaPendingDeprecationWarning

from ...errors import OutputError
from ...files.atomic import WRITTEN_BY, write_bytes_atomic, write_text_atomic, written_here
from . import closed_form, descent, three_parallel

#: The kernels built ahead of time: each IK family's single and batch kernel and the damped least squares'
#: descent (FK and Jacobian kernels compile in about 2 s and take a microsecond: they stay just in time).
KERNELS = {
    "closed_form_solve_one": closed_form.solve_one, "closed_form_solve_batch": closed_form.solve_batch,
    "three_parallel_solve_one": three_parallel.solve_one, "three_parallel_solve_batch": three_parallel.solve_batch,
    "descent_descend": descent.descend,
}
#: The extension module's name, its folder (this package's) and its record.
EXTENSION = "_prebuilt_ik"
FOLDER = Path(__file__).resolve().parent
RECORD = f"{EXTENSION}.json"
#: The folders whose Python sources the kernels are compiled from (every module of them is hashed).
SOURCE_FOLDERS = ("model/chain", "model/ik", "files")
#: Setting it to 0 makes every kernel compile just in time (benchmarks compare both ways).
SWITCH = "DH_PIPELINE_PREBUILT"


def target_cpu() -> str:
    """The CPU the kernels are built for: Numba's (``NUMBA_CPU_NAME`` when set, otherwise this machine's)."""
    return config.CPU_NAME or llvm.get_host_cpu_name()


def fingerprint(package_root: Path | None = None) -> str:
    """SHA-256 of what the machine code depends on: the kernels' sources (every module of SOURCE_FOLDERS under
    ``package_root``, the ``pipeline`` folder by default), the versions of Python, NumPy, Numba and llvmlite,
    and the target CPU with its features."""
    root = package_root or FOLDER.parents[1]
    digest = hashlib.sha256()
    for folder in SOURCE_FOLDERS:
        for source in sorted((root / folder).glob("*.py")):
            digest.update(f"{folder}/{source.name}\0".encode() + source.read_bytes() + b"\0")
    features = config.CPU_FEATURES if config.CPU_FEATURES is not None else llvm.get_host_cpu_features().flatten()
    for part in (sys.version, platform.machine(), np.__version__, numba.__version__, llvmlite.__version__,
                 target_cpu(), features, ",".join(KERNELS)):
        digest.update(part.encode() + b"\0")
    return digest.hexdigest()


@dataclass(frozen=True)
class Prebuilt:
    """The extension this process may use (``module``, None when it may not) and why not (``reason``)."""
    module: object | None
    reason: str


def load(folder: Path = FOLDER) -> Prebuilt:
    """The extension in ``folder`` when its record matches this process (``fingerprint``), else why not."""
    if os.environ.get(SWITCH, "1") == "0":
        return Prebuilt(None, f"{SWITCH}=0: the kernels compile just in time")
    if config.DISABLE_JIT:
        return Prebuilt(None, "NUMBA_DISABLE_JIT: the kernels run as Python")
    record_path = folder / RECORD
    try:
        record = json.loads(record_path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return Prebuilt(None, f"no prebuilt kernels in {folder} (python -m pipeline build-kernels builds them)")
    if not isinstance(record, dict) or record.get("fingerprint") != fingerprint():
        return Prebuilt(None, f"{record_path}: built from other sources, versions or CPU; rebuild it "
                              "(python -m pipeline build-kernels)")
    path = folder / str(record.get("file", ""))
    spec = importlib.util.spec_from_file_location(EXTENSION, path) if path.is_file() else None
    if spec is None:
        return Prebuilt(None, f"{path}: missing; rebuild it (python -m pipeline build-kernels)")
    try:
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    except (ImportError, OSError) as exc:
        return Prebuilt(None, f"{path}: cannot be loaded ({exc}); rebuild it (python -m pipeline build-kernels)")
    return Prebuilt(module, "")


_prebuilt: Prebuilt | None = None
_entries: dict[object, Callable] = {}


def python_entry(kernel) -> Callable:
    """What Python calls for ``kernel`` (a dispatcher of KERNELS): its prebuilt function behind an exact
    check of the arguments (``_fits``) when the extension may be used, the dispatcher otherwise."""
    entry = _entries.get(kernel)
    if entry is None:
        module = prebuilt_status().module
        name = next(name for name, known in KERNELS.items() if known is kernel)
        entry = kernel if module is None else _guarded(getattr(module, name), kernel)
        _entries[kernel] = entry
    return entry


def prebuilt_status() -> Prebuilt:
    """Whether this process uses the prebuilt kernels, and why not (loads the extension's record once)."""
    global _prebuilt
    if _prebuilt is None:
        _prebuilt = load()
    return _prebuilt


def _guarded(function: Callable, kernel) -> Callable:
    """``function`` for arguments of exactly the kernel's one signature, the kernel's dispatcher otherwise.

    The check is one expression compiled for the signature (``_fits``): a few attribute reads per argument, about
    0.1 µs each, where a loop over predicates cost 2-3 µs a call (a fifth of a closed-form IK call)."""
    argument_types = sigutils.normalize_signature(kernel.kernel_signature)[0]
    names = [f"a{i}" for i in range(len(argument_types))]
    arguments = ", ".join(names)
    source = (f"def {kernel.py_func.__name__}({arguments}):\n"
              f"    if {' and '.join(_fits(name, t) for name, t in zip(names, argument_types))}:\n"
              f"        return function({arguments})\n"
              f"    return kernel({arguments})\n")
    namespace = {"ndarray": np.ndarray, "float64": np.dtype(np.float64), "int64": np.int64, "function": function,
                 "kernel": kernel}
    exec(compile(source, f"<prebuilt {kernel.py_func.__name__}>", "exec"), namespace)
    call = namespace[kernel.py_func.__name__]
    call.__doc__ = kernel.py_func.__doc__
    return call


def _fits(name: str, argument_type) -> str:
    """A Python expression, True when the argument ``name`` is exactly what the machine code was built for:
    a float64 ndarray (not a subclass; native byte order; an unpickled array's dtype is an equal copy, not
    NumPy's own instance, so a dtype that is not NumPy's is compared by ``==``) of the type's dimensions, C-contiguous, aligned and
    writable where the type is a writable C-contiguous array (``flags.carray``), writable where it is writable;
    an int or int64 within int64 where the type is int64."""
    if isinstance(argument_type, types.Array):
        if argument_type.dtype != types.float64:
            raise TypeError(f"prebuilt kernels take float64 arrays and int64 values, not {argument_type}")
        test = (f"type({name}) is ndarray and ({name}.dtype is float64 or {name}.dtype == float64) "
                f"and {name}.ndim == {argument_type.ndim}")
        if argument_type.layout == "C":
            if not argument_type.mutable:
                raise TypeError(f"prebuilt kernels take writable C-contiguous or any-layout arrays, not {argument_type}")
            return f"{test} and {name}.flags.carray"
        return f"{test} and {name}.flags.writeable" if argument_type.mutable else test
    if argument_type != types.int64:
        raise TypeError(f"prebuilt kernels take float64 arrays and int64 values, not {argument_type}")
    return f"(type({name}) is int or type({name}) is int64) and {-2 ** 63} <= {name} <= {2 ** 63 - 1}"


@dataclass(frozen=True)
class BuildReport:
    """What ``build`` wrote: the extension and its record [paths], and how long the build took [s]."""
    extension: Path
    record: Path
    seconds: float


def build(folder: Path = FOLDER) -> BuildReport:
    """Compile KERNELS ahead of time for ``target_cpu()`` into ``folder``: the extension, then its record
    (written last: a build that fails or is killed leaves no record that matches). Raises OutputError when
    ``folder`` holds a record the package did not write, or when the build fails (with the compiler's
    reason)."""
    with warnings.catch_warnings():                    # pending deprecation since Numba 0.57: see the README
        warnings.simplefilter("ignore", NumbaPendingDeprecationWarning)
        from numba.pycc import CC                      # setuptools and a C compiler: only a build needs them

    start = time.perf_counter()
    record_path = folder / RECORD
    if record_path.exists() and not written_here(record_path):
        raise OutputError(f"{record_path}: not written by this package; it is never replaced")
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    with tempfile.TemporaryDirectory(prefix="dh-prebuild-") as scratch:
        cc = CC(EXTENSION)
        cc.output_dir, cc.target_cpu = scratch, target_cpu()
        for name, kernel in KERNELS.items():
            cc.export(name, kernel.kernel_signature)(kernel.py_func)
        try:
            cc.compile()
        except Exception as exc:                       # the C compiler's or linker's reason, whatever raised it
            raise OutputError(f"cannot build the prebuilt IK kernels: {type(exc).__name__}: {exc}") from exc
        built = next(Path(scratch).glob(f"{EXTENSION}*{suffix}"))
        extension = folder / f"{EXTENSION}{suffix}"
        write_bytes_atomic(extension, built.read_bytes(), replace=True)
    seconds = time.perf_counter() - start
    record = {"written_by": WRITTEN_BY, "file": extension.name, "fingerprint": fingerprint(),
              "kernels": list(KERNELS), "target_cpu": target_cpu(), "build_s": round(seconds, 1)}
    write_text_atomic(record_path, json.dumps(record, indent=1) + "\n", replace=False)
    return BuildReport(extension, record_path, seconds)


def main() -> int:
    try:
        report = build()
    except OutputError as exc:
        print(f"prebuilt IK kernels: {exc}; IK compiles just in time instead (about 15 s on a first call)",
              file=sys.stderr)
        return 1
    print(f"prebuilt IK kernels for {target_cpu()} in {report.seconds:.0f} s: {report.extension}")
    return 0

